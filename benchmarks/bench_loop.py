"""Wall time of whole scenarios: the Python closed loop against the compiled loop, with their agreement.

Run::

    .venv/bin/python benchmarks/bench_loop.py                        # NMPC and FL, 1 s scenario, 20 repeats
    .venv/bin/python benchmarks/bench_loop.py --controllers nmpc --repeat 50 --duration 1.0

For each controller, the same scenario (default rig profile: noise, quantization, limits, stops,
friction, amplifier lag; a hover and two moves lasting ``--duration`` seconds in all) runs
``--repeat`` times on each loop, interleaved: the Python loop
(:func:`maglev_ocp.runner.run_scenario`, controller on ``backend: c``) and the compiled loop
(:func:`maglev_ocp.codegen.loop_c.run_scenario_compiled`). Printed: median and p99 of the wall time
of a whole scenario (plan, loop, metrics; the one-time compilation excluded: it is cached by content
hash and done before timing), the speed-up, and the largest difference between the two logs.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))


def scenario(ctype: str, duration: float) -> dict:
    """A hover and two moves, ``duration`` seconds in all, on the default rig profile."""
    h = duration / 3
    return {
        "name": f"bench_loop_{ctype}",
        "seed": 3,
        "controller": {"type": ctype, "backend": "c"},
        "plant": {"profile": "default"},
        "targets": [
            {"g": 0.020, "d": 0.000, "hold": h},
            {"g": 0.017, "d": 0.020, "hold": h},
            {"g": 0.022, "d": -0.010, "hold": duration - 2 * h},
        ],
    }


def max_difference(a: dict, b: dict) -> float:
    """Largest absolute difference between two logs' numeric columns."""
    worst = 0.0
    for key, x in a.items():
        if x.dtype == object:
            continue
        d = np.abs(x - b[key])
        d = d[~np.isnan(d)]
        worst = max(worst, float(d.max()) if d.size else 0.0)
    return worst


def main(argv: list[str] | None = None) -> int:
    """Time both loops per controller and print the table."""
    from maglev_ocp.codegen.loop_c import run_scenario_compiled
    from maglev_ocp.runner import run_scenario
    from maglev_ocp.scenario import scenario_from_dict

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--controllers", nargs="+", default=["nmpc", "fl"])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--duration", type=float, default=1.0, help="scenario length [s]")
    args = ap.parse_args(argv)
    rows = []
    for ctype in args.controllers:
        sc = scenario_from_dict(scenario(ctype, args.duration))
        py, cc = run_scenario(sc, progress=False), run_scenario_compiled(sc)  # builds, caches, warms up
        diff = max_difference(py.columns, cc.columns)
        t_py, t_cc = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            run_scenario(sc, progress=False)
            t_py.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            run_scenario_compiled(sc)
            t_cc.append(time.perf_counter() - t0)
        rows.append((ctype, len(cc.columns["t"]), np.array(t_py) * 1e3, np.array(t_cc) * 1e3, diff))
    head = (
        f"{'controller':<10} {'steps':>6} {'python med/p99 [ms]':>20} {'compiled med/p99 [ms]':>22} "
        f"{'speed-up':>9} {'max |diff|':>11}"
    )
    print(head)
    print("-" * len(head))
    for ctype, n, tp, tc, diff in rows:
        print(
            f"{ctype:<10} {n:>6} {np.median(tp):>9.1f} / {np.percentile(tp, 99):>7.1f} "
            f"{np.median(tc):>10.1f} / {np.percentile(tc, 99):>8.1f} {np.median(tp) / np.median(tc):>8.1f}x "
            f"{diff:>11.1e}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
