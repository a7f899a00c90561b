"""Stage 1 of the step: the extended-state high-gain observer, symbolic, with online constant corrections.

The observer of :mod:`maglev_ocp.observers` (same gains, same predictor-corrector
update) on the quantized encoders: state and a constant acceleration disturbance
per axis, the latter used by the prediction for offset-free tracking.

With ``settings.adapt`` it is also an adaptive observer: the relative errors
``theta`` of chosen model constants (those that enter the model linearly, e.g.
the thrust constant C1 and the attraction constant C4) are estimated from the
innovation, and the model the observer, the feed-forward and the prediction
use is the corrected one, ``p_j (1 + theta_j)``. A constant acceleration
disturbance cannot follow an error proportional to the current: during a move
it learns the move's mismatch (e.g. 2 % of a 50 m/s^2 thrust) and, when the
current drops at the end of the move, pushes the mover past the target while it
decays. The constants' errors do not decay when the current drops.

The update is the discrete form of the adaptive observer of Q. Zhang (IEEE TAC
47(3), 2002): per axis the error of the estimate ``(pos, vel, a_dist)`` is
``eps = eta + Ups theta_err`` with ``eta`` decaying by the observer's own error
dynamics ``(I - L H) F`` and the sensitivity ``Ups`` propagated as

    Ups^- = F Ups + G b,     Ups^+ = (I - L H) Ups^-,

``b`` the acceleration per unit relative error (the constant's column of the
model's linear-in-parameters split, :meth:`maglev_ocp.model.MaglevModel.linear_split`,
times its value). The innovation is then ``e = H Ups^- theta_err`` plus a
decaying term, a linear regression on ``phi = H Ups^-`` solved by recursive least
squares (``K = P phi^T (phi P phi^T + R)^-1``, ``R`` the innovation's noise,
measured online at rest (:func:`innovation_noise`),
``P`` starting at the prior ``adapt_prior^2 I``) with projection onto
``|theta| <= adapt_bound``; the estimate moves by ``Ups^+ dtheta``. ``phi`` is
only non-zero for a few observer time constants after the current changes (the
disturbance state absorbs a constant ``b``), so the constants are learnt from
the moves and frozen at rest.
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.observers import observer_update_innovation
from maglev_ocp.signals import PARAM_NAMES

from .design import StepDesign, adapted


def corrected_params(d: StepDesign, p: ca.SX, theta: ca.SX) -> ca.SX:
    """The parameter vector with the adapted constants corrected: ``p_j (1 + theta_j)``."""
    names = adapted(d.settings)
    if not names:
        return p
    scale = [1] * p.shape[0]
    for j, n in enumerate(names):
        scale[PARAM_NAMES.index(n)] = 1 + theta[j]
    return p * ca.vertcat(*scale)


def innovation_noise(d: StepDesign, S: dict, e: ca.SX, measure: ca.SX) -> tuple[ca.SX, ca.SX]:
    """The innovation's variance per axis the update assumes, and the new ``noise`` state piece.

    With ``adapt_noise`` set, its square. Else measured: the running mean
    square of the innovation over the periods ``measure`` (the constants not
    updated, the observer past its start-up, a finite reading), an average
    over the first periods and an exponential one of time constant
    ``adapt_noise_time`` after; the update takes it no lower than
    ``adapt_noise_floor^2``. The innovation there is the encoders' noise and
    quantization plus the rig's unmodelled forces at rest, which are what the
    least squares must weigh each period's evidence against: an assumed noise
    three times too large keeps a weakly excited constant (C4 on a gap move)
    at a fraction of its error for many moves (the prior's pull to zero).
    """
    s = d.settings
    if s.adapt_noise is not None:
        return ca.DM.ones(2) * s.adapt_noise**2, S["noise"]
    window = round(s.adapt_window / d.Ts)
    n_rest = ca.fmax(S["age"][0] - window, 1)  # a bound on the periods measured so far
    a = ca.fmax(1 / n_rest, d.Ts / s.adapt_noise_time)
    noise = ca.if_else(measure, S["noise"] + a * (e**2 - S["noise"]), S["noise"])
    return ca.fmax(S["noise"], s.adapt_noise_floor**2), noise


def _adapt(
    d: StepDesign, S: dict, p: ca.SX, e: ca.SX, ok_update: ca.SX, r2: ca.SX
) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """Sensitivity propagation and the constants' update; ``(dtheta, ups_plus, theta_new, cov_new)``.

    ``ups`` columns are the sensitivities of ``(g, g_dot, a_g, d, d_dot, a_d)``
    to each constant's relative error; ``e`` the innovation ``(e_g, e_d)``,
    ``r2`` its noise variance per axis (:func:`innovation_noise`).
    """
    s, Ts, L = d.settings, d.Ts, d.L_obs
    names = adapted(s)
    n = len(names)
    # acceleration per unit relative error of each constant, at the prior estimate and the applied current
    A, _ = d.model.linear_split(names)(S["xhat"], S["u_prev"], p)
    pj = ca.vertcat(*[p[PARAM_NAMES.index(nm)] for nm in names])
    ups = ca.reshape(S["ups"], 6, n)
    cols, phis = [], []
    for j in range(n):
        col = []
        for axis, row in ((0, 1), (1, 3)):
            b = A[row, j] * pj[j]
            u_pos, u_vel, u_w = ups[3 * axis, j], ups[3 * axis + 1, j], ups[3 * axis + 2, j]
            # Ups^- = F Ups + G b (double integrator with the disturbance state, as the observer's gain design)
            m_pos = u_pos + Ts * u_vel + Ts**2 / 2 * (u_w + b)
            m_vel = u_vel + Ts * (u_w + b)
            phis.append(m_pos)
            # Ups^+ = (I - L H) Ups^-
            col += [m_pos - L[0] * m_pos, m_vel - L[1] * m_pos, u_w - L[2] * m_pos]
        cols.append(ca.vertcat(*col))
    ups_plus = ca.horzcat(*cols)
    Phi = ca.reshape(ca.vertcat(*phis), 2, n)  # rows (g, d), one column per constant
    # recursive least squares (a Kalman filter on constant parameters): the innovation's noise
    # (quantization, process noise) weighs each period's evidence; P shrinks as the moves inform theta
    P = ca.reshape(S["cov"], n, n)
    Sm = ca.mtimes(ca.mtimes(Phi, P), Phi.T) + ca.diag(r2)
    K = ca.mtimes(ca.mtimes(P, Phi.T), ca.inv(Sm))
    P_new = P - ca.mtimes(ca.mtimes(K, Phi), P)
    P_new = 0.5 * (P_new + P_new.T)
    theta_new = ca.fmin(ca.fmax(S["theta"] + ca.mtimes(K, e), -s.adapt_bound), s.adapt_bound)
    dtheta = ca.if_else(ok_update, theta_new - S["theta"], ca.SX.zeros(n))
    cov = ca.if_else(ok_update, ca.vec(P_new), S["cov"])
    return dtheta, ups_plus, S["theta"] + dtheta, cov


def observe(d: StepDesign, S: dict, y: ca.SX, p: ca.SX, moving: ca.SX | None = None) -> tuple[ca.SX, ...]:
    """Observer update from the state pieces ``S`` and the reading ``y = (g, d)``.

    Right after reset (``fresh``) the estimate is kept (no prediction over a
    period that has not passed); a non-finite reading is skipped (prediction only).
    ``moving`` (1 while the reference moves) opens the constants' update for the
    move and ``adapt_window`` after it (but not within ``adapt_window`` of the
    reset): the excitation is the planned move's currents; a push while
    holding, or the quantization's limit cycle at rest,
    moves the current too but would bias the constants (a 100 N pull drove
    C3 and C4 to -18 % and +25 % without the window).

    Returns
    -------
    fresh, xhat, dist, w : casadi.SX
        The fresh flag, the state and disturbance estimates, and the disturbance
        the prediction uses (``dist``, or zero without ``offset_free``).
    p_hat : casadi.SX
        The parameter vector with the adapted constants corrected (``p`` without ``adapt``).
    pieces : casadi.SX
        The new ``theta``, ``ups``, ``cov``, ``since``, ``age`` and ``noise`` state pieces (empty without
        ``adapt``).
    """
    fresh = S["fresh"][0] > 0.5
    adapt = bool(adapted(d.settings))
    p_obs = corrected_params(d, p, S["theta"]) if adapt else p
    # a model file's effects are part of the prediction over the period (as in FL): added to the
    # disturbance for the update, taken out after it, so ``dist`` stays the residual disturbance
    eff = d.effect_accel(S["xhat"], S["u_prev"], p_obs) if d.effects else None
    dist_in = S["dist"] if eff is None else S["dist"] + eff
    xo, do, e = observer_update_innovation(
        S["xhat"], dist_in, S["u_prev"], y, p_obs, d.L_obs, d.Ts, disturbance=True, skip_nonfinite=True
    )
    if eff is not None:
        do = do - eff
    theta, pieces = (S["theta"] if adapt else ca.SX(0, 1)), ca.SX(0, 1)
    if adapt:
        moving = ca.SX(1) if moving is None else moving
        since = ca.if_else(moving, 0, ca.fmin(S["since"][0] + 1, 1e6))
        age = ca.fmin(S["age"][0] + 1, 1e6)
        window = round(d.settings.adapt_window / d.Ts)
        # not during the observer's own start-up either: its converging estimate is no model error
        started = ca.logic_and(ca.logic_not(fresh), age > window)
        ok = ca.logic_and(started, since <= window)
        finite = ca.fabs(y[0]) + ca.fabs(y[1]) < 1e3  # as observer_update_innovation's skip
        r2, noise = innovation_noise(d, S, e, ca.logic_and(ca.logic_and(started, ca.logic_not(ok)), finite))
        dtheta, ups_plus, theta, cov = _adapt(d, S, p, e, ok, r2)
        corr = ca.mtimes(ups_plus, dtheta)  # the estimate moves with the constants: eps = eta + Ups theta_err
        xo = xo + ca.vertcat(corr[0], corr[1], corr[3], corr[4])
        do = do + ca.vertcat(corr[2], corr[5])
        pieces = ca.vertcat(theta, ca.if_else(fresh, S["ups"], ca.vec(ups_plus)), cov, since, age, noise)
    xhat = ca.if_else(fresh, S["xhat"], xo)
    dist = ca.if_else(fresh, S["dist"], do)
    w = dist if d.settings.offset_free else ca.SX.zeros(2)
    p_hat = corrected_params(d, p, theta) if adapt else p
    return fresh, xhat, dist, w, p_hat, pieces


__all__ = ["corrected_params", "innovation_noise", "observe"]
