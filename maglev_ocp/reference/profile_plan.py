"""Minimum-time moves in milliseconds: time-optimal parameterizations of a few paths (``min_time_solver: profile``).

The minimum-time NLP (:func:`maglev_ocp.ocp.min_time.solve_min_time`) costs
0.1-0.4 s per move, two moves per campaign run. Its answer has a structure a
planner can build directly. The shared model's accelerations do not depend on
the velocities (seed eq. (2) with cogging), so along a fixed path
``p(sigma)``, ``sigma`` in [0, 1], the currents a move needs at a point depend
only on the point, ``sigma''`` and ``sigma'^2`` (``p'' sigma'^2`` is the
path's bend). The limits then give, at each point, the largest ``sigma''``
speeding up and braking, and the shortest rest-to-rest move along the path is
the time-optimal path parameterization of a double integrator with
position-dependent bounds:

    sigma'^2 = min(2 int_0^sigma a, 2 int_sigma^1 b),

full acceleration until the braking curve is met, full braking after it
(bang-bang, like the NLP's solution, with the acceleration the limits allow
*at each gap and position* the move passes, not the worst of them).

The paths are the straight line and, for a move that changes the gap and
``d``, a few gap timings (:func:`candidate_shapes`): the NLP's moves accelerate at
the smaller gap, where the thrust per ampere is larger, and open the gap while
braking, where that needs less ``i_d``. A move mostly in ``d`` also tries
the gap closing mid-move and reopening (a *dip*): the NLP's short moves in
``d`` do so even when the gap does not change overall. The candidates are a
coarse grid of these continuous families, so a second pass tries the
neighbours of the fastest (:func:`refined_shapes`). The fastest path whose
move passes the check on the model wins
(:func:`maglev_ocp.reference.min_time._profile_table`).

The bounds come from the shared model's accelerations written as polynomials
in the currents (:func:`inverse_coefficients_function`: coefficients by
differentiation of :meth:`~maglev_ocp.model.MaglevModel.f`, nothing retyped),
``a_d = h0 - L1 i_q`` and ``a_g = c00 - Lq i_q^2 + L3 i_d - L4 i_d^2``, and a
vectorized bisection over all points and paths at once (with a model file's
static effects: its inverse,
:func:`maglev_ocp.reference.feasibility.planning_inverse_function`). Against
the NLP on 200+ random moves of the envelope: ``python -m benchmarks.min_time_planner``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import constants as k
from ..fastcall import BufferedFunction
from ..model import get_model
from ..params import Params
from .feasibility import PlanEffects, _mapped_inverse

#: Points along the path at which the acceleration bounds are computed.
PROFILE_GRID = 121
#: Bisection steps of the bounds (relative resolution ``2**-PROFILE_BISECTIONS`` of the bracket). 13 steps
#: moved the planned moves enough to change a closed-loop comparison (the cogging-aware NMPC's tracking gain
#: through the slots at 15 mm, ``tests/test_closed_loop_nmpc.py``: 25 % -> 19 %): kept at 15.
PROFILE_BISECTIONS = 15
#: Upper end of the first bracket of the bounds [m/s^2 along the path's longer axis]: the envelope's bounds are
#: 20-65 m/s^2 (NMPC planning defaults), so at most two doublings or a bisection from 0 (resolution
#: ``32 * 2**-15`` m/s^2, 0.005 % of the smallest bound).
PROFILE_FIRST_BRACKET = 32.0
#: Fixed-point iterations of a bent path's bounds with its speed (the iteration stops earlier when
#: every duration changed by less than :data:`PROFILE_TOLERANCE` of itself).
PROFILE_ITERATIONS = 5
#: A bent path this much slower than the best one after two iterations is dropped (:func:`path_profiles`;
#: 0.02 gave the same durations on 400 random moves at 20 % more planning time).
PROFILE_PRUNE = 0.01
#: Relative change of the durations at which the fixed-point iteration stops.
PROFILE_TOLERANCE = 1e-4
#: ``(alpha, weight)`` of the gap following ``d`` (:class:`PathShape`, :func:`candidate_shapes`): a coarse grid,
#: refined around its fastest member (:data:`BEND_STEPS`); a denser first grid (11 + 5 bends) gave the same
#: worst moves at 1.5x the planning cost.
GAP_BENDS: tuple[tuple[float, float], ...] = ((2.0, 0.25), (2.0, 0.5), (2.0, 1.0), (2.5, 1.0), (3.0, 1.0), (4.0, 1.0))
#: ``(alpha, weight)`` of ``d`` following the gap (:class:`PathShape`, :func:`candidate_shapes`).
D_BENDS: tuple[tuple[float, float], ...] = ((2.0, 0.25), (2.0, 0.5), (2.0, 1.0))
#: Smallest change of both the gap and ``d`` [m] for which bent paths are tried.
MIN_BENT_MOVE_M = 2e-4
#: Gap dips tried on the straight path, as fractions of ``|dd|`` (:class:`PathShape` ``dip``, :func:`candidate_shapes`).
GAP_DIPS: tuple[float, ...] = (0.02, 0.05)
#: Largest gap dip [m].
MAX_DIP_M = 2e-3
#: Dips are tried (besides the bends) when the gap changes by less than this fraction of ``|dd|``: a bend's gap
#: excursion scales with the gap's change, so a move mostly in ``d`` needs the dip to close the gap at all.
DIP_BELOW = 0.25
#: ``(alpha factor, weight factor)`` of the neighbours of the fastest bend tried in a second pass
#: (:func:`refined_shapes`); the timing of the NLP's moves varies continuously with the move.
BEND_STEPS: tuple[tuple[float, float], ...] = ((1.5, 1.0), (1.0, 0.5), (1.25, 0.5))
#: Factors on the fastest dip tried in the second pass.
DIP_STEPS: tuple[float, ...] = (0.7, 1.4)
#: Margins (fractions of the limits) tried in turn until the smoothed move passes the model check.
PROFILE_MARGINS: tuple[float, ...] = (2e-4, 2e-3, 1e-2)


@functools.lru_cache(maxsize=1)
def inverse_coefficients_function() -> ca.Function:
    """``coefficients(x, p) -> (h0, L1, c00, L3, L4, Lq)`` of the shared model's accelerations in the currents.

    The shared model's ``f`` (seed eq. (2) with cogging) is, in the currents,
    ``a_d = h0 - L1 i_q`` and ``a_g = c00 - Lq i_q^2 + L3 i_d - L4 i_d^2``; the
    coefficients are its derivatives at zero current (the same ones
    :func:`maglev_ocp.model.inverse_expressions` takes), so a planner can solve
    for the currents of many accelerations at a point without calling CasADi
    per acceleration.
    """
    m = get_model()
    x, p, u = ca.SX.sym("x", 4), ca.SX.sym("p", m.np_), ca.SX.sym("u", 2)
    f = m.f(x, u, p)
    a_g, a_d = f[1], f[3]
    zero = ca.DM.zeros(2)

    def at0(e: ca.SX) -> ca.SX:
        return ca.substitute(e, u, zero)

    h0 = at0(a_d)
    L1 = -at0(ca.jacobian(a_d, u[0]))
    c00 = at0(a_g)
    L3 = at0(ca.jacobian(a_g, u[1]))
    L4 = -0.5 * at0(ca.hessian(a_g, u[1])[0])
    Lq = -0.5 * at0(ca.hessian(a_g, u[0])[0])
    out = ca.vertcat(h0, L1, c00, L3, L4, Lq)
    return ca.Function("inverse_coefficients", [x, p], [out], ["x", "p"], ["c"])


@functools.lru_cache(maxsize=4)
def _mapped_coefficients(n: int) -> BufferedFunction:
    return BufferedFunction(inverse_coefficients_function().map(n))


def currents(coef: np.ndarray, a_g: np.ndarray, a_d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Currents ``(i_q, i_d)`` giving the accelerations ``(a_g, a_d)`` at points with coefficients ``coef``.

    ``coef``: rows ``(h0, L1, c00, L3, L4, Lq)`` of :func:`inverse_coefficients_function`
    (shape (6, n)). ``i_d`` is the root of smaller magnitude of the quadratic
    (as in :func:`maglev_ocp.model.inverse_expressions`); the third output
    marks accelerations the field cannot give (negative discriminant).
    """
    h0, L1, c00, L3, L4, Lq = coef
    i_q = (h0 - a_d) / L1
    c = a_g - c00 + Lq * i_q**2
    disc = L3**2 - 4.0 * L4 * c
    i_d = 2.0 * c / (L3 + np.sqrt(np.maximum(disc, 0.0)))
    return i_q, i_d, disc < 0.0


def _admissible(coef, a_g, a_d, lim_q: float, lim_d: float, lim_amp: float) -> np.ndarray:
    i_q, i_d, unr = currents(coef, a_g, a_d)
    return (~unr) & (np.abs(i_q) <= lim_q) & (np.abs(i_d) <= lim_d) & (i_q**2 + i_d**2 <= lim_amp**2)


def _bounds(admissible, sign: np.ndarray, scale: float, start: np.ndarray | None) -> np.ndarray:
    """Largest ``|s''|`` with ``admissible(sign |s''|)`` at every point, by bracketing and bisection from 0.

    ``start``: the previous bounds (the bracket starts just above them), or ``None``.
    Points where even ``s'' = 0`` is not admissible get 0.
    """
    ok0 = admissible(0.0 * sign)
    lo = np.zeros(sign.size)
    hi = np.full(sign.size, PROFILE_FIRST_BRACKET / scale) if start is None else np.maximum(1.25 * start, 1e-3 / scale)
    steps = PROFILE_BISECTIONS
    if start is not None:  # the bounds move little from one iteration to the next: a narrow bracket first
        below = 0.8 * start
        lo = np.where(admissible(sign * below) & ok0, below, 0.0)
        steps = PROFILE_BISECTIONS - 4  # the bracket [0.8, 1.25] of the last bounds: 0.45 / 2^11, 0.02 % of them
    grow = ok0.copy()
    for _ in range(60):  # bracket: double until inadmissible
        ok = admissible(sign * hi) & grow
        if not ok.any():
            break
        lo = np.where(ok, hi, lo)
        hi = np.where(ok, 2.0 * hi, hi)
        grow = ok
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        ok = admissible(sign * mid) & ok0
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return lo


def follower_progress(sigma: np.ndarray, alpha: float, late: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Share ``S`` of the following axis's change done at path coordinate ``sigma``, with ``S'`` and ``S''``.

    The leading axis has done ``sigma`` of its change. ``alpha = 1``: the
    straight path. ``alpha >= 2`` (``S''`` bounded): the follower moves late,
    ``S = sigma^alpha``, or early, ``S = 1 - (1 - sigma)^alpha``. With ``d``
    leading, a gap that opens late does so while the mover brakes (opening the
    gap needs less ``i_d``, which leaves more of the amplitude to the thrust's
    ``i_q``) and a gap that closes early lets the mover accelerate at the
    smaller gap (the thrust per ampere ``L1 = C1 f1`` grows as the gap shrinks,
    seed eq. (2)); the minimum-time NLP's moves do both
    (:mod:`maglev_ocp.ocp.min_time`).
    """
    if alpha != 1.0 and alpha < 2.0:
        raise ValueError(f"timing alpha = {alpha}: 1 or at least 2 (S'' is unbounded at the start otherwise)")
    r = sigma if late else 1.0 - sigma
    S = r**alpha
    S1 = alpha * r ** (alpha - 1.0)
    S2 = alpha * (alpha - 1.0) * r ** (alpha - 2.0) if alpha != 1.0 else np.zeros_like(r)
    if late:
        return S, S1, S2
    return 1.0 - S, S1, -S2


@dataclass(frozen=True)
class PathShape:
    """A path from ``p0`` to ``p1``: the leading axis moves with the path coordinate, the other follows.

    Attributes
    ----------
    alpha : float
        Timing exponent of the follower (:func:`follower_progress`; 1: the straight path).
    lead : {"d", "g"}
        The axis whose share of its change is the path coordinate.
    late : bool
        The follower moves late (``sigma^alpha``) or early.
    weight : float
        Share of the bent timing in the follower's progress, the rest straight
        (``(1 - w) sigma + w S``, ``0 < w <= 1``: a milder bend).
    dip : float
        A gap excursion [m] added along the path, ``dip * 16 sigma^2 (1 - sigma)^2``
        (peak at mid-move, zero slope and curvature-bounded at both ends; negative:
        the gap closes). The minimum-time NLP's moves in ``d`` close the gap while
        they accelerate and brake, even when the gap does not change overall: the
        thrust per ampere ``L1 = C1 f1`` grows as the gap shrinks (seed eq. (2)).
    """

    alpha: float = 1.0
    lead: str = "d"
    late: bool = True
    weight: float = 1.0
    dip: float = 0.0

    def axes(self, sigma: np.ndarray, delta: tuple[float, float]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``[(s, s', s'') of g, (s, s', s'') of d]`` at ``sigma`` scaled by ``delta = (dg, dd)``."""
        lin = (sigma, np.ones_like(sigma), np.zeros_like(sigma))
        S, S1, S2 = follower_progress(sigma, self.alpha, self.late)
        w = self.weight
        fol = ((1.0 - w) * sigma + w * S, (1.0 - w) + w * S1, w * S2)
        order = (fol, lin) if self.lead == "d" else (lin, fol)
        out = [(dl * a, dl * b, dl * c) for dl, (a, b, c) in zip(delta, order, strict=True)]
        if self.dip:
            b0, b1, b2 = bump(sigma)
            g, g1, g2 = out[0]
            out[0] = (g + self.dip * b0, g1 + self.dip * b1, g2 + self.dip * b2)
        return out


def bump(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``16 sigma^2 (1 - sigma)^2`` (1 at ``sigma = 1/2``, 0 with zero slope at both ends) and its derivatives."""
    r = sigma * (1.0 - sigma)
    return 16.0 * r**2, 32.0 * r * (1.0 - 2.0 * sigma), 32.0 * ((1.0 - 2.0 * sigma) ** 2 - 2.0 * r)


STRAIGHT = PathShape()


def candidate_shapes(dg: float, dd: float, g0: float | None = None) -> tuple[PathShape, ...]:
    """The paths tried for a move of ``(dg, dd)`` [m]: the straight one first, bent ones if both axes move.

    The bends go the way the minimum-time moves do (:func:`follower_progress`):
    a gap that opens does so late in the move, one that closes early. With
    ``d`` leading, the gap follows with each of :data:`GAP_BENDS`; with the gap
    leading (the same direction seen from the other axis, better for moves of
    a few mm in both), ``d`` follows with each of :data:`D_BENDS`. A move in
    ``d`` also tries the straight path with the gap closing mid-move by each of
    :data:`GAP_DIPS` of ``|dd|`` (:class:`PathShape` ``dip``), as long as the
    path stays within the gap envelope (``g0``: the start gap; no dips without it).
    """
    out = [STRAIGHT]
    if abs(dd) >= MIN_BENT_MOVE_M and abs(dg) < DIP_BELOW * abs(dd) and g0 is not None:
        out += [sh for frac in GAP_DIPS if _inside(sh := PathShape(dip=-min(frac * abs(dd), MAX_DIP_M)), g0, dg)]
    if min(abs(dg), abs(dd)) < MIN_BENT_MOVE_M:
        return tuple(out)
    opening = dg >= 0.0
    out += [PathShape(a, "d", opening, w) for a, w in GAP_BENDS]
    out += [PathShape(a, "g", not opening, w) for a, w in D_BENDS]
    return tuple(out)


def _inside(shape: PathShape, g0: float, dg: float) -> bool:
    """The path's gap stays within the gap envelope (a dip must not take the mover below it)."""
    sig = np.linspace(0.0, 1.0, 41)
    return bool(np.min(g0 + dg * sig + shape.dip * bump(sig)[0]) >= k.g_envelope[0] - 1e-12)


def refined_shapes(best: PathShape, g0: float, dg: float) -> tuple[PathShape, ...]:
    """Neighbours of the fastest path of the first pass (a bend's timing and share, a dip's depth), for a
    second pass: the candidates are a coarse grid of a continuous family, so the optimum lies between them."""
    if best.dip:
        out = [PathShape(dip=max(best.dip * f, -MAX_DIP_M)) for f in DIP_STEPS]
        return tuple(sh for sh in out if _inside(sh, g0, dg) and sh != best)
    if best.alpha == 1.0:
        return ()
    out = []
    for fa, fw in BEND_STEPS:
        a, w = max(best.alpha * fa, 2.0), min(best.weight * fw, 1.0)
        sh = PathShape(a, best.lead, best.late, w)
        if sh != best and sh not in out:
            out.append(sh)
    return tuple(out)


@dataclass(frozen=True)
class PathProfile:
    """The time-optimal parameterization of one path from ``p0`` to ``p1``.

    Attributes
    ----------
    shape : PathShape
        The path.
    T : float
        Duration of the move [s] (``inf`` when the parameterization did not reach the end).
    t, sigma : ndarray
        Times [s] at the grid points ``sigma`` of the path coordinate.
    u : ndarray
        Constant ``sigma''`` on each segment [1/s^2].
    """

    shape: PathShape
    T: float
    t: np.ndarray
    sigma: np.ndarray
    u: np.ndarray

    def sample(self, p0: tuple[float, float], p1: tuple[float, float], tau) -> np.ndarray:
        """Rows ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` at times ``tau`` (at rest at ``p1`` from ``T`` on)."""
        tau = np.clip(np.asarray(tau, dtype=float), 0.0, self.T)
        t, u = self.t, self.u
        i = np.clip(np.searchsorted(t, tau, side="right") - 1, 0, len(u) - 1)
        h = tau - t[i]
        v_i = np.concatenate([[0.0], np.cumsum(u * np.diff(t))])[i]
        sg = np.clip(self.sigma[i] + v_i * h + 0.5 * u[i] * h**2, 0.0, 1.0)
        sd, sdd = v_i + u[i] * h, u[i]
        cols = []
        for p, (s, s1, s2) in zip(p0, self.shape.axes(sg, (p1[0] - p0[0], p1[1] - p0[1])), strict=True):
            cols += [p + s, s1 * sd, s1 * sdd + s2 * sd**2]  # chain rule along the path
        rows = np.column_stack(cols)
        rows[tau >= self.T] = [p1[0], 0.0, 0.0, p1[1], 0.0, 0.0]
        return rows


def path_profiles(
    p0: tuple[float, float],
    p1: tuple[float, float],
    params: Params,
    lim_q: float,
    lim_d: float,
    lim_amp: float,
    effects: PlanEffects | None = None,
    shapes: tuple[PathShape, ...] = (STRAIGHT,),
    n: int = PROFILE_GRID,
    prune_above: float | None = None,
) -> list[PathProfile] | None:
    """Time-optimal rest-to-rest parameterizations of the paths ``shapes`` from ``p0`` to ``p1``, all at once.

    Along a path ``p(sigma)`` (:class:`PathShape`) the accelerations are
    ``p' sigma'' + p'' sigma'^2``. At each grid point the limits give the
    largest ``sigma''`` speeding up and braking (bisection on the currents:
    :func:`currents` of the shared model's coefficients, or with ``effects``
    the model file's inverse
    :func:`~maglev_ocp.reference.feasibility.planning_inverse_function`); full
    acceleration from rest at 0 until the braking curve to rest at 1 is met
    gives ``sigma'^2`` along the path. A bent path's bounds depend on
    ``sigma'^2`` (its ``p''`` term), so they are iterated with it (fixed
    point, :data:`PROFILE_ITERATIONS`); the straight path is exact at once. A
    profile is only a candidate: the caller checks the sampled move on the model.
    From the second iteration on, a path more than :data:`PROFILE_PRUNE` slower
    than the best one so far (or than ``prune_above`` [s], e.g. the straight
    path's duration) is no longer iterated and comes back with ``T = inf``.

    Returns
    -------
    list of PathProfile or None
        One per shape; ``None`` if holding still somewhere on the first path needs more than the limits.
    """
    K = len(shapes)
    sig = np.linspace(0.0, 1.0, n)
    delta = (p1[0] - p0[0], p1[1] - p0[1])
    ax = [sh.axes(sig, delta) for sh in shapes]
    # position, p' and p'' of each axis over the K paths' n points
    (g, pg, cg), (d, pd, cd) = ([np.concatenate([a[j][m] for a in ax]) for m in range(3)] for j in range(2))
    x = np.vstack([p0[0] + g, np.zeros(K * n), p0[1] + d, np.zeros(K * n)])
    pv = params.vector()
    # every array below: the K paths' n points, then the same for braking (sign -1)
    pg, cg, pd, cd = (np.tile(v, 2) for v in (pg, cg, pd, cd))
    sign = np.concatenate([np.ones(K * n), -np.ones(K * n)])

    coefficients = effects is None or not effects.names
    if coefficients:
        (c,) = _mapped_coefficients(K * n)(x, np.tile(pv[:, None], (1, K * n)))
        cc = np.tile(c.reshape(K * n, 6).T, (1, 2))
    else:
        inv = _mapped_inverse(2 * K * n, effects.names)
        xx, P = np.tile(x, (1, 2)), np.tile(pv[:, None], (1, 2 * K * n))
        th = np.tile(np.asarray(effects.theta, dtype=float)[:, None], (1, 2 * K * n))

    def admissible_on(sel: np.ndarray, v2: np.ndarray):
        """``admissible(s2)`` on the points ``sel`` (of the ``2 K n``) at ``sigma'^2 = v2`` there."""
        if coefficients:
            c_s, pg_s, pd_s, ag0, ad0 = cc[:, sel], pg[sel], pd[sel], cg[sel] * v2, cd[sel] * v2

            def admissible(s2: np.ndarray) -> np.ndarray:
                return _admissible(c_s, s2 * pg_s + ag0, s2 * pd_s + ad0, lim_q, lim_d, lim_amp)

            return admissible
        assert sel.size == 2 * K * n  # the mapped inverse has one size: every point, no pruning

        def admissible_eff(s2: np.ndarray) -> np.ndarray:
            u, unr = inv(xx, np.vstack([s2 * pg + cg * v2, s2 * pd + cd * v2]), P, th)
            i_q, i_d = u.reshape(-1, 2).T
            with np.errstate(invalid="ignore"):
                return (unr < 0.5) & (np.abs(i_q) <= lim_q) & (np.abs(i_d) <= lim_d) & (i_q**2 + i_d**2 <= lim_amp**2)

        return admissible_eff

    every = np.arange(2 * K * n)
    if not admissible_on(every, np.zeros(2 * K * n))(np.zeros(2 * K * n))[:n].all():
        return None  # holding still on the first path already needs more than the limits
    scale = max(abs(delta[0]), abs(delta[1]))
    ds = np.diff(sig)
    bounds = np.zeros(2 * K * n)
    x2, T, T_prev = np.zeros((K, n)), np.full(K, np.inf), None
    active = np.ones(K, dtype=bool)  # paths still iterated (a bent path far slower than the best is dropped)
    bent = any(sh.alpha != 1.0 or sh.dip for sh in shapes)
    for it in range(PROFILE_ITERATIONS if bent else 1):
        sel = (np.arange(2)[:, None, None] * K * n + np.flatnonzero(active)[None, :, None] * n + np.arange(n)).ravel()
        k_act = int(active.sum())
        bounds[sel] = _bounds(
            admissible_on(sel, np.tile(x2[active].ravel(), 2)), sign[sel], scale, None if it == 0 else bounds[sel]
        )
        b = bounds.reshape(2, K, n)[:, active]
        acc, brk = np.minimum(b[0, :, 1:], b[0, :, :-1]), np.minimum(b[1, :, 1:], b[1, :, :-1])
        fwd = np.concatenate([np.zeros((k_act, 1)), np.cumsum(2.0 * acc * ds, axis=1)], axis=1)
        bwd = np.concatenate([np.cumsum((2.0 * brk * ds)[:, ::-1], axis=1)[:, ::-1], np.zeros((k_act, 1))], axis=1)
        x2[active] = np.minimum(fwd, bwd)
        v = np.sqrt(x2[active])
        with np.errstate(divide="ignore"):
            T[active] = np.sum(2.0 * ds / (v[:, 1:] + v[:, :-1]), axis=1)
        if T_prev is not None and np.all(np.abs(T[active] - T_prev[active]) <= PROFILE_TOLERANCE * T[active]):
            break
        T_prev = T.copy()
        if it >= 1 and coefficients and prune_above is not None:
            best = min(float(np.min(T[active])), prune_above)
            active &= T <= (1.0 + PROFILE_PRUNE) * best
            if not active.any():
                break
    T[~active] = np.inf
    v = np.sqrt(x2)
    out = []
    for j, sh in enumerate(shapes):
        with np.errstate(divide="ignore"):
            dt = 2.0 * ds / (v[j, 1:] + v[j, :-1])
        t = np.concatenate([[0.0], np.cumsum(dt)])
        u = (x2[j, 1:] - x2[j, :-1]) / (2.0 * ds)
        out.append(PathProfile(sh, float(t[-1]) if active[j] else np.inf, t, sig, u))
    return out


def table_length(T: float, step: float) -> int:
    """Number of table points of a move of ``T`` seconds at ``step`` (at least 3)."""
    return max(math.ceil(T / step), 2) + 1


__all__ = [
    "D_BENDS",
    "GAP_BENDS",
    "GAP_DIPS",
    "PROFILE_BISECTIONS",
    "PROFILE_FIRST_BRACKET",
    "PROFILE_GRID",
    "PROFILE_ITERATIONS",
    "PROFILE_MARGINS",
    "PathProfile",
    "PathShape",
    "bump",
    "candidate_shapes",
    "currents",
    "follower_progress",
    "inverse_coefficients_function",
    "path_profiles",
    "refined_shapes",
    "table_length",
]
