"""Wall time of a diagnosis dataset: the generator's runs on the Python loop against the compiled loop.

Run::

    .venv/bin/python benchmarks/bench_generate.py                  # default dataset (6 runs x 10 s), 5 seeds
    .venv/bin/python benchmarks/bench_generate.py --repeat 9 --runs 6 --duration 10

:func:`maglev_ocp.diagnosis.generate.generate_dataset` on the default rig profile with seeds
``1..repeat``, once with ``loop: python`` (:func:`maglev_ocp.loop.run_closed_loop`, the Python PID)
and once with ``loop: compiled`` (:func:`maglev_ocp.codegen.loop_c.run_closed_loop_compiled`),
interleaved, after one warm-up of each (the libraries are built once per machine and cached).
Printed: the median and the extremes of the time per dataset, the speed-up, the largest difference
between the two datasets' columns, and the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    """Time ``--repeat`` datasets on each loop; print the table."""
    from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
    from maglev_ocp.plant import PlantConfig

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="datasets per loop (seeds 1..N)")
    ap.add_argument("--runs", type=int, default=6, help="runs per dataset")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per run")
    args = ap.parse_args(argv)
    cfg = PlantConfig.from_profile("default")
    loops = ("python", "compiled")

    def gen(loop: str, seed: int):
        s = GeneratorSettings(loop=loop, n_runs=args.runs, run_duration=args.duration)
        return generate_dataset(cfg, seed=seed, settings=s)

    for loop in loops:  # warm-up: build or load the libraries
        gen(loop, 0)
    load0 = os.getloadavg()
    times: dict[str, list[float]] = {lp: [] for lp in loops}
    worst = 0.0
    for seed in range(1, args.repeat + 1):
        out = {}
        for loop in loops:
            t0 = time.perf_counter()
            out[loop] = gen(loop, seed)
            times[loop].append(time.perf_counter() - t0)
        for a, b in zip(out["python"].dataset.runs, out["compiled"].dataset.runs, strict=True):
            for key, col in a.columns.items():
                worst = max(worst, float(np.nanmax(np.abs(np.asarray(col) - np.asarray(b.columns[key])))))
    load1 = os.getloadavg()
    print(f"dataset: {args.runs} runs x {args.duration:g} s, default rig profile, {args.repeat} seeds")
    print("| loop | median [s] | min [s] | max [s] |")
    print("|---|---:|---:|---:|")
    for loop in loops:
        t = np.array(times[loop])
        print(f"| {loop} | {np.median(t):.3f} | {t.min():.3f} | {t.max():.3f} |")
    print(f"speed-up {np.median(times['python']) / np.median(times['compiled']):.1f}x, max |diff| {worst:.3g}")
    print(f"load average before {load0[0]:.2f}, after {load1[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
