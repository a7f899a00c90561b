"""What a diagnosis is asked: its settings (:class:`DiagnoseSettings`) and the verdict's thresholds.

:class:`DiagnoseSettings` is validated by pydantic (:class:`~maglev_ocp.config.Strict`: unknown keys and
impossible values are refused); :class:`VerdictRules` is the subset the verdict's tests read.
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import Field, field_validator

from ..config import Strict
from .library import CandidateSpec, family_specs


@dataclass(frozen=True)
class VerdictRules:
    """Thresholds of the verdict.

    Attributes
    ----------
    z_min : float
        Held-out improvement significance a candidate needs.
    bic_margin : float
        Required drop of the training information criterion.
    closes_min : float
        Fraction of the gap an effect (or pair) must close to be named.
    confusable_z : float
        Candidates within this paired z of the best form a confusable set.
    second_min : float
        Fraction of the *remaining* gap a second effect must close to be added.
    """

    z_min: float = 4.0
    bic_margin: float = 10.0
    closes_min: float = 0.5
    confusable_z: float = 2.0
    second_min: float = 0.5


class DiagnoseSettings(Strict):
    """Settings of :func:`diagnose` (all have defaults that suit 1 kHz rig logs).

    Attributes
    ----------
    fc_hz, numtaps, decimate : float, int, int
        Residual filter (see :class:`~.residuals.ResidualSettings`).
    holdout_every : int
        Hold out every n-th run (at least one).
    candidates : list of str or None
        Restrict the candidate library (default: all; ``parameter_error`` is
        dropped against a calibrated baseline, which absorbs it).
    z_min, bic_margin, closes_min, confusable_z, second_min : float
        Verdict thresholds (see :class:`~.attribution.VerdictRules`).
    n_null : int
        Null draws (circular shifts) of the period scan's threshold, an
        extreme-value quantile at a false alarm of 1e-3 per channel (its scale
        is estimated to about ``sqrt(1.1 / n_null)``, 10 % at 100).
    seed : int
        Seed of the null draws and subsampling (same seed, same report).
    horizon_s : float
        Window of the simulated-trajectory comparison [s].
    simulate : bool
        Run the trajectory comparison.
    consequence : bool
        Simulate each found effect's closed-loop consequence with the shipped
        controllers (only with ``simulate``).
    prior_sd : float
        Sd of the Gaussian prior at nominal on C1..C3 of a calibrated baseline,
        relative to nominal (C4, xi0 and ell five times looser; 0: no prior).
    baseline_cogging : bool
        The calibrated baseline carries the shared model's cogging law (seed
        eq. (9), MODEL.md) with xi0 and ell calibrated, so that cogging that
        follows eq. (9) is part of the baseline and only cogging that differs
        is an effect (default); off: the cogging-blind seed eq. (2).
    clean_min : float
        Smallest fraction of the training samples outside the regions with a
        gap for the baseline to be recalibrated on them.
    max_effects : int
        Most effects the forward selection holds at once. One more than the
        sets the self-checks draw (three): an effect that entered early to take
        up another's law misfit (a saturation standing in for an end effect's
        overhang loss) leaves through the backward check once the true effect
        has entered as a fourth (independent rig, seed 47 #48).
    forward_pool, forward_z : int, float
        Candidates refitted jointly with the current model at each forward
        step: the ``forward_pool`` converged singles with the best information
        criterion whose own held-out z exceeds ``forward_z`` (default: every
        other library effect, no gate; a single's scores are corrupted by the
        other effects still in its residual).
    family_top : int
        Effects (the best singles) whose whole law family is fitted. 8: every library effect's (the families
        exist because a default member the data do not favour may hide a member they do, and ranking by the
        default member missed one each time the bar was lower: at 4, a cogging whose normal force is not the
        library's (default member dBIC +18) ranked behind eddy drag (+7) and its learned member, which closes
        92 % of the gap, was never tried; at 5, a saturation whose current terms fall faster than the magnets'
        pull (default member +16, stuck at zero loss) ranked sixth while its current-terms and per-term members
        halve the vertical residual).
    z_enter : float
        Held-out z for the forward selection to admit an effect (the
        backward check then asks ``z_min`` of each one in the full model).
    resolved_share : float
        The final model's constants and effects are refitted on the training
        samples whose model acceleration the measured velocities determine:
        those where a change of the velocities by their resolution moves it by
        less than this share of the channel's floor (0: no such refit).
    resolved_min : float
        Smallest fraction of a channel's training samples that must be
        resolved for that channel to be restricted to them.
    resolved_z : float
        The refit on the resolved samples is adopted when it fits the held-out
        runs' resolved samples better than the fit over all samples by this
        paired z (one standard error: the refit adds no effect and changes no
        verdict, it only removes samples a steep law cannot be evaluated on).
    remainder_max : float
        A verdict stands only if, in every channel where its model leaves more
        than this many times the noise model's floor (held-out rms), it closes
        at least ``closes_min`` of that channel's gap; otherwise the library
        does not account for the gap: ``unexplained``. On the independent rig,
        right verdicts that close less than half of a channel's gap leave at
        most 1.9x there, and where they leave more (up to 27x, a steep end
        effect's law misfit) they close at least 66 %; a cable spring taken up
        by a commutation drift leaves 19-32x and closes 33-47 %.
    claim_guard : bool
        The no-false-claim guard (:mod:`.stages.claims`): an effect stays in the verdict only when its
        signature shows in the held-out residual of the model without it and its gain survives the other
        effects refitted at full freedom; a named verdict leaving a gap no signature has is partly explained.
    signature_null : int
        Circular shifts of the null reference of a signature test (:func:`.signatures.evidence`).
    signature_alpha : float
        The signature must explain more than the null's ``1 - signature_alpha`` quantile.
    signature_min_floor : float
        ... and at least this rms over the channel's noise floor where its share is just above that quantile
        (beyond twice the quantile lower, to half of it at eight times: :func:`.signatures.material_bar`).
    leftover_ratio : float
        Test (c) of the claim guard (:mod:`.stages.claims`): an effect named beside others whose signature is a
        static map of the state and the currents stays only if, in some channel where its signature shows, the
        rms its signature explains is at least this many times the rms the verdict's model leaves above the
        noise floor there (the others' leftover misfit, out of which a flexible member can carve a share of
        its own shape; 0: no test).
    end_locality : float
        Test (d) of the claim guard (:mod:`.stages.claims`): an end effect stays only if its force lost as the
        array overhangs stays below this share of its largest value within the middle sixth of the stroke the
        runs visit, ``|d| <= stroke / 6`` (an overhang acts at the ends; 0: no test).
    end_force_decay : float
        Test (d) of the claim guard, the end force's origin: an end effect seen only along d (its signature not
        in the gap channel) whose fitted loss of the magnetic terms is nil rests on its end force alone, and stays
        only if that force falls as the gap opens as the overlap's co-energy does: its fitted decay length in the
        gap, plus one standard error, at most this many times a pole-pitch field energy's ``tau / (2 pi)`` (a
        contact at the stroke's end, a bumper or a stop, pushes whatever the gap; 0: no test).
    lock_beta : float
        Test (e) of the claim guard (:mod:`.stages.claims`): cogging is not claimed when, in the channel where its
        shape is largest, the shape moves along ``d`` with the currents' electrical angle by at least this
        fraction of the current vector's angle (1: a ripple locked to the currents; significant against the
        circular-shift null; :func:`.angle_lock.angle_lock`) (0: no test).
    lock_beta_max : float
        ... and at most this fraction (a ripple locked to the currents shifts by their angle, 1; noise biases
        the estimate towards 0, not beyond 1: a larger shift is some other law's);
    lock_share : float
        ... and the shift's column explains at least this share of the shape's rms.
    lock_field_decay : float
        ... unless the shape falls as the gap opens as a field's ripple of its period ``p`` does: its decay length
        (:func:`.angle_lock.ripple_decay`) at most this many times Laplace's ``p / (2 pi)`` in the gap (the
        magnets' pull on the teeth; a ripple of the currents falls with the force constants, over ``tau / pi``,
        about 18 mm; 0: no such exception).
    lag_channel_min : float
        Test (f) of the claim guard (:mod:`.stages.lag_channels`): one lag of the phase currents acts on the
        thrust and the lift alike, so in every channel where the fitted amplifier lag predicts a force error of at
        least this many noise floors (rms on the held-out runs), the held-out residual must bear it out (0: no
        test);
    lag_borne_min : float
        ... by at least this least-squares coefficient of the residual without the lag on the lag's predicted
        error (1: in full; a lag of the gap measurement leaves the thrust channel near 0).
    gap_min_floor : float
        A located gap (a period in d that is no library period, a drift in time) is reported when it explains
        at least this rms over the channel's noise floor (0: no search).
    drift_min_floor : float
        A dependence of the baseline residual on session time at a fixed state (:mod:`.outside`) is evidence of
        a gap when its rms on the held-out runs is at least this over the noise floor and its held-out z at
        least ``z_min`` (0: no test).
    exclude_laws : dict of str to list of str
        Law-family members left out of the candidate library, by effect (``{"end_effect": ["two ends"]}``;
        the member names are :func:`.library.family_specs`' ``law``, ``default`` for the library's own law).
        An effect whose every member is left out is not a candidate at all. For the leave-one-law-out check
        (:mod:`.selftest_lolo`: is a rig law still named when the members written to match it are gone?);
        an unknown effect or member is refused with the allowed ones. Read through :meth:`families`.
    fit_workers : int
        Processes the selection's independent fits (the candidates, each forward step's joint refits, the
        backward check's drop-one models) are spread over; 0: one per available CPU, at most 4, and 1 inside
        a worker process of a self-check or campaign (its siblings use the other cores). The result does not
        depend on it: the same fits, from the same starts, used in the same order.
    """

    fc_hz: float = Field(15.0, gt=0.5, le=200.0)
    numtaps: int = Field(401, ge=31, le=4001)
    decimate: int = Field(8, ge=1, le=100)
    holdout_every: int = Field(3, ge=2, le=20)
    candidates: list[str] | None = None
    z_min: float = Field(4.0, gt=0)
    bic_margin: float = Field(10.0, ge=0)
    closes_min: float = Field(0.5, gt=0, le=1)
    confusable_z: float = Field(2.0, ge=0)
    second_min: float = Field(0.5, gt=0, le=1)
    n_null: int = Field(100, ge=20, le=1000)
    seed: int = Field(0, ge=0)
    horizon_s: float = Field(0.05, gt=0.002, le=1.0)
    simulate: bool = True
    consequence: bool = True
    prior_sd: float = Field(0.1, ge=0.0, le=10.0)
    clean_min: float = Field(0.3, ge=0.0, le=1.0)
    baseline_cogging: bool = True
    max_effects: int = Field(4, ge=1, le=8)
    forward_pool: int = Field(6, ge=0, le=10)
    forward_z: float = Field(-100.0, ge=-100.0)
    family_top: int = Field(8, ge=0, le=10)
    z_enter: float = Field(2.0, ge=0.0)
    resolved_share: float = Field(0.5, ge=0.0, le=10.0)
    resolved_min: float = Field(0.1, ge=0.0, le=1.0)
    resolved_z: float = Field(1.0, ge=0.0)
    remainder_max: float = Field(3.0, ge=1.0, le=100.0)
    claim_guard: bool = True
    signature_null: int = Field(60, ge=20, le=1000)
    signature_alpha: float = Field(0.01, gt=0.0, lt=0.5)
    signature_min_floor: float = Field(0.3, ge=0.0, le=10.0)
    leftover_ratio: float = Field(1.0, ge=0.0, le=10.0)
    end_locality: float = Field(0.1, ge=0.0, le=1.0)
    end_force_decay: float = Field(2.0, ge=0.0, le=10.0)
    lock_beta: float = Field(0.3, ge=0.0, le=2.0)
    lock_beta_max: float = Field(1.3, ge=0.0, le=5.0)
    lock_share: float = Field(0.05, ge=0.0, le=1.0)
    lock_field_decay: float = Field(2.0, ge=0.0, le=10.0)
    lag_channel_min: float = Field(0.5, ge=0.0, le=100.0)
    lag_borne_min: float = Field(0.5, ge=0.0, le=2.0)
    gap_min_floor: float = Field(1.0, ge=0.0, le=100.0)
    drift_min_floor: float = Field(0.5, ge=0.0, le=100.0)
    exclude_laws: dict[str, list[str]] = Field(default_factory=dict)

    @field_validator("exclude_laws")
    @classmethod
    def _known_laws(cls, value: dict[str, list[str]]) -> dict[str, list[str]]:
        """Every effect and member named must exist in the library (the allowed ones in the message)."""
        fam = family_specs()
        for effect, laws in value.items():
            if effect not in fam:
                raise ValueError(f"unknown effect {effect!r}; allowed: {', '.join(fam)}")
            allowed = [m.law for m in fam[effect]]
            bad = [law for law in laws if law not in allowed]
            if bad:
                raise ValueError(f"{effect}: unknown law member(s) {bad}; allowed: {allowed}")
        return value

    def families(self) -> dict[str, tuple[CandidateSpec, ...]]:
        """The candidate library the diagnosis uses: :func:`.library.family_specs` less the members of
        ``exclude_laws`` (an effect with no member left is dropped). Each family's first member is the one
        fitted alone first (the library's law unless that is excluded)."""
        out = {}
        for effect, members in family_specs().items():
            drop = set(self.exclude_laws.get(effect, ()))
            kept = tuple(m for m in members if m.law not in drop)
            if kept:
                out[effect] = kept
        return out

    fit_workers: int = Field(0, ge=0, le=64)

    def rules(self) -> VerdictRules:
        """Verdict thresholds."""
        return VerdictRules(self.z_min, self.bic_margin, self.closes_min, self.confusable_z, self.second_min)


__all__ = ["DiagnoseSettings", "VerdictRules"]
