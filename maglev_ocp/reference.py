"""Reference generator: point-to-point moves that the current limits allow.

A set-point step of 100 mm would ask any controller for an acceleration the
8 A amplifiers cannot give, and a saturated loop on an open-loop unstable axis
is a poor way to move. This module plans, for each target of a scenario, a
smooth rest-to-rest move of the shortest duration whose *model-inverse*
currents stay within a fraction of the limits along the whole path:

- the shape is a jerk-limited bang-bang profile (trapezoidal acceleration,
  ``ramp_fraction`` of the move spent ramping; 0 gives pure bang-bang, the
  time-optimal profile of a double integrator);
- both axes share one duration ``T`` (a straight line in the ``(g, d)`` plane);
  with ``d_timing: free`` the horizontal axis may accelerate for less or more
  than half of it (:func:`split_profile`), with ``gap_timing: free`` the gap may
  change in a part of it, each placed where the move is shortest (a move that
  changes the gap by several mm is then a few per cent shorter: it accelerates
  at the smaller gap, where the thrust per ampere is larger);
- ``T`` is the smallest duration (bisection) for which the currents of the
  controller's model's exact inverse (cogging included, see
  :func:`maglev_ocp.model.model_inverse_function`; with the static effects of
  the controller's model file, :func:`planning_inverse_function`) along the
  planned states and accelerations satisfy ``|i_q|, |i_d| <= f * 8 A`` and
  ``sqrt(i_q^2 + i_d^2) <= f * 8 A`` with ``f = current_fraction``. So the
  acceleration is the one the limits allow *at the gaps the move passes*
  (larger at small gaps, where ``L1 = C1 f1`` is larger, and less when the
  hover current already takes part of the amplitude).

The remaining fraction ``1 - f`` of the current is the feedback's margin.
The same plan serves every controller: the runner hands each controller
:meth:`ReferencePlan.at` at every step (positions and velocities at the
sample, accelerations averaged over the coming 1 ms period, which is what a
zero-order-held current can deliver), and a controller with a horizon can
read ahead with :meth:`ReferencePlan.sample` (the runner calls a controller's
``set_reference_plan(plan)`` if it has one).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import casadi as ca
import numpy as np
from pydantic import Field

from . import constants as k
from .blocks import Reference
from .config import Strict
from .effects import EffectSet, effect_delta_function
from .errors import ConfigError
from .fastcall import BufferedFunction
from .model import get_model, model_inverse_function
from .ocp.min_time import MinTimeSettings, solve_min_time
from .params import NOMINAL, Params

_log = logging.getLogger(__name__)


class ReferenceSettings(Strict):
    """How targets become references (a scenario's ``reference:`` block).

    Attributes
    ----------
    shaping : {"trajectory", "step", "min_time"}
        ``trajectory``: plan a current-feasible move to each target (default);
        ``step``: jump the set-point to the target at its switch time;
        ``min_time``: the minimum-time move of the controller's model within
        ``current_fraction`` of the current limits (``i_d`` within
        ``i_d_fraction`` of its axis limit if given)
        (:func:`maglev_ocp.ocp.min_time.solve_min_time`, gap kept between the
        start and target gaps), a move at the limits for a controller that
        handles them itself (an option of the NMPC, see
        :meth:`maglev_ocp.controllers.nmpc.NMPCSettings.reference_defaults`); a move the
        solver does not converge on falls back to ``trajectory``.
    current_fraction : float
        Fraction of the current limits the planned feedforward may use; the
        rest is left to the feedback.
    ramp_fraction : float
        Fraction of the move spent ramping the acceleration up or down
        (0 = pure bang-bang; at most 0.25).
    axis_fraction : float or None
        Fraction of the per-axis limit (8 A on ``i_q`` and on ``i_d``) the
        planned feedforward may use, when it should differ from
        ``current_fraction`` (which then bounds the amplitude only): a move that
        saturates ``i_d`` leaves the open-loop unstable gap axis no feedback.
    i_d_fraction : float or None
        Fraction of the ``i_d`` axis limit the planned feedforward may use, when
        it should differ from the ``i_q`` axis's (``axis_fraction``, else
        ``current_fraction``): ``i_d`` holds the open-loop unstable gap, whose
        feedback needs headroom when a fast gap move drives ``i_d`` to its limit,
        while the thrust's ``i_q`` is only bounded by the amplitude.
    d_timing : {"symmetric", "free"}
        ``symmetric``: the horizontal axis accelerates for half of the move and
        brakes for the other half; ``free``: it accelerates for a share
        (:data:`D_SPLITS`) of the move and brakes, harder or softer, for the
        rest, whichever gives the shortest feasible move. The minimum-time moves
        show why: a move that changes the gap accelerates at the smaller gap,
        where the thrust per ampere ``L1 = C1 f1`` is larger, harder and for a
        shorter time than it brakes at the larger gap (or the other way round).
    gap_timing : {"with_d", "free"}
        ``with_d``: both axes share the move's duration (a straight line in the
        ``(g, d)`` plane); ``free``: the gap changes in a part of the move (a
        share of :data:`GAP_SHARES` of its duration, placed at one of
        :data:`GAP_PLACES` of the rest), whichever gives the shortest feasible
        move. The minimum-time moves (:mod:`maglev_ocp.ocp.min_time`) show why:
        the thrust per ampere is larger at a smaller gap (``L1 = C1 f1``), and a
        gap that opens while the mover brakes needs less ``i_d``, which leaves
        more of the current amplitude to ``i_q``.
    """

    shaping: Literal["trajectory", "step", "min_time"] = "trajectory"
    current_fraction: float = Field(0.85, gt=0.05, le=1.0)
    ramp_fraction: float = Field(0.05, ge=0.0, le=0.25)
    axis_fraction: float | None = Field(None, gt=0.05, le=1.0)
    i_d_fraction: float | None = Field(None, gt=0.05, le=1.0)
    gap_timing: Literal["with_d", "free"] = "with_d"
    d_timing: Literal["symmetric", "free"] = "symmetric"

    @property
    def axis_limit_fraction(self) -> float:
        """Fraction of the per-axis limit: ``axis_fraction``, else ``current_fraction``."""
        return self.current_fraction if self.axis_fraction is None else self.axis_fraction

    @property
    def i_d_limit_fraction(self) -> float:
        """Fraction of the ``i_d`` axis limit: ``i_d_fraction``, else :attr:`axis_limit_fraction`."""
        return self.axis_limit_fraction if self.i_d_fraction is None else self.i_d_fraction


#: Shares of the move the horizontal axis may spend accelerating with ``d_timing: free`` (0.5: symmetric).
D_SPLITS: tuple[float, ...] = (0.5, 0.45, 0.55, 0.4, 0.6, 0.35, 0.65)
#: Shares of the gap's part of the move the gap may spend accelerating with ``gap_timing: free``.
GAP_SPLITS: tuple[float, ...] = (0.5, 0.35, 0.65, 0.2, 0.8)
#: Shares of the move's duration the gap may take with ``gap_timing: free`` (the fastest move is kept).
GAP_SHARES: tuple[float, ...] = (1.0, 0.75, 0.55, 0.4)
#: Where the gap's part of the move starts, as a fraction of the time left beside it (0: at the start, 1: at the end).
GAP_PLACES: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)


def _backend(x):
    """``(where, fmin, fmax, logic_or)`` of the array type of ``x``: CasADi's for SX/MX/DM, NumPy's otherwise."""
    if isinstance(x, ca.SX | ca.MX | ca.DM):
        return ca.if_else, ca.fmin, ca.fmax, ca.logic_or
    return np.where, np.minimum, np.maximum, np.logical_or


def unit_profile(tau, ramp):
    """Normalized jerk-limited rest-to-rest profile ``(s, s', s'')`` at ``tau`` in [0, 1].

    The one jerk-limited (trapezoidal-acceleration) bang-bang profile of the
    suite: the runner's :class:`Move` samples it with NumPy arrays, the NMPC's
    internal planner (:mod:`maglev_ocp.controllers.nmpc.planner`) builds it from CasADi SX
    (branch-free ``if_else``, so it is part of the generated C). The
    acceleration ramps from 0 to its peak ``A = 4 / (1 - 2 ramp)`` over
    ``ramp``, holds, ramps back to 0 at ``tau = 1/2``; the second half mirrors
    the first (``s(tau) = 1 - s(1 - tau)``, ``s''(tau) = -s''(1 - tau)``).
    Before the move it is at rest at 0, after it at rest at 1.

    Parameters
    ----------
    tau : ndarray or casadi.SX
        Normalized time ``t / T``.
    ramp : float or casadi.SX
        Ramp fraction (see :class:`ReferenceSettings`), ``0 <= ramp <= 1/4``
        (0: pure bang-bang, the time-optimal profile of a double integrator).

    Returns
    -------
    s, s', s'' : same type as ``tau``
        Position, velocity and acceleration of the unit move in unit time.
    """
    where, fmin, fmax, lor = _backend(tau)
    if where is np.where:
        tau = np.asarray(tau, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        first = tau < 0.5
        u = fmax(fmin(where(first, tau, 1.0 - tau), 0.5), 0.0)  # time into the accelerating half
        r = ramp
        rs = fmax(r, 1e-300)  # ramp 0: the ramp branches are never taken, but must not divide by zero
        A = 4.0 / (1.0 - 2.0 * r)  # peak: the half move covers A (1/2)(1/2 - r) / 2 = 1/2
        # ramp up (u < r)
        a1, v1, p1 = u / rs, u**2 / (2 * rs), u**3 / (6 * rs)
        # constant acceleration (r <= u < 1/2 - r)
        vr, pr = r / 2, r**2 / 6
        e = u - r
        a2, v2, p2 = 1.0 + 0 * u, vr + e, pr + vr * e + e**2 / 2
        # ramp down (u >= 1/2 - r)
        sc = 0.5 - 2 * r  # length of the constant phase
        vc, pc = vr + sc, pr + vr * sc + sc**2 / 2
        e = u - (0.5 - r)
        a3 = 1.0 - e / rs
        v3 = vc + e - e**2 / (2 * rs)
        p3 = pc + vc * e + e**2 / 2 - e**3 / (6 * rs)
        in1, in2 = u < r, u < 0.5 - r
        phases = ((p1, p2, p3), (v1, v2, v3), (a1, a2, a3))
        pos, vel, acc = (A * where(in1, x1, where(in2, x2, x3)) for x1, x2, x3 in phases)
        before, done = tau < 0.0, tau >= 1.0
        rest = lor(before, done)
        s = where(done, 1.0, where(before, 0.0, where(first, pos, 1.0 - pos)))
        vel = where(rest, 0.0, vel)
        acc = where(rest, 0.0, where(first, acc, -acc))
    return s, vel, acc


def peak_acceleration_factor(ramp: float) -> float:
    """Peak of ``s''`` of the unit move, ``4 / (1 - 2 ramp)`` (4 for pure bang-bang)."""
    return 4.0 / (1.0 - 2.0 * float(ramp))


def split_profile(tau, ramp, split: float = 0.5):
    """:func:`unit_profile` with the acceleration phase taking ``split`` of the unit time, braking the rest.

    Both phases are the halves of the jerk-limited unit profile, each stretched
    to its own duration: the peak velocity (2, as for the symmetric profile)
    is reached at ``tau = split``, the acceleration is ``1 / (2 split)`` times
    the unit profile's before and ``1 / (2 (1 - split))`` times it after, so
    the move is rest to rest over the same distance (each phase covers its
    share of it). ``split = 0.5`` is :func:`unit_profile` itself.

    Parameters
    ----------
    tau : ndarray
        Normalized time ``t / T``.
    ramp : float
        Ramp fraction of each phase's stretched unit time.
    split : float
        Share of the move spent accelerating, in (0, 1).

    Returns
    -------
    s, s', s'' : ndarray
        Position, velocity and acceleration of the unit move in unit time.
    """
    if split == 0.5:
        return unit_profile(tau, ramp)
    tau = np.asarray(tau, dtype=float)
    a, b = 2.0 * split, 2.0 * (1.0 - split)
    s1, v1, a1 = unit_profile(tau / a, ramp)
    s2, v2, a2 = unit_profile(1.0 - (1.0 - tau) / b, ramp)
    first = tau < split
    s = np.where(first, a * s1, 1.0 - b * (1.0 - s2))
    return s, np.where(first, v1, v2), np.where(first, a1 / a, a2 / b)


@dataclass(frozen=True)
class Move:
    """One planned rest-to-rest move from ``p0`` to ``p1`` starting at ``t0``.

    Attributes
    ----------
    t0 : float
        Start time [s].
    T : float
        Duration [s] (0 for no motion).
    p0, p1 : tuple of float
        Start and end positions ``(g, d)`` [m].
    ramp : float
        Ramp fraction of the profile.
    gap_T : float or None
        Duration of the gap's part of the move [s] (``None``: the whole ``T``).
    gap_start : float
        When the gap's part starts, from ``t0`` [s].
    split : float
        Share of the move the horizontal axis spends accelerating (see :func:`split_profile`).
    gap_split : float
        Share of the gap's part of the move the gap spends accelerating.
    """

    t0: float
    T: float
    p0: tuple[float, float]
    p1: tuple[float, float]
    ramp: float = 0.1
    gap_T: float | None = None
    gap_start: float = 0.0
    split: float = 0.5
    gap_split: float = 0.5

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Reference at times ``t``: array (len(t), 6) ordered g, g_dot, g_ddot, d, d_dot, d_ddot."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((len(t), 6))
        p0, p1 = np.asarray(self.p0), np.asarray(self.p1)
        if self.T <= 0:
            out[:, 0], out[:, 3] = p1[0], p1[1]
            return out
        delta = p1 - p0
        for j, col in enumerate((0, 3)):
            t0, T = self.t0, self.T
            if j == 0 and self.gap_T is not None:
                t0, T = self.t0 + self.gap_start, self.gap_T
            s, v, a = split_profile((t - t0) / T, self.ramp, self.split if j == 1 else self.gap_split)
            out[:, col] = p0[j] + delta[j] * s
            out[:, col + 1] = delta[j] * v / T
            out[:, col + 2] = delta[j] * a / T**2
        return out

    def with_gap_share(self, share: float, place: float = 0.0) -> Move:
        """The same move with the gap changing in ``share`` of its duration (see ``gap_timing: free``).

        The gap's part starts at ``place`` (0..1) of the time left beside it.
        """
        if share >= 1.0:
            return Move(self.t0, self.T, self.p0, self.p1, self.ramp, split=self.split, gap_split=self.gap_split)
        gT = share * self.T
        return Move(self.t0, self.T, self.p0, self.p1, self.ramp, gT, place * (self.T - gT), self.split, self.gap_split)


@dataclass(frozen=True)
class TabulatedMove:
    """A rest-to-rest move given as a table on a fine time grid (a minimum-time move, ``shaping: min_time``).

    Attributes
    ----------
    t0, T : float
        Start time and duration [s].
    p0, p1 : tuple of float
        Start and end ``(g, d)`` [m].
    tau : ndarray
        Table times from the start, ``0..T`` [s].
    rows : ndarray, shape (len(tau), 6)
        Reference rows (g, g_dot, g_ddot, d, d_dot, d_ddot) at ``tau``.
    """

    t0: float
    T: float
    p0: tuple[float, float]
    p1: tuple[float, float]
    tau: np.ndarray = field(repr=False)
    rows: np.ndarray = field(repr=False)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Reference at times ``t`` (linear interpolation of the table; at rest before and after)."""
        s = np.atleast_1d(np.asarray(t, dtype=float)) - self.t0
        out = np.empty((len(s), 6))
        for j in range(6):
            out[:, j] = np.interp(s, self.tau, self.rows[:, j])
        before, after = s < 0, s > self.T
        out[before] = [self.p0[0], 0, 0, self.p0[1], 0, 0]
        out[after] = [self.p1[0], 0, 0, self.p1[1], 0, 0]
        return out


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
    tau = np.linspace(0.0, res.T, max(math.ceil(res.T / MIN_TIME_TABLE_STEP), 2) + 1)
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


def plan_min_time_move(
    p0: Sequence[float],
    p1: Sequence[float],
    params: Params,
    settings: ReferenceSettings,
    t0: float = 0.0,
    effects: PlanEffects | None = None,
) -> Move | TabulatedMove:
    """The minimum-time move from ``p0`` to ``p1`` within ``current_fraction`` of the limits (``shaping: min_time``).

    Solved on the controller's model constants (:func:`maglev_ocp.ocp.min_time.solve_min_time`,
    cached per move); a move of less than 1 mm or one the solver does not
    converge on is planned as ``trajectory`` (:func:`plan_move`). The
    minimum-time problem is solved on the shared model; with ``effects`` (the
    static effects of the controller's model file) the solved move's currents
    are checked on the model with them (:func:`planning_inverse_function`,
    the same fractions of the limits) and a move that does not fit is planned
    as ``trajectory`` on that model instead.
    """
    a, b = (float(p0[0]), float(p0[1])), (float(p1[0]), float(p1[1]))
    if max(abs(b[0] - a[0]), abs(b[1] - a[1])) >= 1e-3:
        tab = _min_time_table(
            a,
            b,
            tuple(params.vector().tolist()),
            settings.current_fraction,
            settings.axis_limit_fraction,
            settings.i_d_fraction,
        )
        if tab is None:
            _log.warning("minimum-time move %s -> %s m not solved: planned as a trajectory", a, b)
        else:
            mv = TabulatedMove(t0, tab[0], a, b, tab[1], tab[2])
            lim_axes = np.array([settings.axis_limit_fraction, settings.i_d_limit_fraction]) * k.i_axis_max
            if effects is None or _limits_ok(
                tab[2], params, lim_axes, settings.current_fraction * k.i_amp_max, effects
            ):
                return mv
            _log.info("minimum-time move %s -> %s m exceeds the limits with the model's effects: trajectory", a, b)
    return plan_move(a, b, params, settings, t0=t0, effects=effects)


@dataclass(frozen=True)
class PlanEffects:
    """Static effects of the controller's model file, for the planner's feasibility check.

    Attributes
    ----------
    names : tuple of str
        Effect names (:class:`maglev_ocp.effects.EffectSet`).
    theta : tuple of float
        Their parameters in the effect set's order.
    """

    names: tuple[str, ...]
    theta: tuple[float, ...]


#: Newton steps of the effect-aware inverse (from the shared model's inverse; quadratic convergence).
INVERSE_NEWTON_STEPS = 4
#: Residual of the effect-aware inverse beyond which a point counts as out of reach [m/s^2, + relative].
INVERSE_TOLERANCE = 1e-3


@functools.lru_cache(maxsize=16)
def planning_inverse_function(effects: tuple[str, ...] = ()) -> ca.Function:
    """``planning_inverse(x, a, p, theta) -> (u, unreachable)``: currents for accelerations ``a`` with the effects.

    Without effects it is the shared model's exact inverse
    (:func:`maglev_ocp.model.model_inverse_function`, ``theta`` unused). With
    effects, the shared inverse is the first guess and Newton's method on the
    model-plus-effects accelerations (the shared model's ``f`` plus
    :func:`maglev_ocp.effects.effect_delta_function`) refines it
    (:data:`INVERSE_NEWTON_STEPS`); a point counts as unreachable when the
    shared inverse says so or the residual stays beyond
    :data:`INVERSE_TOLERANCE` ``(1 + |a|)``, so a move the model cannot follow is
    never declared feasible.
    """
    m = get_model()
    x, a, p = ca.SX.sym("x", 4), ca.SX.sym("a", 2), ca.SX.sym("p", m.np_)
    es = EffectSet(effects)
    theta = ca.SX.sym("theta", max(es.n_theta, 1))
    u, unr = model_inverse_function()(x, a, p)
    if effects:
        us = ca.SX.sym("u", 2)
        f = m.f(x, us, p)
        acc = ca.vertcat(f[1], f[3]) + effect_delta_function(effects)(x, us, p, theta[: es.n_theta])
        step = us - ca.mtimes(ca.inv(ca.jacobian(acc, us)), acc - a)
        newton = ca.Function("newton", [x, a, us, p, theta], [step])
        residual = ca.Function("residual", [x, a, us, p, theta], [acc - a])
        for _ in range(INVERSE_NEWTON_STEPS):
            u = newton(x, a, u, p, theta)
        r = residual(x, a, u, p, theta)
        off = ca.fmax(
            ca.fabs(r[0]) - INVERSE_TOLERANCE * (1 + ca.fabs(a[0])),
            ca.fabs(r[1]) - INVERSE_TOLERANCE * (1 + ca.fabs(a[1])),
        )
        unr = ca.logic_or(unr, off > 0)
    return ca.Function("planning_inverse", [x, a, p, theta], [u, unr], ["x", "a", "p", "theta"], ["u", "unreachable"])


def _limits_ok(
    samples: np.ndarray, params: Params, lim_axes: np.ndarray, lim_amp: float, effects: PlanEffects | None = None
) -> bool:
    """Do the model-inverse currents along ``samples`` (rows of :meth:`Move.sample`) fit the limits?

    ``lim_axes``: bounds of ``|i_q|`` and ``|i_d|`` [A]; ``lim_amp``: bound of the amplitude [A];
    ``effects``: the model file's static effects (:func:`planning_inverse_function`).
    """
    n = samples.shape[0]
    names = effects.names if effects is not None else ()
    theta = np.asarray(effects.theta if effects is not None and effects.theta else (0.0,), dtype=float)
    inv = _mapped_inverse(n, names)
    x = np.vstack([samples[:, 0], samples[:, 1], samples[:, 3], samples[:, 4]])
    a = np.vstack([samples[:, 2], samples[:, 5]])
    P = np.tile(params.vector()[:, None], (1, n))
    u, unr = inv(x, a, P, np.tile(theta[:, None], (1, n)))  # buffer API: no DM conversions
    u = u.reshape(n, 2).T
    if np.any(np.asarray(unr) > 0) or not np.all(np.isfinite(u)):
        return False
    amp = np.hypot(u[0], u[1])
    return bool(np.all(np.abs(u) <= np.asarray(lim_axes)[:, None]) and np.all(amp <= lim_amp))


def _limits_ok_st(
    samples: np.ndarray,
    params: Params,
    st: ReferenceSettings,
    i_axis: float,
    i_amp: float,
    effects: PlanEffects | None = None,
) -> bool:
    """:func:`_limits_ok` with the settings' fractions of the axis limit ``i_axis`` and the amplitude ``i_amp``."""
    lim_axes = np.array([st.axis_limit_fraction, st.i_d_limit_fraction]) * i_axis
    return _limits_ok(samples, params, lim_axes, st.current_fraction * i_amp, effects)


@functools.lru_cache(maxsize=16)
def _mapped_inverse(n: int, effects: tuple[str, ...] = ()) -> BufferedFunction:
    return BufferedFunction(planning_inverse_function(effects).map(n))


def plan_move(
    p0: Sequence[float],
    p1: Sequence[float],
    params: Params = NOMINAL,
    settings: ReferenceSettings | None = None,
    t0: float = 0.0,
    n_check: int = 161,
    i_axis: float = k.i_axis_max,
    i_amp: float = k.i_amp_max,
    effects: PlanEffects | None = None,
) -> Move:
    """Plan the shortest current-feasible move from ``p0`` to ``p1`` (see the module docstring).

    Parameters
    ----------
    p0, p1 : sequence of float
        Start and end ``(g, d)`` [m], both at rest.
    params : Params
        The model the plan is computed on (the controller's belief).
    settings : ReferenceSettings
        Current fraction and ramp fraction.
    t0 : float
        Start time of the move [s].
    n_check : int
        Number of points along the move at which the currents are checked.
    i_axis, i_amp : float
        Current limits [A].
    effects : PlanEffects, optional
        The static effects of the controller's model file: the currents are
        checked on the model with them (:func:`planning_inverse_function`).

    Returns
    -------
    Move

    Raises
    ------
    ConfigError
        If even holding still at ``p0`` or ``p1`` needs more than the allowed current.
    """
    st = settings or ReferenceSettings()
    p0 = (float(p0[0]), float(p0[1]))
    p1 = (float(p1[0]), float(p1[1]))
    frac, ramp = st.current_fraction, st.ramp_fraction
    for pt in (p0, p1):
        hold = Move(0.0, 0.0, pt, pt, ramp).sample(np.zeros(1))
        if not _limits_ok_st(hold, params, st, i_axis, i_amp, effects):
            raise ConfigError(
                f"holding g = {pt[0] * 1e3:.2f} mm, d = {pt[1] * 1e3:.2f} mm needs more than "
                f"{frac:.2f} x the current limits"
            )
    dist = max(abs(p1[0] - p0[0]), abs(p1[1] - p0[1]))
    if dist < 1e-12:
        return Move(t0, 0.0, p0, p1, ramp)
    tau = np.linspace(0.0, 1.0, n_check)

    def shortest(split: float, share: float, place: float, gap_split: float) -> Move | None:
        def move(T: float, t_0: float = 0.0) -> Move:
            return Move(t_0, T, p0, p1, ramp, split=split, gap_split=gap_split).with_gap_share(share, place)

        def feasible(T: float) -> bool:
            return _limits_ok_st(move(T).sample(tau * T), params, st, i_axis, i_amp, effects)

        T = _shortest_duration(feasible, dist, ramp)
        return None if T is None else move(T, t0)

    splits = D_SPLITS if st.d_timing == "free" and abs(p1[1] - p0[1]) > 1e-12 else (0.5,)
    timings, gap_splits = [(1.0, 0.0)], (0.5,)
    if st.gap_timing == "free" and abs(p1[0] - p0[0]) > 1e-12:
        timings += [(sh, pl) for sh in GAP_SHARES if sh < 1.0 for pl in GAP_PLACES]
        gap_splits = GAP_SPLITS
    best = _coordinate_search(shortest, splits, timings, gap_splits)
    if best is None:
        raise ConfigError(f"no feasible move from {p0} to {p1} m within the current limits")
    return best


def _coordinate_search(
    shortest, splits: Sequence[float], timings: Sequence[tuple[float, float]], gap_splits: Sequence[float]
) -> Move | None:
    """The shortest of the moves ``shortest(split, share, place, gap_split)`` over the candidates.

    Coordinate search, one parameter group at a time from the best move so far:
    the horizontal splits (gap over the whole move), the gap's timings, the
    gap's splits, then the horizontal splits and the gap's timings once more
    (every candidate is a feasible move; the search only decides which are tried).
    """
    best: Move | None = None
    tried: set[tuple[float, float, float, float]] = set()

    def at() -> tuple[float, float, float, float]:
        if best is None:
            return (0.5, 1.0, 0.0, 0.5)
        if best.gap_T is None:
            return (best.split, 1.0, 0.0, best.gap_split)
        free = best.T - best.gap_T
        return (best.split, best.gap_T / best.T, best.gap_start / free if free > 0 else 0.0, best.gap_split)

    def consider(cands: list[tuple[float, float, float, float]]) -> None:
        nonlocal best
        for c in cands:
            if c in tried:
                continue
            tried.add(c)
            mv = shortest(*c)
            if mv is not None and (best is None or mv.T < best.T - 1e-6):
                best = mv

    for group in ("split", "timing", "gap_split", "split", "timing"):
        sp, sh, pl, gs = at()
        if group == "split":
            consider([(s2, sh, pl, gs) for s2 in splits])
        elif group == "timing":
            consider([(sp, s2, p2, gs) for s2, p2 in timings])
        else:
            consider([(sp, sh, pl, g2) for g2 in gap_splits])
    return best


def _shortest_duration(feasible, dist: float, ramp: float) -> float | None:
    """Smallest duration ``T`` with ``feasible(T)`` (bracketing, then bisection to 10 us); ``None`` if none."""
    # Lower bound: the whole amplitude as acceleration at the strongest thrust in the envelope.
    c_a = peak_acceleration_factor(ramp)
    T_hi = max(math.sqrt(c_a * dist / 200.0), 1e-3)
    while not feasible(T_hi):
        T_hi *= 1.5
        if T_hi > 1e3:
            return None
    T_lo = T_hi / 1.5 if T_hi > 1e-3 else 0.0
    while T_lo > 1e-4 and feasible(T_lo):
        T_hi, T_lo = T_lo, T_lo / 1.5
    for _ in range(40):
        if T_hi - T_lo < 1e-5:
            break
        mid = 0.5 * (T_lo + T_hi)
        if feasible(mid):
            T_hi = mid
        else:
            T_lo = mid
    return T_hi


@dataclass(frozen=True)
class Target:
    """A positioning target held for ``hold`` seconds."""

    g: float
    d: float
    hold: float


@dataclass
class ReferencePlan:
    """Reference over a whole scenario: one move per target, each starting at the target's switch time.

    Attributes
    ----------
    targets : list of Target
        Targets in order.
    switch_times : ndarray
        Time at which each target becomes active [s].
    moves : list of Move
        The planned move to each target (duration 0 with ``shaping: step``).
    shaping : str
        ``trajectory`` or ``step``.
    """

    targets: list[Target]
    switch_times: np.ndarray
    moves: list[Move]
    shaping: str = "trajectory"
    start: tuple[float, float] = (0.020, 0.0)
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def duration(self) -> float:
        """End of the last hold [s]."""
        return float(self.switch_times[-1] + self.targets[-1].hold)

    def target_index(self, t: float) -> int:
        """Index of the target active at time ``t``."""
        return int(np.clip(np.searchsorted(self.switch_times, t, side="right") - 1, 0, len(self.targets) - 1))

    def sample(self, t: np.ndarray, zoh: float | None = None) -> np.ndarray:
        """Reference rows (g, g_dot, g_ddot, d, d_dot, d_ddot) at times ``t`` (array (n, 6)).

        Parameters
        ----------
        t : ndarray
            Times [s].
        zoh : float, optional
            If given (the control period), the accelerations are the reference's
            MEAN acceleration over ``[t, t + zoh]``, ``(v(t + zoh) - v(t)) / zoh``:
            the constant acceleration a zero-order-held current must produce for
            the reference velocity to be met at the next sample. The instantaneous
            acceleration at ``t`` lags that by half a period, which during the
            acceleration ramps of a fast move costs tens of micrometres of tracking.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = self._sample(t)
        if zoh:
            ahead = self._sample(t + zoh)
            out[:, 2] = (ahead[:, 1] - out[:, 1]) / zoh
            out[:, 5] = (ahead[:, 4] - out[:, 4]) / zoh
        return out

    def _sample(self, t: np.ndarray) -> np.ndarray:
        out = np.empty((len(t), 6))
        idx = np.clip(np.searchsorted(self.switch_times, t, side="right") - 1, 0, len(self.targets) - 1)
        before = t < self.switch_times[0]
        for i in np.unique(idx):
            sel = idx == i
            out[sel] = self.moves[i].sample(t[sel])
        if before.any():
            out[before] = [self.start[0], 0, 0, self.start[1], 0, 0]
        return out

    def at(self, t: float, zoh: float | None = k.Ts) -> Reference:
        """The :class:`~maglev_ocp.blocks.Reference` at time ``t``.

        Its accelerations are the mean over the coming control period ``zoh``
        (see :meth:`sample`; ``zoh=None`` for the instantaneous ones): what the
        runner hands every controller.
        """
        r = self.sample(np.array([t]), zoh)[0]
        return Reference(g=r[0], d=r[3], g_dot=r[1], d_dot=r[4], g_ddot=r[2], d_ddot=r[5])

    def table(self) -> str:
        """One line per target: switch time, target and planned move duration."""
        lines = [f"{'#':>3} {'t_switch [s]':>12} {'g [mm]':>8} {'d [mm]':>8} {'hold [s]':>8} {'move [s]':>9}"]
        for i, (tg, ts, mv) in enumerate(zip(self.targets, self.switch_times, self.moves, strict=True)):
            lines.append(f"{i:3d} {ts:12.3f} {tg.g * 1e3:8.3f} {tg.d * 1e3:8.3f} {tg.hold:8.3f} {mv.T:9.4f}")
        return "\n".join(lines)


def plan_targets(
    start: Sequence[float],
    targets: Sequence[Target],
    params: Params = NOMINAL,
    settings: ReferenceSettings | None = None,
    t_start: float = 0.0,
    source: str = "targets",
    effects: PlanEffects | None = None,
) -> ReferencePlan:
    """Plan the reference of a scenario: from ``start`` through every target in order.

    Parameters
    ----------
    start : sequence of float
        Initial ``(g, d)`` [m] (the mover at rest there).
    targets : sequence of Target
        Targets, each active for its ``hold``.
    params : Params
        The controller's model (moves are planned on what the controller believes).
    settings : ReferenceSettings
        Shaping options.
    t_start : float
        Switch time of the first target [s].
    source : str
        Name used in error messages (e.g. ``scenario.yaml: targets``).
    effects : PlanEffects, optional
        The static effects of the controller's model file (the moves' currents
        are checked on the model with them).

    Raises
    ------
    ConfigError
        If a planned move does not fit in its target's hold.
    """
    st = settings or ReferenceSettings()
    if not targets:
        raise ConfigError(f"{source}: at least one target is needed")
    t = t_start
    prev = (float(start[0]), float(start[1]))
    moves, switch = [], []
    for i, tg in enumerate(targets):
        if st.shaping == "step":
            mv = Move(t, 0.0, (tg.g, tg.d), (tg.g, tg.d), st.ramp_fraction)
        else:
            plan = plan_min_time_move if st.shaping == "min_time" else plan_move
            try:
                mv = plan(prev, (tg.g, tg.d), params, st, t0=t, effects=effects)
            except ConfigError as err:
                raise ConfigError(f"{source}[{i}]: {err}") from None
            if mv.T >= tg.hold:
                raise ConfigError(
                    f"{source}[{i}].hold: the planned move takes {mv.T:.3f} s, not less than the hold "
                    f"{tg.hold:.3f} s (lengthen the hold or raise reference.current_fraction)"
                )
        moves.append(mv)
        switch.append(t)
        t += tg.hold
        prev = (tg.g, tg.d)
    return ReferencePlan(list(targets), np.array(switch), moves, st.shaping, (float(start[0]), float(start[1])))


__all__ = [
    "D_SPLITS",
    "GAP_PLACES",
    "GAP_SHARES",
    "GAP_SPLITS",
    "MIN_TIME_TABLE_STEP",
    "Move",
    "PlanEffects",
    "ReferencePlan",
    "ReferenceSettings",
    "TabulatedMove",
    "Target",
    "peak_acceleration_factor",
    "plan_min_time_move",
    "plan_move",
    "plan_targets",
    "planning_inverse_function",
    "split_profile",
    "unit_profile",
]
