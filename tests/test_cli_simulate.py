"""``maglev simulate``: datasets the reader accepts, seeds, open loop, locks, help, checks."""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.cli import main
from maglev_ocp.model import get_model
from maglev_ocp.params import NOMINAL
from maglev_ocp.riglog import REQUIRED_COLUMNS, read_dataset


def sim(*args: str) -> int:
    return main(["simulate", "--no-progress", *args])


def test_hover_writes_a_dataset_the_reader_accepts(tmp_path, capsys):
    out = tmp_path / "hover"
    assert sim("--experiment", "hover", "--g", "15", "--duration", "0.5", "--out", str(out), "--plot") == 0
    ds = read_dataset(out)
    (run,) = ds.runs
    assert run.file == "hover_g15p0_d0p0.csv" and run.locked == ()
    assert all(c in run.names for c in (*REQUIRED_COLUMNS, "g_ref", "d_ref", "g_true"))
    assert len(run) == 500 and abs(run["g_true"][-100:] - 0.015).max() < 1e-4
    assert ds.meta["experiment"] == "hover" and ds.meta["plant"]["profile"] == "default"
    assert ds.meta["true_params"]["C1"] != NOMINAL.C1  # the default rig's constants are off a little
    assert (out / "hover_g15p0_d0p0.png").stat().st_size > 1000
    assert "hover_g15p0_d0p0.csv" in capsys.readouterr().out


def test_same_seed_same_bytes_different_seed_different(tmp_path):
    for name, seed in (("a", "4"), ("b", "4"), ("c", "5")):
        out = str(tmp_path / name)
        assert sim("--experiment", "excitation", "--duration", "0.3", "--seed", seed, "--out", out) == 0
    files = ("excitation_g20p0_d0p0.csv", "dataset.yaml")
    a, b, c = ([(tmp_path / n / f).read_bytes() for f in files] for n in "abc")
    assert a == b
    assert a[0] != c[0] and a[1] != c[1]


def test_open_loop_constant_current_at_locked_gap_is_the_seed_parabola(tmp_path):
    """Seed section V.A: g locked, constant i_q: d(t) = d0 - L1(g) i_q t^2 / 2 (eq. (5))."""
    params = tmp_path / "p.yaml"
    NOMINAL.without_cogging().save(params)
    out = tmp_path / "par"
    assert (
        sim(
            "--constant",
            "-0.5",
            "0",
            "--lock",
            "g",
            "--g",
            "22.5",
            "--d",
            "-50",
            "--duration",
            "0.2",
            "--profile",
            "ideal",
            "--params",
            str(params),
            "--out",
            str(out),
        )
        == 0
    )
    (run,) = read_dataset(out).runs
    assert run.locked == ("g",) and np.all(run["g"] == 0.0225)
    assert np.all(run["i_q"] == -0.5) and np.all(run["i_d"] == 0.0)
    c = np.polyfit(run.t, run["d"], 2)
    L1 = NOMINAL.C1 * float(get_model().shape(0.0225)[3])
    assert 2 * c[0] / 0.5 == pytest.approx(L1, rel=1e-3)


def test_open_loop_current_file_zoh_and_stop_event(tmp_path, capsys):
    csv = tmp_path / "cur.csv"
    csv.write_text("t,i_q,i_d,note\n0,0,1.4984,start\n0.0105,0,6.0,push\n")
    out = tmp_path / "fall"
    assert sim("--currents", str(csv), "--duration", "0.4", "--out", str(out)) == 0
    (run,) = read_dataset(out).runs
    i_d = run["i_d"]
    assert np.all(i_d[:11] == 1.4984) and np.all(i_d[11:] == 6.0)  # ZOH: the row at or before each sample
    printed = capsys.readouterr().out
    assert "stop event" in printed and "g hit its upper stop" in printed  # an event, not a crash
    assert read_dataset(out).runs[0].meta["stop_events"][0]["axis"] == "g"


def test_lock_d_excitation_sweeps_only_the_gap(tmp_path):
    out = tmp_path / "v"
    assert (
        sim(
            "--experiment",
            "excitation",
            "--lock",
            "d",
            "--d",
            str(3 * k.t1 / 2 * 1e3),
            "--duration",
            "1.5",
            "--out",
            str(out),
        )
        == 0
    )
    (run,) = read_dataset(out).runs
    assert run.locked == ("d",) and len(np.unique(run["d"])) == 1
    assert np.all(run["i_q"] == 0.0)  # the seed sets u1 = 0 with d locked
    assert np.ptp(run["g_ref"]) > 1e-4


def test_help_has_examples(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "example" in text and "maglev simulate --experiment hover" in text


def test_check_prints_a_summary(tmp_path, capsys):
    out = tmp_path / "ok"
    assert sim("--duration", "0.05", "--out", str(out)) == 0
    capsys.readouterr()
    assert main(["simulate", "--check", str(out)]) == 0
    assert "hover_g20p0_d0p0.csv" in capsys.readouterr().out
