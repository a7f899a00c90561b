"""Speed and agreement of the fits' filter: the polyphase product's two sums over the phases.

The diagnosis's fits spend most of their time filtering Jacobian blocks (:meth:`maglev_ocp.diagnosis.fitdata.
Dataset.filter`: a 401-tap zero-phase FIR, every 8th sample kept). After the dense ``phases x 8`` product, the
phases are summed either as one strided reduction or as shifted slice additions
(:func:`maglev_ocp.diagnosis.fitdata._shifted_sum`, used from ``_SHIFTED_ADDS_MIN_COLUMNS`` columns on). This
benchmark times both on the training runs of one dataset of the library generator (6 runs of 10 s, split as the
diagnosis splits it) for several column counts, interleaved so that a load on the machine weighs on both alike,
and prints the median and 99th percentile of each with the largest difference between their results (0: the
same bits).

Run::

    .venv/bin/python benchmarks/bench_filter.py
    .venv/bin/python benchmarks/bench_filter.py --reps 200 --columns 1 4 8 17 30
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

from maglev_ocp.diagnosis import DiagnoseSettings, fitdata  # noqa: E402
from maglev_ocp.diagnosis.candidates import Dataset  # noqa: E402
from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset  # noqa: E402
from maglev_ocp.diagnosis.selftest import selftest_plant  # noqa: E402
from maglev_ocp.diagnosis.stages.split import split_dataset  # noqa: E402
from maglev_ocp.params import NOMINAL  # noqa: E402


def training_data(seed: int) -> Dataset:
    """The fits' data of one library-generator dataset (no effect, 6 runs of 10 s): its training runs."""
    gen = generate_dataset(selftest_plant("given", {}), NOMINAL, seed=seed, settings=GeneratorSettings())
    split = split_dataset(gen.dataset, DiagnoseSettings())
    return Dataset(split.train, np.array([10.0, 10.0]), split.filt)


def time_both(data: Dataset, k: int, reps: int, rng: np.random.Generator) -> dict[str, float]:
    """Median and p99 [ms] of each sum on ``k`` random columns, and the largest difference of their results."""
    X = rng.standard_normal((len(data.Z), k))
    times: dict[str, list[float]] = {"strided": [], "shifted": []}
    diff = 0.0
    keep = fitdata._SHIFTED_ADDS_MIN_COLUMNS
    try:
        with fitdata.one_blas_thread():
            for _ in range(reps):
                out = {}
                for name, threshold in (("strided", 10**9), ("shifted", 1)):
                    fitdata._SHIFTED_ADDS_MIN_COLUMNS = threshold
                    t0 = time.perf_counter()
                    out[name] = data.filter(X, 1)
                    times[name].append(time.perf_counter() - t0)
                diff = max(diff, float(np.max(np.abs(out["strided"] - out["shifted"]))))
    finally:
        fitdata._SHIFTED_ADDS_MIN_COLUMNS = keep
    row: dict[str, float] = {"max_abs_difference": diff}
    for name, t in times.items():
        row[f"{name}_median_ms"] = 1e3 * float(np.median(t))
        row[f"{name}_p99_ms"] = 1e3 * float(np.percentile(t, 99))
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--columns", type=int, nargs="+", default=[1, 2, 4, 8, 17, 30])
    ap.add_argument("--reps", type=int, default=100)
    ap.add_argument("--seed", type=int, default=11, help="the dataset's seed (a development seed)")
    a = ap.parse_args(argv)
    data = training_data(a.seed)
    rng = np.random.default_rng(a.seed)
    print(f"training runs: {len(data.runs)}, samples: {len(data.Z)}, default from "
          f"{fitdata._SHIFTED_ADDS_MIN_COLUMNS} columns: shifted")  # fmt: skip
    print("| columns | strided median / p99 [ms] | shifted median / p99 [ms] | speed-up (median) | max |diff| |")
    print("|---|---|---|---|---|")
    for k in a.columns:
        r = time_both(data, k, a.reps, rng)
        print(f"| {k} | {r['strided_median_ms']:.2f} / {r['strided_p99_ms']:.2f} | {r['shifted_median_ms']:.2f} / "
              f"{r['shifted_p99_ms']:.2f} | {r['strided_median_ms'] / r['shifted_median_ms']:.2f}x | "
              f"{r['max_abs_difference']:.1e} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
