"""Rig-log datasets (RIG_LOG.md): writing, reading back bit for bit, extras, summaries."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from maglev_ocp.riglog import FORMAT, Dataset, RunLog, read_dataset, write_dataset


def make_run(file: str = "run.csv", n: int = 50, locked=(), seed: int = 0, Ts: float = 1e-3) -> RunLog:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * Ts
    g = np.round((0.02 + 1e-4 * np.sin(7 * t) + 3e-6 * rng.standard_normal(n)) / 1e-5) * 1e-5
    d = np.round((0.01 * np.sin(3 * t)) / 1e-5) * 1e-5
    if "g" in locked:
        g[:] = 0.015
    if "d" in locked:
        d[:] = 0.0
    return RunLog(
        file,
        {
            "t": t,
            "g": g,
            "d": d,
            "i_q": rng.normal(0, 0.3, n),
            "i_d": 1.5 + rng.normal(0, 0.1, n),
            "g_ref": np.full(n, 0.02),
        },
        tuple(locked),
    )


def test_round_trip_is_bit_for_bit_with_extras_and_locks(tmp_path):
    runs = [
        make_run("free.csv"),
        make_run("hover_d0.csv", locked=("d",), seed=1),
        make_run("parabola.csv", locked=("g",), seed=2),
    ]
    runs[0] = runs[0].with_columns(flag=np.array(["ok"] * 49 + ["late"]), sparse=np.r_[np.nan, np.ones(49)])
    write_dataset(tmp_path, runs, meta={"seed": 3, "true_params": {"C1": np.float64(14.3)}}, description="unit test")
    ds = read_dataset(tmp_path)
    assert isinstance(ds, Dataset) and len(ds) == 3 and ds.sample_time == 1e-3 and ds.encoder_resolution == 1e-5
    assert ds.meta == {"seed": 3, "true_params": {"C1": 14.3}}
    for a, b in zip(runs, ds, strict=True):
        assert a.file == b.file and a.locked == b.locked and a.names == b.names
        for c in a.names:
            if a[c].dtype.kind == "f":
                assert np.array_equal(a[c], b[c], equal_nan=True), c
            else:
                assert list(a[c]) == list(b[c]), c
    assert np.array_equal(np.round(ds.run("free.csv")["g"] / 1e-5) * 1e-5, ds.run("free.csv")["g"])
    doc = yaml.safe_load((tmp_path / "dataset.yaml").read_text())
    assert doc["format"] == FORMAT and doc["runs"][1] == {"file": "hover_d0.csv", "locked": ["d"]}
    # reading the dataset.yaml path works too
    assert read_dataset(tmp_path / "dataset.yaml").run("parabola.csv").locked == ("g",)


def test_views(tmp_path):
    run = make_run(n=30)
    text = run.table(max_rows=6)
    assert "run.csv" in text and "..." in text and "i_q" in text
    assert run.y.shape == (30, 2) and run.u.shape == (30, 2) and run.duration == pytest.approx(0.029)
    write_dataset(tmp_path, [run])
    summary = read_dataset(tmp_path).table()
    assert "run.csv" in summary and "g min..max [mm]" in summary
    with pytest.raises(KeyError, match=r"run\.csv"):
        read_dataset(tmp_path).run("other.csv")


def test_writer_refuses_inconsistent_runs(tmp_path):
    with pytest.raises(ValueError, match="distinct"):
        write_dataset(tmp_path, [make_run("a.csv"), make_run("a.csv")])
    with pytest.raises(ValueError, match="locked"):
        RunLog("x.csv", {"t": np.zeros(2)}, ("g", "d"))
    with pytest.raises(ValueError, match="rows"):
        RunLog("x.csv", {"t": np.zeros(2), "g": np.zeros(3)})
    bad = RunLog("x.csv", {"t": np.arange(3) * 1e-3, "g": np.zeros(3)})
    with pytest.raises(ValueError, match="required"):
        write_dataset(tmp_path, [bad])


@settings(max_examples=40, deadline=None)
@given(
    # gaps within the reader's physical range (0..64 mm, riglog.PHYSICAL_RANGES); outside it is refused (below)
    st.lists(st.floats(min_value=0.0, max_value=0.06, allow_nan=False), min_size=2, max_size=30),
    st.sampled_from([1e-5, 1e-6, 2.5e-5]),
)
def test_quantized_values_survive_csv_exactly(tmp_path_factory, values, res):
    """Any quantized value round(v / res) * res reads back bit for bit (repr is round-trip exact)."""
    folder = tmp_path_factory.mktemp("q")
    v = np.round(np.asarray(values) / res) * res
    n = len(v)
    run = RunLog(
        "q.csv", {"t": np.arange(n) * 1e-3, "g": v, "d": -v, "i_q": np.asarray(values) * 7, "i_d": np.zeros(n)}
    )
    write_dataset(folder, [run], encoder_resolution=res)
    back = read_dataset(folder).run("q.csv")
    for c in run.names:
        assert np.array_equal(back[c], run[c])
    assert np.array_equal(np.round(back["g"] / res) * res, back["g"])


def test_quoted_header_cell_spanning_lines_still_gives_one_line_error(tmp_path):
    """A stray quote in the header makes csv read the whole file as one cell: the error stays one line."""
    from maglev_ocp.errors import DataError

    (tmp_path / "dataset.yaml").write_text(
        f"format: {FORMAT}\nsample_time: 0.001\nencoder_resolution: 1.0e-05\n"
        "runs:\n  - {file: free.csv, locked: []}\n"
    )
    rows = "\n".join(f"{k * 1e-3},0.02,0.0,0.0,1.0" for k in range(20))
    (tmp_path / "free.csv").write_text('",g,d,i_q,i_d\n' + rows + "\n")
    with pytest.raises(DataError) as err:
        read_dataset(tmp_path)
    msg = str(err.value)
    assert "\n" not in msg and "free.csv" in msg and len(msg) <= 600
