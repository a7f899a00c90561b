"""The NMPC controller: the step Function, evaluated by an injected evaluator, inside the Controller protocol.

:class:`NMPC` follows :class:`~maglev_ocp.blocks.Controller`; its settings are
:class:`~maglev_ocp.controllers.nmpc.settings.NMPCSettings`. One control step is the single
CasADi Function of :mod:`maglev_ocp.controllers.nmpc.step`. *How* it is evaluated is not
the controller's business: it is given a :class:`StepEvaluators` factory that
turns the step's Functions into callables. The default,
:func:`casadi_evaluators`, evaluates them with CasADi's buffer API
(:class:`maglev_ocp.fastcall.BufferedFunction`); the C backend
(:func:`maglev_ocp.codegen.backend.c_evaluators`) returns the very same
Functions code-generated, compiled and loaded. The Python glue around the call
(reference input, statistics, timing) is the same for both, so the runner,
``maglev bench``, the harness and the peer benchmark time the same object.

Example
-------
>>> from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings
>>> ctrl = NMPC(NMPCSettings(horizon=20), NOMINAL)
>>> ctrl.reset(y0, Reference(0.020, 0.0))
>>> out = ctrl.step(y, Reference(0.020, 0.05))    # out.u, out.x_hat, out.stats
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import casadi as ca
import numpy as np

from maglev_ocp import constants as k
from maglev_ocp.blocks import ControlOutput, Measurement, Reference
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.params import NOMINAL, Params

from ..model_file import load_controller_model
from .layout import STATS_NAMES, STATUS_TEXT, StateLayout
from .reference import HorizonReference
from .settings import NMPCSettings
from .step import step_functions

#: A step evaluator: called with the Function's inputs (arrays), returns its outputs (flat arrays).
Evaluator = Callable[..., list[np.ndarray]]


@dataclass(frozen=True)
class StepFunctions:
    """What an evaluator factory gets: the NMPC's Functions for one reference mode and their design.

    Attributes
    ----------
    init, step : casadi.Function
        ``nmpc_init(meas, ref, p) -> state`` and ``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)``.
    layout : StateLayout
        Layout of the state vector.
    settings : NMPCSettings
        The settings they were built from.
    params : Params
        What the controller's model believes (before ``use_cogging`` is applied).
    mode : {"plan", "preview"}
        Reference mode baked in.
    """

    init: ca.Function
    step: ca.Function
    layout: StateLayout
    settings: NMPCSettings
    params: Params
    mode: str


class StepEvaluators(Protocol):
    """Turns an NMPC's :class:`StepFunctions` into ``(init, step)`` evaluators.

    An optional ``backend`` attribute names it (``"python"``, ``"c"``).
    """

    def __call__(self, fns: StepFunctions) -> tuple[Evaluator, Evaluator]: ...


def casadi_evaluators(fns: StepFunctions) -> tuple[Evaluator, Evaluator]:
    """The Python backend: ``nmpc_init`` and ``nmpc_step`` through CasADi's buffer API."""
    return BufferedFunction(fns.init), BufferedFunction(fns.step)


casadi_evaluators.backend = "python"  # type: ignore[attr-defined]


class NMPC:
    """Nonlinear MPC (RTI, multiple shooting, ADMM), following the Controller protocol.

    Parameters
    ----------
    settings : NMPCSettings
        Design and tuning.
    params : Params
        The controller's model parameters (cogging dropped if ``use_cogging`` is off).
    evaluators : StepEvaluators
        How the step Functions are evaluated (default :func:`casadi_evaluators`;
        the compiled C: :func:`maglev_ocp.codegen.backend.c_evaluators`).

    Notes
    -----
    ``stats`` of each step: ``status`` (``ok``, ``inaccurate``, ``fallback``),
    ``fallback``, ``iterations``, ``iters_to_tol``, the QP residuals, the
    disturbance estimates, ``step_time_us`` (the whole ``step``), ``kernel_us``
    and ``kernel_cpu_us`` (the evaluator call alone: wall clock and thread CPU time).
    """

    name = "nmpc"

    def __init__(
        self,
        settings: NMPCSettings | None = None,
        params: Params = NOMINAL,
        evaluators: StepEvaluators = casadi_evaluators,
    ):
        self.settings = settings or NMPCSettings()
        # a model file (settings.model): its constants are the controller's parameters, its lag's transport
        # delay and time constant in whole periods (and a plant file's computation delay) add to
        # delay_samples; the step takes its effects
        self.model = load_controller_model(self.settings.model) if self.settings.model else None
        if self.model is not None:
            params = self.model.params
            if self.model.delay_periods(k.Ts):  # transport delay + the lag's time constant, whole periods
                total = self.settings.delay_samples + self.model.delay_periods(k.Ts)
                self.settings = NMPCSettings.model_validate({**self.settings.model_dump(), "delay_samples": total})
        self.params = params
        self.evaluators = evaluators
        self.backend: str = getattr(evaluators, "backend", "custom")
        model_params = params if self.settings.use_cogging else params.without_cogging()
        self.model_params = model_params
        self.p = model_params.vector()
        self.reference = HorizonReference(
            self.settings.horizon, k.Ts, period_mean=self.settings.feedforward == "period_mean"
        )
        self._prepared: dict[str, tuple[StepFunctions, Evaluator, Evaluator]] = {}
        self._mode: str | None = None
        self._k = 0
        self._pending_faults = 0
        self.state: np.ndarray | None = None

    # -------------------------------------------------------------- reference
    def set_reference_plan(self, plan) -> None:
        """Let the NMPC read the runner's reference ahead (a :class:`maglev_ocp.reference.ReferencePlan`)."""
        self.reference.set_plan(plan)

    # ------------------------------------------------------------------- steps
    def prepare(self, mode: str) -> StepFunctions:
        """Build the step of reference mode ``mode`` and its evaluators (once per mode; compiles for C)."""
        if mode not in self._prepared:
            init, step, b = step_functions(self.settings, mode, self.model_params)
            fns = StepFunctions(init, step, b.layout, self.settings, self.params, mode)
            self._prepared[mode] = (fns, *self.evaluators(fns))
        fns, self._init, self._step = self._prepared[mode]
        self.layout, self.step_function, self.init_function = fns.layout, fns.step, fns.init
        return fns

    @property
    def step_evaluator(self) -> Evaluator:
        """The evaluator of ``nmpc_step`` in use (after :meth:`prepare` or :meth:`reset`)."""
        return self._step

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start at rest at the reading ``y0``, aiming at ``ref``."""
        self._mode = self.reference.resolve_mode(self.settings.reference)
        self.reference.clear_cache()
        self.prepare(self._mode)
        meas = np.array([y0.y[0], y0.y[1], 0.0])
        (st,) = self._init(meas, self.reference.matrix(self._mode, y0.t, ref), self.p)
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
        refm = self.reference.matrix(self._mode, y.t, ref, self.settings.delay_samples)
        c1 = time.thread_time()
        t1 = time.perf_counter()
        u, st, stats, xh = self._step(self.state, meas, refm, self.p)
        kernel_us = (time.perf_counter() - t1) * 1e6
        kernel_cpu_us = (time.thread_time() - c1) * 1e6
        self.state = st.copy()
        u = u.copy()
        dt_us = (time.perf_counter() - t0) * 1e6
        self._k += 1
        return ControlOutput(u=u, x_hat=xh.copy(), stats=self._stats(stats, dt_us, kernel_us, kernel_cpu_us))

    @staticmethod
    def _stats(stats: np.ndarray, dt_us: float, kernel_us: float, kernel_cpu_us: float) -> dict[str, Any]:
        sv = dict(zip(STATS_NAMES, stats.tolist(), strict=True))
        status = int(sv["status"])
        return {
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
            "kernel_cpu_us": kernel_cpu_us,
        }

    # --------------------------------------------------------------- inspection
    def plan_arrays(self) -> dict[str, np.ndarray]:
        """Current shooting nodes ``X`` (N+1 x 4) and currents ``U`` (N x 2) of the warm start."""
        S = self.layout.split(self.state)
        N = self.settings.horizon
        return {"X": S["X"].reshape(N + 1, 4), "U": S["U"].reshape(N, 2)}


__all__ = ["NMPC", "Evaluator", "StepEvaluators", "StepFunctions", "casadi_evaluators"]
