"""Bad plant YAML, bad datasets and bad CLI values: one-line errors and exit code 2, never a traceback."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from maglev_ocp.cli import main
from maglev_ocp.errors import ConfigError, DataError
from maglev_ocp.plant import PlantConfig, load_plant_config
from maglev_ocp.riglog import RunLog, read_dataset, write_dataset


def run_cli(capsys, *args: str) -> tuple[int, str]:
    code = main(list(args))
    err = capsys.readouterr().err.strip()
    return code, err


# ---------------------------------------------------------------------------- plant YAML
BAD_PLANT_YAML = [
    # (yaml text, text the one-line message must contain)
    ("foo: 1\n", "foo: unknown key"),
    ("process_noise: {x: 1}\n", "process_noise.x: unknown key"),
    ("effects: {magic: {enabled: true}}\n", "effects.magic: unknown key"),
    ("effects: {friction: {mu: 0.3}}\n", "effects.friction.mu: unknown key"),
    ("process_noise: {g: -1}\n", "process_noise.g"),
    ("process_noise: {g: .nan}\n", "process_noise.g"),
    ("measurement_noise: {d: .inf}\n", "measurement_noise.d"),
    ("quantization: {resolution: 0}\n", "quantization.resolution"),
    ("integrator: {n_sub: 0}\n", "integrator.n_sub"),
    ("effects: {saturation: {enabled: true, loss_8mm: 2}}\n", "effects.saturation.loss_8mm"),
    ("effects: {amplifier_lag: {delay_samples: 1.5}}\n", "effects.amplifier_lag.delay_samples"),
    ("stops: {g: [0.03, 0.01]}\n", "stops.g"),
    ("stops: {g: 5}\n", "stops.g"),
    ("stops: {d: [0, 1, 2]}\n", "stops.d"),
    ("lock: {axis: x}\n", "lock.axis"),
    ("lock: {axis: g, value: 0.5}\n", "lock.value"),
    ("mismatch: {relative: {C1: 0.9}}\n", "mismatch.relative.C1"),
    ("mismatch: {overrides: {C2: -3}}\n", "mismatch.overrides.C2"),
    ("mismatch: {distribution: cauchy}\n", "mismatch.distribution"),
    ("process_noise: {g: abc}\n", "process_noise.g"),
    ("quantization: {enabled: maybe}\n", "quantization.enabled"),
    ("effects: {friction: yes}\n", "effects.friction"),
    ("integrator: {n_sub: 2.5}\n", "integrator.n_sub"),
    ("current_limits: [8, 8]\n", "current_limits"),
    ("profile: fancy\n", "profile"),
    ("profile: [1]\n", "profile"),
    ("a: [1, 2\n", "does not parse"),
    ("key: : :\n", "does not parse"),
    ("x:\n\t- 1\n", "does not parse"),
    ("- 1\n- 2\n", "expected a mapping"),
    ("just a string\n", "expected a mapping"),
    ("42\n", "expected a mapping"),
]


@pytest.mark.parametrize(("text", "expect"), BAD_PLANT_YAML)
def test_bad_plant_yaml_is_one_line_and_exit_2(tmp_path, capsys, text, expect):
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    code, err = run_cli(
        capsys, "simulate", "--plant", str(f), "--duration", "0.01", "--out", str(tmp_path / "o"), "--no-progress"
    )
    assert code == 2
    assert "\n" not in err and str(f) in err and expect in err, err
    assert not (tmp_path / "o").exists()  # nothing written


def test_missing_and_binary_plant_files(tmp_path, capsys):
    code, err = run_cli(capsys, "simulate", "--plant", str(tmp_path / "nope.yaml"))
    assert code == 2 and "cannot read" in err and "\n" not in err
    f = tmp_path / "bin.yaml"
    f.write_bytes(b"\xff\xfe\x00\x01garbage")
    code, err = run_cli(capsys, "simulate", "--plant", str(f))
    assert code == 2 and str(f) in err and "\n" not in err


def test_empty_plant_file_means_the_default_profile(tmp_path):
    f = tmp_path / "empty.yaml"
    f.write_text("")
    assert load_plant_config(f) == PlantConfig.from_profile("default")


_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
_junk = st.recursive(
    _scalars,
    lambda c: st.one_of(st.lists(c, max_size=3), st.dictionaries(st.text(max_size=6), c, max_size=3)),
    max_leaves=8,
)
_sections = st.sampled_from(
    [
        "profile",
        "mismatch",
        "process_noise",
        "current_noise",
        "measurement_noise",
        "quantization",
        "current_limits",
        "stops",
        "lock",
        "effects",
        "integrator",
        "other",
    ]
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(section=_sections, junk=_junk)
def test_any_yaml_is_a_config_or_a_one_line_config_error(tmp_path, section, junk):
    f = tmp_path / "h.yaml"
    f.write_text(yaml.safe_dump({section: junk}))
    try:
        cfg = load_plant_config(f)
    except ConfigError as err:
        msg = str(err)
        assert "\n" not in msg and str(f) in msg
    else:
        assert isinstance(cfg, PlantConfig)


@settings(max_examples=60, deadline=None)
@given(
    key=st.sampled_from(["g", "d"]),
    value=st.one_of(st.floats(), st.text(max_size=5), st.none(), st.lists(st.floats(), max_size=3)),
)
def test_any_override_value_is_validated(key, value):
    try:
        cfg = PlantConfig.from_profile("default", {"process_noise": {key: value}})
    except ConfigError as err:
        assert "\n" not in str(err) and f"process_noise.{key}" in str(err)
    else:
        v = getattr(cfg.process_noise, key)
        assert 0 <= v <= 50


# ------------------------------------------------------------------------------- CLI values
@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["--duration", "-1"], "--duration"),
        (["--duration", "nan"], "--duration"),
        (["--g", "100"], "--g"),
        (["--g", "35"], "--g"),  # inside 5..40 but beyond the stops of the default rig
        (["--d", "-70"], "--d"),
        (["--seed", "-3"], "--seed"),
        (["--constant", "1e9", "0"], "--constant"),
        (["--profile", "fancy"], "unknown plant profile"),
        (["--params", "/nonexistent/params.yaml"], "cannot read"),
        (["--experiment", "hover", "--constant", "0", "0"], "--experiment"),
    ],
)
def test_bad_cli_values_are_one_line_and_exit_2(tmp_path, capsys, args, expect):
    code, err = run_cli(capsys, "simulate", "--no-progress", "--out", str(tmp_path / "o"), *args)
    assert code == 2 and "\n" not in err and expect in err, err


@pytest.mark.parametrize(
    ("text", "expect"),
    [
        ("", "empty file"),
        ("t,i_q\n0,1\n", "missing column 'i_d'"),
        ("t,i_q,i_d\n0,1,x\n", "row 1 (line 2), column 'i_d'"),
        ("t,i_q,i_d\n0,1,2\n0.1,1,inf\n", "row 2 (line 3), column 'i_d': non-finite"),
        ("t,i_q,i_d\n0,1,2\n0,1,2\n", "row 2 (line 3), column 't'"),
        ("t,i_q,i_d\n-1,1,2\n", "column 't'"),
        ("t,i_q,i_d\n0,1\n", "row 1 (line 2): 2 fields"),
        ("t,i_q,i_d\n", "no data rows"),
    ],
)
def test_bad_current_files(tmp_path, capsys, text, expect):
    f = tmp_path / "cur.csv"
    f.write_text(text)
    code, err = run_cli(capsys, "simulate", "--no-progress", "--currents", str(f), "--out", str(tmp_path / "o"))
    assert code == 2 and "\n" not in err and str(f) in err and expect in err, err


# ------------------------------------------------------------------------------ datasets
def _good_dataset(folder, n: int = 20):
    t = np.arange(n) * 1e-3
    runs = [
        RunLog(
            "free.csv",
            {"t": t, "g": np.full(n, 0.02), "d": np.linspace(0, 1e-3, n), "i_q": np.zeros(n), "i_d": np.ones(n)},
        ),
        RunLog(
            "hover.csv",
            {"t": t, "g": np.linspace(0.02, 0.021, n), "d": np.zeros(n), "i_q": np.zeros(n), "i_d": np.ones(n)},
            ("d",),
        ),
    ]
    write_dataset(folder, runs)
    return folder


def _edit_yaml(folder, fn):
    p = folder / "dataset.yaml"
    doc = yaml.safe_load(p.read_text())
    fn(doc)
    p.write_text(yaml.safe_dump(doc))


def _edit_csv(folder, name, row, col, value):
    p = folder / name
    lines = p.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(col)] = value
    lines[row] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")


def _set(key, value):
    return lambda d: d.__setitem__(key, value)


BAD_DATASETS = [
    # (name, corruption(folder), text the message must contain)
    ("yaml-parse", lambda f: (f / "dataset.yaml").write_text("format: [\n"), "does not parse"),
    ("yaml-list", lambda f: (f / "dataset.yaml").write_text("- 1\n"), "expected a mapping"),
    ("yaml-empty", lambda f: (f / "dataset.yaml").write_text(""), "empty file"),
    ("yaml-missing", lambda f: (f / "dataset.yaml").unlink(), "dataset.yaml: missing"),
    ("no-sample-time", lambda f: _edit_yaml(f, lambda d: d.pop("sample_time")), "sample_time: required key missing"),
    ("no-runs", lambda f: _edit_yaml(f, lambda d: d.pop("runs")), "runs: required key missing"),
    ("no-format", lambda f: _edit_yaml(f, lambda d: d.pop("format")), "format: required key missing"),
    ("wrong-format", lambda f: _edit_yaml(f, _set("format", "maglev-rig-log/2")), "format: expected"),
    ("bad-sample-time", lambda f: _edit_yaml(f, _set("sample_time", -1)), "sample_time"),
    ("text-sample-time", lambda f: _edit_yaml(f, _set("sample_time", "fast")), "sample_time"),
    ("unknown-key", lambda f: _edit_yaml(f, _set("colour", "red")), "colour: unknown key"),
    ("empty-runs", lambda f: _edit_yaml(f, _set("runs", [])), "runs"),
    ("locked-both", lambda f: _edit_yaml(f, lambda d: d["runs"][0].__setitem__("locked", ["g", "d"])), "runs.0.locked"),
    ("locked-x", lambda f: _edit_yaml(f, lambda d: d["runs"][0].__setitem__("locked", ["x"])), "runs.0.locked"),
    ("locked-str", lambda f: _edit_yaml(f, lambda d: d["runs"][0].__setitem__("locked", "g")), "runs.0.locked"),
    ("locked-missing", lambda f: _edit_yaml(f, lambda d: d["runs"][1].pop("locked")), "runs.1.locked"),
    ("run-file-missing", lambda f: (f / "hover.csv").unlink(), "'hover.csv' does not exist"),
    ("run-file-escape", lambda f: _edit_yaml(f, lambda d: d["runs"][0].__setitem__("file", "../x.csv")), "runs.0.file"),
    ("run-twice", lambda f: _edit_yaml(f, lambda d: d["runs"].append(dict(d["runs"][0]))), "listed twice"),
    ("csv-empty", lambda f: (f / "free.csv").write_text(""), "free.csv: empty file"),
    ("csv-header-only", lambda f: (f / "free.csv").write_text("t,g,d,i_q,i_d\n"), "at least 2 data rows"),
    (
        "csv-missing-col",
        lambda f: (f / "free.csv").write_text("t,g,d,i_q\n0,1,1,1\n0.001,1,1,1\n"),
        "missing column 'i_d'",
    ),
    (
        "csv-dup-col",
        lambda f: (f / "free.csv").write_text("t,g,d,i_q,i_d,g\n0,1,1,1,1,1\n0.001,1,1,1,1,1\n"),
        "'g' appears twice",
    ),
    ("csv-ragged", lambda f: _edit_csv(f, "free.csv", 5, "i_d", "1,2"), "free.csv: row 5 (line 6): 6 fields"),
    ("csv-text", lambda f: _edit_csv(f, "free.csv", 7, "g", "abc"), "free.csv: row 7 (line 8), column 'g': not a num"),
    ("csv-blank-cell", lambda f: _edit_csv(f, "free.csv", 3, "i_q", ""), "row 3 (line 4), column 'i_q'"),
    ("csv-nan", lambda f: _edit_csv(f, "free.csv", 4, "d", "nan"), "row 4 (line 5), column 'd': non-finite"),
    ("csv-inf", lambda f: _edit_csv(f, "hover.csv", 9, "i_d", "-inf"), "hover.csv: row 9 (line 10), column 'i_d'"),
    ("csv-time-back", lambda f: _edit_csv(f, "free.csv", 10, "t", "0.001"), "row 10 (line 11), column 't': time does"),
    ("csv-time-uneven", lambda f: _edit_csv(f, "free.csv", 20, "t", "0.0195"), "row 20 (line 21), column 't': time st"),
    ("csv-locked-moves", lambda f: _edit_csv(f, "hover.csv", 6, "d", "0.001"), "row 6 (line 7), column 'd': axis d"),
    (
        "csv-blank-line",
        lambda f: (f / "free.csv").write_text("t,g,d,i_q,i_d\n0,1,1,1,1\n\n0.001,1,1,1,1\n"),
        "row 2 (line 3): 0 fields",
    ),
    ("csv-binary", lambda f: (f / "free.csv").write_bytes(b"\x89PNG\r\n\x1a\n\xff\xff"), "not a text file"),
]


@pytest.mark.parametrize(("name", "corrupt", "expect"), BAD_DATASETS, ids=[c[0] for c in BAD_DATASETS])
def test_bad_dataset_is_refused_naming_file_row_column(tmp_path, capsys, name, corrupt, expect):
    folder = _good_dataset(tmp_path / "ds")
    read_dataset(folder)  # fine before
    corrupt(folder)
    with pytest.raises(DataError) as exc:
        read_dataset(folder)
    msg = str(exc.value)
    assert "\n" not in msg and expect in msg, msg
    code, err = run_cli(capsys, "simulate", "--check", str(folder))
    assert code == 2 and "\n" not in err and expect in err


def test_missing_dataset_folder(tmp_path, capsys):
    code, err = run_cli(capsys, "simulate", "--check", str(tmp_path / "none"))
    assert code == 2 and "no such dataset folder" in err


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(row=st.integers(0, 20), col=st.integers(0, 4), text=st.text(max_size=6))
def test_any_cell_edit_gives_a_dataset_or_a_data_error(tmp_path_factory, row, col, text):
    folder = _good_dataset(tmp_path_factory.mktemp("h"))
    p = folder / "free.csv"
    lines = p.read_text().splitlines()
    cells = lines[row].split(",")
    cells[col] = text
    lines[row] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    try:
        ds = read_dataset(folder)
    except DataError as err:
        assert "\n" not in str(err) and "free.csv" in str(err)
    else:
        run = ds.run("free.csv")
        for c in ("t", "g", "d", "i_q", "i_d"):
            assert np.all(np.isfinite(run[c]))
        assert np.all(np.diff(run.t) > 0)


def test_console_command_prints_one_line_without_traceback(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("process_noise: {g: -1}\n")
    proc = subprocess.run(
        [sys.executable, "-m", "maglev_ocp", "simulate", "--plant", str(f)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr and "process_noise.g" in proc.stderr
