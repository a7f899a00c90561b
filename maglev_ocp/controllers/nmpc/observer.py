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

from maglev_ocp.observers import adapt_constants, adapt_gate, adapt_shift, noise_gate, observer_update_innovation
from maglev_ocp.observers import corrected_params as shared_corrected_params
from maglev_ocp.observers import innovation_noise as shared_innovation_noise

from .design import StepDesign, adapted


def corrected_params(d: StepDesign, p: ca.SX, theta: ca.SX) -> ca.SX:
    """``p`` with the adapted constants corrected (:func:`maglev_ocp.observers.corrected_params`)."""
    return shared_corrected_params(p, theta, adapted(d.settings))


def innovation_noise(d: StepDesign, S: dict, e: ca.SX, measure: ca.SX) -> tuple[ca.SX, ca.SX]:
    """The innovation's variance per axis and the next ``noise`` piece.

    See :func:`maglev_ocp.observers.innovation_noise`; the settings give the
    fixed value (``adapt_noise``) or the measurement's time constant and floor.
    """
    s = d.settings
    return shared_innovation_noise(
        S["noise"], S["age"][0], e, measure, s.adapt_noise, round(s.adapt_window / d.Ts), d.Ts,
        s.adapt_noise_time, s.adapt_noise_floor,
    )  # fmt: skip


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
        s = d.settings
        window = round(s.adapt_window / d.Ts)
        ok, since, age = adapt_gate(S["since"][0], S["age"][0], moving, fresh, window)
        r2, noise = innovation_noise(d, S, e, noise_gate(ok, age, fresh, y, window))
        dtheta, ups_plus, theta, cov = adapt_constants(
            S["xhat"], S["u_prev"], p, S["ups"], S["theta"], S["cov"], e, ok, adapted(s), d.L_obs, d.Ts,
            r2, s.adapt_bound,
        )  # fmt: skip
        dx, dd = adapt_shift(ups_plus, dtheta)  # the estimate moves with the constants: eps = eta + Ups theta_err
        xo, do = xo + dx, do + dd
        pieces = ca.vertcat(theta, ca.if_else(fresh, S["ups"], ca.vec(ups_plus)), cov, since, age, noise)
    xhat = ca.if_else(fresh, S["xhat"], xo)
    dist = ca.if_else(fresh, S["dist"], do)
    w = dist if d.settings.offset_free else ca.SX.zeros(2)
    p_hat = corrected_params(d, p, theta) if adapt else p
    return fresh, xhat, dist, w, p_hat, pieces


__all__ = ["corrected_params", "innovation_noise", "observe"]
