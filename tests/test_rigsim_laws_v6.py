"""The sixth law set of the independent rig (maglev_ocp.rigsim.laws_v6, ``laws="v6"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from the
source's formula or physics (periods of the slot grid, curl-free forces, quadrature, the exact circuit equation,
frequency responses from ``scipy.signal``, the observer's error constant, the Clarke/Park transforms written out
again, seed eq. (2) through ``physics.accelerations``), tolerances fixed beforehand; the v6 draw is seeded, covers
every family, stays finite and bounded over the rig's envelope; datasets generated from the law sets before it are
the same bytes as at commit ac59446 (before this set; the earlier sets' draws: test_rigsim_draw_bytes.py).
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
from maglev_ocp.rigsim.laws_v6 import V6_LAWS, array_field, carter_width, make_law, pm_coenergy, yoke_flux
from maglev_ocp.rigsim.physics import NOMINAL, accelerations, shape

G_LO, G_HI = k.g_stop
KP = math.pi / k.tau
L = k.pm * k.tau


def _pull(g, i_q=0.0, i_d=0.0):
    """Magnetic pull [N] of seed eq. (2), nominal constants, from the rig's accelerations."""
    return NOMINAL.Mv * (k.G - float(accelerations(g, 0.0, i_q, i_d, NOMINAL, with_cogging=False)[0]))


# ----------------------------------------------------------------------------- cogging
def test_array_field_is_furlanis_block_field():
    # Bz of one magnet's top face minus its bottom face, by quadrature of the surface charge (1/(x^2 + y^2) kernel)
    x, y = 0.013, 0.012
    a = k.taup / 2
    want = 0.0
    for j in range(k.pm):
        c = (j - 1.5) * k.tau
        top = integrate.quad(lambda s, c=c: y / ((x - s) ** 2 + y * y), c - a, c + a)[0]
        bot = integrate.quad(lambda s, c=c: (y + k.hm) / ((x - s) ** 2 + (y + k.hm) ** 2), c - a, c + a)[0]
        want += (-1) ** j * (top - bot)
    assert float(array_field(x, y)) == pytest.approx(want, rel=1e-9)


def test_finite_array_cogging_has_the_slot_pitch_period_and_is_conservative():
    law = make_law("cogging", {"family": "finite_array", "xi0": 2.0, "x0": 0.004})
    d = np.linspace(-0.04, 0.02, 61)
    for g in (0.013, 0.018):
        f0 = law.force(0 * d + g, 0, d, 0)
        f1 = law.force(0 * d + g, 0, d + k.t1, 0)
        assert np.max(np.abs(f1[1] - f0[1])) < 1e-9 and np.max(np.abs(f1[0] - f0[0])) < 1e-9
    x = np.linspace(0, k.t1, 401)
    assert np.max(np.abs(law.force(0 * x + 0.015, 0, x, 0)[1])) == pytest.approx(2.0, rel=2e-3)  # xi0 at 15 mm
    # the slot-pitch harmonics decay faster than seed eq. (9)'s 3.6 mm: the peak falls more than 4x over 5 mm
    assert np.max(np.abs(law.force(0 * x + 0.020, 0, x, 0)[1])) < 0.25 * 2.0
    g = np.linspace(0.012, 0.026, 5)[:, None] + 0 * d[None, :]
    dd = 0 * g + d[None, :]
    h = 1e-6
    dfd_dg = (law.force(g + h, 0, dd, 0)[1] - law.force(g - h, 0, dd, 0)[1]) / (2 * h)
    dfg_dd = (law.force(g, 0, dd + h, 0)[0] - law.force(g, 0, dd - h, 0)[0]) / (2 * h)
    assert np.max(np.abs(dfd_dg - dfg_dd)) < 1e-3 * np.max(np.abs(dfd_dg))


def test_paired_teeth_repeat_every_two_slots_only():
    law = make_law("cogging", {"family": "paired_teeth", "xi0": 2.0, "delta_p": 1.2e-3, "eps_b": 0.25})
    d = np.linspace(-0.03, 0.01, 41)
    f0 = law.force(0 * d + 0.016, 0, d, 0)[1]
    assert np.max(np.abs(law.force(0 * d + 0.016, 0, d + 2 * k.t1, 0)[1] - f0)) < 1e-9
    assert np.max(np.abs(law.force(0 * d + 0.016, 0, d + k.t1, 0)[1] - f0)) > 0.05 * np.max(np.abs(f0))
    # without the pairing it is the finite-array law again
    plain = make_law("cogging", {"family": "paired_teeth", "xi0": 2.0, "delta_p": 0.0, "eps_b": 0.0})
    ref = make_law("cogging", {"family": "finite_array", "xi0": 2.0})
    assert plain.force(0 * d + 0.016, 0, d, 0)[1] == pytest.approx(ref.force(0 * d + 0.016, 0, d, 0)[1], abs=2e-3)


# ---------------------------------------------------------------------------- friction
def test_rail_friction_odd_in_speed_and_following_the_rail():
    p = {"family": "rail_position", "Fc_g": 0.2, "Fc_d": 0.3, "a_b": 0.2, "p_b": 8e-3, "ph_b": 0.5}
    p.update(a_r=0.3, p_r=0.1, ph_r=-1.0, b_g=0.0, b_d=1.0, v_reg=1e-5)
    law = make_law("friction", p)
    d = np.linspace(-0.05, 0.05, 101)
    v = 0 * d + 0.05
    fg, fd = law.force(0 * d + 0.02, v, d, v)
    fgm, fdm = law.force(0 * d + 0.02, -v, d, -v)
    assert fg == pytest.approx(-fgm, abs=1e-12) and fd == pytest.approx(-fdm, abs=1e-12)
    prof = 1 + 0.2 * np.cos(2 * math.pi * d / 8e-3 + 0.5) + 0.3 * np.cos(2 * math.pi * d / 0.1 - 1.0)
    assert -fd == pytest.approx(0.3 * prof + 1.0 * 0.05, rel=1e-9)
    assert -fg == pytest.approx(0.2 * prof, rel=1e-9)


def test_reset_integrator_elastic_breakaway_and_sliding():
    law = make_law("friction", {"family": "reset_integrator", "Fc_d": 0.3, "z0": 1e-5, "a": 0.5, "b_d": 0.0})
    law.reset(1)
    h, v = 1e-4, 1e-3  # 0.1 um per step
    f = [law.held(np.array([0.0]), np.array([v]), h)[1][0] for _ in range(150)]
    f = -np.array(f)
    assert f[49] == pytest.approx(0.3 / 1e-5 * 50 * v * h * 1.5, rel=1e-9)  # elastic, sigma0 (1 + a) z
    assert np.max(f) == pytest.approx(1.5 * 0.3 * 99 / 100, rel=1e-6)  # breakaway just before z0
    assert f[-1] == pytest.approx(0.3, rel=1e-12)  # then sliding at Fc
    law.held(np.array([0.0]), np.array([-v]), h)  # reversal: elastic again, the stiction factor back
    assert -law.held(np.array([0.0]), np.array([0.0]), h)[1][0] == pytest.approx(0.3 * 0.99 * 1.5, rel=1e-9)


# -------------------------------------------------------------------------- end effects
def test_segment_joint_against_quadrature_and_virtual_work():
    law = make_law("end_effect", {"family": "segment_joint", "x_j": 0.01, "w_j": 0.015})
    g = 0.017
    r = 0.015 / (2 * g)
    we = (4 / math.pi) * (r * math.atan(r) - math.log(math.sqrt(1 + r * r))) * g  # Carter
    assert float(carter_width(0.015, g)) == pytest.approx(we, rel=1e-12)
    for d in (-0.03, 0.0, 0.025):
        u = 0.01 - d
        lost = integrate.quad(lambda x: math.sin(KP * x) ** 2, u - we / 2, u + we / 2)[0] / (L / 2)
        assert law.rho_g(np.array([d]), np.array([g]))[0] == pytest.approx(1 - lost, rel=1e-9)
        h = 1e-7
        r1, r0 = law.rho_g(np.array([d + h]), np.array([g]))[0], law.rho_g(np.array([d - h]), np.array([g]))[0]
        drho = (r1 - r0) / (2 * h)
        fd = law.force(np.array([g]), 0, np.array([d]), 0)[1][0]
        assert fd == pytest.approx(float(pm_coenergy(g)) * drho, rel=1e-5)
    # the co-energy's gap derivative is the magnets' pull
    hh = 1e-6
    assert -(pm_coenergy(g + hh) - pm_coenergy(g - hh)) / (2 * hh) == pytest.approx(
        NOMINAL.Mv * NOMINAL.C2 * float(shape(g).f2), rel=1e-3
    )


def test_yoke_step_circuit_and_gap_dependence():
    for beta, r in ((0.4, 0.1), (1.2, 0.2)):
        phi = float(yoke_flux(beta, r))
        assert phi * (1 + r / (1 - beta * phi)) == pytest.approx(1 + r, rel=1e-12) and 0 < phi < 1
    spec = {"family": "yoke_step", "e_p": 0.02, "e_n": 0.02, "l_y": 0.02, "b_lo": 1.0, "r": 0.1}
    law, linear = make_law("end_effect", spec), make_law("end_effect", {**spec, "b_lo": 1e-9})
    d = np.array([0.01])  # the array's end 10 mm into the clamping yoke, 10 mm short of the stator's end
    extra = [linear.rho_g(d, np.array([g]))[0] - law.rho_g(d, np.array([g]))[0] for g in (0.013, 0.018, 0.024)]
    assert extra[0] > extra[1] > extra[2] > 0  # the end yoke saturates more at the smaller gaps
    phi = float(yoke_flux(1.0 * float(shape(0.018).B / shape(G_LO).B), 0.1))
    # a long yoke (100 mm) with the array's ends 50 and 80 mm into it: (1 - phi^2) of those lengths lost (the
    # overlaps are smoothed over the gap, 18 mm: a few % off the sharp lengths)
    spec = {**spec, "e_p": 0.035, "e_n": 0.035, "l_y": 0.1}
    law, linear = make_law("end_effect", spec), make_law("end_effect", {**spec, "b_lo": 1e-9})
    x = np.array([-0.015])
    lost = (linear.rho_g(x, np.array([0.018]))[0] - law.rho_g(x, np.array([0.018]))[0]) * L
    assert lost == pytest.approx((1 - phi * phi) * (0.05 + 0.08), rel=0.06)


# --------------------------------------------------------------------------- saturation
def test_incremental_arctan_secant_and_incremental_permeabilities():
    law = make_law("saturation", {"family": "incremental_arctan", "b_lo": 0.8, "r": 0.2})
    km, kc = law._arctan(np.array([G_LO]))
    b = 0.8 * km[0]  # self-consistent operating point at the lower stop
    y = math.pi * b / 2
    assert km[0] == pytest.approx(1.2 / (1 + 0.2 * math.tan(y) / y), rel=1e-9)
    assert kc[0] == pytest.approx(1.2 / (1 + 0.2 / math.cos(y) ** 2), rel=1e-9)
    f = [np.ones(3) for _ in range(4)]
    law.factors(np.array([G_LO, 0.02, G_HI]), np.zeros(3), f)
    assert f[0][2] == pytest.approx(1.0) and f[1][2] == pytest.approx(1.0)
    assert f[1][0] < f[0][0] < 1.0  # the currents' incremental permeability falls faster than the magnets' secant
    with pytest.raises(ValueError, match="b_lo"):
        make_law("saturation", {"family": "incremental_arctan", "b_lo": 1.2})


def test_tooth_flux_follows_the_teeth():
    law = make_law("saturation", {"family": "tooth_flux", "b_lo": 0.3, "x0": 0.002})
    d = np.linspace(-0.03, 0.01, 41)
    l0 = law.loss(0 * d + 0.014, d=d)
    assert law.loss(0 * d + 0.014, d=d + k.t1) == pytest.approx(l0, abs=1e-9)  # period t1
    assert np.ptp(l0) > 1e-3  # and it does change with where the teeth sit
    # against the teeth summed here (Frohlich f(b) = b / (1 + b))
    fl = law.tooth_fluxes(np.array([G_LO]), np.array([0.0]))
    u = np.linspace(0, k.t1, 25)
    ref = max(float(np.max(np.abs(law.tooth_fluxes(np.array([G_LO]), np.array([x]))))) for x in u)
    b = 0.3 * fl[0] / ref
    assert np.max(np.abs(b)) <= 0.3 + 1e-12
    km2 = np.sum((b / (1 + np.abs(b))) ** 2) / np.sum(b * b)
    bh = 0.3 * law.tooth_fluxes(np.full_like(u, G_HI), u) / ref
    hi = np.mean(np.sum((bh / (1 + np.abs(bh))) ** 2, axis=-1) / np.sum(bh * bh, axis=-1))
    assert 1 - law.loss(np.array([G_LO]), d=np.array([0.0]))[0] == pytest.approx(math.sqrt(km2 / hi), rel=2e-3)
    means = [np.mean(law.loss(0 * d + g, d=d)) for g in (0.012, 0.018, 0.024)]
    assert means[0] > means[1] > means[2] > -1e-3


# ------------------------------------------------------------------- amplifier and delay
def _freq(law, w):
    A, B, C = law.ss(0)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def test_sine_filter_response():
    law = make_law("amplifier_lag", {"family": "sine_filter", "bandwidth_hz": 300.0, "fr_hz": 1500.0, "zeta": 0.2})
    wc, wr = 2 * math.pi * 300, 2 * math.pi * 1500
    tf = signal.TransferFunction([wc * wr * wr], np.polymul([1, wc], [1, 2 * 0.2 * wr, wr * wr]))
    for w in (0.0, 500.0, wr, 3 * wr):
        want = np.polyval(tf.num, 1j * w) / np.polyval(tf.den, 1j * w)
        assert _freq(law, w) == pytest.approx(complex(want), rel=1e-9)
    # the filter's own part peaks at 1 / (2 zeta) at its resonance
    assert abs(_freq(law, wr) * (1 + 1j * wr / wc)) == pytest.approx(1 / (2 * 0.2), rel=1e-9)
    ph = [np.angle(_freq(law, x)) for x in (1e-2 - 1e-3, 1e-2 + 1e-3)]
    assert -(ph[1] - ph[0]) / 2e-3 == pytest.approx(law.group_delay(0.0), rel=1e-4)


def test_detuned_pi_dc_gain_slow_tail_and_delay():
    spec = {"family": "detuned_pi", "bandwidth_hz": 300.0, "tau_w": 5e-3, "rho_R": 0.75, "rho_L": 1.0}
    law = make_law("amplifier_lag", spec)
    assert _freq(law, 0.0) == pytest.approx(1.0, abs=1e-12)
    wc, a = 2 * math.pi * 300, 200.0
    # the loop written out: PI (Kp = wc L^, Ki = wc R^) on L di/dt = -R i + v; in units of L
    tf = signal.TransferFunction([wc, wc * 0.75 * a], [1, a + wc, wc * 0.75 * a])
    t = np.linspace(0, 0.03, 3001)
    _, y = signal.step(tf, T=t)
    _, Bd = law.discrete(0, t[2000])
    assert (Bd @ np.array([1.0, 0.0])) @ law.ss(0)[2] == pytest.approx(y[2000], abs=1e-6)
    assert abs(y[int(3 / (wc * 1e-5))] - 1) > 0.02  # three loop time constants later it still creeps
    ideal = make_law("amplifier_lag", {**spec, "rho_R": 1.0})
    assert abs(_freq(ideal, 500.0) - wc / (500j + wc)) < 1e-12  # exact cancellation: the first-order loop
    ph = [np.angle(_freq(law, x)) for x in (1e-2 - 1e-3, 1e-2 + 1e-3)]
    assert -(ph[1] - ph[0]) / 2e-3 == pytest.approx(1 / (wc * 0.75), rel=1e-4)


# ------------------------------------------------------------------------- commutation
def test_tracking_observer_error_constants():
    law = make_law("commutation_offset", {"family": "tracking_observer", "delta0": 0.0, "fn_hz": 6.0, "zeta": 0.8})
    law.reset(1)
    h, acc = 1e-3, 1.5
    for n in range(3000):  # constant acceleration: e -> (pi / tau) a / wn^2
        law.held(np.array([0.0]), np.array([acc * n * h]), h)
    wn = 2 * math.pi * 6.0
    assert law.state[0, 0] == pytest.approx(KP * acc / wn**2, rel=1e-3)
    for _ in range(3000):  # constant speed: e -> 0
        law.held(np.array([0.0]), np.array([4.5]), h)
    assert abs(law.state[0, 0]) < 1e-6
    X = np.zeros((1, 6))
    law.state[0, 0] = 0.04  # the currents are placed at the observer's angle: an error e acts as delta0 = -e
    iq, idd = law.rotate_at(np.array([1.0]), np.array([2.0]), X, None)
    const = make_law("commutation_offset", {"family": "constant", "delta0": -0.04})
    assert (iq[0], idd[0]) == pytest.approx(tuple(x for x in const.rotate(1.0, 2.0, 0.0)), abs=1e-12)
    assert "peak_angle_error_rad" in law.recorded()


def test_armature_field_sensor_angle():
    spec = {"family": "armature_field_sensor", "delta0": 0.0, "a_q": 0.05, "a_d": 0.01, "c_s": 5e-3}
    law = make_law("commutation_offset", spec)
    X = np.zeros((3, 6))
    X[:, 0] = [0.012, 0.018, 0.024]
    iq, idd = law.rotate_at(np.zeros(3), np.full(3, 2.0), X, None)
    assert iq == pytest.approx(np.zeros(3), abs=1e-15) and idd == pytest.approx(np.full(3, 2.0))  # no thrust: none
    a = law.angle(X[:, 2], 0, X[:, 0], np.full(3, 1.0), np.full(3, 2.0))
    b = np.array([shape(g + 5e-3).B / shape(k.g_cog_ref + 5e-3).B for g in X[:, 0]]).ravel()  # MODEL.md's field
    assert a == pytest.approx(np.arctan2(0.05, b - 0.02), rel=1e-9)
    assert a[2] > a[1] > a[0]  # the magnets' field weakens at the sensor as the gap opens
    iq, idd = law.rotate_at(np.full(3, 1.0), np.full(3, 2.0), X, None)
    assert iq**2 + idd**2 == pytest.approx(np.full(3, 5.0))


# --------------------------------------------------------------------------- eddy drag
def test_plate_patch_where_the_plate_is():
    law = make_law("eddy_drag", {"family": "plate_patch", "c0": 40.0, "x_a": -0.02, "l_p": 0.08, "r_p": 0.015})
    g = np.array([0.016])
    assert law.force(g, np.array([0.0]), np.array([0.01]), np.array([0.0]))[1][0] == 0.0  # zero at rest
    f1 = law.force(g, np.array([0.0]), np.array([0.01]), np.array([0.1]))[1][0]
    f2 = law.force(g, np.array([0.0]), np.array([0.01]), np.array([0.2]))[1][0]
    assert f1 < 0 and f2 == pytest.approx(2 * f1, rel=1e-12)
    # magnet 2 (at d + tau/2 = 38.6 mm) sits 58.6 mm in from x_a and 1.4 mm in from the far edge
    xj = 0.01 + 0.5 * k.tau
    eta = (1 - math.exp(-2 * (xj + 0.02) / 0.015)) * (1 - math.exp(-2 * (0.06 - xj) / 0.015))
    xj1 = 0.01 - 0.5 * k.tau
    eta += (1 - math.exp(-2 * (xj1 + 0.02) / 0.015)) * (1 - math.exp(-2 * (0.06 - xj1) / 0.015))
    bb = (shape(0.016).B / shape(k.g_cog_ref).B) ** 2
    assert -f1 == pytest.approx(40.0 * float(bb) * eta / 4 * 0.1, rel=1e-9)
    far = law.force(g, np.array([0.1]), np.array([0.0]), np.array([0.1]))
    moved = make_law("eddy_drag", {"family": "plate_patch", "c0": 40.0, "x_a": 0.3, "l_p": 0.05})
    assert moved.force(g, np.array([0.1]), np.array([0.0]), np.array([0.1]))[1][0] == 0.0 and far[1][0] < 0


def test_receding_image_lags_the_speed():
    law = make_law("eddy_drag", {"family": "receding_image", "c0": 20.0, "tau_e": 2e-3})
    law.reset(1)
    g = np.array([0.018])
    assert law.force(g, np.array([0.0]), np.array([0.0]), np.array([0.0]))[1][0] == 0.0  # at rest
    for _ in range(3):
        law.held(np.array([0.0]), np.array([0.2]), 1e-3)
    c = 20.0 * float((shape(0.018).B / shape(k.g_cog_ref).B) ** 2)
    fd = law.force(g, np.array([0.0]), np.array([0.0]), np.array([0.2]))[1][0]
    assert fd == pytest.approx(-c * 0.2 * (1 - math.exp(-3e-3 / 2e-3)), rel=1e-12)  # a step of speed: tau_e
    assert law.recorded()["peak_force_d_n"] == pytest.approx(-fd)


# --------------------------------------------------------------------- out of the library
def _park_check(law, i_q, i_d, d):
    """The loop's measured currents, transformed with the sensors' errors written out again."""
    p = law.p
    th = math.pi * d / k.tau + p["theta0"]
    ia_m = i_d * math.cos(th) - i_q * math.sin(th)
    ib_m = i_d * math.cos(th - 2 * math.pi / 3) - i_q * math.sin(th - 2 * math.pi / 3)
    ia, ib = (ia_m - p["off_a"]) / (1 + p["eps_a"]), (ib_m - p["off_b"]) / (1 + p["eps_b"])
    ic = -ia - ib
    i_d2 = 2 / 3 * (ia * math.cos(th) + ib * math.cos(th - 2 * math.pi / 3) + ic * math.cos(th + 2 * math.pi / 3))
    i_q2 = -2 / 3 * (ia * math.sin(th) + ib * math.sin(th - 2 * math.pi / 3) + ic * math.sin(th + 2 * math.pi / 3))
    return i_q2, i_d2


def test_phase_current_sensor_against_the_three_phase_transform():
    spec = {"family": "gain_offset", "eps_a": 0.03, "eps_b": -0.01, "off_a": 0.04, "off_b": -0.02, "theta0": 0.7}
    law = make_law("phase_current_sensor", spec)
    for iq, idd, d in ((0.3, 2.5, 0.01), (-1.0, 4.0, -0.033)):
        got = law.carried(np.array([iq]), np.array([idd]), np.array([d]))
        assert (got[0][0], got[1][0]) == pytest.approx(_park_check(law, iq, idd, d), abs=1e-12)
    clean = make_law("phase_current_sensor", {"family": "gain_offset", "eps_a": 0.0, "off_a": 0.0})
    out = clean.carried(np.array([0.5]), np.array([3.0]), np.array([0.02]))
    assert (out[0][0], out[1][0]) == pytest.approx((0.5, 3.0), abs=1e-12)
    # a gain error alone: period tau along d (twice the electrical angle); an offset alone: period 2 tau
    d = np.linspace(-0.05, 0.05, 201)
    gain = make_law("phase_current_sensor", {"family": "gain_offset", "eps_a": 0.03, "off_a": 0.0})
    e0 = gain.carried(0 * d, 0 * d + 3.0, d)[1]
    assert gain.carried(0 * d, 0 * d + 3.0, d + k.tau)[1] == pytest.approx(e0, abs=1e-12)
    off = make_law("phase_current_sensor", {"family": "gain_offset", "eps_a": 0.0, "off_a": 0.04})
    o0 = off.carried(0 * d, 0 * d + 3.0, d)[1]
    assert off.carried(0 * d, 0 * d + 3.0, d + k.tau)[1] == pytest.approx(2 * 3.0 - o0, abs=1e-12)


def test_stator_flatness_moves_the_magnetic_gap():
    spec = {"family": "tilt_bow_steps", "tilt": 3e-4, "bow": 2e-5, "ls": 0.08, "x0": -0.1, "h1": 1e-5}
    law = make_law("stator_flatness", spec)
    d = 0.03
    E = float(integrate.quad(lambda x: 3e-4 * x + 2e-5 * ((x / 0.06) ** 2 - 1 / 3) + 1e-5 * (x > 0.06),
                             d - L / 2, d + L / 2, points=[0.06])[0] / L)  # fmt: skip
    assert float(law.mean_error(d)) == pytest.approx(E, rel=1e-9)
    g, iq, idd = 0.017, 0.4, 2.5
    f = [np.ones(1) for _ in range(4)]
    law.factors(np.array([g]), np.array([d]), f)
    km, kc, _, thr = (float(x[0]) for x in f)
    sh, sm = shape(g), shape(g - E)
    c = NOMINAL
    want = c.C2 * sm.f2 - c.C3 * sm.f3 * idd  # seed eq. (2) at the magnetic gap (the small C4 term left out)
    got = c.C2 * sh.f2 * km * km - c.C3 * sh.f3 * idd * km * kc
    assert float(got) == pytest.approx(float(want), rel=1e-12)
    assert float(c.C1 * sh.f1 * km * kc * thr * iq) == pytest.approx(float(c.C1 * sm.f1 * iq), rel=1e-12)
    assert _pull(g - E, 0, idd) > _pull(g, 0, idd)  # a stator nearer the mover pulls harder


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v6_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    X = np.column_stack([g, v, d, v, 0 * g, 0 * g])
    for seed in range(120):
        sc = draw(seed, laws="v6")
        assert sc == draw(seed, laws="v6")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v6"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5), read_tol_m=1e-4)
            if law.has_rotate_at:
                law.reset(g.size)
                for iq, idd in ((0 * g + 0.5, 0 * g + 3.0), (0 * g - 8.0, 0 * g + 8.0)):
                    q2, d2 = law.rotate_at(iq, idd, X, None)
                    assert np.all(np.isfinite(q2)) and np.all(np.isfinite(d2)), (name, spec)
                    # within the moves' currents and the gap band: under 0.35 A (0.1 rad) of change on 3 A; at the
                    # limits the magnitude within 5 % (a rotation, or the sensors' few % of gain)
                    if iq[0] == 0.5:
                        band = (g >= k.g_envelope[0]) & (g <= k.g_envelope[1])
                        assert np.max(np.hypot(q2 - iq, d2 - idd)[band]) < 0.35, (name, spec)
                    else:
                        assert np.allclose(np.hypot(q2, d2), np.hypot(iq, idd), rtol=0.05), (name, spec)
            if name == "amplifier_lag":
                A, B, C = law.ss(0)
                assert C @ np.linalg.solve(-A, B[:, 0]) == pytest.approx(1.0, abs=1e-9)
                assert np.all(np.linalg.eigvals(A).real < 0)
    assert seen == {(n, f) for n, c in V6_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v5_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit ac59446 with the same call on an AMD EPYC
    # (numpy 2.4.6 at X86_V3); on another SIMD level the unquantized call against data/rig_digests.json ("v6_*",
    # recorded at ac59446 and the same at the merge of the sixth set)
    cases = {
        "v5a": (
            {
                "cogging": {"family": "on_load"},
                "friction": {"family": "rate_state"},
                "commutation_offset": {"family": "sw_lag"},
            },
            13,
            {"X86_V3": "a6a4d116ff4c212b9d7d7f743ba8c5c0ecb874ef778d5d8141e67e0f7a87345c"},
        ),
        "v5b": (
            {
                "saturation": {"family": "cross_flux"},
                "eddy_drag": {"family": "hysteresis_lag"},
                "amplifier_lag": {"family": "loop_delay"},
            },
            17,
            {"X86_V3": "86a56c59f517ecd2cab885285d14087d4694552d40e62a21299df589330d38ad"},
        ),
        "v5ool": (
            {"core_hysteresis": None, "end_effect": {"family": "chamfer"}},
            19,
            {"X86_V3": "dc68f5b23ac1f3ebcbd65f7c69dae51a4bf20ce38451adaef1a2f4e47429f6bf"},
        ),
    }
    assert_same_datasets(tmp_path, cases, "v6")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v6_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "cogging": {"family": "finite_array"},
        "commutation_offset": {"family": "tracking_observer"},
        "eddy_drag": {"family": "receding_image"},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "cogging+commutation_offset+eddy_drag"
    assert all(e["law_set"] == "v6" for e in truth["effects"].values())
    assert truth["effects"]["cogging"]["peak_force_n"] > 0.05
    assert 0.0 < truth["effects"]["eddy_drag"]["peak_force_n"] < 5.0  # recorded while simulated
    assert truth["effects"]["commutation_offset"]["peak_angle_error_rad"] > 0.0
    assert truth["hover_error_rms_m"]["g"] < 1e-4 and truth["hover_error_rms_m"]["d"] < 3e-4  # still controlled
    ool = generate(tmp_path / "c", {"phase_current_sensor": None}, seed=5, settings=s)
    t2 = json.loads((ool / "truth.json").read_text())
    assert t2["expected_verdict"] == "unexplained" and t2["effects"]["phase_current_sensor"]["peak_force_n"] > 0.1
