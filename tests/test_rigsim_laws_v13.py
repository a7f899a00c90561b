"""The thirteenth law set of the independent rig (maglev_ocp.rigsim.laws_v13, ``laws="v13"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (energies differentiated by finite differences with MODEL.md's field and ``f2`` written
out again, the slot openings' sinc series, Amontons' load, the dither's average of ``sgn`` over a cycle integrated,
the array sampled point by point over the stator's ends, a first-order lag stepped by hand, Laplace's fringe
integrated, Preisach's relays switched by hand, the Linkwitz-Riley and Pade responses from their parts, the sensor's
slant and the heads' switch by hand, the eddy loop's lag integrated, gravity on the tilted base, the probe's filter
stepped by hand), tolerances fixed beforehand; every family runs in the closed loop and changes the data; the v13
draw is seeded, covers every family, stays finite and bounded over the rig's envelope; datasets generated from the
twelfth set are the same bytes as at commit e5cc599 (before this set; the earlier sets' draws:
test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets, dataset_hash
from scipy import integrate

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws_v13 import V13_LAWS, law_class, make_law

G_LO, G_HI = k.g_stop
KP = math.pi / k.tau
L = k.pm * k.tau
G15 = 0.015


def _field(g):
    """MODEL.md's ``B(g)``, written out again."""
    coef = (4 / math.pi) * k.Br * math.sin(math.pi * k.taup / (2 * k.tau)) * math.sinh(math.pi * k.hm / k.tau)
    return coef / np.sinh(math.pi * (k.hm + np.asarray(g, dtype=float)) / k.tau)


def _f2(g):
    """MODEL.md's ``f2 = lam B^2``, written out again."""
    lam = 1 - k.b0**2 / (4 * k.t1 * (np.asarray(g, dtype=float) + k.b0 / 2 + k.hm / k.mu_rec))
    return lam * _field(g) ** 2


def _grad(fun, g, d, h=1e-7):
    """``(-dW/dg, -dW/dd)`` by central differences."""
    return -(fun(g + h, d) - fun(g - h, d)) / (2 * h), -(fun(g, d + h) - fun(g, d - h)) / (2 * h)


def _overhang(d, e_p, e_n, n=400001):
    """The array's length beyond the stator ``[-(L/2 + e_n), L/2 + e_p]``, sampled point by point."""
    x = np.linspace(d - L / 2, d + L / 2, n)
    return np.mean((x > L / 2 + e_p) | (x < -(L / 2 + e_n))) * L


def test_every_family_resolves_to_the_thirteenth_set():
    for name, cls in V13_LAWS.items():
        for fam in cls.families:
            assert law_class(name, fam) is cls, (name, fam)
            assert make_law(name, {"family": fam}).describe()["law_set"] == "v13"


# ----------------------------------------------------------------------------- cogging
def test_open_slot_series_is_the_gradient_of_the_sinc_weighted_slot_energy():
    beta, xi0, x0 = 0.37, 3.0, 0.004
    law = make_law("cogging", {"family": "open_slot_series", "xi0": xi0, "beta": beta, "x0": x0})

    def energy(g, d):
        w = 0.0
        for kk in range(1, 6):
            s = math.sin(kk * math.pi * beta) / (kk * math.pi * beta) / (math.sin(math.pi * beta) / (math.pi * beta))
            a = xi0 * s * np.exp(-2 * math.pi * kk * (g - 0.01) / k.t1)
            w = w + k.t1 / (2 * math.pi * kk) * a * np.cos(2 * math.pi * kk * (d - x0) / k.t1)
        return w

    d = np.linspace(-0.03, 0.03, 41)
    for g in (0.011, 0.015, 0.024):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d)
        assert np.allclose(fd, wd, atol=2e-6) and np.allclose(fg, wg, atol=2e-6)


def test_open_slots_of_half_the_pitch_have_no_even_harmonics_and_sharpen_as_the_gap_closes():
    law = make_law("cogging", {"family": "open_slot_series", "xi0": 3.0, "beta": 0.5, "x0": 0.0})
    d = np.linspace(0.0, k.t1, 256, endpoint=False)
    _, f1 = law.force(0.013 + 0 * d, 0 * d, d, 0 * d)
    _, f2 = law.force(0.013 + 0 * d, 0 * d, d + k.t1 / 2, 0 * d)
    assert np.allclose(f2, -f1, atol=1e-12)  # sinc(k/2) = 0 for even k: half a pitch on, the force reverses
    share = []
    for g in (0.011, 0.02):
        _, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        c = np.abs(np.fft.rfft(fd))
        share.append(c[3] / c[1])
    # the third harmonic's share falls with the gap as exp(-2 pi 2 dg / t1) (sinc(3/2)/sinc(1/2) = -1/3 at 10 mm)
    want = [abs(-1 / 3) * math.exp(-4 * math.pi * (g - 0.01) / k.t1) for g in (0.011, 0.02)]
    assert share == pytest.approx(want, rel=1e-6)


def test_unequal_poles_add_sidebands_of_the_pole_pair_and_stay_conservative():
    xi0, e, x_m, x0 = 3.0, 0.2, 0.01, 0.002
    law = make_law("cogging", {"family": "unequal_poles", "xi0": xi0, "e": e, "x_m": x_m, "x0": x0})

    def energy(g, d):
        a = xi0 * np.exp(-2 * math.pi * (g - 0.01) / k.t1) * (1 + e * np.cos(math.pi * (d - x_m) / k.tau))
        return k.t1 / (2 * math.pi) * a * np.cos(2 * math.pi * (d - x0) / k.t1)

    d = np.linspace(-0.045, 0.045, 61)
    for g in (0.012, 0.018):
        fg, fd = law.force(g + 0 * d, 0 * d, d, 0 * d)
        wg, wd = _grad(energy, g + 0 * d, d)
        assert np.allclose(fd, wd, atol=2e-6) and np.allclose(fg, wg, atol=2e-6)
    flat = make_law("cogging", {"family": "unequal_poles", "xi0": xi0, "e": 0.0, "x0": x0})
    fd0 = flat.force(0.01 + 0 * d, 0 * d, d, 0 * d)[1]
    assert np.allclose(fd0, xi0 * np.sin(2 * math.pi * (d - x0) / k.t1), atol=1e-12)  # equal poles: one harmonic


# ---------------------------------------------------------------------------- friction
def test_pull_loaded_friction_follows_the_magnets_pull_by_amontons():
    law = make_law(
        "friction", {"family": "pull_loaded", "Fc_d": 0.2, "Fc_g": 0.1, "b_d": 0.0, "b_g": 0.0, "kappa": 0.6}
    )
    for g in (0.011, G15, 0.024):
        want = 0.2 * (1 + 0.6 * (_f2(g) / _f2(G15) - 1))
        fg, fd = law.force(g, 0.5, 0.0, 0.5)
        assert fd == pytest.approx(-want, rel=1e-6) and fg == pytest.approx(-0.1, rel=1e-6)
        assert law.force(g, -0.5, 0.0, -0.5)[1] == pytest.approx(want, rel=1e-6)  # odd in the speed
    assert law.force(0.011, 0, 0, 0.5)[1] < law.force(0.02, 0, 0, 0.5)[1]  # more load, more friction


def test_dither_smoothed_friction_is_the_average_of_coulomb_over_the_dither_cycle():
    v_d, fc, b = 4e-3, 0.2, 0.5
    law = make_law("friction", {"family": "dither_smoothed", "Fc_d": fc, "Fc_g": fc, "b_d": b, "b_g": b, "v_d": v_d})
    ph = np.linspace(0, 2 * math.pi, 200001)
    for v in (0.0, 1e-3, 2.5e-3, 3.9e-3, -3e-3, 8e-3, -0.1):
        mean_sgn = np.mean(np.sign(v + v_d * np.sin(ph)))
        want = -(fc * mean_sgn + b * v)
        fg, fd = law.force(0.015, v, 0.0, v)
        assert fd == pytest.approx(want, abs=2e-4) and fg == pytest.approx(want, abs=2e-4)
    h = 1e-7
    slope = -(law.force(0.015, 0, 0, h)[1] - law.force(0.015, 0, 0, -h)[1]) / (2 * h)
    assert slope == pytest.approx(2 * fc / (math.pi * v_d) + b, rel=1e-6)  # finite through zero speed


# -------------------------------------------------------------------------- end effects
def test_delayed_entry_follows_the_overhang_with_a_first_order_lag():
    e_p, e_n, tau_e = 0.02, 0.03, 0.01
    law = make_law("end_effect", {"family": "delayed_entry", "e_p": e_p, "e_n": e_n, "tau_e": tau_e})
    assert law.end_factors(0.015, 0.0)[0] == pytest.approx(1.0)
    for d in (0.03, 0.045, -0.04):  # outside a simulation: the settled loss
        pull, coup = law.end_factors(0.015, d)
        assert pull == pytest.approx(1 - _overhang(d, e_p, e_n) / L, abs=1e-5) and coup == pull
    law.reset(1)
    g = np.array([0.015])
    f = [np.ones(1) for _ in range(4)]
    law.factors_i(g, np.array([0.0]), np.zeros(1), np.zeros(1), f)  # at rest at d = 0: nothing lost
    assert f[0][0] == pytest.approx(1.0)
    o1 = _overhang(0.045, e_p, e_n)
    for n in range(1, 31):  # the array jumps to 45 mm; the loss builds up over control periods of 1 ms
        f = [np.ones(1) for _ in range(4)]
        law.factors_i(g, np.array([0.045]), np.zeros(1), np.zeros(1), f)
        law.advance(None, None, 1e-3)
        assert law.o_e[0] == pytest.approx(o1 * (1 - math.exp(-n * 1e-3 / tau_e)), abs=2e-7)
    assert law.recorded()["peak_force_g_n"] > 0.0


def test_armature_fringe_keeps_the_currents_coupling_over_the_fringe():
    e_p, e_n, c_a = 0.02, 0.03, 0.6
    law = make_law("end_effect", {"family": "armature_fringe", "e_p": e_p, "e_n": e_n, "c_a": c_a})
    for g in (0.012, 0.02):
        lam = c_a * (g + k.hm)
        for d in (0.0, 0.03, 0.045, -0.045):
            o = _overhang(d, e_p, e_n)
            kept = integrate.quad(lambda x, lam=lam: math.exp(-x / lam), 0.0, o)[0] if o > 0 else 0.0
            pull, coup = law.end_factors(g, d)
            assert pull == pytest.approx(1 - o / L, abs=1e-5)
            assert coup == pytest.approx(1 - (o - kept) / L, abs=1e-5)
            f = [np.ones(1), np.ones(1), np.ones(1), np.ones(1)]
            law.factors(np.array([g]), np.array([d]), f)
            assert f[0][0] ** 2 == pytest.approx(pull, rel=1e-12) and f[0][0] * f[1][0] == pytest.approx(coup)
    # the fringe is longer at a larger gap: more coupling kept at the same overhang
    assert law.end_factors(0.024, 0.045)[1] > law.end_factors(0.012, 0.045)[1] > law.end_factors(0.012, 0.045)[0]


# --------------------------------------------------------------------------- saturation
def _b(g):
    return _field(g) / _field(G_LO)


def test_villari_stress_saturates_the_iron_earlier_the_harder_it_is_pulled():
    law = make_law("saturation", {"family": "villari_stress", "l_lo": 0.15, "n": 2.0, "s_v": 0.4})
    for g in (G_LO, 0.013, 0.02):
        x = _b(g) * (1 + 0.4 * (_f2(g) / _f2(G_LO) - 1))
        assert law.magnetization(g) == pytest.approx(x, rel=1e-6)
        f = [np.ones(1) for _ in range(4)]
        law.factors_i(np.array([g]), np.zeros(1), np.zeros(1), np.zeros(1), f)
        assert f[0][0] == pytest.approx(1 - 0.15 * x**2, rel=1e-6) and f[1][0] == f[0][0]
    assert law.magnetization(G_LO) == pytest.approx(1.0)  # the lower stop: the loss l_lo itself
    plain = make_law("saturation", {"family": "villari_stress", "s_v": 0.0})
    assert plain.magnetization(0.018) == pytest.approx(_b(0.018), rel=1e-6)
    assert law.magnetization(0.018) < plain.magnetization(0.018)  # less pull than at the stop: less stress


def test_preisach_relays_remember_where_the_flux_came_from():
    p = {"family": "preisach_relays", "l_lo": 0.15, "n": 2.0, "b_c": 0.7, "w": 0.1, "h_w": 0.03, "h_p": 0.2}
    law = make_law("saturation", p)
    centres = 0.7 + 0.1 * (np.arange(8) - 3.5) / 4
    assert np.allclose(law.centres(), centres)

    def gap_at(b):  # invert b(g) by bisection
        lo, hi = G_LO, G_HI
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _b(mid) > b else (lo, mid)
        return 0.5 * (lo + hi)

    def run(path):
        law.reset(1)
        for b in path:
            f = [np.ones(1) for _ in range(4)]
            law.factors_i(np.array([gap_at(b)]), np.zeros(1), np.zeros(1), np.zeros(1), f)
            law.advance(None, None, 1e-3)
        return law.relays[0].copy(), f[0][0]

    # the relays switch between control periods: the factor of a period holds the last period's relays (the middle
    # read twice)
    up, f_up = run([0.55, 0.7, 0.85, 0.7, 0.7])  # from below, over the band, back to its middle
    down, f_dn = run([0.85, 0.7, 0.55, 0.7, 0.7])
    by_hand_up = np.where(centres - 0.03 < 0.7, 1.0, -1.0)  # up from 0.85; down again those whose centre is >= 0.73
    by_hand_dn = np.where(centres + 0.03 < 0.7, 1.0, -1.0)  # down at 0.55; up again those whose centre is < 0.67
    assert np.array_equal(up, by_hand_up) and np.array_equal(down, by_hand_dn)
    x_up, x_dn = 0.7 * (1 + 0.2 * up.mean()), 0.7 * (1 + 0.2 * down.mean())
    assert f_up == pytest.approx(1 - 0.15 * x_up**2, rel=1e-5) and f_dn == pytest.approx(1 - 0.15 * x_dn**2, rel=1e-5)
    assert f_up < f_dn  # came down from high flux: more magnetized, more loss at the same gap
    narrow = make_law("saturation", {**p, "h_w": 0.0})
    narrow.reset(1)
    assert np.array_equal(narrow.switch(0.7, np.ones(8)), narrow.switch(0.7, -np.ones(8)))  # no band, no memory


# ---------------------------------------------------------------------------- amplifier
def _response(law, w):
    A, B, C = law.ss(0)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def test_linkwitz_riley_is_minus_six_db_and_minus_180_degrees_at_its_corner():
    law = make_law("amplifier_lag", {"family": "linkwitz_riley4", "f_c": 600.0})
    wc = 2 * math.pi * 600.0
    h = _response(law, wc)
    assert abs(h) == pytest.approx(0.5, rel=1e-9) and abs(np.angle(h)) == pytest.approx(math.pi, abs=1e-9)
    for w in (0.3 * wc, 2.0 * wc):  # the square of Butterworth's second order
        bw2 = 1 / (1 - (w / wc) ** 2 + 1j * math.sqrt(2) * w / wc)
        assert _response(law, w) == pytest.approx(bw2**2, rel=1e-9)
    assert law.dc_gain() == pytest.approx(1.0) and law.group_delay(1e-3) == pytest.approx(2 * math.sqrt(2) / wc)


def test_pade_pwm_is_an_all_pass_delay_behind_a_first_order_loop():
    tau_a, T_d = 4e-4, 2.5e-4
    law = make_law("amplifier_lag", {"family": "pade_pwm", "tau_a": tau_a, "T_d": T_d, "delay_samples": 0.5})
    for w in (50.0, 500.0, 3000.0, 20000.0):
        h = _response(law, w)
        assert abs(h) == pytest.approx(1 / math.sqrt(1 + (w * tau_a) ** 2), rel=1e-9)  # the Pade part is all-pass
        if w * T_d < 0.2:  # the exact delay's phase at low frequency (Pade's error ~ (w T)^5 / 720)
            assert np.angle(h) == pytest.approx(-w * T_d - math.atan(w * tau_a), abs=1e-6)
    assert law.group_delay(1e-3) == pytest.approx(tau_a + T_d + 0.5e-3)
    A, _, _ = law.ss(0)
    assert np.all(np.linalg.eigvals(A).real < 0)


# -------------------------------------------------------------------------- commutation
def _angle(law, g, d, v=0.0, t=0.0):
    X = np.zeros((np.size(g), 6))
    X[:, 0], X[:, 2], X[:, 3] = g, d, v
    q2, d2 = law.rotate_at(np.ones(np.size(g)), np.zeros(np.size(g)), X, t)
    return np.arctan2(d2, q2)


def test_slanted_sensor_errs_in_proportion_to_the_gap_change():
    law = make_law("commutation_offset", {"family": "slanted_sensor", "delta0": 0.01, "tan_a": 0.3})
    g = np.array([0.012, 0.015, 0.02, 0.024])
    want = 0.01 + (math.pi / k.tau) * 0.3 * (g - G15)  # the sensor moved along the stroke by dg tan(alpha)
    for d in (-0.04, 0.0, 0.03):
        assert np.allclose(_angle(law, g, d + 0 * g, v=0.3), want, atol=1e-12)


def test_head_switchover_switches_with_hysteresis():
    p = {"family": "head_switchover", "delta_a": 0.1, "delta_b": -0.08, "d_s": 0.005, "h_s": 0.002}
    law = make_law("commutation_offset", p)
    law.reset(1)
    path = [-0.01, 0.004, 0.0068, 0.0071, 0.005, 0.0032, 0.0029, 0.006]
    want = [0.1, 0.1, 0.1, -0.08, -0.08, -0.08, 0.1, 0.1]  # to B above 7 mm, back to A below 3 mm
    got = [float(_angle(law, np.array([0.015]), np.array([x]))[0]) for x in path]
    assert got == pytest.approx(want, abs=1e-12)
    fresh = make_law("commutation_offset", p)
    fresh.reset(1)
    assert float(_angle(fresh, np.array([0.015]), np.array([0.0071]))[0]) == pytest.approx(-0.08)  # starts above


# --------------------------------------------------------------------------- eddy drag
def test_inductive_loop_drag_lags_the_speed_by_its_time_constant():
    c_d, c_g, tau_e, h = 4.0, 1.5, 0.008, 2.5e-4
    law = make_law("eddy_drag", {"family": "inductive_loop", "c_d": c_d, "c_g": c_g, "tau_e": tau_e})
    law.reset(1)
    assert law.has_held and not law.has_force
    vg, vd = 0.02, 0.3
    t = 0.0
    for _ in range(60):  # a step of speed from rest: the mean over each sub-step of -c v (1 - exp(-t / tau))
        fg, fd = law.held(np.array([vg]), np.array([vd]), h)
        mean = integrate.quad(lambda s: 1 - math.exp(-s / tau_e), t, t + h)[0] / h
        assert fd[0] == pytest.approx(-c_d * vd * mean, rel=1e-9) and fg[0] == pytest.approx(-c_g * vg * mean, rel=1e-9)
        t += h
    for _ in range(2000):
        fg, fd = law.held(np.array([0.0]), np.array([0.0]), h)
    assert abs(fd[0]) < 1e-9  # stopped: the loop's current dies out


def test_armature_sheet_drag_grows_with_the_armature_field():
    c0, kap = 2.5, 0.2
    law = make_law("eddy_drag", {"family": "armature_sheet", "c0": c0, "kappa": kap})
    assert law.has_force_i and not law.has_held
    for g in (0.012, 0.02):
        b2 = (_field(g) / _field(G15)) ** 2
        fg, fd = law.force_i(g, 0.1, 0.0, 0.3, 0.0, 0.0)
        assert fd == pytest.approx(-c0 * b2 * 0.3, rel=1e-6) and fg == 0.0
        for iq, idd in ((3.0, 0.0), (-3.0, 0.0), (0.0, 2.0), (0.0, -2.0), (2.0, 1.0)):
            want = -c0 * b2 * ((1 + kap * idd) ** 2 + (kap * iq) ** 2) * 0.3
            assert law.force_i(g, 0.0, 0.02, 0.3, iq, idd)[1] == pytest.approx(want, rel=1e-6)
    assert law.force_i(0.015, 0, 0, 0.3, 3.0, 0)[1] == law.force_i(0.015, 0, 0, 0.3, -3.0, 0)[1]  # q: either sign


# ----------------------------------------------------------------------- out of the library
def test_base_tilt_is_gravity_along_the_tilted_stroke():
    law = make_law("base_tilt", {"family": "levelling_feet", "theta0": 0.008, "kappa": -0.1})
    for d in (-0.045, 0.0, 0.03):
        th = 0.008 - 0.1 * d
        fg, fd = law.force(0.015, 0.0, d, 0.0)
        assert fd == pytest.approx(-k.Mh * 9.81 * math.sin(th), rel=1e-12)
        assert fg == pytest.approx(k.Mv * 9.81 * (1 - math.cos(th)), rel=1e-9) and fg >= 0
    level = make_law("base_tilt", {"family": "levelling_feet", "theta0": 0.0, "kappa": -0.1})
    assert level.force(0.015, 0, 0.04, 0)[1] > 0 > level.force(0.015, 0, -0.04, 0)[1]  # the feet give: pushed out


def test_probe_filter_reads_the_gap_through_a_first_order_lag():
    law = make_law("probe_filter", {"family": "demodulator_lpf", "f_p": 100.0})
    tau = 1 / (2 * math.pi * 100.0)
    law.reset(2)
    g0, g1 = np.array([0.015, 0.02]), np.array([0.016, 0.019])
    assert np.array_equal(law.read_at(g0, np.zeros(2), np.zeros(2))[0], g0)  # starts at the first gap
    for n in range(1, 8):
        gr, dr = law.read_at(g1, np.array([0.01, 0.02]), np.full(2, n * 1e-3))
        assert np.allclose(gr, g1 + (g0 - g1) * math.exp(-n * 1e-3 / tau), atol=1e-15)
        assert np.array_equal(dr, [0.01, 0.02])  # the horizontal encoder untouched
    # along a recorded trajectory: the same recursion
    path = np.array([[0.015] + [0.016] * 7, [0.02] + [0.019] * 7])
    t = np.arange(8) * 1e-3
    assert np.allclose(law.read_at(path, path, t)[0][:, -1], gr, atol=1e-15)
    assert law.read_at(g1, g1, None)[0] is not None


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v13_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    for seed in range(160):
        sc = draw(seed, laws="v13")
        assert sc == draw(seed, laws="v13")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v13"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5))
            if getattr(law, "has_force_i", False):  # at the current limit
                _, fd = law.force_i(g, v, d, v, 0 * g + 5.0, 0 * g + 6.0)
                assert np.all(np.isfinite(fd)) and np.max(np.abs(fd)) < 50.0, (name, spec)
            if getattr(law, "has_factors_i", False):  # the factors over the envelope, at the current limit
                law.reset(0)
                f = [np.ones_like(g) for _ in range(4)]
                law.factors_i(g, d, 0 * g + 5.0, 0 * g + 6.0, f)
                assert all(np.all((x > 0.5) & (x < 1.5)) for x in f), (name, spec)
            if getattr(law, "has_rotate_at", False):  # at most 0.45 rad over the stops
                law.reset(0)
                X = np.zeros((g.size, 6))
                X[:, 0], X[:, 2], X[:, 3] = g, d, v
                q2, d2 = law.rotate_at(0 * g + 5.0, 0 * g + 6.0, X, 0 * g + 0.0123)
                ang = np.angle((d2 + 1j * q2) / (6.0 + 5.0j))
                assert np.max(np.abs(ang)) < 0.45, (name, spec)
            if getattr(law, "has_read_at", False):  # a step of 2 mm read within 2 mm, the filter's output between
                law.reset(0)
                law.read_at(0 * g + 0.015, d, 0 * g)
                gr, dr = law.read_at(0 * g + 0.017, d, 0 * g + 1e-3)
                assert np.all((gr > 0.015) & (gr < 0.017)) and np.array_equal(dr, d), (name, spec)
            if name == "amplifier_lag":
                A, B, C = law.ss(0)
                assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(1.0, abs=1e-9)
                assert np.all(np.linalg.eigvals(A).real < 0) and law.group_delay(1e-3) < 2.5e-3
    assert seen == {(n, f) for n, c in V13_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest two sets')
def test_every_v13_family_runs_in_the_closed_loop_and_changes_the_data(tmp_path):
    s = RigSettings(n_runs=2, duration=1.0)
    base = generate(tmp_path / "none", None, seed=7, settings=s)
    runs0 = [p.read_bytes() for p in sorted(base.glob("run_*.csv"))]
    # the 1 s runs stay within a few mm of d = 0: the end laws' stator ends put near, the switch between heads too
    extra = {
        "delayed_entry": {"e_p": 0.002, "e_n": 0.002},
        "armature_fringe": {"e_p": 0.002, "e_n": 0.002},
        "head_switchover": {"d_s": 0.0, "h_s": 0.0005},
    }
    for name, cls in V13_LAWS.items():
        for fam in cls.families:
            out = generate(tmp_path / fam, {name: {"family": fam, **extra.get(fam, {})}}, seed=7, settings=s)
            assert [p.read_bytes() for p in sorted(out.glob("run_*.csv"))] != runs0, (name, fam)
            truth = json.loads((out / "truth.json").read_text())
            e = truth["effects"][name]
            assert e["law_set"] == "v13" and e["family"] == fam
            size = {"amplifier_lag": "effective_delay_s", "probe_filter": "peak_error_g_m"}.get(name, "peak_force_n")
            assert np.isfinite(e[size]) and e[size] != 0.0, (name, fam, e)
            assert truth["hover_error_rms_m"]["g"] < 2e-4 and truth["hover_error_rms_m"]["d"] < 4e-4, (name, fam)


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest two sets')
def test_v12_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit e5cc599 (before this set) with the same call
    # on an AMD EPYC (numpy at X86_V4); on another SIMD level the unquantized call against data/rig_digests.json
    # ("v13_*", recorded at e5cc599)
    cases = {
        "v12a": (
            {
                "cogging": {"family": "warm_magnets"},
                "friction": {"family": "iwan_presliding"},
                "end_effect": {"family": "half_filled_slots"},
            },
            37,
            {"X86_V4": "6f5fb0184e7766c074ba575d4031afbc622e5e91bb16c0291c70be76bb3597cd"},
        ),
        "v12b": (
            {
                "saturation": {"family": "rayleigh_loop"},
                "amplifier_lag": {"family": "cdm3"},
                "eddy_drag": {"family": "tilted_sheet"},
            },
            41,
            {"X86_V4": "2f14c4f9225d61980704827fb79d5abb673ffd27a87c0b1d8733fa2a409cddb1"},
        ),
        "v12ool": (
            {"mains_hum": None, "end_bumpers": None, "commutation_offset": {"family": "pole_pitch_mismatch"}},
            43,
            {"X86_V4": "0f380cfc2f31af9901a5a8831b6fb2446e52b58dcd3807d0fbf6bb6cfdde3502"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v13")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest two sets')
def test_v13_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "cogging": {"family": "unequal_poles"},
        "saturation": {"family": "preisach_relays"},
        "commutation_offset": {"family": "slanted_sensor"},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "cogging+commutation_offset+saturation"
    assert all(e["law_set"] == "v13" for e in truth["effects"].values())
    assert truth["effects"]["cogging"]["peak_force_n"] > 0.05
    assert 0.0 < truth["effects"]["saturation"]["peak_force_g_n"] < 20.0  # recorded while simulated
    assert truth["effects"]["commutation_offset"]["peak_force_d_n"] > 0.0
    ool = generate(tmp_path / "c", {"probe_filter": {"f_p": 80.0}}, seed=5, settings=s)
    t2 = json.loads((ool / "truth.json").read_text())
    e = t2["effects"]["probe_filter"]
    assert t2["expected_verdict"] == "unexplained" and e["library"] is False
    assert 0.0 < e["peak_error_g_m"] < 1e-4 and e["peak_error_d_m"] == 0.0
