"""``maglev campaign``: Monte Carlo robustness studies and sweeps on Dask, with resume."""

from __future__ import annotations

import argparse
import os
import sys


def register(sub) -> None:
    """Add the ``campaign`` subcommand."""
    from . import add_command, add_quiet

    p = add_command(
        sub,
        "campaign",
        help="run a campaign of closed-loop runs (robustness, sweeps) on Dask",
        description=(
            "Expand CAMPAIGN.yaml (a base scenario and what varies: parameter perturbations,\n"
            "seeds, random targets, controller settings on a grid) into runs, execute them on a\n"
            "local Dask cluster of N worker processes (or a remote scheduler), one folder per run\n"
            "under DIR/runs/, and write DIR/summary.csv (+ .parquet), DIR/by_case.csv and figures.\n"
            "Runs already finished in DIR are skipped, so the same command resumes a stopped\n"
            "campaign; a run that raises is recorded as failed and the campaign goes on."
        ),
        example="maglev campaign campaigns/robustness_fl.yaml --out results/campaigns/robustness_fl --workers 2",
    )
    p.add_argument("campaign", metavar="CAMPAIGN.yaml", help="campaign file")
    p.add_argument("--out", required=True, metavar="DIR", help="campaign folder (created; reused to resume)")
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the local Dask cluster; 1 runs in-process (default: CPU count)",
    )
    where.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786",
    )
    p.add_argument(
        "--limit",
        type=int,
        default=None,
        metavar="K",
        help="execute at most K runs now (the rest on a later invocation)",
    )
    p.add_argument("--retry-failed", action="store_true", help="re-run runs recorded as failed")
    p.add_argument("--plan", action="store_true", help="only print the expansion (cases and runs), run nothing")
    p.add_argument("--no-figures", action="store_true", help="write the summary tables only")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev campaign``."""
    from ..campaign import load_campaign, run_campaign
    from ..campaign.expand import expand, validate_cases
    from ..output import check_output_dir

    camp = load_campaign(args.campaign)  # refuses a campaign above the size limit before expanding
    from . import MAX_CAMPAIGN_LIMIT, MAX_WORKERS, check_count

    if args.workers is not None:
        check_count("--workers", args.workers, 1, MAX_WORKERS)
    if args.limit is not None:
        check_count("--limit", args.limit, 0, MAX_CAMPAIGN_LIMIT)
    if not args.plan:
        check_output_dir(args.out, replaced=False, expect=("campaign.yaml", "plan.csv", "runs"))
    validate_cases(camp, source=str(args.campaign))  # bad settings on the grid: one line now, not per run
    if args.plan:
        specs = expand(camp)
        cases = sorted({(s.case, s.controller, str(s.grid)) for s in specs})
        print(f"campaign {camp.name}: {len(specs)} runs = {camp.n_runs} draws x {len(cases)} cases")
        for c, ctrl, grid in cases:
            print(f"  case {c}: {ctrl} {grid if grid != '{}' else ''}")
        return 0
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    res = run_campaign(
        camp,
        args.out,
        workers=workers,
        scheduler=args.scheduler,
        limit=args.limit,
        retry_failed=args.retry_failed,
        progress=not args.quiet,
        figures=not args.no_figures,
    )
    print(res)
    rep = res.report
    if rep.ran and rep.failed == rep.ran:
        print(
            f"maglev campaign: error: every run of this invocation failed ({rep.failed}); "
            f"see {rep.out_dir}/runs/<run>/run.json",
            file=sys.stderr,
        )
        return 1
    return 0
