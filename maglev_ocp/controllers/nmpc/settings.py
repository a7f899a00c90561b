"""Settings of the NMPC: the one place where every option has its name, its default and its meaning.

:class:`NMPCSettings` is the ``controller:`` block of a scenario (``type:
nmpc``). The step builder (:mod:`maglev_ocp.controllers.nmpc.step` and its stage modules)
reads it directly; the few derived quantities it needs (weight tuples, the
soft-bounded stages, the current box) are properties here, so nothing is
renamed or defaulted twice. How the step is *evaluated* (CasADi in Python or the
compiled C) is not a setting of the controller: it is the evaluator the NMPC is
given (:class:`maglev_ocp.controllers.nmpc.controller.NMPC`, ``evaluators``).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from maglev_ocp import constants as k
from maglev_ocp.config import Strict
from maglev_ocp.observers import AdaptSettings

from ..model_file import (
    MODEL_SETTING_DESCRIPTION,
    UNTRUSTED_MODEL_DESCRIPTION,
    UntrustedPolicy,
    check_model_path,
    check_model_trust,
)


class NMPCWeights(Strict):
    """Stage weights of the tracking cost (per 1 ms stage; currents in A, positions in m).

    The ratio ``q_pos / r`` sets the closed-loop bandwidth: for a double
    integrator with input gain ``b`` [m/s^2/A], ``omega ~ (q b^2 / r)^(1/4)``;
    ``4e7`` with ``b ~ 6.7`` gives about 200 rad/s: stiff enough that the lag of
    the disturbance estimate after a fast move (friction, parameter error) costs
    only a few micrometres.
    """

    g: float = Field(4e7, ge=0, description="gap error [1/m^2]")
    g_dot: float = Field(1e2, ge=0, description="gap-rate error [s^2/m^2]")
    d: float = Field(4e7, ge=0, description="position error [1/m^2]")
    d_dot: float = Field(1e2, ge=0, description="velocity error [s^2/m^2]")
    i_q: float = Field(1.0, gt=0, description="i_q deviation from the feed-forward [1/A^2]")
    i_d: float = Field(1.0, gt=0, description="i_d deviation from the feed-forward [1/A^2]")
    terminal_scale: float = Field(1.0, gt=0, description="factor on the LQR terminal weight")


class ADMMOptions(Strict):
    """ADMM (OSQP's iteration) on the condensed QP: at most ``iterations``, stopped early on the residuals.

    Worst case: ``iterations`` iterations and (Riccati QP, ``adapt_at > 0``) one
    refactorization; every stop is a conditional block of a fixed chain, so the
    generated C has no data-dependent loop. ``adapt_at`` applies to the Riccati
    x-update only (the dense reference path keeps its first ``rho``).
    """

    rho_scale: float = Field(0.35, gt=0, description="rho = rho_scale sqrt(lambda_min lambda_max) of the QP Hessian")
    rho_g_rel: float = Field(1.0, gt=0, description="penalty of the soft gap rows (mm) relative to the currents'")
    sigma: float = Field(1e-6, gt=0)
    alpha: float = Field(1.6, gt=0, lt=2)
    check_every: int = Field(2, ge=1, description="residuals checked every this many iterations")
    tol_prim: float = Field(1e-2, gt=0, description="primal residual for status ok [A or mm]")
    tol_dual: float = Field(1e-2, gt=0, description="dual residual for status ok")
    adapt_at: int = Field(
        10, ge=0, description="iteration after which rho is rebalanced once if not converged (0: never; Riccati QP)"
    )
    adapt_ratio: float = Field(3.0, gt=1, description="rebalance only if the residual ratio is beyond this factor")
    early_exit: bool = Field(
        True,
        description="stop at the first checkpoint with both residuals below tolerance (iterations: the maximum)",
    )


class OSQPOptions(Strict):
    """OSQP (``solver: osqp``, Python backend only) on the condensed QP with the disks as tangent cuts.

    ``embedded: false`` runs the osqp package (polished by default); ``embedded: true`` runs OSQP's own
    generated C (``codegen``, embedded mode 2: the matrices are parameters, since the linearization
    changes them every step), built once per design (:mod:`maglev_ocp.controllers.nmpc.osqp_embedded`). Embedded
    mode has no polishing, so its default tolerances are tighter.
    """

    embedded: bool = Field(
        False, description="OSQP's own generated C (embedded mode 2, compiled once per design) instead of the package"
    )
    eps_abs: float | None = Field(None, gt=0, description="absolute tolerance (default 1e-5; embedded 1e-8)")
    eps_rel: float | None = Field(None, gt=0, description="relative tolerance (default 1e-5; embedded 1e-8)")
    max_iter: int = Field(40000, ge=1)
    polish: bool | None = Field(
        None, description="polish the ADMM solution (default: on for the package; embedded code has no polishing)"
    )
    passes: int = Field(6, ge=1, le=8, description="cutting-plane passes on the disks (1: one cut at ubar)")
    polygon: int = Field(8, ge=0, le=64, description="sides of the fixed circumscribed polygon of each disk")

    @model_validator(mode="after")
    def _embedded_has_no_polishing(self) -> OSQPOptions:
        if self.embedded and self.polish:
            raise ValueError(
                "osqp.polish: true is not available with osqp.embedded: true (OSQP's embedded code has no "
                "polishing); allowed: polish: false or unset"
            )
        return self

    @property
    def abs_tolerance(self) -> float:
        """``eps_abs`` in effect."""
        return self.eps_abs if self.eps_abs is not None else (1e-8 if self.embedded else 1e-5)

    @property
    def rel_tolerance(self) -> float:
        """``eps_rel`` in effect."""
        return self.eps_rel if self.eps_rel is not None else (1e-8 if self.embedded else 1e-5)

    @property
    def polishing(self) -> bool:
        """Whether the solution is polished (never in embedded code)."""
        return (not self.embedded) if self.polish is None else bool(self.polish)


class SoftGap(Strict):
    """Soft bounds that keep the predicted gap off the stops (exact + quadratic penalty)."""

    g_min: float = Field(10e-3, gt=k.g_stop[0], lt=k.g_stop[1], description="[m]")
    g_max: float = Field(30e-3, gt=k.g_stop[0], lt=k.g_stop[1], description="[m]")
    w_linear: float = Field(10.0, ge=0, description="exact-penalty weight per mm")
    w_quadratic: float = Field(100.0, ge=0, description="quadratic weight per mm^2")
    stride: int = Field(4, ge=0, description="bound every this many stages (0: off)")


class PlanOptions(Strict):
    """Internal planner (``reference: plan``): jerk-limited bang-bang moves."""

    accel_margin: float = Field(0.9, gt=0.1, le=1.0, description="fraction of the current-limited thrust")
    gap_accel: float = Field(20.0, gt=0, description="peak gap acceleration [m/s^2]")
    jerk_time: float = Field(2e-3, ge=1e-4, le=0.05, description="acceleration ramp time [s]")


class NMPCSettings(AdaptSettings):
    """Settings of :class:`NMPC` (a scenario's ``controller:`` block with ``type: nmpc``).

    Attributes
    ----------
    horizon : int
        Number of 1 ms shooting intervals.
    reference : {"auto", "preview", "plan"}
        ``preview``: track the runner's reference over the horizon (read ahead
        from its plan when it gives one, else extrapolated from the reference's
        rates); ``plan``: plan a current-limited move internally whenever the
        target changes (for set-point steps); ``auto``: ``preview`` when the
        runner gives a trajectory plan, else ``plan``.
    use_cogging : bool
        Cogging in the controller's model (else the seed's eq. (2)).
    offset_free : bool
        Use the observer's disturbance estimate in the prediction.
    adapt : list of str
        Constants (of C1..C4, which enter the model linearly) whose relative
        error the observer estimates online from the encoder innovation (an
        adaptive observer with the constants' sensitivities as regressors,
        :func:`maglev_ocp.controllers.nmpc.observer.observe`). The default ``C1, C4``:
        the thrust and the current-squared attraction, whose errors scale with
        the move's currents. A constant's error is only learnt while its
        regressor is excited (during moves); the constant-acceleration
        disturbance keeps what is left.
    delay_samples : int
        The loop's computation delay [control periods] (``plant.delay_samples``
        plus the amplifier's transport delay in a scenario). The step keeps the
        ``N`` commands sent but not yet applied, updates the observer with the
        one really applied over the last period, predicts the estimate ``N``
        samples ahead through them and optimises from that predicted state
        against the reference ``N`` samples ahead (a state-space Smith
        predictor inside the step: nothing to retune).
    model : str or None
        A model file (:mod:`maglev_ocp.controllers.model_file`: constants plus fitted
        effects, the plant files' format, e.g. the ``model.yaml`` of ``maglev
        diagnose``). Its constants replace the controller's parameters; its
        static effects enter the prediction model (inside the RK4), the
        observer's prediction and the feed-forward currents (the step bakes
        their parameters in, so the compiled C carries them too); an amplifier
        lag's transport delay plus its time constant in whole periods
        (:meth:`~maglev_ocp.controllers.model_file.ControllerModel.delay_periods`, and a plant file's
        ``delay_samples``) add to ``delay_samples`` (:class:`NMPC` does the sum).
    force_failure_steps : list of int
        Step indices at which the QP is poisoned with NaN (tests of the fallback).
    """

    type: Literal["nmpc"] = "nmpc"
    horizon: int = Field(20, ge=4, le=80)
    n_sub: int = Field(1, ge=1, le=10, description="RK4 sub-steps of the prediction model")
    jacobian: Literal["taylor", "exact"] = "taylor"
    weights: NMPCWeights = Field(default_factory=NMPCWeights)
    solver: Literal["admm", "osqp"] = Field(
        "admm",
        description="QP solver: our ADMM (code-generated) or OSQP (the osqp package or, osqp.embedded, OSQP's "
        "own generated C; Python backend only)",
    )
    qp: Literal["riccati", "dense"] = Field(
        "riccati", description="ADMM x-update: stage-wise Riccati recursion (O(N)) or dense condensed Cholesky"
    )
    iterations: int = Field(
        40, ge=1, le=500, description="ADMM iterations per step: the maximum (admm.early_exit) or the fixed count"
    )
    admm: ADMMOptions = Field(default_factory=ADMMOptions)
    osqp: OSQPOptions = Field(default_factory=OSQPOptions)
    soft_gap: SoftGap = Field(default_factory=SoftGap)
    observer_eps: float = Field(
        3e-3,
        gt=1e-4,
        le=0.1,
        description="high-gain observer time constant [s]: how fast the disturbance estimate follows a change. "
        "2 ms lowers the tour's steady RMS in d (6.5 -> 4.4 um, the estimate of the move's thrust mismatch dies "
        "sooner) but loses the loop on a rig with an unmodelled 300 Hz amplifier lag and one-period delay, "
        "which 3 ms holds",
    )
    offset_free: bool = True
    feedforward: Literal["instant", "period_mean"] = Field(
        "instant",
        description="accelerations of the previewed reference the feed-forward currents are computed from: "
        "the plan's at each node (instant) or its mean over the node's period (period_mean, what a "
        "zero-order-held current must produce; the runner hands FL these). period_mean removes the half-period "
        "lag of the feed-forward (tour tracking RMS about halved, delay tour steady d <= 5.7 um on seeds 1-8) "
        "but on the default rig its unmodelled 2 kHz amplifier lag then leaves ~1 um more steady gap RMS "
        "after the 25 mm gap move, which the half-period-late feed-forward happened to offset",
    )
    use_cogging: bool = True
    reference: Literal["auto", "preview", "plan"] = "auto"
    plan: PlanOptions = Field(default_factory=PlanOptions)
    current_limit: float = Field(k.i_amp_max, gt=0, le=k.i_amp_max, description="disk radius used [A]")
    lqr_schedule: bool = Field(
        True,
        description="design the LQR terminal weight and fallback on the controller's own parameters, the "
        "fallback gain on a grid of gaps interpolated at the reference gap (false: nominal constants at 20 mm)",
    )
    delay_samples: int = Field(
        0,
        ge=0,
        le=10,
        description="computation delay predicted through [control periods]: the current computed at sample k "
        "is applied at k + N; the step propagates its estimate N samples with the commands in flight and "
        "optimises from there (0: no delay model)",
    )
    model: str | None = Field(None, description=MODEL_SETTING_DESCRIPTION)
    untrusted_model: UntrustedPolicy = Field("refuse", description=UNTRUSTED_MODEL_DESCRIPTION)
    force_failure_steps: list[int] = Field(default_factory=list)

    @field_validator("model")
    @classmethod
    def _model_exists(cls, v: str | None) -> str | None:
        return check_model_path(v)

    @model_validator(mode="after")
    def _model_trusted(self) -> NMPCSettings:
        check_model_trust(self.model, self.untrusted_model)
        return self

    # ------------------------------------------------------------- planning defaults
    @staticmethod
    def reference_defaults() -> dict[str, object]:
        """How the NMPC wants a scenario's moves planned when the scenario's ``reference:`` leaves it open.

        Minimum-time moves at 0.97 of the current limits on the controller's
        model (``shaping: min_time``, :func:`maglev_ocp.reference.plan_min_time_move`):
        the QP has the limits as constraints and closes the rest. With a model
        file the solved move's currents are checked on the model with its
        effects, and a move that does not fit there, or one the solver does not
        converge on, is the suite's jerk-limited trajectory at the same
        fractions (``i_d`` at FL's 0.85 for the unstable gap's feedback), its
        horizontal acceleration phase and the gap's part of the move placed
        freely (``d_timing``, ``gap_timing: free``). Random 60-100 mm moves on the
        default plant settle at 1.014 x median, 1.025 x at worst, their minimum
        time (``python -m benchmarks.min_time_moves``; 1.136 / 1.210 x with FL's
        plan). A plan this close to the limits needs a model that is not weaker
        than the rig: with the blind model on a rig whose force is 10-15 %
        weaker the targets still settle, but the tracking RMS against the plan
        rises ten- to twentyfold; load the diagnosed model file there, or set
        ``reference: {shaping: trajectory, current_fraction: 0.85}`` (FL's plan).
        A scenario that sets a key keeps its value.
        """
        return {
            "shaping": "min_time",
            "current_fraction": 0.97,
            "i_d_fraction": 0.85,
            "ramp_fraction": 0.02,
            "gap_timing": "free",
            "d_timing": "free",
        }

    # ------------------------------------------------------------- derived (read by the step builder)
    @property
    def Q(self) -> tuple[float, float, float, float]:
        """Stage state weights ``(g, g_dot, d, d_dot)``."""
        w = self.weights
        return (w.g, w.g_dot, w.d, w.d_dot)

    @property
    def R(self) -> tuple[float, float]:
        """Stage input weights ``(i_q, i_d)``."""
        return (self.weights.i_q, self.weights.i_d)

    @property
    def i_box(self) -> float:
        """Per-axis current bound [A]: the amplifier's axis limit within the disk used."""
        return min(k.i_axis_max, self.current_limit)

    @property
    def gap_stages(self) -> tuple[int, ...]:
        """Stages whose predicted gap is softly bounded (``stride, 2 stride, ... <= horizon``)."""
        stride = self.soft_gap.stride
        if stride <= 0:
            return ()
        return tuple(range(stride, self.horizon + 1, stride))

    @property
    def n_gap(self) -> int:
        """Number of soft gap rows."""
        return len(self.gap_stages)


__all__ = ["ADMMOptions", "NMPCSettings", "NMPCWeights", "OSQPOptions", "PlanOptions", "SoftGap"]
