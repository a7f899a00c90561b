"""The C backend: controller steps evaluated by the generated code, compiled and loaded.

``backend: c`` in a scenario means the closed loop runs on the very code the
rig would run. There is one C path:

* the NMPC is the Python :class:`maglev_ocp.controllers.nmpc.NMPC` given the compiled
  evaluators :func:`c_evaluators` (its step Function code-generated
  (:func:`maglev_ocp.codegen.functions.nmpc_code`), built in the content-hash
  cache (:func:`maglev_ocp.codegen.build.build_cached`; once per design and
  machine) and called through ctypes (:mod:`maglev_ocp.codegen.loader`)); the
  Python glue around the call (reference input, statistics, timing) is the
  NMPC's own, so both backends feed identical inputs to the same Function and
  are timed the same way;
* feedback linearization: :class:`CompiledFL` (observer and law in one compiled call);
* the PID regulators: :class:`CompiledPID` (observer, schedule and regulators in one compiled call).

:func:`build_c_controller` is the runner's builder for ``backend: c``;
:func:`register_c_backend` (called when :mod:`maglev_ocp.codegen` is imported)
registers it with :func:`maglev_ocp.runner.register_backend`, so the runner,
which sits below code generation, never imports it. ``maglev bench``, the
harness check and ``benchmarks/peer_acados.py`` build their controllers with
:func:`build_c_controller` too.

Compiler flags: ``cflags`` argument, else ``$MAGLEV_CODEGEN_CFLAGS``, else
:data:`maglev_ocp.codegen.templates.DEFAULT_CFLAGS`.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from maglev_ocp.controllers.fl import FeedbackLinearization, fl_adapted, law_stats
from maglev_ocp.controllers.nmpc import NMPC, StepFunctions
from maglev_ocp.controllers.pid import PIDController, hover_error

from .. import constants as k
from ..blocks import ControlOutput, Measurement, Reference
from ..errors import UserError
from ..params import NOMINAL, Params
from ..runner import register_backend
from .build import BuildResult, build_cached
from .fl_fn import fl_state_slices
from .functions import ControllerCode, fl_code, nmpc_code, observer_code, pid_code
from .loader import CompiledFunction, CompiledLibrary
from .sources import generate_sources
from .templates import DEFAULT_CFLAGS


def default_cflags() -> str:
    """Compiler flags of the C backend (``$MAGLEV_CODEGEN_CFLAGS`` or :data:`DEFAULT_CFLAGS`)."""
    return os.environ.get("MAGLEV_CODEGEN_CFLAGS", DEFAULT_CFLAGS)


def compile_codes(codes: list[ControllerCode], cflags: str | None = None, progress: bool = True) -> BuildResult:
    """Generate and build (or fetch from the cache) a library holding ``codes``."""
    flags = cflags if cflags is not None else default_cflags()
    return build_cached(generate_sources(codes, flags), flags, progress=progress)


class _Timed:
    """A :class:`CompiledFunction` that remembers how long its last C call took [µs].

    ``last_us`` is wall-clock time, ``last_cpu_us`` the thread's CPU time (without
    the time the OS gave to other processes).
    """

    def __init__(self, fn: CompiledFunction):
        self.fn = fn
        self.last_us = float("nan")
        self.last_cpu_us = float("nan")

    def __call__(self, *inputs) -> list[np.ndarray]:
        fn = self.fn
        for dst, src in zip(fn.args, inputs, strict=True):
            dst[:] = np.ravel(np.asarray(src, dtype=float), order="F")
        c0 = time.thread_time()
        t0 = time.perf_counter()
        fn.call_raw()
        t1 = time.perf_counter()
        self.last_cpu_us = (time.thread_time() - c0) * 1e6
        self.last_us = (t1 - t0) * 1e6
        return fn.res


class CEvaluators:
    """The NMPC's step evaluators on compiled C (a :class:`maglev_ocp.controllers.nmpc.StepEvaluators`).

    Parameters
    ----------
    cflags : str, optional
        Compiler flags (default :func:`default_cflags`).
    progress : bool
        Progress bar while compiling.

    Attributes
    ----------
    builds : dict of str to BuildResult
        The library built for each reference mode.
    """

    backend = "c"

    def __init__(self, cflags: str | None = None, progress: bool = True):
        self.cflags = cflags
        self.progress = progress
        self.builds: dict[str, BuildResult] = {}

    def __call__(self, fns: StepFunctions) -> tuple[CompiledFunction, CompiledFunction]:
        """Generate, build (cached) and load ``nmpc_init``/``nmpc_step`` of ``fns``' design."""
        b = compile_codes([nmpc_code(fns.settings, fns.params, fns.mode)], self.cflags, self.progress)
        self.builds[fns.mode] = b
        lib = CompiledLibrary(b.library)
        return lib.function("nmpc_init"), lib.function("nmpc_step")


def c_evaluators(cflags: str | None = None, progress: bool = True) -> CEvaluators:
    """Evaluators that run an NMPC's step as compiled C: ``NMPC(settings, params, evaluators=c_evaluators())``."""
    return CEvaluators(cflags, progress)


class CompiledFL(FeedbackLinearization):
    """:class:`maglev_ocp.controllers.fl.FeedbackLinearization` whose whole step (observer + law) is compiled C."""

    backend = "c"

    def __init__(
        self,
        settings=None,
        params: Params = NOMINAL,
        Ts: float = k.Ts,
        cflags: str | None = None,
        progress: bool = True,
    ):
        super().__init__(settings, params, Ts)
        if abs(Ts - k.Ts) > 1e-15:
            raise UserError(f"the C backend is generated for Ts = {k.Ts} s, got {Ts}")
        self.build = compile_codes([fl_code(self.settings, params)], cflags, progress)
        lib = CompiledLibrary(self.build.library)
        self._c_init = lib.function("fl_init")
        self._c_step = _Timed(lib.function("fl_step"))
        self._state: np.ndarray | None = None

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start at reading ``y0`` at rest (``fl_init``)."""
        super().reset(y0, ref)
        (st,) = self._c_init(np.asarray(y0.y, dtype=float))
        self._state = st.copy()

    @property
    def adapted_constants(self) -> dict[str, float]:
        """The compiled step's estimate of each adapted constant's relative error (from its state)."""
        names = fl_adapted(self.settings)
        if not names or self._state is None:
            return dict.fromkeys(names, 0.0)
        theta = self._state[fl_state_slices(self.delay, len(names))["adapt"]][: len(names)]
        return {n: float(v) for n, v in zip(names, theta, strict=True)}

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """Observer update and control law in one compiled call (``fl_step``)."""
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        r = (ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot)
        if self._preview is not None:  # the reference when the command computed now takes effect
            r = self._preview.at(y.t)
        u, st, xh, dist, v, fl = self._c_step(self._state, y.y, r, self._p, self._gains)
        self._state = st.copy()
        u = u.copy()
        law_failed = not bool(np.all(np.isfinite(u)))
        if law_failed:  # hold a safe current, flagged (as the Python FL does), never 0 A
            u = self._safe_current(xh)
        else:
            self._u_good = u
        self._u_prev = u
        stats = {
            **law_stats(fl, v, dist, law_failed, int(law_failed)),
            "kernel_us": self._c_step.last_us,
            "kernel_cpu_us": self._c_step.last_cpu_us,
        }
        return ControlOutput(u=u, x_hat=xh.copy(), stats=stats)


class CompiledPID(PIDController):
    """:class:`~maglev_ocp.controllers.pid.PIDController` whose step (observer, schedule, regulators) is compiled C."""

    backend = "c"

    def __init__(
        self,
        params: Params = NOMINAL,
        settings=None,
        Ts: float = k.Ts,
        cflags: str | None = None,
        progress: bool = True,
    ):
        super().__init__(params, settings, Ts)
        if abs(Ts - k.Ts) > 1e-15:
            raise UserError(f"the C backend is generated for Ts = {k.Ts} s, got {Ts}")
        self.build = compile_codes([pid_code(self.settings, params)], cflags, progress)
        lib = CompiledLibrary(self.build.library)
        self._c_init = lib.function("pid_init")
        self._c_step = _Timed(lib.function("pid_step"))
        self._pvec = params.vector()
        self._state: np.ndarray | None = None

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Start at reading ``y0`` at rest (``pid_init``)."""
        (st,) = self._c_init(np.asarray(y0.y, dtype=float), self._pvec)
        if not np.all(np.isfinite(st)):
            raise hover_error(float(y0.y[0]), float(y0.y[1]))
        self._state = st.copy()

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """Observer update, gain schedule and both regulators in one compiled call (``pid_step``)."""
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        r = (ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot)
        if self.lead:  # the model file's lag: the feed-forward's row ahead follows (PIDController.step)
            r = r + (self._preview.at(y.t) if self._preview is not None else r)
        u, st, xh, ueq, flags = self._c_step(self._state, y.y, r, self._pvec)
        self._state = st.copy()
        stats = {
            "i_q_eq": float(ueq[0]),
            "i_d_eq": float(ueq[1]),
            "saturated": bool(flags[0]),
            "kernel_us": self._c_step.last_us,
            "kernel_cpu_us": self._c_step.last_cpu_us,
        }
        if flags[1]:
            stats["fallback"] = 1
        return ControlOutput(u=u.copy(), x_hat=xh.copy(), stats=stats)


class CompiledObserver:
    """The high-gain observer's update as compiled C, with :class:`HighGainObserver`'s interface.

    Parameters
    ----------
    params : Params
        Model parameters of the prediction.
    eps : float
        Observer time constant [s].
    disturbance : bool
        Estimate the acceleration disturbance.
    """

    def __init__(
        self,
        params: Params = NOMINAL,
        eps: float = 4e-3,
        disturbance: bool = True,
        cflags: str | None = None,
        progress: bool = True,
    ):
        self.params = params
        self._p = params.vector()
        self.build = compile_codes([observer_code(eps, disturbance, params)], cflags, progress)
        self._f = _Timed(CompiledLibrary(self.build.library).function("observer_step"))
        self.x_hat = np.zeros(4)
        self.dist = np.zeros(2)

    def reset(self, y0: np.ndarray, x0: np.ndarray | None = None) -> None:
        """Start at rest at the reading ``y0 = (g, d)`` (or at ``x0``)."""
        y0 = np.asarray(y0, dtype=float)
        self.x_hat = np.array([y0[0], 0.0, y0[1], 0.0]) if x0 is None else np.asarray(x0, float).copy()
        self.dist = np.zeros(2)

    def step(self, y: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """Update with reading ``y`` taken after ``u_prev`` was held for one period; returns ``x_hat``."""
        xn, dn = self._f(self.x_hat, self.dist, u_prev, y, self._p)
        self.x_hat = xn.copy()
        self.dist = dn.copy()
        return self.x_hat.copy()

    @property
    def disturbance(self) -> np.ndarray:
        """Estimated acceleration disturbance ``(a_g, a_d)`` [m/s^2]."""
        return self.dist.copy()

    @property
    def last_us(self) -> float:
        """Time of the last C call [µs]."""
        return self._f.last_us


def build_c_controller(ctype: str, settings: Any, params: Params, cflags: str | None = None, progress: bool = True):
    """The runner's hook for ``backend: c``: controller ``ctype`` on its compiled step.

    Parameters
    ----------
    ctype : {"nmpc", "fl", "pid"}
        Controller type.
    settings : NMPCSettings, FLSettings or PIDSettings
        The controller's validated settings.
    params : Params
        What the controller's model believes.

    Raises
    ------
    UserError
        For a controller without a C backend, or when no C compiler / make is available.
    """
    if ctype == "nmpc":
        return NMPC(settings, params, evaluators=c_evaluators(cflags, progress))
    if ctype == "fl":
        return CompiledFL(settings, params, cflags=cflags, progress=progress)
    if ctype == "pid":
        return CompiledPID(params, settings, cflags=cflags, progress=progress)
    raise UserError(f"controller.backend: 'c' is available for nmpc, fl and pid, not for {ctype!r}")


def compile_controller(ctrl, cflags: str | None = None, progress: bool = True):
    """A controller equal to ``ctrl`` (same settings and parameters) running on compiled C."""
    if getattr(ctrl, "backend", None) == "c":
        return ctrl
    name = getattr(ctrl, "name", type(ctrl).__name__)
    if name not in ("nmpc", "fl", "pid"):
        raise UserError(f"no C backend for controller {name!r}")
    return build_c_controller(name, ctrl.settings, ctrl.params, cflags=cflags, progress=progress)


def register_c_backend() -> None:
    """Make ``backend: c`` available to the runner (:func:`maglev_ocp.runner.register_backend`)."""
    register_backend("c", build_c_controller)


__all__ = [
    "CEvaluators",
    "CompiledFL",
    "CompiledObserver",
    "CompiledPID",
    "build_c_controller",
    "c_evaluators",
    "compile_codes",
    "compile_controller",
    "default_cflags",
    "register_c_backend",
]
