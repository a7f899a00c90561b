"""The eighteenth law set of the independent rig (maglev_ocp.rigsim.laws_v18, ``laws="v18"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (the edge triangle as its Fourier series of odd harmonics over n^2, energies
differentiated by finite differences, the magnetic circuit's flux density squared, Reynolds' squeeze film's cube law
and the film's shear, Archard's flash-temperature softening, the fringe's ramp limits, the yoke's series reluctance,
the soft limiter's hard-clip limit, Weiss's self-consistent field by brentq, the interpolator's sinc^3 at low
frequency and the legs' sum of lags multiplied out, the stationary loop's phase at the electrical frequency, the
octant arctangent's error and symmetries, the reflection from a moving magnetizable conductor by its boundary
conditions, the rectifier's dead zone, the reel's energy, the scale's expansion), tolerances fixed beforehand; every
family runs in the closed loop and changes the data; the v18 draw is seeded, covers every family, stays finite and
bounded over the rig's envelope; datasets generated from the seventeenth set are the same bytes as at commit b63247d
(before this set; the earlier sets' draws: test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets
from scipy.optimize import brentq

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim import laws_v17 as v17
from maglev_ocp.rigsim.laws_v18 import V18_LAWS, law_class, make_law

G_LO, G_HI = k.g_stop
L = k.pm * k.tau
G15 = 0.015
K = math.pi / k.tau


def _field(g):
    """MODEL.md's ``B(g)``, written out again."""
    coef = (4 / math.pi) * k.Br * math.sin(math.pi * k.taup / (2 * k.tau)) * math.sinh(math.pi * k.hm / k.tau)
    return coef / np.sinh(math.pi * (k.hm + np.asarray(g, dtype=float)) / k.tau)


def _grad(fun, g, d, h=1e-7):
    """``(-dW/dg, -dW/dd)`` by central differences."""
    return -(fun(g + h, d) - fun(g - h, d)) / (2 * h), -(fun(g, d + h) - fun(g, d - h)) / (2 * h)


def _ones(n):
    return [np.ones(n) for _ in range(4)]


def _factors(law, g, d):
    g, d = np.atleast_1d(np.asarray(g, dtype=float)), np.atleast_1d(np.asarray(d, dtype=float))
    g, d = np.broadcast_arrays(g, d)
    f = _ones(g.size)
    law.factors(g.ravel(), d.ravel(), f)
    return f[0], f[1]


def test_every_family_resolves_to_the_eighteenth_set_and_earlier_ones_as_before():
    for name, cls in V18_LAWS.items():
        for fam in cls.families:
            assert law_class(name, fam) is cls, (name, fam)
            assert make_law(name, {"family": fam}).describe()["law_set"] == "v18"
    for reg in v17.REGISTRIES:
        for name, cls in reg.items():
            for fam in cls.families:
                assert law_class(name, fam) is v17.law_class(name, fam), (name, fam)


# ----------------------------------------------------------------------------- cogging
def test_edge_triangle_is_the_odd_harmonics_over_n_squared_and_conservative():
    xi0, x0 = 3.0, 0.004
    law = make_law("cogging", {"family": "edge_triangle", "xi0": xi0, "x0": x0})
    kap = 2 * math.pi / k.t1

    def energy(g, d):  # the triangle's Fourier series (8 / pi^2) sum (-1)^m sin((2m+1) th) / (2m+1)^2, integrated
        th = kap * (d - x0)
        s = sum((-1) ** m * np.cos((2 * m + 1) * th) / (2 * m + 1) ** 3 for m in range(400))
        return xi0 * np.exp(-kap * (g - 0.01)) / kap * 8 / math.pi**2 * s

    d = np.linspace(-0.02, 0.02, 23)
    for g in (G_LO, G15, 0.024):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d, h=1e-7)
        a = xi0 * math.exp(-kap * (g - 0.01))
        assert np.allclose(fd, wd, atol=1e-5 * a) and np.allclose(fg, wg, atol=1e-5 * a), g
    # the peak xi0 at 10 mm a quarter period on, the force linear in between (a triangle)
    q = x0 + k.t1 / 4
    assert law.force(0.01, 0.0, q, 0.0)[1] == pytest.approx(xi0, rel=1e-12)
    assert law.force(0.01, 0.0, x0 + k.t1 / 12, 0.0)[1] == pytest.approx(xi0 / 3, rel=1e-9)
    dd = np.arange(512) * k.t1 / 512 + x0
    spec = np.abs(np.fft.rfft(law.force(0.01 + 0 * dd, 0 * dd, dd, 0 * dd)[1])) / 256
    assert spec[1] == pytest.approx(8 * xi0 / math.pi**2, rel=1e-4)
    assert spec[3] / spec[1] == pytest.approx(1 / 9, rel=1e-3) and spec[2] < 1e-12 * xi0


def test_recoil_circuit_follows_the_gap_flux_density_squared():
    xi0, mr, x0 = 3.0, 1.05, 0.002
    law = make_law("cogging", {"family": "recoil_circuit", "xi0": xi0, "mu_r": mr, "x0": x0})

    def bg(g):  # the magnet (its recoil permeability) in series with the gap: B_g = B_r hm / (hm + mu_r g)
        return k.Br * k.hm / (k.hm + mr * g)

    def energy(g, d):
        return k.t1 / (2 * math.pi) * xi0 * (bg(g) / bg(0.01)) ** 2 * np.cos(2 * math.pi * (d - x0) / k.t1)

    d = np.linspace(-0.02, 0.02, 19)
    for g in (G_LO, 0.01, G15, G_HI):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d, h=1e-8)
        assert np.allclose(fd, wd, rtol=1e-6, atol=1e-8) and np.allclose(fg, wg, rtol=1e-6, atol=1e-8), g
    assert law.force(0.01, 0.0, x0 + k.t1 / 4, 0.0)[1] == pytest.approx(xi0, rel=1e-12)
    f20 = law.force(0.02, 0.0, x0 + k.t1 / 4, 0.0)[1]
    assert f20 == pytest.approx(xi0 * ((k.hm + mr * 0.01) / (k.hm + mr * 0.02)) ** 2, rel=1e-12)


# ---------------------------------------------------------------------------- friction
def test_oil_pad_squeezes_as_the_cube_and_shears_as_the_film():
    p = {"family": "oil_pad", "Fc_g": 0.0, "Fc_d": 0.0, "c_sq": 0.5, "c_sh": 0.8, "h_m": 0.005}
    law = make_law("friction", p)
    v = 0.01
    h = {g: 0.005 + g - G_LO for g in (G_LO, 0.012, G15, 0.03)}
    for g, hg in h.items():  # Reynolds' parallel plates: 3 pi eta R^4 h_dot / (2 h^3); Couette: eta A v / h
        assert -law.force(g, v, 0.0, 0.0)[0] / v == pytest.approx(0.5 * (h[G15] / hg) ** 3, rel=1e-12)
        assert -law.force(g, 0.0, 0.0, v)[1] / v == pytest.approx(0.8 * h[G15] / hg, rel=1e-12)
    assert law.force(G15, -v, 0.0, 0.0)[0] == pytest.approx(-law.force(G15, v, 0.0, 0.0)[0], rel=1e-12)
    assert law.force(G15, 0.0, 0.01, 0.2)[0] == 0.0 and law.force(G15, 0.2, 0.01, 0.0)[1] == 0.0
    c = make_law("friction", {**p, "Fc_d": 0.2})
    assert c.force(G15, 0.0, 0.0, 0.1)[1] == pytest.approx(-0.2 * math.tanh(100) - 0.08, rel=1e-12)


def test_flash_temperature_halves_the_friction_at_v_t():
    p = {"family": "flash_temperature", "Fc_g": 0.1, "Fc_d": 0.3, "b_g": 0.0, "b_d": 0.0, "v_T": 0.1}
    law = make_law("friction", p)
    # Archard: the flash temperature rises as sqrt(v) at high Peclet number; the junctions' shear falls with it
    for v in (0.025, 0.1, 0.4):
        assert law.force(G15, 0.0, 0.02, v)[1] == pytest.approx(-0.3 / (1 + math.sqrt(v / 0.1)), rel=1e-9)
    assert law.force(G15, 0.0, 0.0, 0.1)[1] == pytest.approx(-0.15, rel=1e-9)
    assert law.force(G15, 0.0, 0.0, -0.1)[1] == pytest.approx(0.15, rel=1e-9)
    assert abs(law.force(G15, 0.0, 0.0, 1e-3)[1]) > 0.9 * 0.3 * math.tanh(1)  # near rest: Coulomb
    assert law.force(G15, 0.05, 0.0, 0.0)[0] == pytest.approx(-0.1 * math.tanh(50), rel=1e-12)
    v = np.linspace(0.01, 0.5, 50)
    assert np.all(np.diff(-law.force(G15 + 0 * v, 0 * v, 0 * v, v)[1]) < 0)  # velocity weakening


# -------------------------------------------------------------------------- end effects
def test_gap_fringe_is_a_ramp_softened_over_the_gap():
    ep, en, cf = 0.02, 0.03, 0.5
    law = make_law("end_effect", {"family": "gap_fringe", "e_p": ep, "e_n": en, "c_f": cf})
    for g in (0.01, 0.025):
        km, kc = _factors(law, g, 0.0)
        assert np.array_equal(km, kc) and km[0] > 0.999 - 4 * cf * g / L
        # far past the end: the bare overhang lost (the ramp), to e^{-x / (c_f g)}
        km, _ = _factors(law, g, ep + 0.06)
        assert km[0] ** 2 == pytest.approx(1 - 0.06 / L, abs=2 * cf * g * math.exp(-0.06 / (cf * g)) / L + 1e-12)
        # at the end itself: c_f g log 2 lost
        km, _ = _factors(law, g, ep)
        far = cf * g * math.log1p(math.exp(-(ep + en) / (cf * g)))  # the other end, ep + en away
        assert km[0] ** 2 == pytest.approx(1 - (cf * g * math.log(2) + far) / L, rel=1e-12)
    a, b = _factors(law, 0.01, ep)[0][0], _factors(law, 0.025, ep)[0][0]
    assert b < a  # a larger gap fringes further


def test_yoke_return_adds_a_series_reluctance_near_the_ends():
    ep, en, re_, lam = 0.02, 0.025, 0.2, 0.008
    law = make_law("end_effect", {"family": "yoke_return", "e_p": ep, "e_n": en, "r_e": re_, "lam": lam})

    def share(x):  # the logistic share near an end
        return 1 / (1 + math.exp(x / lam))

    for d in (-0.06, -0.01, 0.0, 0.02, 0.05):
        # a magnetic circuit: flux = mmf / (R0 (1 + r_e (u_p + u_n))), normalized at d = 0
        r = 1 + re_ * (share(ep - d) + share(en + d))
        r0 = 1 + re_ * (share(ep) + share(en))
        km, kc = _factors(law, G15, d)
        assert km[0] == pytest.approx(r0 / r, rel=1e-12) and kc[0] == km[0]
    far = _factors(law, G15, 0.5)[0][0]
    assert far == pytest.approx((1 + re_ * (share(ep) + share(en))) / (1 + re_), rel=1e-9)


# --------------------------------------------------------------------------- saturation
def test_soft_limiter_meets_its_loss_and_tends_to_a_hard_clip():
    for lo, p in ((0.05, 1.0), (0.03, 3.0)):
        law = make_law("saturation", {"family": "soft_limiter", "l_lo": lo, "p": p})
        g = np.array([G_LO, 0.012, G15, G_HI])
        km, kc = _factors(law, g, 0 * g)
        x = _field(g) / _field(G_LO)
        xs = brentq(lambda s, lo=lo, p=p: (1 + s ** (-2 * p)) ** (-1 / (2 * p)) - (1 - lo), 1e-3, 1e3)
        y = x / (1 + (x / xs) ** (2 * p)) ** (1 / (2 * p))  # Rapp's output
        assert np.allclose(km, y / x, rtol=1e-12) and np.array_equal(km, kc) and km[0] == pytest.approx(1 - lo)
        assert np.all(np.diff(km) > 0)
    sharp = make_law("saturation", {"family": "soft_limiter", "l_lo": 0.05, "p": 60.0})
    km, _ = _factors(sharp, np.array([G_LO, 0.02]), np.zeros(2))
    assert km[0] == pytest.approx(0.95) and km[1] == pytest.approx(1.0, abs=1e-6)  # the clip at 0.95 of the stop


def test_weiss_field_is_the_self_consistent_mean_field():
    for lo, lam in ((0.05, 0.5), (0.03, 0.75), (0.07, 0.3)):
        law = make_law("saturation", {"family": "weiss_field", "l_lo": lo, "lam": lam})

        def m_of(a, x, lam=lam):
            return brentq(lambda m: m - math.tanh(a * x + lam * m), 0.0, 1.0, xtol=1e-15)

        def kept(a, x, lam=lam):
            return (1 - lam) * m_of(a, x) / (a * x)

        a = brentq(lambda a, lo=lo: kept(a, 1.0) - (1 - lo), 1e-3, 50.0, xtol=1e-14)
        g = np.array([G_LO, 0.012, 0.02, G_HI])
        km, _ = _factors(law, g, 0 * g)
        want = [kept(a, xx) for xx in _field(g) / _field(G_LO)]
        assert np.allclose(km, want, atol=1e-8) and km[0] == pytest.approx(1 - lo, abs=1e-8), lam
    # lam = 0: no molecular field, Langevin's J = 1/2 case: tanh(a x) / (a x)
    free = make_law("saturation", {"family": "weiss_field", "l_lo": 0.05, "lam": 0.0})
    a = brentq(lambda a: math.tanh(a) / a - 0.95, 1e-3, 50.0, xtol=1e-14)
    x = float(_field(0.02) / _field(G_LO))
    assert _factors(free, 0.02, 0.0)[0][0] == pytest.approx(math.tanh(a * x) / (a * x), abs=1e-8)


# ------------------------------------------------------------------- amplifier and delay
def _response(law, w):
    A, B, C = law.ss(0)
    return np.array([C @ np.linalg.solve(1j * x * np.eye(A.shape[0]) - A, B[:, 0]) for x in np.atleast_1d(w)])


def test_cic_reference_is_sinc_cubed_at_low_frequency_behind_the_loop():
    T, fc = 1e-4, 500.0
    law = make_law("amplifier_lag", {"family": "cic_reference", "T": T, "f_c": fc})
    wc = 2 * math.pi * fc
    for w in (50.0, 500.0, 3000.0):
        s = 1j * w
        pade = 1 / (1 + s * T / 2 + (s * T) ** 2 / 12) ** 3
        assert _response(law, w)[0] == pytest.approx(pade / (1 + s / wc), rel=1e-9)
        sinc3 = ((1 - np.exp(-s * T)) / (s * T)) ** 3  # the interpolator's exact response
        assert abs(pade - sinc3) < 0.02 * (w * T) ** 3 + 1e-12
    assert law.group_delay(1e-3) == pytest.approx(1.5 * T + 1 / wc, rel=1e-12)
    A, B, C = law.ss(0)
    assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(1.0, abs=1e-12)


def test_interleaved_legs_are_the_mean_of_two_lags():
    f1, f2 = 200.0, 900.0
    law = make_law("amplifier_lag", {"family": "interleaved_legs", "f_1": f1, "f_2": f2})
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
    for w in (30.0, w1, 5000.0, 3e4):
        s = 1j * w
        assert _response(law, w)[0] == pytest.approx(0.5 / (1 + s / w1) + 0.5 / (1 + s / w2), rel=1e-9)
    assert law.group_delay(1e-3) == pytest.approx(0.5 / w1 + 0.5 / w2, rel=1e-12)
    same = make_law("amplifier_lag", {"family": "interleaved_legs", "f_1": f1, "f_2": f1})
    assert _response(same, 700.0)[0] == pytest.approx(1 / (1 + 700j / w1), rel=1e-9)  # equal legs: one lag


# ------------------------------------------------------------------------- commutation
def _angle(law, g, d, v=0.0, t=0.0):
    law.reset(0)
    X = np.zeros((np.size(d), 6))
    X[:, 0], X[:, 2], X[:, 3] = g, d, v
    q2, d2 = law.rotate_at(np.zeros(np.size(d)), np.ones(np.size(d)), X, t)
    return np.arctan2(-q2, d2)  # rotating (0, 1) by +delta gives i_q = -sin(delta)


def test_stationary_pi_lags_by_the_loops_phase_at_the_electrical_frequency():
    fc = 80.0
    law = make_law("commutation_offset", {"family": "stationary_pi", "delta0": 0.01, "f_c": fc})
    for v in (-0.4, -0.05, 0.0, 0.1, 0.5):
        we = math.pi * v / k.tau  # the electrical frequency of the references
        h = (2 * math.pi * fc) / (1j * we + 2 * math.pi * fc)  # the loop at j w_e
        assert _angle(law, G15, np.array([0.02]), v)[0] == pytest.approx(0.01 + np.angle(h), abs=1e-12), v
    assert law.angle_at(0.01, 0.03, 0.2) == law.angle_at(0.03, -0.03, 0.2)  # no gap or position dependence


def test_atan_approx_is_the_octant_arctangents_error():
    for c, bound in ((0.0, 0.0711), (0.273, 0.0038)):  # Rajan et al. 2006: the linear and the corrected forms
        law = make_law("commutation_offset", {"family": "atan_approx", "delta0": 0.0, "c": c, "x_0": 0.004})
        th = np.linspace(-math.pi, math.pi, 4001)[:-1]
        d = 0.004 + th * k.tau / math.pi
        got = _angle(law, G15, d)
        assert np.max(np.abs(got)) == pytest.approx(bound, abs=2e-4)
        first = (th > 0) & (th < math.pi / 4)  # in the first octant: (pi/4) tan th + c tan th (1 - tan th) - th
        z = np.tan(th[first])
        assert np.allclose(got[first], math.pi / 4 * z + c * z * (1 - z) - th[first], atol=1e-12)
        # the octants' symmetries: odd about 0 and about pi/4 (swapping sine and cosine), period pi/2
        assert np.allclose(law.angle_at(G15, 0.004 - (d - 0.004)), -law.angle_at(G15, d), atol=1e-12)
        q = 0.004 + (math.pi / 2 - th) * k.tau / math.pi
        assert np.allclose(law.angle_at(G15, q), -law.angle_at(G15, d), atol=1e-12)
        assert np.allclose(law.angle_at(G15, d + k.tau / 2), law.angle_at(G15, d), atol=1e-12)
    assert law.angle_at(0.01, 0.02, 0.3) == law.angle_at(0.03, 0.02, 0.0)  # no gap or speed dependence


# --------------------------------------------------------------------------- eddy drag
def test_solid_yoke_is_the_reflection_from_a_moving_magnetizable_conductor():
    fa, mr, vs = 10.0, 60.0, 0.02
    law = make_law("eddy_drag", {"family": "solid_yoke", "F_a": fa, "mu_r": mr, "v_s": vs})

    def reflection(v):  # A = A_i e^{kz} + A_r e^{-kz} above, A_c e^{gamma z} in the plate (z < 0): A and H_x continuous
        gam = np.sqrt(1 + 1j * v / vs)  # gamma / k
        m = np.array([[1.0, -1.0], [-1.0, -gam / mr]])  # unknowns (A_r, A_c) per unit A_i (k = 1)
        return np.linalg.solve(m, np.array([-1.0, -1.0]))[0]

    r0 = (mr - 1) / (mr + 1)
    assert reflection(0.0).real == pytest.approx(r0, rel=1e-12)  # an iron image at rest
    for g, v in ((G15, 0.05), (G15, 0.3), (0.011, -0.2), (0.025, 0.4)):
        b2 = (_field(g) / _field(G15)) ** 2
        r = reflection(v)
        fg, fd = law.force(g, 0.0, 0.0, v)
        assert fd == pytest.approx(fa * b2 * r.imag / r0, rel=1e-9) and fd * v < 0  # a drag
        assert fg == pytest.approx(fa * b2 * (1 - r.real / r0), rel=1e-9) and fg > 0  # the pull weakens
    assert np.allclose(law.force(G15, 0.0, 0.0, 0.0), 0.0, atol=1e-12)
    # low speed: a viscous drag F_a s mu_r / (mu_r + 1)^2 / R0, s = v / v_s
    v = 1e-5
    assert law.force(G15, 0.0, 0.0, v)[1] == pytest.approx(-fa * (v / vs) * mr / (mr + 1) ** 2 / r0, rel=1e-6)


def test_idle_rectifier_drags_only_past_the_link_voltage():
    law = make_law("eddy_drag", {"family": "idle_rectifier", "c_r": 8.0, "v_th": 0.1})
    assert abs(law.force(G15, 0.0, 0.0, 0.05)[1]) < 8.0 * 5e-3 * math.exp(-10)  # below: the diodes block
    assert law.force(G15, 0.0, 0.0, 0.3)[1] == pytest.approx(-8.0 * 0.2, rel=1e-12)  # above: the EMF's excess / R
    assert law.force(G15, 0.0, 0.0, -0.3)[1] == pytest.approx(8.0 * 0.2, rel=1e-12)
    assert law.force(G15, 0.0, 0.0, 0.1)[1] == pytest.approx(-8.0 * 5e-3 * math.log(2), rel=1e-12)  # the knee
    b = float(_field(0.025) / _field(G15))
    assert law.force(0.025, 0.0, 0.0, 0.4)[1] == pytest.approx(-8.0 * b * (b * 0.4 - 0.1), rel=1e-9)
    assert law.force(G15, 0.4, 0.0, 0.4)[0] == 0.0


# ------------------------------------------------------------------------------ out of the library
def test_spring_reel_is_the_gradient_of_its_springs_energy():
    t0, ks, xr, hr = 0.6, 6.0, 0.2, -0.04
    law = make_law("spring_reel", {"T0": t0, "k_s": ks, "x_r": xr, "h_r": hr})
    l0 = math.hypot(xr, hr)

    def energy(g, d):  # the spring's energy over the cable paid out: T0 l + k_s (l - l0)^2 / 2
        ln = np.hypot(xr - d, hr + g - G15)
        return t0 * ln + 0.5 * ks * (ln - l0) ** 2

    d = np.linspace(-0.06, 0.06, 13)
    for g in (G_LO, G15, G_HI):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d)
        assert np.allclose(fd, wd, rtol=1e-6, atol=1e-8) and np.allclose(fg, wg, rtol=1e-6, atol=1e-8), g
    fg, fd = law.force(G15, 0.0, 0.0, 0.0)
    assert math.hypot(fg, fd) == pytest.approx(t0, rel=1e-12) and fd > 0 and fg > 0  # towards the reel, down


def test_expanding_scale_reads_short_from_its_clamp_as_it_warms():
    ce, tau, xf = 1e-4, 20.0, 0.1
    law = make_law("expanding_scale", {"c_e": ce, "tau_th": tau, "x_f": xf})
    g = np.array([[0.012, 0.015, 0.02]])
    d = np.array([[-0.05, 0.1, 0.03]])
    t = np.array([[0.0, 5.0, 1e4]])
    gr, dr = law.read_at(g, d, t)
    assert np.array_equal(gr, g)
    assert dr[0, 0] == d[0, 0]  # cold at the start
    assert dr[0, 1] == pytest.approx(0.1, abs=1e-15)  # at the clamp: no error
    assert dr[0, 2] - 0.03 == pytest.approx(-ce * (0.03 - xf), rel=1e-9)  # warm: alpha dT (x - x_f)
    half = law.read_at(g, d, np.full((1, 3), tau * math.log(2)))[1]
    assert half[0, 0] + 0.05 == pytest.approx(0.5 * ce * (0.05 + xf), rel=1e-9)


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v18_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    for seed in range(160):
        sc = draw(seed, laws="v18")
        assert sc == draw(seed, laws="v18")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v18"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5))
            if getattr(law, "has_rotate_at", False):  # at most 0.45 rad over the stops, +-60 mm, +-0.5 m/s
                assert np.max(np.abs(law.angle_at(g, d, v, 0.00599))) < 0.45, (name, spec)
            if getattr(law, "has_read_at", False):  # readings within 1 mm over the envelope (law_checks' bound)
                gr, dr = law.read_at(g, d, None)
                assert np.max(np.abs(gr - g)) < 1e-3 and np.max(np.abs(dr - d)) < 1e-3, (name, spec)
            if name == "amplifier_lag":
                A, B, C = law.ss(0)
                assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(1.0, abs=1e-9)
                assert np.all(np.linalg.eigvals(A).real < 0) and law.group_delay(1e-3) < 3e-3
    assert seen == {(n, f) for n, c in V18_LAWS.items() for f in c.families}


def test_every_v18_family_runs_in_the_closed_loop_and_changes_the_data(tmp_path):
    s = RigSettings(n_runs=1, duration=0.6)  # one run each: the file's time within 40 s on a shared machine
    base = generate(tmp_path / "none", None, seed=7, settings=s)
    runs0 = [p.read_bytes() for p in sorted(base.glob("run_*.csv"))]
    # the short runs stay within a few mm of d = 0 and near the hover gap: the ends put near, the scale warm soon,
    extra = {
        "gap_fringe": {"e_p": -0.002, "e_n": 0.02},
        "yoke_return": {"e_p": 0.0, "e_n": 0.02},
        "warming_scale": {"tau_th": 0.2, "c_e": 1.5e-4},
        "idle_rectifier": {"v_th": 0.0, "c_r": 12.0},  # the short runs move slowly: no threshold
    }
    for name, cls in V18_LAWS.items():
        for fam in cls.families:
            out = generate(tmp_path / fam, {name: {"family": fam, **extra.get(fam, {})}}, seed=7, settings=s)
            assert [p.read_bytes() for p in sorted(out.glob("run_*.csv"))] != runs0, (name, fam)
            truth = json.loads((out / "truth.json").read_text())
            e = truth["effects"][name]
            assert e["law_set"] == "v18" and e["family"] == fam
            sizes = {"amplifier_lag": "effective_delay_s", "expanding_scale": "peak_error_d_m"}
            size = sizes.get(name, "peak_force_n")
            assert np.isfinite(np.max(e[size])) and np.max(np.abs(e[size])) != 0.0, (name, fam, e)
            assert truth["hover_error_rms_m"]["g"] < 2e-4 and truth["hover_error_rms_m"]["d"] < 4e-4, (name, fam)


def test_v17_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit b63247d (before this set) with the same call
    # on an AMD EPYC (numpy at X86_V3); on another SIMD level the unquantized call against data/rig_digests.json
    # ("v18_*", recorded at b63247d)
    cases = {
        "v17a": (
            {
                "cogging": {"family": "line_dipoles"},
                "friction": {"family": "skewed_rollers"},
                "end_effect": {"family": "end_poles"},
            },
            47,
            {"X86_V3": "0159f7f3cd1c802301bd2e140def8ecd59962ddd91861576c8dff59b842aa4e7"},
        ),
        "v17b": (
            {
                "saturation": {"family": "brillouin"},
                "amplifier_lag": {"family": "output_lc"},
                "eddy_drag": {"family": "excess_loss"},
            },
            53,
            {"X86_V3": "8d9d9f917ce45235c34d7292c16b95ead15a93ce14f45df28d13957c6273c516"},
        ),
        "v17ool": (
            {"hanging_cable": None, "probe_target_edge": None, "commutation_offset": {"family": "held_angle"}},
            59,
            {"X86_V3": "a7533284bc9e386a4f5eab28167cada89ad9a975fe68924d91d15bdc6ee0ae01"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v18")
