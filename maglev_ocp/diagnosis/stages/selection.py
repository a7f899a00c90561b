"""Stage 4, selection: every library effect fitted and scored alone, its law family, then forward selection.

:func:`attribute` fits every library effect on top of the baseline (jointly with the calibrated constants),
scores it on the held-out runs, chooses the law-family member of the most promising ones and gives the
single-effect verdict; :func:`forward` adds further effects by joint refits with a held-out test at each step
and checks them backward (:mod:`.joint`). Both work on the selection's own record, :class:`.models.Attribution`.
"""

from __future__ import annotations

import math

import numpy as np

from ..attribution import EffectScore, decide, delta_bic, paired_z, stack
from ..fit import FitResult
from ..library import CandidateSpec, combine, family_specs
from ..verdict import EffectSets, Verdict
from .baseline import Baseline, check_fit
from .joint import backward, confirm_slots, shares
from .localization import Localization
from .models import Attribution, FitJob, Run, fit_and_score, fit_many, joint_spec, warm_start


def library_names() -> tuple[str, ...]:
    """The candidate library, in report order."""
    return tuple(family_specs())


def attribute(run: Run, loc: Localization) -> Attribution:
    """Stage 4: every library effect fitted on top of the baseline (its law family for the most promising
    ones), scored on the held-out runs; the single-effect verdict."""
    base, st, warnings = run.base, run.settings, run.warnings
    rules = st.rules()
    fam = run.families()  # the library less the settings' exclude_laws and what the data cannot test
    names = [n for n in (st.candidates or library_names()) if n in fam]
    if not base.given:
        names = [n for n in names if n != "parameter_error"]
    specs: dict[str, CandidateSpec] = {}
    fits: dict[str, FitResult] = {}
    scores: list[EffectScore] = []
    jobs = [FitJob(name, spec, spec.note, False) for name in names for spec in [joint_spec(fam[name][0], base)]]
    for job, (fit, sc) in zip(jobs, fit_many(run, jobs, "candidates"), strict=True):
        check_fit(fit, f"candidate {job.name}", warnings)
        specs[job.name], fits[job.name] = job.spec, fit
        scores.append(sc)
    att = Attribution(specs, fits, scores, Verdict(EffectSets.none(), [], False, []), None)
    _choose_laws(run, att)
    att.verdict, att.best = decide(att.scores, loc.gap_detected, rules, loc.evidence)
    if att.best is None and loc.gap_detected:
        # Several effects at once: each single fit sees the others in its residual, which inflates the held-out
        # noise of its paired test (a triple's friction closed 54 % of the gap at z = 3.7). The forward selection
        # then starts from the single the training data favour most among those that improve the held-out runs
        # (z >= z_enter); the verdict stays unexplained unless the joint model it reaches is significant and
        # closes the gap (:func:`forward`).
        start = [s for s in att.scores if s.fit is not None and s.fit.success and s.z >= st.z_enter
                 and s.delta_bic <= -rules.bic_margin]  # fmt: skip
        if start:
            att.best = min(start, key=lambda s: s.delta_bic)
            att.verdict.reasons.append(
                f"no single effect is significant on its own; forward selection from {att.best.name} (held-out "
                f"z = {att.best.z:.1f}, dBIC = {att.best.delta_bic:.0f}), the joint model to be judged"
            )
    return att


def _choose_laws(run: Run, att: Attribution) -> None:
    """Stage 4a: the law families of the ``st.family_top`` effects whose default member the information
    criterion favours most (by default every effect's: a default member the data do not favour may still hide
    a law of its family that they do, e.g. a cogging of another shape with no fundamental at seed eq. (9)'s
    period left the default member at 0 %, eighth of eight, while its co-energy member closed the gap); the
    member is chosen by
    the information criterion (effective sample size) among those whose held-out residual is not
    significantly worse than the best member's (paired z below ``confusable_z``)."""
    base, st, warnings = run.base, run.settings, run.warnings
    rules = st.rules()
    fam = run.families()  # the library less the settings' exclude_laws and what the data cannot test
    # The training data's information criterion ranks them (a law that differs can leave the default member's
    # held-out gain small while the data clearly favour the effect).
    promising = [
        s
        for s in sorted(att.scores, key=lambda s: s.delta_bic)
        if len(fam.get(s.name, ())) > 1 and s.fit is not None and s.fit.success
    ][: st.family_top]
    # Every member of every family at once (each starts from its own effect's single fit, which no other
    # family's choice changes), spread over the workers; then chosen family by family.
    jobs = [FitJob(sc.name, spec, spec.note, False, warm_start(sc.name, att.fits[sc.name]))
            for sc in promising for spec in (joint_spec(mem, base) for mem in fam[sc.name][1:])]  # fmt: skip
    done = iter(zip(jobs, fit_many(run, jobs, "law families"), strict=True))
    for sc in promising:
        name = sc.name
        tried = [(sc, att.specs[name], att.fits[name])]
        for mem in fam[name][1:]:
            job, (fit, ms) = next(done)
            check_fit(fit, f"candidate {name} ({mem.law})", warnings)
            tried.append((ms, job.spec, fit))
        ok = [t for t in tried if t[2].success]
        if not ok:
            continue
        top = min(ok, key=lambda t: t[0].r2_after)
        near = [t for t in ok if t is top or paired_z(t[0].e_after, top[0].e_after) < rules.confusable_z]
        chosen = min(near, key=lambda t: delta_bic(t[2], top[2], base.noise_infl))
        laws = ", ".join(f"{t[1].law} (dBIC {t[0].delta_bic:.0f}, held-out {t[0].reduction:.1%})" for t in tried)
        chosen[0].law_choice = f"law '{chosen[1].law}' chosen among: {laws}"
        if chosen[0] is not sc:
            att.scores[att.scores.index(sc)] = chosen[0]
            att.specs[name], att.fits[name] = chosen[1], chosen[2]
        for t in tried:
            if t is not chosen:
                t[0].name = f"{name}[{t[1].law}]"
                att.members.append(t[0])


def _forward_trials(
    run: Run,
    att: Attribution,
    names: list[str],
    pool: list[str],
    current: tuple[CandidateSpec, FitResult, EffectScore],
    e_base: np.ndarray,
) -> list[tuple]:
    """One forward step: each pooled candidate refitted jointly with the current model.

    Returns ``(name, closes_remaining, paired_z, delta_bic, score, spec, fit, screen_z)`` per candidate.
    """
    base, warnings = run.base, run.warnings
    spec, fit, cur = current
    trials, jobs = [], []
    for o in pool:
        single = next(s for s in att.scores if s.name == o)
        # The screen (does the single fit's correction remain?) is recorded, not a gate: a single fitted with
        # other effects still in the residual can be corrupted by them (cogging beyond eq. (9) next to friction
        # screened at z = -1.5 and was needed), and the joint refits are cheap.
        t_screen = _screen(e_base, single.e_after, cur.e_after, base)
        jspec = combine(spec, att.specs[o])
        warm = {**warm_start(o, att.fits[o]), **fit.params()}
        if att.specs[o].lag and not spec.lag:
            # The lag's single fit saw the other effects in its residual, so its delay is no centre for the
            # joint search (friction next to a 0.8 ms lag left it at a delay of 0): search the whole range.
            warm.pop("effective_delay_s", None)
        # A lag already in the model keeps the delay its search found while a candidate is tried (the other
        # parameters are refitted jointly); the accepted model's delay is searched again (:func:`_forward`).
        # The current model with the candidate at its spec's start is the other start (fit.fit_candidate): the
        # single fit's values belong to its own constants.
        jobs.append(FitJob(jspec.name, jspec, jspec.note, True, warm, hold_lag=spec.lag, alt=fit.params()))
        trials.append((o, t_screen))
    fits = fit_many(run, jobs, f"forward step {len(names) + 1}")
    out = []
    for (o, t_screen), job, (jfit, js) in zip(trials, jobs, fits, strict=True):
        jspec = job.spec
        check_fit(jfit, f"joint fit {jspec.name}", warnings)
        # What remains is measured above the data-based floor here (1 in its units): above the noise model's, the
        # laws' misfit of the effects still missing weighs in, and a triple's second effect would have to close
        # half of that before the third may enter.
        extra = (cur.r2_after - js.r2_after) / max(cur.r2_after - 1.0, cur.r2_after - js.r2_after, 1e-12)
        zp = paired_z(cur.e_after, js.e_after)
        dbic = delta_bic(jfit, fit, base.noise_infl)
        att.models[frozenset([*names, o])] = (jspec, jfit, js)
        att.scores.append(js)
        out.append((o, extra, zp, dbic, js, jspec, jfit, t_screen))
    return out


def _research_lag(
    run: Run,
    att: Attribution,
    names: list[str],
    trial: tuple[CandidateSpec, FitResult, EffectScore],
    held: bool,
) -> tuple[FitResult, EffectScore]:
    """The accepted model of a forward step; if its trial held the lag's delay, with the delay searched again
    around its value (the model stored under its effect set, its score replacing the trial's)."""
    jspec, jfit, js = trial
    if not held:
        return jfit, js
    fit, sc = fit_and_score(run, jspec.name, jspec, jspec.note, True, jfit.params())
    att.models[frozenset(names)] = (jspec, fit, sc)
    att.scores = [sc if s_.name == jspec.name else s_ for s_ in att.scores]
    return fit, sc


def _forward_pass(
    run: Run,
    att: Attribution,
    names: list[str],
    slots: list[list[str]],
    pool: list[str],
    current: tuple[CandidateSpec, FitResult, EffectScore],
    e_base: np.ndarray,
) -> tuple[list[str], list[list[str]], tuple[CandidateSpec, FitResult, EffectScore]]:
    """Forward steps from the model of ``names`` until no candidate of ``pool`` enters (see :func:`forward`)."""
    st = run.settings
    rules = st.rules()
    names, slots, pool = list(names), [list(x) for x in slots], [o for o in pool if o not in names]
    spec, fit, cur = current
    while pool and len(names) < st.max_effects:
        trials = _forward_trials(run, att, names, pool, (spec, fit, cur), e_base)
        good = [t for t in trials if t[2] >= st.z_enter and t[3] <= -rules.bic_margin and t[1] >= rules.second_min
                and t[6].success]  # fmt: skip
        for o, extra, zp, dbic, *_, t_screen in trials:
            att.steps.append(
                dict(step=len(names) + 1, candidate=o, on_top_of=list(names), closes_remaining=extra, paired_z=zp,
                     delta_bic=dbic, screen_z=t_screen, accepted=False)
            )  # fmt: skip
        if not good:
            break
        # The candidate whose joint model fits the held-out runs best (the fraction of the remaining gap it
        # closes is clipped at 1 and would leave ties once the model reaches the floor).
        o, extra, zp, dbic, js, jspec, jfit, _ = min(good, key=lambda t: t[4].r2_after)
        # A trial that held the delay (a lag already in the model): the accepted model's delay searched again.
        jfit, js = _research_lag(run, att, [*names, o], (jspec, jfit, js), spec.lag)
        conf = [t[0] for t in good if t[0] != o and paired_z(t[4].e_after, js.e_after) < rules.confusable_z]
        for row in att.steps[-len(trials) :]:
            row["accepted"] = row["candidate"] == o
        for slot in slots:
            if o in slot[1:]:
                slot.remove(o)
        slots.append([o, *conf])
        names.append(o)
        pool.remove(o)
        att.verdict.reasons.append(
            f"a significant gap remained; adding {o} (joint refit with {', '.join(names[:-1])}) closes {extra:.0%} "
            f"of it on the held-out runs (paired z = {zp:.1f}, dBIC = {dbic:.0f})"
            + (f"; {', '.join(conf)} would do as well: confusable" if conf else "")
        )
        spec, fit, cur = jspec, jfit, js
    return names, slots, (spec, fit, cur)


def forward(run: Run, att: Attribution) -> None:
    """Stage 4b: forward selection of several effects.

    From the best single effect (or, when none is significant alone, the one
    the information criterion favours, :func:`attribute`), each step refits
    every remaining promising candidate **jointly** with the effects already
    selected (and the baseline's constants), warm-started from the earlier
    fits, and scores it on the held-out runs against the current model. Of
    the candidates whose held-out gain is significant (paired z >=
    ``z_enter``), whose information criterion drops by ``bic_margin`` and
    that close at least ``second_min`` of what remained above the data-based
    floor, the step adds the one whose joint model fits the held-out runs
    best; otherwise the selection stops. A backward check (:func:`.joint.backward`) then
    keeps only the effects the full joint model needs (drop-one held-out z
    >= ``z_min``); if it drops one, the forward steps resume without it
    (stepwise selection: an effect that entered to take up another law's
    misfit leaves its place to a candidate that a later step would have
    added). Candidates that pass at the same step and
    fit the held-out runs as well as the chosen one form a confusable slot
    (``a|b``) unless a later step adds them as effects of their own.
    """
    split, base, st = run.split, run.base, run.settings
    rules = st.rules()
    best = att.best
    att.final_spec, att.final_fit = base.spec, None
    if best is None:
        return
    spec, fit, cur = att.specs[best.name], att.fits[best.name], best
    att.final_spec, att.final_fit, att.final_score = spec, fit, best
    att.models = {frozenset([s.name]): (att.specs[s.name], att.fits[s.name], s) for s in att.scores}
    slots = [[best.name, *best.confusable_with]]
    names = [best.name]
    att.remaining = base.floors_of(spec, fit, split)
    # Candidates worth a joint refit: every other converged single, best information criterion first. Neither
    # the held-out z nor the criterion of a single is the test here: other effects still in its residual inflate
    # its noise and corrupt its fit (a 0.8 ms amplifier lag next to friction fitted alone at dBIC +11 and
    # held-out z -2.3, and was needed); the joint refit with the current model is the test.
    pool = [
        s.name
        for s in sorted(att.scores, key=lambda s: s.delta_bic)
        if s.name != best.name and s.fit is not None and s.fit.success and s.z > st.forward_z
    ][: st.forward_pool]
    e_base = stack(base.b_test, base.fvec)
    dropped: set[str] = set()
    while True:
        names, slots, (spec, fit, cur) = _forward_pass(run, att, names, slots, pool, (spec, fit, cur), e_base)
        if len(names) < 2:
            break
        laws = {n: att.specs[n].law for n in names}
        kept, slots = backward(run, att, names, slots)
        spec, fit, cur = att.models[frozenset(kept)]
        gone = set(names) - set(kept)
        relawed = [n for n in kept if att.specs[n].law != laws[n]]
        names = kept
        # Stepwise: an effect the backward check dropped was holding a place another candidate may fill (its
        # law's misfit looked like a second effect until the others were in): the forward pass resumes without it.
        # So it does when the backward check chose another law for an effect (:func:`.joint.rechoose_law`): the
        # old law's misfit hid what the candidates still out could gain (an 800 Hz lag beside a learned cogging
        # series that had taken up friction's misfit gained held-out z 1.3; the closed form left its signature).
        dropped |= gone
        pool = [o for o in pool if o not in names and o not in dropped]
        if (not gone and not relawed) or not pool or len(names) >= st.max_effects:
            break
    if len(names) > 1:
        slots = confirm_slots(run, att, names, slots)
    att.remaining = base.floors_of(spec, fit, split)
    if len(names) == 1 and names[0] != best.name:  # the backward pass kept another single
        att.verdict = Verdict(EffectSets.of(slots[:1]), list(names), True, att.verdict.reasons)
        att.final_spec, att.final_fit, att.final_score = spec, fit, cur
    if len(names) > 1:
        if not att.verdict.sets.unexplained or (cur.closes >= rules.closes_min and cur.significant):
            att.verdict = Verdict(EffectSets.of(slots), list(names), True, att.verdict.reasons)
            att.final_spec, att.final_fit, att.final_score = spec, fit, cur
            shares(run, att, names)
    elif att.verdict.sets.unexplained:
        att.final_spec, att.final_fit, att.final_score = base.spec, None, None
    if att.verdict.sets.unexplained:
        att.verdict.reasons.append(
            f"no candidate, alone or with others, closes {rules.closes_min:.0%} of the gap: unexplained"
        )


def _screen(e_base: np.ndarray, e_single: np.ndarray, e_cur: np.ndarray, base: Baseline) -> float:
    """Does the current model's held-out residual still hold what a candidate's single fit corrects?

    ``delta = e_base - e_single`` is the single fit's correction (floor-
    normalized, held-out samples); its regression coefficient on the current
    residual ``e_cur``, in standard errors (noise inflation of the filter):
    a cheap screen before a joint refit. A candidate that only absorbed part of
    an effect already in the model corrects nothing that remains.
    """
    if e_single is None or len(e_single) != len(e_cur) or len(e_cur) < 10:
        return 0.0
    d = e_base - e_single
    dd = float(d @ d)
    if dd <= 0:
        return 0.0
    sig = float(np.sqrt(np.mean(e_cur**2)))
    return float(d @ e_cur) / (math.sqrt(dd) * sig * math.sqrt(base.noise_infl))


__all__ = ["attribute", "forward", "library_names"]
