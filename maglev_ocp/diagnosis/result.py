"""The result of a diagnosis (:class:`Diagnosis`), its JSON content and its text summary.

Plain data built by :func:`maglev_ocp.diagnosis.diagnose.diagnose`; the files
(``report.json``, ``report.md``, figures) are written by
:func:`maglev_ocp.diagnosis.report.write_report`. ``report.json`` holds at
least the keys the issue asks for::

    {"verdict": "cogging" | "none" | "unexplained" | "<effect>" | "a|b" | "a+b",
     "effects": [{"name", "params", "heldout_rms_before", "heldout_rms_after", "reduction", "selected", ...}],
     "regions": [{"channel", "g_range_m", "d_range_m", "freq_band_hz", "excess_over_floor", ...}],
     "noise_floor": {"vertical": {...}, "horizontal": {...}},
     "baseline_params": {"C1": ..., ...}}

plus ``unexplained`` (what the final model leaves beyond the noise model: channel,
kind, frequency and damping or band, region), ``noise_model`` (model floors,
whiteness, peaks, the lag's ``resonance_guard``), ``consequences`` (force, delay,
closed-loop error per effect; which matter for the 0.1 mm goal; the model files
``model.yaml`` / ``baseline.yaml``), the reasons of the verdict, the remaining regions, the localization
summaries (spectral lines, period scan), the simulated-trajectory errors, the
train/held-out split, the timing and the ``warnings`` (fits whose solver did
not converge). ``a|b`` is a confusable set (the effects explain the held-out
runs equally well), ``a+b`` two effects together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..params import Params
from .attribution import EffectScore, Verdict
from .consequence import EffectSize
from .localize import BinStats, ChannelFloor, PeriodScan, Region
from .peaks import NoiseCheck, ResonanceGuard, SpectralPeak
from .residuals import Residual
from .settings import DiagnoseSettings
from .simulate_compare import TrajectoryComparison
from .spectra import Spectrum


@dataclass
class ChannelView:
    """Localization of one channel for one model (baseline or augmented).

    Attributes
    ----------
    map_gd : BinStats
        Residual over gap x position, with per-bin floors.
    bins : dict of BinStats
        1-D views over each feature.
    spectrum : Spectrum or None
        Welch PSD and peak bands.
    period : PeriodScan or None
        Least-squares period scan in d.
    band : list of float or None
        Band holding most of the residual's excess power.
    """

    map_gd: BinStats
    bins: dict[str, BinStats]
    spectrum: Spectrum | None
    period: PeriodScan | None
    band: list[float] | None


@dataclass
class HeldOut:
    """The held-out data of a diagnosis, for scoring other models on the same samples (self-check).

    Attributes
    ----------
    runs : list of PreparedRun
        Held-out runs.
    u : list of ndarray
        Their commanded currents.
    floors : ndarray
        Channel floors used for normalization [m/s^2].
    baseline : list of Residual
        Baseline residuals of the held-out runs.
    """

    runs: list
    u: list
    floors: np.ndarray
    baseline: list


@dataclass
class NoiseFindings:
    """What the noise model says: model floors, whiteness, peaks, what stays unexplained, the lag guard.

    Attributes
    ----------
    checks : dict
        ``{channel: NoiseCheck}`` of the baseline residual (all runs).
    peaks : list of SpectralPeak
        Baseline peaks confirmed in the training and the held-out runs alone.
    checks_after : dict
        ``{channel: NoiseCheck}`` of the final model's residual.
    remaining_peaks : list of SpectralPeak
        Confirmed peaks the final model leaves (at least half their power).
    unexplained : list of dict
        What the final model leaves beyond the noise model, each with ``channel``,
        ``kind`` (``resonance``, ``line`` or ``excess``), frequency / band / damping or
        the excess, and the region (``g_range_m``, ``d_range_m``).
    guards : dict
        ``{candidate: ResonanceGuard}`` for every lag-type candidate; the verdict
        reads ``guards[name].absorbs_resonance`` (:data:`~.noise.GUARD_FLAG`).
    coverage : list of dict
        Per channel, what the verdict's model closes of the gap above the model
        floor (``before_over_floor``, ``after_over_floor``, ``closes``, ``short``;
        :func:`~.stages.guards.channel_coverage`).
    partial : dict
        When a verdict was turned ``unexplained`` because a channel's gap stayed
        open: the effect set and its per-channel coverage (it explains part of
        the gap); empty otherwise.
    claims : dict
        The no-false-claim guard's evidence per effect, the effects it dropped and the located gap
        (:class:`~.stages.claims.ClaimChecks`); empty when it did not run.
    """

    checks: dict[str, NoiseCheck]
    peaks: list[SpectralPeak]
    checks_after: dict[str, NoiseCheck] = field(default_factory=dict)
    remaining_peaks: list[SpectralPeak] = field(default_factory=list)
    unexplained: list[dict] = field(default_factory=list)
    guards: dict[str, ResonanceGuard] = field(default_factory=dict)
    coverage: list[dict] = field(default_factory=list)
    partial: dict = field(default_factory=dict)
    claims: dict = field(default_factory=dict)

    def resolution(self, default: float) -> float:
        """The encoder resolution [m] the noise model was fitted with (its quantization part), else ``default``:
        what a noise model of another residual of the same data is fitted with."""
        return self.checks[next(iter(self.checks))].model.q if self.checks else default

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            "baseline": {ch: c.to_dict() for ch, c in self.checks.items()},
            "confirmed_peaks": [p.to_dict() for p in self.peaks],
            "final_model": {ch: c.to_dict() for ch, c in self.checks_after.items()},
            "remaining_peaks": [p.to_dict() for p in self.remaining_peaks],
            "resonance_guard": {n: g.to_dict() for n, g in self.guards.items()},
            "channel_coverage": self.coverage,
            "partly_explained_by": self.partial,
            "claim_guard": self.claims,
        }


@dataclass
class Consequences:
    """Physical size and closed-loop consequence of the found effects; the augmented model as a plant file.

    Attributes
    ----------
    sizes : list of EffectSize
        One per effect of the verdict.
    matters, negligible : list of str
        Effects that move a shipped controller by at least a tenth of the 0.1 mm
        goal, and those that do not (detectable but negligible).
    model_file : dict
        The augmented model as a plant file (``model.yaml``).
    baseline_file : dict
        The baseline as a plant file (``baseline.yaml``).
    dropped : list of str
        Fitted keys the plant file cannot carry.
    label : str
        The augmented model's name (``baseline`` if no effect was found).
    """

    sizes: list[EffectSize]
    matters: list[str]
    negligible: list[str]
    model_file: dict
    baseline_file: dict
    dropped: list[str] = field(default_factory=list)
    label: str = "baseline"

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            "effects": [s.to_dict() for s in self.sizes],
            "matters": self.matters,
            "negligible": self.negligible,
            "model": self.label,
            "model_file": "model.yaml",
            "baseline_file": "baseline.yaml",
            "dropped_from_model_file": self.dropped,
        }


@dataclass
class Diagnosis:
    """Everything a diagnosis found (see :mod:`maglev_ocp.diagnosis.report` for the files it writes).

    Attributes
    ----------
    verdict : Verdict
        The verdict and the reasons.
    scores : list of EffectScore
        Candidates (and any pair tried), ranked best first.
    floors : dict
        ``{channel: ChannelFloor}`` of the baseline.
    remaining : dict
        ``{channel: ChannelFloor}`` after the selected effect(s) (or the best candidate).
    baseline_params : Params
        The baseline model's constants as the effects do not drag them: for a
        calibrated baseline with effects found, those of the joint refit with
        the effects (the calibration alone is in ``baseline_calibration``);
        otherwise the calibrated (or given) ones.
    baseline_mode : str
        ``calibrated`` or ``given``.
    baseline_stderr : dict
        Standard errors of the calibrated constants.
    views_before, views_after : dict
        ``{channel: ChannelView}`` of the baseline and of the final model (all runs).
    regions : list of Region
        Where the baseline residual exceeds the floor.
    remaining_regions : list of Region
        Where the final model's residual still does.
    trajectories : TrajectoryComparison or None
        Short-window simulation errors on the held-out runs.
    train, test : list of str
        Run names used for fitting and for scoring.
    timing : dict
        Seconds per stage.
    residuals_before, residuals_after : list of Residual
        Baseline and final residuals of every run (for figures).
    final_model : str
        Label of the final model (``baseline`` or the selected effects).
    settings : DiagnoseSettings or None
        The settings used.
    quantization_floor : float
        Analytic quantization part of the noise floor [m/s^2].
    heldout : HeldOut or None
        Held-out data for scoring other models (self-check).
    warnings : list of str
        Fits whose solver did not converge (their candidates are not counted as evidence).
    noise : NoiseFindings or None
        Noise-model floors, whiteness, spectral peaks, the unexplained remainder, the lag guard.
    consequences : Consequences or None
        Size and closed-loop consequence of the found effects, the model files.
    effects_found : list of str
        The effects of the verdict, in the order the forward selection added them.
    shares : dict
        ``{effect: {share_of_gap, heldout_rms_reduction_m_s2, ...}}`` by drop-one refits (two or more effects).
    forward_steps : list of dict
        Every forward-selection trial (candidate, on top of what, gain, z, dBIC, accepted).
    law_members : list of EffectScore
        Law-family members fitted but not chosen.
    final_score : EffectScore or None
        The final model's score (the joint fit of the verdict's effects).
    constants_moved : dict
        ``{C: {baseline, final, change_pct, change_in_stderr}}``: the joint refit's constants against the baseline.
    baseline_calibration : dict
        How the calibrated baseline was obtained (clean samples, excluded regions, both passes' constants) and,
        under ``resolved_refit``, the final model's refit on the samples whose velocities are resolved (fractions
        kept, the constants of the fit over all samples and of the refit, held-out check, adopted or why not).
    prior : dict
        The prior at nominal of the calibration (sd and weight).
    thrust_constant : dict
        The thrust constant partialled out of the forces that do not scale with ``i_q`` (plain and partialled
        values, standard error, used or why not; :mod:`.stages.thrust`).
    residual_baseline_params : Params or None
        The constants the baseline residuals (``floors``, ``views_before``, scores' "before") were computed with.
    """

    verdict: Verdict
    scores: list[EffectScore]
    floors: dict[str, ChannelFloor]
    remaining: dict[str, ChannelFloor]
    baseline_params: Params
    baseline_mode: str
    baseline_stderr: dict[str, float]
    views_before: dict[str, ChannelView]
    views_after: dict[str, ChannelView]
    regions: list[Region]
    remaining_regions: list[Region]
    trajectories: TrajectoryComparison | None
    train: list[str]
    test: list[str]
    timing: dict[str, float] = field(default_factory=dict)
    residuals_before: list[Residual] = field(default_factory=list)
    residuals_after: list[Residual] = field(default_factory=list)
    final_model: str = "baseline"
    settings: DiagnoseSettings | None = None
    quantization_floor: float = math.nan
    heldout: HeldOut | None = None
    warnings: list[str] = field(default_factory=list)
    noise: NoiseFindings | None = None
    consequences: Consequences | None = None
    # Several effects, law families, baseline calibration (issue 11 items 2, 3, 5).
    effects_found: list[str] = field(default_factory=list)
    shares: dict[str, dict] = field(default_factory=dict)
    forward_steps: list[dict] = field(default_factory=list)
    law_members: list[EffectScore] = field(default_factory=list)
    final_score: EffectScore | None = None
    constants_moved: dict[str, dict] = field(default_factory=dict)
    baseline_calibration: dict = field(default_factory=dict)
    prior: dict = field(default_factory=dict)
    thrust_constant: dict = field(default_factory=dict)
    residual_baseline_params: Params | None = None

    def to_json(self) -> dict:
        """The ``report.json`` content."""
        return report_json(self)

    def table(self) -> str:
        """Text summary (printed by ``maglev diagnose``)."""
        return summary_table(self)


def _clean(x):
    """JSON-safe copy: numpy scalars to float, NaN/inf to None."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    return x


def report_json(d: Diagnosis) -> dict:
    """The content of ``report.json``."""
    loc = {}
    for ch, v in d.views_before.items():
        loc[ch] = {
            "spectral_peaks": v.spectrum.peaks if v.spectrum is not None else [],
            "dominant_band_hz": v.band,
            "period_scan": v.period.to_dict() if v.period is not None else None,
        }
    out = {
        "verdict": d.verdict.verdict,
        "verdict_effects": d.verdict.selected if d.verdict.named else [],
        "reasons": d.verdict.reasons,
        "effects": [s.to_dict() for s in d.scores],
        "regions": [r.to_dict() for r in d.regions],
        "remaining_regions": [r.to_dict() for r in d.remaining_regions],
        "noise_floor": {ch: f.to_dict() for ch, f in d.floors.items()},
        "remaining_floor": {ch: f.to_dict() for ch, f in d.remaining.items()},
        "quantization_floor_m_s2": d.quantization_floor,
        "baseline_params": d.baseline_params.as_dict(),
        "baseline_mode": d.baseline_mode,
        "baseline_stderr": d.baseline_stderr,
        "localization": loc,
        "trajectories": d.trajectories.to_dict() if d.trajectories is not None else None,
        "final_model": d.final_model,
        "split": {"train": d.train, "heldout": d.test},
        "timing_s": d.timing,
        "settings": d.settings.model_dump() if d.settings is not None else None,
        "warnings": d.warnings,
        "noise_model": d.noise.to_dict() if d.noise is not None else None,
        "unexplained": d.noise.unexplained if d.noise is not None else [],
        "consequences": d.consequences.to_dict() if d.consequences is not None else None,
        "effects_found": d.effects_found,
        "effect_shares": d.shares,
        "forward_selection": d.forward_steps,
        "law_members": [s.to_dict() for s in d.law_members],
        "constants_moved": d.constants_moved,
        "baseline_calibration": d.baseline_calibration,
        "baseline_prior": d.prior,
        "thrust_constant": d.thrust_constant,
        "residual_baseline_params": d.residual_baseline_params.as_dict() if d.residual_baseline_params else None,
    }
    if d.noise is not None:
        for ch, c in d.noise.checks.items():
            if ch in out["noise_floor"]:
                out["noise_floor"][ch]["model_floor_m_s2"] = c.floor
                out["noise_floor"][ch]["white"] = c.whiteness.white
    return _clean(out)


def summary_table(d: Diagnosis) -> str:
    """Text summary: verdict, floors, ranked candidates, regions."""
    lines = [f"verdict: {d.verdict.verdict}"]
    lines += [f"  - {r}" for r in d.verdict.reasons]
    lines.append(
        f"baseline ({d.baseline_mode}): "
        + ", ".join(f"{n}={getattr(d.baseline_params, n):.5g}" for n in ("C1", "C2", "C3", "C4", "xi0"))
    )
    lines.append("")
    lines.append(f"{'channel':<11} {'rms [m/s^2]':>12} {'floor':>10} {'quant.':>9} {'map gain':>9} {'z':>7}  gap")
    for ch, f in d.floors.items():
        lines.append(
            f"{ch:<11} {f.rms:12.4g} {f.floor:10.3g} {f.quantization:9.2g} {f.gain:9.1%} {f.z:7.1f}  "
            f"{'yes' if f.significant else 'no'}"
        )
    lines.append("")
    head = f"{'candidate':<32} {'before':>9} {'after':>9} {'reduction':>9} {'closes':>7} {'z':>7} {'dBIC':>8}  sel"
    lines += [head, "-" * len(head)]
    for s in d.scores:
        lines.append(
            f"{s.name:<32} {s.heldout_rms_before:9.4g} {s.heldout_rms_after:9.4g} {s.reduction:9.1%} "
            f"{s.closes:7.0%} {s.z:7.1f} {s.delta_bic:8.0f}  {'*' if s.selected else ''}"
        )
    lines += [f"  {s.name}: {s.fitted_text()}" for s in d.scores if s.selected]
    lines += _effects_lines(d)
    if d.regions:
        lines.append("")
        lines.append("regions where the baseline residual exceeds the floor:")
        for r in d.regions:
            band = f", band {r.freq_band_hz[0]:.2f}..{r.freq_band_hz[1]:.2f} Hz" if r.freq_band_hz else ""
            lines.append(
                f"  {r.channel:<10} g {r.g_range_m[0] * 1e3:6.2f}..{r.g_range_m[1] * 1e3:6.2f} mm, "
                f"d {r.d_range_m[0] * 1e3:7.2f}..{r.d_range_m[1] * 1e3:7.2f} mm{band}, "
                f"{r.excess_over_floor:.2f} x floor (z {r.z:.1f})"
            )
    if d.trajectories is not None:
        lines.append("")
        lines.append(f"simulated {d.trajectories.horizon * 1e3:.0f} ms windows on held-out runs, rms error [mm]:")
        for lab, e in d.trajectories.rms.items():
            lines.append(f"  {lab:<10} " + "  ".join(f"{ax} {v * 1e3:.4f}" for ax, v in e.items() if v is not None))
    lines += _noise_lines(d)
    lines += [f"warning: {w}" for w in d.warnings]
    lines.append(f"\ntime: {d.timing.get('total_s', float('nan')):.1f} s")
    return "\n".join(lines)


def _noise_lines(d: Diagnosis) -> list[str]:
    """Summary lines of the noise model, the unexplained remainder and the effects' sizes."""
    lines: list[str] = []
    if d.noise is not None and d.noise.checks:
        lines.append("")
        lines.append("noise model (floor from quantization, encoder and acceleration noise through the filter):")
        for ch, c in d.noise.checks.items():
            lines.append(
                f"  {ch:<10} model floor {c.floor:.3g} m/s^2 (quantization {c.quantization:.2g}), residual rms "
                f"{c.rms:.3g} = {c.excess_ratio:.1f}x, {'white' if c.whiteness.white else 'not white'} "
                f"(flatness {c.whiteness.flatness:.2f}, null {c.whiteness.flatness_null:.2f})"
            )
        for p in d.noise.peaks:
            lines.append(f"  peak: {p.describe()}")
        for u in d.noise.unexplained:
            lines.append(f"  unexplained: {u['what']}")
        for n, g in d.noise.guards.items():
            if g.absorbs_resonance:
                lines.append(
                    f"  {n}: {g.fraction_in_peaks:.0%} of its improvement lies in the resonance peaks: "
                    "a lag cannot explain a narrow resonance"
                )
    if d.consequences is not None and d.consequences.sizes:
        lines.append("")
        lines.append("size and consequence of the effects found:")
        lines += [f"  {s.summary}" for s in d.consequences.sizes]
    return lines


__all__ = [
    "ChannelView",
    "Consequences",
    "DiagnoseSettings",
    "Diagnosis",
    "HeldOut",
    "NoiseFindings",
    "report_json",
    "summary_table",
]


def _effects_lines(d: Diagnosis) -> list[str]:
    """Text lines: each effect's law and share of the gap, the constants' move, the calibration."""
    lines = []
    for e, sh in d.shares.items():
        lines.append(
            f"  share of the gap: {e} ({sh.get('law', 'default')}) {sh['share_of_gap']:.0%} "
            f"(held-out rms reduction {sh['heldout_rms_reduction_m_s2']:.3g} m/s^2)"
        )
    for s in d.scores:
        if s.selected and s.law_choice:
            lines.append(f"  {s.name}: {s.law_choice}")
    if d.baseline_calibration:
        lines.append(f"  baseline calibration: {d.baseline_calibration.get('reason', '')}")
    if d.constants_moved:
        lines.append(
            "  constants, baseline -> joint refit with the effects: "
            + ", ".join(
                f"{n} {v['baseline']:.4g} -> {v['final']:.4g} ({v['change_pct']:+.1f} %, "
                f"{v['change_in_stderr']:+.1f} se)"
                for n, v in d.constants_moved.items()
            )
        )
    return lines
