"""Stage 5, guards: checks that can overturn a verdict, each returning a new record instead of editing it.

A lag, or a law of the gap and the currents (saturation: :func:`lineless`), whose improvement lies in a
narrow resonance is not counted (:func:`lag_guards`, :func:`apply_resonance_guard`); a verdict whose model
leaves a channel's gap mostly open, many times the noise floor, is ``unexplained`` (:func:`channel_coverage`,
:func:`apply_coverage`); an effect enters the verdict only when its own signature closes the gap it claims
(:mod:`.claims`, the no-false-claim guard) and a named verdict that leaves a located gap no library signature
has is partly explained (``a+unexplained``), among them a dependence on session time at a fixed state that
the verdict's model leaves (:func:`apply_drift`, :mod:`..outside`). :func:`run_guards` applies them in order
and returns a :class:`Guarded`.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..fit import residuals_with
from ..outside import TimeDrift, time_drift
from ..peaks import GUARD_FLAG, ResonanceGuard, SpectralPeak, confirm_peaks, resonance_guard
from ..residuals import CHANNELS, Residual
from ..result import NoiseFindings
from ..settings import DiagnoseSettings, VerdictRules
from ..signatures import SIGNATURES
from ..verdict import EffectSets
from .baseline import Baseline
from .claims import ClaimChecks, check_claims
from .localization import Localization
from .models import Attribution, Run, settle_verdict
from .split import Split


def _own(att: Attribution) -> Attribution:
    """A copy of the selection's record that a guard may change: its verdict, scores and shares copied (the
    final and best scores mapped to their copies), the fits and models shared."""
    scores = [copy.copy(s) for s in att.scores]
    mapped = {id(s): c for s, c in zip(att.scores, scores, strict=True)}
    verdict = replace(att.verdict, selected=list(att.verdict.selected), reasons=list(att.verdict.reasons))
    return replace(
        att,
        scores=scores,
        verdict=verdict,
        final_score=mapped.get(id(att.final_score), att.final_score),
        best=mapped.get(id(att.best), att.best),
        shares=dict(att.shares),
    )


def lineless(effect: str) -> bool:
    """Whether ``effect`` can leave no spectral line of its own: its signature has no period in ``d`` and reads
    only the gap, the position, the speed along d and the currents (:data:`..signatures.SIGNATURES`: saturation,
    the commutation offset and its latency, a parameter error). Such a law scales or rotates the model's own
    terms, so whatever line it makes is at a frequency of the motion, where the model predicts most of the
    measured power (a forced line, :func:`..peaks.forced_peaks`, which the resonance guard leaves out); an
    improvement that lies in a resonance the model does not predict is that resonance absorbed through the
    currents the controller moves with it (a lightly damped frame mode named ``saturation``, issue 27)."""
    sig = SIGNATURES.get(effect)
    return sig is not None and not sig.periods_m and set(sig.variables) <= {"g", "d", "d_dot", "i_q", "i_d"}


def lag_guards(split: Split, base: Baseline, att: Attribution, noise: NoiseFindings) -> dict[str, ResonanceGuard]:
    """Resonance guard of every lag-type candidate, and of every line-less effect of the verdict
    (:func:`lineless`), on the held-out runs (see :func:`..peaks.resonance_guard`).

    A lag named with other effects is judged by what it adds to them: ``before`` is the joint model of the
    others (from the backward check, :func:`.joint.backward`), ``after`` the full model, and only the
    baseline's peaks that still stand in the others' residual (training and held-out runs,
    :func:`..peaks.confirm_peaks`) are peaks it could absorb. The baseline's lines can be another effect's
    signature (saturation over a periodic excitation leaves lines at the motion's frequencies that a lag fitted
    alone partly absorbs); those are not resonances.
    """
    out = {}
    sel = list(att.verdict.selected) if att.final_fit is not None else []
    for name, spec in att.specs.items():
        if name not in att.fits or not (spec.lag or (name in sel and lineless(name))):
            continue
        rest = frozenset(n for n in sel if n != name)
        if name in sel and rest and rest in att.models:
            r_spec, r_fit, _ = att.models[rest]
            before = residuals_with(r_spec, r_fit, split.test, base.p, split.u_test)
            before_train = residuals_with(r_spec, r_fit, split.train, base.p, split.u_train)
            after = residuals_with(att.final_spec, att.final_fit, split.test, base.p, split.u_test)
            peaks = _standing_peaks(noise, [before_train, before])
        else:
            before, peaks = base.b_test, noise.peaks
            after = residuals_with(spec, att.fits[name], split.test, base.p, split.u_test)
        out[name] = resonance_guard(name, before, after, peaks, split.filt.h, split.filt.Ts)
    return out


def _standing_peaks(noise: NoiseFindings, parts: Sequence[Sequence[Residual]]) -> list[SpectralPeak]:
    """The baseline's confirmed peaks that every part of a model's residual still shows beyond the noise model."""
    out: list[SpectralPeak] = []
    for c, ch in enumerate(CHANNELS):
        pks = [p for p in noise.peaks if p.channel == ch]
        if pks and ch in noise.checks:
            out += confirm_peaks(pks, parts, noise.checks[ch].model, c)
    return out


def channel_coverage(att: Attribution, noise: NoiseFindings, rules: VerdictRules, remainder_max: float) -> list[dict]:
    """What the verdict's model closes of each channel's gap, above the noise model's floor, on the held-out runs.

    Per channel: the baseline's held-out rms ``b``, the final model's ``a``, the noise model's floor ``nf``
    (:mod:`.noise`), and the fraction of the channel's gap it closes, ``(b^2 - a^2) / (b^2 - nf^2)``. A channel
    is *short* when what remains is more than ``remainder_max`` times the floor and less than
    ``rules.closes_min`` of its gap is closed.
    """
    sc = att.final_score
    if sc is None or att.final_fit is None:
        return []
    rows = []
    for ch, (b, a) in sc.per_channel.items():
        nc = noise.checks.get(ch)
        if nc is None or not (np.isfinite(nc.floor) and nc.floor > 0 and np.isfinite(a) and np.isfinite(b)):
            continue
        gap = b * b - nc.floor**2
        closed = (b * b - a * a) / gap if gap > 0 else 1.0
        short = bool(a > remainder_max * nc.floor and closed < rules.closes_min)
        rows.append(dict(channel=ch, before_over_floor=b / nc.floor, after_over_floor=a / nc.floor,
                         closes=closed, short=short))  # fmt: skip
    return rows


def apply_coverage(
    base: Baseline, att: Attribution, noise: NoiseFindings, st: DiagnoseSettings
) -> tuple[Attribution, list[dict], dict]:
    """A verdict names the rig's gap only if its model accounts for the gap of every channel that has one.

    The verdict's "closes" pools the channels; a library effect can take up the part of an effect outside the
    library that looks like it (a drifting commutation angle mixes the levitation current into the thrust in
    proportion to ``d``: the linear part of a cable's spring) and close most of one channel's gap while the
    other keeps many times the noise floor. When the final model leaves more than ``remainder_max`` times the
    noise model's floor in a channel and closes less than ``closes_min`` of that channel's gap, the library
    does not account for it: the verdict becomes ``unexplained``, and the reasons say what the candidate
    explained, channel by channel (:func:`channel_coverage`).

    Returns the selection's record (a new one when the verdict changes), the per-channel coverage rows and,
    when the verdict was turned ``unexplained``, what explains part of the gap (else empty).
    """
    if not att.verdict.named:
        return att, [], {}
    rules = st.rules()
    rows = channel_coverage(att, noise, rules, st.remainder_max)
    short = [r for r in rows if r["short"]]
    if not short:
        return att, rows, {}
    att = _own(att)
    v = att.verdict
    parts = ", ".join(f"{r['channel']} {r['closes']:.0%}" for r in rows)
    for r in short:
        v.reasons.append(
            f"{v.verdict} closes {r['closes']:.0%} of the {r['channel']} gap above the noise model's floor and "
            f"leaves {r['after_over_floor']:.1f}x that floor (a verdict leaves at most {st.remainder_max:.0f}x "
            f"or closes {rules.closes_min:.0%} of each channel's gap): the library does not account for the "
            f"{r['channel']} gap"
        )
    v.reasons.append(f"unexplained; {v.verdict} explains part of the gap (per channel: {parts})")
    partial = {"model": v.verdict, "per_channel": rows}
    v.sets, v.selected = EffectSets.gap_unexplained(), []
    # The final model is the baseline again and no score is selected (:func:`.models.settle_verdict`); the effect
    # set's score and shares describe no verdict any more.
    settle_verdict(base, att)
    att.final_score, att.shares = None, {}
    return att, rows, partial


def apply_resonance_guard(base: Baseline, att: Attribution, guards: dict[str, ResonanceGuard]) -> Attribution:
    """A lag never absorbs a resonance: drop a flagged lag from the verdict (alone, the verdict is ``unexplained``).

    The verdict stage may call :func:`lag_guards` itself and read each guard's
    :data:`~..peaks.GUARD_FLAG`; this stage enforces it on whatever verdict it gets. Returns the
    selection's record, a new one when a lag is dropped. The lags judged are the members of a single slot
    (``a|b``) or the effects of a set (``a+b``).
    """
    sets = att.verdict.sets
    if not sets.named:
        return att
    names = list(sets.slots[0]) if len(sets.slots) == 1 else list(sets.effects)
    bad = [n for n in names if n in guards and getattr(guards[n], GUARD_FLAG)]
    if not bad:
        return att
    att = _own(att)
    v = att.verdict
    for n in bad:
        g = guards[n]
        v.reasons.append(
            f"{n}: {g.fraction_in_peaks:.0%} of its improvement lies in the residual's peak(s) at "
            + ", ".join(f"{f:.2f}" for f in g.peaks_hz)
            + (
                " Hz; a lag scales the residual smoothly over frequency"
                if att.specs[n].lag
                else " Hz; a static law of the gap and the currents makes no line the motion does not have"
            )
            + " and cannot explain a narrow resonance: not counted"
        )
    keep = [n for n in names if n not in bad]
    for s_ in att.scores:
        if s_.name in bad or s_.name == v.verdict:
            s_.selected = False
    if not keep:
        v.sets, v.selected = EffectSets.gap_unexplained(), []
        att.final_spec, att.final_fit = base.spec, None
        att.remaining = base.floors
        return att
    v.sets, v.selected = sets.without(bad), keep
    if len(keep) == 1 and keep[0] in att.fits:
        att.final_spec, att.final_fit = att.specs[keep[0]], att.fits[keep[0]]
    return att


def apply_drift(
    split: Split,
    base: Baseline,
    att: Attribution,
    loc: Localization | None,
    noise: NoiseFindings,
    st: DiagnoseSettings,
) -> tuple[Attribution, list[TimeDrift]]:
    """A named verdict cannot explain a drift in session time: with one left, it is partly explained.

    No library effect depends on time at a fixed state (:mod:`..outside`). When the localization found such a
    drift in the baseline residual (:attr:`.localization.Localization.outside`), the verdict's model is tested
    for it in turn (:func:`..outside.time_drift` on its training and held-out residuals, against the noise
    model's floor, ``st.z_min`` and ``st.drift_min_floor``): an effect's law may take up part of a drift
    through the runs' operating points, never all of it at every state. If the drift remains, the verdict
    becomes ``a+unexplained`` and its reasons say where (the swing over the session, as a force and as a
    reading drift). Returns the selection's record (a new one when the verdict changes) and the drifts that
    remain.
    """
    if loc is None or not loc.outside or not att.verdict.named or att.final_fit is None:
        return att, []
    a_train = residuals_with(att.final_spec, att.final_fit, split.train, base.p, split.u_train)
    a_test = residuals_with(att.final_spec, att.final_fit, split.test, base.p, split.u_test)
    left: list[TimeDrift] = []
    for d in loc.outside:
        c = CHANNELS.index(d.channel)
        nc = noise.checks.get(d.channel)
        fl = nc.floor if nc is not None and np.isfinite(nc.floor) else base.fvec[c]
        td = time_drift(a_train, a_test, c, float(fl), z_crit=st.z_min, min_over_floor=st.drift_min_floor,
                        mass=d.mass, stiffness=d.stiffness)  # fmt: skip
        if td is not None and td.significant:
            left.append(td)
    if not left:
        return att, []
    att = _own(att)
    att.verdict.sets = att.verdict.sets.partly()
    att.verdict.reasons.append(
        f"partly explained: {att.verdict.verdict.replace('+unexplained', '')} leaves a drift in session time that "
        "no library effect has: " + "; ".join(d.describe() for d in left)
    )
    return att, left


@dataclass(frozen=True)
class Guarded:
    """What the guards return: the selection's record as they leave it, and their own findings.

    Attributes
    ----------
    attribution : Attribution
        The selection's record, a new one if a guard changed the verdict.
    guards : dict
        ``{candidate: ResonanceGuard}`` for every lag-type candidate (:func:`lag_guards`).
    coverage : list of dict
        Per channel, what the verdict's model closes of the gap (:func:`channel_coverage`).
    partial : dict
        When the coverage turned the verdict ``unexplained``: the effect set and its coverage; else empty.
    claims : ClaimChecks or None
        The no-false-claim guard's evidence per effect and the located gap (:func:`.claims.check_claims`).
    drifts : tuple of TimeDrift
        Drifts in session time the verdict's model leaves (:func:`apply_drift`).
    warnings : tuple of str
        Fits of the guards whose solver did not converge.
    """

    attribution: Attribution
    guards: dict[str, ResonanceGuard]
    coverage: list[dict]
    partial: dict
    claims: ClaimChecks | None = None
    warnings: tuple[str, ...] = ()
    drifts: tuple[TimeDrift, ...] = ()


def run_guards(
    split: Split,
    base: Baseline,
    att: Attribution,
    noise: NoiseFindings,
    st: DiagnoseSettings,
    progress: bool = False,
    loc: Localization | None = None,
) -> Guarded:
    """The guards in order: the lags' resonance guard, the no-false-claim guard (each effect's signature and
    its gain over the others' full freedom), the channel coverage (each may overturn the verdict), then a drift
    in session time the verdict leaves (``loc``: the localization that found it, :func:`apply_drift`)."""
    guards = lag_guards(split, base, att, noise)
    att = apply_resonance_guard(base, att, guards)
    claims = None
    run = Run(split, base, st, progress=progress)
    if st.claim_guard and att.verdict.named:
        att = _own(att)
        att.models = dict(att.models)
        claims = check_claims(run, att, noise)
    att, coverage, partial = apply_coverage(base, att, noise, st)
    att, drifts = apply_drift(split, base, att, loc, noise, st)
    return Guarded(att, guards, coverage, partial, claims, tuple(run.warnings), tuple(drifts))


__all__ = [
    "Guarded",
    "apply_coverage",
    "apply_drift",
    "apply_resonance_guard",
    "channel_coverage",
    "lag_guards",
    "lineless",
    "run_guards",
]
