"""The run plan a confusable verdict gets: its alternatives from the diagnosis, the design, the files.

When a verdict holds a confusable slot (``a|b``), :func:`write_experiment`
takes each member's fitted candidate (effect set, effect parameters, the model
constants its fit moved; the effects of the verdict's other slots are common to
all alternatives), lets :func:`.experiment.design` choose the excitation that
separates them best against the diagnosis's held-out noise floors, and writes

* ``experiment.yaml``: the run plan (``maglev-run-plan/1``), for ``maglev
  simulate --experiment`` or a rig;
* ``experiment_references/*.csv``: each run's reference, for a rig's own loop;
* a section of ``report.md`` and an ``experiment`` entry of ``report.json``
  naming the excitation, its predicted SNR and why.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

from ..loop.run_plan import RunPlan, write_plan, write_reference_csvs
from ..output import atomic_write_text
from .experiment import Alternative, Design, MenuEntry, Refit, design
from .fit import FitResult
from .library import PRIOR_SD
from .result import Diagnosis

#: Folder (inside the report folder) of the plan's reference CSVs.
REFERENCES_DIR = "experiment_references"


def confusable_slot(d: Diagnosis) -> tuple[str, ...] | None:
    """The verdict's first slot with alternatives, or None."""
    for slot in d.verdict.sets.slots:
        if len(slot) > 1:
            return tuple(slot)
    return None


def _effect_values(fit: FitResult) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """A fit's effect parameters ``{effect: {param: value}}`` and the model constants it moved ``{C1: ...}``."""
    free = {f.key: float(v) for f, v in zip(fit.spec.free, fit.w, strict=True)}
    effect: dict[str, dict[str, float]] = {}
    consts: dict[str, float] = {}
    for key, v in [*free.items(), *fit.spec.fixed, *((a, free[b]) for a, b in fit.spec.ties if b in free)]:
        head, _, name = key.partition(".")
        if head == "p":
            consts[name] = float(v)
        elif name:
            effect.setdefault(head, {})[name] = float(v)
    return effect, consts


def _refits(fits: Sequence[FitResult]) -> tuple[Refit, ...]:
    """What a refit of these fits may move: their free parameters, constants with their prior sd in physical
    units (the fit's own prior, else :data:`.library.PRIOR_SD` relative to the value), effect parameters flat."""
    out: dict[str, Refit] = {}
    for fit in fits:
        for f, v in zip(fit.spec.free, fit.w, strict=True):
            if f.key in out:
                continue
            sd = f.prior[1] if f.prior is not None else None
            if sd is None and f.key.startswith("p."):
                rel = PRIOR_SD.get(f.key[2:])
                sd = None if rel is None else rel * max(abs(float(v)), 1e-12)
            out[f.key] = Refit(f.key, float(f.scale), sd)
    return tuple(out.values())


def alternatives_of(d: Diagnosis, slot: tuple[str, ...]) -> list[Alternative]:
    """Each slot member's fitted candidate, with the verdict's other effects as common members.

    Each carries what a refit on new runs may move (its fit's free parameters and those of the other slots'
    fits, the calibrated constants with their prior) and its fit's ties, for the design's refit
    (:func:`.experiment.score_entry`).
    """
    fits = {s.name: s.fit for s in d.scores if s.fit is not None and s.fit.success}
    final = d.final_score.fit if d.final_score is not None and d.final_score.fit is not None else None
    common_params, _ = _effect_values(final) if final is not None else ({}, {})
    others = [e for e in d.verdict.sets.effects if e not in slot]
    alts = []
    for member in slot:
        fit = fits.get(member)
        if fit is None:
            continue
        eff, consts = _effect_values(fit)
        names = tuple(
            dict.fromkeys([*(n for o in others for n in fits[o].spec.effects if o in fits), *fit.spec.effects])
        )
        params = {**{k: v for k, v in common_params.items() if k in names}, **eff}
        used = [fits[o] for o in others if o in fits] + [fit]
        ties = tuple(t for f in used for t in f.spec.ties)
        alts.append(Alternative(member, names, params, consts, _refits(used), ties))
    return alts


def experiment_markdown(plan: RunPlan, dz: Design) -> str:
    """The report section naming the excitation, its predicted SNR and the runs."""
    lines = [
        "## Experiment to separate the confusable effects",
        "",
        f"The data cannot tell **{' | '.join(plan.slot)}** apart. The excitation that separates them best is "
        f"**{plan.excitation}** (predicted SNR {plan.predicted_snr:.1f} over {plan.duration_s:.0f} s of runs, "
        f"{dz.repeats} pass(es)): {plan.why}.",
        "",
        "SNR after the rival alternative refits its effect parameters and the calibrated constants (prior "
        "sd `PRIOR_SD`) to the other's prediction on the new runs; the last column holds both at their fitted "
        "values.",
        "",
        "| excitation | SNR (one pass) | SNR per minute | vertical | horizontal | SNR, nothing refitted |",
        "|---|---:|---:|---:|---:|---:|",
        *(
            f"| {s.name} | {s.snr:.2f} | {s.snr_per_minute:.2f} | {s.per_channel['vertical']:.2f} | "
            f"{s.per_channel['horizontal']:.2f} | {s.snr_fixed:.2f} |"
            for s in sorted(dz.scores, key=lambda s: -s.snr_per_minute)
        ),
        "",
        "Runs of `experiment.yaml` (references in `experiment_references/`, CSV `t, g_ref, d_ref, g_dot_ref, "
        "d_dot_ref` in s, m, m/s, for the rig's own loop):",
        "",
        *(f"{i + 1}. {r.label()}" for i, r in enumerate(plan.runs[: len(plan.runs) // dz.repeats])),
        "",
        "Next: run it on the rig that gave the data (or `maglev simulate --experiment experiment.yaml --plant "
        "THE_RIG.yaml --out DATA2` on the same plant file, its constants pinned), then "
        "`maglev diagnose run DATA DATA2 --out DIR` decides on both datasets.",
        "",
    ]
    return "\n".join(lines)


def write_experiment(
    d: Diagnosis, out_dir: str | os.PathLike, progress: bool = False, menu: Sequence[MenuEntry] | None = None
) -> RunPlan | None:
    """For a confusable verdict: design the separating experiment and write it (module docstring); else None.

    ``menu`` (default :func:`.experiment.default_menu`) is what the design chooses from.
    """
    slot = confusable_slot(d)
    if slot is None:
        return None
    alts = alternatives_of(d, slot)
    out = Path(out_dir)
    if len(alts) < 2:
        note = (
            "\n## Experiment to separate the confusable effects\n\n"
            f"Not designed: fewer than two of {', '.join(slot)} have a converged fit.\n"
        )
        atomic_write_text(out / "report.md", (out / "report.md").read_text() + note)
        return None
    floors = {c: float(f.floor) for c, f in d.floors.items()}
    for c in ("vertical", "horizontal"):
        floors.setdefault(c, max(floors.values(), default=1.0))
    st = d.settings
    from .residuals import ResidualSettings

    rs = ResidualSettings(st.fc_hz, st.numtaps | 1, st.decimate) if st is not None else ResidualSettings()
    dz = design(alts, d.baseline_params, floors, menu=menu, residual=rs, progress=progress)
    write_plan(dz.plan, out / "experiment.yaml")
    write_reference_csvs(dz.plan, out / REFERENCES_DIR)
    atomic_write_text(out / "report.md", (out / "report.md").read_text() + "\n" + experiment_markdown(dz.plan, dz))
    rep = json.loads((out / "report.json").read_text())
    rep["experiment"] = {
        **dz.plan.model_dump(mode="json", exclude={"runs"}),
        "file": "experiment.yaml",
        "runs": [r.label() for r in dz.plan.runs],
        "scores": {
            s.name: {"snr": s.snr, "snr_per_minute": s.snr_per_minute, **s.per_channel, "snr_fixed": s.snr_fixed}
            for s in dz.scores
        },
    }
    atomic_write_text(out / "report.json", json.dumps(rep, indent=2))
    return dz.plan


__all__ = ["REFERENCES_DIR", "alternatives_of", "confusable_slot", "experiment_markdown", "write_experiment"]
