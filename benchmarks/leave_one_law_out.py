"""Leave-one-law-out on the independent rig's first law families (issue 27, "What it must show").

For each law family of :mod:`maglev_ocp.rigsim.laws` the library members matched to it
(:data:`maglev_ocp.diagnosis.selftest_lolo.MATCHED`, with the reason) are excluded from the candidate library
(``DiagnoseSettings.exclude_laws``) and N datasets of that family (alternately alone and in a pair, seeded)
are diagnosed blind. The table (family, excluded members, named right, what was named instead, sizes) goes to
``OUT.md`` and ``OUT.json`` with the command, the seed and the code version. Target: each family named right on
>= 85 % of its datasets.

Run::

    python -m benchmarks.leave_one_law_out --n 10 --seed S --workers 2                  # the full check
    python -m benchmarks.leave_one_law_out --n 2 --seed S --families end_effect/cosine  # a development run

``make check-long`` runs it through ``tests/test_long.py::test_leave_one_law_out`` (a fresh seed per commit).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from maglev_ocp.diagnosis.selftest import SelftestSettings  # noqa: E402
from maglev_ocp.diagnosis.selftest_lolo import (  # noqa: E402
    lolo_markdown,
    reload_document,
    run_leave_one_law_out,
    write_lolo,
)


def code_version() -> str:
    """The checkout's git commit (``+dirty`` with uncommitted changes; ``unknown`` outside git)."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--n", type=int, default=10, help="datasets per rig law family (alternately single and pair)")
    ap.add_argument("--seed", type=int, default=None, help="seed of every draw (one not spent in development)")
    ap.add_argument("--families", nargs="+", default=None, metavar="EFFECT/FAMILY", help="only these families")
    ap.add_argument("--workers", type=int, default=2, help="local worker processes")
    ap.add_argument("--out", default="results/long/leave_one_law_out", help="writes OUT.md and OUT.json")
    ap.add_argument("--rewrite", action="store_true", help="only recompute OUT's table from OUT.json's cases")
    a = ap.parse_args(argv)
    if a.rewrite:
        src = Path(a.out).with_suffix(".json")
        if not src.exists():
            print(f"leave_one_law_out: {src} does not exist", file=sys.stderr)
            return 2
        doc = reload_document(json.loads(src.read_text()))
        write_lolo(doc, a.out)
        print(lolo_markdown(doc))
        return 0
    if a.seed is None:
        print("leave_one_law_out: --seed is required (unless --rewrite)", file=sys.stderr)
        return 2
    if a.n < 1 or a.workers < 1:
        print("leave_one_law_out: --n and --workers must be >= 1", file=sys.stderr)
        return 2
    argv_s = " ".join(argv if argv is not None else sys.argv[1:])
    meta = {
        "command": f"python -m benchmarks.leave_one_law_out {argv_s}".strip(),
        "code_version": code_version(),
        "date": datetime.now(timezone.utc).strftime("%Y-%m-%d"),
    }
    try:
        doc = run_leave_one_law_out(a.n, a.seed, a.families, SelftestSettings(seed=a.seed), a.workers,
                                    out=a.out, meta=meta)  # fmt: skip
    except ValueError as e:
        print(f"leave_one_law_out: {e}", file=sys.stderr)
        return 2
    print(lolo_markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
