"""The newcomer's mistakes of issue 28: each gets one line on stderr, exit code 2, no traceback, nothing written.

The truths are the rig's: a gap of 20 (mm) is not a gap in metres (the stage's stops are 8..32 mm), no
amplifier gives 1e308 A (the limit is 8 A), ``0.00_4`` is no number a rig logger writes, ``true`` is not a
seed. (``calibrate`` on one short hover: tests/test_calibration.py.)
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from maglev_ocp.cli import main
from maglev_ocp.riglog import RunLog, write_dataset


def cli(*args: str) -> tuple[int, str, str]:
    """Run ``maglev ARGS`` in-process; exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:  # --version / --help
            code = exc.code if isinstance(exc.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def refused(args: list[str], *words: str, nothing_at: Path | None = None) -> str:
    """Assert one line on stderr with ``words``, exit 2, no traceback, nothing at ``nothing_at``; the line."""
    code, out, err = cli(*args)
    assert code == 2, (code, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    if nothing_at is not None:
        assert not nothing_at.exists()
    return lines[0]


@pytest.fixture
def dataset(tmp_path) -> Path:
    """A valid 0.2 s hover log at 20 mm (SI units)."""
    n = 200
    rng = np.random.default_rng(0)
    cols = {
        "t": np.arange(n) * 1e-3,
        "g": 0.020 + np.round(rng.normal(0, 5e-6, n) / 1e-5) * 1e-5,
        "d": np.round(rng.normal(0, 5e-6, n) / 1e-5) * 1e-5,
        "i_q": np.zeros(n),
        "i_d": 1.6 + rng.normal(0, 0.01, n),
    }
    folder = tmp_path / "ds"
    write_dataset(folder, [RunLog("hover.csv", cols)])
    return folder


def _edit_cell(folder: Path, row: int, column: str, text: str) -> None:
    """Replace one cell of hover.csv (data row ``row``, 1-based) by ``text``."""
    path = folder / "hover.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = text
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def _scale_columns(folder: Path, columns: tuple[str, ...], factor: float) -> None:
    path = folder / "hover.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    idx = [header.index(c) for c in columns]
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for j in idx:
            cells[j] = repr(float(cells[j]) * factor)
        out.append(",".join(cells))
    path.write_text("\n".join(out) + "\n")


def test_the_valid_log_is_read(dataset, tmp_path):
    """The control case: the same log unchanged passes the checks."""
    code, out, err = cli("simulate", "--check", str(dataset))
    assert code == 0 and "hover.csv" in out, err


def test_a_rig_log_in_millimetres_is_refused(dataset, tmp_path):
    _scale_columns(dataset, ("g", "d"), 1e3)
    line = refused(
        ["calibrate", str(dataset), "--out", str(tmp_path / "cal"), "--quiet"],
        "hover.csv",
        "row 1",
        "'g'",
        "metres",
        nothing_at=tmp_path / "cal",
    )
    assert "0..0.064 m" in line


def test_a_current_of_1e308_amperes_is_refused(dataset, tmp_path):
    _edit_cell(dataset, 5, "i_d", "1e308")
    refused(
        ["calibrate", str(dataset), "--out", str(tmp_path / "cal")],
        "row 5",
        "'i_d'",
        "outside the physical range",
        nothing_at=tmp_path / "cal",
    )


def test_a_number_with_an_underscore_is_refused(dataset, tmp_path):
    _edit_cell(dataset, 7, "g", "0.02_0")
    refused(
        ["diagnose", "run", str(dataset), "--out", str(tmp_path / "rep")],
        "row 7",
        "'g'",
        "not a plain number",
        nothing_at=tmp_path / "rep",
    )


def test_a_boolean_seed_in_a_scenario_is_refused(tmp_path):
    sc = tmp_path / "sc.yaml"
    sc.write_text("name: t\nseed: true\ncontroller: {type: pid}\ntargets:\n  - {g: 0.020, d: 0.0, hold: 0.2}\n")
    refused(["run", str(sc), "--out", str(tmp_path / "out")], "seed", "boolean", nothing_at=tmp_path / "out")
    sc.write_text(
        "name: t\ncontroller: {type: pid}\ntargets: []\nrandom_targets: {n: true, hold: 0.2}\n"
    )  # a count too
    refused(["run", str(sc), "--out", str(tmp_path / "out")], "random_targets.n", nothing_at=tmp_path / "out")


def test_check_with_simulation_flags_is_refused(dataset, tmp_path):
    out = tmp_path / "new"
    refused(
        ["simulate", "--check", str(dataset), "--out", str(out), "--experiment", "hover"],
        "--check",
        "--out",
        "--experiment",
        nothing_at=out,
    )


def test_a_warmup_of_hours_is_refused(tmp_path):
    refused(["bench", "--warmup", "100000000", "--out", str(tmp_path / "b.json")], "--warmup", "0..10000")
    assert not (tmp_path / "b.json").exists()


def test_simulate_without_out_writes_nothing_into_results(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    refused(["simulate", "--duration", "0.01"], "--out", nothing_at=tmp_path / "results")


def test_the_old_diagnose_forms_say_what_to_write(tmp_path):
    refused(["diagnose", "--selftest", "3"], "maglev diagnose selftest N")
    refused(
        ["diagnose", "data/rig", "--out", str(tmp_path / "r")],
        "maglev diagnose run data/rig",
        nothing_at=tmp_path / "r",
    )
    refused(["diagnose"], "run|selftest|generate|closed-loop")


def test_version():
    code, out, _ = cli("--version")
    assert code == 0 and out.startswith("maglev ")
