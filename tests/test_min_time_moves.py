"""Moves at the limit by default (issue 12, item 4): the NMPC plans minimum-time moves and tracks them.

Fast: the tabulated minimum-time move is rest to rest and consistent; the
asymmetric profile is rest to rest and free timing is never slower; the
planner's feasibility check uses the controller's model file (constants and
effects); the NMPC's planning defaults fill only the ``reference:`` keys a
scenario leaves open (FL keeps the suite's defaults). Slow: default settings,
default plant, random start and end points (seeded, not the shipped ones):
every move of >= 60 mm settles within 1.05 x the minimum time of the same move
(:func:`maglev_ocp.ocp.min_time.solve_min_time`).
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.min_time_moves import random_moves
from maglev_ocp import constants as k
from maglev_ocp.effects import EffectSet
from maglev_ocp.model import get_model
from maglev_ocp.ocp.min_time import solve_min_time
from maglev_ocp.output import dump_yaml
from maglev_ocp.params import NOMINAL
from maglev_ocp.reference import (
    ReferenceSettings,
    TabulatedMove,
    plan_min_time_move,
    plan_move,
    planning_inverse_function,
    split_profile,
    unit_profile,
)
from maglev_ocp.reference.min_time import MIN_TIME_SMOOTHING
from maglev_ocp.runner import plan_run, run_scenario
from maglev_ocp.scenario import scenario_from_dict


def _scenario(ctrl: dict, start, end, reference: dict | None = None) -> dict:
    sc = {
        "name": "min_time_move",
        "seed": 3,
        "controller": ctrl,
        "plant": {"profile": "default"},
        "start": {"g": start[0], "d": start[1]},
        "targets": [{"g": end[0], "d": end[1], "hold": 0.4}],
    }
    if reference is not None:
        sc["reference"] = reference
    return sc


def test_min_time_move_is_rest_to_rest_and_consistent():
    st = ReferenceSettings(shaping="min_time", current_fraction=0.97)
    mv = plan_min_time_move((0.018, -0.03), (0.021, 0.04), NOMINAL, st, t0=0.5)
    assert isinstance(mv, TabulatedMove)
    r = mv.sample(np.array([0.0, 0.5, 0.5 + mv.T, 2.0]))
    np.testing.assert_allclose(r[[0, 1], :], [[0.018, 0, 0, -0.03, 0, 0]] * 2, atol=1e-12)
    np.testing.assert_allclose(r[[2, 3], :], [[0.021, 0, 0, 0.04, 0, 0]] * 2, atol=1e-9)
    # velocity integrates to the displacement, acceleration to zero velocity change
    assert np.trapezoid(mv.rows[:, 4], mv.tau) == pytest.approx(0.07, rel=1e-3)
    # (within the trapezoid rule's error at the two acceleration steps where the unsmoothed move leaves and
    # reaches rest: half a table step times each step, at most a step times the peak acceleration)
    h = mv.tau[1] - mv.tau[0]
    assert abs(np.trapezoid(mv.rows[:, 5], mv.tau)) < h * np.max(np.abs(mv.rows[:, 5]))
    # below 1 mm the jerk-limited trajectory is planned instead
    assert not isinstance(plan_min_time_move((0.02, 0.0), (0.02, 5e-4), NOMINAL, st), TabulatedMove)


def test_scenario_reference_settings_reach_the_plan():
    mt = {"shaping": "min_time", "current_fraction": 0.97, "axis_fraction": 0.87}
    nm = scenario_from_dict(_scenario({"type": "nmpc"}, (0.02, -0.03), (0.02, 0.03), mt))
    assert nm.reference.shaping == "min_time" and nm.reference.current_fraction == 0.97
    assert nm.reference.axis_fraction == 0.87
    fl = scenario_from_dict(_scenario({"type": "fl"}, (0.02, -0.03), (0.02, 0.03)))
    assert fl.reference == ReferenceSettings()
    # the NMPC's defaults: minimum-time moves at 0.97 of the limits, FL's headroom kept on i_d
    dflt = scenario_from_dict(_scenario({"type": "nmpc"}, (0.02, -0.03), (0.02, 0.03))).reference
    assert dflt.shaping == "min_time" and dflt.current_fraction == 0.97 and dflt.i_d_limit_fraction == 0.85
    assert dflt.gap_timing == "free" and dflt.d_timing == "free"
    # keys a scenario sets win: FL's plan on request
    own = scenario_from_dict(
        _scenario({"type": "nmpc"}, (0.02, -0.03), (0.02, 0.03), {"shaping": "trajectory", "current_fraction": 0.8})
    )
    assert own.reference.shaping == "trajectory" and own.reference.current_fraction == 0.8


@pytest.mark.parametrize("split", [0.3, 0.5, 0.62])
def test_split_profile_is_rest_to_rest_and_consistent(split):
    tau = np.linspace(-0.1, 1.1, 24001)
    s, v, a = split_profile(tau, 0.02, split)
    assert s[0] == 0 and s[-1] == 1 and v[0] == v[-1] == 0 and a[0] == a[-1] == 0
    # velocity integrates to the position, acceleration to the velocity (to the grid's accuracy)
    np.testing.assert_allclose(np.concatenate([[0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(tau))]), s, atol=1e-6)
    np.testing.assert_allclose(np.concatenate([[0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(tau))]), v, atol=1e-3)
    # the peak velocity at the split, the accelerations of the two phases in the ratio (1 - split) / split
    assert tau[np.argmax(v)] == pytest.approx(split, abs=1e-3)
    assert a.max() / -a.min() == pytest.approx((1 - split) / split, rel=1e-9)
    if split == 0.5:
        np.testing.assert_array_equal(np.stack(split_profile(tau, 0.02, 0.5)), np.stack(unit_profile(tau, 0.02)))


def test_free_timing_plans_gap_changing_moves_faster():
    """A move that opens the gap 6.5 mm: accelerate harder at the small gap, open it late (the minimum-time shape)."""
    st = {"current_fraction": 0.97, "i_d_fraction": 0.85, "ramp_fraction": 0.02}
    p0, p1 = (0.0176, -0.023), (0.0241, 0.0385)
    sym = plan_move(p0, p1, NOMINAL, ReferenceSettings(**st))
    free = plan_move(p0, p1, NOMINAL, ReferenceSettings(**st, gap_timing="free", d_timing="free"))
    assert free.T < 0.985 * sym.T  # measured: 2.9 % shorter
    assert free.split < 0.5 and free.gap_T is not None and free.gap_start > 0  # accelerates first, gap later
    r = free.sample(np.linspace(0, free.T, 4001))
    assert r[:, 5].max() > 1.05 * -r[:, 5].min()  # harder acceleration than braking (thrust is larger at 17.6 mm)
    np.testing.assert_allclose(free.sample(np.array([free.T + 1e-3]))[0], [p1[0], 0, 0, p1[1], 0, 0], atol=1e-12)


def _model_file(tmp_path, effects: dict) -> str:
    path = tmp_path / "model.yaml"
    consts = {n: float(getattr(NOMINAL, n)) for n in ("C1", "C2", "C3", "C4", "xi0", "ell", "Mh", "Mv")}
    dump_yaml(path, {**consts, "effects": {n: {"enabled": True, **v} for n, v in effects.items()}})
    return str(path)


def test_planning_inverse_solves_the_model_with_effects():
    """Newton on the model plus effects: the currents give the asked accelerations (commutation offset rotates them)."""
    names = ("commutation_offset", "saturation")
    es = EffectSet(names)
    theta = es.vector({"commutation_offset": {"delta": 0.15}, "saturation": {"loss_8mm": 0.3, "ell_sat": 5e-3}})
    inv = planning_inverse_function(names)
    acc = es.accel_function()
    p = NOMINAL.vector()
    for x, a in (([0.016, 0.0, -0.02, 0.5], [3.0, 40.0]), ([0.024, -0.1, 0.03, 1.0], [-5.0, -35.0])):
        u, unr = inv(x, a, p, theta)
        assert float(unr) == 0
        np.testing.assert_allclose(np.asarray(acc(x, u, p, theta)).ravel(), a, atol=1e-6)
        u0 = np.asarray(get_model().u_eq(x[0], x[2], p)).ravel()  # sanity: not the hover currents
        assert np.linalg.norm(np.asarray(u).ravel() - u0) > 1.0
    # beyond the field's reach: flagged
    assert float(inv([0.02, 0, 0, 0], [400.0, 0.0], p, theta)[1]) == 1


def test_plan_uses_the_controllers_model_file(tmp_path):
    """A model file whose thrust is weaker (saturation) gives longer moves whose currents fit on that model."""
    start, end = (0.018, -0.04), (0.02, 0.04)
    weak = {"saturation": {"loss_8mm": 0.3, "ell_sat": 5e-3}}
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    files = (_model_file(tmp_path / "a", {}), _model_file(tmp_path / "b", weak))
    plain, sat = (plan_run(scenario_from_dict(_scenario({"type": "nmpc", "model": f}, start, end))) for f in files)
    T0, T1 = plain.plan.moves[0].T, sat.plan.moves[0].T
    # the effect's thrust loss at the move's mean gap (19 mm, from the effect law, not the planner) stretches a
    # thrust-limited move by 1 / sqrt(1 - loss) (3.3 %: 1.017); the profile planner measured 1.016
    es = EffectSet(("saturation",))
    theta = es.vector(weak)
    x, u = [0.019, 0.0, 0.0, 0.0], [7.0, 3.0]
    a_eff = float(np.asarray(es.accel_function()(x, u, NOMINAL.vector(), theta)).ravel()[1])
    a_nom = float(np.asarray(get_model().f(x, u, NOMINAL.vector())).ravel()[3])
    expected = 1.0 / np.sqrt(a_eff / a_nom)
    sm = MIN_TIME_SMOOTHING  # both moves include it
    assert (T1 - sm) / (T0 - sm) == pytest.approx(expected, abs=0.006)
    # the weaker model's move: currents within 0.97 of the limits on the model with the effect
    inv = planning_inverse_function(("saturation",))
    r = sat.refs[: round(sat.plan.moves[0].T / k.Ts)]
    for row in r[::5]:
        u, unr = inv([row[0], row[1], row[3], row[4]], [row[2], row[5]], NOMINAL.vector(), theta)
        assert float(unr) == 0 and np.hypot(*np.asarray(u).ravel()) <= 0.97 * k.i_amp_max + 0.05


@pytest.mark.slow
def test_random_moves_settle_within_105_percent_of_the_minimum_time():
    """Issue 12: default NMPC settings, default plant, random 60-100 mm moves (seed 2026): settle <= 1.05 T_min.

    Measured 1.011-1.024 x on these moves; ``python -m benchmarks.min_time_moves --seeds 2026 99 7 31``
    (32 moves): 1.014 x median, 1.025 x worst.
    """
    for start, end in random_moves(8, 2026):
        t_min = solve_min_time(start, end).T
        res = run_scenario(_scenario({"type": "nmpc"}, start, end), progress=False)
        tg = res.metrics.targets[0]
        assert tg.settled and res.metrics.stop_hits == 0, (start, end)
        assert tg.settle_time_s <= 1.05 * t_min, (start, end, tg.settle_time_s, t_min)
