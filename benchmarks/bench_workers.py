"""Speed figures that used to be wall-clock limits inside tests: the plant's simulation rate and the cost of a
large-array workload in a Dask worker against the same work in-process.

Run::

    .venv/bin/python benchmarks/bench_workers.py                 # 20 repeats of each
    .venv/bin/python benchmarks/bench_workers.py --repeat 50
    .venv/bin/python benchmarks/bench_workers.py --campaign 1000 --repeat 2   # the whole campaign command

Printed for each: median and 99th percentile, and the ratio that matters:

* **plant**: simulated seconds per CPU second of :class:`maglev_ocp.plant.Plant` on the default profile (500
  steps of 1 ms per repeat; process CPU time, so other jobs on a shared machine do not count);
* **workers**: 300 allocations of 4 MB arrays and a product each (what a diagnosis fit does), in a Dask worker of
  :func:`maglev_ocp.parallel.map_ordered` and in this process. Dask's default ``MALLOC_TRIM_THRESHOLD_`` made
  every large array a fresh mapping in the workers (4-20x slower); the workers unset it, so the ratio should be
  about 1 (``tests/test_parallel.py`` checks the environment; the speed is measured here).
* **campaign** (``--campaign N``): the whole command ``maglev campaign COPY --out DIR --workers W --quiet``
  on ``campaigns/robustness_nmpc.yaml`` copied with ``n_runs: N`` (base scenario by its absolute path), on 2
  workers and on 1 (in-process), alternating (2, 1, 1, 2, 2, 1, ...) so that other jobs on a shared machine
  weigh on both; wall time of each command with the 1-minute load average before and after it, the median
  per worker count and their ratio (the speed-up of the whole command). Every command must succeed on every
  run and write the same ``summary.csv`` (its columns that do not depend on timing, byte for byte). An untimed
  command on 2 runs comes first: it compiles the loop's libraries if none are cached for this code version.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import shutil
import subprocess
import sys
import tempfile
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


def _summary_digest(out: Path) -> tuple[int, int, str]:
    """(runs, runs ok, SHA-256 of the summary's columns that do not depend on timing) of a campaign folder."""
    import pandas as pd

    from maglev_ocp.campaign import deterministic_columns

    t = pd.read_csv(out / "summary.csv")
    buf = io.StringIO()
    t[deterministic_columns(list(t.columns))].to_csv(buf, index=False)
    return len(t), int((t["status"] == "ok").sum()), hashlib.sha256(buf.getvalue().encode()).hexdigest()[:16]


def campaign_speed(n_runs: int, repeat: int, keep: Path | None = None) -> list[dict]:
    """Time ``maglev campaign`` on 2 workers and on 1, ``repeat`` times each, alternating; one dict per command."""
    import yaml

    src = ROOT / "campaigns" / "robustness_nmpc.yaml"
    camp = yaml.safe_load(src.read_text())
    camp["n_runs"] = n_runs
    camp["base_scenario"] = str((src.parent / camp["base_scenario"]).resolve())
    work = Path(tempfile.mkdtemp(prefix="maglev-bench-campaign-", dir=keep))
    copy = work / f"robustness_nmpc_{n_runs}.yaml"
    copy.write_text(yaml.safe_dump(camp, sort_keys=False))
    maglev = Path(sys.executable).parent / "maglev"
    rows = []
    try:
        # untimed: compiles the loop's libraries if this code version has none cached yet
        warm = [str(maglev), "campaign", str(copy), "--out", str(work / "warm-up"), "--limit", "2", "--quiet"]
        subprocess.run([*warm, "--workers", "1"], capture_output=True, check=True)
        for r in range(repeat):
            for w in (2, 1) if r % 2 == 0 else (1, 2):
                out = work / f"out-w{w}-r{r}"
                cmd = [str(maglev), "campaign", str(copy), "--out", str(out), "--workers", str(w), "--quiet"]
                load0 = os.getloadavg()[0]
                t0 = time.perf_counter()
                proc = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                load1 = os.getloadavg()[0]
                if proc.returncode:
                    raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-500:]}")
                n, ok, digest = _summary_digest(out)
                rows.append({"workers": w, "repeat": r, "wall_s": wall, "load": (load0, load1), "runs": n, "ok": ok})
                rows[-1]["digest"] = digest
                print(f"| {w} | {r + 1} | {wall:.2f} | {load0:.2f} / {load1:.2f} | {ok} / {n} | {digest} |", flush=True)
                if keep is None:
                    shutil.rmtree(out, ignore_errors=True)
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return rows


def _stats(x: np.ndarray) -> str:
    return f"median {np.median(x):.4g}, p99 {np.percentile(x, 99):.4g}"


def main(argv: list[str] | None = None) -> int:
    """Print the plant's simulation rate and the worker/in-process allocation ratio (or the campaign's speed)."""
    from maglev_ocp.parallel import map_ordered

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=20, choices=range(2, 1001), metavar="N")
    ap.add_argument(
        "--campaign",
        type=int,
        default=None,
        choices=range(1, 100_001),
        metavar="RUNS",
        help="time the whole `maglev campaign` command on RUNS NMPC runs instead (2 vs 1 worker, --repeat each)",
    )
    ap.add_argument("--keep", type=Path, default=None, metavar="DIR", help="keep the campaign folders under DIR")
    args = ap.parse_args(argv)
    if args.campaign is not None:
        print("| workers | repeat | wall of the command [s] | load average (1 min) before / after", end="")
        print(" | runs ok | summary digest |")
        print("|---|---|---|---|---|---|")
        rows = campaign_speed(args.campaign, args.repeat, args.keep)
        med = {w: float(np.median([r["wall_s"] for r in rows if r["workers"] == w])) for w in (1, 2)}
        same = len({r["digest"] for r in rows}) == 1
        print(f"median wall: 1 worker {med[1]:.2f} s, 2 workers {med[2]:.2f} s; speed-up {med[1] / med[2]:.2f}x")
        print(f"summary.csv (columns independent of timing) identical in every command: {same}")
        return 0 if same and all(r["ok"] == r["runs"] for r in rows) else 1
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
