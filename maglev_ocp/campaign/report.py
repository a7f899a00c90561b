"""Shipped campaigns: tabulate success rates and executions, measure scaling.

:func:`markdown_table` and :func:`executions_table` make the Markdown tables of
``results/campaigns/robustness.md`` (the README quotes them) from campaign
results and their folders; :func:`scaling` runs one campaign afresh on 1, 2,
... workers and tabulates the wall times.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..output import atomic_write_text
from . import CampaignResult, run_campaign
from .config import load_campaign

#: Folder of the shipped campaign files (``campaigns/`` at the repository root).
CAMPAIGN_DIR = Path(__file__).resolve().parents[2] / "campaigns"


def campaign_path(name: str) -> Path:
    """Path of the shipped campaign ``name`` (``campaigns/<name>.yaml``)."""
    return CAMPAIGN_DIR / f"{name}.yaml"


def markdown_table(results: dict[str, CampaignResult]) -> str:
    """Markdown: per campaign and case, runs, success rate (95 % interval), settle and step times."""
    lines = [
        "| campaign | case | runs | failed | success [%] | 95 % interval [%] | settle median / p90 [ms] "
        "| worst RMS median [µm] | step median / worst p99 [µs] |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, res in results.items():
        for _, r in res.summary.by_case().iterrows():
            lines.append(
                f"| {name} | {r['label']} | {r['runs']} | {r['failed']} | {r['success_pct']:.1f} "
                f"| {r['ci95_low_pct']:.1f} to {r['ci95_high_pct']:.1f} "
                f"| {r['settle_median_ms']:.0f} / {r['settle_p90_ms']:.0f} | {r['rms_max_median_um']:.1f} "
                f"| {r['step_median_us']:.0f} / {r['step_p99_max_us']:.0f} |"
            )
    return "\n".join(lines) + "\n"


def executions_table(campaigns_dir: Path, names: tuple[str, ...]) -> str:
    """Markdown: every invocation that ran something (runs, workers, wall time, CPU efficiency, load).

    Step times in the tables are wall-clock measurements of the controller's
    computation: on a machine busy with other work (load average above the
    number of CPUs) they are inflated, which this table makes visible.
    """
    import json

    lines = [
        "| campaign | runs executed | workers | wall time [s] | CPU efficiency | load average (1 min) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name in names:
        p = Path(campaigns_dir) / name / "executions.jsonl"
        for line in p.read_text().splitlines() if p.is_file() else []:
            e = json.loads(line)
            if e.get("ran", 0) > 0:
                lines.append(
                    f"| {name} | {e['ran']} | {e['workers']} | {e['wall_s']:.0f} "
                    f"| {e.get('efficiency', float('nan')):.2f} | {e.get('load_avg_1m', float('nan')):.1f} |"
                )
    return "\n".join(lines) + f"\n\n({os.cpu_count()} CPUs on the machine that wrote this.)\n"


@dataclass
class ScalingResult:
    """Wall time of the same campaign on different numbers of workers."""

    campaign: str
    runs: int
    wall_s: dict[int, float]
    efficiency: dict[int, float]
    load_avg_1m: dict[int, float]

    def table(self) -> str:
        """Markdown table: workers, wall time, speed-up."""
        base = self.wall_s[min(self.wall_s)]
        rows = [
            "| workers | wall time [s] | speed-up | CPU efficiency | load average (1 min) |",
            "|---:|---:|---:|---:|---:|",
        ]
        rows += [
            f"| {w} | {t:.1f} | {base / t:.2f} | {self.efficiency[w]:.2f} | {self.load_avg_1m[w]:.1f} |"
            for w, t in sorted(self.wall_s.items())
        ]
        return f"campaign {self.campaign}, {self.runs} runs\n\n" + "\n".join(rows) + "\n"

    def save(self, path: str | os.PathLike) -> None:
        """Write :meth:`table` (Markdown)."""
        atomic_write_text(path, self.table())


def scaling(
    name_or_path: str | os.PathLike,
    workers: tuple[int, ...] = (1, 2),
    limit: int | None = None,
    progress: bool = False,
    n_runs: int | None = None,
) -> ScalingResult:
    """Run one campaign afresh (temporary folders) on each number of workers; wall time of each.

    ``n_runs`` replaces the campaign's number of runs (more draws of the same
    distributions, from the same root seed), ``limit`` executes only the first ones.

    The wall time includes the cluster start-up and each worker's first builds,
    which is what a user waits for. The CPU efficiency (the runs' CPU time over
    wall time x workers) tells whether each worker had a core of its own: on a
    machine busy with other work it drops, and so does the speed-up.
    """
    path = Path(name_or_path)
    if not path.suffix:
        path = campaign_path(str(name_or_path))
    camp = load_campaign(path)
    if n_runs is not None:
        camp = camp.model_copy(update={"n_runs": int(n_runs)})
    walls: dict[int, float] = {}
    eff: dict[int, float] = {}
    load: dict[int, float] = {}
    n = 0
    for w in workers:
        tmp = Path(tempfile.mkdtemp(prefix=f"maglev-scaling-{camp.name}-"))
        try:
            t0 = time.perf_counter()
            res = run_campaign(camp, tmp, workers=w, limit=limit, progress=progress, figures=False)
            walls[w] = time.perf_counter() - t0
            n = res.report.ran
            eff[w] = res.report.cpu_s / (walls[w] * w)
            load[w] = res.report.load_avg_1m
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return ScalingResult(camp.name, n, walls, eff, load)
