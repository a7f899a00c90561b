"""Summary of a campaign: one row per run, tables per case, figures.

Row columns:

* identity: ``index, run_id, controller, case, draw, seed, status, error, success``;
* ``grid.<key>``: the case's grid point; ``dev.plant.<P>`` / ``dev.belief.<P>``:
  drawn parameter deviations [%];
* ``ov.<key>``: every override applied to the base scenario (nested values
  flattened with dots, lists as JSON);
* ``m.<key>``: every metric of the run, flattened (per-target metrics as
  ``m.targets.<i>.<key>``), plus ``settle_time_max_s`` (slowest target, NaN
  if one never settled) and ``rms_error_max_m`` (worst steady RMS error of
  both axes over the targets);
* ``wall_s``: the run's wall time.

``success`` is the issue's criterion: the run finished, every target settled
within the tolerance, and no stop was hit.

Columns that measure time (``step_time``, ``wall_s``) differ from one execution to
the next; :func:`deterministic_columns` names the others, which are equal
for the same campaign whatever executed it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..output import atomic_write_bytes, atomic_write_text
from .execute import read_run_record, run_dir
from .expand import RunSpec

#: Metric names (in the runner's ``metrics.json``) the summary relies on.
TARGETS_KEY = "targets"
ALL_SETTLED = "all_settled"
STOP_HITS = "stop_hits"
SETTLE_TIME = "settle_time_s"
RMS_KEYS = ("rms_error_g_m", "rms_error_d_m")


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    """Flatten nested dicts (and lists of dicts) into dotted scalar columns."""
    if isinstance(value, dict):
        for k_, v in value.items():
            _flatten(f"{prefix}.{k_}" if prefix else str(k_), v, out)
    elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        for i, v in enumerate(value):
            _flatten(f"{prefix}.{i}", v, out)
    elif isinstance(value, (list, tuple)):
        out[prefix] = json.dumps(value)
    elif value is None:
        out[prefix] = np.nan
    else:
        out[prefix] = value


def _target_list(metrics: dict[str, Any]) -> list[dict[str, Any]]:
    t = metrics.get(TARGETS_KEY)
    if isinstance(t, list):
        return [x for x in t if isinstance(x, dict)]
    if isinstance(t, dict):  # keyed by index
        return [t[k_] for k_ in sorted(t, key=lambda s: int(s) if str(s).isdigit() else str(s))]
    return []


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def run_row(spec: RunSpec, record: dict[str, Any] | None, metrics: dict[str, Any] | None) -> dict[str, Any]:
    """One summary row for a run (``record`` None: not finished yet)."""
    row: dict[str, Any] = {
        "index": spec.index,
        "run_id": spec.run_id,
        "controller": spec.controller,
        "case": spec.case,
        "draw": spec.draw,
        "seed": spec.seed,
        "status": "pending" if record is None else record.get("status", "failed"),
        "error": (record or {}).get("error") or "",
    }
    for key, v in spec.grid.items():
        row[f"grid.{key}"] = json.dumps(v) if isinstance(v, (dict, list)) else v
    for key, v in spec.deviations.items():
        row[f"dev.{key}"] = float(v)
    ov: dict[str, Any] = {}
    for key, v in spec.overrides.items():
        _flatten(key, v, ov)
    row.update({f"ov.{k_}": v for k_, v in ov.items()})
    m = metrics or {}
    flat: dict[str, Any] = {}
    _flatten("", m, flat)
    row.update({f"m.{k_}": v for k_, v in flat.items()})
    targets = _target_list(m)
    st = [_num(t.get(SETTLE_TIME)) if t.get("settled", True) else float("nan") for t in targets]
    row["n_targets"] = len(targets)
    row["settle_time_max_s"] = max(st) if st and not any(math.isnan(x) for x in st) else float("nan")
    rms = [_num(t.get(k_)) for t in targets for k_ in RMS_KEYS]
    rms = [x for x in rms if not math.isnan(x)]
    row["rms_error_max_m"] = max(rms) if rms else float("nan")
    row["success"] = bool(
        row["status"] == "ok" and bool(m.get(ALL_SETTLED, False)) and int(_num(m.get(STOP_HITS, 1)) or 0) == 0
    )
    row["wall_s"] = _num((record or {}).get("wall_s"))
    row["cpu_s"] = _num((record or {}).get("cpu_s"))
    return row


def is_timing_column(name: str) -> bool:
    """True for columns that measure time and change between executions."""
    return name in ("wall_s", "cpu_s") or "step_time" in name or name.endswith("_us") or "wall" in name


def deterministic_columns(columns: list[str]) -> list[str]:
    """Columns that depend only on the campaign (not on which machine ran it, nor when)."""
    return [c for c in columns if not is_timing_column(c)]


def wilson(k_: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a success rate ``k_/n`` (95 % by default)."""
    if n == 0:
        return (float("nan"), float("nan"))
    p = k_ / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (max(0.0, c - h), min(1.0, c + h))


@dataclass
class CampaignSummary:
    """The summary table of a campaign and its figures.

    Attributes
    ----------
    name : str
        Campaign name.
    table : pandas.DataFrame
        One row per run (finished or not), in expansion order.
    """

    name: str
    table: Any

    @property
    def finished(self) -> Any:
        """Rows of finished runs (ok or failed)."""
        return self.table[self.table["status"] != "pending"]

    def case_label(self, row: Any) -> str:
        """Label of a case: controller and its grid point."""
        g = [f"{c.split('.')[-1]}: {_short(str(row[c]))}" for c in self.table.columns if c.startswith("grid.")]
        return f"c{int(row['case'])} {row['controller']}" + (f" ({'; '.join(g)})" if g else "")

    def by_case(self) -> Any:
        """Per-case table: runs, failures, success rate (95 % Wilson interval), settle and step times."""
        import pandas as pd

        t = self.finished
        rows = []
        for case, grp in t.groupby("case", sort=True):
            n = len(grp)
            ok = int(grp["success"].sum())
            lo, hi = wilson(ok, n)
            st = grp["settle_time_max_s"].dropna()
            step = grp["m.step_time_us.median"] if "m.step_time_us.median" in grp else pd.Series(dtype=float)
            p99 = grp["m.step_time_us.p99"] if "m.step_time_us.p99" in grp else pd.Series(dtype=float)
            rows.append(
                {
                    "case": int(case),
                    "label": self.case_label(grp.iloc[0]),
                    "runs": n,
                    "failed": int((grp["status"] == "failed").sum()),
                    "success_pct": 100.0 * ok / n,
                    "ci95_low_pct": 100 * lo,
                    "ci95_high_pct": 100 * hi,
                    "settle_median_ms": 1e3 * float(st.median()) if len(st) else float("nan"),
                    "settle_p90_ms": 1e3 * float(st.quantile(0.9)) if len(st) else float("nan"),
                    "rms_max_median_um": 1e6 * float(grp["rms_error_max_m"].median()),
                    "step_median_us": float(pd.to_numeric(step, errors="coerce").median()),
                    "step_p99_max_us": float(pd.to_numeric(p99, errors="coerce").max()),
                }
            )
        return pd.DataFrame(rows)

    def __str__(self) -> str:
        t = self.by_case()
        if t.empty:
            return f"campaign {self.name}: no finished runs"
        return f"campaign {self.name}:\n" + t.to_string(index=False, float_format=lambda x: f"{x:.1f}")

    def save(self, out_dir: str | os.PathLike, figures: bool = True) -> list[Path]:
        """Write ``summary.csv`` (and ``summary.parquet`` if pyarrow is installed), ``by_case.csv``, figures."""
        out = Path(out_dir)
        written = [out / "summary.csv", out / "by_case.csv"]
        atomic_write_text(written[0], self.table.to_csv(index=False))
        atomic_write_text(written[1], self.by_case().to_csv(index=False))
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            pass
        else:
            import io

            buf = io.BytesIO()
            self.table.astype({c: str for c in self.table.columns if self.table[c].dtype == object}).to_parquet(
                buf, index=False
            )
            atomic_write_bytes(out / "summary.parquet", buf.getvalue())
            written.append(out / "summary.parquet")
        if figures and len(self.finished):
            for name, png in draw_figures(self).items():
                atomic_write_bytes(out / name, png)
                written.append(out / name)
        return written


def summarize(out_dir: str | os.PathLike, specs: list[RunSpec], name: str = "campaign") -> CampaignSummary:
    """Build the summary table from the run folders of ``out_dir`` (any subset may be finished)."""
    import pandas as pd

    rows = []
    for s in specs:
        rec = read_run_record(Path(out_dir), s.run_id)
        metrics = None
        if rec is not None:
            mp = run_dir(Path(out_dir), s.run_id) / "metrics.json"
            metrics = json.loads(mp.read_text()) if mp.is_file() else None
        rows.append(run_row(s, rec, metrics))
    return CampaignSummary(name, pd.DataFrame(rows))


def _short(v: str) -> str:
    """Compact label of a grid value (a JSON mapping becomes ``k=v, ...``)."""
    try:
        obj = json.loads(v)
    except (TypeError, ValueError):
        return v
    if isinstance(obj, dict):
        return ", ".join(f"{k_}={x:g}" if isinstance(x, (int, float)) else f"{k_}={x}" for k_, x in obj.items())
    return v


def _groups(s: CampaignSummary) -> list[tuple[str, Any]]:
    t = s.finished
    return [(s.case_label(g.iloc[0]), g) for _, g in t.groupby("case", sort=True)]


def _per_case_axes(ax, labels: list[str], ylabel: str, title: str) -> None:
    """One x tick per case (slanted when there are many), the y label, the title and a y grid."""
    n = len(labels)
    ax.set_xticks(range(n), labels, rotation=20 if n > 3 else 0, ha="right" if n > 3 else "center", fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, axis="y", alpha=0.3)


def _render(fig, **layout: Any) -> bytes:
    """Lay ``fig`` out (``layout``: ``tight_layout``'s arguments), close it and return it as PNG bytes."""
    import io

    import matplotlib.pyplot as plt

    fig.tight_layout(**layout)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def _vs_columns(s: CampaignSummary) -> list[str]:
    """The varied quantities the summary draws the metrics against (``dev.*`` deviations, ``grid.*`` settings)."""
    return [c for c in s.finished.columns if c.startswith(("dev.", "grid."))]


def _has_tradeoff(s: CampaignSummary) -> bool:
    """Whether the summary has a speed-vs-computation figure (a sweep with step times)."""
    t = s.finished
    return any(c.startswith("grid.") for c in t.columns) and "m.step_time_us.median" in t


def figure_names(s: CampaignSummary) -> list[str]:
    """File names of the summary's figures, in the order :func:`draw_figures` draws them."""
    names = ["success_rate.png", "settle_time.png"] + (["tradeoff.png"] if _has_tradeoff(s) else [])
    return names + [f"vs_{col.replace('.', '_')}.png" for col in _vs_columns(s)]


def draw_figures(s: CampaignSummary, names: Collection[str] | None = None) -> dict[str, bytes]:
    """Figures: success rate and settle-time distribution per case, metrics vs each varied quantity.

    Parameters
    ----------
    s : CampaignSummary
        The summary.
    names : collection of str, optional
        Only these of :func:`figure_names` (default: all).

    Returns
    -------
    dict
        PNG bytes by file name, in the order of :func:`figure_names`.
    """
    import matplotlib

    matplotlib.use("Agg")

    wanted = set(figure_names(s) if names is None else names)
    drawn: dict[str, bytes] = {}
    groups = _groups(s)
    labels = [lab for lab, _ in groups]
    if "success_rate.png" in wanted:
        _success_rate(s, groups, labels, drawn)
    if "settle_time.png" in wanted:
        _settle_time(s, groups, labels, drawn)
    t = s.finished
    if "tradeoff.png" in wanted and _has_tradeoff(s):
        _tradeoff(s, groups, drawn)
    for col in _vs_columns(s):
        if f"vs_{col.replace('.', '_')}.png" in wanted:
            _metrics_vs(s, t, col, groups, drawn)
    return {n: drawn[n] for n in figure_names(s) if n in drawn}


def _success_rate(s: CampaignSummary, groups: list[tuple[str, Any]], labels: list[str], drawn: dict) -> None:
    """Bar per case: the share of successful runs with its 95 % Wilson interval."""
    import matplotlib.pyplot as plt

    n_g = len(groups)
    fig, ax = plt.subplots(figsize=(max(5.0, 0.9 * n_g + 2), 3.8))
    rates, errs = [], [[], []]
    for _, g in groups:
        n, ok = len(g), int(g["success"].sum())
        lo, hi = wilson(ok, n)
        r = 100 * ok / n
        rates.append(r)
        errs[0].append(max(0.0, r - 100 * lo))
        errs[1].append(max(0.0, 100 * hi - r))
    ax.bar(range(n_g), rates, yerr=errs, capsize=4, color="tab:blue", alpha=0.8)
    for i, (_, g) in enumerate(groups):
        ax.text(i, 2, f"n={len(g)}", ha="center", va="bottom", fontsize=8, color="white")
    ax.set_ylim(0, 105)
    _per_case_axes(
        ax,
        labels,
        "success rate [%] (all targets within tolerance, no stop)",
        f"{s.name}: success rate per case (95 % Wilson interval)",
    )
    drawn["success_rate.png"] = _render(fig)


def _settle_time(s: CampaignSummary, groups: list[tuple[str, Any]], labels: list[str], drawn: dict) -> None:
    """Violin per case: the settle times of every settled target of every run."""
    import matplotlib.pyplot as plt

    n_g = len(groups)
    fig, ax = plt.subplots(figsize=(max(5.0, 0.9 * n_g + 2), 3.8))
    data = []
    for _, g in groups:
        cols = [c for c in g.columns if c.startswith("m.targets.") and c.endswith("." + SETTLE_TIME)]
        vals = np.concatenate([np.asarray(g[c], dtype=float) for c in cols]) if cols else np.array([])
        data.append(1e3 * vals[np.isfinite(vals)])
    if any(len(d) for d in data):
        ax.violinplot([d if len(d) else [np.nan] for d in data], positions=range(n_g), showmedians=True)
    _per_case_axes(ax, labels, "settle time per target [ms]", f"{s.name}: settle-time distribution per case")
    drawn["settle_time.png"] = _render(fig)


def _tradeoff(s: CampaignSummary, groups: list[tuple[str, Any]], drawn: dict) -> None:
    """Trade-off of a sweep: per case, median settle time against median controller step time."""
    import matplotlib.pyplot as plt

    n_g = len(groups)
    fig, ax = plt.subplots(figsize=(7.5, 4.4 + 0.16 * n_g))
    for j, (lab, g) in enumerate(groups):
        st = 1e3 * np.nanmedian(np.asarray(g["settle_time_max_s"], dtype=float))
        stp = np.nanmedian(np.asarray(g["m.step_time_us.median"], dtype=float))
        rate = 100 * float(np.mean(np.asarray(g["success"], dtype=bool)))
        ax.scatter([stp], [st], s=40, color=f"C{j % 10}", label=f"{lab} [{rate:.0f} % success]")
        ax.annotate(lab.split()[0], (stp, st), fontsize=7, xytext=(4, 3), textcoords="offset points")
    fig.legend(loc="lower center", fontsize=7, ncol=1 if n_g > 4 else 2, frameon=False)
    ax.set_xlabel("controller step time, median over runs [µs]")
    ax.set_ylabel("slowest settle time, median over runs [ms]")
    ax.set_title(f"{s.name}: speed of motion vs computation per case")
    ax.grid(True, alpha=0.3)
    drawn["tradeoff.png"] = _render(fig, rect=(0, 0.17 * n_g / (4.4 / 0.16 + n_g) * 6 + 0.02, 1, 1))


def _metrics_vs(s: CampaignSummary, t: Any, col: str, groups: list[tuple[str, Any]], drawn: dict) -> None:
    """Metrics against one varied quantity: scatter per case (deviations) or box per value (grid settings)."""
    import matplotlib.pyplot as plt

    n_g = len(groups)
    metrics_y = [
        ("settle_time_max_s", 1e3, "slowest settle time [ms]"),
        ("rms_error_max_m", 1e6, "worst steady RMS error [µm]"),
    ]
    if "m.step_time_us.p99" in t:
        metrics_y.append(("m.step_time_us.p99", 1.0, "controller step time p99 [µs]"))
    fig, axs = plt.subplots(1, len(metrics_y), figsize=(4.2 * len(metrics_y), 3.8), squeeze=False)
    if col.startswith("dev."):
        # Scatter per case against the drawn deviation; o success, x failure.
        for a, (ycol, scale, ylab) in zip(axs[0], metrics_y, strict=True):
            for j, (lab, g) in enumerate(groups):
                x = np.asarray(g[col], dtype=float)
                y = scale * np.asarray(g[ycol], dtype=float)
                ok = np.asarray(g["success"], dtype=bool)
                a.scatter(x[ok], y[ok], s=10, color=f"C{j % 10}", label=lab, alpha=0.7)
                a.scatter(x[~ok], y[~ok], s=18, marker="x", color=f"C{j % 10}", alpha=0.9)
            a.set_xlabel(f"{col[4:]} deviation [%]")
            a.set_ylabel(ylab)
            a.grid(True, alpha=0.3)
        if n_g <= 6:
            axs[0][0].legend(fontsize=7, title="o success, x failure", title_fontsize=7)
    else:
        # Box per grid value (pooled over the other varied settings), in grid order.
        cats = list(dict.fromkeys(str(v) for v in t[col]))
        names = [_short(v) for v in cats]
        for a, (ycol, scale, ylab) in zip(axs[0], metrics_y, strict=True):
            data = []
            for c in cats:
                y = scale * np.asarray(t.loc[t[col].astype(str) == c, ycol], dtype=float)
                data.append(y[np.isfinite(y)] if np.isfinite(y).any() else np.array([np.nan]))
            a.boxplot(data, positions=range(len(cats)), widths=0.5, showfliers=True)
            a.set_xticks(range(len(cats)), names, fontsize=7, rotation=15 if len(cats) > 3 else 0)
            a.set_xlabel(col[5:])
            a.set_ylabel(ylab)
            a.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"{s.name}: metrics vs {col}")
    drawn[f"vs_{col.replace('.', '_')}.png"] = _render(fig)
