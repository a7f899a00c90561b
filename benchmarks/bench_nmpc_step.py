"""Time one NMPC control step over closed-loop scenarios (median, p99 and worst, after warm-up).

Usage::

    .venv/bin/python benchmarks/bench_nmpc_step.py                         # traverse + tour, Python backend
    .venv/bin/python benchmarks/bench_nmpc_step.py --backend c --json      # the compiled step
    .venv/bin/python benchmarks/bench_nmpc_step.py --scenario scenarios/random_nmpc.yaml --horizon 30

The time is the wall time of ``NMPC.step`` as the scenario runner measures it
(the whole step: observer, reference, RTI linearization, Riccati factorization,
ADMM, fallback checks, warm-start shift, plus the Python glue: reading the
reference plan ahead, statistics), the thread's CPU time over the same call,
and ``kernel``: the call of the step Function alone (CasADi evaluation for
``python``, the compiled C through ctypes for ``c``). The machine has 2 cores shared with
whatever else runs: the wall-clock p99 and worst case are sensitive to that
load (preemption), the CPU time much less; the 1-min load average is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SCENARIOS = ("traverse_20mm_nmpc.yaml", "tour_nmpc.yaml")


def _stats(a: np.ndarray) -> dict:
    return {"median_us": float(np.median(a)), "p99_us": float(np.percentile(a, 99)), "max_us": float(a.max())}


def bench(
    scenarios: list[Path], backend: str = "python", horizon: int | None = None, warmup: int = 50, progress: bool = True
) -> dict:
    """Run the scenarios with the NMPC and return step-time statistics [µs].

    Returns
    -------
    dict
        ``{"backend", "horizon", "n_steps", "median_us", "p99_us", "max_us", "per_scenario": {...}}``.
    """
    import maglev_ocp.codegen  # noqa: F401  (registers backend: c with the runner)
    from maglev_ocp.codegen.bench import StepTimer
    from maglev_ocp.config import load_yaml
    from maglev_ocp.runner import build_controller, run_scenario
    from maglev_ocp.scenario import scenario_from_dict

    times, cpus, kers, per = [], [], [], {}
    for path in scenarios:
        data = load_yaml(path)
        ctrl = dict(data.get("controller", {}))
        if ctrl.get("type") != "nmpc":
            raise SystemExit(f"{path}: controller.type must be nmpc")
        ctrl["backend"] = backend
        if horizon is not None:
            ctrl["horizon"] = horizon
        data["controller"] = ctrl
        timed = StepTimer(build_controller(scenario_from_dict(data)))  # its CPU time and kernel_us per step
        res = run_scenario(data, progress=progress, figures=False, controller=timed)
        st = np.asarray(res.step_time_us, float)[warmup:]
        cpu = np.asarray(timed.cpu_us, float)[warmup:]
        ker = np.asarray(timed.kernel_us, float)[warmup:]
        times.append(st)
        cpus.append(cpu)
        kers.append(ker)
        per[res.scenario.name] = {
            "n_steps": int(st.size),
            **_stats(st),
            "cpu": _stats(cpu),
            "kernel": _stats(ker),
            "passed": bool(res.passed),
        }
    allt, allc, allk = np.concatenate(times), np.concatenate(cpus), np.concatenate(kers)
    return {
        "backend": backend,
        "horizon": horizon or 20,
        "n_steps": int(allt.size),
        **_stats(allt),
        "cpu": _stats(allc),
        "kernel": _stats(allk),
        "load_avg_1min": os.getloadavg()[0],
        "per_scenario": per,
    }


def table(r: dict) -> str:
    """Text view of :func:`bench`'s result."""
    lines = [
        f"NMPC step time, backend {r['backend']}, horizon {r['horizon']} "
        f"(1-min load average {r['load_avg_1min']:.2f} on {os.cpu_count()} cores)",
        "median / p99 / max [µs] of: the whole step (wall), its CPU time, the step Function call alone (wall)",
        f"{'scenario':<22} {'steps':>6} {'step (wall)':>22} {'step (CPU)':>22} {'kernel (wall)':>22}",
    ]

    def fmt(d: dict) -> str:
        return f"{d['median_us']:.0f} / {d['p99_us']:.0f} / {d['max_us']:.0f}"

    def row(name: str, n: int, s: dict) -> str:
        return f"{name:<22} {n:6d} {fmt(s):>22} {fmt(s['cpu']):>22} {fmt(s['kernel']):>22}"

    for name, s in r["per_scenario"].items():
        lines.append(row(name, s["n_steps"], s))
    lines.append(row("all", r["n_steps"], r))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--scenario",
        action="append",
        default=None,
        metavar="YAML",
        help="scenario(s) with controller type nmpc (default: traverse_20mm_nmpc, tour_nmpc)",
    )
    ap.add_argument("--backend", choices=("python", "c"), default="python")
    ap.add_argument("--horizon", type=int, default=None)
    ap.add_argument("--warmup", type=int, default=50, help="steps dropped at the start of each run")
    ap.add_argument("--json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    paths = [Path(p) for p in a.scenario] if a.scenario else [ROOT / "scenarios" / s for s in DEFAULT_SCENARIOS]
    r = bench(paths, a.backend, a.horizon, a.warmup, progress=not a.json)
    print(json.dumps(r, indent=2) if a.json else table(r))
    return 0


if __name__ == "__main__":
    sys.exit(main())
