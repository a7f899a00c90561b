"""A controller as a discrete map ``(m_k, y_k) -> (m_{k+1}, u_k)`` and its linearization at a fixed point.

Every controller of the suite keeps a memory between steps (observer estimate and disturbance, integrators,
last command, the NMPC's warm start) and computes its command from that memory and the reading. The
analysis needs only

* a way to read and write the memory (:class:`MemoryAccess`: named attributes of the controller, e.g.
  ``observer.x_hat``), and
* the controller's public ``step(y, ref)``,

so it works for any controller a user brings: the map's Jacobians are central finite differences of
``step`` with the memory set (:func:`linearize_by_differences`). A controller whose step is one CasADi
Function with the memory as an input and an output (the NMPC's ``step_function``) is linearized exactly
by CasADi's automatic differentiation instead (:func:`linearize_function`).

The fixed point itself is found by running the controller on the noise-free analysis plant at the hover
point until its memory stops changing (:func:`settle`): observer, disturbance estimate, integrators and
warm starts are then where the loop keeps them.
"""

from __future__ import annotations

import functools
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..blocks import Controller, Measurement, Reference
from .plant_model import AnalysisPlant, DelayedPlantSim

#: Memory of the suite's controllers, by controller name: attribute paths read and written as one vector.
MEMORY_PATHS: dict[str, tuple[str, ...]] = {
    "fl": ("observer.x_hat", "observer.dist", "_z", "_u_prev", "_sent"),
    "pid": ("observer.x_hat", "observer.dist", "_int", "_u_prev"),
}


class MemoryAccess:
    """Read and write a controller's memory as one float vector, from attribute paths.

    Parameters
    ----------
    controller : object
        The controller.
    paths : sequence of str
        Dotted attribute paths of float arrays (e.g. ``"observer.x_hat"``) or of deques of equal-size
        arrays (a buffer of commands sent); their concatenation is the memory.
    """

    def __init__(self, controller: Any, paths: Sequence[str]):
        if not paths:
            raise ValueError("a controller's memory needs at least one attribute path")
        self.controller = controller
        self.paths = tuple(paths)
        self._sizes = [np.asarray(self._get(p), dtype=float).size for p in self.paths]

    def _owner(self, path: str) -> tuple[Any, str]:
        *head, last = path.split(".")
        obj = functools.reduce(getattr, head, self.controller) if head else self.controller
        return obj, last

    def _get(self, path: str) -> Any:
        obj, name = self._owner(path)
        return getattr(obj, name)

    @property
    def size(self) -> int:
        """Length of the memory vector."""
        return int(sum(self._sizes))

    def get(self) -> np.ndarray:
        """The memory now (a copy)."""
        return np.concatenate([np.asarray(self._get(p), dtype=float).ravel() for p in self.paths])

    def set(self, m: np.ndarray) -> None:
        """Overwrite the memory with ``m`` (each attribute keeps its shape)."""
        m = np.asarray(m, dtype=float).ravel()
        if m.size != self.size:
            raise ValueError(f"memory has {self.size} entries, got {m.size}")
        i = 0
        for path, n in zip(self.paths, self._sizes, strict=True):
            obj, name = self._owner(path)
            old = getattr(obj, name)
            new = m[i : i + n].reshape(np.shape(np.asarray(old, dtype=float))).copy()
            if isinstance(old, deque):  # keep a buffer a buffer (its length limit included)
                new = deque(list(new), maxlen=old.maxlen)
            setattr(obj, name, new)
            i += n


def memory_access(controller: Any, paths: Sequence[str] | None = None) -> MemoryAccess:
    """The :class:`MemoryAccess` of a controller: ``paths`` if given, else the suite's known layout.

    A controller with a ``state`` vector (the NMPC's memory in and out of its step Function) uses it.
    """
    if paths is None:
        name = getattr(controller, "name", type(controller).__name__)
        if MEMORY_PATHS.get(name):
            paths = MEMORY_PATHS[name]
        elif isinstance(getattr(controller, "state", None), np.ndarray):
            paths = ("state",)
        else:
            raise ValueError(
                f"controller {name!r}: unknown memory layout; pass the attribute paths of its memory "
                "(e.g. paths=['observer.x_hat', '_z'])"
            )
    return MemoryAccess(controller, paths)


@dataclass
class LinearController:
    """Linearized controller ``m+ = A m + B y``, ``u = C m + D y`` (deviations from the fixed point).

    Attributes
    ----------
    A, B, C, D : ndarray
        The map's Jacobians.
    m0 : ndarray
        Memory at the fixed point.
    y0, u0 : ndarray (2,)
        Reading and command at the fixed point.
    residual : float
        ``max |m(m0, y0) - m0|`` (how stationary the fixed point is; memory units).
    method : str
        ``"ad"`` (CasADi automatic differentiation) or ``"fd"`` (central differences of ``step``).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    m0: np.ndarray
    y0: np.ndarray
    u0: np.ndarray
    residual: float
    method: str


def _closure(adj: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Boolean mask of the nodes reachable from ``seeds`` along ``adj[i, j]`` (an edge j -> i)."""
    mask = seeds.copy()
    frontier = seeds.copy()
    while frontier.any():
        new = adj[:, frontier].any(axis=1) & ~mask
        mask |= new
        frontier = new
    return mask


def coupled_memory(ctrl: LinearController, rel_tol: float = 1e-12) -> np.ndarray:
    """Mask of the memory entries that take part in the loop: driven by the reading and seen by the command.

    Structural (the sparsity of the Jacobians, entries below ``rel_tol`` times the largest one count
    as zero): an entry is kept if a chain of nonzero Jacobian entries leads from the reading to it
    and from it to the command.
    """
    big = max(float(np.max(np.abs(ctrl.A), initial=0)), float(np.max(np.abs(ctrl.B), initial=0)), 1e-300)
    A = np.abs(ctrl.A) > rel_tol * big
    reach = _closure(A, (np.abs(ctrl.B) > rel_tol * big).any(axis=1))
    bigc = max(float(np.max(np.abs(ctrl.C), initial=0)), 1e-300)
    seen = _closure(A.T, (np.abs(ctrl.C) > rel_tol * bigc).any(axis=0))
    return reach & seen


def _restrict(ctrl: LinearController, Q: np.ndarray) -> LinearController:
    """The controller on the memory subspace spanned by the orthonormal columns of ``Q``."""
    return LinearController(
        A=Q.T @ ctrl.A @ Q,
        B=Q.T @ ctrl.B,
        C=ctrl.C @ Q,
        D=ctrl.D,
        m0=Q.T @ ctrl.m0,
        y0=ctrl.y0,
        u0=ctrl.u0,
        residual=ctrl.residual,
        method=ctrl.method,
    )


def minimal_part(ctrl: LinearController, rel_tol: float = 1e-12) -> LinearController:
    """The controller without the memory the loop never moves or its command never sees.

    Such memory cannot take part in the loop: a timer or a stored target (``m+ = m``, not driven by
    the reading) and an integrator with zero gain (not seen by the command) only add poles at
    ``z = 1`` that would make the closed loop look unstable. The entries kept are those of
    :func:`coupled_memory` (the structural Kalman decomposition: reachable from the reading and
    observable in the command); the transfer function ``y -> u`` is unchanged. Structural, not
    numerical: an NMPC's warm start spans scales from 1e-6 to 1e4, where a numerical rank decision
    would be arbitrary, while the Jacobian entries of uncoupled memory are exactly zero.
    """
    keep = coupled_memory(ctrl, rel_tol)
    if keep.all():
        return ctrl
    return _restrict(ctrl, np.eye(ctrl.A.shape[0])[:, keep])


def settle(
    controller: Controller,
    plant: AnalysisPlant,
    g: float,
    d: float,
    *,
    n_steps: int = 600,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the controller on the noise-free plant at the hover point ``(g, d)`` to its steady state.

    Returns
    -------
    xa, y, u : ndarray
        Plant state, reading and the controller's command at the last step (the controller's memory is
        left at its steady state).
    """
    sim = DelayedPlantSim(plant)
    xa0, u0 = plant.hover(g, d)
    y = sim.reset(xa0, u0)
    ref = Reference(g, d)
    t = 0.0
    controller.reset(Measurement(t, y.copy()), ref)
    u = u0
    for i in range(n_steps):
        t = i * plant.Ts
        u = np.asarray(controller.step(Measurement(t, y.copy()), ref).u, dtype=float)
        if not np.all(np.isfinite(u)):
            raise RuntimeError(f"controller returned {u} while settling at g = {g * 1e3:.1f} mm, d = {d * 1e3:.1f} mm")
        y = sim.step(u)
    return sim.xa.copy(), y, u


def _step_at(controller: Controller, mem: MemoryAccess, m: np.ndarray, y: np.ndarray, ref: Reference, t: float):
    mem.set(m)
    out = controller.step(Measurement(t, np.asarray(y, dtype=float).copy()), ref)
    return mem.get(), np.asarray(out.u, dtype=float).ravel()


def linearize_by_differences(
    controller: Controller,
    mem: MemoryAccess,
    y0: np.ndarray,
    ref: Reference,
    *,
    t: float = 1.0,
    rel_step: float = 1e-6,
    scale: np.ndarray | None = None,
) -> LinearController:
    """Central finite differences of the controller's ``step`` around its current memory.

    Works for any controller whose memory ``mem`` can read and write. The controller is restored to
    its memory afterwards (other attributes a step changes, e.g. counters, are not restored). The
    step of entry ``j`` is ``rel_step * max(|m_j|, scale_j)``; the default scale is 1e-3 (positions
    in m, currents in A and estimates alike stay well resolved).

    Parameters
    ----------
    controller : Controller
        At its fixed point (see :func:`settle`).
    mem : MemoryAccess
        Its memory.
    y0 : ndarray (2,)
        Reading at the fixed point.
    ref : Reference
        Reference held during the analysis.
    t : float
        Time handed to ``step`` (only time-varying references care).
    """
    m0 = mem.get()
    try:
        m1, u0 = _step_at(controller, mem, m0, y0, ref, t)
        nm = m0.size
        sc = np.full(nm, 1e-3) if scale is None else np.asarray(scale, dtype=float)
        cols_m, cols_u = [], []
        for j in range(nm + 2):
            if j < nm:
                h = rel_step * max(abs(m0[j]), sc[j])
                e = np.zeros(nm)
                e[j] = h
                mp, up = _step_at(controller, mem, m0 + e, y0, ref, t)
                mn, un = _step_at(controller, mem, m0 - e, y0, ref, t)
            else:
                c = j - nm
                h = rel_step * max(abs(y0[c]), 1e-3)
                e = np.zeros(2)
                e[c] = h
                mp, up = _step_at(controller, mem, m0, y0 + e, ref, t)
                mn, un = _step_at(controller, mem, m0, y0 - e, ref, t)
            cols_m.append((mp - mn) / (2 * h))
            cols_u.append((up - un) / (2 * h))
        Jm, Ju = np.column_stack(cols_m), np.column_stack(cols_u)
    finally:
        mem.set(m0)
    return LinearController(
        A=Jm[:, :nm],
        B=Jm[:, nm:],
        C=Ju[:, :nm],
        D=Ju[:, nm:],
        m0=m0,
        y0=np.asarray(y0, dtype=float).copy(),
        u0=u0,
        residual=float(np.max(np.abs(m1 - m0))),
        method="fd",
    )


def linearize_function(
    fn: ca.Function,
    args: Sequence[np.ndarray],
    *,
    memory_in: int,
    memory_out: int,
    reading_in: int,
    reading_slice: slice = slice(0, 2),
    command_out: int = 0,
) -> LinearController:
    """Exact Jacobians of a step Function with the memory as an input and an output (CasADi AD).

    Parameters
    ----------
    fn : casadi.Function
        The controller's step, e.g. the NMPC's ``nmpc_step(state, meas, ref, p) -> (u, state_next, ...)``.
    args : sequence of ndarray
        Its numeric inputs at the fixed point.
    memory_in, memory_out : int
        Index of the memory input and output.
    reading_in : int
        Index of the input that holds the reading; ``reading_slice`` selects ``(g, d)`` in it.
    command_out : int
        Index of the command output ``(i_q, i_d)``.
    """
    syms = [ca.MX.sym(f"a{i}", fn.size_in(i)) for i in range(fn.n_in())]
    outs = fn.call(syms)
    m_sym, y_sym = syms[memory_in], syms[reading_in]
    mn, u = outs[memory_out], outs[command_out]
    jac = ca.Function(
        "step_jacobians",
        syms,
        [ca.jacobian(mn, m_sym), ca.jacobian(mn, y_sym), ca.jacobian(u, m_sym), ca.jacobian(u, y_sym), mn, u],
    )
    vals = [np.asarray(v, dtype=float) for v in jac(*args)]
    A, By, C, Dy, m1, u0 = vals
    m0 = np.asarray(args[memory_in], dtype=float).ravel()
    y0 = np.asarray(args[reading_in], dtype=float).ravel()[reading_slice]
    return LinearController(
        A=A,
        B=By[:, reading_slice],
        C=C,
        D=Dy[:, reading_slice],
        m0=m0,
        y0=y0,
        u0=u0.ravel(),
        residual=float(np.max(np.abs(m1.ravel() - m0))),
        method="ad",
    )


def function_step(controller: Any) -> tuple[ca.Function, dict[str, int]] | None:
    """The controller's step as a CasADi Function with its memory in and out, if it exposes one.

    Recognized: a ``step_function`` attribute with inputs ``(state, meas, ...)`` and outputs
    ``(u, state_next, ...)`` and the memory in ``state`` (the NMPC). Returns the Function and the
    indices for :func:`linearize_function`, or ``None``.
    """
    fn = getattr(controller, "step_function", None)
    if not isinstance(fn, ca.Function) or not isinstance(getattr(controller, "state", None), np.ndarray):
        return None
    names_in, names_out = fn.name_in(), fn.name_out()
    try:
        idx = {
            "memory_in": next(i for i, n in enumerate(names_in) if "state" in n),
            "reading_in": next(i for i, n in enumerate(names_in) if "meas" in n or n == "y"),
            "memory_out": next(i for i, n in enumerate(names_out) if "state" in n),
            "command_out": next(i for i, n in enumerate(names_out) if n == "u"),
        }
    except StopIteration:
        return None
    return fn, idx


class StepRecorder:
    """An evaluator factory that remembers the inputs of the last step call (for exact AD linearization).

    Controllers whose step Function is evaluated by an injected evaluator (the NMPC's
    ``evaluators=`` argument: a factory returning ``(init, step)`` callables) are built with this
    wrapper around their usual factory; after a step, :attr:`last_step_args` are the Function's
    numeric inputs, which :func:`linearize_function` needs.

    Parameters
    ----------
    base : callable
        The evaluator factory to wrap (e.g. ``maglev_ocp.controllers.nmpc.casadi_evaluators``).
    """

    def __init__(self, base: Any):
        self.base = base
        self.backend = getattr(base, "backend", "custom")
        self.last_step_args: list[np.ndarray] | None = None

    def __call__(self, fns: Any) -> tuple[Any, Any]:
        """Evaluators of ``fns``: the base ones, the step one recording its inputs."""
        init, step = self.base(fns)

        def recorded(*args: np.ndarray) -> Any:
            self.last_step_args = [np.array(a, dtype=float, copy=True) for a in args]
            return step(*args)

        return init, recorded


def linearize_recorded(controller: Any, recorder: StepRecorder, y0: np.ndarray) -> LinearController:
    """Exact (AD) linearization of a settled controller from the inputs its last step was called with.

    The memory input is replaced by the controller's memory now (the fixed point) and the reading by ``y0``.
    """
    fs = function_step(controller)
    if fs is None or recorder.last_step_args is None:
        raise ValueError("the controller exposes no step Function with memory in and out, or it has not stepped")
    fn, idx = fs
    args = list(recorder.last_step_args)
    args[idx["memory_in"]] = np.asarray(controller.state, dtype=float).copy()
    meas = args[idx["reading_in"]].copy()
    meas[0:2] = y0
    args[idx["reading_in"]] = meas
    return linearize_function(fn, args, **idx)


def linearize_controller(
    controller: Controller,
    y0: np.ndarray,
    ref: Reference,
    *,
    method: str = "auto",
    paths: Sequence[str] | None = None,
    function_args: Sequence[np.ndarray] | None = None,
) -> LinearController:
    """Linearize a settled controller: AD of its step Function when it has one (and ``method`` allows).

    Parameters
    ----------
    controller : Controller
        At its fixed point.
    y0 : ndarray (2,)
        Reading at the fixed point.
    ref : Reference
        The held reference.
    method : {"auto", "ad", "fd"}
        ``auto``: AD if the controller exposes a step Function and ``function_args`` are given, else FD.
    paths : sequence of str, optional
        Memory attribute paths for FD (default: :func:`memory_access`).
    function_args : sequence of ndarray, optional
        The step Function's numeric inputs at the fixed point (needed for AD).
    """
    fs = function_step(controller)
    if method == "ad" or (method == "auto" and fs is not None and function_args is not None):
        if fs is None or function_args is None:
            raise ValueError(f"controller {getattr(controller, 'name', '?')!r} exposes no step Function for AD")
        fn, idx = fs
        return linearize_function(fn, function_args, **idx)
    return linearize_by_differences(controller, memory_access(controller, paths), y0, ref)


__all__ = [
    "MEMORY_PATHS",
    "LinearController",
    "MemoryAccess",
    "StepRecorder",
    "coupled_memory",
    "function_step",
    "linearize_by_differences",
    "linearize_controller",
    "linearize_function",
    "linearize_recorded",
    "memory_access",
    "minimal_part",
    "settle",
]
