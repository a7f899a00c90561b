"""The suite's rest-to-rest profiles: the jerk-limited unit move, its asymmetric split, planned moves."""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np


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
