"""Stage 3 of the step: RTI linearization of the multiple-shooting prediction, and the linear prediction.

One linearization per shooting interval along the shifted previous solution
(:func:`fn_stage`, mapped over the horizon), on the shared model with cogging
(unless the parameter vector switches it off) plus the observer's disturbance;
after the QP, :func:`fn_pred_stage` propagates the corrections to the new
shooting nodes.
"""

from __future__ import annotations

import casadi as ca

from .design import StepDesign
from .layout import NU, NX
from .planner import feedforward_currents


def fn_stage(d: StepDesign) -> ca.Function:
    """RTI linearization of one shooting interval (SX, mapped): ``(x, u, x_next, p, w) -> (A, B, c)``."""
    m = d.model
    x, u, xn, p, w = (
        ca.SX.sym("x", NX),
        ca.SX.sym("u", NU),
        ca.SX.sym("x_next", NX),
        ca.SX.sym("p", m.np_),
        ca.SX.sym("w", 2),
    )
    xe, A, B = d.FJ(x, u, p, w)
    # B dense (its structural zero would make every consumer re-densify the stacked Bs)
    return ca.Function(
        "nmpc_stage",
        [x, u, xn, p, w],
        [A, ca.densify(B), xe - xn],
        ["x", "u", "x_next", "p", "w"],
        ["A", "B", "c"],
        {"cse": True},
    )


def fn_pred_stage() -> ca.Function:
    """Linear prediction of one stage (SX): ``(dx, A, B, v, c, xbar_next) -> (dx_next, x_next)``."""
    dx, A, B, v, c, xbn = (
        ca.SX.sym("dx", NX),
        ca.SX.sym("A", NX, NX),
        ca.SX.sym("B", NX, NU),
        ca.SX.sym("v", NU),
        ca.SX.sym("c", NX),
        ca.SX.sym("xbar_next", NX),
    )
    dxn = ca.mtimes(A, dx) + ca.mtimes(B, v) + c
    return ca.Function(
        "nmpc_pred_stage",
        [dx, A, B, v, c, xbn],
        [dxn, xbn + dxn],
        ["dx", "A", "B", "v", "c", "xbar_next"],
        ["dx_next", "x_next"],
    )


def predict_through_delay(d: StepDesign, xhat: ca.SX, u_flight: ca.SX, p: ca.SX, w: ca.SX) -> ca.SX:
    """The estimate ``n_delay`` periods ahead: the prediction model driven by the commands in flight.

    ``u_flight`` holds the ``n_delay`` commands sent but not yet applied,
    oldest first, as ``(i_q, i_d)`` pairs; each period is one step of the
    prediction model (RK4 of the shared model plus the observer's disturbance
    ``w``), the same model the QP predicts with, so the state the QP starts
    from and its shooting nodes live on the same clock (``n_delay`` periods
    ahead of the reading).
    """
    x = xhat
    for j in range(d.settings.delay_samples):
        x = d.F(x, u_flight[NU * j : NU * (j + 1)], p, w)
    return x


def u_feedforward(d: StepDesign, x: ca.SX, acc: ca.SX, p: ca.SX, w: ca.SX, n_fix: int = 2) -> ca.SX:
    """Feed-forward currents for accelerations ``acc`` at state ``x`` on the prediction model.

    The shared model's inversion (:func:`~.planner.feedforward_currents`) with the
    model file's effects (``d.effects``) as part of the disturbance, evaluated
    at the currents of the previous pass (a fixed point: exact after one pass
    for effects of the state alone, such as friction and cogging; effects of the
    current, such as a commutation offset, converge geometrically). Without
    effects: :func:`~.planner.feedforward_currents` itself.
    """
    u = feedforward_currents(x, acc, p, w)
    if not d.effects:
        return u
    for _ in range(n_fix):
        u = feedforward_currents(x, acc, p, w + d.effect_accel(x, u, p))
    return u


__all__ = ["fn_pred_stage", "fn_stage", "predict_through_delay", "u_feedforward"]
