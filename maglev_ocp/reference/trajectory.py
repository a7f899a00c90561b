"""``shaping: trajectory``: the shortest current-feasible jerk-limited move (bisection on its duration)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import constants as k
from ..errors import ConfigError
from ..params import NOMINAL, Params
from .feasibility import PlanEffects, _limits_ok_st
from .profiles import Move, peak_acceleration_factor
from .settings import D_SPLITS, GAP_PLACES, GAP_SHARES, GAP_SPLITS, ReferenceSettings


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
