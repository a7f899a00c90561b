"""The seventeenth law set of the independent rig (maglev_ocp.rigsim.laws_v17, ``laws="v17"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (the slot dipoles' harmonic series summed term by term, energies differentiated by finite
differences, the oblique ends' overhang sampled across the depth, the clipped wave's fundamental from an FFT,
Brillouin's function as the Boltzmann mean over the 2J + 1 states, the filters' responses multiplied out from their
sections, the held angle from the position at the last update, the two-axis sensor's field summed over the
magnetization's FFT, Bertotti's loss scaling, the search coil's linkage differentiated numerically, the catenary
solved again and its weight's height integrated, the probe's edge), tolerances fixed beforehand; every family runs
in the closed loop and changes the data; the v17 draw is seeded, covers every family, stays finite and bounded over
the rig's envelope; datasets generated from the sixteenth set are the same bytes as at commit 0275ed6 (before this
set; the earlier sets' draws: test_rigsim_draw_bytes.py).
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
from maglev_ocp.rigsim import laws_v16 as v16
from maglev_ocp.rigsim.laws_v17 import V17_LAWS, law_class, make_law

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


def _bisect(fun, lo, hi, n=200):
    """The root of an increasing ``fun`` on ``[lo, hi]``, scalar bisection."""
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fun(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


def test_every_family_resolves_to_the_seventeenth_set_and_earlier_ones_as_before():
    for name, cls in V17_LAWS.items():
        for fam in cls.families:
            assert law_class(name, fam) is cls, (name, fam)
            assert make_law(name, {"family": fam}).describe()["law_set"] == "v17"
    for reg in v16.REGISTRIES:
        for name, cls in reg.items():
            for fam in cls.families:
                assert law_class(name, fam) is v16.law_class(name, fam), (name, fam)


# ----------------------------------------------------------------------------- cogging
def test_line_dipoles_are_the_geometric_series_of_slot_harmonics():
    xi0, h0, x0 = 3.0, 0.004, 0.003
    law = make_law("cogging", {"family": "line_dipoles", "xi0": xi0, "h0": h0, "x0": x0})
    q0 = math.exp(-2 * math.pi * h0 / k.t1)

    def energy(g, d):  # harmonic n: q^n, its energy 1/n of its force's (t1 / 2 pi) share, summed term by term
        q = np.exp(-2 * math.pi * (g - 0.01 + h0) / k.t1)
        th = 2 * math.pi * (d - x0) / k.t1
        return k.t1 / (2 * math.pi) * xi0 / q0 * sum(q**n * np.cos(n * th) / n for n in range(1, 400))

    d = np.linspace(-0.02, 0.02, 17)
    for g in (G_LO, 0.012, G15, 0.024):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d, h=1e-7)
        assert np.allclose(fd, wd, atol=1e-6 * xi0 / q0) and np.allclose(fg, wg, atol=1e-6 * xi0 / q0), g
    dd = np.arange(256) * k.t1 / 256 + x0
    spec = np.fft.rfft(law.force(0.01 + 0 * dd, 0 * dd, dd, 0 * dd)[1]) / 128
    assert abs(spec[1]) == pytest.approx(xi0, rel=1e-9)  # the fundamental xi0 at 10 mm
    assert abs(spec[2]) / abs(spec[1]) == pytest.approx(q0, rel=1e-9)  # the harmonics fall geometrically


def test_yoke_holes_are_the_gradient_of_the_holes_energy():
    fh, hy, lh, pb, xb = 0.3, 0.02, 0.005, 0.05, 0.011
    law = make_law("cogging", {"family": "yoke_holes", "F_h": fh, "h_y": hy, "l_h": lh, "p_b": pb, "x_b": xb})
    holes = np.array([x for x in xb + pb * np.arange(-10, 11) if abs(x) <= 0.17])

    def energy(g, d):
        foot = sum(0.5 * (np.tanh((x - d + L / 2) / lh) - np.tanh((x - d - L / 2) / lh)) for x in holes)
        return 2 * lh * fh * (_field(g + hy) / _field(G15 + hy)) ** 2 * foot

    d = np.linspace(-0.06, 0.06, 41)
    for g in (0.01, G15, 0.025):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d, h=1e-8)
        assert np.allclose(fd, wd, rtol=1e-5, atol=1e-7) and np.allclose(fg, wg, rtol=1e-5, atol=1e-7), g
    # one hole's edge alone, far from the others: the pull F_h at 15 mm
    one = make_law("cogging", {"family": "yoke_holes", "F_h": fh, "h_y": hy, "l_h": lh, "p_b": 0.3, "x_b": 0.0})
    assert one.force(G15, 0.0, L / 2, 0.0)[1] == pytest.approx(fh, rel=1e-9)


# ---------------------------------------------------------------------------- friction
def test_skewed_rollers_resist_in_their_own_axes():
    fr, fl, a = 0.1, 0.5, 0.05
    p = {"family": "skewed_rollers", "F_r": fr, "F_l": fl, "alpha": a, "b_g": 0.0, "b_d": 0.0}
    law = make_law("friction", p)
    u, n = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])  # (d, g)
    rng = np.random.default_rng(3)
    for _ in range(20):
        v = rng.normal(size=2) * 0.05  # (d_dot, g_dot)
        fg, fd = law.force(G15, v[1], 0.0, v[0])
        f = np.array([fd, fg])
        assert f @ u == pytest.approx(-fr * math.tanh(v @ u / 1e-3), abs=1e-12)
        assert f @ n == pytest.approx(-fl * math.tanh(v @ n / 1e-3), abs=1e-12)
        assert f @ v <= 0.0  # dissipative
    # a fast move along d alone pushes the gap axis by F_l cos(alpha) - F_r sin(alpha)
    fg, _ = law.force(G15, 0.0, 0.0, 0.5)  # tanh(25) = 1 to 4e-22
    assert fg == pytest.approx(fl * math.cos(a) - fr * math.sin(a), rel=1e-9)
    plain = make_law("friction", {**p, "alpha": 0.0})
    assert plain.force(G15, 0.0, 0.0, 0.2)[0] == 0.0 and plain.force(G15, 0.2, 0.0, 0.0)[0] == pytest.approx(-fl)


def test_grease_banks_raise_the_viscous_drag_where_the_moves_turn():
    p = {"family": "grease_banks", "Fc_g": 0.0, "Fc_d": 0.0, "b_g": 0.0, "b_d": 0.4, "b_e": 6.0, "x_e": 0.04}
    law = make_law("friction", {**p, "w_e": 0.01})
    v = 0.05
    assert -law.force(G15, 0.0, 0.04, v)[1] / v == pytest.approx(0.4 + 6.0 * (1 + math.exp(-64)), rel=1e-12)
    assert -law.force(G15, 0.0, 0.0, v)[1] / v == pytest.approx(0.4 + 2 * 6.0 * math.exp(-16), rel=1e-12)
    assert law.force(G15, 0.0, 0.03, v)[1] == pytest.approx(law.force(G15, 0.0, -0.03, v)[1], rel=1e-12)
    assert law.force(G15, 0.0, 0.04, -v)[1] == pytest.approx(-law.force(G15, 0.0, 0.04, v)[1], rel=1e-12)


# -------------------------------------------------------------------------- end effects
def test_oblique_ends_lose_the_overhang_averaged_over_the_depth():
    ep, en, s = 0.01, 0.02, 0.03
    law = make_law("end_effect", {"family": "oblique_ends", "e_p": ep, "e_n": en, "s": s})
    y = (np.arange(20000) + 0.5) / 20000  # across the depth, 0..1
    for d in (-0.06, -0.03, 0.0, 0.012, 0.025, 0.05):
        end_p, end_n = L / 2 + ep + s * y, -(L / 2 + en + s * y)  # each end's place at depth y
        over = np.maximum(d + L / 2 - end_p, 0) + np.maximum(end_n - (d - L / 2), 0)
        f = _ones(1)
        law.factors(np.array([G15]), np.array([d]), f)
        assert f[0][0] ** 2 == pytest.approx(1 - np.mean(over) / L, abs=1e-9), d
        assert f[1][0] == f[0][0]


def test_end_poles_are_the_gradient_of_two_line_poles_energy():
    ep, en, fe, ze = 0.015, 0.025, 0.6, 0.01
    law = make_law("end_effect", {"family": "end_poles", "e_p": ep, "e_n": en, "F_e": fe, "z_e": ze})
    r0 = k.tau / 2

    def energy(g, d):  # opposite line poles attract: W = c log r
        w = 0.0
        for x_end, x_pole in ((L / 2 + ep, d + L / 2 - r0), (-(L / 2 + en), d - L / 2 + r0)):
            w = w + fe * r0 * 0.5 * np.log((x_end - x_pole) ** 2 + (k.hm / 2 + g + ze) ** 2)
        return w

    d = np.linspace(-0.06, 0.06, 25)
    for g in (G_LO, G15, 0.025):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d)
        assert np.allclose(fd, wd, rtol=1e-6, atol=1e-9) and np.allclose(fg, wg, rtol=1e-6, atol=1e-9)
    same = make_law("end_effect", {"family": "end_poles", "e_p": 0.02, "e_n": 0.02, "F_e": fe, "z_e": ze})
    assert same.force(G15, 0.0, 0.0, 0.0)[1] == pytest.approx(0.0, abs=1e-14)  # the ends balance in the middle
    # at distance r0 straight across, the pull F_e
    at = make_law("end_effect", {"family": "end_poles", "e_p": 0.0, "e_n": 0.2, "F_e": fe, "z_e": r0 - k.hm / 2 - G15})
    fg, _ = at.force(G15, 0.0, r0, 0.0)
    far = fe * r0 * r0 / ((0.2 + 2 * r0) ** 2 + r0**2)  # the other end's pull on the gap axis
    assert -fg == pytest.approx(fe + far, rel=1e-9)


# --------------------------------------------------------------------------- saturation
def test_clipped_teeth_keep_the_clipped_waves_fundamental():
    gk = 0.016
    law = make_law("saturation", {"family": "clipped_teeth", "g_k": gk})
    th = (np.arange(4096) + 0.5) * 2 * math.pi / 4096
    g = np.array([G_LO, 0.011, 0.014, gk, 0.02, G_HI])
    f = _ones(g.size)
    law.factors(g, 0 * g, f)
    xs = _field(gk) / _field(G_LO)
    for gi, kk in zip(g, f[0], strict=True):
        x = _field(gi) / _field(G_LO)
        wave = np.clip(x * np.sin(th), -xs, xs)
        fund = 2 * np.mean(wave * np.sin(th))
        assert kk == pytest.approx(fund / x, abs=1e-6), gi
    assert np.all(f[0][3:] == 1.0) and np.array_equal(f[0], f[1]) and np.all(np.diff(f[0]) >= 0)


def test_brillouin_is_the_boltzmann_mean_over_the_states():
    def bj(j, y):  # <m>/J over m = -J..J with weights exp(m y / J)
        m = np.arange(-j, j + 0.5, 1.0)
        w = np.exp(m * y / j)
        return float(np.sum(m * w) / np.sum(w) / j)

    for j, lo in ((1.0, 0.05), (2.5, 0.04), (0.5, 0.06)):
        law = make_law("saturation", {"family": "brillouin", "l_lo": lo, "J": j})
        slope = (j + 1) / (3 * j)

        def kept(a, x, j=j, slope=slope):
            return bj(j, a * x) / (slope * a * x)

        a = _bisect(lambda a, j=j, lo=lo: (1 - lo) - kept(a, 1.0), 1e-3, 50.0)
        g = np.array([G_LO, 0.012, 0.02, G_HI])
        f = _ones(4)
        law.factors(g, 0 * g, f)
        want = [kept(a, xx) for xx in _field(g) / _field(G_LO)]
        assert np.allclose(f[0], want, atol=1e-9) and f[0][0] == pytest.approx(1 - lo, abs=1e-9), j
    # J = 1/2 is Ising's tanh
    half = make_law("saturation", {"family": "brillouin", "l_lo": 0.05, "J": 0.5})
    a = _bisect(lambda a: 0.95 - math.tanh(a) / a, 1e-3, 50.0)
    f = _ones(1)
    half.factors(np.array([0.02]), np.array([0.0]), f)
    x = float(_field(0.02) / _field(G_LO))
    assert f[0][0] == pytest.approx(math.tanh(a * x) / (a * x), abs=1e-9)


# ------------------------------------------------------------------- amplifier and delay
def _response(law, w):
    A, B, C = law.ss(0)
    return np.array([C @ np.linalg.solve(1j * x * np.eye(A.shape[0]) - A, B[:, 0]) for x in np.atleast_1d(w)])


def test_output_lc_is_the_loop_times_the_current_divider():
    fc, fr, z = 400.0, 2000.0, 0.1
    law = make_law("amplifier_lag", {"family": "output_lc", "f_c": fc, "f_r": fr, "zeta": z})
    wc, wr = 2 * math.pi * fc, 2 * math.pi * fr
    for w in (10.0, 2e3, wr, 3e4):
        s = 1j * w
        # the divider: the filter's capacitor (1 / sC) against the coil's branch (sL + R), L C = 1/wr^2, R C = 2z/wr
        c_, l_ = 1e-6, 1 / (wr**2 * 1e-6)
        r_ = 2 * z / (wr * c_)
        div = (1 / (s * c_)) / (1 / (s * c_) + s * l_ + r_)
        assert _response(law, w)[0] == pytest.approx(div / (1 + s / wc), rel=1e-9)
    assert law.group_delay(1e-3) == pytest.approx(1 / wc + 2 * z / wr, rel=1e-12)
    assert abs(_response(law, wr)[0] * (1 + 1j * wr / wc)) == pytest.approx(1 / (2 * z), rel=1e-9)  # the divider's Q


def test_sensor_doublet_creeps_up_with_the_slow_pole():
    tp, tz, tf = 2e-3, 1.5e-3, 2e-4
    law = make_law("amplifier_lag", {"family": "sensor_doublet", "tau_p": tp, "tau_z": tz, "tau_f": tf})
    for w in (30.0, 500.0, 4e3):
        s = 1j * w
        assert _response(law, w)[0] == pytest.approx((1 + s * tz) / ((1 + s * tp) * (1 + s * tf)), rel=1e-9)
    assert law.group_delay(1e-3) == pytest.approx(tp + tf - tz, rel=1e-12)
    # the step response: partial fractions, at t = 5 tau_f (the fast part gone) short by (1 - tz/tp) e^{-t/tp}
    A, B, C = law.ss(0)
    from scipy.linalg import expm

    t = 5e-3
    step = C @ np.linalg.solve(A, (expm(A * t) - np.eye(A.shape[0])) @ B[:, 0])
    slow = (tp - tz) / (tp - tf) * math.exp(-t / tp)
    fast = (tz - tf) / (tp - tf) * math.exp(-t / tf)
    assert step == pytest.approx(1 - slow - fast, rel=1e-9)


# ------------------------------------------------------------------------- commutation
def _angle(law, g, d, v=0.0, t=0.0):
    law.reset(0)
    X = np.zeros((np.size(d), 6))
    X[:, 0], X[:, 2], X[:, 3] = g, d, v
    q2, d2 = law.rotate_at(np.zeros(np.size(d)), np.ones(np.size(d)), X, t)
    return np.arctan2(-q2, d2)  # rotating (0, 1) by +delta gives i_q = -sin(delta)


def test_held_angle_is_the_position_at_the_last_update():
    tu, t0, v = 4e-3, 1e-3, 0.3
    law = make_law("commutation_offset", {"family": "held_angle", "delta0": 0.0, "T_u": tu, "t_0": t0})
    for t in (0.0, 1e-3, 2.5e-3, 4.9e-3, 0.1234):
        last = t0 + math.floor((t - t0) / tu) * tu  # the last update
        d_now, d_then = 0.01 + v * t, 0.01 + v * last
        want = math.pi * (d_then - d_now) / k.tau  # the angle used less the true one
        assert _angle(law, G15, np.array([d_now]), v, t)[0] == pytest.approx(want, abs=1e-12), t
    assert law.angle_at(G15, 0.0, 0.0, 0.002) == 0.0  # at rest the held angle is right


def test_two_axis_hall_reads_the_fields_harmonics_in_quadrature():
    hs, xh = 0.004, 0.006
    law = make_law("commutation_offset", {"family": "two_axis_hall", "delta0": 0.0, "h_s": hs, "x_h": xh})
    n = 1 << 14  # the magnetization over a pole pair: +1 over |x| < taup/2, -1 a pole pitch on
    x = np.arange(n) * 2 * k.tau / n
    xc = np.minimum(x, 2 * k.tau - x)
    mag = np.where(xc < k.taup / 2, 1.0, 0.0) - np.where(np.abs(x - k.tau) < k.taup / 2, 1.0, 0.0)
    c = np.fft.rfft(mag).real
    d = np.linspace(-0.05, 0.05, 41)
    th = math.pi * (xh - d + L / 2 - k.tau / 2) / k.tau
    for g in (0.012, G15, 0.025):
        z = g + hs  # below the magnets' face; a layer hm thick: (1 - e^{-j K hm}) e^{-j K z}
        b = {j: c[j] * (1 - math.exp(-j * K * k.hm)) * math.exp(-j * K * z) for j in range(1, 40, 2)}
        bz_jbx = sum(b[j] * np.exp(1j * j * th) for j in b)  # B_z + j B_x, harmonic by harmonic in quadrature
        want = np.angle(bz_jbx * np.exp(-1j * th))
        tol = 2 * abs(b[7] / b[1])  # the law stops at the fifth harmonic
        assert np.allclose(law.angle_at(g + 0 * d, d), want, atol=tol), g
        assert np.allclose(_angle(law, g, d), want, atol=tol)
        # small harmonics: delta ~ e3 sin 2th
        e3 = b[3] / b[1]
        assert np.max(np.abs(want - e3 * np.sin(2 * th))) < 3 * e3**2 + 3 * abs(b[5] / b[1])


# --------------------------------------------------------------------------- eddy drag
def test_excess_loss_follows_bertottis_separation():
    law = make_law("eddy_drag", {"family": "excess_loss", "c_c": 0.0, "F_x": 0.5})
    cl = make_law("eddy_drag", {"family": "excess_loss", "c_c": 3.0, "F_x": 0.0})
    # drag = loss / speed: the excess loss per time ~ f^{3/2}, the drag ~ sqrt(v); the classical ~ v
    f1, f4 = law.force(G15, 0.0, 0.0, 0.1)[1], law.force(G15, 0.0, 0.0, 0.4)[1]
    assert f1 == pytest.approx(-0.5 * (1 + 1e-4) ** -0.25, rel=1e-12) and f4 / f1 == pytest.approx(2.0, rel=1e-4)
    assert cl.force(G15, 0.0, 0.0, 0.2)[1] == pytest.approx(-0.6, rel=1e-12)
    for g in (0.01, 0.025):  # B^{3/2} and B^2
        b = _field(g) / _field(G15)
        assert law.force(g, 0.0, 0.0, 0.1)[1] / f1 == pytest.approx(b**1.5, rel=1e-9)
        assert cl.force(g, 0.0, 0.0, 0.2)[1] / -0.6 == pytest.approx(b**2, rel=1e-9)
    assert law.force(G15, 0.3, 0.0, 0.1)[0] == 0.0 and law.force(G15, 0.0, 0.0, 0.0)[1] == 0.0


def test_search_coil_damps_along_its_linkages_gradient():
    cs, xc, le = 3.0, 0.01, 0.005
    law = make_law("eddy_drag", {"family": "search_coil", "c_s": cs, "x_c": xc, "l_e": le})

    def phi(g, d):  # the coil's linkage over Phi_0
        foot = 0.5 * (np.tanh((xc - d + L / 2) / le) - np.tanh((xc - d - L / 2) / le))
        return _field(g) / _field(G15) * np.cos(K * (d - xc)) * foot

    rng = np.random.default_rng(5)
    for _ in range(12):
        g, d = rng.uniform(0.01, 0.03), rng.uniform(-0.06, 0.06)
        v = rng.normal(size=2) * 0.1  # (g_dot, d_dot)
        h = 1e-7
        grad = np.array([(phi(g + h, d) - phi(g - h, d)) / (2 * h), (phi(g, d + h) - phi(g, d - h)) / (2 * h)])
        want = -cs / K**2 * grad * (grad @ v)  # EMF -grad.v, current over R, force i grad
        got = np.array(law.force(g, v[0], d, v[1]))
        assert np.allclose(got, want, rtol=1e-6, atol=1e-9)
        assert got @ v <= 0.0
        along = np.array([-grad[1], grad[0]]) * 0.1 / np.hypot(*grad)  # along the level line: no EMF, no force
        assert np.allclose(law.force(g, along[0], d, along[1]), 0.0, atol=1e-8)
    assert law.force(G15, 0.0, xc + math.pi / (2 * K), 0.1)[1] == pytest.approx(-cs * 0.1, rel=1e-6)


# ------------------------------------------------------------------------------ out of the library
def test_hanging_cable_is_the_gradient_of_its_weights_height():
    w, s, ha, xa = 1.5, 0.5, 0.25, 0.15
    law = make_law("hanging_cable", {"w": w, "S": s, "h_a": ha, "x_a": xa})

    def energy(g, d):  # the cable's weight times the height of its centre of gravity (mover's attachment at 0)
        out = []
        for gi, di in zip(np.atleast_1d(g), np.atleast_1d(d), strict=True):
            x, y = xa - di, ha + gi - G15
            a = brentq(lambda a, x=x, y=y: 2 * a * math.sinh(x / (2 * a)) - math.sqrt(s * s - y * y), 1e-3, 100.0)
            m = math.atanh(y / s)  # the chord's middle over a, from the vertex
            u0 = m - x / (2 * a)
            u = np.linspace(u0, u0 + x / a, 20001)
            z = a * (np.cosh(u) - np.cosh(u0)) - (gi - G15)  # height over the mover's attachment at 15 mm
            ds = a * np.cosh(u)  # arc length per unit u
            out.append(w * np.trapezoid(z * ds, u))
        return np.array(out)

    d = np.linspace(-0.06, 0.06, 7)
    for g in (0.01, 0.02, 0.03):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d, h=1e-5)
        assert np.allclose(fd, wd, rtol=1e-5, atol=1e-7) and np.allclose(fg, wg, rtol=1e-5, atol=1e-7), g
    # the anchor below the mover: the mover carries the cable down to the vertex
    law, ha, s = make_law("hanging_cable", {"w": w, "S": 0.4, "h_a": -0.2, "x_a": xa}), -0.2, 0.4
    fg, fd = law.force(0.02 + 0 * d, 0 * d, d, 0 * d)
    wg, wd = _grad(energy, 0.02 + 0 * d, d, h=1e-5)
    assert np.allclose(fd, wd, rtol=1e-5, atol=1e-7) and np.allclose(fg, wg, rtol=1e-5, atol=1e-7)
    assert np.all(fg > 0.0)  # pulled down, away from the stator
    mirror = make_law("hanging_cable", {"w": w, "S": s, "h_a": ha, "x_a": -xa})
    assert mirror.force(0.02, 0.0, -0.03, 0.0)[1] == pytest.approx(-law.force(0.02, 0.0, 0.03, 0.0)[1], rel=1e-12)


def test_probe_target_edge_reads_the_gap_large_past_the_edge():
    em, de = 5e-5, 0.02
    law = make_law("probe_target_edge", {"e_m": em, "d_e": de, "side": 1.0, "c_s": 0.1})
    g = np.array([[0.012, 0.015, 0.02, 0.015]])
    d = np.array([[-0.04, de, 0.05, 0.06]])
    gr, dr = law.read_at(g, d, np.arange(4) * 1e-3)
    assert np.array_equal(dr, d)
    assert gr[0, 0] - g[0, 0] == pytest.approx(0.0, abs=1e-12)  # on the target
    assert gr[0, 1] - G15 == pytest.approx(em / 2, rel=1e-12)  # on the edge: half
    assert gr[0, 2] - 0.02 == pytest.approx(em * (0.02 / G15) ** 2, rel=1e-9)  # off: the full error, ~ standoff^2
    other = make_law("probe_target_edge", {"e_m": em, "d_e": de, "side": -1.0, "c_s": 0.1})
    assert other.read_at(g, d, None)[0][0, 3] - G15 == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v17_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    for seed in range(160):
        sc = draw(seed, laws="v17")
        assert sc == draw(seed, laws="v17")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v17"
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
                # (3 ms: the doublet's largest by construction is 0.3 + 0.4 * 4 + 1 sample = 2.9 ms)
                assert np.all(np.linalg.eigvals(A).real < 0) and law.group_delay(1e-3) < 3e-3
    assert seen == {(n, f) for n, c in V17_LAWS.items() for f in c.families}


def test_every_v17_family_runs_in_the_closed_loop_and_changes_the_data(tmp_path):
    s = RigSettings(n_runs=1, duration=0.6)  # one run each: the file's time within 40 s on a shared machine
    base = generate(tmp_path / "none", None, seed=7, settings=s)
    runs0 = [p.read_bytes() for p in sorted(base.glob("run_*.csv"))]
    # the short runs stay within a few mm of d = 0 and near the hover gap: the ends, the knee and the edge put near
    extra = {
        "oblique_ends": {"e_p": -0.002, "e_n": 0.02, "s": 0.004},
        "clipped_teeth": {"g_k": 0.019},
        "spot_overhang": {"d_e": 0.0, "e_m": 5e-5},
        "search_coil": {"x_c": 0.02},
    }
    for name, cls in V17_LAWS.items():
        for fam in cls.families:
            out = generate(tmp_path / fam, {name: {"family": fam, **extra.get(fam, {})}}, seed=7, settings=s)
            assert [p.read_bytes() for p in sorted(out.glob("run_*.csv"))] != runs0, (name, fam)
            truth = json.loads((out / "truth.json").read_text())
            e = truth["effects"][name]
            assert e["law_set"] == "v17" and e["family"] == fam
            sizes = {"amplifier_lag": "effective_delay_s", "probe_target_edge": "peak_error_g_m"}
            size = sizes.get(name, "peak_force_n")
            assert np.isfinite(e[size]) and e[size] != 0.0, (name, fam, e)
            assert truth["hover_error_rms_m"]["g"] < 2e-4 and truth["hover_error_rms_m"]["d"] < 4e-4, (name, fam)


def test_v16_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit 0275ed6 (before this set) with the same call
    # on an AMD EPYC (numpy at X86_V3); on another SIMD level the unquantized call against data/rig_digests.json
    # ("v17_*", recorded at 0275ed6)
    cases = {
        "v16a": (
            {
                "cogging": {"family": "bread_loaf"},
                "friction": {"family": "lip_wiper"},
                "end_effect": {"family": "frame_image"},
            },
            37,
            {"X86_V3": "996cb6b8bdef0535a8900f88dc4d12ac7c4338c827ae7fb67b9ea12466a62e59"},
        ),
        "v16b": (
            {
                "saturation": {"family": "akulov_approach"},
                "amplifier_lag": {"family": "cauer3"},
                "eddy_drag": {"family": "cooling_tubes"},
            },
            41,
            {"X86_V3": "cb76aa62d27c80b0cdbc7af3ed2214f3740617c90deb8ce0d30b067dff38c21b"},
        ),
        "v16ool": (
            {"ferrous_debris": None, "scale_joint": None, "commutation_offset": {"family": "shield_lag"}},
            43,
            {"X86_V3": "1a30abc4f2af8fb9afc15b89b6a5e00bc9532d626297b7ca7b7195534c9fbd50"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v17")
