"""The seventh law set of the independent rig (maglev_ocp.rigsim.laws_v7, ``laws="v7"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (a first-order lag simulated by ``scipy.signal``, the energy differentiated by finite
differences, the slots of the winding listed one by one, the three-phase transforms written out again, frequency
and step responses from ``scipy.signal``, quadrature, Newton's law through the rig's right-hand side, the damped
oscillator's closed form, seed eq. (2) through ``physics.accelerations``), tolerances fixed beforehand; every
family runs in the closed loop and changes the data; the v7 draw is seeded, covers every family, stays finite and
bounded over the rig's envelope; datasets generated from the law sets before it are the same bytes as at commit
8fb2b1d (before this set; the earlier sets' draws: test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets, dataset_hash
from scipy import integrate, signal

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws_v6 import array_field
from maglev_ocp.rigsim.laws_v7 import G_REF, V7_LAWS, make_law
from maglev_ocp.rigsim.physics import NOMINAL, Constants, accelerations, shape
from maglev_ocp.rigsim.sim import Rig

G_LO, G_HI = k.g_stop
KP = math.pi / k.tau
L = k.pm * k.tau


def _static_cogging(g, d, xi0, c2, phi2, x0):
    """The slot-pitch harmonics written out again: ``(F_g, F_d)`` of ``W = (t1/2pi) sum a_k/k cos theta_k``."""
    fg = fd = 0.0
    for kk, c, ph in ((1, 1 - abs(c2), 0.0), (2, c2, phi2)):
        a = xi0 * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1)
        th = 2 * math.pi * kk * (d - x0) / k.t1 + ph
        fg, fd = fg + a * np.cos(th), fd + a * np.sin(th)
    return fg, fd


# ----------------------------------------------------------------------------- cogging
def test_lossy_teeth_static_at_rest_and_a_first_order_lag_in_motion():
    spec = {"family": "lossy_teeth", "xi0": 3.0, "c2": 0.3, "phi2": 0.8, "x0": 0.004, "tau_e": 4e-3}
    law = make_law("cogging", spec)
    d = np.linspace(-0.04, 0.04, 81)
    g = 0 * d + 0.014
    fg, fd = law.force(g, 0 * d, d, 0 * d)
    wg, wd = _static_cogging(g, d, 3.0, 0.3, 0.8, 0.004)
    assert fg == pytest.approx(wg, abs=1e-12) and fd == pytest.approx(wd, abs=1e-12)
    assert law.force(g, 0, d + k.t1, 0)[1] == pytest.approx(fd, abs=1e-12)  # the slot pitch
    # conservative at rest: dF_d/dg = dF_g/dd
    h = 1e-7
    dfd_dg = (law.force(g + h, 0, d, 0)[1] - law.force(g - h, 0, d, 0)[1]) / (2 * h)
    dfg_dd = (law.force(g, 0, d + h, 0)[0] - law.force(g, 0, d - h, 0)[0]) / (2 * h)
    assert dfd_dg == pytest.approx(dfg_dd, rel=1e-5, abs=1e-3)
    # moving at 0.25 m/s: the static force along d(t) through 1 / (tau_e s + 1) (scipy), after the transient
    v = 0.25
    t = np.linspace(0.0, 0.12, 24001)
    dt = -0.02 + v * t
    sg, sd = _static_cogging(0 * t + 0.014, dt, 3.0, 0.3, 0.8, 0.004)
    lag = signal.lti([1.0], [4e-3, 1.0])
    yd = signal.lsim(lag, sd, t)[1]
    yg = signal.lsim(lag, sg, t)[1]
    tail = t > 0.06
    got_g, got_d = law.force(0 * t + 0.014, 0 * t, dt, 0 * t + v)
    assert np.max(np.abs(got_d - yd)[tail]) < 1e-4 * np.max(np.abs(sd))
    assert np.max(np.abs(got_g - yg)[tail]) < 1e-4 * np.max(np.abs(sg))
    # and the first harmonic alone shrinks by 1 / sqrt(1 + (omega tau)^2)
    one = make_law("cogging", {**spec, "c2": 0.0})
    x = np.linspace(0, k.t1, 401)
    w = 2 * math.pi * v / k.t1
    peak = np.max(np.abs(one.force(0 * x + 0.014, 0, x, 0 * x + v)[1]))
    assert peak == pytest.approx(np.max(np.abs(one.force(0 * x + 0.014, 0, x, 0)[1])) / math.hypot(1, w * 4e-3), 1e-4)


def test_tip_saturation_energy_limit_and_gap():
    spec = {"family": "tip_saturation", "xi0": 4.0, "c2": -0.25, "phi2": 1.1, "x0": 0.002, "xi_s": 3.0}
    law = make_law("cogging", spec)
    d = np.linspace(-0.03, 0.03, 61)
    # the unsaturated limit (xi_s >> the energy swing) is the static law
    big = make_law("cogging", {**spec, "xi_s": 1e9})
    for g in (0.01, 0.02):
        got = big.force(0 * d + g, 0, d, 0)
        want = _static_cogging(0 * d + g, d, 4.0, -0.25, 1.1, 0.002)
        assert got[0] == pytest.approx(want[0], rel=1e-9) and got[1] == pytest.approx(want[1], rel=1e-9)

    def energy(g, x):  # W = (t1 / 2 pi) xi_s tanh(u / xi_s), u = sum a_k / k cos theta_k, written out
        u = 0.0
        for kk, c, ph in ((1, 0.75, 0.0), (2, -0.25, 1.1)):
            a = 4.0 * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1)
            u = u + a / kk * np.cos(2 * math.pi * kk * (x - 0.002) / k.t1 + ph)
        return k.t1 / (2 * math.pi) * 3.0 * np.tanh(u / 3.0)

    h = 1e-7
    for g in (0.009, 0.012, 0.018):
        fg, fd = law.force(0 * d + g, 0, d, 0)
        assert fd == pytest.approx(-(energy(g, d + h) - energy(g, d - h)) / (2 * h), rel=1e-5, abs=1e-6)
        assert fg == pytest.approx(-(energy(g + h, d) - energy(g - h, d)) / (2 * h), rel=1e-5, abs=1e-6)
    # the saturation takes more of the peak at the small gaps
    x = np.linspace(0, k.t1, 801)
    ratio = [
        np.max(np.abs(law.force(0 * x + g, 0, x, 0)[1])) / np.max(np.abs(big.force(0 * x + g, 0, x, 0)[1]))
        for g in (0.009, 0.012, 0.02)
    ]
    assert ratio[0] < ratio[1] < ratio[2] <= 1.0 and ratio[2] > 0.99


# ---------------------------------------------------------------------------- friction
def test_power_law_friction():
    spec = {"family": "power_law", "Fc_g": 0.2, "Fc_d": 0.3, "F1_g": 0.1, "F1_d": 0.25, "n": 0.5, "v0": 1e-6}
    law = make_law("friction", {**spec, "v_reg": 1e-6})
    v = np.array([0.01, 0.1, 0.4])
    fg, fd = law.force(0 * v + 0.02, v, 0 * v, v)
    fgm, fdm = law.force(0 * v + 0.02, -v, 0 * v, -v)
    assert fg == pytest.approx(-fgm, abs=1e-12) and fd == pytest.approx(-fdm, abs=1e-12)
    assert -fd == pytest.approx(0.3 + 0.25 * (v / 0.1) ** 0.5, rel=1e-8)  # Ostwald-de Waele: shear stress ~ rate^n
    assert -fg == pytest.approx(0.2 + 0.1 * (v / 0.1) ** 0.5, rel=1e-8)


def test_frictional_memory_follows_the_lagged_stribeck_curve():
    spec = {"family": "frictional_memory", "Fc_d": 0.2, "Fs_d": 0.15, "vs": 5e-3, "tau_L": 0.02, "b_d": 0.0}
    law = make_law("friction", {**spec, "v_reg": 1e-7})
    law.reset(1)
    h, v = 1e-3, 0.02
    f = -np.array([law.held(np.array([0.0]), np.array([v]), h)[1][0] for _ in range(100)])
    t = h * np.arange(1, 101)
    w = v * (1 - np.exp(-t / 0.02))  # the film's speed after a step from rest
    assert f == pytest.approx(0.2 + 0.15 * np.exp(-((w / 5e-3) ** 2)), rel=1e-9)
    assert f[0] > 0.33 and f[-1] == pytest.approx(0.2, abs=1e-6)  # starts near the static level, ends on the curve
    # a speed sweep up and back down: the friction at the same speed differs (the memory's loop)
    law.reset(1)
    up = [law.held(np.array([0.0]), np.array([s]), h)[1][0] for s in np.linspace(0, 0.01, 21)]
    down = [law.held(np.array([0.0]), np.array([s]), h)[1][0] for s in np.linspace(0.01, 0, 21)]
    assert abs(up[10] - down[10]) > 0.01


# -------------------------------------------------------------------------- end effects
def _missing(e_p, e_n, x_w, d):
    """Each phase's slot length missing from under the array at ``d``, from the slots listed one by one."""
    hi, lo = L / 2 + e_p, -L / 2 - e_n
    gaps = [(hi, max(d + L / 2, hi)), (min(d - L / 2, lo), lo)]
    out = {"a": 0.0, "b": 0.0, "c": 0.0}
    for n in range(-60, 60):
        a, b = x_w + n * k.t1, x_w + (n + 1) * k.t1
        ph = {0: "a", 1: "c", 2: "b"}[n % 3]  # a, -c, b, -a, c, -b
        for p, q in gaps:
            out[ph] += max(0.0, min(b, q) - max(a, p))
    return out


def test_phase_unbalance_against_the_slots_and_the_three_phase_transform():
    spec = {"family": "phase_unbalance", "e_p": 0.015, "e_n": 0.025, "x_w": 0.011}
    law = make_law("end_effect", spec)
    for d in (-0.055, -0.035, 0.0, 0.012, 0.03, 0.05):
        miss = _missing(0.015, 0.025, 0.011, d)
        eps = law.shares(np.array([d]))[0]
        assert eps == pytest.approx([miss[x] / (L / 3) for x in "abc"], abs=1e-12)
        over = max(0.0, d - 0.015) + max(0.0, -d - 0.025)
        assert sum(miss.values()) == pytest.approx(over, abs=1e-12)
        iq, idd = 1.3, 2.7
        th = math.pi * (d - 0.011 - k.t1 / 2) / k.tau
        angles = {"a": th, "b": th - 2 * math.pi / 3, "c": th + 2 * math.pi / 3}
        rho = 1 - over / L  # the overhanging magnets' pull lost: every term
        assert float(law.rho(np.array([d]))[0]) == pytest.approx(rho, abs=1e-12)
        f = [np.ones(1) for _ in range(4)]
        law.factors(np.array([0.02]), np.array([d]), f)
        assert float(f[2][0]) == pytest.approx(rho, abs=1e-12)
        assert rho == pytest.approx(1 - sum(miss.values()) / (3 * L / 3), abs=1e-12)  # the phases' mean share
        ph = {x: (idd * math.cos(a) - iq * math.sin(a)) * (1 - miss[x] / (L / 3)) / rho for x, a in angles.items()}
        want_d = 2 / 3 * sum(ph[x] * math.cos(a) for x, a in angles.items())
        want_q = -2 / 3 * sum(ph[x] * math.sin(a) for x, a in angles.items())
        got = law.carried(np.array([iq]), np.array([idd]), np.array([d]))
        assert (got[0][0], got[1][0]) == pytest.approx((want_q, want_d), abs=1e-12)
        if over == 0.0:  # the array inside the stator: nothing changes
            assert (got[0][0], got[1][0]) == pytest.approx((iq, idd), abs=1e-12)


def test_armature_reluctance_is_the_coenergy_gradient():
    spec = {"family": "armature_reluctance", "e_p": 0.02, "e_n": 0.03, "dL_p": 2e-3, "dL_n": 1e-3, "w": 8e-3}
    law = make_law("end_effect", spec)

    def ind(x):  # L(d) - L0 written out
        return -2e-3 / (1 + math.exp(-(x - 0.02) / 8e-3)) - 1e-3 / (1 + math.exp(-(-x - 0.03) / 8e-3))

    h = 1e-7
    for d in (-0.05, -0.03, 0.0, 0.02, 0.04):
        iq, idd = 2.0, -3.0
        fd = law.force_i(0.02, 0.0, np.array([d]), 0.0, iq, idd)[1][0]
        assert fd == pytest.approx(0.75 * 13.0 * (ind(d + h) - ind(d - h)) / (2 * h), rel=1e-6, abs=1e-12)
        assert law.force_i(0.02, 0.0, np.array([d]), 0.0, 0.0, 0.0)[1][0] == 0.0
    # inward at both ends: the array is pulled back over the winding
    assert law.force_i(0.02, 0, np.array([0.02]), 0, 3.0, 0.0)[1][0] < 0
    assert law.force_i(0.02, 0, np.array([-0.03]), 0, 3.0, 0.0)[1][0] > 0


# --------------------------------------------------------------------------- saturation
def test_leakage_knee_depends_on_the_current_alone():
    law = make_law("saturation", {"family": "leakage_knee", "i_k": 6.0, "p": 3.0})
    assert law.has_factors_i and not law.has_factors
    g = np.array([G_LO, 0.02, G_HI])
    f = [np.ones(3) for _ in range(4)]
    law.factors_i(g, 0 * g, 0 * g + 3.0, 0 * g - 4.0, f)
    assert f[1] == pytest.approx(np.full(3, (1 + (5.0 / 6.0) ** 3) ** (-1 / 3)), rel=1e-12)  # |i| = 5 A
    assert f[0] == pytest.approx(np.ones(3)) and f[3] == pytest.approx(np.ones(3))
    assert float(law.knee(0.01, 0.0)) == pytest.approx(1.0, abs=1e-8)  # linear below the knee
    assert float(law.knee(600.0, 0.0)) == pytest.approx(6.0 / 600.0, rel=1e-5)  # ~ i_k / |i| above it


def test_saturation_factor_is_seed_eq2_at_the_lengthened_gap():
    law = make_law("saturation", {"family": "saturation_factor", "k_lo": 0.15, "n": 3.0})
    for g in (G_LO, 0.015, 0.025):
        ge = g * (1 + 0.15 * (float(shape(g).B) / float(shape(G_LO).B)) ** 3)
        f = [np.ones(1) for _ in range(4)]
        law.factors(np.array([g]), np.zeros(1), f)
        km, kc, _, thr = (float(x[0]) for x in f)
        sh, se, c = shape(g), shape(ge), NOMINAL
        idd, iq = 2.0, 0.7
        got = c.C2 * sh.f2 * km * km - c.C3 * sh.f3 * idd * km * kc
        assert float(got) == pytest.approx(float(c.C2 * se.f2 - c.C3 * se.f3 * idd), rel=1e-12)
        assert float(c.C1 * sh.f1 * km * kc * thr * iq) == pytest.approx(float(c.C1 * se.f1 * iq), rel=1e-12)
        pull_e = -float(accelerations(ge, 0.0, 0.0, 0.0, NOMINAL, with_cogging=False)[0]) + k.G
        assert float(c.C2 * sh.f2 * km * km) == pytest.approx(pull_e, rel=1e-12)
    losses = [float(law.loss(np.array([g]))[0]) for g in (G_LO, 0.015, 0.025)]
    assert losses[0] > losses[1] > losses[2] > 0.0
    none = make_law("saturation", {"family": "saturation_factor", "k_lo": 0.0})
    f = [np.ones(2) for _ in range(4)]
    none.factors(np.array([G_LO, G_HI]), np.zeros(2), f)
    assert all(x == pytest.approx(np.ones(2), abs=1e-12) for x in f)


# ------------------------------------------------------------------- amplifier and delay
def _freq(law, w, axis=0):
    A, B, C = law.ss(axis)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def test_feedforward_response_lead_and_delay():
    law = make_law("amplifier_lag", {"family": "feedforward", "bandwidth_hz": 250.0, "alpha": 1.25, "ff_hz": 2e3})
    wc, wf = 2 * math.pi * 250, 2 * math.pi * 2e3
    num, den = np.polymul([wf], [1.25, wc]), np.polymul([1, wc], [1, wf])
    for w in (0.0, 300.0, wc, 5 * wf):
        assert _freq(law, w) == pytest.approx(complex(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)), rel=1e-9)
    ph = [np.angle(_freq(law, x)) for x in (1e-2 - 1e-3, 1e-2 + 1e-3)]
    gd = -(ph[1] - ph[0]) / 2e-3
    assert gd == pytest.approx(law.group_delay(0.0), rel=1e-4) and gd < 0  # a lead: the model's L too large
    exact = make_law("amplifier_lag", {"family": "feedforward", "bandwidth_hz": 250.0, "alpha": 1.0, "ff_hz": 2e3})
    assert abs(_freq(exact, 700.0) - wf / (700j + wf)) < 1e-12  # the right model: only the derivative filter left


def test_proportional_loop_gain_delay_and_back_emf_error():
    spec = {"family": "proportional_loop", "bandwidth_hz": 400.0, "rho": 0.05, "L": 8e-3, "ke_q": 12.0, "ke_d": 30.0}
    law = make_law("amplifier_lag", spec)
    wc = 2 * math.pi * 400
    Kp = wc * 8e-3 / 1.05  # R + Kp = wc L, R = 0.05 Kp
    # the circuit L di/dt = -R i + Kp (u - i) - ke v, written out, against the state space
    tf = signal.TransferFunction([Kp / 8e-3], [1, (0.05 * Kp + Kp) / 8e-3])
    t = np.linspace(0, 5e-3, 501)
    _, y = signal.step(tf, T=t)
    _, Bd = law.discrete(0, t[300])
    assert (Bd @ np.array([1.0, 0.0])) @ law.ss(0)[2] == pytest.approx(y[300], rel=1e-9)
    assert law.dc_gain() == pytest.approx(Kp / (Kp + 0.05 * Kp)) and law.equilibrium(np.ones((1, 2)))[0, 0, 0] < 1
    for ax, ke in ((0, 12.0), (1, 30.0)):  # steady speed 0.2 m/s, no command: the back-EMF's current
        A, B, C = law.ss(ax)
        x = -np.linalg.solve(A, B[:, 1] * 0.2)
        assert float(C @ x) == pytest.approx(-ke * 0.2 / (Kp * 1.05), rel=1e-12)
    assert law.group_delay(1e-3) == pytest.approx(1 / wc)


# ------------------------------------------------------------------------- commutation
def test_tape_defect_steps():
    spec = {"family": "tape_defect", "delta0": 0.01, "p_t": 1.2e-3, "x_1": 0.01, "m_1": 1.0, "x_2": -0.02}
    law = make_law("commutation_offset", {**spec, "m_2": -1.0, "w": 2e-4})
    step = KP * 1.2e-3
    a = law.angle(np.array([-0.05, -0.01, 0.03]))
    assert a == pytest.approx([0.01, 0.01 - step, 0.01], abs=1e-12)  # -1 past x_2, back to 0 past x_1
    one = make_law("commutation_offset", {**spec, "m_2": 0.0, "w": 2e-4})
    assert one.angle(np.array([0.02]))[0] - one.angle(np.array([0.0]))[0] == pytest.approx(step, rel=1e-12)
    iq, idd = one.rotate(np.array([1.0]), np.array([3.0]), np.array([0.03]))
    c, s = math.cos(0.01 + step), math.sin(0.01 + step)
    assert (iq[0], idd[0]) == pytest.approx((c - 3 * s, s + 3 * c), abs=1e-12)


def test_sincos_heydemann_angle_errors():
    spec = {"family": "sincos_heydemann", "delta0": 0.0, "p": 0.02, "q": -0.015, "r": 0.025, "alpha": 0.02}
    law = make_law("commutation_offset", {**spec, "theta0": 0.4})
    d = np.linspace(-0.05, 0.05, 101)
    th = KP * d + 0.4
    est = [math.atan2(1.025 * math.sin(x + 0.02) - 0.015, math.cos(x) + 0.02) for x in th]
    want = [(e - x + math.pi) % (2 * math.pi) - math.pi for e, x in zip(est, th, strict=True)]
    assert law.angle(d) == pytest.approx(want, abs=1e-12)
    clean = make_law("commutation_offset", {"family": "sincos_heydemann", "p": 0, "q": 0, "r": 0, "alpha": 0})
    assert clean.angle(d) == pytest.approx(np.zeros_like(d), abs=1e-12)
    # offsets: period 2 tau; gain and quadrature alone: period tau (half the electrical period)
    off = make_law("commutation_offset", {"family": "sincos_heydemann", "p": 0.02, "q": 0.01, "r": 0, "alpha": 0})
    assert off.angle(d + k.tau) == pytest.approx(-off.angle(d), abs=2e-3)
    gain = make_law("commutation_offset", {"family": "sincos_heydemann", "p": 0, "q": 0, "r": 0.03, "alpha": 0.02})
    assert gain.angle(d + k.tau) == pytest.approx(gain.angle(d), abs=1e-12)


# --------------------------------------------------------------------------- eddy drag
def test_damper_bars_sum_the_field_over_the_bars():
    law = make_law("eddy_drag", {"family": "damper_bars", "c0": 20.0, "x0": 0.005})
    xb = 0.005 + np.arange(-14, 15) * k.t1

    def bars(g, d):
        return sum(float(array_field(x - d, g)) ** 2 for x in xb)

    u = np.linspace(0, k.t1, 64, endpoint=False)
    q = np.mean([bars(G_REF, x) for x in u])
    for g, d in ((0.012, 0.0), (0.018, 0.031), (0.024, -0.047)):
        c = float(law.coefficient(np.array([g]), np.array([d]))[0])
        assert c == pytest.approx(20.0 * bars(g, d) / q, rel=1e-10)
        fg, fd = law.force(np.array([g]), np.array([0.1]), np.array([d]), np.array([0.2]))
        assert fd[0] == pytest.approx(-0.2 * c, rel=1e-12) and fg[0] == 0.0
    x = np.linspace(-0.01, 0.01, 41)
    c0 = law.coefficient(0 * x + G_REF, x)
    assert np.mean(law.coefficient(0 * u + G_REF, u)) == pytest.approx(20.0, rel=1e-12)  # c0: the mean at 15 mm
    assert law.coefficient(0 * x + G_REF, x + k.t1) == pytest.approx(c0, rel=1e-3)  # ripples with the slot pitch
    assert np.ptp(c0) > 1e-3 * np.mean(c0)


def test_parallel_paths_against_quadrature():
    spec = {"family": "parallel_paths", "c0": 10.0, "x_m": 0.01, "x_a": 0.02}
    law = make_law("eddy_drag", spec)

    def imbalance(d):
        tot = 0.0
        for j in range(3):
            xj = 0.02 + j * 2 * k.tau / 3

            def f(x, xj=xj):
                return math.sin(KP * (x - xj)) * math.cos(KP * (x - d))

            ka = integrate.quad(f, d - L / 2, 0.01, limit=200)[0]
            kb = integrate.quad(f, 0.01, d + L / 2, limit=200)[0]
            tot += ((ka - kb) / (L / 2)) ** 2
        return 2 / 3 * tot

    for d in (-0.05, 0.0, 0.01, 0.04):
        assert float(law.imbalance(np.array([d]))[0]) == pytest.approx(imbalance(d), rel=1e-9, abs=1e-12)
    b2 = float((shape(0.02).B / shape(G_REF).B) ** 2)
    fd = law.force(np.array([0.02]), 0.0, np.array([-0.05]), np.array([0.3]))[1][0]
    assert fd == pytest.approx(-10.0 * b2 * imbalance(-0.05) * 0.3, rel=1e-9)
    # a completely unequal cover (the split past the array's end) drags with c0 at 15 mm
    past = make_law("eddy_drag", {**spec, "x_m": 0.2})
    assert float(past.coefficient(np.array([G_REF]), np.array([0.0]))[0]) == pytest.approx(10.0, rel=1e-9)
    assert float(law.imbalance(np.array([0.01]))[0]) < 0.01 * imbalance(-0.05)  # centred on the split: little


# --------------------------------------------------------------------- out of the library
def test_payload_swap_is_newtons_law_for_the_loaded_runs():
    law = make_law("payload_swap", {"family": "alternate_runs", "m_p": 0.25, "first": 1.0})
    assert law.masses(5) == pytest.approx([0, 0.25, 0, 0.25, 0])
    c = Constants()  # nominal masses, as the law's
    ideal = RigSettings.ideal(nominal_cogging=False)
    rig, base = Rig(c, [law], ideal), Rig(c, [], ideal)
    law.reset(2)
    X = np.zeros((2, 6))
    X[:, 0], X[:, 2] = 0.018, 0.01
    iq, idd = np.array([1.5, 1.5]), np.array([2.0, 2.0])
    dX, dX0 = rig.rhs(X, iq, idd, 0.0, 0.0, 1.0, 0.0), base.rhs(X, iq, idd, 0.0, 0.0, 1.0, 0.0)
    a_up = k.G - dX0[:, 1]
    # (Mv + m) g'' = (Mv + m) G - Mv a_up and (Mh + m) d'' = Mh d''_0
    assert dX[0, 1] == pytest.approx(dX0[0, 1], rel=1e-12) and dX[0, 3] == pytest.approx(dX0[0, 3], rel=1e-12)
    assert (k.Mv + 0.25) * dX[1, 1] == pytest.approx((k.Mv + 0.25) * k.G - k.Mv * a_up[1], rel=1e-12)
    assert (k.Mh + 0.25) * dX[1, 3] == pytest.approx(k.Mh * dX0[1, 3], rel=1e-12)


def test_flexible_payload_oscillates_as_a_damped_mass_spring():
    spec = {"family": "tool_mount", "m_p": 0.12, "f_g": 30.0, "f_d": 22.0, "zeta": 0.04}
    law = make_law("flexible_payload", spec)
    law.reset(1)
    kg, cg = law.stiffness(0)
    assert kg == pytest.approx(0.12 * (2 * math.pi * 30) ** 2) and cg == pytest.approx(2 * 0.04 * 0.12 * 60 * math.pi)
    # at rest the mount carries the payload's weight on the gap axis and nothing along d
    fg, fd = law.held(np.array([0.0]), np.array([0.0]), 1e-3)
    assert fg[0] == pytest.approx(0.12 * k.G, rel=1e-12) and fd[0] == pytest.approx(0.0, abs=1e-12)
    # pluck the payload along d by 0.1 mm with the mover held: z(t) of the damped oscillator's closed form
    law.state[0, 1, :] = [1e-4, 0.0]
    wn, z = 2 * math.pi * 22.0, 0.04
    wd = wn * math.sqrt(1 - z * z)
    for n in range(1, 61):
        law.held(np.array([0.0]), np.array([0.0]), 1e-3)
        t = n * 1e-3
        want = 1e-4 * math.exp(-z * wn * t) * (math.cos(wd * t) + z / math.sqrt(1 - z * z) * math.sin(wd * t))
        assert law.state[0, 1, 0] == pytest.approx(want, abs=1e-13)
    # a mover accelerating along +d: the payload lags and pulls it back
    law.reset(1)
    fd = [law.held(np.array([0.0]), np.array([0.5 * n * 1e-4]), 1e-4)[1][0] for n in range(20)]
    assert fd[-1] < 0


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v7_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    X = np.column_stack([g, v, d, v, 0 * g, 0 * g])
    for seed in range(120):
        sc = draw(seed, laws="v7")
        assert sc == draw(seed, laws="v7")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v7"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5))
            if getattr(law, "has_force_i", False):
                fg, fd = law.force_i(g, v, d, v, 0 * g + 8.0, 0 * g)
                assert np.all(np.isfinite(fd)) and np.max(np.abs(fd)) < 50.0 and not np.any(fg), (name, spec)
            if getattr(law, "has_factors_i", False):
                f = [np.ones_like(g) for _ in range(4)]
                law.factors_i(g, d, 0 * g + 5.0, 0 * g + 6.0, f)  # at the current limit
                assert all(np.all((x > 0.5) & (x <= 1.0)) for x in f), (name, spec)
            if law.has_rotate or getattr(law, "has_rotate_at", False):
                iq, idd = 0 * g + 0.5, 0 * g + 3.0
                q2, d2 = law.rotate_at(iq, idd, X, None) if law.has_rotate_at else law.rotate(iq, idd, d)
                assert np.all(np.isfinite(q2)) and np.all(np.isfinite(d2)), (name, spec)
                if name == "commutation_offset":  # a rotation of at most 0.25 rad
                    assert np.allclose(np.hypot(q2, d2), np.hypot(iq, idd)), (name, spec)
                    assert np.max(np.hypot(q2 - iq, d2 - idd)) < 0.25 * 3.05, (name, spec)
                else:  # the phases keep 1 - eps_j of their force, rho of it through the factors
                    rho = law.rho(d)
                    assert np.all(np.hypot(q2, d2) * rho <= np.hypot(iq, idd) * (1 + 1e-12)), (name, spec)
                    assert np.all(np.hypot(q2, d2) * rho >= 0.5 * np.hypot(iq, idd)), (name, spec)
            if name == "amplifier_lag":
                A, B, C = law.ss(0)
                assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(law.dc_gain(), abs=1e-9)
                assert 0.9 < law.dc_gain() <= 1.0 and np.all(np.linalg.eigvals(A).real < 0)
    assert seen == {(n, f) for n, c in V7_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_every_v7_family_runs_in_the_closed_loop_and_changes_the_data(tmp_path):
    s = RigSettings(n_runs=2, duration=1.0)
    base = generate(tmp_path / "none", None, seed=7, settings=s)
    runs0 = [p.read_bytes() for p in sorted(base.glob("run_*.csv"))]
    for name, cls in V7_LAWS.items():
        for fam in cls.families:
            out = generate(tmp_path / fam, {name: {"family": fam}}, seed=7, settings=s)
            assert [p.read_bytes() for p in sorted(out.glob("run_*.csv"))] != runs0, (name, fam)
            truth = json.loads((out / "truth.json").read_text())
            e = truth["effects"][name]
            assert e["law_set"] == "v7" and e["family"] == fam
            size = e["effective_delay_s"] if name == "amplifier_lag" else e["peak_force_n"]
            assert np.isfinite(size) and (size != 0.0), (name, fam, e)
            assert truth["hover_error_rms_m"]["g"] < 2e-4 and truth["hover_error_rms_m"]["d"] < 3e-4, (name, fam)


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v6_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit 8fb2b1d with the same call on an AMD EPYC
    # (numpy 2.4.6 at X86_V4); on another SIMD level the unquantized call against data/rig_digests.json ("v7_*",
    # recorded at 8fb2b1d)
    cases = {
        "v6a": (
            {
                "friction": {"family": "rail_position"},
                "saturation": {"family": "incremental_arctan"},
                "commutation_offset": {"family": "tracking_observer"},
            },
            13,
            {"X86_V4": "efbcc8d2f3a1de57105a6742d9a0a008a0ee318c9cc90e0ba542339b8dcc5433"},
        ),
        "v6b": (
            {
                "end_effect": {"family": "segment_joint"},
                "amplifier_lag": {"family": "sine_filter"},
                "eddy_drag": {"family": "receding_image"},
            },
            17,
            {"X86_V4": "76add9ad2e0d4fda7209967ea5ba82829123feb83905d1b2c3b36a8ba83290e6"},
        ),
        "v6ool": (
            {"stator_flatness": None, "cogging": {"family": "paired_teeth"}},
            19,
            {"X86_V4": "1836b4e640c4f75b8bb6b441f8b7b0cdca1e3f582f492ba8f0c5a574e152d845"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v7")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v7_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "cogging": {"family": "lossy_teeth"},
        "friction": {"family": "frictional_memory"},
        "amplifier_lag": {"family": "proportional_loop"},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "amplifier_lag+cogging+friction"
    assert all(e["law_set"] == "v7" for e in truth["effects"].values())
    assert truth["effects"]["cogging"]["peak_force_n"] > 0.05
    assert 0.0 < truth["effects"]["friction"]["peak_force_d_n"] < 2.0  # the held force, recorded per period
    assert truth["effects"]["amplifier_lag"]["effective_delay_s"] > 0.0
    ool = generate(tmp_path / "c", {"payload_swap": {"m_p": 0.2, "first": 1.0}}, seed=5, settings=s)
    t2 = json.loads((ool / "truth.json").read_text())
    e = t2["effects"]["payload_swap"]
    assert t2["expected_verdict"] == "unexplained" and e["library"] is False
    # the loaded run's magnetic pull at hover is about the payload's weight off the unloaded mover's acceleration
    assert 0.5 * 0.2 * k.G < e["peak_force_g_n"] < 2.0 * 0.2 * k.G
