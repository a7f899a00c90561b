"""Closed-loop tracking of the independent rig on scenarios drawn from the third law set (``laws="v3"``).

Draws ``draw(seed, laws="v3")`` for ``--first`` .. ``--first + --n - 1``, generates each dataset (short runs by
default) and prints its kind, the tracking RMS per axis and each effect's peak force from ``truth.json``:
a check that the drawn laws matter and that none destabilises the rig's own controller.

Usage: ``python benchmarks/rigsim_v3_sweep.py [--first 1000] [--n 40] [--runs 2] [--duration 4]``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from maglev_ocp.rigsim import RigSettings, draw, generate


def main() -> None:
    """Generate the drawn scenarios and print one line each."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--first", type=int, default=1000)
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--duration", type=float, default=4.0)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(a.first, a.first + a.n):
            sc = draw(seed, laws="v3")
            settings = RigSettings(n_runs=a.runs, duration=a.duration)
            folder = generate(Path(tmp) / str(seed), sc["effects"], seed, settings)
            tr = json.loads((folder / "truth.json").read_text())
            h = tr["hover_error_rms_m"]
            pk = {n: round(e.get("peak_force_n", 0.0), 2) for n, e in tr["effects"].items()}
            print(f"{seed} {sc['kind']:15s} g {h['g'] * 1e6:6.1f} d {h['d'] * 1e6:6.1f} um  {pk}", flush=True)


if __name__ == "__main__":
    main()
