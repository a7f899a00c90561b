"""The diagnosis pipeline: the stages in order, their timings and progress, the :class:`Diagnosis` assembled.

:func:`diagnose` takes any ``maglev-rig-log/1`` dataset (closed- or open-loop,
any controller, locked axes allowed) and returns a :class:`Diagnosis`, whose
:meth:`~Diagnosis.save` writes ``report.json``, ``report.md`` and the figures
(:mod:`.report`). The stages, one module each in :mod:`.stages`, each with its
own result and none writing into another's:

1. **split** (:mod:`.stages.split`): whole runs held out for scoring, runs cut
   at stop contacts, every run filtered;
2. **baseline** (:mod:`.stages.baseline`): the nominal model with its cogging
   law (seed eq. (9)), C1..C4, xi0 and ell calibrated on the training runs with
   a prior at nominal (or ``params`` as given); residuals and floors;
3. **localization** (:mod:`.stages.localization`): the residual over the
   state, its spectrum and period scan, the evidence of a gap; the noise
   model's floor, whiteness and peaks;
4. **selection** (:mod:`.stages.selection`, :mod:`.stages.joint`): every
   library effect fitted and scored on the held-out runs, law families,
   forward selection with joint refits and a backward check, confusable slots,
   shares, laws chosen again in the joint model;
5. **guards** (:mod:`.stages.guards`, :mod:`.stages.claims`): a lag that absorbs
   a resonance is not counted; an effect whose signature does not show in the
   residual without it, or whose gain is another effect's misfit, is not
   claimed; a verdict that leaves a channel's gap open is ``unexplained``, one
   that leaves a located gap no signature has is partly explained;
6. **refit** (:mod:`.stages.refit`): the constants calibrated on the clean
   samples (reported) and the final model on the samples the velocities
   resolve (the report's constants and ``model.yaml``);
7. **quantify** (:mod:`.stages.quantify`): residuals of the final model,
   remaining regions, simulated trajectories, what stays unexplained beyond the
   noise model, each effect's consequence.

The verdict is an :class:`~.verdict.EffectSets` (``none``, ``unexplained``,
slots of effects with their confusable alternatives); its text form is the
report's. Settings: :mod:`.settings`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from ..constants import encoder_resolution
from ..params import Params
from ..riglog import Dataset as RigDataset
from .attribution import rank
from .library import combine
from .result import ChannelView, DiagnoseSettings, Diagnosis, HeldOut
from .stages.baseline import calibrate_baseline, prior_sd
from .stages.guards import apply_coverage, apply_resonance_guard, channel_coverage, lag_guards, run_guards
from .stages.joint import refine_laws
from .stages.localization import localize_gap, noise_floor_ms, noise_stage
from .stages.models import Run, settle_verdict
from .stages.quantify import consequence_stage, quantify, unexplained_stage
from .stages.refit import clean_calibration, constants_moved, resolved_refit, undragged
from .stages.selection import attribute, forward, library_names
from .stages.split import runs_from_dataset, split_dataset, split_runs

#: The candidate library, in report order.
LIBRARY: tuple[str, ...] = library_names()

#: The stages :func:`diagnose` runs, in order, as its progress bar and ``timing`` name them.
STAGES: tuple[str, ...] = (
    "split",
    "baseline",
    "localization",
    "clean_calibration",
    "noise",
    "candidates",
    "forward",
    "guards",
    "resolved_refit",
    "quantify",
    "unexplained",
    "consequence",
)


#: A stage that took longer than this [s] leaves a line with its time under the progress bars.
STAGE_LINE_S: float = 2.0


class _Clock:
    """Wall time of each stage (``timing[<stage>_s]``), a progress bar over the stages naming the one running,
    and a line for every stage that took more than :data:`STAGE_LINE_S` (never silent: the stages' own bars
    show the fits inside them)."""

    def __init__(self, progress: bool) -> None:
        self.timing: dict[str, float] = {}
        self.progress = progress
        self.bar = tqdm(total=len(STAGES), desc="diagnosis", disable=not progress, leave=False)
        self.t_all = time.perf_counter()
        self.cpu_all = time.process_time()

    def run(self, name: str, fn: Callable, *args, **kwargs):
        """Run one stage, timed, with its name on the progress bar."""
        self.bar.set_description_str(f"diagnosis: {name}")
        t0 = time.perf_counter()
        out = fn(*args, **kwargs)
        dt = time.perf_counter() - t0
        self.timing[f"{name}_s"] = dt
        if self.progress and dt > STAGE_LINE_S:
            self.bar.write(f"diagnosis: {name} done in {dt:.1f} s", file=sys.stderr)
        self.bar.update(1)
        return out

    def close(self) -> dict[str, float]:
        """The timings with the total wall and CPU time."""
        self.bar.close()
        self.timing["total_s"] = time.perf_counter() - self.t_all
        self.timing["cpu_s"] = time.process_time() - self.cpu_all
        return self.timing


def diagnose(
    dataset: RigDataset,
    params: Params | None = None,
    settings: DiagnoseSettings | None = None,
    progress: bool = False,
) -> Diagnosis:
    """Diagnose the gap between the model and a dataset (the stages of the module docstring).

    Parameters
    ----------
    dataset : riglog.Dataset
        Any rig-log dataset.
    params : Params, optional
        The model to test as given; default: the nominal model with its
        cogging law, calibrated (C1..C4, xi0, ell) on the training runs.
    settings : DiagnoseSettings
        Filter, split, thresholds.
    progress : bool
        Progress bars: over the stages, the candidates and the forward steps.

    Returns
    -------
    Diagnosis
        With ``warnings`` naming every fit whose solver did not converge and
        ``timing`` the wall time of every stage.
    """
    st = settings or DiagnoseSettings()
    rng = np.random.default_rng(np.random.SeedSequence(st.seed))
    clock = _Clock(progress)
    q_enc = float(dataset.encoder_resolution or 0.0) or encoder_resolution

    split = clock.run("split", split_dataset, dataset, st)
    base = clock.run("baseline", calibrate_baseline, split, params, st, q_enc)
    loc = clock.run("localization", localize_gap, split, base, st, rng)
    clean = clock.run("clean_calibration", clean_calibration, split, base, loc, st)
    noise, loc = clock.run(
        "noise", noise_stage, split, base, loc, q_enc, st.seed, drift_z=st.z_min, drift_min_floor=st.drift_min_floor
    )
    base = replace(base, floor_ms=noise_floor_ms(base, noise))
    run = Run(split, base, st, progress=progress)
    try:  # the selection's fit workers (forked on its first fits) stop with it
        att = clock.run("candidates", attribute, run, loc)

        def select() -> None:
            forward(run, att)
            refine_laws(run, att)
            settle_verdict(base, att)

        clock.run("forward", select)
    finally:
        run.close()
    guarded = clock.run("guards", run_guards, split, base, att, noise, st, progress, loc)
    att = clock.run("resolved_refit", resolved_refit, split, base, guarded.attribution, st)
    q = clock.run("quantify", quantify, split, base, loc, att, st, rng)
    verdict = replace(att.verdict, selected=list(att.verdict.selected), reasons=[*att.verdict.reasons, *q.reasons])
    unexpl = clock.run("unexplained", unexplained_stage, split, base, verdict, q, noise, st)
    cons, verdict = clock.run(
        "consequence", consequence_stage, split, base, att, unexpl.verdict, st, params, progress=progress
    )
    noise = replace(
        noise,
        checks_after=unexpl.checks_after,
        remaining_peaks=unexpl.remaining_peaks,
        unexplained=unexpl.unexplained,
        guards=guarded.guards,
        coverage=guarded.coverage,
        partial=guarded.partial,
        claims=guarded.claims.to_dict() if guarded.claims is not None else {},
    )
    timing = clock.close()
    final = att.final_fit is not None
    return Diagnosis(
        verdict=verdict,
        scores=rank(att.scores),
        floors=base.floors,
        remaining=att.remaining,
        baseline_params=undragged(base, att),
        residual_baseline_params=base.params,
        baseline_mode="given" if base.given else "calibrated",
        baseline_stderr=base.stderr,
        views_before=loc.views,
        views_after=q.views_after,
        regions=q.regions,
        remaining_regions=q.remaining_regions,
        trajectories=q.trajectories,
        train=[r.name for r in split.train_in],
        test=[r.name for r in split.test_in],
        timing=timing,
        residuals_before=base.b_train + base.b_test,
        residuals_after=q.residuals_after,
        final_model=att.final_spec.name if final else "baseline",
        settings=st,
        quantization_floor=base.q_floor,
        heldout=HeldOut(split.test, split.u_test, base.fvec, base.b_test),
        warnings=[*split.stops, *base.warnings, *run.warnings, *guarded.warnings],
        noise=noise,
        consequences=cons,
        effects_found=list(verdict.selected) if final else [],
        shares=att.shares,
        forward_steps=att.steps,
        law_members=att.members,
        final_score=att.final_score if final else None,
        constants_moved=constants_moved(base, att),
        baseline_calibration={**clean.to_dict(undragged(base, att).vector()), "resolved_refit": att.resolved}
        if not base.given
        else {},
        prior={
            "sd_relative_to_nominal": prior_sd(st),
            "weight": f"one independent sample per {base.noise_lag} residual samples (the filter's main lobe)",
        }
        if not base.given
        else {},
        thrust_constant=base.thrust.to_dict() if base.thrust is not None else {},
    )


__all__ = [
    "LIBRARY",
    "STAGES",
    "ChannelView",
    "DiagnoseSettings",
    "Diagnosis",
    "HeldOut",
    "apply_coverage",
    "apply_resonance_guard",
    "channel_coverage",
    "combine",
    "consequence_stage",
    "diagnose",
    "lag_guards",
    "noise_stage",
    "runs_from_dataset",
    "split_runs",
    "unexplained_stage",
]
