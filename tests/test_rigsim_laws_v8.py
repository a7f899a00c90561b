"""The eighth law set of the independent rig (maglev_ocp.rigsim.laws_v8, ``laws="v8"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (the energy differentiated by finite differences, the strip fields integrated by
quadrature, the play operator and the travelled path stepped by hand, seed eq. (2) through ``physics.shape``,
frequency and step responses from ``numpy`` polynomials and ``scipy.signal``, the quantized angle from ``round`` and
``floor``, the modules' overlaps by sampling the array), tolerances fixed beforehand; every family runs in the
closed loop and changes the data; the v8 draw is seeded, covers every family, stays finite and bounded over the
rig's envelope; datasets generated from the law sets before it are the same bytes as at commit 84b564b (before
this set; the earlier sets' draws: test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets, dataset_hash
from scipy import integrate, optimize, signal

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws_v8 import G_REF, V8_LAWS, make_law
from maglev_ocp.rigsim.physics import NOMINAL, shape

G_LO, G_HI = k.g_stop
KP = math.pi / k.tau
L = k.pm * k.tau


def _harmonics(g, x, xi0, cs):
    """``(F_g, F_d)`` of ``W = (t1/2pi) sum a_k/k cos theta_k`` written out; ``cs = [(k, c_k, phi_k)]``, x0 = 0."""
    fg = fd = 0.0
    for kk, c, ph in cs:
        a = xi0 * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1)
        th = 2 * math.pi * kk * x / k.t1 + ph
        fg, fd = fg + a * np.cos(th), fd + a * np.sin(th)
    return fg, fd


def _bz(x, y):
    """``Bz`` of the four alternating magnets (units ``Br/pi``): each face a uniformly charged strip, ``atan`` written
    out (Furlani 2001, ch. 4)."""
    tot = 0.0
    for j in range(k.pm):
        u = x - (j - 1.5) * k.tau
        for yy, sgn in ((y, 1.0), (y + k.hm, -1.0)):
            tot = tot + (-1.0) ** j * sgn * (np.arctan((u + k.taup / 2) / yy) - np.arctan((u - k.taup / 2) / yy))
    return tot


def _strip_bz(x, y):
    """``Bz`` of the four alternating magnets (units ``Br/pi``) by quadrature of their face charges."""
    tot = 0.0
    for j in range(k.pm):
        c = (j - 1.5) * k.tau
        for yy, sgn in ((y, 1.0), (y + k.hm, -1.0)):
            val = integrate.quad(lambda s, yy=yy: yy / ((x - s) ** 2 + yy**2), c - k.taup / 2, c + k.taup / 2)[0]
            tot += (-1.0) ** j * sgn * val
    return tot


# ----------------------------------------------------------------------------- cogging
def test_hysteretic_teeth_static_at_rest_and_a_play_in_motion():
    spec = {"family": "hysteretic_teeth", "xi0": 3.0, "c2": 0.3, "phi2": 0.8, "c3": -0.1, "phi3": 0.4, "x0": 0.0}
    law = make_law("cogging", {**spec, "delta_h": 1e-3})
    cs = [(1, 0.6, 0.0), (2, 0.3, 0.8), (3, -0.1, 0.4)]
    d = np.linspace(-0.04, 0.04, 81)
    law.reset(d.size)
    g = 0 * d + 0.013
    fg, fd = law.force(g, 0 * d, d, 0 * d)
    wg, wd = _harmonics(g, d, 3.0, cs)
    assert fg == pytest.approx(wg, abs=1e-12) and fd == pytest.approx(wd, abs=1e-12)
    assert law.force(g, 0, d + k.t1, 0)[1] == pytest.approx(fd, abs=1e-12)  # the slot pitch
    h = 1e-7  # conservative at rest: dF_d/dg = dF_g/dd
    dfd_dg = (law.force(g + h, 0, d, 0)[1] - law.force(g - h, 0, d, 0)[1]) / (2 * h)
    dfg_dd = (law.force(g, 0, d + h, 0)[0] - law.force(g, 0, d - h, 0)[0]) / (2 * h)
    assert dfd_dg == pytest.approx(dfg_dd, rel=1e-5, abs=1e-3)
    # moving +: the play fills, the pattern trails by delta_h
    for _ in range(50):
        law.held(0 * d, 0 * d + 0.1, 1e-4)  # 0.5 mm of travel
    assert law.state == pytest.approx(np.full(d.size, 5e-4))
    for _ in range(100):
        law.held(0 * d, 0 * d + 0.1, 1e-4)
    assert law.state == pytest.approx(np.full(d.size, 1e-3))
    assert law.force(g, 0, d, 0 * d + 0.1)[1] == pytest.approx(_harmonics(g, d - 1e-3, 3.0, cs)[1], abs=1e-12)
    # a step back of 0.4 mm inside the play: the pattern stays where it was (position d - z unchanged)
    before = law.force(g, 0, d, 0)[1]
    for _ in range(4):
        law.held(0 * d, 0 * d - 0.1, 1e-3)
    assert law.force(g, 0, d - 4e-4, 0)[1] == pytest.approx(before, abs=1e-12)


def test_end_pair_is_an_energy_gradient_and_its_ends_decay_slowly():
    spec = {"family": "end_pair", "xi0": 3.0, "c2": -0.2, "phi2": 0.5, "x0": 0.0, "xi_p": 1.0, "xi_n": 0.7}
    law = make_law("cogging", {**spec, "psi_p": 0.3, "psi_n": -1.2, "h_e": 5e-3})

    def energy(g, x):  # W = interior + both ends, written out
        w = 0.0
        for kk, c, ph in ((1, 0.8, 0.0), (2, -0.2, 0.5)):
            a = 3.0 * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1)
            w = w + a / kk * np.cos(2 * math.pi * kk * x / k.t1 + ph)
        for xi, psi in ((1.0, 0.3), (0.7, -1.2)):
            w = w + xi * (15e-3 / (g + 5e-3)) ** 2 * np.cos(2 * math.pi * x / k.t1 + psi)
        return k.t1 / (2 * math.pi) * w

    d = np.linspace(-0.03, 0.03, 61)
    h = 1e-7
    for g in (0.01, 0.016, 0.024):
        fg, fd = law.force(0 * d + g, 0, d, 0)
        assert fd == pytest.approx(-(energy(g, d + h) - energy(g, d - h)) / (2 * h), rel=1e-5, abs=1e-6)
        assert fg == pytest.approx(-(energy(g + h, d) - energy(g - h, d)) / (2 * h), rel=1e-5, abs=1e-6)
    # from 10 to 22 mm the ends keep (15/27)^2 of their detent, the interior's first harmonic exp(-2 pi 12/t1)
    x = np.linspace(0, k.t1, 801)
    ends = make_law("cogging", {**spec, "xi0": 0.0, "psi_p": 0.3, "psi_n": -1.2, "h_e": 5e-3})
    r_ends = np.ptp(ends.force(0 * x + 0.022, 0, x, 0)[1]) / np.ptp(ends.force(0 * x + 0.01, 0, x, 0)[1])
    assert r_ends == pytest.approx((15 / 27) ** 2, rel=1e-6)
    assert (15 / 27) ** 2 > 10 * math.exp(-2 * math.pi * 12e-3 / k.t1)


# ---------------------------------------------------------------------------- friction
def test_grease_churning_falls_with_the_travelled_path():
    spec = {"family": "grease_churning", "Fc_d": 0.2, "a_d": 1.5, "s_c": 0.05, "b_d": 0.5, "v_reg": 1e-7}
    law = make_law("friction", spec)
    law.reset(1)
    h, v = 1e-3, 0.1
    f = -np.array([law.held(np.array([0.0]), np.array([v]), h)[1][0] for _ in range(300)])
    s_mid = v * h * (np.arange(300) + 0.5)  # the path at each sub-step's middle
    assert f == pytest.approx(0.2 * (1 + 1.5 * np.exp(-s_mid / 0.05)) + 0.5 * v, rel=1e-12)
    # the same path travelled back and forth: the level keeps falling (not a function of the speed)
    law.reset(1)
    fwd = [law.held(np.array([0.0]), np.array([0.05]), h)[1][0] for _ in range(200)]
    back = [law.held(np.array([0.0]), np.array([-0.05]), h)[1][0] for _ in range(200)]
    assert -fwd[0] > -fwd[-1] > back[-1] > 0 and back[0] == pytest.approx(-fwd[-1], rel=0.02)
    law.reset(1)  # a new run churns again
    assert -law.held(np.array([0.0]), np.array([v]), h)[1][0] == pytest.approx(f[0], rel=1e-12)


def test_seal_asymmetric_rubs_harder_one_way():
    spec = {"family": "seal_asymmetric", "Fp_g": 0.3, "Fn_g": 0.15, "Fp_d": 0.1, "Fn_d": 0.25, "b_g": 1.0}
    law = make_law("friction", {**spec, "b_d": 0.0, "v_reg": 1e-6})
    v = np.array([0.02, 0.2])
    fg, fd = law.force(0 * v + 0.02, v, 0 * v, v)
    fgm, fdm = law.force(0 * v + 0.02, -v, 0 * v, -v)
    assert fg == pytest.approx(-(0.3 + 1.0 * v), rel=1e-9) and fgm == pytest.approx(0.15 + 1.0 * v, rel=1e-9)
    assert fd == pytest.approx(np.full(2, -0.1), rel=1e-9) and fdm == pytest.approx(np.full(2, 0.25), rel=1e-9)
    assert law.force(0.02, 0.0, 0.0, 0.0) == (0.0, 0.0)  # no force at rest


# -------------------------------------------------------------------------- end effects
def test_end_face_is_the_gradient_of_the_field_energy_over_the_stator():
    law = make_law("end_effect", {"family": "end_face", "e_p": 0.015, "e_n": 0.03, "F_e": 2.0})
    xp, xn = L / 2 + 0.015, L / 2 + 0.03
    u = np.linspace(0, L / 2 + 0.02, 4001)
    b2max = float(np.max(_bz(u, G_REF) ** 2))
    assert [_bz(x, 0.02) for x in (0.0, 0.05, 0.11)] == pytest.approx([_strip_bz(x, 0.02) for x in (0.0, 0.05, 0.11)])

    def energy(d, g):  # W = -c int_{-xn}^{xp} Bz(x - d)^2 dx by quadrature, c = F_e / b2max
        return -2.0 / b2max * integrate.quad(lambda x: _bz(x - d, g) ** 2, -xn, xp, limit=400, epsabs=1e-13)[0]

    h = 1e-5
    for d, g in ((0.04, 0.015), (0.05, 0.02), (-0.045, 0.013), (0.0, 0.018)):
        want = -(energy(d + h, g) - energy(d - h, g)) / (2 * h)
        got = float(law.force(np.array([g]), 0.0, np.array([d]), 0.0)[1][0])
        assert got == pytest.approx(want, rel=2e-3, abs=1e-4)
    assert law.force(0.015, 0.0, 0.05, 0.0)[1] < 0 < law.force(0.015, 0.0, -0.055, 0.0)[1]  # back over the stator
    assert abs(law.force(0.015, 0.0, 0.0, 0.0)[1]) < 0.05 * 2.0  # little with the array well inside
    assert law.force(0.015, 0.0, 0.05, 0.0)[0] == 0.0


def test_base_plate_keeps_part_of_the_overhangs_pull():
    law = make_law("end_effect", {"family": "base_plate", "e_p": 0.02, "e_n": 0.01, "h_f": 0.012})
    c = NOMINAL
    for g, d in ((0.012, 0.05), (0.02, -0.04), (0.025, 0.0), (0.016, 0.01)):
        over = max(0.0, d - 0.02) + max(0.0, -d - 0.01)
        o = 1 - over / L
        r = float(shape(g + 0.012).B / shape(g).B) ** 2  # a magnet's pull ~ B^2 at the plate, MODEL.md's B(g)
        f = [np.ones(1) for _ in range(4)]
        law.factors(np.array([g]), np.array([d]), f)
        km, kc, rho, thr = (float(x[0]) for x in f)
        sh = shape(g)
        assert c.C2 * sh.f2 * km * km * rho == pytest.approx(float(c.C2 * sh.f2 * (o + (1 - o) * r)), rel=1e-12)
        assert km * kc * rho * thr == pytest.approx(o, rel=1e-12)  # the C3 and C1 terms: the winding's overlap
        if over == 0.0:
            assert (km, kc, rho, thr) == pytest.approx((1, 1, 1, 1), abs=1e-12)
    # the plate helps more at large gaps (its extra distance matters less)
    loss = [1 - float(law.pull(np.array([g]), np.array([0.06]))[0]) for g in (0.01, 0.03)]
    assert loss[0] > loss[1] > 0


# --------------------------------------------------------------------------- saturation
def test_permeability_peak_is_not_monotone_in_the_gap():
    spec = {"family": "permeability_peak", "r": 0.05, "b_m": 0.5, "s_lo": 0.7, "s_hi": 0.5}
    law = make_law("saturation", spec)

    def b(g):
        return float(shape(g).B / shape(G_LO).B)

    g_m = optimize.brentq(lambda g: b(g) - 0.5, G_LO, G_HI)
    for g in (G_LO, 0.012, g_m, 0.025, G_HI):
        u = math.log(b(g) / 0.5)
        mu = math.exp(-(u**2) / (2 * (0.7 if u < 0 else 0.5) ** 2))
        want = 1.05 / (1 + 0.05 / mu)  # the iron's reluctance r / mu in series with the gap's
        f = [np.ones(1) for _ in range(4)]
        law.factors(np.array([g]), np.zeros(1), f)
        assert float(f[0][0]) == pytest.approx(want, rel=1e-12) and float(f[1][0]) == pytest.approx(want, rel=1e-12)
    loss = [float(law.loss(np.array([g]))[0]) for g in (G_LO, 0.012, g_m, 0.025, G_HI)]
    assert loss[2] == pytest.approx(0.0, abs=1e-12)
    assert loss[0] > loss[1] > loss[2] < loss[3] < loss[4]


def test_two_slope_flux_ceiling():
    law = make_law("saturation", {"family": "two_slope", "b_s": 0.75, "m": 0.4, "w_s": 1e-4})
    for g in (G_LO, 0.009, 0.011):
        b = float(shape(g).B / shape(G_LO).B)
        t = b if b < 0.75 else 0.75 + 0.4 * (b - 0.75)  # the two-slope curve
        f = [np.ones(1) for _ in range(4)]
        law.factors(np.array([g]), np.zeros(1), f)
        assert float(f[0][0]) == pytest.approx(t / b, rel=1e-9) and float(f[1][0]) == pytest.approx(t / b, rel=1e-9)
    assert float(law.loss(np.array([0.015]))[0]) == pytest.approx(0.0, abs=1e-12)  # nothing above the knee's gap
    # below the knee the pull ~ t(b)^2 grows with the slope m only
    bb = np.array([0.8, 0.9, 1.0])
    t = law.iron_flux(bb)
    assert np.diff(t) == pytest.approx(np.full(2, 0.04), rel=1e-6)


# ------------------------------------------------------------------- amplifier and delay
def _freq(law, w):
    A, B, C = law.ss(0)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def test_bessel4_response_and_flat_delay():
    law = make_law("amplifier_lag", {"family": "bessel4", "T": 5e-4})
    den = np.array([1.0, 10.0, 45.0, 105.0, 105.0])  # Thomson's fourth-order polynomial
    for w in (0.0, 300.0, 2000.0, 1e4):
        want = 105.0 / np.polyval(den, 1j * w * 5e-4)
        assert _freq(law, w) == pytest.approx(complex(want), rel=1e-9)
    for w in (10.0, 1000.0, 2500.0):  # the group delay stays T up to near the corner (maximally flat)
        ph = [np.angle(_freq(law, x)) for x in (w - 0.5, w + 0.5)]
        assert -(ph[1] - ph[0]) == pytest.approx(5e-4, rel=0.03)
    assert law.group_delay(1e-3) == pytest.approx(5e-4)
    tf = signal.TransferFunction([105.0], den * 5e-4 ** np.arange(4, -1, -1))
    t = np.linspace(0, 3e-3, 301)
    y = signal.step(tf, T=t)[1]
    _, Bd = law.discrete(0, t[150])
    assert (Bd @ np.array([1.0, 0.0])) @ law.ss(0)[2] == pytest.approx(y[150], rel=1e-7)


def test_notch_filtered_dip_and_delay():
    spec = {"family": "notch_filtered", "bandwidth_hz": 400.0, "notch_hz": 150.0, "zeta_p": 0.3, "zeta_z": 0.03}
    law = make_law("amplifier_lag", spec)
    wc, wn = 2 * math.pi * 400, 2 * math.pi * 150
    num = np.polymul([wc], [1, 2 * 0.03 * wn, wn * wn])
    den = np.polymul([1, wc], [1, 2 * 0.3 * wn, wn * wn])
    for w in (0.0, 100.0, wn, 5000.0):
        assert _freq(law, w) == pytest.approx(complex(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)), rel=1e-9)
    notch = abs(_freq(law, wn) * (1j * wn + wc) / wc)
    assert notch == pytest.approx(0.1, rel=1e-9)  # depth zeta_z / zeta_p
    ph = [np.angle(_freq(law, x)) for x in (0.05, 0.15)]
    assert -(ph[1] - ph[0]) / 0.1 == pytest.approx(law.group_delay(0.0), rel=1e-5)
    assert law.group_delay(0.0) == pytest.approx(1 / wc + 2 * 0.27 / wn)


# ------------------------------------------------------------------------- commutation
def test_angle_table_is_the_quantized_angle():
    for m, quant in ((0.0, np.round), (1.0, np.floor)):
        law = make_law("commutation_offset", {"family": "angle_table", "N": 24.0, "m": m, "theta0": 0.3, "r_s": 0.9999})
        d = np.linspace(-0.05, 0.05, 2001)
        th = KP * d + 0.3
        want = 2 * math.pi / 24 * quant(24 * th / (2 * math.pi)) - th
        u = 24 * th / (2 * math.pi) - 0.5 * m
        far = np.abs(np.abs(u - np.round(u)) - 0.5) > 0.02  # away from the steps
        assert law.angle(d)[far] == pytest.approx(want[far], abs=2e-3)
        x = np.linspace(0, 2 * k.tau / 24, 2001, endpoint=False)  # one step of the table
        assert np.mean(law.angle(x)) == pytest.approx(-m * math.pi / 24, abs=1e-4)
        assert law.angle(d + 2 * k.tau / 24) == pytest.approx(law.angle(d), abs=1e-9)  # period 2 tau / N
    iq, idd = law.rotate(np.array([0.5]), np.array([3.0]), np.array([0.01]))
    assert math.hypot(iq[0], idd[0]) == pytest.approx(math.hypot(0.5, 3.0))


def test_module_offsets_weigh_the_modules_under_the_array():
    eps = (0.04, -0.02, 0.03, -0.05, 0.01, 0.02)
    spec = {"family": "module_offsets", "delta0": 0.01, "l_m": 3 * k.tau, "x_b": 0.02}
    law = make_law("commutation_offset", {**spec, **{f"eps_{j}": e for j, e in enumerate(eps)}})

    def by_sampling(d):  # the array sampled at 200001 points, each assigned to its module
        x = np.linspace(d - L / 2, d + L / 2, 200001)
        j = np.floor((x - 0.02) / (3 * k.tau)).astype(int) + 3
        return 0.01 + np.mean(np.array(eps)[j])

    for d in (-0.06, -0.02, 0.0, 0.03, 0.055):
        assert float(law.angle(np.array([d]))[0]) == pytest.approx(by_sampling(d), abs=2e-6)
    # piecewise linear: constant second difference between breaks
    d = np.linspace(0.021, 0.029, 5)
    a = law.angle(d)
    assert np.diff(a, 2) == pytest.approx(np.zeros(3), abs=1e-12)


# --------------------------------------------------------------------------- eddy drag
def test_shorted_formers_damping_tensor_against_quadrature():
    law = make_law("eddy_drag", {"family": "shorted_formers", "c0": 12.0, "x0": 0.004})
    x1 = 0.004 + np.arange(-13, 14) * k.t1

    def flux(b, d, g):  # the array's flux through former b by quadrature of the strip field
        return integrate.quad(lambda x: _bz(x - d, g), x1[b], x1[b] + k.tau, limit=200, epsabs=1e-13)[0]

    g, d, h = 0.017, 0.012, 1e-6
    pg, pd = law.gradients(np.array([g]), np.array([d]))
    for b in (10, 13, 15):
        assert pd[0, b] == pytest.approx((flux(b, d + h, g) - flux(b, d - h, g)) / (2 * h), rel=1e-4, abs=1e-4)
        assert pg[0, b] == pytest.approx((flux(b, d, g + h) - flux(b, d, g - h)) / (2 * h), rel=1e-4, abs=1e-4)
    (cgg, cgd), (cdg, cdd) = law.tensor(np.array([g]), np.array([d]))
    assert cgd == cdg and cgg[0] * cdd[0] >= cgd[0] ** 2 and cgg[0] > 0 and cdd[0] > 0  # symmetric, positive
    fg, fd = law.force(np.array([g]), np.array([0.01]), np.array([d]), np.array([0.2]))
    assert (fg[0], fd[0]) == pytest.approx((-(cgg[0] * 0.01 + cgd[0] * 0.2), -(cgd[0] * 0.01 + cdd[0] * 0.2)))
    u = np.linspace(0, k.t1, 64, endpoint=False)
    assert np.mean(law.tensor(0 * u + G_REF, u)[1][1]) == pytest.approx(12.0, rel=1e-12)  # c0: the mean at 15 mm
    assert law.tensor(0 * u + G_REF, u + k.t1)[1][1] == pytest.approx(law.tensor(0 * u + G_REF, u)[1][1], rel=1e-3)


def test_armature_plate_drag_grows_with_the_currents():
    spec = {"family": "armature_plate", "c0": 10.0, "h_p": 0.01, "kappa_d": 0.1, "kappa_q": 0.05}
    law = make_law("eddy_drag", spec)
    for g, iq, idd in ((G_REF, 0.0, 0.0), (0.02, 1.0, 3.0), (0.012, -2.0, -1.0)):
        b = float(shape(g + 0.01).B / shape(G_REF + 0.01).B)  # the magnets' field at the plate, MODEL.md's B
        want = 10.0 * ((b - 0.1 * idd) ** 2 + (0.05 * iq) ** 2)
        fg, fd = law.force_i(np.array([g]), 0.3, np.array([0.0]), np.array([0.2]), np.array([iq]), np.array([idd]))
        assert fd[0] == pytest.approx(-0.2 * want, rel=1e-12) and fg[0] == 0.0
    assert float(law.coefficient(G_REF, 0.0, 0.0)) == pytest.approx(10.0)


# --------------------------------------------------------------------- out of the library
def test_floor_vibration_is_the_bases_inertial_force():
    spec = {"family": "machinery", "f1": 20.0, "A_g": 0.1, "A_d": 0.2, "h2": 0.4, "phi_g": 0.3, "phi_d": -1.0}
    law = make_law("floor_vibration", {**spec, "phi2": 0.7})
    law.reset(2)
    t0 = np.array([0.0, 10.0])
    law.advance(np.zeros((2, 2)), t0, 1e-3)
    fg, fd = law.held(np.zeros(2), np.zeros(2), 5e-4)
    tm = t0 + 2.5e-4
    w = 2 * math.pi * 20.0 * tm
    ag = 0.1 * (np.sin(w + 0.3) + 0.4 * np.sin(2 * w + 0.6 + 0.7))
    ad = 0.2 * (np.sin(w - 1.0) + 0.4 * np.sin(2 * w - 2.0 + 0.7))
    assert fg == pytest.approx(-k.Mv * ag, rel=1e-12) and fd == pytest.approx(-k.Mh * ad, rel=1e-12)
    fg2, _ = law.held(np.zeros(2), np.zeros(2), 5e-4)  # the second sub-step's midpoint
    w2 = 2 * math.pi * 20.0 * (t0 + 7.5e-4)
    assert fg2 == pytest.approx(-k.Mv * 0.1 * (np.sin(w2 + 0.3) + 0.4 * np.sin(2 * w2 + 1.3)), rel=1e-12)
    rec = law.recorded()
    assert rec["peak_force_g_n"] == pytest.approx(max(np.max(np.abs(fg)), np.max(np.abs(fg2))))


def test_drag_chain_ripples_with_twice_the_link_pitch():
    law = make_law("drag_chain", {"family": "polygon", "F_a": 0.3, "F_t": 0.1, "p_c": 0.012, "x_c": 0.003})
    d = np.linspace(-0.05, 0.05, 201)
    fg, fd = law.force(0 * d + 0.02, 0 * d, d, 0 * d)
    assert law.force(0 * d + 0.02, 0, d + 0.024, 0)[1] == pytest.approx(fd, abs=1e-12)
    assert law.force(0 * d + 0.02, 0, d + 0.012, 0)[1] == pytest.approx(-fd, abs=1e-12)
    assert np.max(np.abs(fd)) == pytest.approx(0.3, rel=1e-3) and np.max(np.abs(fg)) == pytest.approx(0.1, rel=1e-3)
    assert float(law.force(0.02, 0, 0.003, 0)[1]) == pytest.approx(-0.3)


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v8_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    for seed in range(120):
        sc = draw(seed, laws="v8")
        assert sc == draw(seed, laws="v8")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v8"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5))
            if getattr(law, "has_force_i", False):
                fg, fd = law.force_i(g, v, d, v, 0 * g + 5.0, 0 * g + 6.0)  # at the current limit
                assert np.all(np.isfinite(fd)) and np.max(np.abs(fd)) < 50.0 and not np.any(fg), (name, spec)
            if law.has_rotate:  # a rotation of at most 0.25 rad
                iq, idd = 0 * g + 0.5, 0 * g + 3.0
                q2, d2 = law.rotate(iq, idd, d)
                assert np.allclose(np.hypot(q2, d2), np.hypot(iq, idd)), (name, spec)
                assert np.max(np.abs(law.angle(d))) < 0.25, (name, spec)
            if name == "saturation":  # at most 45 % of the pull lost over the stops
                assert np.all(law.loss(g) < 0.45) and np.all(law.loss(g) >= -1e-12), (name, spec)
            if name == "amplifier_lag":
                A, B, C = law.ss(0)
                assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(1.0, abs=1e-9)
                assert np.all(np.linalg.eigvals(A).real < 0) and law.group_delay(1e-3) < 2.5e-3
    assert seen == {(n, f) for n, c in V8_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_every_v8_family_runs_in_the_closed_loop_and_changes_the_data(tmp_path):
    s = RigSettings(n_runs=2, duration=1.0)
    base = generate(tmp_path / "none", None, seed=7, settings=s)
    runs0 = [p.read_bytes() for p in sorted(base.glob("run_*.csv"))]
    # the 1 s runs stay within a few mm of d = 0: the base plate's stator ends put at the array's (the default's,
    # 20 and 30 mm past them, are never reached); every other family at its defaults
    extra = {"base_plate": {"e_p": 0.0, "e_n": 0.0}}
    for name, cls in V8_LAWS.items():
        for fam in cls.families:
            out = generate(tmp_path / fam, {name: {"family": fam, **extra.get(fam, {})}}, seed=7, settings=s)
            assert [p.read_bytes() for p in sorted(out.glob("run_*.csv"))] != runs0, (name, fam)
            truth = json.loads((out / "truth.json").read_text())
            e = truth["effects"][name]
            assert e["law_set"] == "v8" and e["family"] == fam
            size = e["effective_delay_s"] if name == "amplifier_lag" else e["peak_force_n"]
            assert np.isfinite(size) and (size != 0.0), (name, fam, e)
            assert truth["hover_error_rms_m"]["g"] < 2e-4 and truth["hover_error_rms_m"]["d"] < 3e-4, (name, fam)


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v7_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit 84b564b with the same call on an AMD EPYC
    # (numpy 2.4.6 at X86_V4); on another SIMD level the unquantized call against data/rig_digests.json ("v8_*",
    # recorded at 84b564b)
    cases = {
        "v7a": (
            {
                "friction": {"family": "power_law"},
                "saturation": {"family": "leakage_knee"},
                "commutation_offset": {"family": "tape_defect"},
            },
            13,
            {"X86_V4": "3875c1c3348a7d5d648b256ff30cdb4b39b764763e10509c9f82c918a250fe43"},
        ),
        "v7b": (
            {
                "end_effect": {"family": "phase_unbalance"},
                "amplifier_lag": {"family": "feedforward"},
                "eddy_drag": {"family": "damper_bars"},
            },
            17,
            {"X86_V4": "3a8a229d47fc0011f475abfa7f6070cbf94f09691a990bb219b5dba063e2c678"},
        ),
        "v7ool": (
            {"flexible_payload": None, "cogging": {"family": "tip_saturation"}},
            19,
            {"X86_V4": "709f5cf64a2f4d5f58c557af0d133784eeb70deb560526d2220721c9d87032a2"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v8")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v8_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "cogging": {"family": "hysteretic_teeth"},
        "friction": {"family": "grease_churning"},
        "amplifier_lag": {"family": "notch_filtered"},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "amplifier_lag+cogging+friction"
    assert all(e["law_set"] == "v8" for e in truth["effects"].values())
    assert truth["effects"]["cogging"]["peak_force_n"] > 0.05
    assert 0.0 < truth["effects"]["friction"]["peak_force_d_n"] < 2.0  # the held force, recorded per period
    assert truth["effects"]["amplifier_lag"]["effective_delay_s"] > 0.0
    ool = generate(tmp_path / "c", {"floor_vibration": {"A_g": 0.1, "A_d": 0.1, "h2": 0.0}}, seed=5, settings=s)
    t2 = json.loads((ool / "truth.json").read_text())
    e = t2["effects"]["floor_vibration"]
    assert t2["expected_verdict"] == "unexplained" and e["library"] is False
    assert e["peak_force_g_n"] == pytest.approx(0.1 * k.Mv, rel=0.01)  # the base's peak acceleration times the mass
