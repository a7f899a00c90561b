"""Speed figures that used to be wall-clock limits inside tests: the plant's simulation rate and the cost of a
large-array workload in a Dask worker against the same work in-process.

Run::

    .venv/bin/python benchmarks/bench_workers.py                 # 20 repeats of each
    .venv/bin/python benchmarks/bench_workers.py --repeat 50

Printed for each: median and 99th percentile, and the ratio that matters:

* **plant**: simulated seconds per CPU second of :class:`maglev_ocp.plant.Plant` on the default profile (500
  steps of 1 ms per repeat; process CPU time, so other jobs on a shared machine do not count);
* **workers**: 300 allocations of 4 MB arrays and a product each (what a diagnosis fit does), in a Dask worker of
  :func:`maglev_ocp.parallel.map_ordered` and in this process. Dask's default ``MALLOC_TRIM_THRESHOLD_`` made
  every large array a fresh mapping in the workers (4-20x slower); the workers unset it, so the ratio should be
  about 1 (``tests/test_parallel.py`` checks the environment; the speed is measured here).
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


def alloc_time(_: int = 0) -> float:
    """Seconds for 300 allocations of 4 MB arrays and a product each."""
    t0 = time.perf_counter()
    x = np.ones(500_000)
    for _ in range(300):
        x = (x * 1.0000001).copy()
    return time.perf_counter() - t0


def plant_rate(repeat: int) -> np.ndarray:
    """Simulated seconds per CPU second of the default-profile plant, one figure per repeat."""
    from maglev_ocp.params import NOMINAL
    from maglev_ocp.plant import Plant, PlantConfig

    plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=0)
    u = np.array([0.0, 1.5])
    out = []
    for _ in range(repeat):
        plant.reset()
        t0 = time.process_time()
        for _ in range(500):
            plant.step(u)
        out.append(0.5 / max(time.process_time() - t0, 1e-9))
    return np.asarray(out)


def _stats(x: np.ndarray) -> str:
    return f"median {np.median(x):.4g}, p99 {np.percentile(x, 99):.4g}"


def main(argv: list[str] | None = None) -> int:
    """Print the plant's simulation rate and the worker/in-process allocation ratio."""
    from maglev_ocp.parallel import map_ordered

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=20, choices=range(2, 1001), metavar="N")
    args = ap.parse_args(argv)
    rate = plant_rate(args.repeat)
    print(f"plant, default profile: simulated s per CPU s: {_stats(rate)}")
    worker = np.asarray(map_ordered(alloc_time, list(range(args.repeat)), workers=2, progress=False))
    here = np.asarray([alloc_time() for _ in range(args.repeat)])
    print(f"allocation workload in a worker [s]: {_stats(worker)}")
    print(f"allocation workload in-process [s]: {_stats(here)}")
    print(f"worker / in-process (medians): {np.median(worker) / np.median(here):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
