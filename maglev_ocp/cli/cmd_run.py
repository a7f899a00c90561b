"""``maglev run``: run closed-loop scenarios against the plant simulator."""

from __future__ import annotations

import argparse
import sys
import traceback
from pathlib import Path

from ..errors import UserError, one_line

EXAMPLES = """examples:
  maglev run scenarios/tour_fl.yaml --out results/run
  maglev run scenarios/*.yaml --out results/all --seed 3
  maglev run scenarios/traverse_20mm_fl.yaml --out /tmp/tr --no-figures"""


#: Files a scenario's result folder has (an existing OUT/<name>/ must hold one to be replaced).
RESULT_FILES: tuple[str, ...] = ("metrics.json", "error.txt", "scenario.yaml")


def register(sub) -> None:
    """Add the ``run`` subcommand."""
    from . import add_command, add_quiet

    p = add_command(
        sub,
        "run",
        help="run closed-loop scenarios (YAML) and check their tolerances",
        description=(
            "Run each scenario in closed loop against the plant simulator (progress bar) and\n"
            "write DIR/<name>/: log.csv (rig-log columns t,g,d,i_q,i_d, then references,\n"
            "true states, estimates, controller statistics), timing.csv (controller step\n"
            "time), metrics.json, scenario.yaml as resolved, positions.png (with the\n"
            "0.1 mm band), currents.png (with the limits) and solver_time.png.\n"
            "Prints a table. Exit code 0 if every tolerance check passes, 1 if one fails\n"
            "(or a scenario could not run), 2 on bad input (checked before anything runs)."
        ),
        example=EXAMPLES.split("\n", 1)[1].strip().splitlines()[0].strip(),
    )
    p.epilog = EXAMPLES
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario YAML file(s)")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder (one subfolder per scenario)")
    p.add_argument("--seed", type=int, default=None, help="replace every scenario's seed")
    p.add_argument("--no-figures", action="store_true", help="skip the figures (faster)")
    add_quiet(p)
    p.add_argument("--details", action="store_true", help="also print each scenario's per-target table")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev run``."""
    from ..output import check_output_dir
    from ..runner import summary_table
    from ..scenario import load_scenario

    if args.seed is not None:
        from . import MAX_SEED, check_count

        check_count("--seed", args.seed, 0, MAX_SEED)
    out = check_output_dir(args.out, replaced=False)  # OUT itself is kept; each OUT/<name>/ is replaced
    # Validate everything first: bad input never leaves half a results folder behind.
    scenarios = [load_scenario(path) for path in args.scenarios]
    names = [s.name for s in scenarios]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise UserError(f"two scenarios share the name {dup[0]!r} (their results would overwrite each other)")
    for sc in scenarios:
        check_output_dir(out / sc.name, f"--out (scenario {sc.name})", expect=RESULT_FILES)
    cache: dict = {}
    rows = []
    ok = True
    for sc in scenarios:
        res, msg = _run_one(sc, out / sc.name, args, cache)
        rows.append((sc.name, res, msg))
        if res is None:
            ok = False
            continue
        ok = ok and res.passed
        if not res.passed:
            why = res.metrics.error or "; ".join(res.metrics.failed_checks) or "run did not finish"
            print(f"maglev run: scenario {sc.name} failed: {one_line(why, 300)}", file=sys.stderr)
        if args.details:
            print(res.table())
            print()
    print(summary_table(rows))
    print(f"results in {out}/")
    return 0 if ok else 1


def _run_one(sc, folder: Path, args: argparse.Namespace, cache: dict):
    """Run one scenario and replace ``folder`` whole with its files; ``(result, None)`` or ``(None, error)``.

    A scenario that crashes is reported and its folder holds ``error.txt`` (the
    traceback), so one scenario's crash never loses the others' results.
    """
    from ..output import atomic_write_text, replace_dir
    from ..runner import run_scenario

    with replace_dir(folder) as tmp:
        try:
            res = run_scenario(sc, seed=args.seed, progress=not args.quiet, cache=cache)
        except UserError:
            raise
        except Exception as err:
            msg = one_line(f"{type(err).__name__}: {err}", 300)
            atomic_write_text(tmp / "error.txt", traceback.format_exc())
            print(f"maglev run: scenario {sc.name} failed: {msg}", file=sys.stderr)
            return None, msg
        res.save(tmp, figures=not args.no_figures)
    return res, None
