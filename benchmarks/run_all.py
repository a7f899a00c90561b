"""Run every benchmark of the suite and print medians and p99s (``make bench``).

Run::

    .venv/bin/python -m benchmarks.run_all                 # all of them
    .venv/bin/python -m benchmarks.run_all --skip-peer     # without the acados comparison
    .venv/bin/python -m benchmarks.run_all --json out.json

1. ``maglev bench`` (:mod:`benchmarks.bench_controllers`): one step of each
   controller (nmpc, fl, pid) and backend (python, c) over the built-in tour;
2. :mod:`benchmarks.bench_nmpc_step`: the NMPC step over the traverse and tour
   scenarios, on the Python and on the C backend;
3. :mod:`benchmarks.peer_acados`: the compiled NMPC step against acados on the
   same OCP instances (skipped, with the reason, when acados is not installed).

Every number is a step time in microseconds (median and p99 after a warm-up);
the C backend is the NMPC given the compiled evaluators, the very object the
runner builds for ``backend: c``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from benchmarks import bench_nmpc_step, peer_acados  # noqa: E402
from maglev_ocp.codegen.bench import run_bench  # noqa: E402


def _controllers(progress: bool) -> dict[str, Any]:
    res = run_bench(progress=progress)
    print("== maglev bench: one step per controller and backend [µs]")
    print(res.table())
    return res.to_dict()


def _nmpc_step(progress: bool) -> dict[str, Any]:
    out = {}
    paths = [ROOT / "scenarios" / s for s in bench_nmpc_step.DEFAULT_SCENARIOS]
    for backend in ("python", "c"):
        r = bench_nmpc_step.bench(paths, backend, progress=progress)
        print(f"\n== NMPC step, backend {backend}: median {r['median_us']:.1f} us, p99 {r['p99_us']:.1f} us")
        print(bench_nmpc_step.table(r))
        out[backend] = r
    return out


def _peer(progress: bool) -> dict[str, Any] | None:
    why = peer_acados.setup_acados()
    if why:
        print(f"\n== peer_acados: skipped: {why}")
        return None
    r = peer_acados.run(progress=progress)
    print(
        f"\n== peer_acados (N = 20): ours median {r.ours['median_us']:.1f} / p99 {r.ours['p99_us']:.1f} us, "
        f"acados median {r.acados_wall['median_us']:.1f} / p99 {r.acados_wall['p99_us']:.1f} us"
    )
    return {"ours": r.ours, "acados": r.acados_wall, "ratio_median": r.ratio_median, "ratio_p99": r.ratio_p99}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks; print their medians and p99s (optionally write them as JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-peer", action="store_true", help="leave out the acados comparison")
    ap.add_argument("--json", default=None, metavar="FILE", help="also write all results as JSON")
    ap.add_argument("--no-progress", action="store_true")
    a = ap.parse_args(argv)
    progress = not a.no_progress
    results: dict[str, Any] = {"controllers": _controllers(progress), "nmpc_step": _nmpc_step(progress)}
    if not a.skip_peer:
        results["peer_acados"] = _peer(progress)
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
