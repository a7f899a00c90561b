"""Loop analysis (``maglev_ocp.analysis``, ``maglev analyze``): margins against hand-computed values,
linearization of controllers and plant, FL's margins, and the delay margin checked by simulation."""

from __future__ import annotations

import json
import math

import casadi as ca
import control
import numpy as np
import pytest
from scipy.optimize import brentq

from maglev_ocp.analysis.controller_map import (
    LinearController,
    linearize_by_differences,
    linearize_function,
    memory_access,
    minimal_part,
    settle,
)
from maglev_ocp.analysis.margins import broken_loop, loop_margins, loop_response
from maglev_ocp.analysis.plant_model import AnalysisPlant, DelayedPlantSim, LinearPlant
from maglev_ocp.analysis.report import analyze_point, delay_cross_check
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.cli import main
from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings

Ts = 1e-3
KP, KD = 1.0e4, 150.0  # PD on a unit double integrator: crossover near 160 rad/s


def _pd_loop() -> tuple[LinearPlant, LinearController]:
    """Two decoupled unit double integrators (ZOH), each under u = -(kp y + kd (y - y_prev) / Ts)."""
    Ap = np.zeros((4, 4))
    Ap[0:2, 0:2] = Ap[2:4, 2:4] = [[1, Ts], [0, 1]]
    Bp = np.zeros((4, 2))
    Bp[0:2, 0] = Bp[2:4, 1] = [Ts**2 / 2, Ts]
    Cp = np.zeros((2, 4))
    Cp[0, 0] = Cp[1, 2] = 1.0
    # memory: the last reading per channel
    ctrl = LinearController(
        A=np.zeros((2, 2)),
        B=np.eye(2),
        C=KD / Ts * np.eye(2),
        D=-(KP + KD / Ts) * np.eye(2),
        m0=np.zeros(2),
        y0=np.zeros(2),
        u0=np.zeros(2),
        residual=0.0,
        method="hand",
    )
    return LinearPlant(Ap, Bp, Cp, Ts), ctrl


def _L_hand(w: np.ndarray) -> np.ndarray:
    """The PD loop written out: P(z) = Ts^2 (z + 1) / (2 (z - 1)^2), K(z) = kp + kd (1 - 1/z) / Ts."""
    z = np.exp(1j * w * Ts)
    return (KP + KD * (1 - 1 / z) / Ts) * Ts**2 * (z + 1) / (2 * (z - 1) ** 2)


def test_margins_of_a_pd_on_a_double_integrator_match_the_hand_computed_ones():
    plant, ctrl = _pd_loop()
    m = loop_margins(broken_loop(plant, ctrl, "input", 0))
    # crossover: |L| = 1; phase crossover: Im L = 0 (between 1000 rad/s and Nyquist)
    wgc = brentq(lambda w: abs(_L_hand(np.array([w]))[0]) - 1, 10, 2000)
    pm = 180 + math.degrees(np.angle(_L_hand(np.array([wgc]))[0]))
    wpc = brentq(lambda w: _L_hand(np.array([w]))[0].imag, 500, 0.9999 * math.pi / Ts)
    gm = 1 / abs(_L_hand(np.array([wpc]))[0])
    w = np.logspace(0, math.log10(0.999 * math.pi / Ts), 20000)
    Lw = _L_hand(w)
    S = 1 / (1 + Lw)
    alpha = 1 / np.max(np.abs(S - 0.5))  # balanced disk margin (Seiler et al. 2020, skew 0)
    assert m.closed_loop_stable
    assert m.w_gc == pytest.approx(wgc, rel=2e-3)
    assert m.pm_deg == pytest.approx(pm, abs=0.1)
    assert m.gm_upper == pytest.approx(gm, rel=5e-3)
    assert m.gm_lower == 0.0  # a double integrator under PD: no lower gain limit
    assert m.delay_margin_s == pytest.approx(math.radians(pm) / wgc, rel=3e-3)
    assert m.disk_alpha == pytest.approx(alpha, rel=5e-3)
    assert 10 ** (m.s_peak_db / 20) == pytest.approx(np.max(np.abs(S)), rel=2e-3)
    assert 10 ** (m.t_peak_db / 20) == pytest.approx(np.max(np.abs(Lw * S)), rel=2e-3)
    # python-control's own disk margin of the same loop (its formulas, its frequency response)
    L = broken_loop(plant, ctrl, "input", 0)
    alpha_pc, dgm_pc, dpm_pc = control.disk_margins(L, w[::20])
    assert m.disk_alpha == pytest.approx(alpha_pc, rel=5e-3)
    assert m.disk_gm_db == pytest.approx(dgm_pc, rel=1e-2)
    assert m.disk_pm_deg == pytest.approx(dpm_pc, rel=1e-2)
    np.testing.assert_allclose(loop_response(L, w[::50]), _L_hand(w[::50]), rtol=1e-8)
    # loop broken at the output of the same SISO channel: the same loop
    mo = loop_margins(broken_loop(plant, ctrl, "output", 1))
    assert mo.pm_deg == pytest.approx(m.pm_deg, abs=1e-6)


def test_a_destabilizing_gain_shows_as_a_negative_margin_and_an_unstable_closed_loop():
    plant, ctrl = _pd_loop()
    ctrl.D = ctrl.D * 60  # 60 x the PD: far beyond the ~30 dB gain margin
    ctrl.C = ctrl.C * 60
    m = loop_margins(broken_loop(plant, ctrl, "input", 0))
    assert not m.closed_loop_stable
    assert m.gm_upper < 1 or m.pm_deg < 0


class _ToyController:
    """A controller the suite does not know: a PD with a filtered derivative, its step a CasADi Function."""

    name = "toy"

    def __init__(self):
        m, y = ca.SX.sym("state", 3), ca.SX.sym("meas", 2)
        yf = 0.7 * m[0:2] + 0.3 * y  # filtered reading
        u = -300 * (y - 0.02) - 5e4 * (yf - m[0:2]) + m[2] * ca.sin(y[0])
        self.step_function = ca.Function(
            "toy_step", [m, y], [u, ca.vertcat(yf, m[2] + 1e-3 * y[1])], ["state", "meas"], ["u", "state_next"]
        )
        self.state = np.array([0.02, 0.001, 0.5])

    def reset(self, y0, ref):
        pass

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        u, st = self.step_function(self.state, y.y)
        self.state = np.asarray(st, dtype=float).ravel()
        return ControlOutput(u=np.asarray(u, dtype=float).ravel())


def test_finite_differences_of_step_match_casadi_jacobians_for_any_controller():
    ctrl = _ToyController()
    y0 = np.array([0.021, 0.002])
    ad = linearize_function(ctrl.step_function, [ctrl.state, y0], memory_in=0, memory_out=1, reading_in=1)
    fd = linearize_by_differences(ctrl, memory_access(ctrl), y0, Reference(0.02, 0.0))
    for a, b in ((ad.A, fd.A), (ad.B, fd.B), (ad.C, fd.C), (ad.D, fd.D)):
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6 * np.max(np.abs(a)))
    np.testing.assert_allclose(ctrl.state, ad.m0)  # the controller's memory is restored


def test_minimal_part_drops_dead_memory_and_keeps_the_transfer_function():
    plant, ctrl = _pd_loop()
    # add an integrator the command never sees (FL's integral state with ki = 0)
    big = LinearController(
        A=np.block([[ctrl.A, np.zeros((2, 1))], [np.zeros((1, 2)), np.ones((1, 1))]]),
        B=np.vstack([ctrl.B, [[Ts, 0.0]]]),
        C=np.hstack([ctrl.C, np.zeros((2, 1))]),
        D=ctrl.D,
        m0=np.zeros(3),
        y0=ctrl.y0,
        u0=ctrl.u0,
        residual=0.0,
        method="hand",
    )
    red = minimal_part(big)
    assert red.A.shape == (2, 2)
    w = np.array([3.0, 100.0, 1000.0])
    for c in (big, red):
        L = broken_loop(plant, c, "input", 0)
        np.testing.assert_allclose(np.ravel(L(np.exp(1j * w * Ts))), _L_hand(w), rtol=1e-9)
    assert not loop_margins(broken_loop(plant, big, "input", 0)).closed_loop_stable  # the dead pole at z = 1
    assert loop_margins(broken_loop(plant, red, "input", 0)).closed_loop_stable


def test_linear_plant_with_delay_predicts_the_simulated_plant():
    plant = AnalysisPlant(lag_hz=2000.0, delay_samples=2)
    xa, u = plant.hover(0.020, 0.01)
    lin = plant.linearize(xa, u)
    sim = DelayedPlantSim(plant)
    sim.reset(xa, u)
    x = np.zeros(lin.A.shape[0])
    rng = np.random.default_rng(1)
    for _ in range(15):
        du = 1e-4 * rng.standard_normal(2)
        y = sim.step(u + du)
        x = lin.A @ x + lin.B @ du
        np.testing.assert_allclose(y - xa[[0, 2]], lin.C @ x, atol=1e-11)
    assert lin.A.shape == (10, 10)


def test_fractional_delay_shifts_the_command_inside_the_period():
    plant = AnalysisPlant(lag_hz=None)
    xa, u = plant.hover(0.020, 0.0)
    step_u = u + np.array([0.0, 0.05])
    ys = []
    for tau in (0.0, 0.5, 1.0):
        sim = DelayedPlantSim(plant, (0.0, tau))
        sim.reset(xa, u)
        ys.append([sim.step(step_u)[0] for _ in range(3)])
    ys = np.array(ys) - xa[0]
    assert ys[2, 0] == pytest.approx(0.0, abs=1e-15)  # one whole sample: nothing in the first period
    assert 0 < abs(ys[1, 0]) < abs(ys[0, 0])  # half a sample: part of the first period
    np.testing.assert_allclose(ys[2, 1], ys[0, 0], rtol=1e-9)  # a whole sample is a shift


@pytest.fixture(scope="module")
def fl_point():
    plant = AnalysisPlant(lag_hz=2000.0, delay_samples=0)
    return plant, analyze_point(FeedbackLinearization, plant, 0.020, 0.0)


def test_fl_margins_at_20_mm(fl_point):
    _, pr = fl_point
    assert pr.closed_loop_radius < 1
    assert pr.residual < 1e-12  # the settled memory is a fixed point
    for lr in pr.loops:
        m = lr.margins
        assert m.closed_loop_stable
        # measured: GM+ ~ 3.6 (11 dB), PM ~ 36 deg, crossover ~ 295 rad/s, DM ~ 2.1 ms (default gains 120 rad/s)
        assert m.gm_upper > 2.5
        assert 25 < m.pm_deg < 50
        assert 200 < m.w_gc < 400
        assert 1.5e-3 < m.delay_margin_s < 3e-3
        assert m.s_peak_db < 7
    g_loop = next(lr for lr in pr.loops if lr.axis == "g" and lr.at == "input")
    assert 0 < g_loop.margins.gm_lower < 0.5  # open-loop unstable gap: a lower gain limit exists


def test_fl_margins_shrink_with_a_computation_delay_it_does_not_compensate():
    plant = AnalysisPlant(lag_hz=2000.0, delay_samples=1)
    pr = analyze_point(lambda: FeedbackLinearization(FLSettings(delay_samples=0)), plant, 0.020, 0.0)
    pr_pred = analyze_point(lambda: FeedbackLinearization(FLSettings(delay_samples=1)), plant, 0.020, 0.0)
    for axis in ("g", "d"):
        blind = next(lr.margins for lr in pr.loops if lr.axis == axis and lr.at == "input")
        pred = next(lr.margins for lr in pr_pred.loops if lr.axis == axis and lr.at == "input")
        assert blind.pm_deg < 25  # ~36 deg without the delay
        assert pred.pm_deg > blind.pm_deg + 5  # the predictor gives phase back


def test_simulated_delay_margin_agrees_with_the_computed_one(fl_point):
    plant, pr = fl_point
    check = delay_cross_check(FeedbackLinearization, plant, pr, "g")
    assert check.simulated.stable_below < check.simulated.unstable_above
    assert check.rel_error < 0.2  # measured: 0.5 %
    assert check.rel_error < 0.05


@pytest.mark.slow
def test_simulated_delay_margin_with_a_computation_delay_and_predictor():
    plant = AnalysisPlant(lag_hz=2000.0, delay_samples=1)

    def make():
        return FeedbackLinearization(FLSettings(delay_samples=1))

    pr = analyze_point(make, plant, 0.015, 0.04)
    for axis in ("g", "d"):
        assert delay_cross_check(make, plant, pr, axis).rel_error < 0.2


def test_settle_leaves_the_controller_at_the_hover_point():
    plant = AnalysisPlant()
    ctrl = FeedbackLinearization()
    xa, _y, u = settle(ctrl, plant, 0.025, -0.04)
    np.testing.assert_allclose(xa[[0, 2]], [0.025, -0.04], atol=1e-9)
    np.testing.assert_allclose(u, plant.hover(0.025, -0.04)[1], atol=1e-6)


def test_cli_analyze_writes_tables_and_figures(tmp_path, capsys):
    out = tmp_path / "an"
    code = main(["analyze", "--gaps", "20", "--positions", "0", "--check-delay", "none", "--out", str(out), "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    rows = doc["margins"]
    assert {(r["axis"], r["at"]) for r in rows} == {("g", "input"), ("g", "output"), ("d", "input"), ("d", "output")}
    assert all(r["stable"] for r in rows)
    for name in ("margins.md", "margins.csv", "margins.json", "bode_fl.png", "nyquist_fl.png", "sensitivity_fl.png"):
        assert (out / name).stat().st_size > 0


def test_cli_analyze_refuses_points_outside_the_stops(capsys):
    code = main(["analyze", "--gaps", "40", "--check-delay", "none"])
    assert code == 2
    assert "--gaps" in capsys.readouterr().err


@pytest.mark.slow
def test_nmpc_margins_and_delay_margin_at_20_mm():
    from maglev_ocp.controllers.nmpc import NMPC

    plant = AnalysisPlant(lag_hz=2000.0, delay_samples=0)
    pr = analyze_point(NMPC, plant, 0.020, 0.0)
    assert pr.method == "fd"  # through its public step, memory = its state vector
    assert pr.closed_loop_radius < 1
    for lr in pr.loops:
        # measured: GM+ ~ 3.1-3.2, PM ~ 27-28 deg, DM ~ 1.8-2.1 samples
        assert lr.margins.closed_loop_stable
        assert lr.margins.gm_upper > 2
        assert 20 < lr.margins.pm_deg < 45
    check = delay_cross_check(NMPC, plant, pr, "d")
    assert check.rel_error < 0.2  # measured: 0.5 %


def test_cli_analyze_takes_controller_and_delay_from_a_scenario(capsys):
    args = ["--scenario", "scenarios/tour_fl_delay1.yaml", "--gaps", "20", "--positions", "0", "--check-delay", "none"]
    code = main(["analyze", *args, "--json"])
    assert code == 0
    rows = json.loads(capsys.readouterr().out)["margins"]
    assert {r["controller"] for r in rows} == {"fl"}
    # the rig's one-period delay is in the loop and the FL predictor compensates it: margins near the delay-free ones
    assert all(r["stable"] and r["pm_deg"] > 25 for r in rows)


@pytest.mark.slow
def test_nmpc_finite_differences_agree_with_automatic_differentiation_of_its_step():
    from maglev_ocp.analysis.controller_map import StepRecorder, linearize_controller, linearize_recorded
    from maglev_ocp.analysis.margins import closed_loop_matrix
    from maglev_ocp.controllers.nmpc import NMPC
    from maglev_ocp.controllers.nmpc.controller import casadi_evaluators

    plant = AnalysisPlant()
    rec = StepRecorder(casadi_evaluators)
    ctrl = NMPC(evaluators=rec)
    xa, y, u = settle(ctrl, plant, 0.020, 0.01)
    fd = minimal_part(linearize_controller(ctrl, y, Reference(0.020, 0.01)))
    ad = minimal_part(linearize_recorded(ctrl, rec, y))
    # rounding in the differences can keep a few more (decoupled) entries than the exact zeros of AD
    assert ad.A.shape[0] <= fd.A.shape[0]
    lp = plant.linearize(xa, u)
    r_fd = np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(lp, fd))))
    r_ad = np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(lp, ad))))
    assert r_fd == pytest.approx(r_ad, abs=1e-4)
    for at, ch in (("input", 0), ("input", 1), ("output", 0)):
        m_fd = loop_margins(broken_loop(lp, fd, at, ch))
        m_ad = loop_margins(broken_loop(lp, ad, at, ch))
        assert m_fd.pm_deg == pytest.approx(m_ad.pm_deg, abs=0.05)
        assert m_fd.gm_upper == pytest.approx(m_ad.gm_upper, rel=1e-3)
