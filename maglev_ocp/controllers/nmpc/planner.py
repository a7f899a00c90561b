"""Stage 2a of the step, reference planning: rest-to-rest moves at the current-limited acceleration.

A 100 mm move takes about 90 ms at the current limits, four times a 20 ms
horizon, so the NMPC tracks a planned reference: when the target changes, the
step plans a jerk-limited bang-bang move (trapezoidal acceleration) of both
axes, synchronized to the same duration, at a fraction of the acceleration the
current disk leaves for thrust at hover. All of it is CasADi SX, evaluated
branch-free, so it is part of the generated C as well.

The profile is the suite's one jerk-limited profile
(:func:`maglev_ocp.reference.unit_profile`, written for NumPy and SX alike).
Also here: the feed-forward currents of a reference (the shared model's
inverse, :func:`maglev_ocp.model.inverse_expressions`, cogging included), used
by the NMPC's input cost.
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.model import get_model, inverse_expressions
from maglev_ocp.reference import unit_profile

from .design import StepDesign

#: Shortest planned move [s] (a target change within a few periods is still a move, not a jump).
MIN_MOVE_TIME = 4e-3


def half_duration(dist: ca.SX, acc: ca.SX, tj: float) -> tuple[ca.SX, ca.SX]:
    """Half duration ``h`` and effective jerk time of a rest-to-rest move of ``|dist|`` at peak ``acc``.

    Solves ``|dist| = acc h (h - tj)`` (the half move of :func:`move_at` covers ``acc h (h - tj) / 2``); moves
    too short for a constant-acceleration phase use ``tj = h/2``.
    """
    D = ca.fabs(dist)
    h1 = (tj + ca.sqrt(tj**2 + 4 * D / acc)) / 2
    h2 = ca.sqrt(2 * D / acc)
    short = h1 < 2 * tj
    return ca.if_else(short, h2, h1), ca.if_else(short, h2 / 2, tj)


def move_at(t: ca.SX, dist: ca.SX, h: ca.SX, tj: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Displacement, velocity and acceleration at time ``t`` of a move of ``dist`` in ``2 h``.

    The suite's one jerk-limited profile (:func:`maglev_ocp.reference.unit_profile`)
    over ``T = 2 h`` with ramp fraction ``tj / T``; its peak acceleration is
    ``dist / (h (h - tj))``. At rest at ``dist`` from ``t = 2 h`` on.
    """
    T = 2 * h
    s, v, a = unit_profile(t / T, tj / T)
    return dist * s, dist * v / T, dist * a / T**2


def feedforward_currents(x: ca.SX, acc: ca.SX, p: ca.SX, w: ca.SX) -> ca.SX:
    """Currents ``(i_q, i_d)`` that give accelerations ``acc = (g_ddot, d_ddot)`` at state ``x``.

    The shared model inverse (:func:`maglev_ocp.model.inverse_expressions`,
    cogging included) for the model accelerations ``acc - w``, ``w`` the
    observer's acceleration disturbance ``(w_g, w_d)``. An opening acceleration
    beyond the field's reach gives the current of the largest one.
    """
    i_q, i_d, _ = inverse_expressions(x, acc - w, p)
    return ca.vertcat(i_q, i_d)


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
        u = inverse_expressions(x, ca.vertcat(-w_g, 0), p, i_q=iq)[1]
        iq = ca.sqrt(ca.fmax(i_max**2 - u**2, 0))
    _, B = m.linearization(x, ca.vertcat(iq, u), p)
    return ca.fabs(B[3, 0]) * iq


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
