"""The whole feedback-linearization step (observer + control law) as CasADi Functions.

:class:`maglev_ocp.controllers.fl.FeedbackLinearization` keeps its observer in Python and
calls the CasADi law :func:`maglev_ocp.controllers.fl.fl_law_function`. For the rig the
step must be one self-contained C function, so this module composes the
observer update (:mod:`maglev_ocp.codegen.observer_fn`, same gains) and the
same law Function into

``fl_step(state_in, meas, ref, p, gains) -> (u, state_out, x_hat, dist, v, flags)``

with the controller's memory in one state vector (:data:`FL_STATE`), and

``fl_init(meas) -> state``: at rest at the reading (as ``FeedbackLinearization.reset``).

Both mirror ``FeedbackLinearization.reset`` / ``step`` line by line, so the C
backend reproduces the Python controller to rounding. With a computation
delay of ``N > 0`` samples (:func:`maglev_ocp.controllers.fl.fl_delay_samples`) the state
also holds the ``N + 1`` commands sent (:func:`fl_state`), the observer is
updated with the oldest (the one applied over the last period) and the law runs
on the FL's own predictor (:func:`maglev_ocp.controllers.fl.fl_predictor_function`, the
shared model's RK4 step through the ``N`` commands in flight); the caller hands
in the reference ``N`` samples ahead, as the Python FL reads it from its plan.

A model file (``settings.model``): its delay is the predictor's (as above) and
its static effects enter the step where the Python FL's enter it, as the same
expressions (:func:`maglev_ocp.controllers.fl.fl_model_effects`,
:meth:`maglev_ocp.controllers.model_file.ModelEffects.expr`: the effect
library's ``effect_delta`` Function with the velocity signs widened, its
parameters baked in as constants): the observer's prediction at its own
estimate, the delay predictor's held acceleration at the planned velocity
(``ref`` rows 1 and 4), and the inverse (two fixed-point passes of the law at
the commanded current and the planned velocity).
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.controllers.fl import (
    EFFECT_PASSES,
    GAIN_FIELDS,
    fl_adapt_state,
    fl_adapted,
    fl_adaptive_observer,
    fl_delay_samples,
    fl_law_function,
    fl_model_effects,
    fl_predictor_function,
    ref_moving,
)
from maglev_ocp.controllers.model_file import load_controller_model

from .. import constants as k
from ..model import get_model
from ..observers import ObserverSettings
from ..signals import REF_FIELDS
from .observer_fn import observer_gain, observer_update

#: Pieces of the FL controller's state vector: name, size, unit, meaning.
FL_STATE: tuple[tuple[str, int, str, str], ...] = (
    ("x_hat", 4, "m, m/s, m, m/s", "observer estimate (g, g_dot, d, d_dot)"),
    ("dist", 2, "m/s^2", "acceleration disturbance estimate (gap, horizontal)"),
    ("z", 2, "m s", "integrals of the position errors (gap, horizontal)"),
    ("u_prev", 2, "A", "currents commanded at the previous step (i_q, i_d)"),
    ("started", 1, "-", "0 right after fl_init (first step skips the observer prediction), then 1"),
)
FL_STATE_SIZE = sum(n for _, n, _, _ in FL_STATE)


def fl_state(delay: int = 0, n_adapt: int = 0) -> tuple[tuple[str, int, str, str], ...]:
    """The state's pieces for a computation delay of ``delay`` samples and ``n_adapt`` adapted constants.

    :data:`FL_STATE`, then the queue of commands sent (``delay > 0``), then the
    adaptive observer's memory (``n_adapt > 0``, :func:`maglev_ocp.controllers.fl.fl_adapt_state`).
    """
    out = FL_STATE
    if delay > 0:
        sent = (
            "sent",
            2 * (delay + 1),
            "A",
            f"the {delay + 1} commands sent (i_q, i_d pairs), oldest first: the first was applied over the "
            "last period, the others are still in flight",
        )
        out = (*out, sent)
    if n_adapt > 0:
        n = n_adapt
        adapt = (
            "adapt",
            7 * n + n * n + 4,
            "-, m, m/s, m/s^2, -, periods, m^2",
            f"adaptive observer: relative errors of the {n} adapted constants, their sensitivities (6 x {n}), "
            "covariance, periods since the reference moved and since reset, the innovation's mean square per axis",
        )
        out = (*out, adapt)
    return out


def fl_state_slices(delay: int = 0, n_adapt: int = 0) -> dict[str, slice]:
    """Slice of each piece of :func:`fl_state` ``(delay, n_adapt)``."""
    out, i = {}, 0
    for name, n, _, _ in fl_state(delay, n_adapt):
        out[name] = slice(i, i + n)
        i += n
    return out


def fl_functions(settings, Ts: float = k.Ts) -> tuple[ca.Function, ca.Function]:
    """``fl_init`` and ``fl_step`` for :class:`maglev_ocp.controllers.fl.FLSettings` ``settings``.

    The observer gain (``settings.observer_eps``, ``settings.disturbance``) and
    the delay predicted through (:func:`maglev_ocp.controllers.fl.fl_delay_samples`) are
    baked in; the model parameters ``p`` and the gain vector ``gains`` (order
    :data:`maglev_ocp.controllers.fl.GAIN_FIELDS`) are inputs.

    Returns
    -------
    fl_init, fl_step : casadi.Function
    """

    law = fl_law_function()
    osettings = ObserverSettings(eps=settings.observer_eps, disturbance=settings.disturbance)
    L = observer_gain(osettings, Ts)
    m = get_model()
    model = load_controller_model(settings.model) if settings.model else None
    delay = fl_delay_samples(settings, model)
    # the model file's effects, widened as the Python FL widens them (one construction: fl_model_effects)
    eff = fl_model_effects(model, model.params.vector(), L, Ts) if model is not None else None
    n_adapt = len(fl_adapted(settings))
    sl = fl_state_slices(delay, n_adapt)
    size = sum(n for _, n, _, _ in fl_state(delay, n_adapt))

    meas0 = ca.SX.sym("meas", 2)
    # the queue of commands sent is filled with the hover current on the first step (it needs p)
    n_sent = 2 * (delay + 1) if delay else 0
    state0 = ca.vertcat(
        meas0[0], 0, meas0[1], 0, ca.SX.zeros(2 + 2 + 2), 0, ca.SX.zeros(n_sent),
        ca.DM(fl_adapt_state(settings)) if n_adapt else ca.SX(0, 1),
    )  # fmt: skip
    fl_init = ca.Function("fl_init", [meas0], [state0], ["meas"], ["state"])

    st, meas, ref = ca.SX.sym("state_in", size), ca.SX.sym("meas", 2), ca.SX.sym("ref", len(REF_FIELDS))
    p, gains = ca.SX.sym("p", m.np_), ca.SX.sym("gains", len(GAIN_FIELDS))
    x_old, d_old, z, u_prev = st[sl["x_hat"]], st[sl["dist"]], st[sl["z"]], st[sl["u_prev"]]
    started = st[sl["started"]][0] > 0.5
    u_applied = u_prev
    if delay:
        # before the run the amplifiers carried the hover current at the reset reading (FeedbackLinearization.reset)
        u_hover = m.u_eq(x_old[0], x_old[2], p)
        u_hover = ca.if_else(ca.fabs(u_hover[0]) + ca.fabs(u_hover[1]) < ca.inf, u_hover, ca.SX.zeros(2))
        sent = ca.if_else(started, st[sl["sent"]], ca.repmat(u_hover, delay + 1))
        u_applied = sent[:2]  # the command sent N + 1 samples ago: applied over the last period
    # the model file's effects are part of the observer's prediction over the period, at its own estimate
    # (FeedbackLinearization.step: added to the disturbance estimate before the update, taken off after);
    # without the disturbance estimate the observer's prediction has no such term (as HighGainObserver.predict)
    obs_eff = eff is not None and settings.disturbance
    d_eff = eff.expr(x_old, u_applied, p) if obs_eff else None
    d_in = d_old + d_eff if obs_eff else d_old
    p_law, ad_next = p, []
    if n_adapt:  # the adaptive observer (the Python FL's Function); the law inverts the corrected constants
        ad_old = st[sl["adapt"]]
        x_obs, d_obs, ad_new, p_hat = fl_adaptive_observer(settings, L, Ts)(
            x_old, d_in, u_applied, meas, p, ad_old, ref_moving(ref)
        )
        p_law = ca.if_else(started, p_hat, p)
        ad_next = [ca.if_else(started, ad_new, ad_old)]
    else:  # a reading that is not finite: prediction only, as the Python FL
        x_obs, d_obs = observer_update(x_old, d_in, u_applied, meas, p, L, Ts, settings.disturbance, True)
    if obs_eff:
        d_obs = d_obs - d_eff  # what is left is the residual disturbance
    # first step after reset: the estimate is the reset reading (no prediction), as in the Python class
    x_hat = ca.if_else(started, x_obs, x_old)
    dist = ca.if_else(started, d_obs, d_old)
    x_law = x_hat
    v_plan = (ref[1], ref[4])  # the planned velocities (the reference N samples ahead): what the effects see
    if delay:  # the FL's own predictor: the estimate N samples ahead through the commands in flight
        # over the periods predicted through, the effects act as they do now (held, as the disturbance)
        d_pred = dist + eff.expr(x_hat, sent[-2:], p, v_plan) if eff is not None else dist
        x_law = fl_predictor_function(delay, Ts)(x_hat, d_pred, sent[2:], p_law)
    out = law(x_law, dist, ref, z, p_law, gains)
    if eff is not None:
        # the inverse with the effects at the command (EFFECT_PASSES fixed-point passes, stopped by a non-finite
        # current)
        for _ in range(EFFECT_PASSES):
            u = out[0]
            ok = ca.fabs(u[0]) + ca.fabs(u[1]) < ca.inf
            new = law(x_law, dist + eff.expr(x_law, u, p, v_plan), ref, z, p_law, gains)
            out = [ca.if_else(ok, a, b) for a, b in zip(new, out, strict=True)]
    u, z_next, v, flags = out
    finite = ca.fabs(u[0]) + ca.fabs(u[1]) < ca.inf  # never command NaN/inf (NaN compares false)
    u = ca.if_else(finite, u, ca.SX.zeros(2))
    z_next = ca.if_else(finite, z_next, z)  # a failed law keeps its integrators (as the Python FL)
    state = ca.vertcat(x_hat, dist, z_next, u, 1, *([sent[2:], u] if delay else []), *ad_next)
    fl_step = ca.Function(
        "fl_step",
        [st, meas, ref, p, gains],
        [u, state, x_hat, dist, v, flags],
        ["state_in", "meas", "ref", "p", "gains"],
        ["u", "state_out", "x_hat", "dist", "v", "flags"],
    )
    return fl_init, fl_step


__all__ = ["FL_STATE", "FL_STATE_SIZE", "fl_functions", "fl_state", "fl_state_slices"]
