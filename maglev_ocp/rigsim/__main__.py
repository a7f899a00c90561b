"""``python -m maglev_ocp.rigsim --out DIR --seed N [--effects a,b] [--draw]``: write one dataset."""

from __future__ import annotations

import argparse
import json
import sys
import time

from .draw import LAW_SETS, draw
from .generate import generate
from .laws_v18 import EFFECTS_V18 as LAWS
from .sim import RigSettings


def main(argv: list[str] | None = None) -> int:
    """Generate a dataset on the independent rig; print its expected verdict and the time it took."""
    ap = argparse.ArgumentParser(prog="python -m maglev_ocp.rigsim", description=__doc__)
    ap.add_argument("--out", required=True, help="dataset folder to write")
    ap.add_argument("--seed", type=int, default=0, help="seed of the rig, excitation and noise (and of --draw)")
    ap.add_argument("--effects", default="", help=f"comma-separated effects with default laws ({', '.join(LAWS)})")
    ap.add_argument("--draw", action="store_true", help="draw a random scenario from the seed (ignores --effects)")
    ap.add_argument(
        "--laws",
        choices=LAW_SETS,
        default="all",
        help="with --draw: law families to draw from (old: the first ones; new: issue 27's; all: both; v3, v4, ...: "
        "one later set alone, maglev_ocp.rigsim.laws_vN; default all)",
    )
    ap.add_argument("--runs", type=int, default=6, help="number of runs (default 6)")
    ap.add_argument("--duration", type=float, default=10.0, help="length of each run [s] (default 10)")
    ap.add_argument(
        "--no-nominal-cogging",
        action="store_true",
        help="leave out the cogging of seed eq. (9) (MODEL.md's shared law)",
    )
    args = ap.parse_args(argv)
    names = [n.strip() for n in args.effects.split(",") if n.strip()]
    unknown = [n for n in names if n not in LAWS]
    if unknown:
        print(f"error: unknown effect(s) {unknown}; known: {', '.join(LAWS)}", file=sys.stderr)
        return 2
    effects = draw(args.seed, laws=args.laws)["effects"] if args.draw else {n: None for n in names}
    if args.runs < 1 or not 0.01 <= args.duration <= 3600:
        print("error: --runs must be >= 1 and --duration within 0.01..3600 s", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    folder = generate(
        args.out,
        effects,
        args.seed,
        RigSettings(n_runs=args.runs, duration=args.duration, nominal_cogging=not args.no_nominal_cogging),
    )
    truth = json.loads((folder / "truth.json").read_text())
    print(f"wrote {folder} in {time.perf_counter() - t0:.1f} s; expected verdict: {truth['expected_verdict']}")
    for name, e in truth["effects"].items():
        print(f"  {name} ({e['family']}): peak force {e['peak_force_n']:.3g} N")
    return 0


if __name__ == "__main__":
    sys.exit(main())
