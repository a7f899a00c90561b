"""``shaping: min_time``: minimum-time moves within fractions of the current limits.

Two planners give the move (``reference.min_time_solver``):

- ``profile`` (default): the time-optimal parameterization of the straight
  path at the bounds the limits give at each point
  (:mod:`maglev_ocp.reference.profile_plan`), a few milliseconds per move;
- ``nlp``: the minimum-time NLP (:func:`maglev_ocp.ocp.min_time.solve_min_time`,
  IPOPT, 0.1-0.4 s per move), the reference the profile is checked against
  (``python -m benchmarks.min_time_planner``): it may also bend the path
  within the gap's 0.1 mm band, and is 1-3 % faster.

Both moves are smoothed the same way (:func:`_smoothed`) and cached per move
(start, end, model constants and fractions of the limits), so a campaign whose
runs repeat a move plans it once per process. Every ``profile`` move is
checked on the controller's model after smoothing (the model file's static
effects included) and never returned when it exceeds the limits.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .. import constants as k
from ..errors import ConfigError
from ..ocp.min_time import MinTimeSettings, solve_min_time
from ..params import Params
from .feasibility import PlanEffects, _limits_ok
from .profile_plan import PROFILE_MARGINS, candidate_shapes, path_profiles, refined_shapes, table_length
from .profiles import Move, TabulatedMove
from .settings import ReferenceSettings
from .trajectory import plan_move

_log = logging.getLogger(__name__)

#: Rounding of a move's end points in the plan cache's key [m] (float noise, far below the 10 um encoders).
CACHE_ROUND_M = 1e-9

#: Table step of a minimum-time move [s] (a tenth of the control period).
MIN_TIME_TABLE_STEP = 1e-4
#: Moving-average width applied to a minimum-time move [s]: jerk-limits its bang-bang accelerations
#: (3 ms: measured on the tours, 2 ms leaves overshoots, 4 ms slower moves).
MIN_TIME_SMOOTHING = 3e-3
#: IPOPT tolerance of a planned minimum-time move: its duration within 0.02 % of the 1e-9 solution
#: (measured on four moves), in about half the iterations' time.
MIN_TIME_TOL = 1e-6
#: IPOPT iterations of the first attempt (from the straight move's duration) before the default start.
MIN_TIME_GUESSED_ITER = 150
#: Shooting intervals of a planned minimum-time move: 1.5 ms for a 75 ms move gives its duration within
#: 0.01 % of the 150-interval solution (measured on three moves) in a tenth of the solve time.
MIN_TIME_INTERVALS = 50
#: IPOPT's Hessian for a planned move: L-BFGS halves the solve (the exact Hessian of the mapped RK4 is most
#: of it); durations within 0.02 % of the exact Hessian's on 11 random moves (campaigns plan one per target).
MIN_TIME_HESSIAN = "limited-memory"
#: Band of ``d`` about the segment between a planned move's start and end [m]: none. With ``i_d`` held
#: below its limit the minimum-time gap move otherwise spends the amplitude left to ``i_q`` on its
#: reluctance pull (``C4 f4 i_q^2``, seed eq. (2)) with alternating signs, and ``d`` swings by 0.25-0.55 mm
#: while only the gap moves (outside the 0.1 mm tolerance, and the tracked plan's d error is still tens of
#: um when the gap arrives) to gain 0.7 % of the move (41.26 -> 41.57 ms for 15 -> 25 mm).
MIN_TIME_D_BAND = 0.0


@functools.lru_cache(maxsize=256)
def _min_time_table(
    p0: tuple[float, float],
    p1: tuple[float, float],
    pvec: tuple[float, ...],
    frac: float,
    frac_axis: float,
    frac_id: float | None = None,
):
    """``(T, tau, rows)`` of the minimum-time move within the fractions of the limits, or ``None`` if not solved."""
    params = Params.from_vector(np.asarray(pvec))
    st = MinTimeSettings(
        n_intervals=MIN_TIME_INTERVALS,
        i_axis=frac_axis * k.i_axis_max,
        i_amp=frac * k.i_amp_max,
        i_d_max=None if frac_id is None else frac_id * k.i_axis_max,
        tol=MIN_TIME_TOL,
        hessian=MIN_TIME_HESSIAN,
        d_band=MIN_TIME_D_BAND,
    )
    # First with the straight bang-bang move's duration as the guess of T (a third of the solve time on
    # long moves) and few iterations; moves mostly of the gap converge from it poorly: then from the default.
    try:
        guess = plan_move(p0, p1, params, ReferenceSettings(current_fraction=frac, ramp_fraction=0.0)).T
        res = solve_min_time(p0, p1, params, replace(st, max_iter=MIN_TIME_GUESSED_ITER), T_guess=guess)
    except ConfigError:
        res = None
    if res is None or not res.success:
        res = solve_min_time(p0, p1, params, st)
    if not res.success:
        return None
    tau = np.linspace(0.0, res.T, table_length(res.T, MIN_TIME_TABLE_STEP))
    smp = res.sample(tau)
    x, acc = smp["x"], smp["acc"]
    rows = np.column_stack([x[:, 0], x[:, 1], acc[:, 0], x[:, 2], x[:, 3], acc[:, 1]])
    rows[0, [1, 2, 4, 5]] = rows[-1, [1, 2, 4, 5]] = 0.0
    return _smoothed(res.T, rows, MIN_TIME_SMOOTHING)


def _smoothed(T: float, rows: np.ndarray, width: float) -> tuple[float, np.ndarray, np.ndarray]:
    """``(T + width, tau, rows)``: the move filtered by a causal moving average of ``width`` seconds.

    The minimum-time move switches its currents, hence its accelerations, at
    once (bang-bang), and the amplifiers cannot follow a jump (their lag, a
    delay): the mover then overshoots where the move ends. The same moving
    average on every row keeps the rows consistent (the filtered velocity is the
    derivative of the filtered position), keeps the move rest-to-rest between
    the same points and caps the jerk at ``2 a_max / width``; the move lasts
    ``width`` longer.
    """
    n = max(round(width / MIN_TIME_TABLE_STEP), 1)
    if n == 1:
        return T, np.linspace(0.0, T, len(rows)), rows
    h = T / (len(rows) - 1)
    tau = np.arange(len(rows) + n - 1) * h
    out = np.empty((len(tau), 6))
    kern = np.ones(n) / n
    for j in range(6):
        padded = np.concatenate([np.full(n - 1, rows[0, j]), rows[:, j], np.full(n - 1, rows[-1, j])])
        out[:, j] = np.convolve(padded, kern, mode="valid")[: len(tau)]
    return float(tau[-1]), tau, out


@functools.lru_cache(maxsize=1024)
def _profile_table(
    p0: tuple[float, float],
    p1: tuple[float, float],
    pvec: tuple[float, ...],
    lim_q: float,
    lim_d: float,
    lim_amp: float,
    effects: PlanEffects | None = None,
):
    """``(T, tau, rows)`` of the fastest path profile whose smoothed move passes the model check; ``None`` if none.

    The candidates are the straight path and, for a move that changes the gap
    and ``d``, bent paths (:func:`~maglev_ocp.reference.profile_plan.candidate_shapes`,
    :func:`~maglev_ocp.reference.profile_plan.path_profiles`). Their bounds are
    computed with the limits narrowed by each of
    :data:`~maglev_ocp.reference.profile_plan.PROFILE_MARGINS` in turn; the
    fastest candidate whose smoothed move's currents (the shared inverse, with
    ``effects``) are within the limits themselves at every table point is kept.
    """
    params = Params.from_vector(np.asarray(pvec))
    lim_axes = np.array([lim_q, lim_d])
    shapes = candidate_shapes(p1[0] - p0[0], p1[1] - p0[1], p0[0])
    for margin in PROFILE_MARGINS:
        keep = 1.0 - margin
        lims = (keep * lim_q, keep * lim_d, keep * lim_amp)
        profiles = path_profiles(p0, p1, params, *lims, effects)  # straight: exact in one pass
        if profiles is None:
            return None
        if len(shapes) > 1:  # bent paths: iterated with their speed
            profiles += path_profiles(p0, p1, params, *lims, effects, shapes[1:], prune_above=profiles[0].T) or []
            fastest = min(profiles, key=lambda pr: pr.T)
            finer = refined_shapes(fastest.shape, p0[0], p1[0] - p0[0])
            if finer:  # the candidates are a coarse grid of continuous families: a second pass around the best
                profiles += path_profiles(p0, p1, params, *lims, effects, finer, prune_above=fastest.T) or []
        for prof in sorted(profiles, key=lambda pr: pr.T):
            if not np.isfinite(prof.T):
                continue
            tau = np.linspace(0.0, prof.T, table_length(prof.T, MIN_TIME_TABLE_STEP))
            rows = prof.sample(p0, p1, tau)
            rows[0, [1, 2, 4, 5]] = rows[-1, [1, 2, 4, 5]] = 0.0  # at rest at both ends (as the NLP's table)
            tab = _smoothed(prof.T, rows, MIN_TIME_SMOOTHING)
            if _limits_ok(tab[2], params, lim_axes, lim_amp, effects):
                return tab
    return None


def min_time_table(
    p0: tuple[float, float],
    p1: tuple[float, float],
    params: Params,
    settings: ReferenceSettings,
    effects: PlanEffects | None = None,
):
    """``(T, tau, rows)`` of the minimum-time move by ``settings.min_time_solver``, or ``None`` (cached per move).

    ``T`` includes the :data:`MIN_TIME_SMOOTHING`; ``rows`` are the reference
    rows (g, g_dot, g_ddot, d, d_dot, d_ddot) at the times ``tau``.
    """

    def rounded(p: tuple[float, float]) -> tuple[float, float]:
        return (round(p[0] / CACHE_ROUND_M) * CACHE_ROUND_M, round(p[1] / CACHE_ROUND_M) * CACHE_ROUND_M)

    a, b = rounded(p0), rounded(p1)
    pvec = tuple(params.vector().tolist())
    if settings.min_time_solver == "nlp":
        return _min_time_table(
            a, b, pvec, settings.current_fraction, settings.axis_limit_fraction, settings.i_d_fraction
        )
    lim_q = settings.axis_limit_fraction * k.i_axis_max
    lim_d = settings.i_d_limit_fraction * k.i_axis_max
    return _profile_table(a, b, pvec, lim_q, lim_d, settings.current_fraction * k.i_amp_max, effects)


def unsmoothed_duration(tab: tuple[float, np.ndarray, np.ndarray]) -> float:
    """Duration [s] of a table ``(T, tau, rows)`` before :func:`_smoothed` added its moving average's width."""
    n = max(round(MIN_TIME_SMOOTHING / MIN_TIME_TABLE_STEP), 1)
    tau = tab[1]
    return float(tab[0] - (n - 1) * (tau[1] - tau[0]))


def plan_min_time_move(
    p0: Sequence[float],
    p1: Sequence[float],
    params: Params,
    settings: ReferenceSettings,
    t0: float = 0.0,
    effects: PlanEffects | None = None,
) -> Move | TabulatedMove:
    """The minimum-time move from ``p0`` to ``p1`` within ``current_fraction`` of the limits (``shaping: min_time``).

    Planned on the controller's model constants by ``settings.min_time_solver``
    (:func:`min_time_table`, cached per move); a move of less than 1 mm or one
    the planner cannot give is planned as ``trajectory`` (:func:`plan_move`).
    With ``effects`` (the static effects of the controller's model file) the
    move's currents are checked on the model with them
    (:func:`~maglev_ocp.reference.feasibility.planning_inverse_function`, the
    same fractions of the limits) and a move that does not fit is planned as
    ``trajectory`` on that model instead.
    """
    a, b = (float(p0[0]), float(p0[1])), (float(p1[0]), float(p1[1]))
    if max(abs(b[0] - a[0]), abs(b[1] - a[1])) >= 1e-3:
        tab = min_time_table(a, b, params, settings, effects)
        if tab is None:
            _log.warning("minimum-time move %s -> %s m not planned: planned as a trajectory", a, b)
        else:
            mv = TabulatedMove(t0, tab[0], a, b, tab[1], tab[2])
            lim_axes = np.array([settings.axis_limit_fraction, settings.i_d_limit_fraction]) * k.i_axis_max
            if (
                effects is None
                or settings.min_time_solver == "profile"
                or _limits_ok(tab[2], params, lim_axes, settings.current_fraction * k.i_amp_max, effects)
            ):
                return mv
            _log.info("minimum-time move %s -> %s m exceeds the limits with the model's effects: trajectory", a, b)
    return plan_move(a, b, params, settings, t0=t0, effects=effects)
