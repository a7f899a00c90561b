"""Every failure of the CLI is one line and the right exit code; result folders are replaced whole or not at all.

Issue 13: output paths that cannot be written are refused before any work,
YAML and CSV limits (nesting depth, duplicate keys, byte-order marks, header
width, cell size), campaign size and up-front validation, SIGINT during a save
(the folder is the old result or the new one, complete), and a property-based
test over every subcommand with mutated inputs and random output paths.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from maglev_ocp.cli import main
from maglev_ocp.config import MAX_YAML_DEPTH, parse_yaml_text
from maglev_ocp.errors import ConfigError, DataError
from maglev_ocp.output import check_output_dir, replace_dir
from maglev_ocp.riglog import MAX_CELL_CHARS, MAX_COLUMNS, read_dataset, write_dataset

REPO = Path(__file__).resolve().parents[1]

TINY_SCENARIO = {
    "name": "tiny",
    "seed": 1,
    "controller": {"type": "pid"},
    "plant": {"profile": "default"},
    "targets": [{"g": 0.020, "d": 0.000, "hold": 0.06}],
}


def cli(*args: str) -> tuple[int, str, str]:
    """Run ``maglev ARGS`` in-process; exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:  # argparse: usage error
            code = exc.code if isinstance(exc.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def assert_one_line_failure(code: int, out: str, err: str, *expect: str, exit_code: int = 2) -> None:
    """Exit ``exit_code``, stderr exactly one line containing every ``expect``, no traceback anywhere."""
    assert code == exit_code, (code, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for e in expect:
        assert e in lines[0], (e, lines[0])


def write_yaml(path: Path, data) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture
def tiny(tmp_path) -> Path:
    return write_yaml(tmp_path / "tiny.yaml", TINY_SCENARIO)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("ds") / "data"
    code, _, err = cli("simulate", "--duration", "0.05", "--out", str(folder), "--no-progress")
    assert code == 0, err
    return folder


# ------------------------------------------------------------------ output paths, before the work
def _commands(tmp: Path, tiny: Path, dataset: Path, out: str) -> dict[str, list[str]]:
    camp = write_yaml(tmp / "camp.yaml", {"name": "c", "base_scenario": str(tiny), "n_runs": 1, "seed": 1, "vary": {}})
    return {
        "run": ["run", str(tiny), "--out", out, "--no-progress"],
        "calibrate": ["calibrate", str(dataset), "--out", out, "--no-progress"],
        "simulate": ["simulate", "--duration", "0.01", "--out", out, "--no-progress"],
        "diagnose": ["diagnose", "run", str(dataset), "--out", out],
        "diagnose-generate": ["diagnose", "generate", out, "--runs", "2", "--duration", "2"],
        "campaign": ["campaign", str(camp), "--out", out, "--quiet", "--workers", "1"],
        "codegen": ["codegen", "--controllers", "observer", "--out", out],
        "bench": ["bench", "--controllers", "pid", "--backends", "python", "--out", out],
        "model-plot": ["model", "--plot", out + ("" if out.endswith((".png", "/")) or not out else "/x.png")],
    }


COMMANDS = ["run", "calibrate", "simulate", "diagnose", "diagnose-generate", "campaign", "codegen", "bench"]


@pytest.mark.parametrize("command", [*COMMANDS, "model-plot"])
def test_output_under_a_regular_file_is_one_line_before_any_work(tmp_path, tiny, dataset, command):
    blocker = tmp_path / "afile"
    blocker.write_text("not a folder\n")
    target = str(blocker / "sub")
    argv = _commands(tmp_path, tiny, dataset, target)[command]  # writes the commands' own input files
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    code, out, err = cli(*argv)
    assert_one_line_failure(code, out, err, str(blocker))
    assert blocker.read_text() == "not a folder\n"
    # nothing written anywhere (no partial result, no temporary folder left behind)
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


@pytest.mark.parametrize("command", [*COMMANDS, "model-plot"])
def test_output_on_a_read_only_location_is_one_line(tmp_path, tiny, dataset, command):
    code, out, err = cli(*_commands(tmp_path, tiny, dataset, "/proc/maglev-out/x")[command])
    assert_one_line_failure(code, out, err, "/proc")


@pytest.mark.parametrize("command", ["run", "calibrate", "simulate", "diagnose", "codegen", "campaign"])
def test_a_file_where_a_folder_is_expected(tmp_path, tiny, dataset, command):
    f = tmp_path / "result"
    f.write_text("x")
    code, out, err = cli(*_commands(tmp_path, tiny, dataset, str(f))[command])
    assert_one_line_failure(code, out, err, str(f))
    assert f.read_text() == "x"


@pytest.mark.parametrize("command", ["bench", "model-plot"])
def test_a_folder_where_a_file_is_expected(tmp_path, tiny, dataset, command):
    d = tmp_path / "dir.png"
    d.mkdir()
    args = _commands(tmp_path, tiny, dataset, str(d))[command]
    if command == "model-plot":
        args = ["model", "--plot", str(d)]
    code, out, err = cli(*args)
    assert_one_line_failure(code, out, err, "is a folder")


def test_empty_out_and_the_current_directory_are_refused(tiny, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = sorted(os.listdir(tmp_path))
    for out in ("", " "):
        code, o, e = cli("run", str(tiny), "--out", out, "--no-progress")
        assert_one_line_failure(code, o, e, "empty path")
    for args in (["codegen", "--out", "."], ["simulate", "--out", ".", "--duration", "0.01"]):
        code, o, e = cli(*args)
        assert_one_line_failure(code, o, e, "refusing")
    assert sorted(os.listdir(tmp_path)) == before


def test_model_plot_format_is_checked(tmp_path):
    code, out, err = cli("model", "--plot", str(tmp_path / "x.txt"))
    assert_one_line_failure(code, out, err, "x.txt", ".png")
    assert cli("model", "--plot", str(tmp_path / "x.svg"))[0] == 0
    assert (tmp_path / "x.svg").read_text().lstrip().startswith("<?xml")


def test_a_folder_that_is_not_an_earlier_result_is_never_replaced(tmp_path, tiny):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    for args in (
        ["codegen", "--controllers", "observer", "--out", str(mine)],
        ["simulate", "--duration", "0.01", "--out", str(mine), "--no-progress"],
        ["diagnose", "generate", str(mine), "--runs", "2", "--duration", "2"],
    ):
        code, out, err = cli(*args)
        assert_one_line_failure(code, out, err, str(mine))
    assert sorted(p.name for p in mine.iterdir()) == ["thesis.tex"]


# ------------------------------------------------------------------ result folders replaced whole
def test_rerun_without_figures_leaves_no_old_figures_and_keeps_other_scenarios(tmp_path, tiny):
    out = tmp_path / "res"
    assert cli("run", str(tiny), "--out", str(out), "--no-progress")[0] == 0
    assert (out / "tiny" / "positions.png").exists()
    (out / "other").mkdir()
    (out / "other" / "metrics.json").write_text("{}")
    (out / "tiny" / "stray.txt").write_text("from an earlier run")
    assert cli("run", str(tiny), "--out", str(out), "--no-progress", "--no-figures")[0] == 0
    files = sorted(p.name for p in (out / "tiny").iterdir())
    assert files == ["dataset.yaml", "log.csv", "metrics.json", "scenario.yaml", "timing.csv"]
    assert (out / "other" / "metrics.json").read_text() == "{}"
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary folders left


def test_simulate_appends_only_with_append_and_never_replaces_a_run(tmp_path):
    out = tmp_path / "ds"
    assert cli("simulate", "--duration", "0.02", "--out", str(out), "--quiet", "--plot")[0] == 0
    before = (out / "dataset.yaml").read_text()
    # into an existing dataset without --append: one line, nothing written
    code, o, e = cli("simulate", "--duration", "0.02", "--g", "18", "--out", str(out), "--quiet")
    assert_one_line_failure(code, o, e, "--append")
    assert (out / "dataset.yaml").read_text() == before
    code, o, _ = cli("simulate", "--duration", "0.02", "--g", "18", "--out", str(out), "--quiet", "--append")
    assert code == 0 and "appended 1 run(s)" in o and "hover_g18p0_d0p0.csv" in o
    ds = read_dataset(out)
    assert [r.file for r in ds.runs] == ["hover_g20p0_d0p0.csv", "hover_g18p0_d0p0.csv"]
    # the same run again is refused, even with --append: a run is never replaced silently
    before = (out / "dataset.yaml").read_text()
    code, o, e = cli("simulate", "--duration", "0.03", "--out", str(out), "--quiet", "--append")
    assert_one_line_failure(code, o, e, "hover_g20p0_d0p0.csv")
    assert (out / "dataset.yaml").read_text() == before and len(read_dataset(out).run("hover_g20p0_d0p0.csv")) == 20
    # runs made with another seed keep the dataset-level metadata of their own simulation
    assert cli("simulate", "--duration", "0.02", "--g", "16", "--seed", "5", "--out", str(out), "--append")[0] == 0
    ds = read_dataset(out)
    assert ds.meta["seed"] == 5 and len(ds.runs) == 3
    assert ds.run("hover_g18p0_d0p0.csv").meta["dataset_meta"]["seed"] == 0
    assert "dataset_meta" not in ds.run("hover_g16p0_d0p0.csv").meta


def test_simulate_refuses_a_dataset_with_another_encoder_before_simulating(tmp_path, dataset):
    out = tmp_path / "other"
    ds = read_dataset(dataset)
    write_dataset(out, ds.runs, ds.sample_time, 1e-6)
    before = (out / "dataset.yaml").read_text()
    code, o, e = cli("simulate", "--duration", "0.01", "--out", str(out), "--quiet", "--append")
    assert_one_line_failure(code, o, e, "encoder_resolution")
    assert (out / "dataset.yaml").read_text() == before


def test_codegen_leaves_no_stale_files(tmp_path):
    out = tmp_path / "c"
    assert cli("codegen", "--controllers", "observer", "--out", str(out))[0] == 0
    (out / "fl_step.c").write_text("/* stale: a controller no longer asked for */")
    assert cli("codegen", "--controllers", "observer", "--out", str(out))[0] == 0
    assert not (out / "fl_step.c").exists()
    assert (out / "observer_step.c").exists()


def test_replace_dir_keeps_the_old_folder_on_failure_and_interrupt(tmp_path):
    final = tmp_path / "r"
    final.mkdir()
    (final / "old.txt").write_text("old")
    for exc in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(exc)), replace_dir(final) as tmp:
            (tmp / "new.txt").write_text("new")
            raise exc
        assert sorted(p.name for p in final.iterdir()) == ["old.txt"]
    with replace_dir(final) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in final.iterdir()) == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]


def test_check_output_dir_creates_nothing(tmp_path):
    p = tmp_path / "a" / "b" / "c"
    assert check_output_dir(p) == p
    assert not (tmp_path / "a").exists()
    with pytest.raises(ConfigError, match="empty path"):
        check_output_dir("")


# ------------------------------------------------------------------ YAML and CSV limits
def test_deeply_nested_yaml_is_one_line_saying_the_limit(tmp_path, tiny):
    deep = "a: " + "[" * 5000 + "]" * 5000 + "\n"
    block = "x:\n" + "".join("  " * i + "k:\n" for i in range(1, 400)) + "  " * 400 + "k: 1\n"
    for text in (deep, block):
        f = tmp_path / "deep.yaml"
        f.write_text(text)
        for args in (
            ["run", str(f), "--out", str(tmp_path / "o")],
            ["model", "--params", str(f)],
            ["simulate", "--plant", str(f), "--out", str(tmp_path / "o")],
            ["campaign", str(f), "--out", str(tmp_path / "o")],
        ):
            code, out, err = cli(*args)
            assert_one_line_failure(code, out, err, str(f), f"limit is {MAX_YAML_DEPTH}")
    ds = tmp_path / "ds"
    ds.mkdir()
    (ds / "dataset.yaml").write_text(deep)
    code, out, err = cli("simulate", "--check", str(ds))
    assert_one_line_failure(code, out, err, "dataset.yaml", str(MAX_YAML_DEPTH))


def test_duplicate_yaml_keys_are_named(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(TINY_SCENARIO, sort_keys=False) + "seed: 2\n")
    code, out, err = cli("run", str(f), "--out", str(tmp_path / "o"))
    assert_one_line_failure(code, out, err, str(f), "duplicate key 'seed'")
    with pytest.raises(ConfigError, match="duplicate key 'b'"):
        parse_yaml_text("a:\n  b: 1\n  b: 2\n", "x")
    assert parse_yaml_text("base: &b {x: 1}\nother:\n  <<: *b\n  x: 2\n", "x")["other"] == {"x": 2}


def test_byte_order_mark_is_accepted_in_yaml_and_csv(tmp_path, dataset):
    f = tmp_path / "s.yaml"
    f.write_bytes(b"\xef\xbb\xbf" + yaml.safe_dump(TINY_SCENARIO).encode())
    assert cli("run", str(f), "--out", str(tmp_path / "o"), "--no-progress", "--no-figures")[0] == 0
    ds = tmp_path / "bom"
    ds.mkdir()
    for p in dataset.iterdir():
        (ds / p.name).write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    assert len(read_dataset(ds).runs) == 1
    cur = tmp_path / "cur.csv"
    cur.write_bytes(b"\xef\xbb\xbft,i_q,i_d\n0,0,0\n0.01,0,0\n")
    code, _, err = cli("simulate", "--currents", str(cur), "--lock", "g", "--out", str(tmp_path / "c"), "--no-progress")
    assert code == 0, err


def test_nan_in_settings_says_nan_and_numbers_are_plain(tmp_path):
    bad = {**TINY_SCENARIO, "targets": [{"g": 0.02, "d": 0.0, "hold": float("nan")}]}
    f = write_yaml(tmp_path / "s.yaml", bad)
    code, out, err = cli("run", str(f), "--out", str(tmp_path / "o"))
    assert_one_line_failure(code, out, err, "NaN/inf is not allowed", "targets.0.hold")
    assert "np.float64" not in err
    bad = {**TINY_SCENARIO, "targets": [{"g": 0.048, "d": 0.0, "hold": 0.1}]}
    code, out, err = cli("run", str(write_yaml(tmp_path / "g.yaml", bad)), "--out", str(tmp_path / "o"))
    assert code == 2 and "np." not in err and "Traceback" not in err


def test_wide_csv_header_is_refused_fast(tmp_path, dataset):
    ds = tmp_path / "wide"
    ds.mkdir()
    (ds / "dataset.yaml").write_text((dataset / "dataset.yaml").read_text())
    name = read_dataset(dataset).runs[0].file
    cols = ["t", "g", "d", "i_q", "i_d"] + [f"x{i}" for i in range(200_000)]
    (ds / name).write_text(",".join(cols) + "\n" + ",".join(["0"] * len(cols)) + "\n")
    with pytest.raises(DataError, match=f"the limit is {MAX_COLUMNS}"):
        read_dataset(ds)
    # duplicate names near the limit: named (the reader's speed on such headers is not a test's business)
    cols = ["t", "g", "d", "i_q", "i_d"] + [f"x{i}" for i in range(MAX_COLUMNS - 6)] + ["x0"]
    (ds / name).write_text(",".join(cols) + "\n")
    with pytest.raises(DataError, match="'x0' appears twice"):
        read_dataset(ds)


@pytest.mark.parametrize("size", [MAX_CELL_CHARS + 1, 1_000_000])
def test_huge_cell_names_file_row_and_column(tmp_path, dataset, size):
    ds = tmp_path / "cell"
    ds.mkdir()
    (ds / "dataset.yaml").write_text((dataset / "dataset.yaml").read_text())
    name = read_dataset(dataset).runs[0].file
    lines = (dataset / name).read_text().splitlines()
    head = lines[0].split(",")
    row = lines[3].split(",")
    row[head.index("i_q")] = "1" * size
    lines[3] = ",".join(row)
    (ds / name).write_text("\n".join(lines) + "\n")
    code, out, err = cli("simulate", "--check", str(ds))
    assert_one_line_failure(code, out, err, name, "row 3", "'i_q'", f"limit is {MAX_CELL_CHARS}")


# ------------------------------------------------------------------ campaigns
def _campaign(tmp_path: Path, tiny: Path, **extra) -> Path:
    doc = {"name": "c", "base_scenario": str(tiny), "n_runs": 1, "seed": 1, **extra}
    return write_yaml(tmp_path / f"camp{len(list(tmp_path.glob('camp*')))}.yaml", doc)


def test_huge_campaign_is_refused_before_expanding(tmp_path, tiny, monkeypatch):
    """A million-case grid is refused from its size alone: the cases are never drawn (``_draw`` would fail the
    test if called); a grid just inside the limit is accepted, so the refusal is the limit's, not the grid's."""
    expand_mod = importlib.import_module("maglev_ocp.campaign.expand")  # the package exports a function `expand`

    grid = {"controller.kp_g": list(range(1000)), "controller.kd_g": list(range(1000))}
    f = _campaign(tmp_path, tiny, n_runs=1000, vary={"grid": grid})
    draw = expand_mod._draw

    def _no_draw(*a, **kw):
        raise AssertionError("cases drawn before the size check")

    monkeypatch.setattr(expand_mod, "_draw", _no_draw)
    code, out, err = cli("campaign", str(f), "--out", str(tmp_path / "o"), "--plan")
    assert_one_line_failure(code, out, err, str(f), "limit")
    assert not (tmp_path / "o").exists()
    monkeypatch.setattr(expand_mod, "_draw", draw)
    small = _campaign(tmp_path, tiny, n_runs=1, vary={"grid": {"controller.omega_g": [70.0, 80.0]}})
    code, out, err = cli("campaign", str(small), "--out", str(tmp_path / "o2"), "--plan")
    assert code == 0, err


def test_bad_grid_settings_are_found_before_any_run(tmp_path):
    base = write_yaml(tmp_path / "n.yaml", {**TINY_SCENARIO, "controller": {"type": "nmpc"}})
    f = _campaign(tmp_path, base, vary={"grid": {"controller.horizon": [10, -3]}})
    code, out, err = cli("campaign", str(f), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet")
    assert_one_line_failure(code, out, err, "controller.horizon", "case 1")
    assert not (tmp_path / "o").exists()


def test_changed_campaign_is_refused_before_anything_is_written(tmp_path, tiny):
    out = tmp_path / "o"
    f = _campaign(tmp_path, tiny, n_runs=2)
    code, _, err = cli("campaign", str(f), "--out", str(out), "--workers", "1", "--quiet", "--limit", "1")
    assert code == 0, err
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.suffix in (".yaml", ".csv")}
    g = _campaign(tmp_path, tiny, n_runs=2, seed=2)
    code, o, e = cli("campaign", str(g), "--out", str(out), "--workers", "1", "--quiet")
    assert_one_line_failure(code, o, e, "different version of the campaign")
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.suffix in (".yaml", ".csv")}
    assert after == before


# ------------------------------------------------------------------ interrupts
def _maglev(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "maglev_ocp", *args],
        cwd=REPO,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _interrupt_run(tmp_path: Path, n: int, seed: int) -> None:
    """SIGINT a re-run at random moments: the folder is the old result or the new one, complete."""
    scen = {**TINY_SCENARIO, "targets": [{"g": 0.020, "d": 0.000, "hold": 0.5}]}
    f = write_yaml(tmp_path / "tiny.yaml", scen)
    out = tmp_path / "out"
    p = _maglev("run", str(f), "--out", str(out), "--no-progress", "--seed", "1")
    t0 = time.perf_counter()
    _, err = p.communicate(timeout=300)
    full = time.perf_counter() - t0
    assert p.returncode == 0, err
    old = _snapshot(out / "tiny")
    rng = random.Random(seed)
    for _ in range(n):
        p = _maglev("run", str(f), "--out", str(out), "--no-progress", "--seed", "2")
        t1 = time.perf_counter()
        # past the interpreter's start-up (imports): the run's temporary folder exists once the work begins
        while not list(out.glob(".tiny.tmp-*")) and p.poll() is None and time.perf_counter() - t1 < 120:
            time.sleep(0.005)
        time.sleep(rng.uniform(0.0, max(full - (time.perf_counter() - t1), 0.05) * 1.2))
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=300)
        assert "Traceback" not in err, err
        assert p.returncode in (0, 130), err
        if p.returncode == 130:
            assert err.strip().splitlines()[-1].endswith("interrupted"), err
        now = _snapshot(out / "tiny")
        assert set(now) == set(old), sorted(now)  # complete: every file of a result, nothing else
        seed_now = yaml.safe_load(now["scenario.yaml"])["seed"]
        if seed_now == 1:
            assert now == old
        else:
            assert seed_now == 2
            assert json.loads(now["metrics.json"])["seed"] == 2
            old = now
        assert not [q for q in out.iterdir() if q.name.startswith(".")]


def test_sigint_during_a_rerun_leaves_the_old_or_the_new_result(tmp_path):
    _interrupt_run(tmp_path, n=2, seed=0)


@pytest.mark.long
def test_sigint_during_a_rerun_many_times(tmp_path):
    _interrupt_run(tmp_path, n=12, seed=1)


# ------------------------------------------------------------------ property-based: every subcommand
WEIRD = [None, 0, -1, 1, 0.5, 1e300, -1e300, float("nan"), float("inf"), "abc", "", [], {}, True, [1, 2], {"x": 1}]


def _leaves(data, prefix=()):
    if isinstance(data, dict):
        for k, v in data.items():
            yield (*prefix, k)
            yield from _leaves(v, (*prefix, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield (*prefix, i)
            yield from _leaves(v, (*prefix, i))


def _mutate(data, draw):
    """One random structural mutation of a YAML document: set a value, delete a key, or add one."""
    import copy

    data = copy.deepcopy(data)
    paths = list(_leaves(data))
    kind = draw(st.sampled_from(["set", "delete", "add", "text"]))
    if kind == "text" or not paths:
        return None, draw(
            st.sampled_from(
                [
                    "\ufeff" + yaml.safe_dump(data),
                    yaml.safe_dump(data) + next(iter(yaml.safe_dump(data).splitlines()), "a: 1") + "\n",
                    "a: " + "[" * 300 + "]" * 300,
                    "- 1\n",
                    "{",
                    "",
                    "\x00\x01",
                    yaml.safe_dump(data).replace(":", "", 1),
                ]
            )
        )
    path = draw(st.sampled_from(paths))
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    if kind == "set":
        parent[path[-1]] = draw(st.sampled_from(WEIRD))
    elif kind == "delete":
        del parent[path[-1]]
    elif isinstance(parent, dict):
        parent[draw(st.sampled_from(["zzz", "seed", "1", "controller"]))] = draw(st.sampled_from(WEIRD))
    return data, None


def _write_doc(path: Path, data, text) -> Path:
    if text is not None:
        path.write_text(text)
    else:
        path.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path


def _out_path(tmp: Path, kind: str) -> str:
    (tmp / "file").write_text("x")
    (tmp / "foreign").mkdir(exist_ok=True)
    (tmp / "foreign" / "notes.txt").write_text("mine")
    return {
        "new": str(tmp / "new" / "sub"),
        "under-file": str(tmp / "file" / "x"),
        "file": str(tmp / "file"),
        "empty": "",
        "readonly": "/proc/maglev/x",
        "foreign": str(tmp / "foreign"),
        "spaces": str(tmp / "a b" / "ü"),
    }[kind]


OUT_KINDS = ["new", "under-file", "file", "empty", "readonly", "foreign", "spaces"]


def _check_outcome(code: int, out: str, err: str, allow: tuple[int, ...] = (0, 2)) -> None:
    assert "Traceback" not in out + err, err
    assert "internal error" not in out + err, err
    assert code in allow, (code, err)
    if code != 0:
        assert len(err.strip().splitlines()) == 1, err


def _fast_case(tmp: Path, target: str, out_kind: str, draw) -> tuple[list[str], tuple[int, ...]]:
    """A subcommand invocation on one mutated input with a random output path (cheap to run)."""
    out = _out_path(tmp, out_kind)
    if target == "scenario":
        data, text = _mutate(TINY_SCENARIO, draw)
        f = _write_doc(tmp / "s.yaml", data, text)
        cmd = draw(st.sampled_from(["run", "codegen", "diagnose-scenario"]))
        if cmd == "run":
            # exit 1 is a failed closed-loop check (a legitimate outcome of a mutated scenario); an internal
            # error also exits 1, so _check_outcome refuses "internal error" in stderr whatever the code
            return ["run", str(f), "--out", out, "--no-progress", "--no-figures"], (0, 1, 2)
        if cmd == "codegen":
            return ["codegen", "--scenario", str(f), "--controllers", "observer", "--out", out], (0, 2)
        return ["diagnose", "closed-loop", str(f)], (2,)  # needs --from or --effect: refused before any work
    if target == "params":
        from maglev_ocp.params import NOMINAL

        base = {"format": "maglev-params/1", **{k: float(v) for k, v in NOMINAL.as_dict().items()}}
        data, text = _mutate(base, draw)
        f = _write_doc(tmp / "p.yaml", data, text)
        cmd = draw(st.sampled_from(["model", "simulate"]))
        if cmd == "model":
            return ["model", "--params", str(f), "--plot", out if out.endswith(".png") else out + ".png"], (0, 2)
        return ["simulate", "--params", str(f), "--duration", "0.01", "--out", out, "--no-progress"], (0, 2)
    if target == "plant":
        data, text = _mutate({"profile": "default", "process_noise": {"g": 0.0}, "stops": {"g": [0.008, 0.032]}}, draw)
        f = _write_doc(tmp / "plant.yaml", data, text)
        return ["simulate", "--plant", str(f), "--duration", "0.01", "--out", out, "--no-progress"], (0, 2)
    if target == "campaign":
        sc = write_yaml(tmp / "base.yaml", TINY_SCENARIO)
        doc = {
            "name": "c",
            "base_scenario": str(sc),
            "n_runs": 2,
            "seed": 1,
            "vary": {"plant": {"C1": {"dist": "uniform", "pct": 5}}, "grid": {"controller.kp_g": [1.0e3]}},
        }
        data, text = _mutate(doc, draw)
        f = _write_doc(tmp / "c.yaml", data, text)
        return ["campaign", str(f), "--out", out or "x", "--plan"], (0, 2)
    # dataset: mutate dataset.yaml or one CSV cell, then read it
    ds = tmp / "ds"
    ds.mkdir(exist_ok=True)
    src = _DATASET_CACHE["folder"]
    for p in src.iterdir():
        (ds / p.name).write_bytes(p.read_bytes())
    if draw(st.booleans()):
        data, text = _mutate(yaml.safe_load((src / "dataset.yaml").read_text()), draw)
        _write_doc(ds / "dataset.yaml", data, text)
    else:
        csv = next(ds.glob("*.csv"))
        lines = csv.read_text().splitlines()
        r = draw(st.integers(0, len(lines) - 1))
        cells = lines[r].split(",")
        c = draw(st.integers(0, len(cells) - 1))
        cells[c] = draw(st.sampled_from(["", "nan", "x", "1e999", "0", "-1", "1" * 2000, '"', "a,b", "\ufeff", "1 2"]))
        lines[r] = ",".join(cells)
        csv.write_text("\n".join(lines) + "\n")
    return ["simulate", "--check", str(ds)], (0, 2)


_DATASET_CACHE: dict[str, Path] = {}


@pytest.fixture
def dataset_source(dataset):
    _DATASET_CACHE["folder"] = dataset
    return dataset


TARGETS = ["scenario", "params", "plant", "campaign", "dataset"]


def _property(tmp_path_factory, data) -> None:
    tmp = tmp_path_factory.mktemp("prop")
    target = data.draw(st.sampled_from(TARGETS))
    out_kind = data.draw(st.sampled_from(OUT_KINDS))
    args, allow = _fast_case(tmp, target, out_kind, data.draw)
    code, out, err = cli(*args)
    _check_outcome(code, out, err, allow)
    if out_kind == "foreign":
        assert (tmp / "foreign" / "notes.txt").read_text() == "mine"
    if out_kind == "file":
        assert (tmp / "file").read_text() == "x"


@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_any_mutated_input_and_output_path_is_exit_0_or_2_and_one_line(tmp_path_factory, dataset_source, data):
    _property(tmp_path_factory, data)


@pytest.mark.long
@settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_any_mutated_input_and_output_path_many(tmp_path_factory, dataset_source, data):
    _property(tmp_path_factory, data)


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data(), command=st.sampled_from(["calibrate", "diagnose", "bench"]))
def test_slow_subcommands_on_mutated_inputs(tmp_path_factory, dataset_source, data, command):
    tmp = tmp_path_factory.mktemp("slow")
    out = _out_path(tmp, data.draw(st.sampled_from(OUT_KINDS)))
    if command == "bench":
        mutated, text = _mutate(TINY_SCENARIO, data.draw)
        f = _write_doc(tmp / "s.yaml", mutated, text)
        args = ["bench", "--scenario", str(f), "--controllers", "pid", "--backends", "python", "--warmup", "0"]
        args += ["--out", out + ".json" if out else out, "--json"]
    else:
        _fast_case(tmp, "dataset", "new", data.draw)
        head = ["diagnose", "run"] if command == "diagnose" else [command]
        args = [*head, str(tmp / "ds"), "--out", out, "--quiet"]
    code, o, e = cli(*args)
    _check_outcome(code, o, e)


def test_unforeseen_errors_are_one_line_with_exit_1(monkeypatch, tmp_path):
    import maglev_ocp.cli.cmd_model as cmd_model

    def boom(*a, **k):
        raise ZeroDivisionError("division by zero deep inside")

    monkeypatch.setattr(cmd_model, "table", boom)
    code, out, err = cli("model")
    assert_one_line_failure(code, out, err, "internal error", "ZeroDivisionError", exit_code=1)
    monkeypatch.setattr(cmd_model, "table", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt()))
    code, out, err = cli("model")
    assert_one_line_failure(code, out, err, "interrupted", exit_code=130)


def test_a_campaign_whose_runs_all_failed_exits_1_with_one_line(tmp_path, tiny, monkeypatch):
    import maglev_ocp.campaign  # noqa: F401 - loads the module below

    ex = sys.modules["maglev_ocp.campaign.execute"]

    def broken(scenario, seed, workdir, save):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(ex, "run_real", broken)
    f = _campaign(tmp_path, tiny, n_runs=2)
    code, out, err = cli("campaign", str(f), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet")
    assert_one_line_failure(code, out, err, "every run", "failed", exit_code=1)


@pytest.mark.parametrize(
    "args",
    [
        ["run"],
        ["run", "x.yaml", "--out", "o", "--seed", "abc"],
        ["simulate", "--lock", "x"],
        ["frobnicate"],
        ["model", "--gaps"],
        ["campaign", "c.yaml", "--out", "o", "--workers", "1", "--scheduler", "tcp://x:1"],
    ],
)
def test_usage_errors_are_one_line(args):
    code, out, err = cli(*args)
    assert_one_line_failure(code, out, err, "error:", "--help")


def test_huge_cell_in_a_current_file_names_row_and_column(tmp_path):
    cur = tmp_path / "cur.csv"
    cur.write_text("t,i_q,i_d\n0,0,0\n0.01," + "1" * 1_000_000 + ",0\n")
    code, out, err = cli("simulate", "--currents", str(cur), "--lock", "g", "--out", str(tmp_path / "c"))
    assert_one_line_failure(code, out, err, str(cur), "row 2", "'i_q'", f"limit is {MAX_CELL_CHARS}")


@pytest.mark.parametrize(
    "argv",
    [
        ["model", "--params", "{p}"],
        ["codegen", "--controllers", "observer", "--params", "{p}", "--out", "{tmp}/cg"],
        ["simulate", "--duration", "0.01", "--params", "{p}", "--out", "{tmp}/sim", "--no-progress"],
    ],
)
def test_parameters_that_cannot_hover_are_refused_naming_the_keys(tmp_path, argv):
    """C3 = C4 ~ 0 (positive, so each key passes alone): no real hover current anywhere -> exit 2, keys named."""
    p = write_yaml(tmp_path / "p.yaml", {"C1": 14.2, "C2": 796.99, "C3": 1e-9, "C4": 1e-9})
    code, out, err = cli(*(a.format(p=p, tmp=tmp_path) for a in argv))
    assert_one_line_failure(code, out, err, "C3", "C4", "hover current")
    assert not (tmp_path / "cg").exists() and not (tmp_path / "sim").exists()
