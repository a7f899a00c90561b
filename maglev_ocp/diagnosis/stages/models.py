"""The selection's context and record: :class:`Run`, :class:`Attribution`, one candidate fitted and scored.

A :class:`Run` (the split, the baseline, the settings and the stage's own warnings) replaces the positional
``(split, base, st, warnings)`` arguments of the selection's steps; :func:`fit_and_score` fits a candidate on
the training runs and scores it on the held-out runs (:mod:`..attribution`).

The selection's independent fits (every candidate, the members of a law family, the joint refits of one
forward step, the drop-one models of a backward check) are spread over the run's worker processes by
:func:`fit_many` (forked once per diagnosis, :func:`maglev_ocp.parallel.fork_pool`, so only each fit's
spec and start values travel); :func:`prefetch` fits ahead what a sequential step is about to ask
:func:`fit_and_score` for. Each fit is the same computation wherever it runs, and the results are used in
the order the sequential code asks for them: the record does not depend on the number of workers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from tqdm import tqdm

from ...parallel import available_cpus, fork_pool
from ..attribution import EffectScore, score
from ..fit import FitResult, fit_candidate, residuals_with
from ..lagfit import LAG_START_KEYS
from ..library import CandidateSpec, offered
from ..localize import ChannelFloor
from ..settings import DiagnoseSettings, VerdictRules
from ..verdict import Verdict
from .baseline import Baseline
from .split import Split


class FitJob(NamedTuple):
    """The arguments of one :func:`fit_and_score` call after ``run``."""

    name: str
    spec: CandidateSpec
    note: str
    pair: bool
    warm: Mapping[str, float] | None = None
    hold_lag: bool = False
    alt: Mapping[str, float] | None = None

    def key(self) -> tuple:
        """What determines the fit: the start values ``warm`` gives ``spec`` (:func:`..fit.fit_candidate` reads
        only those and the lag's search coordinates: its delay, share and damping), not the other entries of
        ``warm``."""
        w = self.warm or {}
        starts = tuple(float(w.get(f.key, f.start)) for f in self.spec.free)
        delay = tuple(w.get(k_) for k_ in LAG_START_KEYS) if w else None
        alt = None if self.alt is None else tuple(float(self.alt.get(f.key, f.start)) for f in self.spec.free)
        return (self.name, self.spec, self.note, self.pair, self.hold_lag, starts, delay, alt)


class _Workers:
    """A run's worker processes (forked on first use) and the fits made ahead for it."""

    def __init__(self) -> None:
        self.pool: Any = None
        self.tried = False
        self.ready: dict[tuple, tuple[FitResult, Any]] = {}

    def close(self) -> None:
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()
        self.pool, self.ready = None, {}


#: The run the forked workers fit on (set just before the fork, read by :func:`_fit_job` in the workers).
_FORKED_RUN: Run | None = None


@dataclass(frozen=True)
class Run:
    """What every step of the selection works on.

    Attributes
    ----------
    split : Split
        Training and held-out runs (stage 1).
    base : Baseline
        The baseline model, residuals and floors (stage 2).
    settings : DiagnoseSettings
        What the diagnosis is asked.
    warnings : list of str
        The selection's own record of fits whose solver did not converge (returned with its result).
    progress : bool
        Progress bars over the candidates and each forward step.
    """

    split: Split
    base: Baseline
    settings: DiagnoseSettings
    warnings: list[str] = field(default_factory=list)
    progress: bool = False
    workers: _Workers = field(default_factory=_Workers, repr=False, compare=False)

    @property
    def rules(self) -> VerdictRules:
        """The verdict's thresholds."""
        return self.settings.rules()

    def families(self) -> dict[str, tuple[CandidateSpec, ...]]:
        """The library the selection tries on these data: the settings' (less ``exclude_laws``) less the learned
        periodic shapes whose period the runs do not span twice (:func:`..library.offered`)."""
        runs = [r.feat["d"] for r in (*self.split.train, *self.split.test) if len(r.feat.get("d", ()))]
        span = max(map(np.max, runs)) - min(map(np.min, runs)) if runs else 0.0
        return offered(self.settings.families(), float(span))

    @property
    def n_workers(self) -> int:
        """Worker processes of the independent fits (``settings.fit_workers``; 0: the CPUs, at most 4)."""
        n = self.settings.fit_workers
        return n if n > 0 else min(available_cpus(), 4)

    def pool(self) -> Any:
        """The worker pool, forked on the first call (None: the fits run in this process)."""
        global _FORKED_RUN
        if not self.workers.tried:
            self.workers.tried = True
            if self.n_workers > 1:
                _FORKED_RUN = self
                try:
                    self.workers.pool = fork_pool(self.n_workers)
                except OSError:  # no processes to be had: the fits run here
                    self.workers.pool = None
                finally:
                    _FORKED_RUN = None if self.workers.pool is None else self
        return self.workers.pool

    def close(self) -> None:
        """Stop the worker processes (the selection is done)."""
        self.workers.close()


@dataclass
class Attribution:
    """Stage 4, the selection's record: candidates, verdict, the final model and what it leaves.

    The selection's steps (:mod:`.selection`, :mod:`.joint`) build it up in place, as one stage's working
    record; the stages after it (:mod:`.guards`, :mod:`.refit`, :mod:`.quantify`) never write into it but
    return a new record (:func:`dataclasses.replace`) or their own evidence.
    """

    specs: dict[str, CandidateSpec]
    fits: dict[str, FitResult]
    scores: list[EffectScore]
    verdict: Verdict
    best: EffectScore | None
    final_spec: CandidateSpec | None = None
    final_fit: FitResult | None = None
    remaining: dict[str, ChannelFloor] = field(default_factory=dict)
    final_score: EffectScore | None = None
    members: list[EffectScore] = field(default_factory=list)  # law-family members not chosen
    models: dict[frozenset, tuple] = field(default_factory=dict)  # effect set -> (spec, fit, score)
    rewarmed: set[frozenset] = field(default_factory=set)  # drop-one sets refitted from a full model (joint.rewarmed)
    steps: list[dict] = field(default_factory=list)  # forward-selection trials
    shares: dict[str, dict] = field(default_factory=dict)  # drop-one shares of the selected effects
    model_fit: FitResult | None = None  # the final model's refit on the resolved samples (constants, model file)
    resolved: dict = field(default_factory=dict)  # how that refit was made (see refit.resolved_refit)

    @property
    def model(self) -> FitResult | None:
        """The fit the constants and the model file come from: the resolved refit if adopted, else the final fit."""
        return self.model_fit if self.model_fit is not None else self.final_fit


def _readable(fit: FitResult, pair: bool) -> tuple[dict[str, float], dict[str, float]]:
    """A fit's values and standard errors under readable names (an effect's own keys without its prefix,
    phases wrapped to [-pi, pi)); ``pair``: joint fits keep the full keys."""
    vals, errs = {}, {}
    for key, v in fit.params().items():
        if key.endswith("_stderr"):
            continue
        name = key if pair else key.split(".", 1)[-1]
        if "phi" in key or key.endswith("_phase"):
            v = float((v + math.pi) % (2 * math.pi) - math.pi)
        vals[name] = float(v)
    se = dict(zip(fit.spec.keys, fit.stderr, strict=True))
    if "effective_delay_s_stderr" in fit.extra:
        se["effective_delay_s"] = fit.extra["effective_delay_s_stderr"]
    for key, s in se.items():
        name = key if pair else key.split(".", 1)[-1]
        errs[name] = float(s) if np.isfinite(s) else None
    return vals, errs


def fit_and_score(
    run: Run,
    name: str,
    spec: CandidateSpec,
    note: str,
    pair: bool,
    warm: dict[str, float] | None = None,
    hold_lag: bool = False,
    alt: Mapping[str, float] | None = None,
) -> tuple[FitResult, EffectScore]:
    """Fit one candidate (or a joint set) on the training runs and score it on the held-out runs (or take the
    fit :func:`prefetch` made ahead with the same spec and start values); ``alt``: another start
    (:func:`..fit.fit_candidate`)."""
    if run.workers.ready:
        done = run.workers.ready.pop(FitJob(name, spec, note, pair, warm, hold_lag, alt).key(), None)
        if done is not None:
            return done
    split, base, rules = run.split, run.base, run.rules
    fit = fit_candidate(spec, base.data_train, base.p, u_runs=split.u_train, warm=warm, hold_lag=hold_lag, alt=alt)
    after = residuals_with(spec, fit, split.test, base.p, split.u_test)
    vals, errs = _readable(fit, pair=pair)
    sc = score(name, fit, base.fit, base.b_test, after, base.fvec, rules, vals, errs, note, base.noise_infl,
               base.floor_ms)  # fmt: skip
    sc.law = spec.law
    return fit, sc


def _fit_job(job: tuple[int, FitJob]) -> tuple[int, tuple[FitResult, EffectScore]]:
    """One fit in a worker process, on the run it was forked with."""
    i, j = job
    assert _FORKED_RUN is not None, "a fit worker without its run"
    return i, fit_and_score(_FORKED_RUN, *j)


def fit_many(run: Run, jobs: Sequence[FitJob], desc: str = "") -> list[tuple[FitResult, EffectScore]]:
    """``[fit_and_score(run, *job) for job in jobs]``, spread over the run's workers (one job each, the
    amplifier lag's searches first: they take longest); a progress bar ``desc`` over the fits."""
    bar = tqdm(total=len(jobs), desc=desc, disable=not (run.progress and desc), leave=False)
    pool = run.pool() if len(jobs) > 1 else None
    try:
        if pool is None:
            out = []
            for j in jobs:
                out.append(fit_and_score(run, *j))
                bar.update()
            return out
        order = sorted(range(len(jobs)), key=lambda i: not jobs[i].spec.lag)
        done: dict[int, tuple[FitResult, EffectScore]] = {}
        for i, res in pool.imap_unordered(_fit_job, [(i, jobs[i]) for i in order]):
            done[i] = res
            bar.update()
        return [done[i] for i in range(len(jobs))]
    finally:
        bar.close()


def prefetch(run: Run, jobs: Sequence[FitJob], desc: str = "") -> None:
    """Make, on the run's workers, the fits a sequential step is about to ask :func:`fit_and_score` for
    (each taken once, by the call with the same spec and start values); nothing without workers."""
    todo, seen = [], set()
    for j in jobs:
        k = j.key()
        if k not in seen and k not in run.workers.ready:
            seen.add(k)
            todo.append(j)
    if len(todo) < 2 or run.pool() is None:
        return
    for j, res in zip(todo, fit_many(run, todo, desc), strict=True):
        run.workers.ready[j.key()] = res


def joint_spec(spec: CandidateSpec, base: Baseline) -> CandidateSpec:
    """The candidate with the baseline's constants refitted jointly (when the baseline was calibrated)."""
    return spec.with_free(base.cal_free) if base.cal_free else spec


def warm_start(name: str, fit: FitResult) -> dict[str, float]:
    """Start values from a fit, also under the effect's own keys (``p.xi0`` starts ``cogging.xi0``)."""
    out = fit.params()
    for key, v in list(out.items()):
        if key.startswith("p.") and key[2:] in ("xi0", "ell"):
            out.setdefault(f"{name}.{key[2:]}", v)
    return out


def settle_verdict(base: Baseline, att: Attribution) -> None:
    """No effect claimed: the final model is the baseline and its gap remains; mark the selected scores."""
    verdict = att.verdict
    if not verdict.named:
        att.final_spec, att.final_fit = base.spec, None
        att.remaining = base.floors
    in_verdict = set(verdict.sets.names)
    for s in att.scores:
        s.selected = verdict.named and (s.name in in_verdict or s.name == verdict.verdict or s is att.final_score)


__all__ = [
    "Attribution",
    "FitJob",
    "Run",
    "fit_and_score",
    "fit_many",
    "joint_spec",
    "prefetch",
    "settle_verdict",
    "warm_start",
]
