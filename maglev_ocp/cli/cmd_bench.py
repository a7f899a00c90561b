"""``maglev bench``: time one control step of each controller and backend over a closed-loop scenario."""

from __future__ import annotations

import argparse
import json
import sys

from ..codegen.bench import BACKENDS, CONTROLLER_TYPES, run_bench
from ..errors import UserError
from . import MAX_WARMUP_STEPS, add_quiet, check_count


def register(sub) -> None:
    """Add the ``bench`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "bench",
        help="time one control step per controller (nmpc, fl, pid) and backend (python, c)",
        description=(
            "Run a closed-loop scenario once per controller and backend and time every step after a\n"
            "warm-up: median, p99 and max in microseconds of the controller's step() (as the runner\n"
            "calls it), and for the C backend of the compiled function alone, wall clock and thread\n"
            "CPU time (the C backend compiles the generated code first, cached per design).\n"
            "Without --scenario a built-in 1 s tour of target steps on the default rig is used; the\n"
            "scenario's controller settings apply to its type, the other types use their defaults."
        ),
        example="maglev bench --controllers nmpc,fl --json",
    )
    p.add_argument("--scenario", default=None, metavar="FILE", help="scenario YAML (default: built-in steps)")
    p.add_argument("--controllers", default="nmpc,fl,pid", metavar="LIST", help="subset of nmpc,fl,pid")
    p.add_argument("--backends", default="python,c", metavar="LIST", help="subset of python,c")
    p.add_argument(
        "--warmup",
        type=int,
        default=50,
        metavar="N",
        help=f"steps dropped before timing, 0..{MAX_WARMUP_STEPS} (default 50)",
    )
    p.add_argument("--cflags", default=None, metavar="FLAGS", help="compiler flags of the C backend")
    p.add_argument(
        "--realtime",
        action="store_true",
        help="run the loops under SCHED_FIFO, as a rig's control loop (needs root/CAP_SYS_NICE)",
    )
    p.add_argument("--json", action="store_true", help="print the numbers as JSON instead of the table")
    p.add_argument("--out", default=None, metavar="FILE", help="also write the JSON to FILE")
    add_quiet(p)
    p.set_defaults(handler=run)


def _subset(value: str, allowed: tuple[str, ...], flag: str) -> list[str]:
    items = [s.strip() for s in value.split(",") if s.strip()]
    bad = [s for s in items if s not in allowed]
    if bad or not items:
        raise UserError(f"{flag}: {','.join(bad) or '(empty)'} not among {','.join(allowed)}")
    return list(dict.fromkeys(items))


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev bench``."""
    controllers = _subset(args.controllers, CONTROLLER_TYPES, "--controllers")
    backends = _subset(args.backends, BACKENDS, "--backends")
    check_count("--warmup", args.warmup, 0, MAX_WARMUP_STEPS)
    if args.out is not None:
        from ..output import check_output_file

        check_output_file(args.out)
    scenario = None
    if args.scenario is not None:
        from ..scenario import load_scenario

        scenario = load_scenario(args.scenario)  # bad input: one line, before the timing runs
    res = run_bench(
        scenario,
        controllers,
        backends,
        warmup=args.warmup,
        cflags=args.cflags,
        progress=not (args.json or args.quiet),
        realtime=args.realtime,
    )
    if args.realtime and not res.meta.get("realtime"):
        print("maglev bench: warning: SCHED_FIFO not permitted here; timed at normal priority", file=sys.stderr)
    if args.out:
        res.save(args.out)
    print(json.dumps(res.to_dict(), indent=2) if args.json else res.table())
    return 0
