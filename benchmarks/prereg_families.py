"""Misses and named-right rate per rig law family of an independent-rig self-check (the pre-registered checks).

Run::

    python -m benchmarks.prereg_families results/prereg/issue27_v6_result.json

Reads the ``selftest.json`` that ``maglev diagnose selftest --generator independent`` writes (its ``cases``,
each with the drawn effects and their ``family`` in ``truth_params``) and prints, in markdown, every miss with the
families of its truth, and a table of the datasets holding each family and how many of them were named right.
Nothing is computed but counts of what the result file holds: the figures are the check's own.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from maglev_ocp.markdown import md_table  # noqa: E402


def families(case: dict) -> list[str]:
    """``effect family`` of every effect drawn for ``case`` (in the draw's order)."""
    eff = case.get("truth_params", {}).get("effects", {})
    return [f"{name} {e.get('family', 'default')}" for name, e in eff.items() if isinstance(e, dict)]


def markdown(doc: dict) -> str:
    """The misses with their families, then the per-family table."""
    cases = doc["cases"]
    lines = ["Misses, by the truth's law family (from the result's `truth_params`):"]
    for c in cases:
        if not c["right"]:
            fam = ", ".join(f"`{f.split(' ')[0]}` `{f.split(' ')[1]}`" for f in families(c)) or "(none)"
            lines.append(f"- case {c['index']}: {fam} -> `{c['verdict']}`")
    held, right = Counter(), Counter()
    for c in cases:
        for f in set(families(c)):
            held[f] += 1
            right[f] += bool(c["right"])
    rows = [[f"`{f.split(' ')[0]}` {f.split(' ')[1]}", str(held[f]), str(right[f])] for f in sorted(held)]
    table = md_table(["family", "datasets", "named right"], rows)
    return "\n".join([*lines, "", "Named right per law family (datasets holding the family, of them named right):", "",
                      table, ""])  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Print the misses and the per-family table of a self-check result."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("result", type=Path, help="a self-check's selftest.json (or a prereg result .json)")
    args = ap.parse_args(argv)
    print(markdown(json.loads(args.result.read_text())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
