"""Feedback linearization: the exact model inverse, the root choice, the guards and the limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from maglev_ocp import constants as k
from maglev_ocp.blocks import Measurement, Reference
from maglev_ocp.controllers.fl import (
    FLAG_FIELDS,
    GAIN_FIELDS,
    FeedbackLinearization,
    FLSettings,
    fl_law_function,
)
from maglev_ocp.errors import ConfigError
from maglev_ocp.model import model_inverse_function
from maglev_ocp.params import NOMINAL
from maglev_ocp.signals import REF_FIELDS


def _accel(model, x, u, p):
    xd = np.asarray(model.f(x, u, p)).ravel()
    return np.array([xd[1], xd[3]])


def _law(x, a_ref, p, gains, dist=(0.0, 0.0), z=(0.0, 0.0)):
    """Evaluate the law with the reference at the state (pure feedforward ``a_ref``)."""
    ref = [x[0], x[1], a_ref[0], x[2], x[3], a_ref[1]]
    u, z_next, v, flags = fl_law_function()(x, list(dist), ref, list(z), p, gains)
    return (
        np.asarray(u).ravel(),
        np.asarray(z_next).ravel(),
        np.asarray(v).ravel(),
        dict(zip(FLAG_FIELDS, np.asarray(flags).ravel(), strict=True)),
    )


@pytest.mark.parametrize("g", [0.015, 0.020, 0.025])
@pytest.mark.parametrize("d", [0.0, 0.009525, -0.028575, 0.04])
def test_inverse_at_rest_is_the_models_hover_current(model, p_nom, g, d):
    """Zero acceleration demanded at rest: the inverse equals the model's u_eq (seed eq. (8) + cogging)."""
    u, unr = model_inverse_function()([g, 0, d, 0], [0, 0], p_nom)
    u_eq = np.asarray(model.u_eq(g, d, p_nom)).ravel()
    assert float(unr) == 0
    np.testing.assert_allclose(np.asarray(u).ravel(), u_eq, rtol=0, atol=1e-10)


@settings(max_examples=60, deadline=None)
@given(
    g=st.floats(0.012, 0.028),
    gd=st.floats(-0.3, 0.3),
    d=st.floats(-0.055, 0.055),
    dd=st.floats(-2, 2),
    ag=st.floats(-30, 20),
    ad=st.floats(-60, 60),
    cog=st.booleans(),
)
def test_inverse_is_exact_including_cogging(model, g, gd, d, dd, ag, ad, cog):
    """The model driven by the inverse's currents produces exactly the demanded accelerations; where the
    demanded opening acceleration is out of reach (flagged), the horizontal one is still exact and the gap
    gets the largest opening acceleration the field can give, which falls short of the demand."""
    p = (NOMINAL if cog else NOMINAL.without_cogging()).vector()
    x = [g, gd, d, dd]
    u, unr = model_inverse_function()(x, [ag, ad], p)
    u = np.asarray(u).ravel()
    a = _accel(model, x, u, p)
    tol = 1e-9 * (1 + abs(ag) + abs(ad))
    assert np.all(np.isfinite(u))
    if not float(unr):
        np.testing.assert_allclose(a, [ag, ad], rtol=0, atol=tol)
        return
    assert a[1] == pytest.approx(ad, abs=tol)
    assert a[0] < ag  # really out of reach
    for di in (-1e-3, 1e-3):  # i_d is the vertex of the vertical quadratic: no other i_d opens faster
        assert _accel(model, x, u + np.array([0.0, di]), p)[0] <= a[0] + 1e-12


@settings(max_examples=40, deadline=None)
@given(g=st.floats(0.012, 0.028), d=st.floats(-0.055, 0.055), excess=st.floats(0.1, 100.0), cog=st.booleans())
def test_unreachable_demand_is_flagged(model, g, d, excess, cog):
    """Demanding more opening acceleration than the vertex of the vertical quadratic gives (L3^2 / (4 L4) above
    the zero-current one) always sets the unreachable flag; a demand just below it never does."""
    p = (NOMINAL if cog else NOMINAL.without_cogging()).vector()
    x = [g, 0.0, d, 0.0]
    u0, _ = model_inverse_function()(x, [0.0, 0.0], p)
    iq = float(np.asarray(u0).ravel()[0])
    a0 = _accel(model, x, [iq, 0.0], p)[0]
    *_, f3, f4 = (float(v) for v in model.shape(g))
    a_max = a0 + (NOMINAL.C3 * f3) ** 2 / (4 * NOMINAL.C4 * f4)  # vertex of a0 + L3 i - L4 i^2
    _, unr = model_inverse_function()(x, [a_max + excess, 0.0], p)
    assert float(unr) == 1
    _, unr = model_inverse_function()(x, [a_max - 1e-6 * abs(a_max) - 1e-9, 0.0], p)
    assert float(unr) == 0


def test_smaller_root_without_cancellation(model):
    """With a tiny C4 the i_d root tends to the linear solution c/L3, to full precision (no cancellation)."""
    p = NOMINAL.without_cogging().with_(C4=1e-12).vector()
    x = [0.020, 0.0, 0.0, 0.0]
    u, _ = model_inverse_function()(x, [0.0, 0.0], p)
    # linear solution: C3 f3 i_d = C2 f2 - G  (i_q = 0, cogging off)
    *_, f2, f3, _ = (float(v) for v in model.shape(0.020))
    i_lin = (NOMINAL.C2 * f2 - k.G) / (NOMINAL.C3 * f3)
    assert float(np.asarray(u).ravel()[1]) == pytest.approx(i_lin, rel=1e-9)


def test_root_is_the_one_of_smaller_magnitude(model, p_nom):
    """Both roots of the vertical quadratic give the same force; the law picks the small one (no field weakening)."""
    x = [0.020, 0.0, 0.0, 0.0]
    u, _ = model_inverse_function()(x, [0.0, 0.0], p_nom)
    i_small = float(np.asarray(u).ravel()[1])
    *_, f3, f4 = (float(v) for v in model.shape(0.020))
    L3, L4 = NOMINAL.C3 * f3, NOMINAL.C4 * f4
    i_other = L3 / L4 - i_small  # the roots sum to L3 / L4
    assert abs(i_small) < abs(i_other)
    a_other = _accel(model, x, [0.0, i_other], p_nom)
    assert a_other[0] == pytest.approx(0.0, abs=1e-8)


def test_unreachable_attraction_is_flagged_and_clipped(p_nom):
    """disc < 0 (opening faster than the field allows): flagged, finite, within the limits, no integration."""
    gains = FLSettings(integral=True).gains()
    x = np.array([0.020, 0.0, 0.0, 0.0])
    u, z_next, _, flags = _law(x, [500.0, 0.0], p_nom, gains, z=(1e-6, 0.0))
    assert flags["unreachable"] == 1 and flags["sat_g"] == 1
    assert np.all(np.isfinite(u))
    assert math.hypot(*u) <= k.i_amp_max + 1e-12
    assert u[1] == pytest.approx(k.i_axis_max)  # the largest opening current the limits allow
    assert z_next[0] == pytest.approx(1e-6)  # anti-windup: the gap integrator is frozen


@settings(max_examples=80, deadline=None)
@given(
    g=st.floats(0.010, 0.030),
    d=st.floats(-0.05, 0.05),
    ag=st.floats(-500, 500),
    ad=st.floats(-500, 500),
    i_max=st.floats(2.0, 8.0),
)
def test_law_respects_current_limits(p_nom, g, d, ag, ad, i_max):
    """Whatever is demanded, |i_q|, |i_d| <= axis limit and the amplitude <= its limit."""
    gains = FLSettings(i_axis_max=i_max, i_amp_max=min(i_max * 1.2, 8.0)).gains()
    u, _, _, flags = _law(np.array([g, 0.0, d, 0.0]), [ag, ad], p_nom, gains)
    assert np.all(np.abs(u) <= i_max + 1e-12)
    assert math.hypot(*u) <= min(i_max * 1.2, 8.0) + 1e-9
    if abs(ad) > 200:
        assert flags["sat_d"] == 1


def test_gap_axis_has_priority_under_amplitude_limit(p_nom):
    """A large thrust demand takes only what the levitation current leaves of the 8 A amplitude."""
    gains = FLSettings().gains()
    x = np.array([0.015, 0.0, 0.0, 0.0])
    u, _, _, flags = _law(x, [0.0, 400.0], p_nom, gains)
    u_hover, _ = model_inverse_function()(x, [0, 0], p_nom)
    i_d_hover = float(np.asarray(u_hover).ravel()[1])
    assert flags["sat_d"] == 1 and flags["sat_g"] == 0
    assert k.i_amp_max * 0.99 <= math.hypot(*u) <= k.i_amp_max + 1e-12  # (nearly) the whole amplitude
    # i_d re-solved for the reluctance of the limited i_q: more than the hover current, still levitating exactly
    assert u[1] > i_d_hover


def test_law_is_pd_with_feedforward_on_the_linearized_outputs(model, p_nom):
    """Off the limits, the closed-loop accelerations are a_ref + kp e + kd e_dot (the outputs' double integrators)."""
    s = FLSettings(integral=False)
    gains = s.gains()
    gd = dict(zip(GAIN_FIELDS, gains, strict=True))
    x = np.array([0.0201, 0.002, -0.001, -0.01])
    ref = np.array([0.020, 0.0, 1.0, 0.0, 0.0, -3.0])
    u, _, v, flags = fl_law_function()(x, [0.0, 0.0], ref, [0.0, 0.0], p_nom, gains)
    r = dict(zip(REF_FIELDS, ref, strict=True))
    v_expect = [
        r["g_ddot"] + gd["kp_g"] * (r["g"] - x[0]) + gd["kd_g"] * (r["g_dot"] - x[1]),
        r["d_ddot"] + gd["kp_d"] * (r["d"] - x[2]) + gd["kd_d"] * (r["d_dot"] - x[3]),
    ]
    np.testing.assert_allclose(np.asarray(v).ravel(), v_expect, rtol=1e-12)
    a = _accel(model, x, np.asarray(u).ravel(), p_nom)
    np.testing.assert_allclose(a, v_expect, rtol=0, atol=1e-9)
    assert not np.any(np.asarray(flags).ravel())


def test_gains_place_the_poles():
    """PD: s^2 + 2 zeta w s + w^2; PID: (s + w)^3."""
    s = FLSettings(omega_g=80, omega_d=50, zeta=0.9)
    g = dict(zip(GAIN_FIELDS, s.gains(), strict=True))
    assert np.roots([1, g["kd_g"], g["kp_g"]]) == pytest.approx(np.roots([1, 2 * 0.9 * 80, 80**2]))
    s3 = FLSettings(omega_g=80, omega_d=50, integral=True)
    g3 = dict(zip(GAIN_FIELDS, s3.gains(), strict=True))
    np.testing.assert_allclose(np.roots([1, g3["kd_d"], g3["kp_d"], g3["ki_d"]]).real, [-50, -50, -50], atol=0.05)


def test_settings_reject_bad_values():
    for bad in ({"omega_g": -1}, {"i_amp_max": 9.0}, {"observer_eps": 0}, {"nope": 1}):
        with pytest.raises(Exception):  # noqa: B017 - pydantic ValidationError
            FLSettings(**bad)
    with pytest.raises(ConfigError):
        from maglev_ocp.config import parse_model

        parse_model(FLSettings, {"omega_d": "fast"}, "x.yaml")


def _quantized_loop(ctrl, x0, n, ref_fn, params=NOMINAL, n_sub=10):
    """Stand-in plant: the shared model (RK4, n_sub sub-steps) with 10 um encoders."""
    from maglev_ocp.model import get_model

    F = get_model().step(k.Ts, n_sub)
    p = params.vector()
    x = np.asarray(x0, float)

    def meas(t):
        return Measurement(t, np.round(x[[0, 2]] / k.encoder_resolution) * k.encoder_resolution, x.copy())

    y = meas(0.0)
    ctrl.reset(y, ref_fn(0.0))
    xs, us = [], []
    for i in range(n):
        out = ctrl.step(y, ref_fn(i * k.Ts))
        us.append(out.u)
        x = np.asarray(F(x, out.u, p)).ravel()
        xs.append(x.copy())
        y = meas((i + 1) * k.Ts)
    return np.array(xs), np.array(us)


def test_hold_from_an_offset_on_the_model_with_quantized_encoders():
    """Starting 0.5 mm / 2 mm off, FL brings both axes within one encoder count and holds there."""
    ctrl = FeedbackLinearization(FLSettings(), NOMINAL)
    target = Reference(g=0.018, d=0.010)
    xs, us = _quantized_loop(ctrl, [0.0185, 0.0, 0.012, 0.0], 400, lambda t: target)
    tail = xs[-150:]
    assert np.max(np.abs(tail[:, 0] - target.g)) <= 1e-5
    assert np.max(np.abs(tail[:, 2] - target.d)) <= 1e-5
    assert np.max(np.hypot(us[:, 0], us[:, 1])) <= k.i_amp_max + 1e-12


def test_cogging_blind_model_relies_on_the_disturbance_estimate():
    """Against the model with cogging at 15 mm, the cogging-aware inversion holds without the disturbance
    observer, while a cogging-blind one is left with the cogging force as a steady offset."""
    target = Reference(g=0.015, d=0.028575)  # 3 t1 / 2: peak of the normal cogging force
    errs = {}
    for name, params in (("aware", NOMINAL), ("blind", NOMINAL.without_cogging())):
        ctrl = FeedbackLinearization(FLSettings(disturbance=False), params)
        xs, _ = _quantized_loop(ctrl, [0.015, 0.0, 0.028575, 0.0], 400, lambda t: target)
        errs[name] = np.max(np.abs(xs[-100:, [0, 2]] - [target.g, target.d]), axis=0)
    assert np.all(errs["aware"] <= 1e-5)
    # blind: the horizontal cogging force xi(15 mm) sin(3 pi / 2) / Mh ~ 0.63 m/s^2 over kp = w^2 -> ~44 um
    assert errs["blind"][1] > 2e-5


def test_law_failure_before_any_good_command_holds_the_hover_current(model, p_nom):
    """A non-finite law output on the very first step: the hover current at the reading (seed eq. (8) with
    cogging), flagged as a fallback and a failure, never 0 A; the integrators are kept."""
    ctrl = FeedbackLinearization(FLSettings(integral=True), NOMINAL)
    law = ctrl._law
    ctrl._law = lambda *a: [np.full(2, np.nan), np.full(2, np.nan), *law(*a)[2:]]
    y0 = Measurement(0.0, np.array([0.018, 0.01]), None)
    ref = Reference(g=0.018, d=0.01)
    ctrl.reset(y0, ref)
    out = ctrl.step(y0, ref)
    np.testing.assert_allclose(out.u, np.asarray(model.u_eq(0.018, 0.01, p_nom)).ravel(), rtol=1e-12)
    assert out.stats["fallback"] == 1 and out.stats["solver_failure"] == 1
    assert np.all(ctrl._z == 0.0)
    # a good step, then a failing one: the last good command is held
    ctrl._law = law
    good = ctrl.step(y0, ref)
    assert good.stats["fallback"] == 0
    ctrl._law = lambda *a: [np.full(2, np.nan), *law(*a)[1:]]
    held = ctrl.step(y0, ref)
    np.testing.assert_array_equal(held.u, good.u)
    assert held.stats["fallback"] == 1


def test_non_finite_reading_is_skipped_by_the_observer():
    """A NaN reading: the observer predicts only (its estimate stays finite) and the step is flagged."""
    ctrl = FeedbackLinearization(FLSettings(), NOMINAL)
    y0 = Measurement(0.0, np.array([0.020, 0.0]), None)
    ref = Reference(g=0.020, d=0.0)
    ctrl.reset(y0, ref)
    ctrl.step(y0, ref)
    out = ctrl.step(Measurement(0.001, np.array([np.nan, 0.0]), None), ref)
    assert np.all(np.isfinite(out.x_hat)) and np.all(np.isfinite(out.u))
    assert out.stats["fallback"] == 1 and out.stats["solver_failure"] == 0
    assert np.all(np.isfinite(ctrl.step(y0, ref).x_hat))
