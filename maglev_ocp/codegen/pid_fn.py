"""The whole PID step (observer + gain schedule + the two regulators + limits) as CasADi Functions.

:class:`maglev_ocp.controllers.pid.PIDController` runs its high-gain observer and its law
numerically. For the C backend and the compiled closed loop the step is one
self-contained function, composed here from the controller's own pieces (never
retyped): the observer's symbolic update (:func:`maglev_ocp.observers.observer_update`,
the gain of :class:`~maglev_ocp.observers.HighGainObserver`), the controller's
gain-schedule Function (:func:`maglev_ocp.controllers.pid.schedule_function`), its inverse
feed-forward (:func:`maglev_ocp.controllers.pid.inverse_feedforward_function` through
:func:`maglev_ocp.controllers.pid.inverse_feedforward`) and its law
(:func:`maglev_ocp.controllers.pid.pid_law` evaluated with :data:`maglev_ocp.controllers.pid.SYMBOLIC`):

``pid_step(state_in, meas, ref, p) -> (u, state_out, x_hat, u_eq, flags)``

``pid_init(meas, p) -> state``: at rest at the reading, the previous current the
(clipped) hover current there, as ``PIDController.reset``.

With a model file (``settings.model``) whose effects the PID's feed-forward
takes (:func:`maglev_ocp.controllers.pid.pid_model_effects`), the feed-forward
correction is the controller's own :func:`maglev_ocp.controllers.pid.effect_correction`
on the effects' expression (:meth:`maglev_ocp.controllers.model_file.ModelEffects.expr`,
parameters baked in). A model file's lag delay (:func:`maglev_ocp.controllers.pid.pid_lead_samples`)
makes the ``ref`` input twelve rows: the reference now (feedback) and the plan's
row that many periods ahead (feed-forward), as the Python step reads them.
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.controllers.pid import (
    SYMBOLIC,
    clip_currents,
    demanded_row,
    effect_correction,
    feedforward_row,
    inverse_feedforward,
    inverse_feedforward_function,
    pid_law,
    pid_lead_samples,
    pid_model_effects,
    schedule_function,
)

from .. import constants as k
from ..model import get_model
from ..observers import ObserverSettings, observer_update
from ..signals import REF_FIELDS
from .observer_fn import observer_gain

#: Pieces of the PID controller's state vector: name, size, unit, meaning.
PID_STATE: tuple[tuple[str, int, str, str], ...] = (
    ("x_hat", 4, "m, m/s, m, m/s", "observer estimate (g, g_dot, d, d_dot)"),
    ("dist", 2, "m/s^2", "acceleration disturbance estimate (gap, horizontal)"),
    ("z", 2, "m s", "integrals of the position errors (gap, horizontal)"),
    ("u_prev", 2, "A", "currents commanded at the previous step (i_q, i_d)"),
    ("ueq_good", 2, "A", "last finite hover current (i_q, i_d), held where the model cannot hover"),
)
PID_STATE_SIZE = sum(n for _, n, _, _ in PID_STATE)
#: 0/1 flags of ``pid_step``.
PID_FLAGS: tuple[str, ...] = ("saturated", "fallback")


def pid_state_slices() -> dict[str, slice]:
    """Slice of each piece of :data:`PID_STATE`."""
    out, i = {}, 0
    for name, n, _, _ in PID_STATE:
        out[name] = slice(i, i + n)
        i += n
    return out


def pid_functions(settings, Ts: float = k.Ts) -> tuple[ca.Function, ca.Function]:
    """``pid_init`` and ``pid_step`` for :class:`maglev_ocp.controllers.pid.PIDSettings` ``settings``.

    The tuning and the observer gain (``settings.observer_eps``, disturbance
    estimate on, as the controller builds its observer) are baked in; the model
    parameters ``p`` are an input.
    """
    L = observer_gain(ObserverSettings(eps=settings.observer_eps), Ts)
    sched = schedule_function()
    np_ = get_model().np_
    sl = pid_state_slices()
    model = load_controller_model(settings.model) if settings.model else None
    eff = pid_model_effects(settings, model, model.params.vector(), L) if model is not None else None

    meas0, p0 = ca.SX.sym("meas", 2), ca.SX.sym("p", np_)
    u_eq0 = sched(meas0[0], meas0[1], p0)[0]
    iq0, id0, _, _ = clip_currents(SYMBOLIC, settings, u_eq0[0], u_eq0[1])
    state0 = ca.vertcat(meas0[0], 0, meas0[1], 0, ca.SX.zeros(4), iq0, id0, u_eq0)
    pid_init = ca.Function("pid_init", [meas0, p0], [state0], ["meas", "p"], ["state"])

    st, meas = ca.SX.sym("state_in", PID_STATE_SIZE), ca.SX.sym("meas", 2)
    # with a model file's lag (pid_lead_samples) the ref input is the row now (feedback) and the plan's row the
    # lag's delay ahead (feed-forward), as PIDController.step reads them
    nr = len(REF_FIELDS)
    lead = pid_lead_samples(settings, model, Ts) if model is not None else 0.0
    ref, p = ca.SX.sym("ref", 2 * nr if lead else nr), ca.SX.sym("p", np_)
    r_now = [ref[i] for i in range(nr)]
    r_ff = [ref[nr + i] for i in range(nr)] if lead else r_now
    x_hat, dist = observer_update(st[sl["x_hat"]], st[sl["dist"]], st[sl["u_prev"]], meas, p, L, Ts, True)
    u_eq, b_v, a21, L1 = sched(r_ff[0], r_ff[3], p)
    # the feed-forward from the model's inverse at the planned row, as PIDController.step takes it
    u_inv = inverse_feedforward_function()(ca.vertcat(*r_ff), p)
    ff, r_ff = inverse_feedforward(SYMBOLIC, settings, (u_inv[0], u_inv[1]), (u_eq[0], u_eq[1]), r_ff)
    u_eq = ca.vertcat(*ff)
    if eff is not None:  # the model file's effects in the feed-forward, as PIDController.effect_feedforward
        r_v = demanded_row(settings, r_ff, r_now, [x_hat[i] for i in range(4)])
        du = effect_correction(lambda x, u: eff.expr(ca.vertcat(*x), ca.vertcat(*u), p), r_v, u_eq, b_v, L1)
        ok = ca.logic_and(ca.fabs(u_eq[0]) + ca.fabs(u_eq[1]) < ca.inf, ca.logic_and(b_v != 0, L1 != 0))
        u_eq = u_eq + ca.if_else(ok, ca.vertcat(*du), ca.SX.zeros(2))
    z, good = st[sl["z"]], st[sl["ueq_good"]]
    out = pid_law(
        SYMBOLIC,
        settings,
        Ts,
        [x_hat[i] for i in range(4)],
        (u_eq[0], u_eq[1], b_v, a21, L1),
        feedforward_row(r_now, r_ff),
        (z[0], z[1]),
        (good[0], good[1]),
    )
    u = ca.vertcat(*out.u)
    state = ca.vertcat(x_hat, dist, *out.z, u, *out.ueq_good)
    flags = ca.vertcat(ca.logic_or(out.q_sat, out.d_sat), out.fallback)
    pid_step = ca.Function(
        "pid_step",
        [st, meas, ref, p],
        [u, state, x_hat, ca.vertcat(*out.ueq_good), flags],
        ["state_in", "meas", "ref", "p"],
        ["u", "state_out", "x_hat", "u_eq", "flags"],
    )
    return pid_init, pid_step


__all__ = ["PID_FLAGS", "PID_STATE", "PID_STATE_SIZE", "pid_functions", "pid_state_slices"]
