"""Timing one control step of each controller and backend over a closed-loop scenario (``maglev bench``).

For every controller (``nmpc``, ``fl``, ``pid``) and backend (``python``,
``c``) the scenario is run in closed loop against the plant simulator, and
each step is timed after a warm-up:

* ``median_us``, ``p99_us``, ``max_us``: the controller's ``step()`` as the
  runner calls it (for ``c``: the Python glue plus the compiled call);
* for ``c`` also ``kernel_median_us`` ...: the compiled C function alone
  (what the rig's 1 ms loop pays), and ``kernel_cpu_*``: its thread CPU time
  (``CLOCK_THREAD_CPUTIME_ID``), which leaves out the time the OS gave to other
  processes (on a loaded machine wall-clock tails measure the scheduler, not the code).

``pid``'s C backend is its whole step compiled (:class:`maglev_ocp.codegen.backend.CompiledPID`).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..output import atomic_write_text
from ..runner import build_controller, run_scenario
from ..scenario import Scenario, load_scenario, scenario_from_dict
from .backend import build_c_controller, default_cflags
from .functions import resolve_nmpc_mode

#: Default closed-loop scenario of the benchmark: hover, then steps across the envelope (1.0 s).
DEFAULT_SCENARIO: dict[str, Any] = {
    "name": "bench_steps",
    "description": "maglev bench: hover, then target steps across the envelope (default rig profile)",
    "seed": 11,
    "controller": {"type": "nmpc"},
    "plant": {"profile": "default"},
    "targets": [
        {"g": 0.020, "d": 0.000, "hold": 0.1},
        {"g": 0.016, "d": 0.045, "hold": 0.3},
        {"g": 0.024, "d": -0.045, "hold": 0.3},
        {"g": 0.020, "d": 0.000, "hold": 0.3},
    ],
}

CONTROLLER_TYPES: tuple[str, ...] = ("nmpc", "fl", "pid")
BACKENDS: tuple[str, ...] = ("python", "c")


@contextlib.contextmanager
def realtime_priority(enabled: bool = True, priority: int = 10):
    """Run the block under ``SCHED_FIFO`` (as a rig's control loop runs), restoring the policy after.

    On a shared machine other processes preempt a normal-priority loop for
    milliseconds, which is what wall-clock tails then measure. Needs
    CAP_SYS_NICE (root); yields whether real-time scheduling is in effect.
    """
    if not enabled or not hasattr(os, "sched_setscheduler"):
        yield False
        return
    try:
        old_policy, old_param = os.sched_getscheduler(0), os.sched_getparam(0)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (PermissionError, OSError):
        yield False
        return
    try:
        yield True
    finally:
        os.sched_setscheduler(0, old_policy, old_param)


def stats_us(values: np.ndarray, prefix: str = "") -> dict[str, float]:
    """Median, p99 and max of a timing series [µs] under ``<prefix>median_us`` etc."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {}
    return {
        f"{prefix}median_us": float(np.median(v)),
        f"{prefix}p99_us": float(np.percentile(v, 99)),
        f"{prefix}max_us": float(v.max()),
    }


class StepTimer:
    """Wraps a controller (its other attributes pass through) and times every ``step`` [µs].

    Per step: ``step_us`` (wall clock), ``cpu_us`` (this thread's CPU time) and the step's
    ``kernel_us`` / ``kernel_cpu_us`` statistics (the compiled kernel alone; NaN where a step
    reports none). The CPU clock is read outside the wall-clock interval.
    """

    def __init__(self, ctrl):
        self._ctrl = ctrl
        self.name = ctrl.name
        self.step_us: list[float] = []
        self.cpu_us: list[float] = []
        self.kernel_us: list[float] = []
        self.kernel_cpu_us: list[float] = []

    def __getattr__(self, item):  # set_reference_plan, settings, ... of the wrapped controller
        return getattr(self._ctrl, item)

    def reset(self, y0, ref) -> None:
        self._ctrl.reset(y0, ref)

    def step(self, y, ref):
        c0 = time.thread_time_ns()
        t0 = time.perf_counter()
        out = self._ctrl.step(y, ref)
        t1 = time.perf_counter()
        c1 = time.thread_time_ns()
        self.step_us.append((t1 - t0) * 1e6)
        self.cpu_us.append((c1 - c0) * 1e-3)
        self.kernel_us.append(float(out.stats.get("kernel_us", np.nan)))
        self.kernel_cpu_us.append(float(out.stats.get("kernel_cpu_us", np.nan)))
        return out


@dataclass
class BenchResult:
    """Per controller and backend: timing statistics (see the module docstring).

    Attributes
    ----------
    results : dict
        ``{controller: {backend: {median_us, p99_us, max_us, ...} or None}}``.
    meta : dict
        Scenario name, steps, warm-up, compiler flags, load average.
    """

    results: dict[str, dict[str, dict[str, Any] | None]]
    meta: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The JSON document: ``{"nmpc": {"c": {...}, "python": {...}}, ...}``; ``meta`` is inside each entry."""
        out: dict[str, Any] = {}
        for ctrl, by_backend in self.results.items():
            out[ctrl] = {b: (None if v is None else {**v, "meta": self.meta}) for b, v in by_backend.items()}
        return out

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_dict` as JSON (atomically)."""
        atomic_write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")
        return Path(path)

    def table(self) -> str:
        """Text table: one row per controller and backend."""
        head = (
            f"{'controller':<10} {'backend':<7} {'steps':>6} {'median':>9} {'p99':>9} {'max':>9} "
            f"{'C median':>9} {'C p99':>9} {'C max':>9} {'C cpu p99':>10}"
        )
        lines = [head, f"{'':<25} {'step() [µs]':^29} {'compiled kernel alone [µs]':^40}", "-" * len(head)]

        def f(v):
            return f"{v:9.1f}" if v is not None else f"{'-':>9}"

        for ctrl, by_backend in self.results.items():
            for b, v in by_backend.items():
                if v is None:
                    lines.append(f"{ctrl:<10} {b:<7} {'n/a (no C backend)':>25}")
                    continue
                lines.append(
                    f"{ctrl:<10} {b:<7} {v['n']:6d} {f(v.get('median_us'))} {f(v.get('p99_us'))} "
                    f"{f(v.get('max_us'))} {f(v.get('kernel_median_us'))} {f(v.get('kernel_p99_us'))} "
                    f"{f(v.get('kernel_max_us'))} {f(v.get('kernel_cpu_p99_us')):>10}"
                )
        m = self.meta
        lines.append(
            f"scenario {m.get('scenario')}, {m.get('steps')} steps per run, first {m.get('warmup')} "
            f"dropped; CFLAGS {m.get('cflags')!r}; load average {m.get('loadavg')}; "
            f"{'SCHED_FIFO' if m.get('realtime') else 'normal priority'}"
        )
        return "\n".join(lines)


def run_bench(
    scenario=None,
    controllers=CONTROLLER_TYPES,
    backends=BACKENDS,
    warmup: int = 50,
    cflags: str | None = None,
    progress: bool = True,
    realtime: bool = False,
) -> BenchResult:
    """Time each controller and backend over ``scenario`` (a path, mapping or ``Scenario``; default built in).

    The scenario's own controller settings are used for its controller type;
    the other types run with their default settings on the same targets and plant.
    ``realtime``: run the closed loops under ``SCHED_FIFO`` (:func:`realtime_priority`).
    """
    if scenario is None:
        base = scenario_from_dict(DEFAULT_SCENARIO, "maglev bench (built-in scenario)")
    elif isinstance(scenario, Scenario):
        base = scenario
    elif isinstance(scenario, dict):
        base = scenario_from_dict(scenario)
    else:
        base = load_scenario(scenario)
    flags = cflags if cflags is not None else default_cflags()
    builders = {"c": functools.partial(build_c_controller, cflags=flags, progress=progress)}
    results: dict[str, dict[str, dict[str, Any] | None]] = {}
    steps, rt_used = 0, False
    for ctype in controllers:
        if ctype == base.controller.type:
            sc = base
        else:
            data = base.resolved()
            data["controller"] = {"type": ctype}
            data["name"] = f"{base.name}_{ctype}"
            sc = scenario_from_dict(data, f"{base.source} (controller {ctype})", base.root_dir)
        results[ctype] = {}
        for backend in backends:
            # the controller exactly as the runner builds it for this backend (C: the compiled evaluators)
            data = sc.resolved()
            data["controller"] = {**data["controller"], "backend": backend}
            ctrl = build_controller(scenario_from_dict(data, sc.source, sc.root_dir), builders)
            if hasattr(ctrl, "prepare"):  # build (and for C compile) the reference mode the run uses before timing
                ctrl.prepare(resolve_nmpc_mode(ctrl.settings, sc.reference.shaping))
            rec = StepTimer(ctrl)
            with realtime_priority(realtime) as rt:
                res = run_scenario(sc, controller=rec, progress=progress and not rt, figures=False)
            rt_used = rt
            steps = len(rec.step_us)
            sl = slice(min(warmup, max(steps - 1, 0)), None)
            entry: dict[str, Any] = {"n": len(rec.step_us[sl]), **stats_us(np.array(rec.step_us)[sl])}
            if backend == "c":
                entry.update(stats_us(np.array(rec.kernel_us)[sl], "kernel_"))
                entry.update(stats_us(np.array(rec.kernel_cpu_us)[sl], "kernel_cpu_"))
            entry["all_settled"] = bool(res.metrics.all_settled) if hasattr(res.metrics, "all_settled") else None
            results[ctype][backend] = entry
    meta = {
        "scenario": base.name,
        "steps": steps,
        "warmup": warmup,
        "cflags": flags,
        "loadavg": [round(v, 2) for v in os.getloadavg()],
        "realtime": rt_used,
    }
    return BenchResult(results, meta)


__all__ = [
    "BACKENDS",
    "CONTROLLER_TYPES",
    "DEFAULT_SCENARIO",
    "BenchResult",
    "realtime_priority",
    "run_bench",
    "stats_us",
]
