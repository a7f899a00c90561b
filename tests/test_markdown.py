"""Every Markdown table the suite writes is well-formed: header, separator and rows have equal cell counts."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from maglev_ocp.markdown import malformed_tables, md_table, parse_md_tables


def test_md_table_escapes_pipes_and_counts_cells():
    text = md_table(["effect", "max|i| [A]"], [["a|b", 1.5], ["none", "-"]])
    (block,) = parse_md_tables(text)
    assert [len(r) for r in block] == [2, 2, 2, 2]
    assert block[2][0] == "a\\|b" and block[0][1] == "max\\|i\\| [A]"
    assert malformed_tables(text) == []
    with pytest.raises(ValueError, match="row 1 has 1 cells"):
        md_table(["a", "b"], [["only one"]])


def test_the_checker_finds_a_broken_table():
    broken = "| a | b | c |\n|---|---|\n| 1 | 2 | 3 |\n"
    assert malformed_tables(broken) == ["table 1 (a | b | c): separator has 2 cells, header 3"]


def _metrics(name: str, ctrl: str) -> dict:
    target = {
        "index": 0,
        "settled": True,
        "settle_time_s": 0.2,
        "rms_error_g_m": 3e-6,
        "rms_error_d_m": 2e-6,
        "rms_tracking_error_g_m": 4e-6,
        "rms_tracking_error_d_m": 5e-6,
    }
    return {
        "scenario": name,
        "controller": ctrl,
        "targets": [target],
        "step_time_us": {"median": 40.0, "p99": 90.0},
        "max_settle_time_s": 0.2,
        "max_rms_error_g_m": 3e-6,
        "max_rms_error_d_m": 2e-6,
        "stop_hits": 0,
        "solver_failures": 0,
        "fallbacks": 0,
        "max_current_A": 5.0,
        "passed": True,
    }


def _disturbance_row(name: str, ctrl: str) -> dict:
    return {
        "scenario": name,
        "controller": ctrl,
        "index": 0,
        "kind": "force_pulse",
        "t_start": 0.3,
        "peak_error_g_m": 1.2e-4,
        "peak_error_d_m": 3e-6,
        "recovery_time_s": 0.05,
        "stop_hits": 0,
        "max_current_A": 8.0,
        "time_at_limit_s": 0.004,
        "rms_error_after_m": 4e-6,
        "settled": "1/1",
    }


def test_the_headline_summary_tables_are_well_formed(tmp_path):
    """summary.md with every section (scenarios, traverse, cogging, disturbances) parses with equal cell counts."""
    from maglev_ocp.main_job import summary_markdown

    names = ["push_g_fl", "push_g_nmpc", "cogging_aware_fl", "cogging_blind_fl", "traverse_20mm_nmpc"]
    results = {n: {"ok": True, "metrics": _metrics(n, n.rsplit("_", 1)[-1]), "disturbances": []} for n in names}
    for n in ("push_g_fl", "push_g_nmpc"):
        results[n]["disturbances"] = [_disturbance_row(n, n.rsplit("_", 1)[-1])]
    results["broken"] = {"ok": False, "error": "boom | with a pipe"}
    text = summary_markdown(results, None, tmp_path, 1.0)
    tables = parse_md_tables(text)
    assert len(tables) >= 4  # scenarios, traverse, cogging, disturbances
    assert malformed_tables(text) == []
    assert "um]" not in text and "[µm]" in text


def test_the_margins_tables_are_well_formed():
    from maglev_ocp.analysis.report import _COLUMNS, markdown_table

    row = {key: (1.0 if "{:" in fmt else "g") for key, _, fmt in _COLUMNS}
    text = markdown_table([row, row])
    assert malformed_tables(text) == [] and len(parse_md_tables(text)[0]) == 4


@pytest.mark.slow
def test_every_markdown_file_the_main_job_writes_is_well_formed(tmp_path):
    """The main job (one disturbance scenario, no OCP or calibration) and every ``.md`` it writes."""
    from maglev_ocp.main_job import main

    out = tmp_path / "results"
    code = main(["--out", str(out), "--scenarios", "push_g_fl", "--no-min-time", "--no-calibration", "--jobs", "1"])
    assert code == 0
    files = sorted(Path(out).rglob("*.md"))
    assert files
    for f in files:
        text = f.read_text()
        assert malformed_tables(text) == [], f
        assert not math.isnan(len(parse_md_tables(text)))
