"""The diagnosis's closed-loop views on the compiled loop (issue 29, item 4): same trajectories as the Python loop.

:func:`maglev_ocp.codegen.loop_c.run_scenario_on` runs a scenario on the
compiled loop wherever it can; the closed-loop consequence of a fitted effect
(:func:`maglev_ocp.diagnosis.consequence.closed_loop_consequence`) and the
closed-loop view from a report step their runs through it. The Python loop
(:func:`maglev_ocp.runner.run_scenario`, the blocks' ``reset``/``step``) is the
independent truth: the consequence scenario on a plant with effects the
controller does not know (friction, cogging, mismatched constants) must give
the same true trajectories, currents and readings on both.
"""

from __future__ import annotations

import numpy as np
import pytest

import maglev_ocp.codegen.loop_c as loop_c
from maglev_ocp.codegen.build import find_compiler
from maglev_ocp.codegen.loop_c import run_scenario_on
from maglev_ocp.diagnosis.consequence import closed_loop_consequence, consequence_scenario
from maglev_ocp.errors import UserError
from maglev_ocp.params import NOMINAL
from maglev_ocp.runner import run_scenario

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler: the compiled loop cannot be built here")

#: Largest difference of the two loops' true positions [m] and currents [A] (float round-off of the same maths).
TOL = 1e-9

EFFECTS_ON = {
    "friction": {"enabled": True, "coulomb_g": 0.2, "coulomb_d": 0.1},
    "cogging": {"enabled": True},
}


def _params() -> dict:
    p = NOMINAL.as_dict()
    return {**p, "C1": 1.05 * p["C1"], "C2": 0.97 * p["C2"]}  # the plant's constants 3-5 % off the nominal ones


class _Counter:
    """Wraps ``run_scenario_compiled`` to count its calls."""

    def __init__(self, fn):
        self.fn, self.calls = fn, 0

    def __call__(self, *a, **kw):
        self.calls += 1
        return self.fn(*a, **kw)


@needs_cc
@pytest.mark.parametrize("ctrl", ["fl", "nmpc"])
def test_consequence_scenario_is_the_same_on_the_compiled_and_python_loops(ctrl, monkeypatch):
    """Consequence scenario with friction, cogging and wrong constants: compiled (auto) == Python to 1e-9."""
    sc = consequence_scenario(ctrl, _params(), EFFECTS_ON, seed=5, controller_params=NOMINAL.as_dict())
    count = _Counter(loop_c.run_scenario_compiled)
    monkeypatch.setattr(loop_c, "run_scenario_compiled", count)
    cc = run_scenario_on(sc)  # auto
    assert count.calls == 1  # auto chose the compiled loop for this plant and controller
    py = run_scenario(sc, progress=False, figures=False)
    assert len(py.columns["t"]) == len(cc.columns["t"]) > 100
    for c in ("g_true", "d_true", "i_q", "i_d"):
        diff = np.max(np.abs(np.asarray(py.columns[c], float) - np.asarray(cc.columns[c], float)))
        assert diff <= TOL, (c, diff)
    # the quantized readings are identical (no encoder count flipped), the targets settle alike
    assert np.array_equal(py.columns["g"], cc.columns["g"]) and np.array_equal(py.columns["d"], cc.columns["d"])
    assert [t.settled for t in py.metrics.targets] == [t.settled for t in cc.metrics.targets]
    # the run moved: the effects and the constants' error leave a tracking error above the encoders' 1 um
    e = np.hypot(py.columns["g_true"] - py.columns["g_ref"], py.columns["d_true"] - py.columns["d_ref"])
    assert np.max(e) > 1e-6


@needs_cc
def test_closed_loop_consequence_runs_on_the_compiled_loop(monkeypatch):
    """The diagnosis's consequence view steps both of its runs per controller through the compiled loop."""
    count = _Counter(loop_c.run_scenario_compiled)
    monkeypatch.setattr(loop_c, "run_scenario_compiled", count)
    out = closed_loop_consequence(_params(), EFFECTS_ON, NOMINAL.as_dict(), controllers=("fl",))
    assert count.calls == 2
    assert out["fl"]["diff_max_m"] > 0.0  # friction and cogging move the trajectory


def test_loop_choice_is_validated():
    """An unknown loop name is refused in one line."""
    with pytest.raises(UserError, match="not one of auto, compiled, python"):
        run_scenario_on({}, loop="fast")


#: One short hold (the scenarios below are only checked, not run).
HOLD = [{"g": 0.02, "d": 0.0, "hold": 0.1}]


def test_auto_says_why_it_runs_the_python_loop(caplog, monkeypatch):
    """What the C path cannot run is refused with its reason, and ``loop: auto`` logs it (as ``rig_loop``)."""
    import maglev_ocp.runner as runner
    from maglev_ocp.codegen.loop_c import compiled_supported, compiled_unsupported
    from maglev_ocp.scenario import scenario_from_dict

    d = {"name": "osqp", "controller": {"type": "nmpc", "solver": "osqp"}, "targets": HOLD}
    sc = scenario_from_dict(d)
    reason = compiled_unsupported(sc)
    assert not compiled_supported(sc) and "solver: osqp" in reason
    with pytest.raises(UserError, match="solver: osqp"):
        run_scenario_on(sc, loop="compiled")
    ran = []
    monkeypatch.setattr(runner, "run_scenario", lambda sc, **kw: ran.append(sc.name) or "python loop")
    with caplog.at_level("INFO", logger="maglev_ocp.codegen.loop_c"):
        assert run_scenario_on(sc) == "python loop"
    assert ran == ["osqp"]
    assert any("auto runs the Python closed loop" in r.message and "solver: osqp" in r.message for r in caplog.records)


def test_model_file_controllers_are_compiled_under_auto(tmp_path, monkeypatch):
    """FL, PID and NMPC with a model file (effects and a lag's delay) have no reason against the compiled loop."""
    from maglev_ocp.codegen.loop_c import compiled_unsupported
    from maglev_ocp.output import dump_yaml
    from maglev_ocp.scenario import scenario_from_dict

    f = tmp_path / "model.yaml"
    dump_yaml(f, {"effects": {"friction": {"enabled": True, "coulomb_d": 0.3}, "amplifier_lag": {
        "enabled": True, "bandwidth_hz": 800.0, "delay_samples": 1}}})  # fmt: skip
    for ctype in ("fl", "pid", "nmpc"):
        d = {"name": ctype, "controller": {"type": ctype, "model": str(f)}, "targets": HOLD}
        assert compiled_unsupported(scenario_from_dict(d)) is None, ctype
