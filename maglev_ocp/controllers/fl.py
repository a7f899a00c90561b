"""Feedback linearization of the stage (the nonlinear design the seed cites as [3]).

The outputs ``(g, d)`` have relative degree {2, 2} and no zero dynamics, so the
model can be inverted exactly: given desired accelerations ``(a_g, a_d)``,
``i_q`` follows from the horizontal equation (linear in ``i_q``) and ``i_d``
from the quadratic of the vertical equation (seed eq. (2), ``shared/spec/NOTES.md``).
The inversion includes cogging (seed eq. (9)) whenever the parameter vector
has ``xi0 > 0``; a cogging-blind controller is the same law with ``xi0 = 0``.

The outer loop turns the two outputs into double integrators driven by a PD
(optionally PID) law with reference feedforward; the extended-state observer's
disturbance estimate is subtracted, which makes the tracking offset-free
against slowly varying model error. Current limits (each axis and the 8 A
amplitude) are enforced with the vertical axis first (it is open-loop
unstable), and the integrators stop when their axis saturates (anti-windup).

The whole control law is one CasADi Function (:func:`fl_law_function`) built
from the shared model's Functions, so it can be code-generated as it is.

Computation delay (``delay_samples: N``, the loop's delay the rig engineer
knows): the current computed from reading k reaches the amplifiers at k + N.
The observer is then updated with the current that was really applied over
the last period (the one sent N + 1 samples ago), and a predictor
(:func:`fl_predictor_function`) propagates its estimate N samples ahead
through the shared model's discrete step with the N currents already sent but
not yet applied (and the disturbance estimate, as the observer's own
prediction does); the law runs on that predicted state (a Smith predictor in
state space: the delay leaves the loop's characteristic equation). The
reference the predicted state must meet is the one N samples ahead: read from
the reference plan when one is given (:meth:`FeedbackLinearization.set_reference_plan`,
as the runner does), so the mover follows the plan on time; without a plan,
the reference handed in is used as it is, so the mover follows it N samples
late, with the delay-free loop's response (extrapolating it instead would
put the feedforward acceleration N samples late, which costs more than the lag).

A model file (``model: FILE``, :mod:`maglev_ocp.controllers.model_file`, e.g. the
``model.yaml`` of ``maglev diagnose``) enters as for the NMPC: its constants are
the controller's parameters, its amplifier lag's transport delay plus its
time constant (rounded to whole periods, :meth:`~maglev_ocp.controllers.model_file.ControllerModel.delay_periods`)
adds to ``delay_samples``, and its static effects (:class:`~maglev_ocp.controllers.model_file.ModelEffects`,
the effect library's laws) enter three places without letting the
measurement noise into the current:

* the inverse: the law's model must give the demanded acceleration with what
  the effects add at the commanded current (a fixed point of :data:`EFFECT_PASSES` passes),
  evaluated at the *planned* velocities (the reference row the law meets, N
  samples ahead with a delay), never at the estimate: a fitted friction sign
  (a diagnosis fixes ``tanh(v / 1 mm/s)``) on the observer's velocity, whose
  noise is 1.2 mm/s from 10 um readings, would switch the Coulomb and Stribeck
  force on the noise and rectify it into an offset (measured on the issue's
  rig at rest: d 7.9 um RMS against 1.4 um blind);
* the observer's prediction over the period, at its own estimate, with every
  regularized sign widened to three standard deviations of the velocity
  estimate's noise (:func:`~maglev_ocp.controllers.model_file.velocity_noise`,
  3.6 mm/s at the default 2 ms observer);
* the delay predictor: the effects' accelerations now (at the planned
  velocity) are held over the N predicted periods like the disturbance
  estimate (without them a commutation offset's thrust from the hover current
  went unpredicted and d rang at 15 um RMS at rest behind a one-period delay).

The compiled FL (:mod:`maglev_ocp.codegen.fl_fn`) carries the model file's
delay and its effects in the same three places, from the same expressions
(:func:`fl_model_effects`, :meth:`~maglev_ocp.controllers.model_file.ModelEffects.expr`).

Adaptive observer (``adapt``, default ``[C1, C3, C4]``, the NMPC's): a constant
acceleration disturbance cannot follow an error of a constant that multiplies
the currents (the rig's C1, C3, C4 are off their nominal values): it learns a
move's mismatch (2 % of a 50 m/s^2 thrust) and carries it into the hold, pushing
the mover past the target while it decays. The observer also estimates the
relative errors of those constants by recursive least squares on the encoder
innovation (:func:`maglev_ocp.observers.adapt_constants`, regressors from
``model.linear_split``), updated only while the reference moves and
``adapt_window`` after (a push while holding teaches nothing), bounded by
``adapt_bound``; the observer's prediction, the predictor and the inversion then
use the corrected constants (:func:`fl_adaptive_observer_function`, the same
Function in the compiled step).
"""

from __future__ import annotations

import functools
import math
from collections import deque

import casadi as ca
import numpy as np
from pydantic import Field, field_validator, model_validator

from maglev_ocp import constants as k
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.model import get_model, inverse_expressions
from maglev_ocp.observers import (
    AdaptSettings,
    HighGainObserver,
    ObserverSettings,
    adapt_constants,
    adapt_gate,
    adapt_shift,
    corrected_params,
    innovation_noise,
    noise_gate,
    observer_update_innovation,
)
from maglev_ocp.params import NOMINAL, Params
from maglev_ocp.signals import REF_FIELDS

from .model_file import (
    MODEL_SETTING_DESCRIPTION,
    SIGN_WIDTH_SIGMAS,
    UNTRUSTED_MODEL_DESCRIPTION,
    ModelEffects,
    UntrustedPolicy,
    check_model_path,
    check_model_trust,
    load_controller_model,
    velocity_noise,
)
from .preview import PlanPreview

#: Order of the gain / limit vector fed to :func:`fl_law_function`.
GAIN_FIELDS: tuple[str, ...] = ("kp_g", "kd_g", "ki_g", "kp_d", "kd_d", "ki_d", "i_axis_max", "i_amp_max", "Ts")
#: Order of the flag vector returned by :func:`fl_law_function`.
FLAG_FIELDS: tuple[str, ...] = ("unreachable", "sat_g", "sat_d")
#: Fixed-point passes of the inverse with a model file's effects at the commanded current (Python and
#: generated step alike): each pass shrinks the error by the effects' share of the current's gain, which a
#: fitted saturation makes large. Measured on the end_saturation rig (diagnosed saturation, 31 % loss at 8 mm;
#: tracking g / d along the plan, um): 2 passes 7.8 / 4.7, 3 passes 5.1 / 3.4, 4 passes 4.5 / 3.5, 6 passes
#: 4.6 / 3.5 (converged at 4; each pass costs one law evaluation).
EFFECT_PASSES: int = 4


def _sat(v: ca.SX, lim: ca.SX) -> ca.SX:
    return ca.fmin(ca.fmax(v, -lim), lim)


@functools.lru_cache(maxsize=1)
def fl_law_function() -> ca.Function:
    """The complete feedback-linearizing control law as one CasADi Function.

    ``fl_law(x_hat, dist, ref, z, p, gains) -> (u, z_next, v, flags)``

    Inputs: ``x_hat`` state estimate (4); ``dist`` acceleration disturbance
    estimate (2, gap then horizontal) [m/s^2]; ``ref`` in the order of
    :data:`REF_FIELDS`; ``z`` integrals of the position errors (2) [m s];
    ``p`` parameter vector; ``gains`` in the order of :data:`GAIN_FIELDS`.
    Outputs: ``u = (i_q, i_d)`` within the limits [A]; ``z_next``; ``v`` the
    demanded output accelerations [m/s^2]; ``flags`` in the order of
    :data:`FLAG_FIELDS` (0/1).
    """
    np_ = get_model().np_
    x, dist, ref, z = ca.SX.sym("x_hat", 4), ca.SX.sym("dist", 2), ca.SX.sym("ref", 6), ca.SX.sym("z", 2)
    p, gains = ca.SX.sym("p", np_), ca.SX.sym("gains", len(GAIN_FIELDS))
    G = dict(zip(GAIN_FIELDS, ca.vertsplit(gains), strict=True))
    R = dict(zip(REF_FIELDS, ca.vertsplit(ref), strict=True))
    e_g, e_gd = R["g"] - x[0], R["g_dot"] - x[1]
    e_d, e_dd = R["d"] - x[2], R["d_dot"] - x[3]
    # Outer loop on the double integrators y'' = v, with reference feedforward.
    v_g = R["g_ddot"] + G["kp_g"] * e_g + G["kd_g"] * e_gd + G["ki_g"] * z[0]
    v_d = R["d_ddot"] + G["kp_d"] * e_d + G["kd_d"] * e_dd + G["ki_d"] * z[1]
    # The model must produce v minus what the observer says the unmodelled part adds.
    a = ca.vertcat(v_g - dist[0], v_d - dist[1])
    i_amp, i_ax = G["i_amp_max"], G["i_axis_max"]
    iq0, _, _ = inverse_expressions(x, a, p)
    # Limits, vertical axis first (open-loop unstable): i_d gets what it needs up to the
    # amplitude, i_q the rest of the amplitude budget. i_q enters the vertical equation through
    # the reluctance term (C4 f4 i_q^2), so i_d is re-solved for the limited i_q; two passes from
    # i_q = 0 settle the split, and the last clip keeps the amplitude within bounds by construction.
    id_lim = ca.fmin(i_ax, i_amp)
    iq = _sat(iq0, i_ax)
    _, id2_raw, unr = inverse_expressions(x, a, p, i_q=ca.SX(0))
    for _ in range(2):
        iq = _sat(iq, ca.sqrt(ca.fmax(i_amp**2 - _sat(id2_raw, id_lim) ** 2, 0)))
        _, id2_raw, unr = inverse_expressions(x, a, p, i_q=iq)
    id2 = _sat(id2_raw, id_lim)
    iq2 = _sat(iq, ca.fmin(i_ax, ca.sqrt(ca.fmax(i_amp**2 - id2**2, 0))))
    tol = 1e-9
    # the gap axis is limited if its current was clipped or the demanded attraction is out of reach
    sat_g = ca.logic_or(ca.fabs(id2 - id2_raw) > tol, unr)
    sat_d = ca.fabs(iq2 - iq0) > tol + 1e-6 * ca.fabs(iq0)
    # Anti-windup: an axis integrates only while its current is not limited.
    z_next = ca.vertcat(
        z[0] + ca.if_else(sat_g, 0, G["Ts"] * e_g),
        z[1] + ca.if_else(sat_d, 0, G["Ts"] * e_d),
    )
    return ca.Function(
        "fl_law",
        [x, dist, ref, z, p, gains],
        [ca.vertcat(iq2, id2), z_next, ca.vertcat(v_g, v_d), ca.vertcat(unr, sat_g, sat_d)],
        ["x_hat", "dist", "ref", "z", "p", "gains"],
        ["u", "z_next", "v", "flags"],
    )


@functools.lru_cache(maxsize=16)
def fl_predictor_function(n: int, Ts: float = k.Ts) -> ca.Function:
    """The delay predictor: the state estimate ``n`` samples ahead, as one CasADi Function.

    ``fl_predict_<n>(x_hat, dist, u_seq, p) -> x_pred``

    ``x_hat`` is the observer's estimate now (4), ``dist`` its acceleration
    disturbance estimate (2) [m/s^2], ``u_seq`` the ``n`` currents already sent
    but not yet applied, oldest first, flattened ``(i_q, i_d)`` pairs (2 n) [A],
    ``p`` the parameter vector. Each sample is the shared model's RK4 step
    (``model.step(Ts, 1)``, the observer's own prediction) plus the constant
    disturbance acceleration integrated over the period (``dist Ts^2 / 2`` on
    the position, ``dist Ts`` on the velocity).
    """
    if n < 1:
        raise ValueError(f"the predictor needs n >= 1 samples, got {n}")
    m = get_model()
    step = m.step(Ts, 1)
    x, dist = ca.SX.sym("x_hat", 4), ca.SX.sym("dist", 2)
    useq, p = ca.SX.sym("u_seq", 2 * n), ca.SX.sym("p", m.np_)
    xk = x
    for j in range(n):
        xk = step(xk, useq[2 * j : 2 * j + 2], p)
        xk = xk + ca.vertcat(dist[0] * Ts**2 / 2, dist[0] * Ts, dist[1] * Ts**2 / 2, dist[1] * Ts)
    return ca.Function(
        f"fl_predict_{n}", [x, dist, useq, p], [xk], ["x_hat", "dist", "u_seq", "p"], ["x_pred"], {"cse": True}
    )


@functools.lru_cache(maxsize=16)
def fl_adaptive_observer_function(
    names: tuple[str, ...],
    L: tuple[float, ...],
    Ts: float,
    noise: float | None,
    bound: float,
    window: int,
    noise_time: float = 0.2,
    noise_floor: float = k.encoder_resolution / 12**0.5,
) -> ca.Function:
    """The FL's adaptive observer update as one CasADi Function (the NMPC's, :mod:`maglev_ocp.observers`).

    ``fl_adaptive_observer(x_hat, dist, u_prev, y, p, adapt, moving) -> (x_next, dist_next, adapt_next, p_hat)``

    The extended-state observer update (:func:`maglev_ocp.observers.observer_update_innovation`,
    a non-finite reading skipped) with the model's constants ``names`` corrected
    by their estimated relative errors ``theta``, which are learnt from the
    innovation while the reference moves and ``window`` periods after
    (:func:`maglev_ocp.observers.adapt_gate`, :func:`maglev_ocp.observers.adapt_constants`).
    ``adapt`` is the adaptation's memory (:func:`fl_adapt_state`: ``theta``,
    ``ups``, ``cov``, ``since``, ``age``, ``noise``); ``moving`` 1 while the reference moves;
    the innovation's variance the update weighs is ``noise^2``, or measured online
    (``noise`` None, :func:`maglev_ocp.observers.innovation_noise`, as the NMPC's);
    ``p_hat`` the corrected parameter vector with the new ``theta``, which the
    law inverts (seed ref. [3]) and the predictor integrates.
    """
    n = len(names)
    np_ = get_model().np_
    x, dist, u, y = ca.SX.sym("x_hat", 4), ca.SX.sym("dist", 2), ca.SX.sym("u_prev", 2), ca.SX.sym("y", 2)
    p, ad, moving = ca.SX.sym("p", np_), ca.SX.sym("adapt", 7 * n + n * n + 4), ca.SX.sym("moving")
    theta, ups, cov = ad[:n], ad[n : 7 * n], ad[7 * n : 7 * n + n * n]
    since, age, msq = ad[7 * n + n * n], ad[7 * n + n * n + 1], ad[7 * n + n * n + 2 :]
    p_obs = corrected_params(p, theta, names)
    xo, do, e = observer_update_innovation(x, dist, u, y, p_obs, L, Ts, disturbance=True, skip_nonfinite=True)
    ok, since, age = adapt_gate(since, age, moving > 0.5, ca.SX(0), window)
    # the innovation's noise, measured past the start-up while the constants are not updated (a finite reading)
    measure = noise_gate(ok, age, ca.SX(0), y, window)
    r2, msq = innovation_noise(msq, age, e, measure, noise, window, Ts, noise_time, noise_floor)
    dtheta, ups_plus, theta, cov = adapt_constants(x, u, p, ups, theta, cov, e, ok, names, L, Ts, r2, bound)
    dx, dd = adapt_shift(ups_plus, dtheta)  # the estimate moves with the constants: eps = eta + Ups theta_err
    ad_next = ca.vertcat(theta, ca.vec(ups_plus), cov, since, age, msq)
    return ca.Function(
        "fl_adaptive_observer",
        [x, dist, u, y, p, ad, moving],
        [xo + dx, do + dd, ad_next, corrected_params(p, theta, names)],
        ["x_hat", "dist", "u_prev", "y", "p", "adapt", "moving"],
        ["x_next", "dist_next", "adapt_next", "p_hat"],
        {"cse": True},
    )


def fl_adapted(settings: FLSettings) -> tuple[str, ...]:
    """The constants the FL's observer adapts (none without the disturbance estimate it works with)."""
    return tuple(settings.adapt) if settings.disturbance else ()


def fl_adapt_state(settings: FLSettings) -> np.ndarray:
    """The adaptation's memory at reset: ``theta = 0``, ``ups = 0``, ``cov = adapt_prior^2 I``, ``since``, ``age``,
    ``noise`` (the innovation's mean square per axis, from the floor or the fixed value)."""
    n = len(fl_adapted(settings))
    r2 = (settings.adapt_noise or settings.adapt_noise_floor) ** 2
    return np.concatenate([np.zeros(7 * n), np.ravel(np.eye(n) * settings.adapt_prior**2), [1e6, 0.0, r2, r2]])


def fl_adaptive_observer(settings: FLSettings, L, Ts: float = k.Ts) -> ca.Function | None:
    """:func:`fl_adaptive_observer_function` for ``settings`` and observer gain ``L`` (None without ``adapt``)."""
    names = fl_adapted(settings)
    if not names:
        return None
    window = round(settings.adapt_window / Ts)
    return fl_adaptive_observer_function(
        names,
        tuple(float(v) for v in L),
        Ts,
        settings.adapt_noise,
        settings.adapt_bound,
        window,
        settings.adapt_noise_time,
        settings.adapt_noise_floor,
    )


def ref_moving(r):
    """1 while the reference row ``r`` (order of :data:`REF_FIELDS`) moves: a rate or acceleration is not 0.

    Numeric rows give a bool, symbolic (SX) rows an expression (the compiled FL's step).
    """
    R = dict(zip(REF_FIELDS, (r[i] for i in range(len(REF_FIELDS))), strict=True))
    return abs(R["g_dot"]) + abs(R["g_ddot"]) + abs(R["d_dot"]) + abs(R["d_ddot"]) > 0


class FLSettings(AdaptSettings):
    """Tuning of :class:`FeedbackLinearization` (the scenario's ``controller:`` block for ``type: fl``).

    Attributes
    ----------
    omega_g, omega_d : float
        Closed-loop bandwidth of the gap and horizontal loops [rad/s]: with
        ``integral: false`` both poles at ``-omega`` (damping ``zeta``), with
        ``integral: true`` a triple pole at ``-omega``. Keep them well below
        the observer's ``1/eps`` and the 1 kHz sampling rate.
    zeta : float
        Damping ratio of the PD loops.
    integral : bool
        Add integral action (on top of the observer's disturbance estimate).
    observer_eps : float
        Time constant of the high-gain observer's error poles [s].
    disturbance : bool
        Estimate and cancel a constant acceleration disturbance per axis
        (offset-free tracking).
    i_axis_max, i_amp_max : float
        Current limits the law respects [A] (at most the amplifier's 8 A).
    delay_samples : int
        The loop's computation delay the controller compensates [control
        periods]: the current computed at sample k is applied at k + N. Set it
        to the rig's delay (``plant.delay_samples`` plus the amplifier's
        transport delay in a scenario); 0 = no predictor.
    model : str or None
        A model file (:mod:`maglev_ocp.controllers.model_file`: constants plus fitted
        effects, the plant profiles' ``effects:`` format). Its constants replace
        the controller's parameters; its static effects enter the observer's
        prediction, the delay predictor and the inversion, at the planned
        velocity in the inversion and with the velocity signs smoothed to the
        estimate's resolution in the observer (module docstring); an amplifier
        lag's transport delay and time constant (whole periods) add to ``delay_samples``.
    adapt : list of str
        Constants (of C1..C4) whose relative error the observer estimates from
        the moves (see the module docstring); ``[]`` turns it off, and it is
        off without ``disturbance``.
    adapt_prior, adapt_noise, adapt_noise_floor, adapt_noise_time, adapt_window, adapt_bound : float
        Prior standard deviation of the relative errors, the innovation's
        standard deviation [m], how long after a move they are still updated [s],
        and their bound.
    """

    omega_g: float = Field(120.0, gt=0, le=400)
    omega_d: float = Field(120.0, gt=0, le=400)
    zeta: float = Field(1.0, gt=0, le=5)
    integral: bool = False
    observer_eps: float = Field(2e-3, gt=0, le=0.1)
    disturbance: bool = True
    i_axis_max: float = Field(k.i_axis_max, gt=0, le=k.i_axis_max)
    i_amp_max: float = Field(k.i_amp_max, gt=0, le=k.i_amp_max)
    delay_samples: int = Field(
        0, ge=0, le=10, description="computation delay compensated by the predictor [control periods]"
    )
    model: str | None = Field(None, description=MODEL_SETTING_DESCRIPTION)
    untrusted_model: UntrustedPolicy = Field("refuse", description=UNTRUSTED_MODEL_DESCRIPTION)
    adapt_noise: float | None = Field(
        4e-6,
        gt=0,
        description="standard deviation of the encoder innovation the constants' estimate assumes [m]: a 10 um "
        "quantization (10 / sqrt(12) = 2.9 um) and 2 um encoder noise give 3.5 um on the default rig (None: "
        "measured online as the NMPC does, the running RMS of the innovation per axis while the constants are "
        "not updated, never below adapt_noise_floor; on the default rig it gives the same tours within 0.3 um "
        "but a 46 um tracking error in the first move, where the estimate, weighed against the quieter "
        "measured noise, swings further)",
    )

    @field_validator("model")
    @classmethod
    def _model_exists(cls, v: str | None) -> str | None:
        return check_model_path(v)

    @model_validator(mode="after")
    def _model_trusted(self) -> FLSettings:
        check_model_trust(self.model, self.untrusted_model)
        return self

    def gains(self, Ts: float = k.Ts) -> np.ndarray:
        """Gain / limit vector in the order of :data:`GAIN_FIELDS`."""
        out = []
        for w in (self.omega_g, self.omega_d):
            if self.integral:  # (s + w)^3
                out += [3 * w**2, 3 * w, w**3]
            else:  # s^2 + 2 zeta w s + w^2
                out += [w**2, 2 * self.zeta * w, 0.0]
        return np.array([*out, self.i_axis_max, self.i_amp_max, Ts], dtype=float)


def law_stats(flags, v, dist, law_failed: bool, fallback: int) -> dict[str, float | int]:
    """The statistics an FL step reports (flags of :data:`FLAG_FIELDS`, demanded accelerations,
    disturbance estimate, whether the law failed and whether a safe current was held instead)."""
    return {
        "unreachable": int(flags[0]),
        "sat_g": int(flags[1]),
        "sat_d": int(flags[2]),
        "v_g": float(v[0]),
        "v_d": float(v[1]),
        "dist_g": float(dist[0]),
        "dist_d": float(dist[1]),
        "solver_failure": int(law_failed),
        "fallback": int(fallback),
    }


def fl_model_effects(model, p: np.ndarray, L: np.ndarray, Ts: float = k.Ts) -> ModelEffects | None:
    """The model file's static effects as the FL evaluates them (None without a model file or effects).

    ``model`` is the loaded model file (or None), ``p`` the parameter vector the effects are
    evaluated with, ``L`` the observer's gain: every regularized velocity sign is widened to
    :data:`~maglev_ocp.controllers.model_file.SIGN_WIDTH_SIGMAS` standard deviations of the
    observer's velocity noise (see the module docstring). The Python step and the generated
    step (:mod:`maglev_ocp.codegen.fl_fn`) both take their effects from here.
    """
    if model is None or not model.effects:
        return None
    return ModelEffects(model, p, SIGN_WIDTH_SIGMAS * velocity_noise(L, Ts))


def fl_delay_samples(settings: FLSettings, model=None, Ts: float = k.Ts) -> int:
    """The delay the FL predicts through [control periods]: ``settings.delay_samples`` plus the model file's.

    ``model`` is the loaded model file of ``settings.model`` if the caller has it
    (else it is loaded here); its amplifier lag's transport delay and its time constant
    rounded to whole periods (:meth:`~maglev_ocp.controllers.model_file.ControllerModel.delay_periods`)
    add to the setting.
    """
    if model is None and settings.model:
        model = load_controller_model(settings.model)
    return int(settings.delay_samples) + (model.delay_periods(Ts) if model is not None else 0)


class FeedbackLinearization:
    """Feedback-linearizing controller with a high-gain (extended-state) observer.

    Parameters
    ----------
    settings : FLSettings
        Tuning.
    params : Params
        What the controller's model believes (e.g. ``params.without_cogging()``
        for a cogging-blind controller).
    Ts : float
        Control period [s].

    Notes
    -----
    The feedforward is ``ref.g_ddot`` / ``ref.d_ddot`` as handed in; the runner
    gives the reference's mean acceleration over the coming period
    (:meth:`maglev_ocp.reference.ReferencePlan.sample` with ``zoh``), the
    acceleration a zero-order-held current can actually deliver.

    ``stats`` of each step: ``unreachable`` (demanded attraction out of reach,
    clipped), ``sat_g``/``sat_d`` (current limits active), ``v_g``/``v_d``
    (demanded accelerations), ``dist_g``/``dist_d`` (disturbance estimates),
    and ``solver_failure`` / ``fallback`` (0 normally; see :meth:`step` for when they are 1).
    """

    name = "fl"

    def __init__(self, settings: FLSettings | None = None, params: Params = NOMINAL, Ts: float = k.Ts):
        self.settings = settings or FLSettings()
        self.model = load_controller_model(self.settings.model) if self.settings.model else None
        if self.model is not None:
            params = self.model.params
        self.params = params
        self.Ts = Ts
        self._p = params.vector()
        self._gains = self.settings.gains(Ts)
        self._law = BufferedFunction(fl_law_function())
        self.observer = HighGainObserver(
            params, ObserverSettings(eps=self.settings.observer_eps, disturbance=self.settings.disturbance), Ts
        )
        # the model file's static effects (None: none), their velocity signs widened to the resolution of the
        # observer's velocity estimate (see the module docstring)
        self.effects = fl_model_effects(self.model, self._p, self.observer.L, Ts)
        # adaptive observer (settings.adapt): the constants' relative errors, learnt from the moves
        self._adapt_fn = fl_adaptive_observer(self.settings, self.observer.L, Ts)
        self._adapt_fn = BufferedFunction(self._adapt_fn) if self._adapt_fn is not None else None
        self._ad = fl_adapt_state(self.settings)
        self._p_hat = self._p  # the parameters the law inverts: p with the adapted constants corrected
        self._z = np.zeros(2)
        self._u_prev = np.zeros(2)
        self._u_good: np.ndarray | None = None  # last finite command of the law
        self._x0 = (0.020, 0.0)  # reading at reset (where the hover fallback is taken before any estimate)
        self._started = False
        self.delay = fl_delay_samples(self.settings, self.model, Ts)
        self._pred = BufferedFunction(fl_predictor_function(self.delay, Ts)) if self.delay else None
        # commands sent, oldest first: [0] is the one applied over the last period, [1:] are still on their way
        self._sent: deque[np.ndarray] = deque([np.zeros(2)] * (self.delay + 1), maxlen=self.delay + 1)
        self._preview: PlanPreview | None = None  # the reference plan read N samples ahead (set_reference_plan)

    def set_reference_plan(self, plan) -> None:
        """Let the predictor read the reference ``delay_samples`` ahead (a :class:`maglev_ocp.reference.ReferencePlan`).

        Only used with ``delay_samples > 0``; ``None`` forgets the plan. The plan is sampled now, not inside a
        timed step (:class:`~maglev_ocp.controllers.preview.PlanPreview`).
        """
        self._preview = PlanPreview(plan, self.delay, self.Ts) if plan is not None and self.delay else None

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start a run at reading ``y0`` (mover assumed at rest); clear integrators."""
        self.observer.reset(np.asarray(y0.y, dtype=float))
        self._ad = fl_adapt_state(self.settings)
        self._p_hat = self._p
        self._z = np.zeros(2)
        self._u_prev = np.zeros(2)
        self._u_good = None
        self._x0 = (float(y0.y[0]), float(y0.y[1]))
        self._started = False
        # before the run the amplifiers carried the hover current (the mover is assumed hovering at rest)
        u_hover = np.asarray(get_model().u_eq(self._x0[0], self._x0[1], self._p), dtype=float).ravel()
        u_hover = u_hover if np.all(np.isfinite(u_hover)) else np.zeros(2)
        self._sent = deque([u_hover.copy() for _ in range(self.delay + 1)], maxlen=self.delay + 1)

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """Observer update with the current applied over the last period, predictor, then the control law.

        With ``delay_samples = N > 0`` the law runs on the estimate predicted
        N samples ahead (see the module docstring) against the plan's reference
        N samples ahead if a plan was given, else ``ref``; the returned
        ``x_hat`` is the estimate now.

        Never commands a non-finite current: a non-finite reading is skipped
        (the observer predicts only), and if the law still returns a non-finite
        current the controller holds a safe one (:meth:`_safe_current`) and keeps
        its integrators. Either case sets ``fallback = 1`` in ``stats`` (a failed
        law also ``solver_failure = 1``), which the run's metrics count.
        """
        fallback = 0
        r = (ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot)
        if self._pred is not None and self._preview is not None:  # the reference when the command computed now acts
            r = self._preview.at(y.t)
        if not self._started:
            x_hat = self.observer.x_hat.copy()
            self._started = True
        else:
            # the current applied over the last period: the last command, or the one sent N samples before it
            u_applied = self._u_prev if not self.delay else self._sent[0]
            # the effects the model file knows are part of the observer's prediction over the period
            # (at its own velocity estimate: the widened sign keeps the estimate's noise out of the prediction)
            d_eff = self._effect(self.observer.x_hat, u_applied)
            self.observer.dist += d_eff
            finite = math.isfinite(y.y[0]) and math.isfinite(y.y[1])
            if self._adapt_fn is not None:  # a non-finite reading is skipped inside (prediction only)
                x_hat, dist, self._ad, self._p_hat = self._adapt_fn(
                    self.observer.x_hat, self.observer.dist, u_applied, y.y, self._p, self._ad, float(ref_moving(r))
                )
                self.observer.x_hat, self.observer.dist = x_hat.copy(), dist.copy()
            elif finite:
                x_hat = self.observer.step(y.y, u_applied)
            else:  # a reading that cannot be used: prediction only (as the NMPC's observer does)
                x_hat = self.observer.predict(u_applied)
                self.observer.x_hat = x_hat.copy()
            fallback = int(not finite)
            self.observer.dist -= d_eff  # what is left is the residual disturbance
        dist = self.observer.disturbance
        x_law, p = x_hat, self._p_hat
        v_plan = (r[1], r[4])  # the planned velocities (N samples ahead with a delay): what the effects see
        if self._pred is not None:
            u_seq = np.concatenate(list(self._sent)[1:])
            # over the periods predicted through, the effects act as they do now (held, as the disturbance)
            d_pred = dist + self._effect(x_hat, self._sent[-1], v_plan)
            (x_law,) = self._pred(x_hat, d_pred, u_seq, p)
        u, z_next, v, fl = self._law(x_law, dist, r, self._z, p, self._gains)
        if self.effects is not None:
            # invert the model with the effects: the law's model must give v minus the residual disturbance
            # minus what the effects add at the current it commands (fixed point, exact for state-only effects);
            # at the planned velocity, so that the velocity estimate's noise does not reach the current
            for _ in range(EFFECT_PASSES):
                if not np.all(np.isfinite(u)):
                    break
                u, z_next, v, fl = self._law(x_law, dist + self._effect(x_law, u, v_plan), r, self._z, p, self._gains)
        law_failed = not (math.isfinite(u[0]) and math.isfinite(u[1]))
        if law_failed:
            u, fallback = self._safe_current(x_hat), 1
        else:
            self._z = z_next
            self._u_good = u
        self._u_prev = u
        if self.delay:
            self._sent.append(np.asarray(u, dtype=float).copy())
        stats = law_stats(fl, v, dist, law_failed, fallback)
        return ControlOutput(u=u, x_hat=x_hat, stats=stats)

    @property
    def adapted_constants(self) -> dict[str, float]:
        """The adaptive observer's estimate of each adapted constant's relative error (empty without ``adapt``)."""
        names = fl_adapted(self.settings) if self._adapt_fn is not None else ()
        return {n: float(self._ad[j]) for j, n in enumerate(names)}

    def _effect(self, x: np.ndarray, u: np.ndarray, velocity: tuple[float, float] | None = None) -> np.ndarray:
        """Accelerations the model file's effects add at state ``x`` and currents ``u`` (zeros without effects).

        ``velocity`` replaces the state's velocities (:class:`~maglev_ocp.controllers.model_file.ModelEffects`).
        """
        if self.effects is None:
            return np.zeros(2)
        return self.effects(x, u, velocity)

    def _safe_current(self, x_hat: np.ndarray) -> np.ndarray:
        """Current to hold when the law has none: the last good command, else the hover current at ``x_hat``.

        The hover current (seed eq. (8) with cogging, ``model.u_eq``) is taken at
        the state estimate if it is finite, else at the reading the run started
        from; it is clipped to the settings' limits, the gap axis first.

        Raises
        ------
        ValueError
            If neither a good command nor a finite hover current exists (the
            controller's parameters cannot hover here).
        """
        if self._u_good is not None:
            return np.array(self._u_good, dtype=float)
        g, d = (float(x_hat[0]), float(x_hat[2])) if np.all(np.isfinite(x_hat)) else self._x0
        u = np.asarray(get_model().u_eq(g, d, self._p), dtype=float).ravel()
        if not np.all(np.isfinite(u)):
            raise ValueError(f"fl: no finite current to hold at g = {g * 1e3:.2f} mm, d = {d * 1e3:.2f} mm")
        s = self.settings
        id_lim = min(s.i_axis_max, s.i_amp_max)  # vertical axis first, as in the law
        i_d = min(max(u[1], -id_lim), id_lim)
        i_q_lim = min(s.i_axis_max, math.sqrt(max(s.i_amp_max**2 - i_d**2, 0.0)))
        return np.array([min(max(u[0], -i_q_lim), i_q_lim), i_d])


__all__ = [
    "EFFECT_PASSES",
    "FLAG_FIELDS",
    "GAIN_FIELDS",
    "FLSettings",
    "FeedbackLinearization",
    "fl_adapt_state",
    "fl_adapted",
    "fl_adaptive_observer",
    "fl_adaptive_observer_function",
    "fl_delay_samples",
    "fl_law_function",
    "fl_model_effects",
    "fl_predictor_function",
    "law_stats",
    "ref_moving",
]
