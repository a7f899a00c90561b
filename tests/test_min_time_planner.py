"""The profile planner of ``shaping: min_time`` (issue 29, item 3): minimum-time moves in milliseconds.

Fast: random moves of the envelope (seeded) against the minimum-time NLP
(within 1 % above it; every move's currents within the limits on the shared
model's exact inverse; positions, velocities and accelerations one motion);
a horizontal move at a constant gap without cogging against the closed-form
bang-bang time from the spec's equations (retyped here from
``spec/MODEL.md``, not taken from the code); the plan cache; the setting's
validation. Slow: more random moves against the NLP.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from benchmarks.min_time_planner import SETTINGS, envelope_moves, kinematic_error, violations
from maglev_ocp import constants as k
from maglev_ocp.params import NOMINAL
from maglev_ocp.reference import ReferenceSettings, TabulatedMove, plan_min_time_move
from maglev_ocp.reference.min_time import _min_time_table, _profile_table, min_time_table, unsmoothed_duration


def _compare(moves) -> list[tuple[float, float, int]]:
    """``(T_profile, T_nlp, violating rows)`` per move (durations without the smoothing)."""
    pvec = tuple(NOMINAL.vector().tolist())
    st = SETTINGS
    out = []
    for p0, p1 in moves:
        tab = _profile_table.__wrapped__(
            p0,
            p1,
            pvec,
            st.axis_limit_fraction * k.i_axis_max,
            st.i_d_limit_fraction * k.i_axis_max,
            st.current_fraction * k.i_amp_max,
        )
        ref = _min_time_table.__wrapped__(p0, p1, pvec, st.current_fraction, st.axis_limit_fraction, st.i_d_fraction)
        assert tab is not None and ref is not None
        ev, ep = kinematic_error(tab[1], tab[2])  # the rows are one motion: each the integral of the next
        assert ev < 0.015 and ep < 1e-6  # the rest rows at both ends (acceleration 0 at t0) cost ~0.7 %
        out.append((unsmoothed_duration(tab), unsmoothed_duration(ref), violations(tab[2])))
    return out


def test_random_moves_within_one_percent_of_the_nlp_and_feasible():
    """6 random moves (seed 41): at most 1 % longer than the NLP's, no row beyond the limits on the model."""
    for T, T_nlp, bad in _compare(envelope_moves(6, 41)):
        assert bad == 0
        assert T <= 1.01 * T_nlp
        # shorter than the NLP's local solution happens (bent paths it did not find), but not by much
        assert T >= 0.95 * T_nlp


@pytest.mark.slow
def test_many_random_moves_within_one_percent_of_the_nlp():
    """40 random moves (seed 7): at most 1 % longer than the NLP's, no row beyond the limits."""
    res = _compare(envelope_moves(40, 7))
    assert all(bad == 0 for _, _, bad in res)
    assert max(T / T_nlp for T, T_nlp, _ in res) <= 1.01


def _spec_thrust_at_hover(g: float, amp: float, lim_d: float) -> float:
    """Largest |d_ddot| hovering at gap ``g`` on the current circle ``amp`` (spec/MODEL.md, no cogging)."""
    b0, t1, hm, mu_rec, tau, taup, Br = 12.7e-3, 19.05e-3, 5e-3, 1.05, 57.15e-3, 28.58e-3, 4e-7 * math.pi * 875400
    lam = 1 - b0**2 / (4 * t1 * (g + b0 / 2 + hm / mu_rec))
    r = b0 / (2 * g)
    gam = (4 / math.pi) * (r * math.atan(r) - math.log(math.sqrt(1 + r**2)))
    Kc = t1 / (t1 - gam * g)
    a = math.pi * (hm + g) / tau
    B = (4 / math.pi) * Br * math.sin(math.pi * taup / (2 * tau)) * math.sinh(math.pi * hm / tau) / math.sinh(a)
    f1, f2 = lam / (Kc * math.sinh(a)), lam * B**2
    f3, f4 = lam * B / math.tanh(a) / Kc, lam / math.tanh(a) ** 2 / Kc**2
    C1, C2, C3, C4, G = 14.20, 796.99, 31.04, 0.07, 9.81
    # hover on the circle: G - C4 f4 amp^2 + C3 f3 i_d - C2 f2 = 0
    i_d = (C2 * f2 + C4 * f4 * amp**2 - G) / (C3 * f3)
    assert abs(i_d) <= lim_d  # the amplitude, not the i_d limit, binds at these gaps
    return C1 * f1 * math.sqrt(amp**2 - i_d**2)


@pytest.mark.parametrize("g", [0.017, 0.022])
def test_constant_gap_move_is_the_closed_form_bang_bang(g):
    """Without cogging, d -40 -> 40 mm along the straight path at a constant gap: T = 2 sqrt(D / a_max) with
    a_max from the spec. The planner itself may close the gap mid-move (a dip: more thrust per ampere), so its
    move is at most that long and stays within the gap envelope."""
    from maglev_ocp.reference.profile_plan import STRAIGHT, path_profiles

    st = ReferenceSettings(shaping="min_time", current_fraction=0.97, i_d_fraction=0.85)
    params = NOMINAL.without_cogging()
    a_max = _spec_thrust_at_hover(g, 0.97 * k.i_amp_max, 0.85 * k.i_axis_max)
    expected = 2.0 * math.sqrt(0.08 / a_max)
    keep = 1.0 - 2e-4  # the planner's first margin from the limits
    lims = (keep * 0.97 * k.i_axis_max, keep * 0.85 * k.i_axis_max, keep * 0.97 * k.i_amp_max)
    (straight,) = path_profiles((g, -0.04), (g, 0.04), params, *lims, shapes=(STRAIGHT,))
    # the 2e-4 margin and each grid segment's weaker end: >= expected, and close to it
    assert straight.T == pytest.approx(expected, rel=2e-3)
    assert straight.T >= expected * (1 - 1e-6)
    tab = min_time_table((g, -0.04), (g, 0.04), params, st)
    assert unsmoothed_duration(tab) <= straight.T * (1 + 1e-9)
    gaps = tab[2][:, 0]
    assert k.g_envelope[0] - 1e-9 <= gaps.min() and gaps.max() <= g + 1e-9  # a dip only closes the gap


def test_repeated_moves_come_from_the_cache():
    """The same move planned twice (another start time) is one planning; the table is the same object."""
    st = ReferenceSettings(shaping="min_time", current_fraction=0.97, i_d_fraction=0.85)
    a = plan_min_time_move((0.019, -0.02), (0.021, 0.03), NOMINAL, st, t0=0.0)
    hits = min_time_table.__globals__["_profile_table"].cache_info().hits
    b = plan_min_time_move((0.019, -0.02), (0.021, 0.03), NOMINAL, st, t0=1.0)
    assert isinstance(a, TabulatedMove) and isinstance(b, TabulatedMove)
    assert b.rows is a.rows and b.t0 == 1.0
    assert min_time_table.__globals__["_profile_table"].cache_info().hits == hits + 1


def test_min_time_solver_is_validated():
    """An unknown planner is refused with the allowed values."""
    with pytest.raises(ValidationError, match="profile"):
        ReferenceSettings(shaping="min_time", min_time_solver="fast")
    assert ReferenceSettings().min_time_solver == "profile"
    np.testing.assert_equal(ReferenceSettings(min_time_solver="nlp").min_time_solver, "nlp")


def test_a_dip_is_a_smooth_gap_excursion_inside_the_envelope():
    """The dip's bump has the derivatives its path uses (finite differences), and is offered only where the
    path stays within the gap envelope."""
    from maglev_ocp.reference.profile_plan import PathShape, bump, candidate_shapes

    s = np.linspace(0.0, 1.0, 2001)
    b0, b1, b2 = bump(s)
    assert b0.max() == pytest.approx(1.0) and b0[0] == b0[-1] == 0.0 and b1[0] == b1[-1] == 0.0
    np.testing.assert_allclose(np.gradient(b0, s)[5:-5], b1[5:-5], atol=1e-4)
    np.testing.assert_allclose(np.gradient(b1, s)[5:-5], b2[5:-5], atol=1e-3)
    mid = candidate_shapes(0.0, 0.03, 0.020)
    assert any(sh.dip < 0 for sh in mid)
    assert not any(sh.dip for sh in candidate_shapes(0.0, 0.03, k.g_envelope[0] + 1e-4))  # no room below
    assert not any(sh.dip for sh in candidate_shapes(0.008, 0.01, 0.017))  # the gap's own change: bends
    (g, _, _), _ = PathShape(dip=-1e-3).axes(s, (0.0, 0.03))
    assert g.min() == pytest.approx(-1e-3)
