"""Nonlinear MPC of the stage: RTI multiple shooting on the shared model, one Function per step.

The controller is :class:`NMPC` (the :class:`~maglev_ocp.blocks.Controller`
protocol); its settings are :class:`NMPCSettings`, the ``controller:`` block of
a scenario. One control step is a single CasADi Function built by
:mod:`controllers.nmpc_step` (observer, reference, RTI linearization,
Riccati-structured fixed-budget ADMM on the current disks and soft gap bounds,
fallback, warm-start shift); the Python backend evaluates it with CasADi, the
C backend is the same Function code-generated (:mod:`maglev_ocp.codegen`).

Example
-------
>>> from controllers.nmpc import NMPC, NMPCSettings
>>> ctrl = NMPC(NMPCSettings(horizon=20), NOMINAL)
>>> ctrl.reset(y0, Reference(0.020, 0.0))
>>> out = ctrl.step(y, Reference(0.020, 0.05))    # out.u, out.x_hat, out.stats
"""

from __future__ import annotations

import functools
import time
from typing import Any, Literal

import numpy as np
from pydantic import Field

from maglev_ocp import constants as k
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.config import Strict
from maglev_ocp.params import NOMINAL, Params

from .nmpc_qp import ADMMSettings
from .nmpc_step import N_MEAS, STATS_NAMES, STATUS_FALLBACK, STATUS_INACCURATE, STATUS_OK, StepBuilder, StepConfig

STATUS_TEXT = {STATUS_OK: "ok", STATUS_INACCURATE: "inaccurate", STATUS_FALLBACK: "fallback"}


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
    """Fixed-budget ADMM (OSQP's iteration) on the condensed QP."""

    rho_scale: float = Field(0.35, gt=0, description="rho = rho_scale sqrt(lambda_min lambda_max) of the QP Hessian")
    rho_g_rel: float = Field(1.0, gt=0, description="penalty of the soft gap rows (mm) relative to the currents'")
    sigma: float = Field(1e-6, gt=0)
    alpha: float = Field(1.6, gt=0, lt=2)
    check_every: int = Field(5, ge=1, description="residuals computed every this many iterations")
    tol_prim: float = Field(1e-2, gt=0, description="primal residual for status ok [A or mm]")
    tol_dual: float = Field(1e-2, gt=0, description="dual residual for status ok")


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


class NMPCSettings(Strict):
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
    force_failure_steps : list of int
        Step indices at which the QP is poisoned with NaN (tests of the fallback).
    """

    type: Literal["nmpc"] = "nmpc"
    backend: Literal["python", "c"] = "python"
    horizon: int = Field(20, ge=4, le=80)
    n_sub: int = Field(1, ge=1, le=10, description="RK4 sub-steps of the prediction model")
    jacobian: Literal["taylor", "exact"] = "taylor"
    weights: NMPCWeights = Field(default_factory=NMPCWeights)
    solver: Literal["admm"] = "admm"
    qp: Literal["riccati", "dense"] = Field(
        "riccati", description="ADMM x-update: stage-wise Riccati recursion (O(N)) or dense condensed Cholesky"
    )
    iterations: int = Field(20, ge=1, le=500, description="ADMM iterations per step (fixed)")
    admm: ADMMOptions = Field(default_factory=ADMMOptions)
    soft_gap: SoftGap = Field(default_factory=SoftGap)
    observer_eps: float = Field(3e-3, gt=1e-4, le=0.1, description="high-gain observer time constant [s]")
    offset_free: bool = True
    use_cogging: bool = True
    reference: Literal["auto", "preview", "plan"] = "auto"
    plan: PlanOptions = Field(default_factory=PlanOptions)
    current_limit: float = Field(k.i_amp_max, gt=0, le=k.i_amp_max, description="disk radius used [A]")
    force_failure_steps: list[int] = Field(default_factory=list)

    def step_config(self, mode: str) -> StepConfig:
        """The numeric design of the step Function for reference mode ``mode`` (``plan``/``preview``)."""
        w, a, sg, pl = self.weights, self.admm, self.soft_gap, self.plan
        return StepConfig(
            N=self.horizon,
            Ts=k.Ts,
            n_sub=self.n_sub,
            Q=(w.g, w.g_dot, w.d, w.d_dot),
            R=(w.i_q, w.i_d),
            terminal_scale=w.terminal_scale,
            n_iter=self.iterations,
            admm=ADMMSettings(rho_scale=a.rho_scale, rho_g_rel=a.rho_g_rel, sigma=a.sigma, alpha=a.alpha),
            i_max=self.current_limit,
            i_box=min(k.i_axis_max, self.current_limit),
            gap_lo=sg.g_min,
            gap_hi=sg.g_max,
            gap_stride=sg.stride,
            soft_w1=sg.w_linear,
            soft_w2=sg.w_quadratic,
            obs_eps=self.observer_eps,
            offset_free=self.offset_free,
            reference=mode,
            accel_margin=pl.accel_margin,
            gap_accel=pl.gap_accel,
            jerk_time=pl.jerk_time,
            tol_prim=a.tol_prim,
            tol_dual=a.tol_dual,
            jacobian=self.jacobian,
            check_every=a.check_every,
            qp=self.qp,
        )


@functools.lru_cache(maxsize=32)
def step_functions(cfg: StepConfig) -> tuple[Any, Any, StepBuilder]:
    """Build (once per design) ``nmpc_init`` and ``nmpc_step`` and the builder holding the layout."""
    b = StepBuilder(cfg)
    return b.build_init(), b.build_step(), b


class _Evaluator:
    """Calls a CasADi Function through its buffer API (no DM conversion: ~10x less overhead)."""

    def __init__(self, fn, n_out_sizes: list[int], in_sizes: list[int]):
        self.fn = fn
        self.args = [np.zeros(n) for n in in_sizes]
        self.res = [np.zeros(n) for n in n_out_sizes]
        buf, self._eval = fn.buffer()
        for i, a in enumerate(self.args):
            buf.set_arg(i, memoryview(a))
        for i, r in enumerate(self.res):
            buf.set_res(i, memoryview(r))
        self._buf = buf

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        for a, v in zip(self.args, inputs, strict=True):
            a[:] = np.ravel(v, order="F")
        self._eval()
        return self.res


class NMPC:
    """Nonlinear MPC (RTI, multiple shooting, ADMM), following the Controller protocol.

    Parameters
    ----------
    settings : NMPCSettings
        Design and tuning.
    params : Params
        The controller's model parameters (cogging dropped if ``use_cogging`` is off).
    """

    name = "nmpc"

    def __init__(self, settings: NMPCSettings | None = None, params: Params = NOMINAL):
        self.settings = settings or NMPCSettings()
        self.params = params
        model_params = params if self.settings.use_cogging else params.without_cogging()
        self.p = model_params.vector()
        self._plan_obj = None
        self._pcache: tuple[int, np.ndarray] | None = None
        self._mode: str | None = None
        self._k = 0
        self._pending_faults = 0
        self.state: np.ndarray | None = None

    # -------------------------------------------------------------- reference
    def set_reference_plan(self, plan) -> None:
        """Let the NMPC read the runner's reference ahead (a :class:`maglev_ocp.reference.ReferencePlan`)."""
        self._plan_obj = plan
        self._pcache = None

    def _resolve_mode(self) -> str:
        mode = self.settings.reference
        if mode == "auto":
            shaping = getattr(self._plan_obj, "shaping", None)
            mode = "preview" if (self._plan_obj is not None and shaping != "step") else "plan"
        return mode

    def _ref_matrix(self, t: float, ref: Reference) -> np.ndarray:
        """Reference input of the step: rows (g, g_dot, g_ddot, d, d_dot, d_ddot), one column per node."""
        N, Ts = self.settings.horizon, k.Ts
        if self._mode == "plan":
            if self._plan_obj is not None:
                tg = self._plan_obj.targets[self._plan_obj.target_index(t)]
                g, d = tg.g, tg.d
            else:
                g, d = ref.g, ref.d
            out = np.zeros((6, N + 1))
            out[0, :], out[3, :] = g, d
            return out
        if self._plan_obj is not None:
            return self._preview(t)
        s = Ts * np.arange(N + 1)
        return np.vstack(
            [
                ref.g + ref.g_dot * s + ref.g_ddot * s**2 / 2,
                ref.g_dot + ref.g_ddot * s,
                np.full(N + 1, ref.g_ddot),
                ref.d + ref.d_dot * s + ref.d_ddot * s**2 / 2,
                ref.d_dot + ref.d_ddot * s,
                np.full(N + 1, ref.d_ddot),
            ]
        )

    _CHUNK = 512  #: periods of the runner's plan sampled at once (the plan is read ahead in blocks)

    def _preview(self, t: float) -> np.ndarray:
        """The runner's plan at ``t + j Ts``, ``j = 0..N``, held at its value just before the next target switch.

        No preview across a target switch: the current target is held until it
        comes. The plan is sampled on the period grid in blocks (cached), so a
        step costs a slice, not a plan evaluation.
        """
        N, Ts, plan = self.settings.horizon, k.Ts, self._plan_obj
        kk = round(t / Ts)
        c = self._pcache
        if c is None or not (c[0] <= kk and kk + N < c[0] + len(c[1])):
            grid = (kk + np.arange(self._CHUNK + N + 1)) * Ts
            c = self._pcache = (kk, plan.sample(grid))
        cols = c[1][kk - c[0] : kk - c[0] + N + 1].copy()
        sw = np.asarray(getattr(plan, "switch_times", []), dtype=float)
        later = sw[sw > t + 1e-9]
        if later.size:
            cut = (kk + np.arange(N + 1)) * Ts >= later[0] - 1e-9
            if cut.any():
                cols[cut] = plan.sample(np.array([later[0] - 1e-9]))[0]
        return cols.T

    # ------------------------------------------------------------------- steps
    def _functions(self, mode: str):
        init, step, b = step_functions(self.settings.step_config(mode))
        self.layout = b.layout
        self.library = None
        N = self.settings.horizon
        ns, npar = b.layout.size, len(self.p)
        self._init = _Evaluator(init, [ns], [N_MEAS, 6 * (N + 1), npar])
        self._step = _Evaluator(step, [2, ns, len(STATS_NAMES), 4], [ns, N_MEAS, 6 * (N + 1), npar])
        self.step_function = step
        self.init_function = init
        if self.settings.backend == "c":
            # The same Function code-generated by maglev_ocp.codegen, compiled (cached per design) and called
            # through ctypes with the same arguments.
            from maglev_ocp.codegen.backend import compile_codes
            from maglev_ocp.codegen.functions import nmpc_code
            from maglev_ocp.codegen.loader import CompiledLibrary

            build = compile_codes([nmpc_code(self.settings, self.params, mode)])
            lib = CompiledLibrary(build.library)
            self._init, self._step = lib.function("nmpc_init"), lib.function("nmpc_step")
            self.library = build.library

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start at rest at the reading ``y0``, aiming at ``ref``."""
        self._mode = self._resolve_mode()
        self._pcache = None
        self._functions(self._mode)
        meas = np.array([y0.y[0], y0.y[1], 0.0])
        (st,) = self._init(meas, self._ref_matrix(y0.t, ref), self.p)
        self.state = st.copy()
        self._k = 0

    def inject_failure(self, n_steps: int = 1) -> None:
        """Poison the QP of the next ``n_steps`` steps with NaN (to test the fallback)."""
        self._pending_faults += int(n_steps)

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """One control period: currents to apply from ``y.t`` on."""
        if self.state is None:
            raise RuntimeError("call NMPC.reset() before NMPC.step()")
        t0 = time.perf_counter()
        fault = 0.0
        if self._pending_faults > 0 or self._k in self.settings.force_failure_steps:
            fault = 1.0
            self._pending_faults = max(self._pending_faults - 1, 0)
        meas = np.array([y.y[0], y.y[1], fault])
        refm = self._ref_matrix(y.t, ref)
        t1 = time.perf_counter()
        u, st, stats, xh = self._step(self.state, meas, refm, self.p)
        kernel_us = (time.perf_counter() - t1) * 1e6
        self.state = st.copy()
        u = u.copy()
        dt_us = (time.perf_counter() - t0) * 1e6
        self._k += 1
        sv = dict(zip(STATS_NAMES, stats.tolist(), strict=True))
        status = int(sv["status"])
        out_stats = {
            "status": STATUS_TEXT.get(status, str(status)),
            "fallback": bool(sv["fallback"]),
            "iterations": int(sv["iterations"]),
            "iters_to_tol": int(sv["iters_to_tol"]),
            "qp_r_prim": sv["qp_r_prim"],
            "qp_r_dual": sv["qp_r_dual"],
            "dist_g": sv["dist_g"],
            "dist_d": sv["dist_d"],
            "step_time_us": dt_us,
            "kernel_us": kernel_us,
        }
        return ControlOutput(u=u, x_hat=xh.copy(), stats=out_stats)

    # --------------------------------------------------------------- inspection
    def plan_arrays(self) -> dict[str, np.ndarray]:
        """Current shooting nodes ``X`` (N+1 x 4) and currents ``U`` (N x 2) of the warm start."""
        S = self.layout.split(self.state)
        N = self.settings.horizon
        return {"X": S["X"].reshape(N + 1, 4), "U": S["U"].reshape(N, 2)}


__all__ = ["NMPC", "ADMMOptions", "NMPCSettings", "NMPCWeights", "PlanOptions", "SoftGap", "step_functions"]
