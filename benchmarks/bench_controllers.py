"""Step time of each controller and backend over a closed-loop scenario (the same as ``maglev bench``).

Run::

    .venv/bin/python benchmarks/bench_controllers.py                       # table
    .venv/bin/python benchmarks/bench_controllers.py --json --out bench.json

All options are those of ``maglev bench`` (see ``maglev bench --help``).
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    """Run ``maglev bench`` with these arguments."""
    from maglev_ocp.cli import main as maglev

    return maglev(["bench", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
