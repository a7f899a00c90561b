"""The NMPC through a computation delay (``delay_samples``) and its operating-point LQR pieces (issue 12).

Fast: the state carries the commands in flight and shifts them; the delay-aware
NMPC holds a delayed plant better than the delay-blind one; the fallback gain is
designed on the controller's parameters over a grid of gaps. Slow: the shipped
one-period-delay tour settles every target with steady RMS <= 6 um.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from maglev_ocp.blocks import Measurement, Reference
from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings, StepBuilder
from maglev_ocp.controllers.nmpc.design import LQR_GAP_GRID, fn_terminal_weight, lqr_design, make_design, scheduled_gain
from maglev_ocp.params import NOMINAL
from maglev_ocp.runner import run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def test_state_carries_and_shifts_the_commands_in_flight():
    ctrl = NMPC(NMPCSettings(delay_samples=2), NOMINAL)
    ref = Reference(0.020, 0.0)
    ctrl.reset(Measurement(0.0, np.array([0.020, 0.0])), ref)
    sl = ctrl.layout.slices()
    assert sl["u_flight"].stop - sl["u_flight"].start == 4
    sent = []
    for j in range(4):
        before = ctrl.state.copy()
        out = ctrl.step(Measurement((j + 1) * 1e-3, np.array([0.020, 0.0])), ref)
        sent.append(out.u.copy())
        # the oldest command in flight is the one applied over the coming period; the new one joins the queue
        np.testing.assert_allclose(ctrl.state[sl["u_prev"]], before[sl["u_flight"]][:2])
        np.testing.assert_allclose(ctrl.state[sl["u_flight"]][2:], out.u)
    np.testing.assert_allclose(ctrl.state[sl["u_prev"]], sent[1])


def test_no_delay_keeps_the_layout():
    assert "u_flight" not in NMPC(NMPCSettings(), NOMINAL).prepare("plan").layout.slices()


def _hold_scenario(delay_model: int) -> dict:
    return {
        "name": f"delay_hold_{delay_model}",
        "seed": 5,
        "controller": {"type": "nmpc", "delay_samples": delay_model, "reference": "preview"},
        "plant": {"profile": "default", "delay_samples": 2},
        "start": {"g": 0.020, "d": 0.0},
        "targets": [{"g": 0.020, "d": 0.0, "hold": 0.15}, {"g": 0.019, "d": 0.005, "hold": 0.25}],
    }


def test_delay_aware_nmpc_beats_the_blind_one_on_a_delayed_plant():
    """Two periods of computation delay: predicting through them lowers the tracking error."""
    rms = {}
    for n in (0, 2):
        res = run_scenario(_hold_scenario(n), progress=False)
        e = np.hypot(res.columns["g_true"] - res.columns["g_ref"], res.columns["d_true"] - res.columns["d_ref"])
        rms[n] = float(np.sqrt(np.mean(e**2)))
        assert res.metrics.stop_hits == 0
    assert rms[2] < 0.7 * rms[0], rms


def test_fallback_gain_follows_the_gap_and_the_parameters():
    s = NMPCSettings()
    d_nom = make_design(s, "plan", NOMINAL)
    strong = NOMINAL.scaled({"C3": 1.3, "C4": 1.3})
    d_own = make_design(s, "plan", strong)
    assert d_nom.K_grid is not None and d_nom.K_grid.shape == (len(LQR_GAP_GRID), 2, 4)
    # the gain changes over the gap range and with the controller's parameters
    assert not np.allclose(d_nom.K_grid[0], d_nom.K_grid[-1], rtol=0.05)
    assert not np.allclose(d_nom.P, d_own.P, rtol=1e-3)
    g = ca.SX.sym("g")
    fK = ca.Function("K", [g], [scheduled_gain(d_nom.K_grid, g)])
    np.testing.assert_allclose(np.asarray(fK(LQR_GAP_GRID[3])), d_nom.K_grid[3], rtol=1e-12, atol=1e-12)
    mid = 0.5 * (LQR_GAP_GRID[3] + LQR_GAP_GRID[4])
    np.testing.assert_allclose(np.asarray(fK(mid)), 0.5 * (d_nom.K_grid[3] + d_nom.K_grid[4]), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(fK(1.0)), d_nom.K_grid[-1])  # clamped beyond the grid
    # switched off: the nominal 20 mm design as before
    assert make_design(NMPCSettings(lqr_schedule=False), "plan", strong).K_grid is None


def test_terminal_weight_follows_the_gap_and_the_parameters():
    """The QP's terminal weight is the DARE solution at the terminal stage's reference gap, on the own parameters."""
    s = NMPCSettings(weights={"terminal_scale": 2.0})
    strong = NOMINAL.scaled({"C3": 1.3, "C4": 1.3})
    fP = {n: fn_terminal_weight(make_design(s, "plan", prm)) for n, prm in (("nom", NOMINAL), ("strong", strong))}
    for prm, f in ((NOMINAL, fP["nom"]), (strong, fP["strong"])):
        for g in (LQR_GAP_GRID[1], LQR_GAP_GRID[6]):
            np.testing.assert_allclose(np.asarray(f(g)), 2.0 * lqr_design(s, prm, g0=g)[0], rtol=1e-9)
    lo, hi = (np.asarray(fP["nom"](g)) for g in (0.015, 0.025))
    assert np.linalg.norm(lo - hi) > 0.05 * np.linalg.norm(hi)  # it changes over the gap range ...
    assert np.linalg.norm(np.asarray(fP["strong"](0.02)) - np.asarray(fP["nom"](0.02))) > 1e-3 * np.linalg.norm(hi)
    mid = 0.5 * (LQR_GAP_GRID[2] + LQR_GAP_GRID[3])
    blend = 0.5 * (np.asarray(fP["nom"](LQR_GAP_GRID[2])) + np.asarray(fP["nom"](LQR_GAP_GRID[3])))
    np.testing.assert_allclose(np.asarray(fP["nom"](mid)), blend, rtol=1e-9)
    # switched off: the constant 20 mm design
    off = make_design(NMPCSettings(lqr_schedule=False), "plan", strong)
    np.testing.assert_array_equal(np.asarray(fn_terminal_weight(off)(0.015)), off.P)


def test_riccati_and_dense_steps_share_the_scheduled_terminal_weight():
    """A horizon ending at 16 mm: both x-updates use the P designed there (same step); the 20 mm P differs."""
    p = NOMINAL.vector()
    ref = np.zeros((6, 21))
    ref[0], ref[3] = np.linspace(0.0195, 0.016, 21), 0.0
    outs = {}
    for name, kw in (("dense", {"qp": "dense"}), ("riccati", {}), ("fixed", {"lqr_schedule": False})):
        b = StepBuilder(NMPCSettings(reference="preview", **kw), "preview", NOMINAL)
        init, step = b.build_init(), b.build_step()
        s0 = np.asarray(init([0.0195, 0.0, 0], ref, p)).ravel()
        s0[b.layout.slices()["xhat"]] = [0.0196, 0.02, 0.0005, 0.05]
        outs[name] = np.asarray(step(s0, [0.0195, 0.0, 0], ref, p)[0]).ravel()
    np.testing.assert_allclose(outs["riccati"], outs["dense"], atol=1e-10)
    assert np.max(np.abs(outs["riccati"] - outs["fixed"])) > 1e-3  # A (measured: 30 mA)


def _thrust_scenario(adapt: list[str], move: bool, push: bool = False) -> dict:
    """Default rig with a known +4 % thrust constant (no random mismatch): hold, then a 40 mm move."""
    over = {"C1": 1.04 * NOMINAL.C1}
    plant = {
        "profile": "default",
        "mismatch": {"relative": dict.fromkeys(("C1", "C2", "C3", "C4"), 0.0), "overrides": over},
    }
    if push:
        plant["disturbances"] = [
            {"type": "force_pulse", "axis": "g", "amplitude": -60.0, "start": 0.1, "duration": 0.02}
        ]
    targets = [{"g": 0.020, "d": 0.0, "hold": 0.25}]
    if move:
        targets.append({"g": 0.020, "d": 0.040, "hold": 0.3})
    return {
        "name": "thrust_adapt",
        "seed": 3,
        "controller": {"type": "nmpc", "adapt": adapt},
        "plant": plant,
        "start": {"g": 0.020, "d": 0.0},
        "targets": targets,
    }


def _run_with_theta(sc: dict) -> tuple[object, np.ndarray]:
    from maglev_ocp.runner import _as_scenario, build_run

    scn = _as_scenario(sc)
    ctrl, _ = build_run(scn, None, {})
    thetas = []
    step = ctrl.step

    def recording(y, ref):
        out = step(y, ref)
        thetas.append(ctrl.state[ctrl.layout.slices()["theta"]].copy())
        return out

    ctrl.step = recording
    res = run_scenario(scn, progress=False, controller=ctrl, figures=False)
    return res, np.array(thetas)


def test_adaptive_observer_learns_the_thrust_constant_from_a_move():
    """A +4 % thrust constant: the move's currents reveal it (estimate within 1 %), and with it the disturbance
    estimate no longer carries the move's mismatch into the hold (smaller steady error after the move)."""
    res, th = _run_with_theta(_thrust_scenario(["C1", "C3", "C4"], move=True))
    t_move = res.metrics.targets[1].t_switch
    k = round(t_move / 1e-3)
    assert np.all(th[: k - 25] == 0.0)  # nothing learnt while holding (the update waits for a move)
    assert abs(th[-1][0] - 0.04) < 0.01, th[-1]
    blind = run_scenario(_thrust_scenario([], move=True), progress=False, figures=False)
    for r in (res, blind):
        assert r.metrics.all_settled and r.metrics.stop_hits == 0
    e_ad, e_bl = res.metrics.targets[1].rms_error_d_m, blind.metrics.targets[1].rms_error_d_m
    assert e_ad < 0.8 * e_bl, (e_ad, e_bl)


def _attraction_scenario(adapt_noise: float | None) -> dict:
    """Default rig with a known -8 % attraction constant C4 (no random mismatch): hold, then a 40 mm move at 15 mm."""
    plant = {
        "profile": "default",
        "mismatch": {"relative": dict.fromkeys(("C1", "C2", "C3", "C4"), 0.0), "overrides": {"C4": 0.92 * NOMINAL.C4}},
    }
    return {
        "name": "attraction_adapt",
        "seed": 5,
        "controller": {"type": "nmpc", "adapt": ["C1", "C4"], "adapt_noise": adapt_noise},
        "plant": plant,
        "start": {"g": 0.015, "d": 0.0},
        "targets": [{"g": 0.015, "d": 0.0, "hold": 0.25}, {"g": 0.015, "d": 0.040, "hold": 0.15}],
    }


def test_measured_innovation_noise_learns_the_attraction_constant_from_one_move():
    """C4 -8 %: the move's i_q^2 pulls the gap (eq. (2)); weighed against the measured innovation noise (the
    encoders' ~3 um) one move reveals it (within 2 %); the former fixed 10 um kept it under half its error."""
    c4 = 1  # adapt: [C1, C4] (C3's i_d and C4's i_d^2 terms are alike over one move at a constant gap)
    res, th = _run_with_theta(_attraction_scenario(None))
    assert res.metrics.all_settled
    assert abs(th[-1][c4] + 0.08) < 0.02, th[-1]
    _, th_fixed = _run_with_theta(_attraction_scenario(1e-5))
    assert abs(th_fixed[-1][c4]) < 0.04, th_fixed[-1]


def test_push_while_holding_teaches_the_constants_nothing():
    """A 60 N pull on the gap moves the currents but not the reference: the constants stay exactly where they were."""
    res, th = _run_with_theta(_thrust_scenario(["C1", "C3", "C4"], move=False, push=True))
    assert res.metrics.all_settled
    assert np.max(np.abs(res.columns["i_d"])) > 3.0  # the pull was felt
    assert np.all(th == 0.0)


def test_adapted_step_compiled_equals_python():
    """The adaptive observer's pieces go through the generated C: the compiled step equals the Python step."""
    from maglev_ocp.codegen.build import find_compiler

    if find_compiler() is None:
        pytest.skip("no C compiler")
    logs = {}
    for backend in ("python", "c"):
        sc = _thrust_scenario(["C1", "C3", "C4"], move=True)
        sc["controller"]["backend"] = backend
        sc["targets"][0]["hold"] = 0.06
        sc["targets"][1]["hold"] = 0.1
        logs[backend] = run_scenario(sc, progress=False, figures=False).columns
    for col in ("i_q", "i_d", "d_hat", "dist_d"):
        np.testing.assert_allclose(logs["c"][col], logs["python"][col], rtol=0, atol=1e-6, err_msg=col)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [None, 3, 8])
def test_one_period_delay_tour_holds_6um(seed):
    """Issue 12: with a one-period delay, every tour target settles and its steady RMS is <= 6 um.

    On the scenario's seed and two other plant draws (3: the worst gap RMS before the fix below, 8:
    the worst after it). Three causes of the steady RMS were found, none the delay's:

    1. after a move the constant-acceleration disturbance estimate held the move's thrust-gain mismatch
       (C1 off by up to 2 % on the default rig: ~1 m/s^2 at the move's 50 m/s^2) and pushed the mover
       ~30 um past the target while it decayed. The observer estimates the relative errors of C1, C3
       and C4 (``NMPCSettings.adapt``, recursive least squares on the move's currents);
    2. the least squares assumed a 10 um innovation noise, three times the default rig's (quantization
       and encoder noise: 3.3 um); the weakly excited C4 (+-10 % on the rig) was then held at a
       fraction of its error by the prior (-3.9 % for -9.2 % on seed 7), and the 15 -> 25 mm gap move,
       whose braking runs on the current disk, overshot its end by ~50 um (steady g 6.0 um on seed 7,
       6.1 on seed 3). The noise is now measured online at rest (``adapt_noise: None``): C4 within
       ~1 % of the rig's after the first d move, that target's g 6.0 -> 4.2 um, seeds 1-8 worst
       g 6.1 -> 4.7 um, d 5.8 -> 5.9 um;
    3. the feed-forward takes the plan's acceleration at each node, half a period late for a
       zero-order-held current (``feedforward: period_mean`` is the option that removes it).
    """
    res = run_scenario(SCENARIOS / "tour_nmpc_delay1.yaml", seed=seed, progress=False, figures=False)
    m = res.metrics
    assert m.all_settled and m.stop_hits == 0 and m.fallbacks == 0
    for tg in m.targets:
        assert tg.rms_error_g_m <= 6e-6 and tg.rms_error_d_m <= 6e-6, tg
