"""The C backend: controllers whose step is the generated code, compiled and loaded.

``backend: c`` in a scenario means the closed loop runs on the very code the
rig would run. The hook for the scenario runner is :func:`build_c_controller`
(same arguments as the Python constructors)::

    from maglev_ocp.codegen.backend import build_c_controller
    ctrl = build_c_controller("nmpc", settings, params)      # or "fl"

:func:`compile_controller` does the same for an existing Python controller
object. Each compiled controller generates the C of its step Function(s)
(:mod:`maglev_ocp.codegen.functions`), builds it in the content-hash cache
(:func:`maglev_ocp.codegen.build.build_cached`; compiled once per design and
machine) and calls it through ctypes (:mod:`maglev_ocp.codegen.loader`). The
Python glue around the call (reference matrix, statistics) is the Python
controller's own, so the two backends feed identical inputs to the same
Function; ``stats["kernel_us"]`` is the wall-clock time of the C call alone,
``stats["kernel_cpu_us"]`` its thread CPU time.

Compiler flags: ``cflags`` argument, else ``$MAGLEV_CODEGEN_CFLAGS``, else
:data:`maglev_ocp.codegen.templates.DEFAULT_CFLAGS`.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from .. import constants as k
from ..blocks import ControlOutput, Measurement, Reference
from ..errors import UserError
from ..params import NOMINAL, Params
from .build import BuildResult, build_cached
from .functions import ControllerCode, fl_code, nmpc_code, observer_code
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
    """A :class:`CompiledFunction` that remembers how long its last C call took [us].

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


def _nmpc_class():
    from controllers.nmpc import NMPC

    class CompiledNMPC(NMPC):
        """:class:`controllers.nmpc.NMPC` whose ``nmpc_init``/``nmpc_step`` run as compiled C.

        Parameters
        ----------
        settings : NMPCSettings
            As for the Python NMPC (``backend`` is ignored).
        params : Params
            What the controller's model believes.
        cflags : str, optional
            Compiler flags.
        progress : bool
            Progress bar while compiling.
        """

        backend = "c"

        def __init__(self, settings=None, params: Params = NOMINAL, cflags: str | None = None, progress: bool = True):
            from controllers.nmpc import NMPCSettings

            settings = settings or NMPCSettings()
            super().__init__(settings.model_copy(update={"backend": "python"}), params)
            self.cflags = cflags
            self.progress = progress
            self.builds: dict[str, BuildResult] = {}
            self._libs: dict[str, tuple[CompiledFunction, _Timed]] = {}

        def compile(self, mode: str) -> BuildResult:
            """Generate and build the step of reference mode ``mode`` (cached); returns the build."""
            if mode not in self.builds:
                b = compile_codes([nmpc_code(self.settings, self.params, mode)], self.cflags, self.progress)
                lib = CompiledLibrary(b.library)
                self._libs[mode] = (lib.function("nmpc_init"), _Timed(lib.function("nmpc_step")))
                self.builds[mode] = b
            return self.builds[mode]

        def _functions(self, mode: str):
            super()._functions(mode)  # layout and the CasADi Functions (kept for inspection)
            self.compile(mode)
            self._init, self._step = self._libs[mode]

        def step(self, y: Measurement, ref: Reference) -> ControlOutput:
            """One control period on the compiled step (see :meth:`NMPC.step`)."""
            out = super().step(y, ref)
            out.stats["kernel_us"] = self._step.last_us
            out.stats["kernel_cpu_us"] = self._step.last_cpu_us
            return out

    return CompiledNMPC


def _fl_class():
    from controllers.fl import FeedbackLinearization

    class CompiledFL(FeedbackLinearization):
        """:class:`controllers.fl.FeedbackLinearization` whose whole step (observer + law) is compiled C."""

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

        def step(self, y: Measurement, ref: Reference) -> ControlOutput:
            """Observer update and control law in one compiled call (``fl_step``)."""
            if self._state is None:
                raise RuntimeError("call reset() before step()")
            r = (ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot)
            u, st, xh, dist, v, fl = self._c_step(self._state, y.y, r, self._p, self._gains)
            self._state = st.copy()
            u = u.copy()
            self._u_prev = u
            stats = {
                "unreachable": int(fl[0]),
                "sat_g": int(fl[1]),
                "sat_d": int(fl[2]),
                "v_g": float(v[0]),
                "v_d": float(v[1]),
                "dist_g": float(dist[0]),
                "dist_d": float(dist[1]),
                "solver_failure": 0,
                "fallback": 0,
                "kernel_us": self._c_step.last_us,
                "kernel_cpu_us": self._c_step.last_cpu_us,
            }
            return ControlOutput(u=u, x_hat=xh.copy(), stats=stats)

    return CompiledFL


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
        """Time of the last C call [us]."""
        return self._f.last_us


def build_c_controller(ctype: str, settings: Any, params: Params, cflags: str | None = None, progress: bool = True):
    """The runner's hook for ``backend: c``: controller ``ctype`` on its compiled step.

    Parameters
    ----------
    ctype : {"nmpc", "fl"}
        Controller type (``pid`` has no CasADi step Function, hence no C backend).
    settings : NMPCSettings or FLSettings
        The controller's validated settings.
    params : Params
        What the controller's model believes.

    Raises
    ------
    UserError
        For a controller without a C backend, or when no C compiler / make is available.
    """
    if ctype == "nmpc":
        return _nmpc_class()(settings, params, cflags=cflags, progress=progress)
    if ctype == "fl":
        return _fl_class()(settings, params, cflags=cflags, progress=progress)
    raise UserError(
        f"controller.backend: 'c' is available for nmpc and fl, not for {ctype!r} "
        "(its law is numeric Python, not a CasADi Function)"
    )


def compile_controller(ctrl, cflags: str | None = None, progress: bool = True):
    """A controller equal to ``ctrl`` (same settings and parameters) running on compiled C."""
    if getattr(ctrl, "backend", None) == "c":
        return ctrl
    name = getattr(ctrl, "name", type(ctrl).__name__)
    if name not in ("nmpc", "fl"):
        raise UserError(f"no C backend for controller {name!r}")
    return build_c_controller(name, ctrl.settings, ctrl.params, cflags=cflags, progress=progress)


__all__ = ["CompiledObserver", "build_c_controller", "compile_codes", "compile_controller", "default_cflags"]
