"""Reference planner: rest-to-rest moves at the acceleration the current limits allow, from the model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.errors import ConfigError
from maglev_ocp.model import model_inverse_function
from maglev_ocp.params import NOMINAL
from maglev_ocp.reference import (
    Move,
    ReferenceSettings,
    Target,
    peak_acceleration_factor,
    plan_move,
    plan_targets,
    unit_profile,
)


@pytest.mark.parametrize("ramp", [0.0, 0.02, 0.1, 0.25])
def test_unit_profile_is_rest_to_rest_and_consistent(ramp):
    """s(0)=0, s(1)=1, zero velocity at both ends; s' and s'' are the derivatives of s."""
    tau = np.linspace(0, 1, 20001)
    s, v, a = unit_profile(tau, ramp)
    assert s[0] == 0 and s[-1] == pytest.approx(1.0, abs=1e-12)
    assert v[0] == pytest.approx(0.0, abs=1e-12) and v[-1] == pytest.approx(0.0, abs=1e-12)
    h = tau[1] - tau[0]
    np.testing.assert_allclose(np.gradient(s, h)[1:-1], v[1:-1], atol=1e-3)
    inner = np.abs(tau - 0.5) > 2e-3  # away from the bang-bang jump
    np.testing.assert_allclose(np.gradient(v, h)[1:-1][inner[1:-1]], a[1:-1][inner[1:-1]], atol=5e-2)
    assert np.max(np.abs(a)) == pytest.approx(peak_acceleration_factor(ramp), rel=1e-12)
    # outside the move: at rest
    s2, v2, a2 = unit_profile(np.array([-0.5, 1.5]), ramp)
    assert list(s2) == [0.0, 1.0] and not v2.any() and not a2.any()


def test_bang_bang_peak_factor_is_four():
    assert peak_acceleration_factor(0.0) == pytest.approx(4.0)
    assert peak_acceleration_factor(0.1) > 4.0


def _currents(move: Move, n: int = 401) -> np.ndarray:
    t = move.t0 + np.linspace(0, move.T, n)
    r = move.sample(t)
    inv = model_inverse_function()
    p = NOMINAL.vector()
    return np.array([np.asarray(inv([ri[0], ri[1], ri[3], ri[4]], [ri[2], ri[5]], p)[0]).ravel() for ri in r])


def test_traverse_at_full_current_matches_the_current_limited_minimum():
    """100 mm at 20 mm, whole current, pure bang-bang: about 0.089 s (issue 4), and the plan touches the limit."""
    st = ReferenceSettings(current_fraction=1.0, ramp_fraction=0.0)
    mv = plan_move((0.020, -0.05), (0.020, 0.05), NOMINAL, st)
    assert mv.T == pytest.approx(0.089, abs=0.002)
    # double-integrator check: T = 2 sqrt(D / a) with a = L1 * sqrt(8^2 - i_d^2) at the hover current
    L1 = NOMINAL.C1 * float(_f1(0.020))
    i_d = float(np.asarray(model_inverse_function()([0.02, 0, 0, 0], [0, 0], NOMINAL.vector())[0]).ravel()[1])
    T_dbl = 2 * math.sqrt(0.1 / (L1 * math.sqrt(k.i_amp_max**2 - i_d**2)))
    assert mv.T == pytest.approx(T_dbl, rel=0.03)  # differs only by the reluctance coupling and cogging
    amp = np.hypot(*_currents(mv).T)
    assert amp.max() <= k.i_amp_max * (1 + 1e-9)
    assert amp.max() >= 0.995 * k.i_amp_max


def _f1(g: float) -> float:
    from maglev_ocp.model import get_model

    return float(get_model().shape(g)[3])


def test_acceleration_follows_the_gap():
    """Thrust per ampere L1 = C1 f1 grows as the gap shrinks: the same traverse is faster at 15 mm than at 25 mm."""
    st = ReferenceSettings()
    T = [plan_move((g, -0.05), (g, 0.05), NOMINAL, st).T for g in (0.015, 0.020, 0.025)]
    assert T[0] < T[1] < T[2]


@pytest.mark.parametrize("frac", [0.6, 0.85])
def test_planned_currents_stay_within_the_fraction(frac):
    """A diagonal move: the model-inverse currents along the plan never exceed frac x 8 A, and the move is tight."""
    st = ReferenceSettings(current_fraction=frac, ramp_fraction=0.05)
    mv = plan_move((0.024, 0.04), (0.016, -0.03), NOMINAL, st)
    u = _currents(mv)
    amp = np.hypot(u[:, 0], u[:, 1])
    assert amp.max() <= frac * k.i_amp_max * (1 + 1e-6)
    assert amp.max() >= 0.97 * frac * k.i_amp_max  # a shorter move would not fit


def test_i_d_fraction_keeps_gap_headroom_while_the_thrust_uses_the_limits():
    """``i_d_fraction`` bounds i_d alone: a gap step is as at that fraction, a traverse uses the amplitude."""
    st = ReferenceSettings(current_fraction=0.97, i_d_fraction=0.85)
    gap = plan_move((0.015, 0.0), (0.025, 0.0), NOMINAL, st)
    u = _currents(gap)
    assert np.abs(u[:, 1]).max() <= 0.85 * k.i_axis_max * (1 + 1e-6)
    assert gap.T == pytest.approx(plan_move((0.015, 0.0), (0.025, 0.0), NOMINAL, ReferenceSettings()).T, rel=1e-3)
    trav = plan_move((0.020, -0.05), (0.020, 0.05), NOMINAL, st)
    u = _currents(trav)
    assert np.hypot(u[:, 0], u[:, 1]).max() >= 0.96 * k.i_amp_max  # the thrust takes the amplitude ...
    assert np.abs(u[:, 0]).max() > 0.85 * k.i_axis_max  # ... beyond what i_d may use
    assert trav.T == pytest.approx(
        plan_move((0.020, -0.05), (0.020, 0.05), NOMINAL, ReferenceSettings(current_fraction=0.97)).T, rel=1e-3
    )


def test_gap_moves_are_planned_too():
    mv = plan_move((0.015, 0.0), (0.025, 0.0), NOMINAL)
    assert 0.01 < mv.T < 0.2
    r = mv.sample(np.array([mv.T / 2]))[0]
    assert r[0] == pytest.approx(0.020, abs=1e-9) and r[1] > 0  # halfway and opening


def test_plan_targets_switch_times_and_continuity():
    tg = [Target(0.020, 0.0, 0.3), Target(0.016, 0.03, 0.4), Target(0.024, -0.02, 0.5)]
    plan = plan_targets((0.020, 0.0), tg, NOMINAL)
    np.testing.assert_allclose(plan.switch_times, [0.0, 0.3, 0.7])
    assert plan.duration == pytest.approx(1.2)
    t = np.arange(0, 1.2, 1e-4)
    r = plan.sample(t)
    for col in (0, 3):  # positions continuous: no step larger than the peak speed times the sample spacing
        assert np.max(np.abs(np.diff(r[:, col]))) <= np.max(np.abs(r[:, col + 1])) * 1e-4 * (1 + 1e-6)
    assert plan.target_index(0.5) == 1
    end = plan.at(0.3 + plan.moves[1].T + 1e-6)
    assert (end.g, end.d, end.g_dot, end.d_dot, end.d_ddot) == pytest.approx((0.016, 0.03, 0, 0, 0), abs=1e-12)
    assert "move [s]" in plan.table()


def test_hold_shorter_than_the_move_is_a_config_error():
    with pytest.raises(ConfigError, match=r"targets\[1\]\.hold"):
        plan_targets((0.02, 0.0), [Target(0.02, 0.0, 0.2), Target(0.02, 0.05, 0.02)], NOMINAL)


def test_step_shaping_jumps():
    plan = plan_targets((0.02, 0.0), [Target(0.016, 0.01, 0.2)], NOMINAL, ReferenceSettings(shaping="step"))
    r = plan.at(0.0)
    assert (r.g, r.d, r.g_dot) == (0.016, 0.01, 0.0)


def test_zoh_accelerations_are_the_period_mean():
    """With zoh = Ts the accelerations are (v(t+Ts) - v(t)) / Ts: one constant acceleration over the period
    then meets the reference velocity at the next sample exactly."""
    plan = plan_targets((0.02, -0.05), [Target(0.02, 0.05, 0.3)], NOMINAL)
    t = np.arange(0, 0.12, k.Ts)
    inst = plan.sample(t)
    z = plan.sample(t, zoh=k.Ts)
    ahead = plan.sample(t + k.Ts)
    np.testing.assert_allclose(inst[:, 4] + k.Ts * z[:, 5], ahead[:, 4], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(z[:, [0, 1, 3, 4]], inst[:, [0, 1, 3, 4]])
    assert np.max(np.abs(z[:, 5] - inst[:, 5])) > 1.0  # differs during the ramps of a fast move
    r = plan.at(0.01)
    assert r.d_ddot == pytest.approx(z[10, 5]) and plan.at(0.01, zoh=None).d_ddot == pytest.approx(inst[10, 5])
