"""Campaigns: Monte Carlo robustness studies and parameter sweeps on Dask.

A campaign file (:mod:`.config`) names a base scenario and what varies; it
expands deterministically into runs (:mod:`.expand`), which execute on a
``dask.distributed`` cluster or in-process with resume (:mod:`.execute`), and
end in one summary table with figures (:mod:`.summary`).

Typical use::

    from maglev_ocp.campaign import run_campaign
    res = run_campaign("campaigns/robustness_fl.yaml", "results/campaigns/robustness_fl", workers=2)
    print(res)                    # per-case success rates, settle and step times
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .config import Campaign, load_campaign
from .execute import ExecutionReport, execute, start_cluster, worker_cache
from .expand import RunSpec, expand
from .summary import CampaignSummary, deterministic_columns, summarize

__all__ = [
    "Campaign",
    "CampaignResult",
    "CampaignSummary",
    "ExecutionReport",
    "RunSpec",
    "deterministic_columns",
    "execute",
    "expand",
    "load_campaign",
    "run_campaign",
    "summarize",
    "worker_cache",
]


@dataclass
class CampaignResult:
    """Outcome of :func:`run_campaign`: what this invocation did, and the summary of the whole campaign."""

    report: ExecutionReport
    summary: CampaignSummary

    def save(self, out_dir: str | os.PathLike | None = None, figures: bool = True) -> list[Path]:
        """Write the summary table(s) and figures (default: into the campaign folder)."""
        return self.summary.save(out_dir or self.report.out_dir, figures=figures)

    def __str__(self) -> str:
        return f"{self.report}\n{self.summary}"


def run_campaign(
    campaign: str | os.PathLike | Campaign,
    out_dir: str | os.PathLike,
    *,
    figures: bool = True,
    **execute_options: Any,
) -> CampaignResult:
    """Execute (or resume) a campaign and write its summary.

    Parameters
    ----------
    campaign : path or Campaign
        Campaign file or a loaded campaign.
    out_dir : path
        Campaign folder; finished runs in it are skipped.
    figures : bool
        Also draw the summary figures.
    **execute_options
        Passed on to :func:`.execute.execute`: ``workers``, ``scheduler``, ``limit``,
        ``retry_failed``, ``run_fn``, ``progress``.

    Returns
    -------
    CampaignResult
        Already saved into ``out_dir``.
    """
    camp = campaign if isinstance(campaign, Campaign) else load_campaign(campaign)
    # The worker processes start (and warm up) while this process expands the campaign and checks its folder.
    cluster = start_cluster(
        int(execute_options.get("workers", 1)) if execute_options.get("limit") != 0 else 1,  # --limit 0: none
        execute_options.get("scheduler"),
        runner=execute_options.get("run_fn") is None,
    )
    closing = None
    try:
        base = camp.base_scenario_dict()
        specs = expand(camp, base)  # once: the runs and the summary share it
        report = execute(camp, out_dir, base=base, specs=specs, cluster=cluster, **execute_options)
        if cluster is not None:  # the workers shut down while the summary is drawn and written
            closing = cluster.close(background=True)
        summary = summarize(out_dir, specs, camp.name)
        result = CampaignResult(report, summary)
        result.save(figures=figures)
    finally:
        if closing is not None:
            closing.join()
        elif cluster is not None:
            cluster.close()
    return result
