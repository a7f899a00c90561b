"""The compiled closed loop (one C call per scenario) equals the Python loop for the same noise draws.

Reference: :func:`maglev_ocp.runner.run_scenario` (the Python :class:`~maglev_ocp.loop.ClosedLoop`)
with the controller on ``backend: c``, i.e. the very compiled step the C loop calls; the plant is the
Python plant (CasADi's virtual machine) on one side and its step Function code-generated on the other.
Noise (process, current, measurement), encoder quantization, limits, stops, the amplifier lag and
friction of the default profile, delays and disturbances are all on: the logs must agree to 1e-9
(they agree bit for bit: every operation rounds the same, so no quantization count can flip).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from maglev_ocp.campaign import run_campaign
from maglev_ocp.campaign.config import load_campaign
from maglev_ocp.codegen.build import find_compiler
from maglev_ocp.codegen.loop_c import nmpc_refs, run_scenario_compiled
from maglev_ocp.config import load_yaml
from maglev_ocp.output import dump_yaml
from maglev_ocp.params import NOMINAL
from maglev_ocp.runner import plan_run, run_scenario
from maglev_ocp.scenario import scenario_from_dict

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler: the compiled loop cannot be built here")
TOL = 1e-9


def _scenario(ctype: str, **extra) -> dict:
    """Short scenario: hover, a diagonal move, a gap step (default rig profile: noise and quantization on)."""
    sc = {
        "name": f"cloop_{ctype}",
        "seed": 11,
        "controller": {"type": ctype, "backend": "c"},
        "plant": {"profile": "default"},
        "targets": [
            {"g": 0.020, "d": 0.000, "hold": 0.06},
            {"g": 0.017, "d": 0.015, "hold": 0.12},
            {"g": 0.022, "d": 0.015, "hold": 0.10},
        ],
    }
    for key, val in extra.items():
        if isinstance(val, dict) and isinstance(sc.get(key), dict):
            sc[key] = {**sc[key], **val}
        else:
            sc[key] = val
    return sc


def _compare(d: dict) -> float:
    sc = scenario_from_dict(d)
    return _log_difference(run_scenario(sc, progress=False), run_scenario_compiled(sc))


def _same(a, b) -> bool:
    """Equal; floats (SI units) to :data:`TOL`, as the log's columns: C and numpy differ in the last bits (an error
    of 5.4e-7 m read 3.5e-18 m apart on an AVX2 machine), counts and flags exactly."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or abs(a - b) <= TOL
    return a == b


def _log_difference(py, cc) -> float:
    """Largest difference of two runs' logs (asserted <= TOL column by column, same metrics)."""
    assert list(py.columns) == list(cc.columns)
    assert py.metrics.error == cc.metrics.error
    worst = 0.0
    for key, a in py.columns.items():
        b = cc.columns[key]
        assert len(a) == len(b), key
        if a.dtype == object:
            assert a.tolist() == b.tolist(), key
            continue
        assert np.array_equal(np.isnan(a), np.isnan(b)), key
        if key == "limited":
            # The limiter's flag may differ at an isolated sample where the command sits on the limit to the last
            # bits (C and numpy differ by an ulp there: one sample of a run on an AVX2 machine, every other column
            # equal to 1e-12). A flip that changed a current fails in the current columns, compared here too.
            flip = np.flatnonzero(a != b)
            assert len(flip) <= max(1, len(a) // 1000), (key, flip)
            a, b = np.delete(a, flip), np.delete(b, flip)
        diff = np.abs(a - b)[~np.isnan(a)]
        worst = max(worst, float(diff.max()) if diff.size else 0.0)
        assert worst <= TOL, (key, worst)
    mp, mc = py.metrics.to_dict(), cc.metrics.to_dict()
    for key in ("targets", "stop_hits", "max_current_A", "passed", "solver_failures", "fallbacks"):
        assert _same(mp.get(key), mc.get(key)), (key, mp.get(key), mc.get(key))
    # the quantized readings are identical, not just close (no encoder count flipped)
    assert np.array_equal(py.columns["g"], cc.columns["g"]) and np.array_equal(py.columns["d"], cc.columns["d"])
    return worst


@needs_cc
def test_fl_compiled_loop_equals_python_loop():
    assert _compare(_scenario("fl")) <= TOL


@needs_cc
@pytest.mark.parametrize("backend", ["c", "python"])
def test_pid_compiled_loop_equals_python_loop(backend):
    """The PID regulators' scenario on the compiled loop (pid_step) equals the Python loop with the Python PID
    and with its backend: c."""
    d = _scenario("pid")
    d["controller"] = {"type": "pid", "backend": backend}
    assert _compare(d) <= TOL


@needs_cc
@pytest.mark.parametrize(
    "extra",
    [
        {"plant": {"disturbances": [{"type": "cable", "stiffness_d": 300.0, "damping_d": 5.0, "weight_g": 3.0}]}},
        {"plant": {"disturbances": [{"type": "payload", "mass": 0.5, "time": 0.1}]}},
        {
            "plant": {
                "disturbances": [
                    {"type": "force_pulse", "axis": "g", "amplitude": -60.0, "start": 0.1, "duration": 0.02}
                ]
            }
        },
        {"plant": {"delay_samples": 1}, "controller": {"type": "fl", "backend": "c"}},  # no predictor
        {"plant": {"delay_samples": 2}, "controller": {"type": "fl", "backend": "c", "delay_samples": 2}},
    ],
    ids=["cable", "payload", "pulse", "delay", "delay2_predicted"],
)
def test_fl_compiled_loop_equals_python_loop_with_disturbances_and_delay(extra):
    assert _compare(_scenario("fl", **extra)) <= TOL


@needs_cc
def test_compiled_fl_with_delay_predictor_equals_python_fl_on_tour_fl_delay1():
    """``backend: c`` FL with ``delay_samples: 1`` (its predictor in the generated step) gives the Python FL's
    log on ``tour_fl_delay1``, in the Python loop and in the compiled loop; without the predictor it would not."""
    root = Path(__file__).resolve().parents[1]
    d = load_yaml(root / "scenarios" / "tour_fl_delay1.yaml")
    d["controller"] = {**d["controller"], "backend": "python"}
    sc_py = scenario_from_dict(d, root_dir=root)
    py = run_scenario(sc_py, progress=False)
    assert py.metrics.passed  # a meaningful run: the predicted FL tracks the tour through the delay
    sc_c = scenario_from_dict({**d, "controller": {**d["controller"], "backend": "c"}}, root_dir=root)
    assert _log_difference(py, run_scenario(sc_c, progress=False)) <= TOL
    assert _log_difference(py, run_scenario_compiled(sc_py)) <= TOL
    # the comparison can see a missing predictor: the same loop without it commands other currents
    blind = scenario_from_dict({**d, "controller": {**d["controller"], "delay_samples": 0}}, root_dir=root)
    cb = run_scenario_compiled(blind)
    assert np.max(np.abs(cb.columns["i_q"] - py.columns["i_q"])) > 1e-3


@needs_cc
def test_fl_delay_campaign_runs_on_the_compiled_loop_and_equals_the_python_loop(tmp_path):
    """A delay campaign (FL predicting 1 and 2 samples) takes the compiled loop under ``loop: auto``, same metrics."""
    from maglev_ocp.campaign.runner_adapter import use_compiled

    d = _campaign("auto")
    d["vary"]["controllers"] = [{"type": "fl"}]
    d["runs"] = [
        {"plant.delay_samples": 1, "controller.delay_samples": 1},
        {"plant.delay_samples": 2, "controller.delay_samples": 2},
    ]
    sc = scenario_from_dict({**_scenario("fl"), "controller": {"type": "fl", "delay_samples": 1}})
    assert use_compiled(sc, "auto")
    out = {}
    for loop in ("python", "auto"):
        dump_yaml(tmp_path / f"{loop}.yaml", {**d, "name": f"delay_{loop}", "execution": {"loop": loop}})
        camp = load_campaign(tmp_path / f"{loop}.yaml")
        res = run_campaign(camp, tmp_path / loop, workers=1, progress=False, figures=False)
        df = res.summary.table.sort_values("run_id").reset_index(drop=True)
        assert (df["status"] == "ok").all() and len(df) == 4
        out[loop] = df
    a, b = out["python"], out["auto"]
    cols = [c for c in a.columns if not any(s in c for s in ("_us", "wall", "cpu", "worker", "time_s_"))]
    cols = [c for c in cols if a[c].dtype.kind in "fi"]
    assert cols
    for c in cols:
        np.testing.assert_allclose(a[c].to_numpy(float), b[c].to_numpy(float), rtol=0, atol=1e-9, err_msg=c)


#: A model file with every kind of term the generated steps must carry: a constant off nominal, friction (its
#: fitted 1 mm/s sign widened by the FL to its velocity estimate's resolution), cogging, a commutation offset,
#: and an amplifier lag whose one-period transport delay the FL predicts through.
MODEL_FILE = {
    "C1": 14.9,
    "effects": {
        "friction": {"enabled": True, "coulomb_g": 0.3, "coulomb_d": 0.4, "stribeck_d": 0.1, "viscous_d": 2.0,
                     "v_reg": 1e-3},
        "cogging": {"enabled": True, "xi0": 5.0, "ell": 3.6e-3},
        "commutation_offset": {"enabled": True, "delta": 0.0873},
        "amplifier_lag": {"enabled": True, "bandwidth_hz": 800.0, "delay_samples": 1},
    },
}  # fmt: skip
#: The rig the model file describes (its friction's sign not the fitted width, no cogging effect beyond the
#: model's own law): what the controller with the model file runs on.
MODEL_RIG = {
    "friction": {"enabled": True, "coulomb_g": 0.3, "coulomb_d": 0.4, "stribeck_d": 0.1, "viscous_d": 2.0},
    "commutation_offset": {"enabled": True, "delta": 0.0873},
    "amplifier_lag": {"enabled": True, "bandwidth_hz": 800.0, "delay_samples": 1},
}


def _model_scenario(ctype: str, path: Path, backend: str = "python") -> dict:
    """``ctype`` fl, pid or pid_inverse (the PID with ``feedforward_law: inverse``)."""
    kind = "pid" if ctype.startswith("pid") else ctype
    d = _scenario(kind, plant={"effects": MODEL_RIG})
    d["controller"] = {"type": kind, "backend": backend, "model": str(path)}
    if ctype == "pid_inverse":
        d["controller"]["feedforward_law"] = "inverse"
    return d


@needs_cc
@pytest.mark.parametrize("ctype", ["fl", "pid", "pid_inverse"])
def test_model_file_controller_is_the_same_in_python_c_and_the_compiled_loop(ctype, tmp_path):
    """With a model file (constants, friction, cogging, commutation offset, a lag's delay) the Python controller,
    its ``backend: c`` step and the compiled loop give the same log to 1e-9; the generated step holds the effects:
    the compiled loop with the same file minus its effects commands other currents."""
    from maglev_ocp.codegen.loop_c import compiled_supported

    f = tmp_path / "model.yaml"
    dump_yaml(f, MODEL_FILE)
    sc = scenario_from_dict(_model_scenario(ctype, f))
    assert compiled_supported(sc)
    py = run_scenario(sc, progress=False)
    assert py.metrics.error is None and py.metrics.stop_hits == 0
    assert _log_difference(py, run_scenario(scenario_from_dict(_model_scenario(ctype, f, "c")), progress=False)) <= TOL
    assert _log_difference(py, run_scenario_compiled(sc)) <= TOL
    # the comparison can see the effects: without them (same constants and delay) the currents differ by > 10 mA
    fb = tmp_path / "no_effects.yaml"
    dump_yaml(fb, {**MODEL_FILE, "effects": {"amplifier_lag": MODEL_FILE["effects"]["amplifier_lag"]}})
    cb = run_scenario_compiled(scenario_from_dict(_model_scenario(ctype, fb)))
    assert max(np.max(np.abs(cb.columns[c] - py.columns[c])) for c in ("i_q", "i_d")) > 1e-2


@needs_cc
def test_nmpc_with_a_model_files_delay_is_the_same_on_the_compiled_loop(tmp_path):
    """The NMPC adds a model file's lag delay to its own (``NMPC``); the compiled loop builds its step with the
    same total and reads the plan that far ahead: its log equals the Python loop's with ``backend: c``."""
    f = tmp_path / "model.yaml"
    dump_yaml(f, MODEL_FILE)
    d = _model_scenario("nmpc", f, "c")
    d["controller"]["feedforward"] = "period_mean"
    d["targets"] = d["targets"][:2]
    assert _log_difference(run_scenario(scenario_from_dict(d), progress=False), run_scenario_compiled(
        scenario_from_dict(d))) <= TOL  # fmt: skip


@needs_cc
def test_compiled_loop_follows_a_model_file_changed_at_the_same_path(tmp_path):
    """The compiled controller is keyed on the model file's content: rewriting the file at the same path (a new
    diagnosis) runs the new effects, equal to the Python FL on the new file, not the library of the old one."""
    from maglev_ocp.codegen.loop_c import controller_library

    f = tmp_path / "model.yaml"
    dump_yaml(f, MODEL_FILE)
    first = run_scenario_compiled(scenario_from_dict(_model_scenario("fl", f)))
    lib_first = controller_library("fl", scenario_from_dict(_model_scenario("fl", f)).controller.settings, NOMINAL)
    stronger = json.loads(json.dumps(MODEL_FILE))
    stronger["effects"]["commutation_offset"]["delta"] = 0.15
    dump_yaml(f, stronger)
    sc = scenario_from_dict(_model_scenario("fl", f))
    assert controller_library("fl", sc.controller.settings, NOMINAL).path != lib_first.path
    second = run_scenario_compiled(sc)
    assert np.max(np.abs(second.columns["i_q"] - first.columns["i_q"])) > 1e-3
    assert _log_difference(run_scenario(sc, progress=False), second) <= TOL


@needs_cc
@pytest.mark.parametrize("shaping", ["trajectory", "step"])
def test_nmpc_compiled_loop_equals_python_loop(shaping):
    assert _compare(_scenario("nmpc", reference={"shaping": shaping})) <= TOL


@needs_cc
def test_nmpc_compiled_loop_equals_python_loop_with_delay():
    """A one-period delay predicted by the NMPC: the compiled loop reads the plan ``delay`` periods ahead too."""
    d = _scenario("nmpc", plant={"delay_samples": 1})
    d["controller"] = {"type": "nmpc", "backend": "c", "delay_samples": 1, "feedforward": "period_mean"}
    assert _compare(d) <= TOL


@pytest.mark.parametrize("ahead", [0, 2])
@pytest.mark.parametrize("period_mean", [False, True])
def test_nmpc_reference_input_is_what_the_nmpc_reads(ahead, period_mean):
    """The pre-computed ``ref`` input of every step equals the NMPC's own read-ahead (preview mode), with and
    without a computation delay; with ``period_mean`` its accelerations are the period means the runner hands
    the controllers."""
    from maglev_ocp.controllers.nmpc.reference import HorizonReference

    sc = scenario_from_dict(_scenario("nmpc"))
    rp = plan_run(sc)
    N = 20
    hr = HorizonReference(N, 1e-3, period_mean=period_mean)
    hr.set_plan(rp.plan)
    refs = nmpc_refs("preview", rp, N, ahead, period_mean)
    for i in range(rp.n):
        m = hr.matrix("preview", i * 1e-3, rp.reference(i), ahead)
        assert np.array_equal(refs[i], np.ravel(m, order="F")), i
    # node 0 of step k is the runner's reference of period k + ahead (never held at a switch)
    col0 = refs[: rp.n - ahead, :6]
    if period_mean:
        np.testing.assert_array_equal(col0, rp.refs[ahead:])
    else:
        np.testing.assert_array_equal(col0[:, [0, 1, 3, 4]], rp.refs[ahead:][:, [0, 1, 3, 4]])
        assert np.max(np.abs(col0[:, [2, 5]] - rp.refs[ahead:][:, [2, 5]])) > 1.0  # instantaneous, not means


def _campaign(loop: str) -> dict:
    return {
        "name": f"cloop_{loop}",
        "base_scenario": str(Path(__file__).resolve().parents[1] / "scenarios" / "gap_steps_fl.yaml"),
        "n_runs": 2,
        "seed": 3,
        "vary": {
            "plant": {"C2": {"dist": "uniform", "pct": 5}},
            "seed": True,
            "targets": {"n": 1, "hold": 0.15},
            "controllers": [{"type": "fl"}, {"type": "nmpc"}],
        },
        "save": {"log": False, "figures": False},
        "execution": {"loop": loop},
    }


@needs_cc
def test_campaign_on_the_compiled_loop_equals_the_python_loop(tmp_path):
    """A few campaign runs (FL and NMPC, python backend) give the same metrics on either loop."""
    out = {}
    for loop in ("python", "compiled"):
        dump_yaml(tmp_path / f"{loop}.yaml", _campaign(loop))
        camp = load_campaign(tmp_path / f"{loop}.yaml")
        res = run_campaign(camp, tmp_path / loop, workers=1, progress=False, figures=False)
        df = res.summary.table.sort_values("run_id").reset_index(drop=True)
        out[loop] = df
        assert (df["status"] == "ok").all()
    a, b = out["python"], out["compiled"]
    cols = [c for c in a.columns if not any(s in c for s in ("_us", "wall", "cpu", "worker", "time_s_"))]
    cols = [c for c in cols if a[c].dtype.kind in "fi"]
    assert cols
    for c in cols:
        np.testing.assert_allclose(a[c].to_numpy(float), b[c].to_numpy(float), rtol=0, atol=1e-9, err_msg=c)
    shutil.rmtree(tmp_path, ignore_errors=True)
