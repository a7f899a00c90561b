"""The scenario runner: files, determinism, metrics, any Controller, failures that never crash a run."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from maglev_ocp import constants as k
from maglev_ocp import runner
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.errors import UserError
from maglev_ocp.loop import ClosedLoop, RigLogRecorder, TraceRecorder
from maglev_ocp.metrics import compute_metrics, target_metrics
from maglev_ocp.model import get_model
from maglev_ocp.params import NOMINAL
from maglev_ocp.reference import Move, ReferencePlan, Target
from maglev_ocp.riglog import read_dataset
from maglev_ocp.runner import build_controller, build_run, plan_run, run_scenario, summary_table
from maglev_ocp.scenario import Checks, StartSpec, scenario_from_dict

#: The scenarios' default hover at the start, before the first target [s].
HOVER = StartSpec().hover

SHORT = {
    "name": "short",
    "seed": 5,
    "controller": {"type": "fl"},
    "plant": {"profile": "default"},
    "targets": [{"g": 0.020, "d": 0.0, "hold": 0.1}, {"g": 0.019, "d": 0.004, "hold": 0.15}],
}


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "short"
    return run_scenario(SHORT, out_dir=out, progress=False), out


def test_files_and_columns(short_run):
    res, out = short_run
    for name in (
        "log.csv",
        "timing.csv",
        "metrics.json",
        "scenario.yaml",
        "dataset.yaml",
        "positions.png",
        "currents.png",
        "solver_time.png",
    ):
        assert (out / name).is_file(), name
    header = (out / "log.csv").read_text().splitlines()[0].split(",")
    assert header[:5] == ["t", "g", "d", "i_q", "i_d"]
    for col in ("g_ref", "d_ref", "g_true", "d_true", "g_dot_hat", "d_dot_hat", "unreachable", "fallback"):
        assert col in header
    assert "step_time_us" not in header  # wall-clock time lives in timing.csv (log.csv stays reproducible)
    ds = read_dataset(out)  # the run folder is a maglev-rig-log/1 dataset
    run = ds.run("log.csv")
    assert len(run) == round((HOVER + 0.25) / k.Ts)
    m = json.loads((out / "metrics.json").read_text())
    for key in ("all_settled", "stop_hits", "solver_failures", "fallbacks", "step_time_us", "targets", "passed"):
        assert key in m
    for key in (
        "settled",
        "settle_time_s",
        "rms_error_g_m",
        "rms_error_d_m",
        "rms_error_g_enc_m",
        "rms_error_d_enc_m",
        "max_current_A",
    ):
        assert key in m["targets"][0]
    assert set(m["step_time_us"]) == {"median", "p99", "max"}
    again = scenario_from_dict(yaml.safe_load((out / "scenario.yaml").read_text()))
    assert again.resolved() == res.scenario.resolved()
    assert "settled" in res.table() and "PASS" in res.table()


def test_encoder_columns_are_quantized_readings_of_the_true_state(short_run):
    res, _ = short_run
    c = res.columns
    q = c["g"] / k.encoder_resolution
    assert np.allclose(q, np.round(q), atol=1e-6)
    assert np.max(np.abs(c["g"] - c["g_true"])) < 2e-5  # 5 um quantization + 2 um noise (a few sigma)


def test_same_seed_same_log_bytes(tmp_path):
    """Bit-identical log.csv for the same seed, also with a controller reused from a cache."""
    cache: dict = {}
    a = run_scenario(SHORT, out_dir=tmp_path / "a", progress=False, cache=cache, figures=False)
    b = run_scenario(SHORT, out_dir=tmp_path / "b", progress=False, cache=cache, figures=False)
    assert len(cache) == 1
    c = run_scenario(SHORT, out_dir=tmp_path / "c", progress=False, seed=6, figures=False)
    la, lb, lc = ((tmp_path / n / "log.csv").read_bytes() for n in "abc")
    assert la == lb
    assert la != lc
    assert a.metrics.targets[1].rms_error_g_m == b.metrics.targets[1].rms_error_g_m
    assert c.scenario.seed == 6


def test_settle_metrics_on_a_known_trajectory():
    """Exponential approach e(t) = e0 exp(-t/tau): settle time = tau ln(e0/tol), RMS over the settled part."""
    Ts, tau, e0, tol = 1e-3, 0.02, 1e-3, 1e-4
    t = np.arange(0, 0.3, Ts)
    e = e0 * np.exp(-t / tau)
    x = np.zeros((len(t), 4))
    x[:, 0] = 0.02 + e
    x[:, 2] = -0.01 - 0.5 * e
    y = np.column_stack([x[:, 0], x[:, 2]])
    u = np.column_stack([np.full(len(t), 3.0), np.full(len(t), 4.0)])
    tm = target_metrics(0, t, x, y, u, Target(0.02, -0.01, 0.3), 0.0, 0.0, tol, 0.05, Ts)
    t_expect = tau * math.log(e0 / tol)
    assert tm.settled and tm.settle_time_s == pytest.approx(t_expect, abs=Ts)
    sel = t >= tm.settle_time_s - 1e-12
    assert tm.rms_error_g_m == pytest.approx(np.sqrt(np.mean(e[sel] ** 2)), rel=1e-12)
    assert tm.rms_error_d_m == pytest.approx(0.5 * tm.rms_error_g_m, rel=1e-12)
    assert tm.max_current_A == pytest.approx(5.0)
    # an excursion late in the hold restarts the clock; too short a settled stretch is not settled
    x2 = x.copy()
    x2[-20, 0] += 5e-4
    tm2 = target_metrics(0, t, x2, y, u, Target(0.02, -0.01, 0.3), 0.0, 0.0, tol, 0.05, Ts)
    assert not tm2.settled and tm2.settle_time_s is None and tm2.rms_error_g_m is None
    # a plan still arriving after the settle instant: the steady errors start where the reference arrives
    t_arrive = 0.1
    tm3 = target_metrics(0, t, x, y, u, Target(0.02, -0.01, 0.3), 0.0, t_arrive, tol, 0.05, Ts)
    late = t >= t_arrive - 1e-12
    assert tm3.settle_time_s == tm.settle_time_s  # the settle instant is the band's, not the plan's
    assert tm3.rms_error_g_m == pytest.approx(np.sqrt(np.mean(e[late] ** 2)), rel=1e-12)
    assert tm3.max_abs_error_g_settled_m == pytest.approx(e[late][0], rel=1e-12)
    # a plan that never arrives within the hold: the whole settled part
    tm4 = target_metrics(0, t, x, y, u, Target(0.02, -0.01, 0.3), 0.0, 1.0, tol, 0.05, Ts)
    assert tm4.rms_error_g_m == pytest.approx(tm.rms_error_g_m, rel=1e-12)


def test_overall_metrics_and_checks():
    plan = ReferencePlan([Target(0.02, 0.0, 0.1)], np.array([0.0]), [Move(0.0, 0.0, (0.02, 0.0), (0.02, 0.0))])
    n = 100
    t = np.arange(n) * k.Ts
    x = np.tile([0.02, 0, 0, 0], (n, 1)).astype(float)
    u = np.tile([0.0, 1.5], (n, 1)).astype(float)
    u[10] = [7.0, 5.0]  # 8.6 A: beyond the amplitude limit
    stats = {
        "status": np.array(["ok"] * 95 + ["fallback"] * 5, dtype=object),
        "fallback": np.array([0.0] * 95 + [1.0] * 5),
    }
    stops = [SimpleNamespace(__str__=lambda self: "stop")]
    m = compute_metrics(
        scenario="s",
        controller="c",
        seed=1,
        t=t,
        x_true=x,
        y_enc=x[:, [0, 2]],
        u=u,
        plan=plan,
        tolerance=1e-4,
        checks=Checks(max_settle_time_s=0.05),
        stats=stats,
        step_time_us=np.arange(n, dtype=float),
        stop_events=stops,
    )
    assert m.solver_failures == 5 and m.fallbacks == 5 and m.stop_hits == 1
    assert not m.currents_within_limits and m.max_current_A == pytest.approx(math.hypot(7, 5))
    assert m.step_time_us["median"] == pytest.approx(49.5) and m.step_time_us["max"] == 99
    assert not m.passed
    assert any("stop" in f for f in m.failed_checks) and any("limits" in f for f in m.failed_checks)
    assert m.to_dict()["passed"] is False and json.dumps(m.to_dict())


class _HoverPD:
    """A minimal Controller (not from this package): hover currents plus a PD on the raw readings."""

    name = "hover_pd"

    def __init__(self, fail_at: int | None = None, nan_at: int | None = None, report_fallback: bool = False):
        self.fail_at, self.nan_at, self.report_fallback = fail_at, nan_at, report_fallback
        self.p = NOMINAL.vector()

    def reset(self, y0: Measurement, ref: Reference) -> None:
        self.k = 0
        self.prev = np.asarray(y0.y, float)

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        self.k += 1
        if self.fail_at is not None and self.k > self.fail_at:
            raise RuntimeError("solver exploded")
        u = np.asarray(get_model().u_eq(ref.g, ref.d, self.p)).ravel()
        v = (np.asarray(y.y) - self.prev) / k.Ts
        self.prev = np.asarray(y.y, float)
        u[1] += -(3000 * (ref.g - y.y[0]) - 30 * v[0]) / 40  # gap: i_d > 0 opens the gap
        u[0] += -(3000 * (ref.d - y.y[1]) - 60 * v[1]) / 6.7
        if self.nan_at is not None and self.k > self.nan_at:
            u[0] = math.nan
        fb = self.report_fallback and self.k % 10 == 0
        return ControlOutput(
            u=np.clip(u, -5, 5), stats={"status": "fallback" if fb else "ok", "fallback": fb, "solve_us": 1.0}
        )


def test_runner_accepts_any_controller(tmp_path):
    sc = {**SHORT, "plant": {"profile": "ideal"}, "targets": [{"g": 0.02, "d": 0.0, "hold": 0.2}]}
    res = run_scenario(sc, progress=False, controller=_HoverPD(report_fallback=True))
    assert res.metrics.error is None and len(res.columns["t"]) == round((HOVER + 0.2) / k.Ts)
    n_fb = round((HOVER + 0.2) / k.Ts) // 10  # every 10th step reports a fallback
    assert res.metrics.fallbacks == n_fb and res.metrics.solver_failures == n_fb
    assert "solve_us" not in res.columns  # timing-like statistics stay out of log.csv
    assert list(res.columns["status"][:2]) == ["ok", "ok"]
    res.save(tmp_path / "o", figures=False)
    assert read_dataset(tmp_path / "o").run("log.csv")["status"][9] == "fallback"


@pytest.mark.parametrize("kind", ["raise", "nan"])
def test_a_failing_controller_ends_the_run_not_the_process(kind, tmp_path):
    sc = {**SHORT, "plant": {"profile": "ideal"}, "targets": [{"g": 0.02, "d": 0.0, "hold": 0.2}]}
    ctrl = _HoverPD(fail_at=50) if kind == "raise" else _HoverPD(nan_at=50)
    res = run_scenario(sc, out_dir=tmp_path / kind, progress=False, controller=ctrl, figures=False)
    assert len(res.columns["t"]) == 50
    assert res.metrics.error and ("solver exploded" in res.metrics.error or "non-finite" in res.metrics.error)
    assert not res.passed
    m = json.loads((tmp_path / kind / "metrics.json").read_text())
    assert m["error"] and m["passed"] is False


def test_scenario_trace_and_rig_log_come_from_the_one_loop():
    """One ClosedLoop with both recorders: the runner's log and the rig-log run of the same steps agree."""
    sc = scenario_from_dict({**SHORT, "targets": [{"g": 0.02, "d": 0.0, "hold": 0.1}]}, "s.yaml")
    rp = plan_run(sc)
    ctrl, plant = build_run(sc, _HoverPD(), cache={})
    trace, riglog = TraceRecorder(rp.n), RigLogRecorder(rp.n)
    loop = ClosedLoop(plant, ctrl, [trace, riglog], on_error="stop")
    loop.reset(np.array([sc.start.g, 0.0, sc.start.d, 0.0]), rp.reference(0))
    assert loop.run(rp.reference, rp.n) == rp.n == round((HOVER + 0.1) / k.Ts) and loop.error is None
    log = riglog.log(plant, "r.csv")
    np.testing.assert_array_equal(log["g"], trace.Y[:, 0])  # same readings
    np.testing.assert_array_equal(log["d_true"], trace.X[:, 2])
    np.testing.assert_array_equal(log["g_ref"], rp.refs[:, 0])
    free = trace.limited == 0  # the plant logs the command after its limiter
    np.testing.assert_array_equal(log["i_q"][free], trace.U[free, 0])
    # and the runner's own stages give the same trace bit for bit
    res = run_scenario(sc, progress=False, controller=_HoverPD())
    np.testing.assert_array_equal(res.columns["g"], trace.Y[:, 0])
    np.testing.assert_array_equal(res.columns["i_q_applied"], trace.UA[:, 0])


def test_loop_error_policy():
    """on_error='raise' lets a controller's exception through; 'stop' ends the run with the message kept."""
    sc = scenario_from_dict({**SHORT, "plant": {"profile": "ideal"}}, "s.yaml")
    _, plant = build_run(sc, _HoverPD(), cache={})
    ref = Reference(g=0.02, d=0.0)
    loop = ClosedLoop(plant, _HoverPD(fail_at=3), on_error="raise")
    loop.reset(None, ref)
    with pytest.raises(RuntimeError, match="solver exploded"):
        loop.run(lambda i: ref, 10)
    assert loop.steps == 3
    loop = ClosedLoop(plant, _HoverPD(nan_at=4), on_error="stop")
    loop.reset(None, ref)
    assert loop.run(lambda i: ref, 10) == 4
    assert "non-finite currents" in loop.error and "t = 0.004 s" in loop.error
    with pytest.raises(ValueError, match="on_error"):
        ClosedLoop(plant, _HoverPD(), on_error="ignore")


def test_c_backend_without_generated_code_is_a_clear_user_error(monkeypatch):
    """backend: c is built by what maglev_ocp.codegen registered; without it, a one-line UserError."""
    monkeypatch.setattr(runner, "CONTROLLER_BACKENDS", {})  # maglev_ocp.codegen not imported
    sc = scenario_from_dict({**SHORT, "controller": {"type": "fl", "backend": "c"}}, "s.yaml")
    with pytest.raises(UserError, match="not available yet"):
        build_controller(sc)


def test_summary_table_lists_every_scenario(short_run):
    res, _ = short_run
    text = summary_table([("short", res, None), ("broken", None, "RuntimeError: boom")])
    assert "short" in text and "PASS" in text and "ERROR" in text and "boom" in text


def _cli(*args, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "maglev_ocp", "run", *args], capture_output=True, text=True, timeout=timeout
    )


def test_cli_exit_codes(tmp_path):
    ok = tmp_path / "ok.yaml"
    ok.write_text(yaml.safe_dump({**SHORT, "name": "ok"}))
    strict = tmp_path / "strict.yaml"  # a settle-time bound nothing can meet: tolerance check fails -> 1
    strict.write_text(
        yaml.safe_dump(
            {
                **SHORT,
                "name": "strict",
                "targets": [{"g": 0.020, "d": 0.0, "hold": 0.1}, {"g": 0.017, "d": 0.01, "hold": 0.15}],
                "checks": {"max_settle_time_s": 0.001},
            }
        )
    )
    out = tmp_path / "out"
    r = _cli(str(ok), "--out", str(out), "--no-progress", "--no-figures")
    assert r.returncode == 0, r.stderr
    assert "ok" in r.stdout and "PASS" in r.stdout
    r = _cli(str(ok), str(strict), "--out", str(out), "--no-progress", "--no-figures")
    assert r.returncode == 1
    assert (out / "ok" / "metrics.json").is_file() and (out / "strict" / "metrics.json").is_file()
    assert json.loads((out / "strict" / "metrics.json").read_text())["passed"] is False
    r = _cli(str(ok), "--out", str(out), "--seed", "-3")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    r = _cli(str(tmp_path / "missing.yaml"), "--out", str(out))
    assert r.returncode == 2 and "missing.yaml" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "maglev_ocp", "run", str(ok)], capture_output=True, text=True)
    assert r.returncode == 2  # --out is required: never writes into the current folder by accident


def test_scenario_path_and_dict_inputs(tmp_path):
    p = Path(tmp_path / "s.yaml")
    p.write_text(yaml.safe_dump({**SHORT, "plant": {"profile": "ideal"}}))
    a = run_scenario(p, progress=False)
    b = run_scenario({**SHORT, "plant": {"profile": "ideal"}}, progress=False)
    assert np.array_equal(a.columns["g_true"], b.columns["g_true"])


def test_main_job_writes_results(tmp_path):
    """The headline job on one scenario: model table, plant simulation, the scenario's folder and summary.md
    (the calibration task, 50 s, in :func:`test_main_job_calibrates_on_the_seed_experiments`, long tier; the
    calibration itself is `test_calibration`'s)."""
    from maglev_ocp.main_job import HEADLINE, SCENARIO_DIR, main

    for n in HEADLINE:
        assert (SCENARIO_DIR / f"{n}.yaml").is_file()
    out = tmp_path / "results"
    rc = main(["--out", str(out), "--scenarios", "gap_steps_fl", "--no-min-time", "--no-calibration", "--jobs", "1"])
    assert rc == 0
    assert not (out / "calibration").exists()
    for f in (
        "model_table.txt",
        "model_table.json",
        "model_table.png",
        "summary.md",
        "summary.json",
        "gap_steps_fl/log.csv",
        "gap_steps_fl/metrics.json",
        "gap_steps_fl/positions.png",
    ):
        assert (out / f).is_file(), f
    assert (out / "simulate" / "dataset.yaml").is_file()
    text = (out / "summary.md").read_text()
    assert "gap_steps_fl" in text and "PASS" in text
    assert "not run (`--no-calibration`)" in text
    assert main(["--out", str(out), "--scenarios", "no_such_scenario"]) == 2


@pytest.mark.long  # the main job's calibration task end to end (`make run` runs it; 50 s)
def test_main_job_calibrates_on_the_seed_experiments(tmp_path):
    """The main job's calibration task: the seed's calibration experiments simulated, `maglev calibrate` on them,
    its folder written and linked from summary.md, and the job's exit code 0 only with it."""
    from maglev_ocp.main_job import main

    out = tmp_path / "results"
    assert main(["--out", str(out), "--scenarios", "gap_steps_fl", "--no-min-time", "--jobs", "1"]) == 0
    assert (out / "calibration" / "README.md").is_file()
    assert "[calibration/README.md](calibration/README.md)" in (out / "summary.md").read_text()
