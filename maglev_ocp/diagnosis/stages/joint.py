"""Stage 4, selection (joint models): drop-one models, the backward check, confusable slots, shares, laws.

Every step here refits a set of effects jointly (warm from the fits on record, :func:`joint_model`): the
backward check keeps only the effects the full joint model needs (:func:`backward`), a confusable slot keeps
only what the final joint model cannot tell apart (:func:`confirm_slots`), each effect's share of the gap
comes from drop-one refits (:func:`shares`), and each effect's law is chosen again in the joint model
(:func:`refine_laws`). All work on the selection's own record, :class:`.models.Attribution`.
"""

from __future__ import annotations

from collections.abc import Sequence

from tqdm import tqdm

from ..attribution import EffectScore, delta_bic, paired_z, resolved_delta_bic, resolved_paired_z
from ..fit import FitResult
from ..lagfit import LAG_START_KEYS
from ..library import CandidateSpec, combine
from ..verdict import EffectSets, Verdict
from .baseline import check_fit
from .models import Attribution, FitJob, Run, fit_and_score, joint_spec, prefetch, warm_start
from .refit import partly_resolved, resolved_errors, resolved_masks


def _joint_job(att: Attribution, names: Sequence[str]) -> FitJob:
    """The fit :func:`joint_model` makes of a set not on record: warm from the singles and the final fit."""
    spec = att.specs[names[0]]
    for n in names[1:]:
        spec = combine(spec, att.specs[n])
    warm: dict[str, float] = {}
    for n in names:
        warm.update(warm_start(n, att.fits[n]))
    if att.final_fit is not None:
        warm.update(att.final_fit.params())
    return FitJob(spec.name, spec, spec.note, True, warm)


def _rewarm_job(spec: CandidateSpec, full: tuple[CandidateSpec, FitResult, EffectScore]) -> FitJob:
    """The fit :func:`rewarmed` makes: ``spec`` started from the full model's values (a lag's search centred on
    the full model's delay and shape, as a warm start centres it, :func:`..fit.fit_candidate`: not over the whole
    range again, which the model on record has searched)."""
    lag = LAG_START_KEYS if spec.lag else ()
    warm = {k_: v for k_, v in full[1].params().items() if k_ in spec.keys or k_ in lag}
    return FitJob(spec.name, spec, spec.note, True, warm)


def _prefetch_sets(
    run: Run,
    att: Attribution,
    sets: Sequence[Sequence[str]],
    full: tuple[CandidateSpec, FitResult, EffectScore] | None,
    desc: str,
) -> None:
    """The fits :func:`joint_model` (and, with ``full``, :func:`rewarmed`) are about to make for ``sets``, made
    ahead on the run's workers (:func:`.models.prefetch`; the sequential code then takes them in its order)."""
    if run.n_workers <= 1:
        return
    jobs = []
    for names in sets:
        key = frozenset(names)
        job = _joint_job(att, names) if key not in att.models else None
        if job is not None:
            jobs.append(job)
        if full is not None and key not in att.rewarmed:
            jobs.append(_rewarm_job(job.spec if job is not None else att.models[key][0], full))
    prefetch(run, jobs, desc)


def joint_model(run: Run, att: Attribution, names: Sequence[str]) -> tuple[CandidateSpec, FitResult, EffectScore]:
    """The joint model of a set of effects: from the forward pass, or refitted (warm) from the final fit."""
    warnings = run.warnings
    key = frozenset(names)
    if key not in att.models:
        job = _joint_job(att, names)
        spec = job.spec
        jfit, js = fit_and_score(run, *job)
        check_fit(jfit, f"drop-one refit {spec.name}", warnings)
        att.models[key] = (spec, jfit, js)
        att.scores.append(js)
    return att.models[key]


def rewarmed(
    run: Run,
    att: Attribution,
    names: Sequence[str],
    full: tuple[CandidateSpec, FitResult, EffectScore],
) -> tuple[CandidateSpec, FitResult, EffectScore]:
    """The joint model of ``names`` (a drop-one set of ``full``) at its best training fit: the one on record,
    or a refit started from the full model's values, whichever fits the training runs better.

    The model on record was fitted before the dropped effect joined; the full model's fit, with more iterations
    from another start, can reach a better optimum of the other effects' and the constants' parameters. Compared
    with the model on record, that gain would count for the dropped effect. (A guard on the comparison: on the
    rig datasets re-run with it, where a near-null commutation offset was kept beside an end effect, the refit
    found no better optimum; the second ripple harmonic the end-effect law lacked was the cause there.)
    """
    warnings = run.warnings
    spec, fit, sc = joint_model(run, att, names)
    key = frozenset(names)
    if key in att.rewarmed:
        return att.models[key]
    att.rewarmed.add(key)
    jfit, js = fit_and_score(run, *_rewarm_job(spec, full))
    check_fit(jfit, f"drop-one refit {spec.name} from the full model", warnings)
    if jfit.success and (not fit.success or jfit.sse < fit.sse):
        att.models[key] = (spec, jfit, js)
        att.scores = [js if s_ is sc else s_ for s_ in att.scores]
    return att.models[key]


def refit_full(
    run: Run,
    att: Attribution,
    full: tuple[CandidateSpec, FitResult, EffectScore],
    without: tuple[CandidateSpec, FitResult, EffectScore],
    dropped: str,
) -> tuple[CandidateSpec, FitResult, EffectScore] | None:
    """The full model refitted from one of its drop-one models, when that nested model fits better.

    A model that holds another can fit the training runs no worse than it at
    its optimum; a drop-one model with the lower training error shows that the
    full model stopped at a poorer optimum (a law chosen again in the joint
    model started from the other law's values: on a rig with LuGre friction, a
    400 Hz lag and saturation, the Stribeck member's joint fit with the lag
    fitted worse than the same model without the lag, and the lag was dropped).
    The refit starts from the drop-one model's values and the dropped effect's
    single fit; a dropped amplifier lag's delay is searched over its whole
    range (its single fit may sit at another delay). Returns the refit if it
    fits better than ``full``, else None.
    """
    spec, fit, _ = full
    warm = warm_start(dropped, att.fits[dropped])
    if att.specs[dropped].lag:
        warm.pop("effective_delay_s", None)
    warm.update(without[1].params())
    warm = {k_: v for k_, v in warm.items() if k_ in spec.keys or k_ == "effective_delay_s"}
    jfit, js = fit_and_score(run, spec.name, spec, spec.note, pair=True, warm=warm)
    check_fit(jfit, f"refit of {spec.name} from its drop-one model without {dropped}", run.warnings)
    if jfit.success and jfit.sse < fit.sse:
        return spec, jfit, js
    return None


def _drop_one_test(
    run: Run,
    full: tuple[CandidateSpec, FitResult, EffectScore],
    without: tuple[CandidateSpec, FitResult, EffectScore],
) -> tuple[float, float, str]:
    """The backward check's test of one effect: the full model against its drop-one model ``without``.

    Returns the held-out paired z, the information criterion's change (``> 0``: the effect lowers it) and a
    note of how they were taken. The samples left out are those where the *other* effects' laws are not
    resolved by the velocities (:func:`.refit.resolved_masks` of the drop-one model): there a friction law's
    misfit is structured, and an effect that gains only there takes up another effect's misfit. The tested
    effect's own unresolved samples are its signature, not another's misfit: friction, whose sign and
    Stribeck terms are what leaves samples unresolved, is judged on all samples (on a foreign rig a real
    Stribeck friction gained z 11 over all samples and 1.5 over the ones its own law left resolved, and was
    dropped when the masks came from the full model).
    """
    split, base, st = run.split, run.base, run.settings
    rules = st.rules()
    masks = masks_tr = None
    if st.resolved_share > 0:
        masks, fracs = resolved_masks(without[0], without[1], split.test, split.u_test, base, split, st)
        masks = masks if partly_resolved(fracs, st) else None
    note = ""
    if masks is None:
        z = paired_z(without[2].e_after, full[2].e_after, inflation="null")
        return z, delta_bic(full[1], without[1], base.noise_infl), note
    e_full = resolved_errors(split, base, full[0], full[1], masks)
    e_wo = resolved_errors(split, base, without[0], without[1], masks)
    z, z_all, z_res = resolved_paired_z(without[2].e_after, full[2].e_after, e_wo, e_full, rules.confusable_z)
    share = len(e_full) / max(len(full[2].e_after), 1)
    note = (
        f" (the resolved samples at the all-sample count); all samples {z_all:.1f}, the {share:.0%} resolved "
        f"{z_res:.1f}"
    )
    masks_tr, _ = resolved_masks(without[0], without[1], split.train, split.u_train, base, split, st)
    e_full_tr = resolved_errors(split, base, full[0], full[1], masks_tr, held_out=False)
    if not len(e_full_tr):
        return z, delta_bic(full[1], without[1], base.noise_infl), note
    e_wo_tr = resolved_errors(split, base, without[0], without[1], masks_tr, held_out=False)
    dbic = resolved_delta_bic(e_full_tr, e_wo_tr, full[1].k, without[1].k, base.noise_infl)
    note += (
        f", dBIC on the resolved training samples {-dbic:.0f} (all: "
        f"{-delta_bic(full[1], without[1], base.noise_infl):.0f})"
    )
    return z, dbic, note


def backward(run: Run, att: Attribution, names: list[str], slots: list[list[str]]) -> tuple[list[str], list[list[str]]]:
    """Backward check of the forward pass: every selected effect must still earn its place in the full model.

    The forward pass admits an effect at ``z_enter`` (its held-out gain is
    measured against a residual that still holds the effects not yet added,
    which inflates the noise); here each effect's drop-one model (the others
    refitted jointly without it) is compared with the full model on the
    held-out runs, whose residual is now near the noise: an effect stays if
    the full model is better by ``z_min`` (the paired z with the products'
    own autocorrelation, :func:`..attribution.paired_z`) and by the information criterion,
    and its gain must also be present on the held-out samples whose velocities
    resolve the other effects' terms (:func:`.refit.resolved_masks` of the
    drop-one model, :func:`_drop_one_test`) when some do not: where a guide
    sticks, the friction law's misfit is structured, not noise, and a small
    effect that only takes it up there is not evidenced
    (library self-check: a saturation or a lag at 0.1 % of the gap next to a
    right friction pair, z 4.5-5.3 over all samples, negative over the
    resolved ones). On the resolved samples the effect must beat the tie
    (``confusable_z``) and show the per-sample evidence ``z_min`` asks of all
    samples: its resolved z brought to the all-sample count
    (:func:`..attribution.resolved_paired_z`; a z shrinks as the square root of
    the samples, and a real 800 Hz lag with half the samples unresolved has
    z 6.35 over all, 3.87 over the resolved half). The premise holds both
    ways: the unresolved samples are evidence neither for nor against an
    effect, so an effect whose gain shows on the resolved samples is not
    vetoed by the unresolved ones, on the held-out runs (the all-sample z) nor
    on the training runs (the information criterion is then taken on the
    resolved training samples, :func:`..attribution.resolved_delta_bic`). The
    weakest failing effect's law is first chosen again in the joint model
    (:func:`rechoose_law`, once per effect); if no other member makes it pass,
    it is dropped and the check repeated.
    """
    st = run.settings
    rules = st.rules()
    names, slots = list(names), [list(x) for x in slots]
    refitted: set[frozenset] = set()
    rechosen: set[str] = set()
    while len(names) > 1:
        full = joint_model(run, att, names)
        tests, detail = [], {}
        _prefetch_sets(run, att, [[n for n in names if n != e] for e in names], full, "backward check fits")
        for e in tqdm(names, desc="backward check", disable=not run.progress, leave=False):
            rest = [n for n in names if n != e]
            without = rewarmed(run, att, rest, full)
            # Both models hold every other effect: the difference is this effect's own signature, and its
            # significance is measured with its products' own autocorrelation (inflation="null"), not bounded by
            # the slow misfit the other effects' laws leave (see paired_z).
            z, dbic, note = _drop_one_test(run, full, without)
            if note:
                detail[e] = note
            tests.append((z, dbic, e, without))
        key = frozenset(names)
        nested_better = [t for t in tests if t[3][1].success and t[3][1].sse < full[1].sse]
        if nested_better and key not in refitted:
            refitted.add(key)
            t = min(nested_better, key=lambda t_: t_[3][1].sse)
            better = refit_full(run, att, full, t[3], t[2])
            if better is not None:
                old = full[2]
                att.models[key] = better
                att.scores = [better[2] if s_ is old else s_ for s_ in att.scores]
                att.verdict.reasons.append(
                    f"backward check: the model without {t[2]} fitted the training runs better than "
                    f"{'+'.join(names)}, which holds it; {'+'.join(names)} refitted from it"
                )
                continue
        tests = [t[:3] for t in tests]
        failing = [t for t in tests if t[0] < rules.z_min or t[1] > -rules.bic_margin]
        if not failing:
            att.verdict.reasons.append(
                "backward check: every effect is needed in the joint model ("
                + ", ".join(
                    f"{e}: drop-one held-out z = {z:.1f}{detail.get(e, '')}, dBIC = {-d:.0f}" for z, d, e in tests
                )
                + ")"
            )
            break
        z, dbic, e = min(failing)
        if e not in rechosen:
            # Before an effect is dropped, its law is chosen again in the joint model: the single fit chose it
            # with the other effects still in the residual (a learned cogging series that took up friction's
            # misfit alone won the single choice and gained z 4 jointly, a closed form with its own decay 32).
            rechosen.add(e)
            if rechoose_law(run, att, names, e, full):
                continue
        att.verdict.reasons.append(
            f"backward check: dropping {e} from {'+'.join(names)} does not worsen the held-out runs significantly "
            f"(z = {z:.1f}{detail.get(e, '')}, dBIC = {-dbic:.0f}): {e} dropped"
        )
        names.remove(e)
        slots = [x for x in slots if x[0] != e]
    return names, slots


def confirm_slots(run: Run, att: Attribution, names: list[str], slots: list[list[str]]) -> list[list[str]]:
    """A confusable slot of a joint model keeps only the alternatives that the final model cannot tell apart.

    A slot's alternatives were judged when its effect entered: as single fits, or at a forward step, with the
    effects not yet added still in the residual. That residual inflates the paired test's noise, so two
    effects of different physics (an overhang loss along d, a saturation along g) passed as fitting the
    held-out runs equally well. Here each alternative replaces its slot's effect in the final model (the
    others refitted jointly with it) and stays in the slot only if that model's held-out residual is not
    significantly worse (paired z below ``confusable_z``), as a single verdict's alternatives are judged.
    """
    st = run.settings
    rules = st.rules()
    _, _, full = joint_model(run, att, names)
    swaps = [[alt if n == slot[0] else n for n in names] for slot in slots for alt in slot[1:] if alt not in names]
    _prefetch_sets(run, att, swaps, None, "confusable slots")
    out = []
    for slot in slots:
        keep = []
        for alt in slot[1:]:
            if alt in names:
                continue
            swapped = [alt if n == slot[0] else n for n in names]
            _, sfit, ssc = joint_model(run, att, swapped)
            if not sfit.success:  # flagged by _model; a fit that did not converge is no evidence of a tie
                why = "did not converge"
            elif (z := paired_z(ssc.e_after, full.e_after)) < rules.confusable_z:
                keep.append(alt)
                continue
            else:
                why = f"fits the held-out runs worse (paired z = {z:.1f})"
            att.verdict.reasons.append(
                f"{alt} in place of {slot[0]} in the joint model ({'+'.join(swapped)}) {why}: not confusable"
            )
        out.append([slot[0], *keep])
    return out


def shares(run: Run, att: Attribution, names: list[str]) -> None:
    """Each selected effect's share of the gap, by drop-one refits: how much the held-out residual grows
    when the others are refitted without it (floor-normalized mean squares), normalized to sum to 1."""
    full = att.final_score
    inc = {}
    for e in names:
        rest = [n for n in names if n != e]
        inc[e] = max(joint_model(run, att, rest)[2].r2_after - full.r2_after, 0.0)
    tot = sum(inc.values())
    gain = full.heldout_rms_before - full.heldout_rms_after
    for e in names:
        sh = inc[e] / tot if tot > 0 else 1.0 / len(names)
        rest = frozenset(n for n in names if n != e)
        att.shares[e] = {
            "share_of_gap": sh,
            "heldout_rms_reduction_m_s2": sh * gain,
            "heldout_rms_without_it_m_s2": att.models[rest][2].heldout_rms_after,
            "law": att.specs[e].law,
        }


def rechoose_law(
    run: Run,
    att: Attribution,
    names: Sequence[str],
    e: str,
    current: tuple[CandidateSpec, FitResult, EffectScore],
) -> tuple[CandidateSpec, FitResult, EffectScore] | None:
    """Effect ``e``'s law chosen again in the joint model of ``names`` (``current``: that model).

    The single-effect law choice (:func:`.selection.attribute`) sees the other effects still in the residual:
    a flexible member can win it by taking up another effect's misfit and then add little beside that
    effect. Here each other member of ``e``'s family is refitted jointly with the rest (warm from
    ``current``); one replaces the current member when the information criterion drops by ``bic_margin``
    and the held-out residual is not worse (paired z >= 0). On a change the record follows: ``e``'s spec
    and single fit, its score's law note, the joint models holding ``e`` (dropped, refitted on demand) and
    the model of ``names`` (the new one). Returns the new joint model, or None when the member stays.
    """
    base, st, warnings = run.base, run.settings, run.warnings
    rules, fam = st.rules(), run.families()
    names = list(names)
    spec, fit, cur = current
    old = att.specs[e]
    # The other start of each member's refit (fit.fit_candidate's alt): the model without e, the member at its
    # spec's start. The joint fit's constants made room for the old member, so its values with a new member
    # may start far above either model (seen: 1e6 against 2.4e3, still at the iteration limit).
    without = att.models.get(frozenset(n for n in names if n != e))
    alt = without[1].params() if without is not None and without[1] is not None and without[1].success else None
    # A lag already in the model keeps the delay (and shape) its search found while another effect's members are
    # tried, as in the forward steps (.selection._forward_trials); the chosen member's model has its lag searched
    # again below. Each trial is then one solve, not a profile search (a transfer-function lag beside cogging
    # and an end effect: 14 members' searches took 236 s of a 457 s diagnosis).
    hold = bool(spec.lag) and not old.lag
    jobs = []
    for mem in fam.get(e, ()):
        if mem.law == old.law:
            continue
        att.specs[e] = joint_spec(mem, base)
        jspec = att.specs[names[0]]
        for n in names[1:]:
            jspec = combine(jspec, att.specs[n])
        att.specs[e] = old
        jobs.append((mem, FitJob(jspec.name, jspec, jspec.note, len(names) > 1, fit.params(), hold, alt)))
    if not jobs:
        return None
    prefetch(run, [j for _, j in jobs], f"laws of {e} in the joint model")
    tried = []
    for mem, job in jobs:
        jfit, js = fit_and_score(run, *job)
        check_fit(jfit, f"law refit {job.spec.name} ({mem.law})", warnings)
        if jfit.success:
            tried.append((delta_bic(jfit, fit, base.noise_infl), paired_z(cur.e_after, js.e_after), mem, job.spec,
                          jfit, js))  # fmt: skip
    good = [t for t in tried if t[0] <= -rules.bic_margin and t[1] >= 0.0]
    if not good:
        return None
    dbic, zp, mem, spec, fit, cur = min(good, key=lambda t: t[0])
    if hold:  # the chosen member's model: the lag's delay searched again around the held one
        rfit, rcur = fit_and_score(run, spec.name, spec, spec.note, len(names) > 1, fit.params())
        check_fit(rfit, f"law refit {spec.name} ({mem.law}), the lag searched again", warnings)
        if rfit.success and rfit.sse <= fit.sse:
            fit, cur = rfit, rcur
    att.specs[e] = joint_spec(mem, base)
    sfit, ssc = fit_and_score(run, e, att.specs[e], att.specs[e].note, False, att.fits[e].params())
    att.fits[e] = sfit
    ssc.law_choice = f"law '{mem.law}' chosen in the joint model (dBIC {dbic:.0f}, held-out z {zp:.1f})"
    att.scores = [ssc if s_.name == e else s_ for s_ in att.scores]
    att.models = {k_: m for k_, m in att.models.items() if e not in k_}
    att.rewarmed = {k_ for k_ in att.rewarmed if e not in k_}
    att.models[frozenset(names)] = (spec, fit, cur)
    att.verdict.reasons.append(
        f"{e}: law '{mem.law}' instead of '{old.law}' in the joint model of {'+'.join(names)} ({ssc.law_choice})"
    )
    return spec, fit, cur


def refine_laws(run: Run, att: Attribution) -> None:
    """Stage 4c: the law of each effect found chosen again in the joint model with the others
    (:func:`rechoose_law`, effect by effect); on a change the backward check again."""
    split, base = run.split, run.base
    v = att.verdict
    names = list(v.selected)
    if att.final_fit is None or not names or not v.named:
        return
    current = (att.final_spec, att.final_fit, att.final_score)
    changed = False
    for e in tqdm(names, desc="laws in the joint model", disable=not run.progress, leave=False):
        new = rechoose_law(run, att, names, e, current)
        if new is not None:
            current, changed = new, True
    spec, fit, cur = current
    att.final_spec, att.final_fit, att.final_score = spec, fit, cur
    if not changed:
        return
    if len(names) > 1:
        # With the laws the joint model chose, an effect admitted to absorb another's law misfit (a lag next to
        # Coulomb friction that was Stribeck) may no longer be needed: the backward check again.
        slots = [list(s) for s in v.sets.slots]
        kept, slots = backward(run, att, names, slots)
        spec, fit, cur = att.models[frozenset(kept)]  # the backward check may have refitted the full model
        att.final_spec, att.final_fit, att.final_score = spec, fit, cur
        if kept != names:
            names = kept
            att.verdict = Verdict(EffectSets.of(slots), list(kept), True, v.reasons)
    att.remaining = base.floors_of(spec, fit, split)
    att.shares = {}
    if len(names) > 1:
        shares(run, att, names)


__all__ = ["backward", "confirm_slots", "joint_model", "rechoose_law", "refine_laws", "rewarmed", "shares"]
