"""Stage 2a of the step, reference planning: rest-to-rest moves at the current-limited acceleration.

A 100 mm move takes about 90 ms at the current limits, four times a 20 ms
horizon, so the NMPC tracks a planned reference: when the target changes, the
step plans a jerk-limited bang-bang move (trapezoidal acceleration) of both
axes, synchronized to the same duration, at a fraction of the acceleration the
current disk leaves for thrust at hover. All of it is CasADi SX, evaluated
branch-free, so it is part of the generated C as well.

Also here: the feed-forward currents of a reference (the model inverted for
given accelerations by Newton's method on the shared model, not retyped), used
by the NMPC's input cost.
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.model import get_model

from .design import StepDesign

#: Shortest planned move [s] (a target change within a few periods is still a move, not a jump).
MIN_MOVE_TIME = 4e-3


def unit_half_profile(t: ca.SX, h: ca.SX, tj: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Accelerating half of a jerk-limited bang-bang move with unit peak acceleration.

    Acceleration ramps from 0 to 1 over ``tj``, holds, ramps back to 0 at ``h``
    (``h >= 2 tj``). Position at ``h`` is ``h (h - tj) / 2``.

    Parameters
    ----------
    t : casadi.SX
        Time since the start [s], clamped to ``[0, h]``.
    h : casadi.SX
        Duration of the half move [s].
    tj : casadi.SX
        Jerk (ramp) time [s], ``0 < tj <= h/2``.

    Returns
    -------
    tuple of casadi.SX
        Position, velocity and acceleration for unit peak acceleration.
    """
    t = ca.fmin(ca.fmax(t, 0), h)
    # phase 1: ramp up
    v1, p1 = tj / 2, tj**2 / 6
    # phase 2: constant acceleration, length h - 2 tj
    s2 = h - 2 * tj
    v2, p2 = v1 + s2, p1 + v1 * s2 + s2**2 / 2
    a_1, v_1, p_1 = t / tj, t**2 / (2 * tj), t**3 / (6 * tj)
    s = t - tj
    a_2, v_2, p_2 = ca.SX(1), v1 + s, p1 + v1 * s + s**2 / 2
    s = t - (h - tj)
    a_3 = 1 - s / tj
    v_3 = v2 + s - s**2 / (2 * tj)
    p_3 = p2 + v2 * s + s**2 / 2 - s**3 / (6 * tj)
    in1, in2 = t < tj, t < h - tj
    pick = lambda e1, e2, e3: ca.if_else(in1, e1, ca.if_else(in2, e2, e3))  # noqa: E731
    return pick(p_1, p_2, p_3), pick(v_1, v_2, v_3), pick(a_1, a_2, a_3)


def half_duration(dist: ca.SX, acc: ca.SX, tj: float) -> tuple[ca.SX, ca.SX]:
    """Half duration ``h`` and effective jerk time of a rest-to-rest move of ``|dist|`` at peak ``acc``.

    Solves ``|dist| = acc h (h - tj)`` (from :func:`unit_half_profile`); moves
    too short for a constant-acceleration phase use ``tj = h/2``.
    """
    D = ca.fabs(dist)
    h1 = (tj + ca.sqrt(tj**2 + 4 * D / acc)) / 2
    h2 = ca.sqrt(2 * D / acc)
    short = h1 < 2 * tj
    return ca.if_else(short, h2, h1), ca.if_else(short, h2 / 2, tj)


def move_at(t: ca.SX, dist: ca.SX, h: ca.SX, tj: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Displacement, velocity and acceleration at time ``t`` of a move of ``dist`` in ``2 h``.

    The peak acceleration follows from ``dist = A h (h - tj)``; the second half
    mirrors the first (``p(t) = dist - p(2h - t)``, ``a(t) = -a(2h - t)``).
    """
    A = dist / (h * (h - tj))
    first = t < h
    tt = ca.if_else(first, t, 2 * h - t)
    p, v, a = unit_half_profile(tt, h, tj)
    pos = ca.if_else(first, A * p, dist - A * p)
    vel = A * v
    acc = ca.if_else(first, A * a, -A * a)
    done = t >= 2 * h
    return ca.if_else(done, dist, pos), ca.if_else(done, 0, vel), ca.if_else(done, 0, acc)


def u_for_accel(x: ca.SX, acc: ca.SX, p: ca.SX, w: ca.SX, n_newton: int = 3) -> ca.SX:
    """Currents that give accelerations ``acc = (g_ddot, d_ddot)`` at state ``x`` (model inversion).

    Newton's method on ``f(x, u, p) + w - acc = 0`` in ``u`` from the hover
    currents ``u_eq``; the vertical equation is quadratic in ``i_d`` and the
    horizontal one linear in ``i_q``, so three steps reach machine precision.
    ``w`` is the acceleration disturbance ``(w_g, w_d)`` of the observer.
    """
    m = get_model()
    u = ca.SX.sym("u", 2)
    xs, ps = ca.SX.sym("x", 4), ca.SX.sym("p", m.np_)
    fx = m.f(xs, u, ps)
    res = ca.vertcat(fx[1], fx[3])
    F = ca.Function("acc_of_u", [xs, u, ps], [res, ca.jacobian(res, u)])
    u0 = m.u_eq(x[0], x[2], p)
    u_k = ca.if_else(ca.fabs(u0[0]) + ca.fabs(u0[1]) < 1e3, u0, ca.vertcat(0, 0))  # NaN: no hover
    for _ in range(n_newton):
        r, J = F(x, u_k, p)
        r = r + w - acc
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        du0 = (J[1, 1] * r[0] - J[0, 1] * r[1]) / det
        du1 = (-J[1, 0] * r[0] + J[0, 0] * r[1]) / det
        u_k = u_k - ca.vertcat(du0, du1)
    return u_k


def thrust_accel_available(g: ca.SX, p: ca.SX, i_max: float, w_g: ca.SX, n_fix: int = 3) -> ca.SX:
    """Largest horizontal acceleration [m/s^2] at gap ``g`` when hovering on the current disk.

    Fixed point ``i_d = hover(g, i_q)``, ``i_q = sqrt(i_max^2 - i_d^2)``: the
    reluctance term of ``i_q^2`` pulls the mover up, so hovering needs more
    ``i_d``, which leaves less ``i_q`` (seed eq. (2) with the amplitude limit).
    """
    m = get_model()
    iq = ca.SX(0)
    x = ca.vertcat(g, 0, 0, 0)
    u = None
    for _ in range(n_fix):
        # hover with the current i_q: vertical acceleration 0 (horizontal left free: i_q given)
        u = _hover_id(x, iq, p, w_g)
        iq = ca.sqrt(ca.fmax(i_max**2 - u**2, 0))
    _, B = m.linearization(x, ca.vertcat(iq, u), p)
    return ca.fabs(B[3, 0]) * iq


def _hover_id(x: ca.SX, iq: ca.SX, p: ca.SX, w_g: ca.SX, n_newton: int = 3) -> ca.SX:
    """``i_d`` that makes the vertical acceleration zero at ``x`` for a given ``i_q`` (Newton)."""
    m = get_model()
    i_d = m.u_eq(x[0], 0, p)[1]
    i_d = ca.if_else(ca.fabs(i_d) < 1e3, i_d, 0)
    for _ in range(n_newton):
        u = ca.vertcat(iq, i_d)
        a = m.f(x, u, p)[1] + w_g
        _, B = m.linearization(x, u, p)
        i_d = i_d - a / B[1, 1]
    return i_d


def plan_duration(d: StepDesign, g_s, d_s, g_t, d_t, p, w_g):
    """Half duration and jerk time of a synchronized rest-to-rest move from ``(g_s, d_s)`` to ``(g_t, d_t)``."""
    pl = d.settings.plan
    # Thrust acceleration left on the current disk at hover, at the weakest of start, middle, end gap.
    acc = [thrust_accel_available(g, p, d.settings.current_limit, w_g) for g in (g_s, g_t, (g_s + g_t) / 2)]
    a_d = pl.accel_margin * ca.fmin(ca.fmin(acc[0], acc[1]), acc[2])
    a_d = ca.fmax(a_d, 1.0)
    h_d, _ = half_duration(d_t - d_s, a_d, pl.jerk_time)
    h_g, _ = half_duration(g_t - g_s, pl.gap_accel, pl.jerk_time)
    h = ca.fmax(ca.fmax(h_d, h_g), MIN_MOVE_TIME / 2)
    tj = ca.fmin(pl.jerk_time, h / 2)
    return h, tj


def advance_plan(d: StepDesign, pl: ca.SX, fresh: ca.SX, xhat: ca.SX, tgt: ca.SX, p: ca.SX, w: ca.SX) -> ca.SX:
    """The planner state after this period: replan from the estimate when the target changes, else advance.

    ``pl = (g_start, d_start, g_target, d_target, t, h, tj)``; in ``preview``
    mode nothing is planned (the runner's reference is tracked) and only the
    clock runs.
    """
    g_t, d_t = tgt[0], tgt[1]
    if d.mode == "plan":
        new = ca.fabs(g_t - pl[2]) + ca.fabs(d_t - pl[3]) > 0
        h_new, tj_new = plan_duration(d, xhat[0], xhat[2], g_t, d_t, p, w[0])
    else:
        new, h_new, tj_new = ca.SX(0), pl[5], pl[6]
    t_adv = ca.if_else(fresh, pl[4], pl[4] + d.Ts)
    return ca.if_else(
        new,
        ca.vertcat(xhat[0], xhat[2], g_t, d_t, 0, h_new, tj_new),
        ca.vertcat(pl[0], pl[1], pl[2], pl[3], ca.fmin(t_adv, 2 * pl[5] + 1.0), pl[5], pl[6]),
    )
