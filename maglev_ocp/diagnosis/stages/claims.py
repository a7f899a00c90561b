"""Stage 5, guards: no effect claimed that is not there; a gap no signature has, located (issue 27, item 2).

An effect of the selection's verdict stays in it only when

(a) **its signature shows**: the held-out residual of the model *without* it (the baseline for a single
    effect, the others' joint model for a set) holds the effect's physical signature beyond the noise and
    beyond the other named effects' signatures (:func:`..signatures.evidence`; friction's on the gap axis by its
    dry level beyond any viscous drag, along d beyond a drag that follows the gap: an air film's damping or a
    conductor's drag is not a guide's friction); and
(b) **its gain is its own**: with the other named effects refitted with their full freedom (the most
    flexible member of each family, :func:`most_flexible`), adding it still improves the held-out runs by
    ``z_min`` (paired z, :func:`..attribution.paired_z`) on the held-out samples where it acts (its region:
    where its correction is at least the median one). A flexible member (:attr:`..library.CandidateSpec.flexible`)
    must also beat its own family's closed-form member on top of those refitted others, else the closed form
    is what is judged.

    Test (b) is one-sided, and that is right only when the others' flexible members *nest* the effect: when
    every variable of its signature is a variable of a static map of the state and the currents
    (:data:`STATIC_VARIABLES`), the others' full freedom can take its shape, and a gain that does not survive
    them is theirs. An effect whose signature depends on something no static map has (the amplifier lag: a
    force error ``dF/di * (i - u)``, i.e. proportional to the *current rate* at a fixed state) is not nested:
    the static flexible members can only imitate it through the closed loop's correlation of the current rate
    with the state (a property of the controller and the excitation, not of the physics), and they pay for it
    with their extra parameters. Then the two explanations of the same gap are compared both ways
    (:func:`_two_sided`, a non-nested model comparison in the spirit of Vuong's test): the verdict's model (the
    others at their chosen members, with the effect) against the others at full freedom without it, on the
    held-out runs. The flexible one must win by ``z_min`` to take the gap; if the verdict's model wins by
    ``z_min`` the effect is kept; if neither wins, the explanation with fewer fitted parameters is kept and the
    tie is said in the verdict's reasons. Test (a) still applies to it first, *at a fixed state*: its own
    signature (the current-rate basis) must show beyond the other effects' signatures and beyond a flexible
    static map of the velocities, the state and the currents (:func:`..signatures.static_basis`, used for every
    :attr:`~..signatures.Signature.dynamic` signature). In closed loop the current rate follows the velocity
    (held-out correlation of ``di_d/dt`` with ``g_dot`` -0.94 on the lag_lugre rig, -0.97 on the foreign rig):
    at one frequency a lag's force error ``-t dF/dt`` is a (negative) damping ``t M w^2 v``, which a friction
    law's viscous and Stribeck terms take up. Only the rate's part at a fixed velocity is the lag's own; it
    grows where the motion has several frequencies (the lag's apparent damping scales with ``w^2``, a
    friction's does not), which is the excitation that separates them.

    That generic static map is fitted *in sample*, on the held-out residual itself, with tens of columns, and
    where the loop ties the current rate closely to the velocity it takes the whole of a small lag's signature
    (library self-check, seed 1: two lags closing 85-100 % of the gap, every static candidate closing none, were
    answered `unexplained`). So when a dynamic signature shows beyond the other effects (significance and size)
    but not beyond that map, what a static *law* can do is judged out of sample instead: each static family a
    closed loop lets imitate it (:func:`static_rivals`: those whose signature has a velocity, friction and eddy
    drag) is fitted at its most flexible member in the effect's place, on the training runs, and compared both
    ways with the verdict's model on the held-out runs (:func:`_two_sided`). The signature counts as shown only
    if every rival loses by ``z_min`` (a tie is not enough); the comparisons are in the record
    (``static_rivals``).

The noise floor that test (a) measures a signature's size against is the noise model's (:mod:`..noise`) fitted
to the residual of the verdict's model, all its effects in (the lower of that and the baseline's floor,
:func:`_verdict_floors`). The noise model is fitted to the spectrum above the residual filter's cut-off, and a
baseline misfit with broad-band content there (the amplifier lag's error grows with frequency; a commutation
offset's follows the current's spectrum) raises the baseline's floor: on the foreign rig 2.3 times the verdict
model's in the vertical channel, where the held-out residual of the model without the lag was half that
floor. As in a nested F test, whose denominator is the fullest model's residual variance, the noise level is
taken from the fullest model; significance (against the circular-shift null) does not depend on it.

(c) **it is larger than what the verdict leaves**: an effect named beside others whose signature is a static map
    of the state and the currents (:func:`nested_in_static`) must explain, in some channel where its signature
    shows, at least ``leftover_ratio`` times the rms that the verdict's model leaves above the noise floor there
    (:func:`leftover_test`). What the verdict leaves is the others' misfit (a law family that misses the rig's
    shape, a hysteresis no static law has); a flexible static member fitted beside them carves out of it the
    share that projects on its own basis, which passes (a) and (b) when the leftover is large: on rigsim's
    seventh set a current-terms saturation beside a friction with frictional memory (a Stribeck level that
    follows the speed with a lag, Hess & Soom 1990) explained 0.4-1.1 floors where the friction's leftover was
    0.4-1.8 floors above the floor, on three datasets without saturation; where saturation was there it explained
    1.4-5 floors more than the leftover. In words of the nested F test: an increment smaller than the residual
    misfit it is carved from is not evidence of its own law. An effect failing (c) leaves that gap to the verdict
    (partly explained where it is located). The amplifier lag (not nested) is judged by the two-sided test
    instead.

(d) **an end effect acts at the ends**: the end effect's force lost as the array overhangs (its loss of the magnetic
    terms and its end forces, as fitted, at either end) must stay below ``end_locality`` of its largest value
    within the middle sixth of the stroke the runs visit, ``|d| <= stroke / 6`` (:func:`end_locality`). The
    calibrated constants describe the machine with the array over the stator at the stroke's middle; a loss
    already there rescales them, and one that grows from the middle is some other force that varies with
    ``|d|`` (on rigsim's ninth set, air purged through the gap under the mover's middle was taken up by end
    effects whose onset the fit put at 0-9 mm, on three of five datasets; its own end effects start 10-35 mm
    from the middle, smoothed over 6-7 mm). And its end force must be the magnets' (:func:`_origin_why`): an end
    effect seen along d alone (its signature not in the gap channel) with no loss of the magnetic terms rests on
    its end force, ``-dW/dd`` of the overlap's co-energy, which falls as the gap opens as the field's energy does
    (over ``tau / (2 pi)``); its fitted decay length plus one standard error must be at most ``end_force_decay``
    times that. A push at the stroke's end whatever the gap is a contact's (rigsim's twelfth set: end bumpers
    were taken for end effects on four of six datasets).

(e) **cogging is fixed to the position, not to the currents**: cogging is the magnets' pull on the stator's
    teeth, a force of the mover's position and gap (seed eq. (9)), whatever its law. Other forces have its
    periods: on this motor the slot pitch ``t1`` is a third of the pole pitch ``tau``, so a ripple at six times the
    electrical angle ``pi d / tau`` (an inverter's dead time, whose per-phase current error steps with each phase
    current's sign) has the slot pitch's period. Such a ripple is a function of the *currents'* electrical angle,
    ``pi d / tau + phi`` with ``phi = atan2(i_q, i_d)``: as the thrust current turns the current vector, the
    ripple moves along ``d`` by ``phi tau / pi``. :func:`..angle_lock.angle_lock` fits the structure at cogging's
    shape in the residual of the model without it (its harmonics times B-splines in the gap) and the
    coefficient ``beta`` of that shape's shift by the current angle beyond it (1 for a ripple locked to the
    currents, 0 for cogging). Where, in the channel where the shape is largest, ``beta`` is between
    ``lock_beta`` and ``lock_beta_max``, significant against the circular-shift null, and its column explains at
    least ``lock_share`` of the shape's rms, the ripple is not cogging's and cogging is not claimed. (On rigsim's
    tenth set, a dead time with clamped phases was taken for cogging on five of its six datasets. A first version
    of this test, which asked whether the ripple's size followed the currents at a fixed gap, was dropped before
    use: true cogging on the fifth to tenth sets followed them as much, through the closed loop and the residual
    filter. A hysteretic cogging of the eighth set shifts by 1.6 times the current angle: beyond ``lock_beta_max``.)
    The shift is small where the current angle swings little (within +-0.1 rad on the rigs), and a misfit of a
    large cogging's shape lends it one: on rigsim's eleventh set two true coggings gave ``beta`` 0.83 and 1.27.
    So a ripple that falls as the gap opens as a field's ripple of its period does (its decay length,
    :func:`..angle_lock.ripple_decay`, within ``lock_field_decay`` times Laplace's ``p / (2 pi)``) is kept
    whatever its shift: the magnets' pull on the teeth falls at least as ``exp(-2 pi g / p)``, a ripple of the
    currents only as the force constants do (over ``tau / pi``, 18 mm). (On the tenth and eleventh sets: seven
    true coggings 3.0-4.7 mm, five dead times 6.4-13.5 mm, against 6.1 mm for the slot pitch.)

(f) **a lag of the currents acts on both axes**: the phase current loops make ``i_q`` and ``i_d`` together, so the
    fitted amplifier lag's predicted force error must be borne out in every channel where it is visible
    (:mod:`.lag_channels`); a lag of the gap reading closes the gap channel alone.

Effects failing any of them are dropped, with the reasons in the verdict and the evidence in :class:`ClaimChecks`
(this stage's own record). What the final model leaves is then scanned for structure that no library
signature has (:func:`..signatures.locate_gap`: a period in ``d`` that is no library period, a drift in time);
a named verdict with such a gap becomes partly explained (``a+unexplained``, the gap located).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ... import constants as k
from ...effects import EndEffect
from ..angle_lock import angle_lock
from ..attribution import EffectScore, paired_z
from ..fit import FitResult, residuals_with
from ..library import CandidateSpec, combine, family_specs
from ..peaks import noise_check
from ..residuals import CHANNELS, Residual
from ..result import NoiseFindings
from ..shape_report import fit_theta
from ..signatures import SIGNATURES, SignatureEvidence, evidence, locate_gap
from ..verdict import EffectSets
from .baseline import check_fit
from .joint import joint_model, shares
from .lag_channels import lag_channels_why
from .models import Attribution, Run, fit_and_score, joint_spec, settle_verdict

#: Features a static map of the state and the currents depends on (keys of
#: :attr:`~..residuals.PreparedRun.feat`): every library member but the amplifier lag is such a map.
STATIC_VARIABLES: frozenset[str] = frozenset({"g", "d", "g_dot", "d_dot", "i_q", "i_d"})


def nested_in_static(effect: str) -> bool:
    """Whether a static map of the state and the currents can take ``effect``'s shape: every variable of its
    signature (:data:`..signatures.SIGNATURES`) is one of :data:`STATIC_VARIABLES` and the signature is not
    :attr:`~..signatures.Signature.dynamic`. False for the amplifier lag (current rates); an effect without a
    signature counts as nested (the one-sided test, the cautious one)."""
    sig = SIGNATURES.get(effect)
    return sig is None or (not sig.dynamic and set(sig.variables) <= STATIC_VARIABLES)


@dataclass
class ClaimChecks:
    """The no-false-claim guard's record.

    Attributes
    ----------
    effects : dict
        ``{effect: {signature: {...}, own_gain: {...} or None, kept: bool, why: str}}``.
    dropped : list of str
        Effects taken out of the verdict.
    gap : list of dict
        Located structure the final model leaves that no library signature has
        (:func:`..signatures.locate_gap`).
    floors : dict
        ``{channel: {baseline, verdict_model, used}}`` [m/s^2]: the noise model's floors of the baseline's and
        of the verdict model's residual, and the one test (a) measured sizes against (:func:`_verdict_floors`).
    """

    effects: dict[str, dict] = field(default_factory=dict)
    dropped: list[str] = field(default_factory=list)
    gap: list[dict] = field(default_factory=list)
    floors: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON form."""
        return {"effects": self.effects, "dropped": self.dropped, "gap": self.gap, "floors": self.floors}


def most_flexible(
    name: str, current: CandidateSpec, families: Mapping[str, tuple[CandidateSpec, ...]] | None = None
) -> CandidateSpec:
    """An effect's family member with the most freedom: a learned-shape member, else the most free parameters
    (``current`` when the family has no other member). ``families``: the candidate library in use
    (:meth:`~maglev_ocp.diagnosis.settings.DiagnoseSettings.families`; default the whole library)."""
    fam = (family_specs() if families is None else families).get(name, ())
    if not fam:
        return current
    return max(fam, key=lambda m: (m.flexible, len(m.free)))


def _floors(noise: NoiseFindings, run: Run) -> dict[str, float]:
    """The noise model's floor of each channel [m/s^2] (the data-based floor where it has none)."""
    out = {ch: fl.floor for ch, fl in run.base.floors.items() if hasattr(fl, "floor")}
    for ch, nc in noise.checks.items():
        if np.isfinite(nc.floor) and nc.floor > 0:
            out[ch] = float(nc.floor)
    return out


def _verdict_floors(
    run: Run, noise: NoiseFindings, floors: dict[str, float], verdict_res: Sequence[Residual]
) -> dict[str, dict[str, float]]:
    """The noise floor of test (a): the noise model fitted to ``verdict_res``, the residual of the verdict's model
    (training and held-out runs, as the baseline's; empty: the baseline's floors), capped at the baseline's
    floor (a misfit can only raise a noise-model floor: the lower of the two is the nearer to the noise).
    ``{channel: {baseline, verdict_model, used}}``."""
    split = run.split
    out = {ch: {"baseline": fl, "verdict_model": float("nan"), "used": fl} for ch, fl in floors.items()}
    if not verdict_res:
        return out
    q = noise.resolution(run.base.q_enc)
    for c, ch in enumerate(CHANNELS):
        nc = noise_check(verdict_res, c, split.filt.w_y, split.filt.w_a, q, split.filt.Ts, run.settings.seed)
        if nc is None or not (np.isfinite(nc.floor) and nc.floor > 0) or ch not in out:
            continue
        rec = out[ch]
        rec["verdict_model"] = float(nc.floor)
        rec["used"] = min(rec["baseline"], float(nc.floor)) if np.isfinite(rec["baseline"]) else float(nc.floor)
    return out


def _joint(run: Run, att: Attribution, specs: Sequence[CandidateSpec], what: str) -> tuple[CandidateSpec, FitResult,
                                                                                             EffectScore]:  # fmt: skip
    """A joint model of the given specs, fitted warm from the final fit and the effects' own fits."""
    spec = specs[0]
    for s in specs[1:]:
        spec = combine(spec, s)
    warm: dict[str, float] = {}
    for s in specs:
        if s.name in att.fits:
            warm.update(att.fits[s.name].params())
    if att.final_fit is not None:
        warm.update(att.final_fit.params())
    warm = {k_: v for k_, v in warm.items() if k_ in spec.keys}
    fit, sc = fit_and_score(run, spec.name, spec, spec.note, pair=True, warm=warm)
    check_fit(fit, f"{what} {spec.name}", run.warnings)
    return spec, fit, sc


def _region_z(e_without: np.ndarray, e_with: np.ndarray) -> tuple[float, float]:
    """Paired z of the model with the effect over the one without it, on all held-out samples and on its
    region (the samples where its correction is at least the median one)."""
    z_all = paired_z(e_without, e_with)
    if len(e_with) != len(e_without) or len(e_with) < 20:
        return z_all, z_all
    d = np.abs(e_without - e_with)
    sel = d >= np.median(d)
    return z_all, paired_z(e_without[sel], e_with[sel])


def leftover_excess(residuals: Sequence[Residual], floors: Mapping[str, float]) -> dict[str, float]:
    """The rms [m/s^2] per channel that ``residuals`` (the verdict model's held-out residual) hold above the noise
    floor, ``sqrt(max(rms^2 - floor^2, 0))``: the misfit test (c) compares an effect's explained rms with."""
    out: dict[str, float] = {}
    for c, ch in enumerate(CHANNELS):
        parts = [r.r[:, c] for r in residuals if r.r.shape[0]]
        y = np.concatenate(parts) if parts else np.zeros(0)
        y = y[np.isfinite(y)]
        fl = floors.get(ch, float("nan"))
        if len(y) == 0 or not (np.isfinite(fl) and fl > 0):
            continue
        out[ch] = float(np.sqrt(max(float(np.mean(y**2)) - fl**2, 0.0)))
    return out


def leftover_test(ev: SignatureEvidence, excess: Mapping[str, float], floors: Mapping[str, float],
                  ratio: float) -> dict:  # fmt: skip
    """Test (c) of the module docstring: does the effect's signature explain, in some channel where it shows, at
    least ``ratio`` times the rms the verdict's model leaves above the floor (``excess``, :func:`leftover_excess`)?

    Returns ``{per_channel: {channel: {explained_m_s2, leftover_m_s2}}, passes}``; a channel without a leftover
    figure counts as passing (nothing to compare with)."""
    per: dict[str, dict[str, float]] = {}
    passes = False
    for ch, rec in ev.per_channel.items():
        if not rec.get("shows"):
            continue
        over, fl = rec.get("rms_explained_over_floor", float("nan")), floors.get(ch, float("nan"))
        explained = over * fl
        left = excess.get(ch, float("nan"))
        per[ch] = {"explained_m_s2": float(explained), "leftover_m_s2": float(left)}
        if not (np.isfinite(explained) and np.isfinite(left)) or explained >= ratio * left:
            passes = True
    return {"per_channel": per, "passes": bool(passes)}


def _leftover_why(e: str, ev: SignatureEvidence, excess: Mapping[str, float], floors: Mapping[str, float],
                  ratio: float) -> tuple[dict | None, str]:  # fmt: skip
    """Test (c) for effect ``e`` named beside others: ``(record, why)``, ``why`` empty when it passes or does not
    apply (ratio 0, an effect no static map nests, no leftover figure)."""
    if ratio <= 0 or not excess or not nested_in_static(e):
        return None, ""
    lo = leftover_test(ev, excess, floors, ratio)
    if lo["passes"]:
        return lo, ""
    txt = ", ".join(f"{ch} {r['explained_m_s2']:.3g} against {r['leftover_m_s2']:.3g} m/s^2"
                    for ch, r in lo["per_channel"].items())  # fmt: skip
    return lo, (f"{e}: its signature explains less than the verdict's model leaves above the noise floor where it "
                f"shows ({txt}): it may be a share of the other effects' misfit, not claimed")  # fmt: skip


def _two_sided(e_flexible: np.ndarray, e_verdict: np.ndarray, k_flexible: int, k_verdict: int,
               z_min: float) -> dict:  # fmt: skip
    """Two explanations of one gap compared both ways on the held-out runs (module docstring, test (b)).

    Parameters
    ----------
    e_flexible, e_verdict : ndarray
        Held-out residuals of the others at full freedom without the effect, and of the verdict's model (the
        others at their chosen members, with the effect).
    k_flexible, k_verdict : int
        Their fitted parameters (:attr:`..fit.FitResult.k`).
    z_min : float
        The paired z either must win by.

    Returns
    -------
    dict
        ``z_region`` / ``z_all`` (the verdict's model over the flexible one, where they differ / on all
        samples), ``k_verdict``, ``k_flexible``, ``winner`` (``verdict``, ``flexible`` or ``tie``) and ``keeps``:
        the effect stays unless the flexible explanation wins, or ties with no fewer parameters.
    """
    z_all, z_reg = _region_z(e_flexible, e_verdict)
    if z_reg >= z_min and z_all > 0:
        winner = "verdict"
    elif z_reg <= -z_min and z_all < 0:
        winner = "flexible"
    else:
        winner = "tie"
    keeps = winner == "verdict" or (winner == "tie" and k_verdict < k_flexible)
    return {"z_region": z_reg, "z_all": z_all, "k_verdict": int(k_verdict), "k_flexible": int(k_flexible),
            "winner": winner, "keeps": bool(keeps)}  # fmt: skip


def _fixed_state_only(ev: SignatureEvidence) -> bool:
    """A dynamic signature that shows beyond the other effects' bases, above the size rule, in some channel, and
    fails only at a fixed state (beyond the generic static map, :func:`..signatures.static_basis`)."""
    return SIGNATURES[ev.effect].dynamic and any(
        rec.get("shows_beyond_others", False) for rec in ev.per_channel.values()
    )


def static_rivals(effect: str, families: Mapping[str, tuple[CandidateSpec, ...]]) -> list[str]:
    """The library's static families that a closed loop lets imitate a dynamic ``effect``: those whose
    signature is a force law of a velocity (a velocity among its variables, no current). At one frequency a lag's
    force error ``-t dF/dt`` is a (negative) damping ``t M w^2 v`` (module docstring), which a friction law's
    viscous and Stribeck terms or an eddy drag take up; a commutation offset's latency (a rotation of the currents
    that follows the speed) scales the currents' force and is judged by its own signature."""
    vel = {"g_dot", "d_dot"}
    return [f for f in families if f != effect and f in SIGNATURES and nested_in_static(f)
            and vel & set(SIGNATURES[f].variables) and not {"i_q", "i_d"} & set(SIGNATURES[f].variables)]  # fmt: skip


def _static_rivals(run: Run, att: Attribution, e: str, rest: Sequence[str]) -> dict[str, dict]:
    """Test (a) for a dynamic effect whose signature fails only at a fixed state (module docstring).

    The generic static map of :func:`..signatures.static_basis` is fitted *in sample*, on the held-out residual
    itself, with tens of columns: where the closed loop ties the current rate to the velocity it takes a small
    lag's whole signature, although no physical static law can (library self-check cases whose lag closes
    85-100 % of the gap, and each static candidate none). What a static *law* can do is judged out of sample: each
    static rival family (:func:`static_rivals`) at its most flexible member, with the other named effects at
    their chosen members, is fitted on the training runs in the effect's place, and compared with the verdict's
    model on the held-out runs both ways (:func:`_two_sided`). ``{family: {law, z_region, z_all, k_verdict,
    k_flexible, winner, keeps}}``; empty when there is no rival or a fit failed (then nothing is concluded).
    """
    fams = run.families()
    names = [*rest, e]
    _, vfit, vsc = joint_model(run, att, names)
    if not vfit.success:
        return {}
    out: dict[str, dict] = {}
    # A rival already named beside the effect is judged by test (b) (its full freedom against the effect).
    for f in (f for f in static_rivals(e, fams) if f not in rest):
        flex = joint_spec(most_flexible(f, fams[f][0], fams), run.base)
        _, ffit, fsc = _joint(run, att, [att.specs[o] for o in rest] + [flex], "claim guard: static rival")
        if not ffit.success:
            return {}
        two = _two_sided(fsc.e_after, vsc.e_after, ffit.k, vfit.k, run.rules.z_min)
        out[f] = {"law": flex.law, **two}
    return out


def _rivals_lose(run: Run, att: Attribution, e: str, rest: Sequence[str], rec: dict) -> bool:
    """Test (a) at a fixed state judged out of sample (:func:`_static_rivals`): True, with the reason in the
    verdict, when every static rival explains the held-out runs worse than the verdict's model; the comparisons
    go to ``rec`` (the effect's guard record)."""
    rivals = _static_rivals(run, att, e, rest)
    rec["static_rivals"] = rivals
    if not (rivals and all(r.get("winner") == "verdict" for r in rivals.values())):
        return False
    rec["signature"]["shows_against_static_rivals"] = True
    att.verdict.reasons.append(
        f"{e}: its signature shows beyond the other effects but not at a fixed state beyond a generic "
        "static map; the library's static laws a closed loop lets imitate it, fitted in its place at full "
        "freedom, explain the held-out runs worse ("
        + ", ".join(f"{f} ({r['law']}): z = {r['z_region']:.1f}" for f, r in rivals.items())
        + "): kept"
    )
    return True


def _two_txt(two: dict) -> str:
    """The two-sided comparison in words (for the verdict's reasons)."""
    if two["winner"] == "tie":
        return (
            f"as well (z = {two['z_region']:.1f} where they differ), with {two['k_flexible']} parameters "
            f"against {two['k_verdict']}: the one with fewer is kept"
        )
    better = "better" if two["winner"] == "verdict" else "worse"
    return f"{better} (the verdict's model {better} by z = {two['z_region']:.1f} where they differ)"


def _own_gain(run: Run, att: Attribution, e: str, names: Sequence[str]) -> dict:
    """Test (b): the effect's held-out gain over the others refitted with their full freedom."""
    rules = run.rules
    others = [n for n in names if n != e]
    fams = run.families()
    flex = {o: joint_spec(most_flexible(o, att.specs[o], fams), run.base) for o in others}
    reuse = all(flex[o].law == att.specs[o].law for o in others)
    if reuse:
        _, rfit, rsc = joint_model(run, att, others)
        _, ffit, fsc = joint_model(run, att, list(names))
    else:
        _, rfit, rsc = _joint(run, att, [flex[o] for o in others], "claim guard: others at full freedom")
        _, ffit, fsc = _joint(run, att, [flex[o] for o in others] + [att.specs[e]], "claim guard: with")
    out = {"others": {o: flex[o].law for o in others}, "refitted": not reuse}
    if not (rfit.success and ffit.success):
        out.update(z_all=None, z_region=None, passes=True, note="a refit did not converge: not counted against it")
        return out
    z_all, z_reg = _region_z(rsc.e_after, fsc.e_after)
    passes = z_reg >= rules.z_min and z_all > 0
    out.update(z_all=z_all, z_region=z_reg, passes=bool(passes))
    if not passes and not reuse and not nested_in_static(e) and all(nested_in_static(o) for o in others):
        _, vfit, vsc = joint_model(run, att, list(names))
        if vfit.success:
            out["two_sided"] = _two_sided(rsc.e_after, vsc.e_after, rfit.k, vfit.k, rules.z_min)
            out["passes"] = out["two_sided"]["keeps"]
    if passes and att.specs[e].flexible:
        closed = next((m for m in fams.get(e, ()) if not m.flexible), None)
        if closed is not None:
            _, cfit, csc = _joint(run, att, [flex[o] for o in others] + [joint_spec(closed, run.base)],
                                  "claim guard: closed form")  # fmt: skip
            if cfit.success:
                zc_all, zc_reg = _region_z(csc.e_after, fsc.e_after)
                out.update(closed_form=closed.law, z_over_closed_form=zc_reg,
                           flexible_justified=bool(zc_reg >= rules.z_min and zc_all > 0))  # fmt: skip
    return out


def _viscous_txt(ev: SignatureEvidence) -> str:
    """What friction's failed test (a) leaves to say when a viscous drag took the residual (its share by channel;
    empty: none): a damping of the gap without a guide's dry level, or a drag that follows the gap."""
    big = {ch: r["beyond_share"] for ch, r in ev.per_channel.items() if r.get("beyond_share", 0.0) >= 0.05}
    if not big:
        return ""
    where = ", ".join(f"{ch} {sh:.0%}" for ch, sh in big.items())
    return (
        f" (a viscous drag takes {where} of the residual, but friction's dry level does not show beyond it: a "
        "damping of the gap without a Coulomb force (an air film, a damper) or a drag that follows the gap (a "
        "conductor's) is not a guide's friction)"
    )


def _judge(run: Run, att: Attribution, e: str, rest: Sequence[str], chosen: Sequence[str],
           floors: Mapping[str, float], excess: Mapping[str, float]) -> tuple[dict, str]:  # fmt: skip
    """Tests (a)-(e) of the module docstring on effect ``e`` with ``rest`` named beside it: its guard record and
    why it is not claimed (empty: it stays). The cheap tests on its signature ((a), (e), (c)) come before the
    refits of (b)."""
    split, base, st = run.split, run.base, run.settings
    if rest:
        r_spec, r_fit, _ = joint_model(run, att, rest)
        without = residuals_with(r_spec, r_fit, split.test, base.p, split.u_test)
    else:
        without = base.b_test
    ev = evidence(e, without, dict(floors), others=rest, n_null=st.signature_null, alpha=st.signature_alpha,
                  min_over_floor=st.signature_min_floor, seed=st.seed)  # fmt: skip
    rec: dict = {"signature": ev.to_dict(), "own_gain": None}
    shows = ev.shows
    if not shows and _fixed_state_only(ev):
        shows = _rivals_lose(run, att, e, rest, rec)
    if not shows:
        why = (f"{e}: its signature ({SIGNATURES[e].symmetry}) does not show in the held-out residual of the "
               "model without it beyond the noise and the other effects' signatures: not claimed")  # fmt: skip
        if e == "friction":
            why += _viscous_txt(ev)
        return rec, why
    why = _angle_lock_why(run, e, without, floors, rest, ev, rec) if SIGNATURES[e].angle_free else ""
    if not why and rest and e in chosen:
        # Test (c), recorded whether it passes or not (the report shows its figures beside (a) and (b)).
        lo, why = _leftover_why(e, ev, excess, floors, st.leftover_ratio)
        if lo is not None:
            rec["leftover"] = lo
        if not why:
            why = _own_gain_why(run, att, e, chosen, rec)
    if e == "end_effect" and not why:
        why = _locality_why(run, att, rec) or _origin_why(run, att, ev, rec)
    if e == "amplifier_lag" and not why:
        why = lag_channels_why(run, att, [*rest, e], floors, rec)
    return rec, why


def check_claims(run: Run, att: Attribution, noise: NoiseFindings) -> ClaimChecks:
    """Tests (a) and (b) of the module docstring on every effect of the verdict; effects failing are dropped
    from ``att`` (the guard's own copy of the selection's record); then the gap the final model leaves, located.
    """
    split, base, st = run.split, run.base, run.settings
    out = ClaimChecks()
    v = att.verdict
    sets = v.sets
    floors = _floors(noise, run)
    # The verdict model's residual: its noise model is test (a)'s floor, and its held-out part is where the gap
    # is located when no effect is dropped.
    v_train: list[Residual] = []
    v_test: list[Residual] = []
    if att.final_spec is not None and att.final_fit is not None and att.final_fit.success:
        v_train = residuals_with(att.final_spec, att.final_fit, split.train, base.p, split.u_train)
        v_test = residuals_with(att.final_spec, att.final_fit, split.test, base.p, split.u_test)
    out.floors = _verdict_floors(run, noise, floors, v_train + v_test)
    sig_floors = {ch: rec["used"] for ch, rec in out.floors.items()}
    excess = leftover_excess(v_test, sig_floors)
    # The effects judged: a single slot's members (each is the verdict's candidate), else each slot's effect.
    names = list(sets.slots[0]) if len(sets.slots) == 1 else list(sets.effects)
    chosen = list(sets.effects)
    bad: list[str] = []
    for e in tqdm(names, desc="claim guard", disable=not run.progress, leave=False):
        if e not in SIGNATURES:
            continue
        rest = [] if len(sets.slots) == 1 else [n for n in chosen if n != e]
        rec, why = _judge(run, att, e, rest, chosen, sig_floors, excess)
        rec["kept"], rec["why"] = not why, why
        out.effects[e] = rec
        if why:
            bad.append(e)
            v.reasons.append(why)
    if bad:
        out.dropped = list(bad)
        _drop(run, att, bad)
    if att.verdict.named and st.gap_min_floor > 0:
        same = not bad and v_test
        final = v_test if same else residuals_with(att.final_spec, att.final_fit, split.test, base.p, split.u_test)
        out.gap = locate_gap(final, floors, min_over_floor=st.gap_min_floor, seed=st.seed)
        if out.gap:
            att.verdict.sets = att.verdict.sets.partly()
            att.verdict.reasons.append(
                "partly explained: the effects found leave a gap no library signature has: "
                + "; ".join(g["what"] for g in out.gap)
            )
    return out


def _stroke(run: Run) -> float:
    """The stroke the runs visit: the 99th percentile of ``|d|`` over the training and held-out runs [m]."""
    d_abs = np.abs(np.concatenate([r.feat["d"] for r in (*run.split.train, *run.split.test)]))
    return float(np.quantile(d_abs, 0.99)) if d_abs.size else 0.0


def _overhang_loss(grid: np.ndarray, theta: Mapping[str, float]) -> np.ndarray:
    """The fitted end effect's loss of the magnetic terms at the positions ``grid``, ``|1 - force_factor|``."""
    return np.array([abs(1.0 - float(EndEffect.force_factor(x, theta))) for x in grid])


def end_locality(run: Run, att: Attribution, n: int = 241) -> dict | None:
    """Test (d): how much of the fitted end effect's action lies in the middle sixth of the stroke visited.

    The action at ``d`` is the force lost, ``1 - factor`` with the overhang factor less the free profile
    (:meth:`EndEffect.force_factor`), or the onset of the end forces
    (:meth:`EndEffect.onset`) where they are fitted; the thrust ripple (everywhere) is not an overhang's.
    Returns ``inner_share`` (the largest action within ``|d| <= stroke / 6`` over the largest on the stroke,
    both ends), ``inner_mm``, ``stroke_mm`` (the 99th percentile of ``|d|`` in the runs), or ``None`` when the
    verdict's model has no end effect or no overhang action.
    """
    spec, fit = att.final_spec, att.final_fit
    if spec is None or fit is None or "end_effect" not in spec.effects:
        return None
    theta = fit_theta(fit, "end_effect")
    stroke = _stroke(run)
    if stroke <= 0:
        return None
    grid = np.linspace(-stroke, stroke, 2 * n - 1)
    # the force lost (``1 - EndEffect.force_factor``) or, where end forces are fitted, their onset
    act = _overhang_loss(grid, theta)
    if abs(theta["end_force"]) > 0 or abs(theta["end_i2"]) > 0:
        act = np.maximum(act, [float(EndEffect.onset(x, theta)) for x in grid])
    peak = float(act.max())
    if peak <= 1e-6:
        return None
    inner = np.abs(grid) <= stroke / 6
    return {"inner_share": float(act[inner].max() / peak), "inner_mm": stroke / 6 * 1e3, "stroke_mm": stroke * 1e3}


def _locality_why(run: Run, att: Attribution, rec: dict) -> str:
    """Test (d) for the end effect (recorded in ``rec``): why it is not claimed, empty when it passes."""
    limit = run.settings.end_locality
    loc = end_locality(run, att) if limit > 0 else None
    if loc is None:
        return ""
    rec["locality"] = loc
    if loc["inner_share"] <= limit:
        return ""
    return (f"end_effect: its loss of force reaches {loc['inner_share']:.0%} of its largest within "
            f"|d| <= {loc['inner_mm']:.0f} mm, the middle sixth of the stroke the runs visit "
            f"(+-{loc['stroke_mm']:.0f} mm; at most {limit:.0%}): an overhang acts at the ends, a force "
            "growing from the middle is not an end effect's, not claimed")  # fmt: skip


#: An end effect whose fitted loss of the magnetic terms stays below this share everywhere on the visited stroke
#: rests on its end force alone (test (d), :func:`end_origin`).
END_LOSS_NIL: float = 0.01


def end_origin(run: Run, att: Attribution) -> dict | None:
    """Test (d), the end force's origin: how the fitted end effect's end force falls as the gap opens.

    Returns ``{loss_peak, end_force_n, decay_mm, decay_se_mm, field_mm}``: the largest loss of the magnetic terms
    on the visited stroke (``1 - force_factor``), the end force at 10 mm [N], its fitted decay length in the gap
    and standard error [mm] (``inf`` where the data do not determine it), and a pole-pitch field energy's decay
    length ``tau / (2 pi)`` [mm]; ``None`` when the verdict's model has no end force.
    """
    spec, fit = att.final_spec, att.final_fit
    if spec is None or fit is None or "end_effect" not in spec.effects:
        return None
    theta = fit_theta(fit, "end_effect")
    if not theta["end_force"] > 0:
        return None
    keys = [f.key for f in fit.spec.free]
    se = float(fit.stderr[keys.index("end_effect.end_ell")]) if "end_effect.end_ell" in keys else math.inf
    stroke = _stroke(run)
    loss = float(_overhang_loss(np.linspace(-stroke, stroke, 201), theta).max())
    return {
        "loss_peak": loss,
        "end_force_n": float(theta["end_force"]),
        "decay_mm": float(theta["end_ell"]) * 1e3,
        "decay_se_mm": se * 1e3 if np.isfinite(se) else math.inf,
        "field_mm": k.tau / (2 * math.pi) * 1e3,
    }


def _origin_why(run: Run, att: Attribution, ev: SignatureEvidence, rec: dict) -> str:
    """Test (d), the end force's origin (recorded in ``rec``): why the end effect is not claimed, empty when it
    passes.

    The end force of a magnetic end effect is the overlap's co-energy pulled along d, ``-dW/dd``, and ``W``
    follows the field's energy over the iron, ``B(g)^2``: the force falls as the gap opens (over ``tau / (2 pi)``,
    9.1 mm, for the poles' fundamental; the same co-energy's ``-dW/dg`` is the pull's loss). A force along d at
    the stroke's end that does not fall with the gap is not the magnets': a stop's bumper, a cable's or a
    bellows' end pushes whatever the gap. Only an end effect seen along d alone (its signature not in the gap
    channel) and with no loss of the magnetic terms (the thrust's and the pull's, which are magnetic by
    themselves) rests on its end force; then the force's fitted decay length, plus one standard error, must be
    at most ``end_force_decay`` times ``tau / (2 pi)``. (On rigsim's eighth set the end faces' force, the
    array's exact field squared, was fitted with a decay of 8.0-9.3 mm, standard errors 0.1-7.7 mm; on the
    twelfth set the end bumpers' with 14-21 mm, standard errors 9-23 mm.)
    """
    limit = run.settings.end_force_decay
    if limit <= 0 or ev.per_channel.get("vertical", {}).get("shows"):
        return ""
    org = end_origin(run, att)
    if org is None or org["loss_peak"] >= END_LOSS_NIL:
        return ""
    rec["origin"] = org
    bound = limit * org["field_mm"]
    if org["decay_mm"] + org["decay_se_mm"] <= bound:
        return ""
    se = f"+- {org['decay_se_mm']:.1f}" if np.isfinite(org["decay_se_mm"]) else "(undetermined)"
    return (f"end_effect: it is seen along d alone, as an end force of {org['end_force_n']:.2f} N with no loss of "
            f"the magnetic terms, and that force does not fall as the gap opens as the magnets' would (decay "
            f"length {org['decay_mm']:.1f} {se} mm; at most {bound:.1f} mm): a push at the stroke's end whatever "
            "the gap is a contact's (a stop, a bumper), not the overlap's co-energy, not claimed")  # fmt: skip


def _angle_lock_why(run: Run, e: str, without: Sequence[Residual], floors: Mapping[str, float],
                    rest: Sequence[str], ev: SignatureEvidence, rec: dict) -> str:  # fmt: skip
    """Test (e) for an effect fixed to the position (:attr:`~..signatures.Signature.angle_free`, recorded in
    ``rec``): why it is not claimed, empty when it passes (module docstring)."""
    st = run.settings
    if st.lock_beta <= 0:
        return ""
    lk = angle_lock(SIGNATURES[e], without, dict(floors), others=rest, n_null=st.signature_null,
                    alpha=st.signature_alpha, seed=st.seed)  # fmt: skip
    rec["angle_lock"] = lk
    shown = [ch for ch, r in ev.per_channel.items() if r.get("shows") and ch in lk]
    if not shown:
        return ""
    # judged where its shape is largest over the floor among the channels where its signature shows
    ch = max(shown, key=lambda c: np.nan_to_num(lk[c]["own_rms_over_floor"]))
    r = lk[ch]
    band = st.lock_beta <= r["beta"] <= st.lock_beta_max
    if not (band and r["beta"] > r["beta_null_q"] and r["lock_share"] >= st.lock_share):
        return ""
    # a ripple falling with the gap as a field's of its period does is the magnets' pull on the teeth, whatever
    # its shift: a ripple of the currents is carried by the force constants, which fall far more slowly
    field_len = st.lock_field_decay * r["period_mm"] / (2 * math.pi)
    if r["decay_mm"] <= field_len:
        rec["angle_lock_field"] = True
        return ""
    return (f"{e}: in the {ch} channel its ripple moves along d with the currents' electrical angle (shift "
            f"{r['beta']:.2f} of the current vector's angle, significant above {r['beta_null_q']:.2f}; "
            f"{r['lock_share']:.0%} of the ripple's rms), and it falls as the gap opens over {r['decay_mm']:.1f} mm, "
            f"more slowly than a field's ripple of its period ({field_len:.1f} mm): a ripple the inverter or the "
            "current loop makes, locked to the currents, is not cogging (fixed to the position), "
            "not claimed")  # fmt: skip


def _own_gain_why(run: Run, att: Attribution, e: str, chosen: Sequence[str], rec: dict) -> str:
    """Test (b) for effect ``e`` named beside others (recorded in ``rec``): why it is not claimed, empty when it
    passes (a pass on the two-sided comparison alone is noted in the verdict's reasons)."""
    g = _own_gain(run, att, e, list(chosen))
    rec["own_gain"] = g
    others_txt = ", ".join(f"{o} ({law})" for o, law in g["others"].items())
    two = g.get("two_sided")
    if not g["passes"]:
        return (f"{e}: with {others_txt} refitted at full freedom it improves the held-out runs where it "
                f"acts by z = {g['z_region']:.1f} (all: {g['z_all']:.1f}; needs {run.rules.z_min:.0f})"
                + (f", and the others' extra freedom explains the same gap {_two_txt(two)}" if two else "")
                + ": its gain is another effect's misfit, not claimed")  # fmt: skip
    if two:
        att.verdict.reasons.append(
            f"{e}: with {others_txt} refitted at full freedom it improves the held-out runs where it acts by "
            f"only z = {g['z_region']:.1f}, but no static map of the state and currents nests its signature: "
            f"the verdict's model against the others' extra freedom without it {_two_txt(two)}: kept"
        )
    return ""


def _drop(run: Run, att: Attribution, bad: Sequence[str]) -> None:
    """Take ``bad`` out of the verdict and make the final model that of the effects left."""
    v = att.verdict
    sets = v.sets.without(bad)
    for s_ in att.scores:
        if s_.name in bad:
            s_.selected = False
    if not sets.named:
        v.sets, v.selected = EffectSets.gap_unexplained(), []
        v.reasons.append("no effect of the verdict is evidenced by its own signature: unexplained")
        settle_verdict(run.base, att)
        att.final_score, att.shares = None, {}
        return
    keep = list(sets.effects)
    v.sets, v.selected = sets, [n for n in v.selected if n not in bad] or keep
    att.final_spec, att.final_fit, att.final_score = joint_model(run, att, keep)
    att.remaining = run.base.floors_of(att.final_spec, att.final_fit, run.split)
    att.shares = {}
    if len(keep) > 1:
        shares(run, att, keep)
    settle_verdict(run.base, att)


__all__ = [
    "END_LOSS_NIL",
    "ClaimChecks",
    "check_claims",
    "end_origin",
    "leftover_excess",
    "leftover_test",
    "most_flexible",
    "static_rivals",
]
