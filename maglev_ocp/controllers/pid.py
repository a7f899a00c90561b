"""The seed's PID regulators (section IV): two independent loops, enough to produce data.

The seed keeps the stage levitated during its identification experiments with
"two PID regulators for the control inputs i_d and i_q to independently make
the horizontal and vertical dynamics track a suitable reference signal made of
a summation of sinusoids", and notes that, the axes being coupled, this "does
not yield good tracking performance" (footnote 2). This module is that pair:

* gap loop: ``i_d = i_d,eq(g_ref, d_ref) + PID(g_ref - g)``, the equilibrium
  current from the shared model (``model.u_eq``, seed eq. (8) with cogging);
* horizontal loop: ``i_q = i_q,eq(g_ref, d_ref) + PID(d_ref - d)``.

The derivative acts on the velocity from the :class:`~maglev_ocp.observers.HighGainObserver`
(a finite difference of 10 um readings is far too noisy). Gains are scheduled
on the reference gap from the model's linearization at hover, placing each
loop's three closed-loop poles at ``-omega`` (``(s + omega)^3``), which keeps
the unstable vertical pole (about +39 rad/s at 20 mm, +64 rad/s at 10 mm)
stabilized anywhere in the stroke. Anti-windup by conditional integration;
the output is clipped to ±8 A per axis and 8 A amplitude, the gap loop first.

A model file (``model: FILE``, :mod:`maglev_ocp.controllers.model_file`, e.g.
the ``model.yaml`` of ``maglev diagnose``): its constants replace the
controller's parameters (equilibrium currents, schedule, observer), and its
static effects enter the feed-forward only: the feed-forward current is
corrected, through the scheduled gains, by what the effects add at the
*planned* state, at the velocity the loops demand (the planned velocity plus
each loop's bandwidth times its position error, :func:`demanded_row`, so a
mover stopped off target inside the friction band gets the fitted friction's
compensation in the direction its loop pushes), with the velocity signs widened
to the observer's velocity resolution as FL's
(:meth:`PIDController.effect_feedforward`); no velocity estimate passes through
the fitted laws (the loops themselves stay linear). The PID has no predictor, but a model file's delay
(its amplifier lag's ``delay_samples``, :func:`pid_lead_samples`) is met by
the feed-forward: given the run's plan (:meth:`PIDController.set_reference_plan`),
the equilibrium current, the reference accelerations and the effects'
correction are taken from the plan that many periods ahead, when the command
computed now acts (:mod:`maglev_ocp.controllers.preview`); the feedback still
compares the estimate with the reference now.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import casadi as ca
import numpy as np
from pydantic import Field, field_validator, model_validator

from maglev_ocp import constants as k
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.config import Strict
from maglev_ocp.errors import ConfigError
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.model import get_model, inverse_expressions
from maglev_ocp.observers import HighGainObserver, ObserverSettings
from maglev_ocp.params import NOMINAL, Params

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


class PIDSettings(Strict):
    """Tuning of :class:`PIDController`.

    Attributes
    ----------
    omega_g, omega_d : float
        Closed-loop pole of the gap / horizontal loop [rad/s] (triple pole at ``-omega``).
    integral : bool
        Use the integral terms (offset-free hover despite parameter errors).
    integral_limit : float
        Bound on each integral term's contribution to the current [A].
    control_g, control_d : bool
        Close the gap / horizontal loop. An open axis gets its fixed current
        (use with a locked axis: the seed sets ``u1 = 0`` with d locked).
    i_q_fixed : float
        ``i_q`` when the horizontal loop is open [A].
    i_d_fixed : float or None
        ``i_d`` when the gap loop is open [A]; None: the equilibrium current.
    feedforward : bool
        Add the feed-forward current of the plan (see ``feedforward_law``).
    feedforward_law : {"linear", "inverse"}
        ``linear`` (default, the seed's regulators, which excite the calibration and diagnosis
        experiments): the equilibrium currents plus the planned accelerations through the gains
        linearized at hover; ``inverse``: the currents the model's inverse gives for the planned
        state, velocity and acceleration (:func:`inverse_feedforward_function`).
    observer_eps : float
        Time constant of the high-gain observer [s].
    i_axis_max, i_amp_max : float
        Current limits [A] (per axis, amplitude).
    model : str or None
        A model file (constants plus fitted effects, :mod:`maglev_ocp.controllers.model_file`):
        its constants replace the controller's parameters, its static effects
        correct the feed-forward at the planned state (see the module docstring).
    """

    omega_g: float = Field(80.0, gt=0, le=2000)
    omega_d: float = Field(25.0, gt=0, le=2000)
    integral: bool = True
    integral_limit: float = Field(3.0, ge=0, le=20)
    control_g: bool = True
    control_d: bool = True
    i_q_fixed: float = Field(0.0, ge=-20, le=20)
    i_d_fixed: float | None = Field(None, ge=-20, le=20)
    feedforward: bool = True
    feedforward_law: Literal["linear", "inverse"] = Field(
        "linear",
        description="how the feed-forward current is computed from the plan: linear (default, the seed's "
        "regulators: the equilibrium current plus the planned accelerations through the gains linearized at "
        "hover; the calibration and diagnosis experiments are excited with it) or inverse (the model's exact "
        "inverse, seed eq. (2), at the planned state and acceleration: the thrust current's pull on the gap, "
        "C4 f4 i_q^2, and the field's nonlinearity included; far closer tracking, recommended with a model file)",
    )
    observer_eps: float = Field(4e-3, gt=1e-4, le=1.0)
    i_axis_max: float = Field(k.i_axis_max, gt=0, le=100)
    i_amp_max: float = Field(k.i_amp_max, gt=0, le=100)
    model: str | None = Field(None, description=MODEL_SETTING_DESCRIPTION)
    untrusted_model: UntrustedPolicy = Field("refuse", description=UNTRUSTED_MODEL_DESCRIPTION)

    @field_validator("model")
    @classmethod
    def _model_exists(cls, v: str | None) -> str | None:
        return check_model_path(v)

    @model_validator(mode="after")
    def _model_trusted(self) -> PIDSettings:
        check_model_trust(self.model, self.untrusted_model)
        return self


def schedule_function() -> ca.Function:
    """``(g, d, p) -> (u_eq, b_v, a21, L1)`` from the shared model's Functions (not retyped)."""
    m = get_model()
    g, d = ca.SX.sym("g"), ca.SX.sym("d")
    p = m.p
    u_eq = m.u_eq(g, d, p)
    u0 = m.u_eq(g, 0, p)  # linearize at the d = 0 hover, where cogging vanishes
    A, B = m.linearization(ca.vertcat(g, 0, 0, 0), u0, p)
    return ca.Function(
        "pid_schedule", [g, d, p], [u_eq, B[1, 1], A[1, 0], -B[3, 0]], ["g", "d", "p"], ["u_eq", "b_v", "a21", "L1"]
    )


def inverse_feedforward_function() -> ca.Function:
    """``(ref, p) -> u_ff``: the currents the model's inverse gives for a planned reference row [A].

    ``ref`` in the order of :data:`maglev_ocp.signals.REF_FIELDS`; the shared model's inverse
    (:func:`maglev_ocp.model.inverse_expressions`, seed eq. (2) solved for the currents, not retyped)
    at the planned state ``(g, g_dot, d, d_dot)`` for the planned accelerations ``(g_ddot, d_ddot)``.
    Unlike the linearized feed-forward it carries the thrust current's pull on the gap
    (``C4 f4 i_q^2``): measured on a noiseless rig without effects (the diagnosed_vs_blind tour), the
    linearized one leaves the PID 36 / 20 um (g / d) off the plan and 22 um RMS in the holds' tails,
    this one 1.1 / 3.4 um and 2.1 um.
    """
    ref, p = ca.SX.sym("ref", 6), ca.SX.sym("p", get_model().np_)
    x = ca.vertcat(ref[0], ref[1], ref[3], ref[4])
    iq, id_, _ = inverse_expressions(x, ca.vertcat(ref[2], ref[5]), p)
    return ca.Function("pid_inverse_ff", [ref, p], [ca.vertcat(iq, id_)], ["ref", "p"], ["u_ff"])


def inverse_feedforward(ops: _Ops, s: PIDSettings, u_ff, u_eq, r_ff) -> tuple[tuple[Any, Any], tuple]:
    """The feed-forward current and row the law takes (numeric or symbolic, as :func:`pid_law`).

    With ``feedforward_law: inverse`` and a finite inverse ``u_ff`` (:func:`inverse_feedforward_function`)
    the feed-forward current is ``u_ff`` and the row's accelerations are zero (they are in ``u_ff``); else
    the equilibrium current ``u_eq`` and the planned row ``r_ff`` (the law adds the accelerations through
    its linearized gains). Returns ``((i_q, i_d), row)``.
    """
    if s.feedforward_law != "inverse":
        return (u_eq[0], u_eq[1]), tuple(r_ff)
    ok = ops.finite(u_ff[0], u_ff[1])
    row = (r_ff[0], r_ff[1], ops.where(ok, 0.0, r_ff[2]), r_ff[3], r_ff[4], ops.where(ok, 0.0, r_ff[5]))
    return (ops.where(ok, u_ff[0], u_eq[0]), ops.where(ok, u_ff[1], u_eq[1])), row


def pid_lead_samples(settings: PIDSettings, model=None, Ts: float = k.Ts) -> float:
    """How far ahead the PID's feed-forward reads the plan [control periods]: the model file's delay.

    The amplifier lag's transport delay plus its first-order part's time constant (below its
    bandwidth a lag delays a signal by about that much), in control periods. ``model`` is the
    loaded model file of ``settings.model`` if the caller has it (else it is loaded here). Zero
    without a model file, without a declared lag, or with ``feedforward`` off.
    """
    if not settings.feedforward or not settings.model:
        return 0.0
    model = model if model is not None else load_controller_model(settings.model)
    return float(model.delay_samples) + float(model.lag_time_s) / Ts


def pid_model_effects(settings: PIDSettings, model, p: np.ndarray, L: np.ndarray) -> ModelEffects | None:
    """The model file's static effects as the PID's feed-forward evaluates them (None: no correction).

    Only with ``feedforward`` on and a model file with effects. They are evaluated at the planned
    state with the velocity the loops demand (:func:`demanded_row`), which holds the position
    estimate; every regularized velocity sign is widened to
    :data:`~maglev_ocp.controllers.model_file.SIGN_WIDTH_SIGMAS` standard deviations of the
    velocity estimate of the PID's observer (gain ``L``), as FL's. The Python step and the
    generated step (:mod:`maglev_ocp.codegen.pid_fn`) both take them from here.
    """
    if model is None or not model.effects or not settings.feedforward:
        return None
    return ModelEffects(model, p, SIGN_WIDTH_SIGMAS * velocity_noise(L))


def demanded_row(s: PIDSettings, r_ff, r, x_hat) -> tuple:
    """The row the effects' feed-forward is evaluated at: ``r_ff`` with each velocity plus what its loop demands.

    The planned velocity plus ``omega`` times the position error (``r - x_hat``): the velocity the loop's
    bandwidth asks to close the error. At rest on the plan it is the planned velocity (0); held off the
    target by Coulomb friction (the mover stuck inside the friction band, where the PD's force at the
    slow loop's gain is below the friction level and only the integrator would break it away, in about
    0.5 s) it points the fitted friction's compensation the way the loop pushes. The position error is
    an estimate, but through a gain of ``omega`` (25-80 rad/s), not a derivative: 10 um readings move it
    by about 0.1 mm/s, below the sign's width. Measured on the foreign rig with a hand-made lag file
    and on lag_lugre: PID steady RMS 43 -> 25 um and 40 -> 25 um. Numeric or symbolic.
    """
    return (
        r_ff[0],
        r_ff[1] + s.omega_g * (r[0] - x_hat[0]),
        r_ff[2],
        r_ff[3],
        r_ff[4] + s.omega_d * (r[3] - x_hat[2]),
        r_ff[5],
    )


def effect_correction(effect: Callable[[Any, Any], Any], r, u_eq, b_v, L1) -> tuple[Any, Any]:
    """Feed-forward correction ``(di_q, di_d)`` [A] for the effects (numeric or symbolic, as :func:`pid_law`).

    ``effect(x, u)`` gives the effects' accelerations ``(da_g, da_d)`` [m/s^2] at a state and
    currents (:class:`~maglev_ocp.controllers.model_file.ModelEffects` or its
    :meth:`~maglev_ocp.controllers.model_file.ModelEffects.expr`); they are taken at the planned
    state ``(g, g_dot, d, d_dot)`` of the reference row ``r`` and the feed-forward current (the
    equilibrium current ``u_eq`` plus the reference accelerations through the scheduled gains,
    as :func:`pid_law` adds them) and cancelled through those gains: ``di_d = -da_g / b_v``
    (``b_v = d g_ddot / d i_d``) and ``di_q = da_d / L1`` (``d_ddot = -L1 i_q``); two
    fixed-point passes for effects that depend on the current (a commutation offset). The caller
    applies it only where ``u_eq`` is finite and ``b_v``, ``L1`` are not zero.
    """
    x_ref = (r[0], r[1], r[3], r[4])
    u_ff = (u_eq[0] + -r[5] / L1, u_eq[1] + r[2] / b_v)
    du = (0.0, 0.0)
    for _ in range(2):
        da = effect(x_ref, (u_ff[0] + du[0], u_ff[1] + du[1]))
        du = (da[1] / L1, -da[0] / b_v)
    return du


def hover_error(g: float, d: float) -> ConfigError:
    """The error of a reset where the controller's model has no hover current (0 A would drop the mover)."""
    return ConfigError(
        f"pid: the controller's model has no hover current at g = {g * 1e3:.2f} mm, "
        f"d = {d * 1e3:.2f} mm (seed eq. (8) has no real root); check controller_params"
    )


class PIDController:
    """The seed's two PID regulators, as a :class:`~maglev_ocp.blocks.Controller`.

    Parameters
    ----------
    params : Params
        Model parameters (nominal or calibrated) for the equilibrium currents,
        the gain schedule and the observer.
    settings : PIDSettings
        Tuning.
    Ts : float
        Control period [s].

    Examples
    --------
    >>> ctrl = PIDController(NOMINAL)
    >>> y = plant.reset(); ctrl.reset(y, Reference(g=0.02, d=0.0))
    >>> for _ in range(1000):
    ...     y = plant.step(ctrl.step(y, Reference(g=0.02, d=0.0)).u)
    """

    name = "pid"

    def __init__(self, params: Params = NOMINAL, settings: PIDSettings | None = None, Ts: float = k.Ts):
        self.settings = settings or PIDSettings()
        self.model = load_controller_model(self.settings.model) if self.settings.model else None
        if self.model is not None:
            params = self.model.params
        self.params = params
        self.Ts = float(Ts)
        self.observer = HighGainObserver(params, ObserverSettings(eps=self.settings.observer_eps), self.Ts)
        # the model file's static effects, evaluated at the planned state only (no estimate: no sign to smooth
        # against noise, the library's regularization is kept)
        self.effects = pid_model_effects(self.settings, self.model, params.vector(), self.observer.L)
        self._sched = schedule_function()
        self._inverse = BufferedFunction(inverse_feedforward_function())
        # buffer evaluation: ~5 us instead of ~100 us for a numpy call
        self._in_p = params.vector()
        self._out = [np.zeros(2), np.zeros(1), np.zeros(1), np.zeros(1)]
        self._buf, self._eval = self._sched.buffer()
        self._g_in, self._d_in = np.zeros(1), np.zeros(1)
        self._buf.set_arg(0, memoryview(self._g_in))
        self._buf.set_arg(1, memoryview(self._d_in))
        self._buf.set_arg(2, memoryview(self._in_p))
        for i, a in enumerate(self._out):
            self._buf.set_res(i, memoryview(a))
        self.lead = pid_lead_samples(self.settings, self.model, self.Ts)
        self._preview: PlanPreview | None = None  # the plan read `lead` periods ahead (set_reference_plan)
        self._int = np.zeros(2)  # integral of the position errors (g, d) [m s]
        self._u_prev = np.zeros(2)
        self._ueq_good = (0.0, 0.0)  # last finite hover current (set at reset)

    def schedule(self, g: float, d: float) -> tuple[np.ndarray, float, float, float]:
        """Equilibrium currents and linear gains at ``(g, d)``: ``(u_eq, b_v, a21, L1)``."""
        self._g_in[0], self._d_in[0] = g, d
        self._eval()
        return self._out[0].copy(), float(self._out[1][0]), float(self._out[2][0]), float(self._out[3][0])

    def set_reference_plan(self, plan) -> None:
        """Let the feed-forward read the plan ``lead`` periods ahead (a :class:`maglev_ocp.reference.ReferencePlan`).

        Only used with a model file that declares a delay (:func:`pid_lead_samples`); ``None`` forgets the plan.
        """
        self._preview = PlanPreview(plan, self.lead, self.Ts) if plan is not None and self.lead else None

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start at reading ``y0`` at rest; the previous current is the hover current there."""
        self.observer.reset(y0.y)
        self._int[:] = 0.0
        u_eq, *_ = self.schedule(float(y0.y[0]), float(y0.y[1]))
        if not np.all(np.isfinite(u_eq)):  # 0 A here would drop the mover: say so instead
            raise hover_error(float(y0.y[0]), float(y0.y[1]))
        self._ueq_good = (float(u_eq[0]), float(u_eq[1]))
        self._u_prev = self._clip(u_eq)[0]

    def effect_feedforward(self, r, u_eq: np.ndarray, b_v: float, L1: float) -> np.ndarray:
        """Correction of the feed-forward current for the model file's effects [A] (zeros without effects).

        :func:`effect_correction` at the reference row ``r`` with the schedule ``(u_eq, b_v, L1)``.
        """
        if self.effects is None or not (np.all(np.isfinite(u_eq)) and b_v != 0.0 and L1 != 0.0):
            return np.zeros(2)
        return np.array(effect_correction(self.effects, r, u_eq, b_v, L1))

    def _clip(self, u: np.ndarray) -> tuple[np.ndarray, bool, bool]:
        """Limit: each axis to ±i_axis_max, then i_q to what the amplitude leaves after i_d."""
        i_q, i_d, q_sat, d_sat = clip_currents(NUMERIC, self.settings, float(u[0]), float(u[1]))
        return np.array([i_q, i_d]), q_sat, d_sat

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """Currents for the next period from reading ``y`` and reference ``ref``.

        If the model has no hover current at the reference (seed eq. (8) has no
        real root there), the last good hover current is held instead of 0 A and
        ``stats["fallback"] = 1`` (counted in the run's metrics).
        """
        x_hat = self.observer.step(y.y, self._u_prev)
        r = (ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot)
        # the feed-forward from the plan when the command computed now acts (lead periods ahead), the feedback
        # against the reference now
        r_ff = self._preview.at(y.t) if self._preview is not None else r
        u_eq, b_v, a21, L1 = self.schedule(r_ff[0], r_ff[3])
        (u_inv,) = self._inverse(np.asarray(r_ff, dtype=float), self._in_p)
        ff, r_ff = inverse_feedforward(NUMERIC, self.settings, (float(u_inv[0]), float(u_inv[1])), u_eq, r_ff)
        u_eq = np.array(ff, dtype=float)
        if self.effects is not None:
            u_eq = u_eq + self.effect_feedforward(demanded_row(self.settings, r_ff, r, x_hat), u_eq, b_v, L1)
        r = feedforward_row(r, r_ff)
        out = pid_law(
            NUMERIC,
            self.settings,
            self.Ts,
            x_hat.tolist(),
            (*u_eq.tolist(), b_v, a21, L1),
            r,
            self._int,
            self._ueq_good,
        )
        u, z_next, ueq_good, hover_fallback = out.u, out.z, out.ueq_good, out.fallback
        self._int[:] = z_next
        self._ueq_good = ueq_good
        u = np.array(u)
        self._u_prev = u
        stats = {"i_q_eq": ueq_good[0], "i_d_eq": ueq_good[1], "saturated": bool(out.q_sat or out.d_sat)}
        if hover_fallback:  # the column appears only in runs that needed it (NaN = 0 in the other rows)
            stats["fallback"] = 1
        return ControlOutput(u=u, x_hat=x_hat, stats=stats)


def feedforward_row(r, r_ff) -> tuple:
    """The law's reference row: positions and velocities of ``r`` (feedback), accelerations of ``r_ff``."""
    return (r[0], r[1], r_ff[2], r[3], r[4], r_ff[5])


# ----------------------------------------------------------------------------- the law, numeric or symbolic
@dataclass(frozen=True)
class _Ops:
    """Scalar operations the law is written in: Python floats (:data:`NUMERIC`) or CasADi SX (:data:`SYMBOLIC`).

    The law (:func:`pid_law`) is written once in these operations, so the Python
    controller and its CasADi step Function (``maglev_ocp.codegen.pid_fn``, the
    ``backend: c`` code) evaluate the same expressions in the same order.
    """

    fmin: Callable[[Any, Any], Any]
    fmax: Callable[[Any, Any], Any]
    sqrt: Callable[[Any], Any]
    where: Callable[[Any, Any, Any], Any]
    ne: Callable[[Any, Any], Any]
    gt0: Callable[[Any], Any]
    both: Callable[[Any, Any], Any]
    neg: Callable[[Any], Any]
    finite: Callable[[Any, Any], Any]


NUMERIC = _Ops(
    fmin=min,
    fmax=max,
    sqrt=math.sqrt,
    where=lambda c, a, b: a if c else b,
    ne=lambda a, b: a != b,
    gt0=lambda a: a > 0,
    both=lambda a, b: a and b,
    neg=lambda a: not a,
    finite=lambda a, b: math.isfinite(a) and math.isfinite(b),
)
SYMBOLIC = _Ops(
    fmin=ca.fmin,
    fmax=ca.fmax,
    sqrt=ca.sqrt,
    where=ca.if_else,
    ne=lambda a, b: a != b,
    gt0=lambda a: a > 0,
    both=ca.logic_and,
    neg=ca.logic_not,
    finite=lambda a, b: ca.fabs(a) + ca.fabs(b) < ca.inf,  # NaN compares false
)


def clip_currents(ops: _Ops, s: PIDSettings, u_q, u_d) -> tuple[Any, Any, Any, Any]:
    """The PID's limits: ``(i_q, i_d, q_saturated, d_saturated)``, the gap axis first, then the amplitude."""
    i_d = ops.fmin(ops.fmax(u_d, -s.i_axis_max), s.i_axis_max)
    i_d = ops.fmin(ops.fmax(i_d, -s.i_amp_max), s.i_amp_max)
    q_max = ops.fmin(s.i_axis_max, ops.sqrt(ops.fmax(s.i_amp_max**2 - i_d**2, 0.0)))
    i_q = ops.fmin(ops.fmax(u_q, -q_max), q_max)
    return i_q, i_d, ops.ne(i_q, u_q), ops.ne(i_d, u_d)


@dataclass
class LawOutput:
    """What one period of :func:`pid_law` gives: currents, next integrals, hover current, flags."""

    u: tuple[Any, Any]
    z: tuple[Any, Any]
    ueq_good: tuple[Any, Any]
    fallback: Any
    q_sat: Any
    d_sat: Any


def pid_law(ops: _Ops, s: PIDSettings, Ts: float, x_hat, sched, ref, z, ueq_good) -> LawOutput:
    """One period of the two PID regulators after the observer update (numeric or symbolic, see :class:`_Ops`).

    Parameters
    ----------
    ops : _Ops
        :data:`NUMERIC` or :data:`SYMBOLIC`.
    s : PIDSettings
        Tuning (its switches are fixed at build time).
    Ts : float
        Control period [s].
    x_hat : sequence (4,)
        Observer estimate ``(g, g_dot, d, d_dot)``.
    sched : sequence (5,)
        ``(i_q,eq, i_d,eq, b_v, a21, L1)`` at the reference (:func:`schedule_function`).
    ref : sequence (6,)
        Reference ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` (``signals.REF_FIELDS`` order).
    z : sequence (2,)
        Integrals of the position errors (gap, horizontal) [m s].
    ueq_good : sequence (2,)
        Last finite hover current (held where the model cannot hover at the reference).
    """
    g_hat, g_dot_hat, d_hat, d_dot_hat = x_hat[0], x_hat[1], x_hat[2], x_hat[3]
    iq_eq, id_eq, b_v, a21, L1 = sched[0], sched[1], sched[2], sched[3], sched[4]
    r_g, r_g_dot, r_g_ddot, r_d, r_d_dot, r_d_ddot = ref[0], ref[1], ref[2], ref[3], ref[4], ref[5]
    ok = ops.finite(iq_eq, id_eq)
    hover_fallback = ops.neg(ok)
    # the model cannot hover at this reference: hold the last good hover current
    iq_eq, id_eq = ops.where(ok, iq_eq, ueq_good[0]), ops.where(ok, id_eq, ueq_good[1])
    ff = 1.0 if s.feedforward else 0.0
    e_g, e_d = r_g - g_hat, r_d - d_hat
    ed_g, ed_d = r_g_dot - g_dot_hat, r_d_dot - d_dot_hat
    wg, wd = s.omega_g, s.omega_d
    # gap: b_v di_d = (a21 + 3 w^2) e + 3 w e_dot + w^3 int(e) (+ g_ddot_ref)
    i_d_pd = ((a21 + 3 * wg**2) * e_g + 3 * wg * ed_g + ff * r_g_ddot) / b_v
    # horizontal: d_ddot = -L1 i_q, so -L1 di_q = 3 w^2 e + 3 w e_dot + w^3 int(e) (+ d_ddot_ref)
    i_q_pd = -(3 * wd**2 * e_d + 3 * wd * ed_d + ff * r_d_ddot) / L1
    kig, kid = wg**3 / b_v, -(wd**3) / L1
    lim = s.integral_limit
    if s.integral:
        ig = ops.fmin(ops.fmax((z[0] + e_g * Ts) * kig, -lim), lim)  # integral current [A]
        iq_int = ops.fmin(ops.fmax((z[1] + e_d * Ts) * kid, -lim), lim)
    else:
        ig = iq_int = 0.0
    i_d = ff * id_eq + i_d_pd + ig if s.control_g else (s.i_d_fixed if s.i_d_fixed is not None else id_eq)
    i_q = ff * iq_eq + i_q_pd + iq_int if s.control_d else s.i_q_fixed
    u_q, u_d, q_sat, d_sat = clip_currents(ops, s, i_q, i_d)
    z_g, z_d = z[0], z[1]
    # anti-windup: keep an integrator only if it does not push further into saturation
    if s.integral:
        z_g = ops.where(ops.both(d_sat, ops.gt0((ig - z[0] * kig) * (i_d - u_d))), z[0], ig / kig)
        z_d = ops.where(ops.both(q_sat, ops.gt0((iq_int - z[1] * kid) * (i_q - u_q))), z[1], iq_int / kid)
    return LawOutput((u_q, u_d), (z_g, z_d), (iq_eq, id_eq), hover_fallback, q_sat, d_sat)


__all__ = [
    "NUMERIC",
    "SYMBOLIC",
    "LawOutput",
    "PIDController",
    "PIDSettings",
    "clip_currents",
    "demanded_row",
    "effect_correction",
    "feedforward_row",
    "hover_error",
    "inverse_feedforward",
    "inverse_feedforward_function",
    "pid_law",
    "pid_lead_samples",
    "pid_model_effects",
    "schedule_function",
]
