"""The FL's adaptive observer (issue 12): the constants that multiply the currents are learnt from the moves.

The default rig profile draws C1, C3 and C4 off their nominal values; a constant
acceleration disturbance cannot follow an error proportional to the current, so
without adaptation the estimate of a move's thrust mismatch is carried into the
hold and pushes the mover past the target while it decays. The FL shares the
NMPC's adaptive observer (:mod:`maglev_ocp.observers`) and inverts the corrected
constants. Fast: a known thrust error is learnt from a move and the hold after
it is better than the blind FL's; a pull while holding teaches nothing; the
step Function the C backend compiles gives the Python FL's estimate. Slow: the
shipped tours with and without a one-period delay hold 6 um on nine seeds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from maglev_ocp.blocks import Reference
from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.params import NOMINAL
from maglev_ocp.runner import _as_scenario, build_run, run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
#: Relative error of the rig's thrust constant in the fast tests (the default profile draws up to 2 %).
C1_ERR = 0.06


def _scenario(adapt: list[str] | None, move: bool, pull: dict | None = None, seed: int = 3) -> dict:
    """Default rig with a known thrust constant error (no random mismatch): hold, then a 40 mm move."""
    plant = {
        "profile": "default",
        "mismatch": {
            "relative": dict.fromkeys(("C1", "C2", "C3", "C4"), 0.0),
            "overrides": {"C1": (1 + C1_ERR) * NOMINAL.C1},
        },
    }
    if pull:
        plant["disturbances"] = [{"type": "force_pulse", "start": 0.1, "duration": 0.03, **pull}]
    targets = [{"g": 0.020, "d": 0.0, "hold": 0.25}]
    if move:
        targets.append({"g": 0.020, "d": 0.040, "hold": 0.3})
    ctrl = {"type": "fl"} if adapt is None else {"type": "fl", "adapt": adapt}
    return {"name": "fl_adapt", "seed": seed, "controller": ctrl, "plant": plant, "targets": targets}


def _run_with_theta(sc: dict):
    """The run and the FL's adapted constants after every step (rows in the order of ``settings.adapt``)."""
    scn = _as_scenario(sc)
    ctrl, _ = build_run(scn, None, {})
    thetas, step = [], ctrl.step

    def recording(y, ref):
        out = step(y, ref)
        thetas.append(list(ctrl.adapted_constants.values()))
        return out

    ctrl.step = recording
    res = run_scenario(scn, progress=False, controller=ctrl, figures=False)
    return res, np.array(thetas)


def test_default_fl_learns_the_thrust_constant_from_a_move_and_holds_better():
    """+6 % thrust constant: learnt from the 40 mm move (within 1.5 %), nothing learnt before it, and the hold after
    the move is better than the blind FL's (which carries the move's mismatch into the hold)."""
    assert FLSettings().adapt == ["C1", "C3", "C4"]  # on by default
    res, th = _run_with_theta(_scenario(None, move=True))
    k_move = round(res.metrics.targets[1].t_switch / 1e-3)
    assert np.all(th[: k_move - 5] == 0.0)  # the update waits for the reference to move
    assert abs(th[-1][0] - C1_ERR) < 0.015, th[-1]
    # C3 and C4 are exact on this rig but a horizontal move hardly excites them: C3 drifts (measured +10 %
    # with adapt_noise 4 um, +1.2 % with 10 um), bounded by the projection; the gap's hold must not suffer from it
    assert np.all(np.abs(th[-1][1:]) <= FLSettings().adapt_bound + 1e-12), th[-1]
    assert res.metrics.targets[1].rms_error_g_m < 3e-6, res.metrics.targets[1].rms_error_g_m
    blind = run_scenario(_scenario([], move=True), progress=False, figures=False)
    for r in (res, blind):
        assert r.metrics.all_settled and r.metrics.stop_hits == 0
    # the true position 20..80 ms after the planned move: the blind FL's decaying mismatch pushes it past the target
    out = []
    for r in (res, blind):
        c, tm = r.columns, r.metrics.targets[1]
        t_end = tm.t_switch + tm.move_time_s
        sel = (c["t"] >= t_end + 0.02) & (c["t"] < t_end + 0.08)
        out.append(float(np.sqrt(np.mean((c["d_true"][sel] - tm.d) ** 2))))
    assert out[0] < 0.7 * out[1], out


@pytest.mark.parametrize("pull", [{"axis": "g", "amplitude": -60.0}, {"axis": "d", "amplitude": 100.0}])
def test_a_pull_while_holding_teaches_the_constants_nothing(pull):
    """A pull on either axis while holding moves the currents but not the reference: the estimates stay at 0."""
    res, th = _run_with_theta(_scenario(None, move=False, pull=pull))
    assert res.metrics.all_settled
    col = "i_d" if pull["axis"] == "g" else "i_q"
    assert np.max(np.abs(res.columns[col])) > 3.0  # the pull was felt
    assert th.shape[1] == 3 and np.all(th == 0.0)


def test_compiled_step_function_carries_the_adaptation_like_the_python_fl():
    """The step Function the C backend compiles (fl_step, its state holding theta) gives the Python FL's currents,
    estimate and constants to 1e-9 through a ramped move that teaches C1."""
    from maglev_ocp.codegen.fl_fn import fl_functions, fl_state_slices
    from maglev_ocp.plant import Plant, PlantConfig

    s = FLSettings(delay_samples=1)
    py = FeedbackLinearization(s, NOMINAL)
    init, step = (BufferedFunction(f) for f in fl_functions(s))
    sl = fl_state_slices(1, 3)["adapt"]
    cfg = PlantConfig.from_profile("default")
    plant = Plant(cfg, params=NOMINAL.with_(C1=(1 + C1_ERR) * NOMINAL.C1), seed=4)  # plus the profile's draw
    y = plant.reset()
    py.reset(y, Reference(0.02, 0.0))
    (st,) = init(y.y)
    a, T = 20.0, 0.04  # bang-bang 16 mm move over 2 T
    u_sent = [py._sent[0]]
    for i in range(250):
        t = i * 1e-3
        tau = t - 0.05
        acc = a if 0 <= tau < T else (-a if T <= tau < 2 * T else 0.0)
        vel = a * tau if 0 <= tau < T else (a * (2 * T - tau) if T <= tau < 2 * T else 0.0)
        pos = (
            0.0
            if tau < 0
            else 0.5 * a * tau**2
            if tau < T
            else a * T**2 - 0.5 * a * (2 * T - tau) ** 2
            if tau < 2 * T
            else a * T**2
        )
        ref = Reference(g=0.02, d=pos, d_dot=vel, d_ddot=acc)
        out = py.step(y, ref)
        r = [ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot]
        u, st, xh, *_ = step(st, y.y, r, NOMINAL.vector(), s.gains())
        assert np.max(np.abs(u - out.u)) <= 1e-9, i
        assert np.max(np.abs(xh - out.x_hat)) <= 1e-12 + 1e-9, i
        np.testing.assert_allclose(st[sl][:3], list(py.adapted_constants.values()), rtol=0, atol=1e-9)
        u_sent.append(out.u)
        y = plant.step(u_sent[-2])  # one period of delay
    assert abs(py.adapted_constants["C1"] - C1_ERR) < 0.035, py.adapted_constants  # it learnt (profile: +-2 %)


@pytest.mark.long
@pytest.mark.parametrize("name", ["tour_fl_delay1", "tour_fl"])
def test_tours_hold_6um_on_nine_seeds(name):
    """Issue 12: every tour target settles within 0.1 mm with steady RMS <= 6 um in both axes, on the scenario's
    seed and seeds 1-8 of the default rig profile (measured worst 5.25 / 5.95 um g / d with the delay, 4.39 / 5.63
    without; without adaptation 6.98 / 10.04 and 6.18 / 8.36)."""
    worst = np.zeros(2)
    for seed in (None, *range(1, 9)):
        res = run_scenario(SCENARIOS / f"{name}.yaml", seed=seed, progress=False, figures=False)
        m = res.metrics
        assert m.all_settled and m.stop_hits == 0 and m.fallbacks == 0, (seed, m.failed_checks)
        for t in m.targets:
            worst = np.maximum(worst, [t.rms_error_g_m, t.rms_error_d_m])
    assert np.all(worst <= 6e-6), worst


def test_backend_c_fl_learns_what_the_python_fl_learns():
    """``backend: c``: the compiled FL's constants (read from its C state) equal the Python FL's after a move."""
    from maglev_ocp.codegen.build import find_compiler

    if find_compiler() is None:
        pytest.skip("no C compiler")
    got = {}
    for backend in ("python", "c"):
        sc = _scenario(None, move=True)
        sc["controller"]["backend"] = backend
        sc["targets"][0]["hold"] = 0.06
        sc["targets"][1]["hold"] = 0.12
        scn = _as_scenario(sc)
        ctrl, _ = build_run(scn, None, {})
        res = run_scenario(scn, progress=False, controller=ctrl, figures=False)
        got[backend] = (np.array(list(ctrl.adapted_constants.values())), res.columns)
    np.testing.assert_allclose(got["c"][0], got["python"][0], rtol=0, atol=1e-9)
    assert abs(got["c"][0][0] - C1_ERR) < 0.015  # it learnt C1
    for col in ("i_q", "i_d", "d_hat", "dist_d"):
        np.testing.assert_allclose(got["c"][1][col], got["python"][1][col], rtol=0, atol=1e-6, err_msg=col)
