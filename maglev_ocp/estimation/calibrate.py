"""``maglev calibrate``: the seed's procedures and the batch fit on one rig-log dataset.

:func:`calibrate` reads a dataset, estimates the velocities with the
high-gain observer, runs every procedure of :mod:`.procedures` the runs allow
(V.A-V.D, NPFISI at the seed's three eps) and the batch fit of all
parameters (:mod:`.batch`), and returns a :class:`CalibrationResult`. Its
:meth:`~CalibrationResult.save` writes

* ``model.yaml`` - the calibrated constants as a model file (:func:`maglev_ocp.params.write_model_file`;
  a controller loads it with ``controller: {model: model.yaml}``), written only when
  :meth:`CalibrationResult.trust_problems` finds nothing, or marked ``trusted: false`` with the reasons;
* ``calibration.json`` - ``params``, ``stderr``, ``correlation``, ``procedures``, ... (SI units);
* ``tables/`` - Table II, Table III, L1 by gap, cogging, batch (Markdown and CSV);
* ``fig*.png`` - the seed's Fig. 3-9 and the estimator diagnostics.

Which estimate becomes the calibrated value: the batch fit for every
parameter it determines (it uses all runs at once, fits the guides' friction
alongside as a nuisance, and gives standard errors); a parameter the data
does not see keeps the prior's value (or V.C's cogging law) and is reported
as such. The NPFISI tables are the seed's procedures, kept side by side as a
cross-check.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError, UserError
from ..output import atomic_write_text
from ..params import NOMINAL, Params, write_model_file
from .batch import BATCH_PARAMS, BatchResult, BatchSettings, batch_estimate
from .data import runs_from_dataset
from .procedures import (
    MAIN_EPS,
    SEED_EPS,
    CoggingResult,
    FullSpanResult,
    HorizontalResult,
    RunGroups,
    VerticalResult,
    classify,
    procedure_va,
    procedure_vb,
    procedure_vc,
    procedure_vd,
)

#: Relative standard error above which a parameter is reported as weakly determined.
WEAK_REL_STDERR = 0.02
#: Relative standard error above which a calibrated constant is refused (untrusted): 10 %, i.e. a 95 % interval
#: of about ±20 %, wider than the whole spread of the rig's constants the plant profiles assume (C1..C3 within
#: ±2 %, C4 ±10 %): beyond it the data say less about the constant than what is known before calibrating.
MAX_REL_STDERR = 0.10
#: Largest condition number of the estimates' correlation matrix (the information matrix scaled to unit
#: diagonal): 1/sqrt(machine epsilon), about 6.7e7. Beyond it the covariance, whose inverse it is, has lost
#: half of its digits, so the standard errors themselves cannot be trusted (the constants are not separable).
MAX_CONDITION = 1.0 / math.sqrt(float(np.finfo(float).eps))
#: The seed's published Table II and III (for the side-by-side tables).
SEED_TABLE_II = {
    0.001: {"C2": 790.97, "C3": 30.47, "C4": 0.11},
    0.01: {"C2": 791.00, "C3": 30.90, "C4": 0.12},
    0.05: {"C2": 788.98, "C3": 32.44, "C4": 0.18},
}
SEED_TABLE_III = {
    0.001: {"C1": 13.97, "C2": 796.93, "C3": 30.33, "C4": 0.06},
    0.01: {"C1": 14.20, "C2": 796.99, "C3": 31.04, "C4": 0.07},
    0.05: {"C1": 16.23, "C2": 795.01, "C3": 33.44, "C4": 0.15},
}


@dataclass
class CalibrationResult:
    """Everything one calibration produced.

    Attributes
    ----------
    dataset : str
        Dataset folder.
    prior : Params
        Parameters the calibration started from.
    params : Params
        Calibrated parameters.
    stderr : dict
        Standard error of each calibrated parameter (None where not estimated).
    source : dict
        Where each value comes from (``batch``, ``V.C`` or ``prior``).
    groups : RunGroups
        How the runs were used.
    va, vb, vc, vd : results or None
        The seed's procedures (None when the dataset does not allow them).
    batch : BatchResult or None
        The batch fit.
    timing : dict
        Seconds per stage.
    """

    dataset: str
    prior: Params
    params: Params
    stderr: dict[str, float | None]
    source: dict[str, str]
    groups: RunGroups
    va: HorizontalResult | None = None
    vb: VerticalResult | None = None
    vc: CoggingResult | None = None
    vd: FullSpanResult | None = None
    batch: BatchResult | None = None
    timing: dict[str, float] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)

    # ------------------------------------------------------------------ views
    @property
    def warnings(self) -> list[str]:
        """Why the calibration may not be trusted: batch fit (solver, bounds, whiteness) and V.C's cogging law."""
        out = list(self.batch.warnings) if self.batch is not None else []
        if self.vc is not None and self.vc.warning:
            out.append(self.vc.warning)
        return out

    @property
    def converged(self) -> bool:
        """The batch fit's solver converged (True without a batch fit: nothing was solved)."""
        return self.batch is None or self.batch.converged

    def weakly_determined(self) -> dict[str, str]:
        """Parameters the data pins down poorly (relative standard error above 2 %, or not seen at all)."""
        out = {}
        for n in BATCH_PARAMS:
            se = self.stderr.get(n)
            v = getattr(self.params, n)
            if self.source.get(n) == "prior":
                out[n] = "not determined by this dataset (prior value kept)"
            elif se is None:
                out[n] = f"from {self.source.get(n)}, without a standard error"
            elif abs(v) > 0 and se / abs(v) > WEAK_REL_STDERR:
                out[n] = f"relative standard error {100 * se / abs(v):.2g} %"
        return out

    def trust_problems(self) -> list[str]:
        """Why the calibrated constants cannot be trusted (empty: they can); one clause per reason.

        Reasons: the batch fit's solver did not converge; a constant at its
        bound (physical or guard, or refitted after crossing its physical bound);
        the information matrix ill-conditioned (condition number of the
        correlation matrix above :data:`MAX_CONDITION`); a relative standard
        error above :data:`MAX_REL_STDERR`. Constants the dataset does not see
        keep the prior's value and are not a reason (the table says so).
        """
        b = self.batch
        if b is None:
            return []
        out = []
        if not b.converged:
            out.append("the batch fit did not converge")
        at_bound = sorted(set(b.info.get("at_bound", [])) | set(b.info.get("below_physical_bound", {}) or {}))
        at_bound = [n for n in at_bound if n in b.names]
        if at_bound:
            out.append(f"{', '.join(at_bound)} at a bound (the data do not fit the model)")
        if len(b.names) > 1:
            corr = np.asarray(b.correlation, dtype=float)
            cond = float(np.linalg.cond(corr)) if np.all(np.isfinite(corr)) else math.inf
            if not cond <= MAX_CONDITION:
                out.append(
                    f"information matrix ill-conditioned (condition number {cond:.2g} > {MAX_CONDITION:.2g}; "
                    "the constants are not separable on these runs)"
                )
        weak = [(n, b.rel_stderr(n)) for n in b.names if not b.rel_stderr(n) <= MAX_REL_STDERR]
        if weak:
            out.append(
                "relative standard error "
                + ", ".join(f"{n} {100 * r:.3g} %" for n, r in weak)
                + f" > {100 * MAX_REL_STDERR:g} %"
            )
        return out

    def least_determined(self) -> str:
        """One line on the parameter with the largest relative standard error and its strongest correlation."""
        if self.batch is None or not self.batch.names:
            return "no batch fit: no standard errors"
        b = self.batch
        n = max(b.names, key=b.rel_stderr)
        i = b.names.index(n)
        others = [j for j in range(len(b.names)) if j != i]
        text = f"least determined: {n}, relative standard error {100 * b.rel_stderr(n):.2g} %"
        if others:
            j = max(others, key=lambda q: abs(b.correlation[i, q]))
            text += f", correlation with {b.names[j]} {b.correlation[i, j]:+.2f}"
        if n == "C4":
            text += (
                " (C4 f4 (i_q^2 + i_d^2) is a small correction at the hover currents, nearly collinear with C3 f3 i_d)"
            )
        return text + ". Standard errors cover noise, not unmodelled effects."

    def correlation(self) -> dict:
        """``{"names": [...], "matrix": [[...]]}`` of the batch estimates (empty without a batch fit)."""
        if self.batch is None:
            return {"names": [], "matrix": []}
        return {"names": list(self.batch.names), "matrix": np.round(self.batch.correlation, 6).tolist()}

    def to_dict(self) -> dict:
        """The content of ``calibration.json`` (SI units)."""
        procs: dict[str, dict] = {}
        for key, res in (("V.A", self.va), ("V.B", self.vb), ("V.C", self.vc), ("V.D", self.vd)):
            procs[key] = (
                {"ran": True, **res.to_dict()}
                if res is not None
                else {"ran": False, "reason": self.skipped.get(key, "")}
            )
        return {
            "format": "maglev-calibration/1",
            "dataset": self.dataset,
            "params": {n: getattr(self.params, n) for n in BATCH_PARAMS},
            "stderr": {n: self.stderr.get(n) for n in BATCH_PARAMS},
            "source": self.source,
            "correlation": self.correlation(),
            "weakly_determined": self.weakly_determined(),
            "least_determined": self.least_determined(),
            "prior": {n: getattr(self.prior, n) for n in BATCH_PARAMS},
            "masses": {"Mh": self.params.Mh, "Mv": self.params.Mv},
            "procedures": procs,
            "batch": self.batch.to_dict() if self.batch is not None else None,
            "converged": self.converged,
            "trusted": not self.trust_problems(),
            "untrusted_because": self.trust_problems(),
            "warnings": self.warnings,
            "runs": self.groups.summary(),
            "timing_s": self.timing,
        }

    def table(self) -> str:
        """Summary table: calibrated value, standard error, source, prior, NPFISI cross-check."""
        vd = self.vd.npfisi.get(MAIN_EPS) if self.vd is not None else None
        lines = [
            "| parameter | calibrated | std. error | rel. [%] | from | prior | V.D NPFISI eps=0.01 |",
            "|---|---|---|---|---|---|---|",
        ]
        for n in BATCH_PARAMS:
            v = getattr(self.params, n)
            se = self.stderr.get(n)
            rel = f"{100 * se / abs(v):.3f}" if se is not None and v else "-"
            sev = f"{se:.3g}" if se is not None else "-"
            cross = f"{vd.final[n]:.5g}" if vd is not None and n in vd.final else "-"
            lines.append(
                f"| {n} | {v:.6g} | {sev} | {rel} | {self.source[n]} | {getattr(self.prior, n):.5g} | {cross} |"
            )
        if self.batch is not None and self.batch.nuisance:
            lines.append("")
            lines.append(
                "Friction of the guides, fitted alongside as nuisance (Coulomb [N], viscous [N s/m]): "
                + ", ".join(
                    f"{n.removeprefix('friction_')} {q['value']:.3g} ± {q['stderr']:.2g}"
                    for n, q in self.batch.nuisance.items()
                )
            )
        weak = self.weakly_determined()
        lines.append("")
        if weak:
            lines.append("Weakly determined:")
            lines += [f"- {n}: {why}" for n, why in weak.items()]
        else:
            lines.append(f"Every parameter has a relative standard error below {100 * WEAK_REL_STDERR:g} %.")
        lines.append(self.least_determined()[0].upper() + self.least_determined()[1:])
        if self.warnings:
            lines.append("")
            lines += [f"WARNING: {w}" for w in self.warnings]
        ran = [k for k, r in (("V.A", self.va), ("V.B", self.vb), ("V.C", self.vc), ("V.D", self.vd)) if r]
        lines.append("")
        lines.append(
            f"Procedures run: {', '.join(ran) or 'none'}"
            + (f"; skipped: {', '.join(f'{k} ({v})' for k, v in self.skipped.items())}" if self.skipped else "")
        )
        return "\n".join(lines)

    def table_ii(self) -> str:
        """Table II (V.B, C2..C4 by eps) beside the seed's."""
        if self.vb is None:
            return "V.B did not run."
        eps = sorted(self.vb.npfisi)
        lines = [
            "| parameter | " + " | ".join(f"eps={e:g} (this) | eps={e:g} (seed)" for e in eps) + " |",
            "|---" * (1 + 2 * len(eps)) + "|",
        ]
        for n in ("C2", "C3", "C4"):
            cells = [
                f"{self.vb.npfisi[e].final[n]:.5g} | {SEED_TABLE_II.get(e, {}).get(n, float('nan')):g}" for e in eps
            ]
            lines.append(f"| {n} | " + " | ".join(cells) + " |")
        return "\n".join(lines)

    def table_iii(self) -> str:
        """Table III (V.D, C1..C4 by eps) beside the seed's, plus the batch fit."""
        if self.vd is None:
            return "V.D did not run."
        eps = sorted(self.vd.npfisi)
        head = "| parameter | " + " | ".join(f"eps={e:g} (this) | eps={e:g} (seed)" for e in eps)
        head += " | batch fit ± std. error |"
        lines = [head, "|---" * (2 + 2 * len(eps)) + "|"]
        for n in ("C1", "C2", "C3", "C4"):
            cells = [
                f"{self.vd.npfisi[e].final[n]:.5g} | {SEED_TABLE_III.get(e, {}).get(n, float('nan')):g}" for e in eps
            ]
            b = "-"
            if self.batch is not None and n in self.batch.values:
                b = f"{self.batch.values[n]:.5g} ± {self.batch.stderr[n]:.2g}"
            lines.append(f"| {n} | " + " | ".join(cells) + f" | {b} |")
        return "\n".join(lines)

    # ----------------------------------------------------------------- output
    def save(self, out: str | os.PathLike, figures: bool = True) -> list[Path]:
        """Write ``model.yaml``, ``calibration.json``, ``tables/`` and the figures into ``out``.

        ``model.yaml`` is marked ``trusted: false`` with the reasons when
        :meth:`trust_problems` finds any (the caller decides whether to write at all).
        """
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        problems = self.trust_problems()
        write_model_file(
            out / "model.yaml",
            self.params,
            written_by=f"maglev calibrate on {Path(self.dataset).name}",
            trusted=not problems,
            untrusted_because=problems,
        )
        written.append(out / "model.yaml")
        atomic_write_text(out / "calibration.json", json.dumps(_plain(self.to_dict()), indent=2))
        written.append(out / "calibration.json")
        tables = {"summary": self.table(), "table_II": self.table_ii(), "table_III": self.table_iii()}
        if self.va is not None:
            tables["L1_fixed_gaps"] = self.va.table()
        if self.vb is not None:
            tables["vertical_V_B"] = self.vb.table()
        if self.vc is not None:
            tables["cogging_V_C"] = self.vc.table()
        if self.vd is not None:
            tables["full_span_V_D"] = self.vd.table()
        if self.batch is not None:
            tables["batch"] = self.batch.table()
        for name, text in tables.items():
            p = out / "tables" / f"{name}.md"
            atomic_write_text(p, text + "\n")
            written.append(p)
            csv_text = _markdown_to_csv(text)
            if csv_text:
                atomic_write_text(p.with_suffix(".csv"), csv_text)
                written.append(p.with_suffix(".csv"))
        if figures:
            from .figures import write_all

            written += write_all(
                out, prior=self.prior, va=self.va, vb=self.vb, vc=self.vc, vd=self.vd, batch=self.batch
            )
        return written


def _plain(v):
    """JSON-safe copy: numpy scalars to floats, NaN to None, tuple keys to strings."""
    if isinstance(v, dict):
        return {str(a): _plain(b) for a, b in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, (np.floating, float)):
        f = float(v)
        return f if math.isfinite(f) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def _markdown_to_csv(md: str) -> str:
    """The first Markdown table of ``md`` as CSV ('' if there is none)."""
    rows = []
    for line in md.splitlines():
        s = line.strip()
        if s.startswith("|") and s.endswith("|"):
            cells = [c.strip() for c in s.strip("|").split("|")]
            if all(set(c) <= set("-: ") for c in cells):
                continue
            rows.append(cells)
        elif rows:
            break
    if not rows:
        return ""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue()


def calibrate(
    dataset: str | os.PathLike,
    *,
    prior: Params = NOMINAL,
    eps_list: tuple[float, ...] = SEED_EPS,
    batch_settings: BatchSettings | None = None,
    progress: bool = True,
) -> CalibrationResult:
    """Calibrate the model on a rig-log dataset (see the module docstring).

    Parameters
    ----------
    dataset : path
        Dataset folder (``maglev-rig-log/1``).
    prior : Params
        Start values (and values of what the data does not determine).
    eps_list : tuple of float
        NPFISI eps values for the seed's tables (must contain 0.01 for V.C).
    batch_settings : BatchSettings, optional
        Batch estimator settings.
    progress : bool
        Show a progress bar over the stages.

    Returns
    -------
    CalibrationResult
    """
    from tqdm import tqdm

    from ..riglog import read_dataset

    eps_list = tuple(sorted(set(float(e) for e in eps_list)))
    if MAIN_EPS not in eps_list:
        raise UserError(f"eps values {list(eps_list)} must include {MAIN_EPS} (the seed's choice, used by V.C)")
    t0 = time.perf_counter()
    timing: dict[str, float] = {"read": 0.0}
    ds = read_dataset(dataset)  # a bad dataset fails here, in one line, before any progress output
    timing["read"] = round(time.perf_counter() - t0, 3)
    if not ds.runs:
        raise DataError(f"{dataset}: no runs")
    stages = ["observer", "V.A", "V.B", "V.C", "V.D", "batch"]
    skipped: dict[str, str] = {}
    with tqdm(total=len(stages), desc="calibrate", unit="stage", disable=not progress) as bar:

        def tick(name: str, t_start: float) -> float:
            timing[name] = round(time.perf_counter() - t_start, 3)
            bar.set_postfix_str(name)
            bar.update(1)
            return time.perf_counter()

        t = time.perf_counter()
        runs = runs_from_dataset(ds, prior)
        groups = classify(runs)
        t = tick("observer", t)
        va = procedure_va(groups, prior, eps_list)
        if va is None:
            skipped["V.A"] = "no run with the gap locked and a constant i_q while d moves"
        t = tick("V.A", t)
        vb = procedure_vb(groups, prior, eps_list)
        if vb is None:
            skipped["V.B"] = "no run with d locked where the cogging vanishes (d = 0) and i_q = 0"
        t = tick("V.B", t)
        vc = procedure_vc(groups, prior, vb)
        if vc is None:
            skipped["V.C"] = (
                "no run with d locked at a cogging peak (3 t1/2) and i_q = 0"
                if not groups.hover_cog
                else "needs V.B (runs with d locked at 0)"
            )
        t = tick("V.C", t)
        vd = procedure_vd(groups, prior, vc, eps_list)
        if vd is None:
            skipped["V.D"] = "no run with both axes free"
        t = tick("V.D", t)
        batch = None
        try:
            batch = batch_estimate(runs, prior, batch_settings)
        except ValueError as err:
            skipped["batch"] = str(err)
        t = tick("batch", t)

    # calibrated values: batch where it determined the parameter, else V.C's cogging law, else the prior
    values = {n: getattr(prior, n) for n in BATCH_PARAMS}
    stderr: dict[str, float | None] = {n: None for n in BATCH_PARAMS}
    source = {n: "prior" for n in BATCH_PARAMS}
    if batch is not None:
        for n in batch.names:
            values[n], stderr[n], source[n] = batch.values[n], batch.stderr[n], "batch"
    if vc is not None and math.isfinite(vc.xi0):
        for n, v in (("xi0", vc.xi0), ("ell", vc.ell)):
            if source[n] == "prior":
                values[n], source[n] = v, "V.C"
    params = prior.with_(**values)
    timing["total"] = round(time.perf_counter() - t0, 3)
    return CalibrationResult(
        str(ds.folder), prior, params, stderr, source, groups, va, vb, vc, vd, batch, timing, skipped
    )


__all__ = ["CalibrationResult", "calibrate"]
