"""The fifth law set of the independent rig (maglev_ocp.rigsim.laws_v5, ``laws="v5"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (the rig's seed eq. (2) through ``physics.accelerations``, MODEL.md's field through
``physics.shape``, quadrature, an ODE solver, an energy minimized on a grid, the exact delay loop), tolerances fixed
beforehand; the v5 draw is seeded, covers every family, stays finite and bounded over the rig's envelope; datasets
generated from the law sets before it are the same bytes as at commit 0cfa3b3 (before this set; the earlier sets'
draws: test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets, dataset_hash
from scipy import integrate, signal, special

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws_v5 import V5_LAWS, make_law
from maglev_ocp.rigsim.physics import NOMINAL, accelerations, equilibrium_current, shape

G_LO, G_HI = k.g_stop
LAM = 2 * k.t1
KP = math.pi / k.tau
L = k.pm * k.tau


def _B(g):
    """MODEL.md's field of the array at the stator surface (the rig's physics module)."""
    return float(shape(np.array([g])).B[0])


def _pull(g, i_q=0.0, i_d=0.0):
    """Magnetic pull [N] of seed eq. (2), nominal constants, from the rig's accelerations."""
    return NOMINAL.Mv * (k.G - float(accelerations(g, 0.0, i_q, i_d, NOMINAL, with_cogging=False)[0]))


def _fields(g):
    """``(kd, kq)``: d- and q-axis field per ampere relative to the magnets', from the pull's dependence on i."""
    p0 = _pull(g)
    h = 1e-4
    kd = -(_pull(g, 0.0, h) - _pull(g, 0.0, -h)) / (2 * h) / (2 * p0)
    kq = math.sqrt((_pull(g, 1.0, 0.0) - p0) / p0)
    return kd, kq


# ----------------------------------------------------------------------------- cogging
def test_on_load_cogging_follows_the_net_field():
    law = make_law("cogging", {"family": "on_load", "xi_h": 2.5, "c1": 1.0, "c2": 0.0, "c3": 0.0})
    d = np.linspace(-0.05, 0.05, 41)
    # at a hover the pull is the weight at every gap: the tangential peak is xi_h whatever the gap (Azar et al.)
    for g in (0.012, 0.018, 0.025):
        i0 = float(equilibrium_current(g))
        _, fd = law.force_i(0 * d + g, 0, d, 0, 0 * d, 0 * d + i0)
        assert fd == pytest.approx(2.5 * np.sin(2 * math.pi * d / LAM), abs=1e-9)
    # without current it is the magnets' own cogging, scaled by their pull; a q current shifts the wave
    g, iq, idd = 0.016, 3.0, 1.0
    _, fd = law.force_i(0 * d + g, 0, d, 0, 0 * d, 0 * d)
    assert fd == pytest.approx(2.5 * _pull(g) / (NOMINAL.Mv * k.G) * np.sin(2 * math.pi * d / LAM), rel=1e-9)
    kd, kq = _fields(g)
    shift = math.atan2(kq * iq, 1 - kd * idd) * k.tau / math.pi
    want = 2.5 * _pull(g, iq, idd) / (NOMINAL.Mv * k.G) * np.sin(2 * math.pi * (d - shift) / LAM)
    assert law.force_i(0 * d + g, 0, d, 0, 0 * d + iq, 0 * d + idd)[1] == pytest.approx(want, rel=1e-6, abs=1e-9)


def test_on_load_cogging_is_conservative_at_frozen_currents():
    law = make_law("cogging", {"family": "on_load", "xi_h": 3.0, "c2": 0.5, "c3": -0.3, "phi2": 0.4})
    g = np.linspace(0.011, 0.026, 6)[:, None] + 0 * np.linspace(-0.05, 0.05, 9)[None, :]
    d = 0 * g + np.linspace(-0.05, 0.05, 9)[None, :]
    h, i_d = 1e-7, 0 * g + 2.0

    def f(gg, dd):
        return law.force_i(gg, 0, dd, 0, 0 * gg, i_d)

    dfd_dg = (f(g + h, d)[1] - f(g - h, d)[1]) / (2 * h)
    dfg_dd = (f(g, d + h)[0] - f(g, d - h)[0]) / (2 * h)
    assert np.max(np.abs(dfd_dg)) > 10.0
    assert np.max(np.abs(dfd_dg - dfg_dd)) < 1e-4 * np.max(np.abs(dfd_dg))


def test_ideal_cells_give_the_periodic_law_and_a_cell_acts_only_under_the_array():
    spec = {"family": "cell_tolerance", "xi0": 3.0, "ell": 4e-3, "c1": 1.0, "c2": 0.0, "c3": 0.0}
    ideal = make_law("cogging", spec)
    d = np.linspace(-0.06, 0.06, 121)
    g = 0.015
    fg, fd = ideal.force(0 * d + g, 0, d, 0)
    A = 3.0 * math.exp(-(g - k.g_cog_ref) / 4e-3)  # seed eq. (9)'s decay
    assert fd == pytest.approx(A * np.sin(2 * math.pi * d / LAM), abs=1e-9)
    # conservative: F_g = -dW/dg = (lambda / 2 pi) A cos(...) / ell for the single harmonic
    assert fg == pytest.approx(LAM / (2 * math.pi) * A * np.cos(2 * math.pi * d / LAM) / 4e-3, abs=1e-9)
    # cell i = 6 (at 6 lambda = 229 mm) is under the array only for d > 95 mm: nothing in the stroke;
    # cell i = 5 (190 mm) enters at d = 57 mm
    far = make_law("cogging", {**spec, "eps12": 0.3, "dx12": 5e-4})
    assert far.force(0 * d + g, 0, d, 0)[1] == pytest.approx(fd, abs=1e-12)
    near = make_law("cogging", {**spec, "eps11": 0.3})
    diff = near.force(0 * d + g, 0, d, 0)[1] - fd
    assert np.max(np.abs(diff[d < 0.056])) < 1e-12 and np.max(np.abs(diff[d > 0.058])) > 1e-3


def test_imperfect_cells_stay_conservative_and_break_the_period():
    spec = {"family": "cell_tolerance", "xi0": 3.0, "c2": 0.4, "phi2": 1.0}
    spec.update({f"eps{j}": 0.2 * math.sin(1.7 * j) for j in range(13)})
    spec.update({f"dx{j}": 8e-4 * math.cos(2.3 * j) for j in range(13)})
    law = make_law("cogging", spec)
    g = np.linspace(0.011, 0.026, 5)[:, None] + 0 * np.linspace(-0.05, 0.05, 13)[None, :]
    d = 0 * g + np.linspace(-0.05, 0.05, 13)[None, :]
    h = 1e-7
    dfd_dg = (law.force(g + h, 0, d, 0)[1] - law.force(g - h, 0, d, 0)[1]) / (2 * h)
    dfg_dd = (law.force(g, 0, d + h, 0)[0] - law.force(g, 0, d - h, 0)[0]) / (2 * h)
    assert np.max(np.abs(dfd_dg - dfg_dd)) < 1e-4 * np.max(np.abs(dfd_dg))
    x = np.linspace(-0.04, 0.0, 50)
    f0 = law.force(0 * x + 0.015, 0, x, 0)[1]
    f1 = law.force(0 * x + 0.015, 0, x + LAM, 0)[1]
    assert np.max(np.abs(f1 - f0)) > 0.02 * np.max(np.abs(f0))  # not periodic along the stroke any more


# ---------------------------------------------------------------------------- friction
def test_palmgren_load_and_speed_laws():
    p = {"family": "palmgren", "Fc_g": 0.1, "Fc_d": 0.2, "mu": 0.006, "cv_g": 0.3, "cv_d": 0.4, "v_reg": 1e-5}
    law = make_law("friction", p)
    g, v, iq = 0.017, 0.2, 3.0
    thrust = NOMINAL.Mh * abs(float(accelerations(g, 0.0, iq, 0.0, NOMINAL, with_cogging=False)[1]))
    fg, fd = law.force_i(np.array([g]), np.array([v]), 0.0, np.array([v]), np.array([iq]), np.array([1.0]))
    assert fg[0] == pytest.approx(-(0.1 + 0.006 * thrust + 0.3 * v ** (2 / 3)), rel=1e-9)  # Palmgren: f1 P + M0
    assert fd[0] == pytest.approx(-(0.2 + 0.4 * v ** (2 / 3)), rel=1e-9)  # the horizontal guide: preload only
    # the lubricant part grows as v^(2/3): 8 times the speed, 4 times the drag
    lo = law.force_i(np.array([g]), np.array([0.01]), 0.0, np.array([0.01]), np.array([0.0]), np.array([0.0]))[1][0]
    hi = law.force_i(np.array([g]), np.array([0.08]), 0.0, np.array([0.08]), np.array([0.0]), np.array([0.0]))[1][0]
    assert (hi + 0.2) / (lo + 0.2) == pytest.approx(4.0, rel=1e-9)


def test_rate_state_steady_state_and_the_aging_law():
    p = {"family": "rate_state", "F0_g": 0.3, "a": 0.02, "b": 0.04, "Dc": 1e-5, "v0": 1e-3, "bv_g": 0.0}
    p["v_reg"] = 1e-4
    law = make_law("friction", p)
    law.reset(1)
    h, V1, V2 = 1e-4, 0.01, 0.05
    for _ in range(200):  # long sliding at V1: theta = Dc / V1
        law.held(np.array([V1]), np.array([0.0]), h)
    f = law.held(np.array([V1]), np.array([0.0]), h)[0][0]
    want = 0.3 * (1 + 0.02 * math.log((V1 + 1e-4) / 1e-3) + 0.04 * math.log(1e-3 / V1)) * math.tanh(V1 / 1e-4)
    assert -f == pytest.approx(want, rel=1e-9)
    # a step to V2: theta follows d theta / dt = 1 - V2 theta / Dc (solved here by an ODE solver)
    sol = integrate.solve_ivp(lambda t, th: 1 - V2 * th / 1e-5, (0, 3 * h), [1e-5 / V1], rtol=1e-12, atol=1e-18)
    for _ in range(3):
        f = law.held(np.array([V2]), np.array([0.0]), h)[0][0]
    th = sol.y[0, -1]
    want = 0.3 * (1 + 0.02 * math.log((V2 + 1e-4) / 1e-3) + 0.04 * math.log(1e-3 * th / 1e-5)) * math.tanh(V2 / 1e-4)
    assert -f == pytest.approx(want, rel=1e-9)
    # healing at rest: theta grows by the dwell time (Dieterich's aging), the level by b ln(theta) of it
    law.reset(1)
    for _ in range(1000):
        law.held(np.array([0.0]), np.array([0.0]), 1e-3)
    assert law.state[0, 0] == pytest.approx(1e-5 / 1e-3 + 1.0, rel=1e-12)


# -------------------------------------------------------------------------- end effects
def test_flux_balance_against_quadrature():
    law = make_law("end_effect", {"family": "flux_balance", "e_p": 0.015, "e_n": 0.03})
    for d in (0.03, 0.045, -0.05):
        ua, ub = max(-L / 2, -(L / 2 + 0.03) - d), min(L / 2, L / 2 + 0.015 - d)
        m = integrate.quad(lambda u: math.sin(KP * u), ua, ub)[0] / (ub - ua)
        e = integrate.quad(lambda u, m=m: (math.sin(KP * u) - m) ** 2, ua, ub, limit=200)[0]
        geo = integrate.quad(lambda u: math.sin(KP * u) ** 2, ua, ub, limit=200)[0]
        rho = law.rho_g(np.array([d]), np.array([0.018]))[0]
        assert rho == pytest.approx(e / (L / 2), rel=1e-9)
        assert rho < geo / (L / 2) - 1e-4  # the flux balance costs more than the overhang alone
    assert law.rho_g(np.array([0.0]), np.array([0.02]))[0] == pytest.approx(1.0, abs=1e-12)


def test_chamfer_against_the_field_over_the_receding_iron():
    s, c = 0.6, 0.012
    law = make_law("end_effect", {"family": "chamfer", "e_p": 0.02, "e_n": 0.03, "s": s, "c": c})
    g = 0.016
    for x in (0.005, 0.012, 0.025):  # overhang beyond e_p
        lost = integrate.quad(lambda u: 1 - (_B(g + s * u) / _B(g)) ** 2, 0, min(x, c))[0] + max(x - c, 0.0)
        rho = law.rho_g(np.array([0.02 + x]), np.array([g]))[0]
        assert rho == pytest.approx(1 - lost / L, rel=1e-7)
    # past the chamfer the iron ends: every further mm of overhang loses a mm's share of the array
    r1, r2 = law.rho_g(np.array([0.05, 0.051]), np.array([g, g]))
    assert (r1 - r2) / 1e-3 == pytest.approx(1 / L, rel=1e-9)


# --------------------------------------------------------------------------- saturation
def _marrocco(b, eps, alpha):
    return eps + (1 - eps) * b ** (2 * alpha) / (b ** (2 * alpha) + 1)


def test_cross_flux_solves_the_series_circuit():
    spec = {"family": "cross_flux", "loss_lo": 0.3, "b_lo": 1.8, "alpha": 2.5, "eps": 1e-3, "target": "both"}
    law = make_law("saturation", spec)
    r = law.ratio_r()
    for g, iq, idd in ((0.012, 0.0, 4.5), (0.02, 3.0, 1.0), (0.03, -2.0, -2.0)):
        kd, kq = _fields(g)
        b = 1.8 * _B(g) / _B(G_LO) * math.hypot(1 - kd * idd, kq * iq)
        f = float(law.flux(np.array([b]))[0])
        assert f * (1 + r * _marrocco(f * b, 1e-3, 2.5)) == pytest.approx(1 + r * 1e-3, rel=1e-9)
    f_hi = float(law.flux(np.array([1.8 * _B(G_HI) / _B(G_LO)]))[0])
    f_lo = float(law.flux(np.array([1.8]))[0])
    assert 1 - f_lo / f_hi == pytest.approx(float(law.loss(np.array([G_LO]))[0]), rel=1e-9)
    assert f_lo == pytest.approx(0.7, rel=1e-9)  # the stated loss at the lower stop (before normalizing)
    # cross saturation: a thrust current saturates the teeth too
    g = np.array([0.015])
    assert law.loss(g, 4.0, 2.0)[0] > law.loss(g, 0.0, 2.0)[0] + 1e-4


def test_magnet_knee_below_and_beyond_the_knee():
    law = make_law("saturation", {"family": "magnet_knee", "w_g": 0.9, "s_k": 1.2, "w_s": 0.03, "l_max": 0.3})
    assert law.loss(np.array([0.025]), 0.0, 0.0)[0] < 1e-3  # far below the knee: no loss
    g = 0.012
    kd, _ = _fields(g)
    i_d = 5.0
    w = 0.9 * (g / (g + k.hm / k.mu_rec) + kd * i_d)
    want = 0.3 * math.tanh(1.2 * 0.03 * math.log1p(math.exp((w - 1) / 0.03)) / 0.3)
    assert law.loss(np.array([g]), 0.0, i_d)[0] == pytest.approx(want, rel=1e-6)
    losses = law.loss(np.full(5, g), 0.0, np.array([0.0, 2.0, 4.0, 6.0, 8.0]))
    assert np.all(np.diff(losses) > 0) and losses[-1] < 0.3  # grows with the demagnetizing current, bounded
    with pytest.raises(ValueError, match="magnet"):
        make_law("saturation", {"family": "magnet_knee", "target": "both"})


# ------------------------------------------------------------------- amplifier and delay
def _freq(law, w):
    A, B, C = law.ss(0)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def _group_delay(law, w=1e-2, h=1e-3):
    ph = [np.angle(_freq(law, x)) for x in (w - h, w + h)]
    return -(ph[1] - ph[0]) / (2 * h)


def test_feedback_filter_response():
    law = make_law("amplifier_lag", {"family": "feedback_filter", "bandwidth_hz": 300.0, "filter_ratio": 1.5})
    wc = 2 * math.pi * 300.0
    wf = 1.5 * wc
    tf = signal.TransferFunction([wc, wc * wf], [1, wf, wc * wf])
    for w in (50.0, 1000.0, 5000.0):
        assert _freq(law, w) == pytest.approx(complex(np.polyval(tf.num, 1j * w) / np.polyval(tf.den, 1j * w)))
    assert _group_delay(law) == pytest.approx(1 / wc - 1 / wf, rel=1e-4)
    assert law.group_delay(1e-3) == pytest.approx(1 / wc - 1 / wf, rel=1e-12)
    t = np.linspace(0, 0.01, 2000)
    _, y = signal.step(tf, T=t)
    _, Bd = law.discrete(0, t[1500])
    assert (Bd @ np.array([1.0, 0.0])) @ law.ss(0)[2] == pytest.approx(y[1500], abs=1e-6)
    assert y.max() > 1.05  # the filter's zero: overshoot


def test_loop_delay_is_the_delayed_loop():
    # the exact loop wc e^{-s Td} / (s + wc e^{-s Td}): the Pade (2, 2) form within 1 % up to the loop's bandwidth
    bw, q = 400.0, 0.7
    law = make_law("amplifier_lag", {"family": "loop_delay", "bandwidth_hz": bw, "q": q})
    wc = 2 * math.pi * bw
    Td = q / wc
    for w in (0.2 * wc, 0.5 * wc, wc):
        e = np.exp(-1j * w * Td)
        want = wc * e / (1j * w + wc * e)
        assert abs(_freq(law, w) - want) < 0.01 * abs(want)
    assert _group_delay(law) == pytest.approx(1 / wc, rel=1e-4)
    with pytest.raises(ValueError, match="q"):
        make_law("amplifier_lag", {"family": "loop_delay", "q": 1.7})


# ------------------------------------------------------------------------- commutation
def test_stoner_wohlfarth_minimizes_the_energy():
    law = make_law("commutation_offset", {"family": "sw_lag", "h_ref": 0.04, "c_s": 5e-3, "x0": 0.01, "psi_e": 0.3})
    phi = np.linspace(-math.pi, math.pi, 400001)
    for g, d in ((0.012, 0.02), (0.024, -0.031)):
        h = 0.04 * _B(k.g_cog_ref + 5e-3) / _B(g + 5e-3)  # Hk / H with MODEL.md's field at the sensor
        th = KP * (d - 0.01)
        # E(phi) = (Hk / 2) sin^2(phi - phi_e) - H cos(phi - th), in units of H
        E = 0.5 * h * np.sin(phi - 0.3) ** 2 - np.cos(phi - th)
        near = np.abs(np.angle(np.exp(1j * (phi - th)))) < 0.5
        err = np.angle(np.exp(1j * (phi[near][np.argmin(E[near])] - th)))
        assert law.angle(np.array([d]), 0.0, np.array([g]))[0] == pytest.approx(err, abs=2e-5)
    x = np.linspace(0, 2 * k.tau, 300)
    a12, a24 = (law.angle(x, 0.0, 0 * x + gg) for gg in (0.012, 0.024))
    assert np.ptp(a24) > 1.5 * np.ptp(a12)  # the field weakens as the gap opens: more lag
    assert law.angle(x + k.tau, 0.0, 0 * x + 0.02) == pytest.approx(law.angle(x, 0.0, 0 * x + 0.02), abs=1e-12)


def test_phase_finding_offsets_per_run():
    spec = {"family": "phase_finding", "delta0": 0.01, "F_stick": 2.0, "I_inj": 1.0, "seed": 42.0}
    law = make_law("commutation_offset", spec)
    law.reset(6)
    kf = NOMINAL.Mh * abs(float(accelerations(k.g_cog_ref, 0.0, 1.0, 0.0, NOMINAL, with_cogging=False)[1]))
    off = law.offsets - 0.01
    assert np.all(np.abs(off) <= math.asin(2.0 / kf) + 1e-12) and np.ptp(off) > 0.02
    X = np.zeros((6, 50, 6))
    X[..., 2] = np.linspace(-0.04, 0.04, 50)[None, :]
    X[..., 0] = 0.018
    a = law.angle(X[..., 2], X[..., 3], X[..., 0])
    assert np.all(a == a[:, :1])  # constant along each run
    again = make_law("commutation_offset", spec)
    again.reset(6)
    assert np.array_equal(again.offsets, law.offsets)
    assert again.describe()["run_offsets_rad"] == pytest.approx(list(law.offsets), abs=0)
    iq, idd = law.rotate_at(np.ones((6, 50)), 2 * np.ones((6, 50)), X, None)
    assert np.allclose(iq**2 + idd**2, 5.0)


# --------------------------------------------------------------------------- eddy drag
def test_end_brake_acts_where_the_plates_are_and_not_with_the_gap():
    law = make_law("eddy_drag", {"family": "end_brake", "c_l": 500.0, "e_p": 0.02, "e_n": 0.01, "s": 2e-3})
    v = np.array([0.1])
    inside = law.force(np.array([0.015]), v, np.array([0.0]), v)
    assert abs(inside[1][0]) < 1e-3 * 500.0 * 0.025 * 0.1  # under 0.1 % of the drag at the stroke's end
    for g in (0.012, 0.024):  # 25 mm of overlap of the array with the plate: c = c_l x 25 mm, both axes
        fg, fd = law.force(np.array([g]), v, np.array([0.045]), v)
        assert fd[0] == pytest.approx(-500.0 * 0.025 * 0.1, rel=1e-3) and fg[0] == pytest.approx(fd[0])
    assert law.force(np.array([0.02]), 2 * v, np.array([-0.04]), 2 * v)[1][0] == pytest.approx(
        2 * law.force(np.array([0.02]), v, np.array([-0.04]), v)[1][0]
    )


def test_hysteresis_drag_sliding_level_and_lag():
    th_h = 0.4
    law = make_law("eddy_drag", {"family": "hysteresis_lag", "F_h0": 0.3, "beta": 1.8, "theta_h": th_h, "c_e": 0.0})
    law.reset(1)
    h, v = 1e-4, 0.5
    for _ in range(300):  # 15 mm of sliding: past the lag (7.3 mm), theta = theta_h
        law.held(np.array([0.0]), np.array([v]), h)
    g = 0.02
    fd = law.force(np.array([g]), 0.0, 0.0, np.array([v]))[1][0]
    assert fd == pytest.approx(-0.3 * (_B(g) / _B(k.g_cog_ref)) ** 1.8, rel=1e-9)  # Steinmetz: ~ B^beta
    # reversal: the drag crosses zero after theta_h tau / pi of travel (Teare's lag angle)
    x_star = th_h * k.tau / math.pi
    n = 50
    for _ in range(n):
        law.held(np.array([0.0]), np.array([-x_star / (n * h)]), h)
    assert abs(law.force(np.array([g]), 0.0, 0.0, np.array([0.0]))[1][0]) < 1e-12
    assert "peak_force_n" in law.recorded() and not hasattr(make_law("eddy_drag", {"family": "end_brake"}), "recorded")


# --------------------------------------------------------------------- out of the library
def test_core_hysteresis_loop():
    law = make_law("core_hysteresis", {"family": "play", "i_c": 0.05, "w": 0.2})
    law.reset(1)
    X = np.zeros((1, 6))
    X[0, 0] = 0.018
    up = np.linspace(1.0, 3.0, 41)
    down = up[::-1]
    out = []
    for i in np.concatenate([up, down]):
        law.advance(np.array([[0.0, i]]), np.array([0.0]), 1e-3)
        out.append(law.rotate_at(np.array([0.0]), np.array([i]), X, None)[1][0])
    out = np.array(out)
    lift = NOMINAL.Mv * abs(float(accelerations(0.018, 0.0, 0.0, 1.0, NOMINAL, with_cogging=False)[0]
                                  - accelerations(0.018, 0.0, 0.0, 0.0, NOMINAL, with_cogging=False)[0]))  # fmt: skip
    rec = law.recorded()
    assert rec["peak_current_offset_a"] == pytest.approx(0.05, abs=1e-12)
    assert rec["peak_force_g_n"] == pytest.approx(0.05 * lift, rel=0.02)  # C3 f3 (the C4 part is small)
    # on the rising branch beyond the play the iron takes i_c off, on the falling branch it adds it: width 2 i_c
    assert out[30] - up[30] == pytest.approx(-0.05, abs=1e-12)
    assert out[41 + 30] - down[30] == pytest.approx(0.05, abs=1e-12)
    law.reset(1)
    law.advance(np.array([[0.0, 2.0]]), np.array([0.0]), 1e-3)
    small = law.rotate_at(np.array([0.0]), np.array([2.1]), X, None)[1][0]
    assert small - 2.1 == pytest.approx(-0.05 * 0.1 / 0.2, abs=1e-12)  # elastic within the play


def test_target_runout_rms_and_the_probe_spot():
    law = make_law("target_runout", {"family": "waviness", "rms": 8e-6, "spot": 8e-3})
    d = np.linspace(0, 20.0, 2_000_001)
    e = law.read(0 * d + 0.02, d)[0] - 0.02
    assert np.sqrt(np.mean(e**2)) == pytest.approx(8e-6, rel=0.02)
    # the probe sees a sinusoid of wavenumber kk averaged over its disc of radius R: 2 J1(kk R) / (kk R)
    lam, R = 0.02, 4e-3
    kk = 2 * math.pi / lam
    avg = integrate.dblquad(lambda r, t: math.cos(kk * r * math.cos(t)) * r, 0, 2 * math.pi, 0, R, epsabs=1e-12)[0] / (
        math.pi * R * R
    )
    assert avg == pytest.approx(2 * special.j1(kk * R) / (kk * R), rel=1e-6)
    assert law.read(np.array([0.02]), np.array([0.01]))[1][0] == 0.01


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v5_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    X = np.column_stack([g, v, d, v, 0 * g, 0 * g])
    hover = np.array([float(equilibrium_current(x)) for x in g])
    for seed in range(120):
        sc = draw(seed, laws="v5")
        assert sc == draw(seed, laws="v5")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v5"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5), read_tol_m=1e-4)
            # currents: the rig's +-8 A anywhere (finite, bounded) and within 3 A of a hover (the controller's
            # range: the forces below FORCE_BOUND_N, the factors near 1)
            for iq, idd in ((0 * g, hover), (0 * g + 8.0, hover), (0 * g - 8.0, 0 * g + 8.0), (0 * g, 0 * g - 8.0)):
                near = np.abs(idd - hover) <= 3.0
                if law.has_force_i:
                    fg, fd = law.force_i(g, v, d, v, iq, idd)
                    assert np.all(np.isfinite(fg)) and np.all(np.isfinite(fd)), (name, spec)
                    assert np.max(np.abs(fg[near]), initial=0) < 50 and np.max(np.abs(fd[near]), initial=0) < 50
                    assert np.max(np.abs(fg)) < 500 and np.max(np.abs(fd)) < 500, (name, spec)
                if law.has_factors_i:
                    f = [np.ones_like(g) for _ in range(4)]
                    law.factors_i(g, d, iq, idd, f)
                    assert all(np.all((x > 0.3) & (x <= 1.0 + 1e-12)) for x in f), (name, spec)
                    assert all(np.all(x[near] > 0.5) for x in f), (name, spec)
            if law.has_rotate_at:
                law.reset(g.size)
                a = law.angle(d, v, g) if law.name == "commutation_offset" else 0 * g
                assert np.all(np.isfinite(a)) and np.max(np.abs(a)) < 0.3, (name, spec)
                iq, idd = law.rotate_at(0 * g + 1.0, 0 * g + 2.0, X, None)
                assert np.all(np.isfinite(iq)) and np.all(np.abs(np.hypot(iq, idd) - math.sqrt(5)) < 0.2)
    assert seen == {(n, f) for n, c in V5_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v4_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit 0cfa3b3 with the same call, per SIMD level
    # (rig_bytes): X86_V4 on the AVX512 CI machine; X86_V3 the same at 0cfa3b3 and ac59446 on an AMD EPYC (numpy
    # 2.4.6); elsewhere the unquantized call against data/rig_digests.json
    cases = {
        "v4": (
            {
                "cogging": {"family": "permeance_wave"},
                "friction": {"family": "bouc_wen"},
                "amplifier_lag": {"family": "eddy_diffusion"},
            },
            13,
            {
                "X86_V4": "9c7a9c2b8881aa3af925a500368e17b0deea6fbe6fdb6b2af06c2e5695a53f4b",
                "X86_V3": "2546860fbf1baeeb1e92dfa80c7769ee5e0409487e90effc7809324c00e20d50",
            },
        ),
        "v4s": (
            {
                "saturation": {"family": "dq_flux"},
                "commutation_offset": {"family": "field_angle"},
                "eddy_drag": {"family": "sheet_2axis"},
            },
            17,
            {
                "X86_V4": "41d3e5010526168624f57e6cf5af9deb12e3d0ee607b8d1971d5181b71e1f402",
                "X86_V3": "2485521eb75416e6202b8a7888c2f5be882a148e52640ecf11a2bc9ff0da9f9e",
            },
        ),
        "v4ool": (
            {"mount_resonance": None},
            19,
            {
                "X86_V4": "fe195e4526547552027de0f0d65519f8f88a4f984dd41b9dde9fceb4aa412d75",
                "X86_V3": "f548c832814c3e0b5409fa5eb8c846b02b33d25c7269e2bb894a0eb7ecd613ac",
            },
        ),
        "v4coil": (
            {"coil_heating": None, "end_effect": {"family": "energy_overhang"}},
            23,
            {
                "X86_V4": "cbb2afcfded0acaf8112f04e8d75252beee0f1a2f0c416d77d5bf787725a2242",
                "X86_V3": "1dd70c1a8ccf62e76e9d5cfb2cd373488f1606bcd44a2d6fb5e96908f28f673b",
            },
        ),
    }
    assert_same_datasets(tmp_path, cases, "v5")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v5_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "cogging": {"family": "on_load"},
        "friction": {"family": "palmgren"},
        "eddy_drag": {"family": "hysteresis_lag"},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "cogging+eddy_drag+friction"
    assert all(e["law_set"] == "v5" for e in truth["effects"].values())
    assert truth["effects"]["cogging"]["peak_force_n"] > 0.5
    assert 0.05 < truth["effects"]["eddy_drag"]["peak_force_n"] < 5.0  # recorded while simulated
    assert truth["effects"]["friction"]["peak_force_n"] > 0.05
    assert truth["hover_error_rms_m"]["g"] < 1e-4 and truth["hover_error_rms_m"]["d"] < 3e-4  # still controlled
    ool = generate(tmp_path / "c", {"core_hysteresis": None}, seed=5, settings=s)
    t2 = json.loads((ool / "truth.json").read_text())
    assert t2["expected_verdict"] == "unexplained" and t2["effects"]["core_hysteresis"]["peak_current_offset_a"] > 0
