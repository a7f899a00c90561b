"""Stage 6, refit: the constants calibrated on the clean samples, and the final model on the resolved ones.

:func:`clean_calibration` calibrates C1..C4 also on the training samples outside the regions the
localization flags (reported, not the residual baseline); :func:`resolved_refit` refits the final model on
the samples whose velocities resolve its laws and returns a new selection record with that refit.
:func:`undragged` and :func:`constants_moved` are the constants the report gives.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ...params import Params
from ...signals import PARAM_NAMES
from ..attribution import paired_z
from ..fit import Dataset, FitResult, fit_candidate, residuals_with, resolution_spread
from ..library import CandidateSpec
from ..residuals import CHANNELS, PreparedRun
from ..settings import DiagnoseSettings
from .baseline import Baseline, calibrated_free, params_with
from .localization import Localization, regions
from .models import Attribution
from .split import Split


@dataclass(frozen=True)
class CleanCalibration:
    """Where the baseline was recalibrated (the part of the data the localization finds clean)."""

    used: bool
    fraction: float
    excluded: list[dict]
    p_first: np.ndarray
    reason: str
    p_clean: np.ndarray | None = None

    def to_dict(self, p_final: np.ndarray) -> dict:
        """JSON-ready view: the excluded boxes, the clean fraction, the constants of both passes."""
        names = ("C1", "C2", "C3", "C4", "xi0", "ell")
        return {
            "calibrated_on_clean_data": self.used,
            "clean_fraction": self.fraction,
            "excluded_regions": self.excluded,
            "reason": self.reason,
            "all_training_samples": {n: float(self.p_first[PARAM_NAMES.index(n)]) for n in names},
            "clean_pass": {n: float(self.p_clean[PARAM_NAMES.index(n)]) for n in names}
            if self.p_clean is not None
            else None,
            "reported": {n: float(p_final[PARAM_NAMES.index(n)]) for n in names},
        }


def _clean_weights(runs: Sequence[PreparedRun], boxes: Sequence[tuple[list[float], list[float]]]) -> list[np.ndarray]:
    """Per-run sample weights: 0 inside any gap x position box (both channels), 1 elsewhere."""
    out = []
    for r in runs:
        w = np.ones((r.n, 2))
        if r.n:
            g, d = r.feat["g"], r.feat["d"]
            bad = np.zeros(r.n, bool)
            for (g0, g1), (d0, d1) in boxes:
                bad |= (g >= g0) & (g <= g1) & (d >= d0) & (d <= d1)
            w[bad] = 0.0
        out.append(w)
    return out


def clean_calibration(split: Split, base: Baseline, loc: Localization, st: DiagnoseSettings) -> CleanCalibration:
    """Calibrate C1..C4 (with the prior) also on the training samples outside the regions with a gap.

    An effect that lives in part of the gap x position plane (cogging at small
    gaps, end effects at the ends of the stroke, saturation near the upper
    stop) drags a calibration over all the data; here the regions the
    localization flags are left out and the constants calibrated on the rest
    (at least ``st.clean_min`` of the samples), and the result is reported.
    It is not the residual baseline: without the small gaps the gap-shape
    constants C2..C4 are poorly determined (on a saturation dataset C4 came
    out 4x nominal), and an effect that is everywhere (friction, a lag) leaves
    no clean part. What undoes the drag is the joint refit of the constants
    with the effects found (:func:`undragged`), and the prior at nominal.
    """
    keep = CleanCalibration(False, 1.0, [], base.p.copy(), "")
    if base.given:
        return replace(keep, reason="baseline given")
    regs = [r for r in regions(loc.views, base.floors) if r.n_bins > 0]
    if not loc.gap_detected or not regs:
        return replace(keep, reason="no region of the gap x position plane exceeds the floor")
    boxes = [(list(r.g_range_m), list(r.d_range_m)) for r in regs]
    row_w = _clean_weights(split.train, boxes)
    tot = sum(float(w.sum()) for w in row_w)
    frac = tot / max(sum(w.size for w in row_w), 1)
    excluded = [{"channel": r.channel, "g_range_m": b[0], "d_range_m": b[1]} for r, b in zip(regs, boxes, strict=True)]
    keep = replace(keep, fraction=frac, excluded=excluded)
    if frac < st.clean_min:
        return replace(keep, reason=f"only {frac:.0%} of the samples lie outside the regions (< {st.clean_min:.0%})")
    if frac > 0.999:
        return replace(keep, reason="the regions hold no training sample")
    data = Dataset(split.train, 1.0 / base.fvec, split.filt, row_w, base.noise_lag)
    spec = CandidateSpec("baseline", free=calibrated_free(base.params, split, st))
    fit = fit_candidate(spec, data, base.p)
    if not fit.success:
        return replace(keep, reason="the calibration on the clean samples did not converge")
    reason = (
        f"calibrated also on the {frac:.0%} of the training samples outside {len(regs)} region(s) (clean_pass); the "
        "residual baseline keeps the calibration on all training samples, and the constants reported are those of "
        "the joint refit with the effects found"
    )
    return replace(keep, used=True, p_clean=params_with(base.p, fit), reason=reason)


def resolved_masks(
    spec: CandidateSpec,
    fit: FitResult | None,
    runs: Sequence[PreparedRun],
    u_runs: Sequence[np.ndarray],
    base: Baseline,
    split: Split,
    st: DiagnoseSettings,
) -> tuple[list[np.ndarray], list[float]]:
    """Per run, the residual samples on which the model's terms are resolved by the velocities, and per channel
    the fraction resolved.

    The residual's velocities are differentiated, smoothed encoder readings; below their resolution
    ``dv = 2 pi f_v q`` (one count ``q`` per time constant of the velocity smoother of cut-off ``f_v``) they are
    not measured. A sample is unresolved when its filtered model acceleration moves by more than
    ``st.resolved_share`` of the floor as either velocity moves by ``dv``
    (:func:`.candidates.resolution_spread`: friction's sign and Stribeck terms, a guide that sticks). A channel
    with fewer than ``st.resolved_min`` resolved samples keeps all of them.
    """
    thr = st.resolved_share * base.fvec
    masks = [s_ < thr for s_ in resolution_spread(spec, fit, runs, base.p, velocity_resolution(split, base), u_runs)]
    fracs = []
    for c in range(len(CHANNELS)):
        rows = [m[:, c] for m, r in zip(masks, runs, strict=True) if r.n and r.valid[c]]
        frac = float(np.mean(np.concatenate(rows))) if rows else 1.0
        if frac < st.resolved_min:
            for m in masks:
                m[:, c] = True
        fracs.append(frac)
    return masks, fracs


def velocity_resolution(split: Split, base: Baseline) -> float:
    """The velocities' resolution [m/s]: one encoder count per time constant of the velocity smoother."""
    return 2.0 * math.pi * split.filt.settings.vel_fc_hz * base.q_enc


def partly_resolved(fracs: Sequence[float], st: DiagnoseSettings) -> bool:
    """Whether the resolved fractions of :func:`resolved_masks` leave out samples worth a separate test."""
    return not all(f > 0.995 or f < st.resolved_min for f in fracs)


def resolved_errors(
    split: Split,
    base: Baseline,
    spec: CandidateSpec,
    fit: FitResult | None,
    masks: Sequence[np.ndarray],
    held_out: bool = True,
) -> np.ndarray:
    """Floor-normalized held-out (``held_out=False``: training) residual of a fitted model on the samples
    ``masks`` keeps (for paired tests and the information criterion on the resolved samples).

    Stacked channel by channel, each run in time order (as :func:`..attribution.stack` stacks all samples), so
    that the paired test's autocorrelation estimate runs along time within a channel, not across channels.
    """
    runs, u = (split.test, split.u_test) if held_out else (split.train, split.u_train)
    res = residuals_with(spec, fit, runs, base.p, u)
    e = []
    for c in range(len(CHANNELS)):
        for r, m in zip(res, masks, strict=True):
            if r.run.n and r.run.valid[c]:
                e.append(r.r[m[:, c], c] / base.fvec[c])
    return np.concatenate(e) if e else np.zeros(0)


def resolved_refit(split: Split, base: Baseline, att: Attribution, st: DiagnoseSettings) -> Attribution:
    """The final model refitted (constants and effects jointly, prior at nominal) on the resolved samples.

    Where a selected effect's law is steep below the velocities' resolution
    (:func:`resolved_masks`; friction's sign and Stribeck terms: a guide that
    sticks holds any force up to breakaway, NOTES.md), the law cannot be
    evaluated from the data, and the misfit is not random: while a guide
    sticks, the controller's current produces no acceleration, which a joint
    fit over all samples explains by a smaller thrust constant (C1 13.8 against
    a true 14.2 on a strong-friction plant). The unresolved samples are left
    out of this refit, per channel. The refit is adopted for the constants and
    the model file (``att.model_fit``) when it fits the held-out resolved
    samples significantly better than the final fit (paired z >=
    ``st.resolved_z``: where that helps); the verdict and its scores are those
    of the selection (all samples). Returns a new record with ``model_fit`` and ``resolved`` set.
    """
    fit, spec = att.final_fit, att.final_spec
    if fit is None or spec is None or base.given or st.resolved_share <= 0 or not base.cal_free:
        return replace(att, model_fit=None, resolved={})
    masks, kept = resolved_masks(spec, fit, split.train, split.u_train, base, split, st)
    dv = velocity_resolution(split, base)
    rec: dict = {"velocity_resolution_m_s": dv, "threshold_m_s2": (st.resolved_share * base.fvec).tolist()}
    rec["adopted"] = False
    for ch, frac in zip(CHANNELS, kept, strict=True):
        rec[f"{ch}_resolved_fraction"] = frac
    if not partly_resolved(kept, st):
        rec["reason"] = "the final model's terms are resolved on (almost) every sample, or on too few: no refit"
        return replace(att, model_fit=None, resolved=rec)
    data = Dataset(split.train, 1.0 / base.fvec, split.filt, [m.astype(float) for m in masks], base.noise_lag)
    rfit = fit_candidate(spec, data, base.p, u_runs=split.u_train, warm=fit.params())
    if not rfit.success:
        rec["reason"] = f"the refit on the resolved samples did not converge ({rfit.status})"
        return replace(att, model_fit=None, resolved=rec)
    # Held-out check on the held-out runs' resolved samples (floor-normalized mean squares).
    m_test, _ = resolved_masks(spec, fit, split.test, split.u_test, base, split, st)
    es = [resolved_errors(split, base, spec, f_, m_test) for f_ in (fit, rfit)]
    ms = [float(np.mean(e**2)) if e.size else math.nan for e in es]
    z = paired_z(es[0], es[1])
    cal = [f.key for f in base.cal_free]
    rec.update(
        heldout_resolved_ms_all_samples_fit=ms[0],
        heldout_resolved_ms_resolved_fit=ms[1],
        heldout_resolved_z=z,
        all_samples_fit={k_[2:]: float(v) for k_, v in zip(spec.keys, fit.w, strict=True) if k_ in cal},
        resolved_fit={k_[2:]: float(v) for k_, v in zip(spec.keys, rfit.w, strict=True) if k_ in cal},
    )
    if not z >= st.resolved_z:
        rec["reason"] = (
            f"the refit on the resolved samples does not fit the held-out resolved samples significantly better "
            f"(paired z = {z:.1f} < {st.resolved_z:g}): the joint fit over all samples is kept"
        )
        return replace(att, model_fit=None, resolved=rec)
    rec["adopted"] = True
    rec["reason"] = (
        f"constants and effects refitted on the samples the velocities resolve (vertical {kept[0]:.0%}, horizontal "
        f"{kept[1]:.0%} of the training samples; velocity resolution {dv * 1e3:.2f} mm/s; held-out z = {z:.1f})"
    )
    return replace(att, model_fit=rfit, resolved=rec)


def undragged(base: Baseline, att: Attribution) -> Params:
    """The baseline's constants as the effects do not drag them: those of the joint refit with the verdict's
    effects when there are any (a calibrated baseline; on the resolved samples, :func:`resolved_refit`), else
    the calibration's."""
    if base.given or att.model is None:
        return base.params
    return Params.from_vector(params_with(base.p, att.model))


def constants_moved(base: Baseline, att: Attribution) -> dict[str, dict]:
    """How far the joint refit with the verdict's effects moved each calibrated constant from the baseline."""
    fit = att.model
    if fit is None or base.given:
        return {}
    cal = {f.key for f in base.cal_free}
    out = {}
    for f, v, se in zip(fit.spec.free, fit.w, fit.stderr, strict=True):
        if f.key not in cal:  # the calibrated constants (not a cogging-blind baseline's xi0 the effect moves)
            continue
        n = f.key[2:]
        b = float(base.p[PARAM_NAMES.index(n)])
        out[n] = {
            "baseline": b,
            "final": float(v),
            "change_pct": 100.0 * (float(v) - b) / b if b else math.nan,
            "change_in_stderr": (float(v) - b) / float(se) if np.isfinite(se) and se > 0 else math.nan,
            "stderr": float(se),
        }
    return out


__all__ = [
    "CleanCalibration",
    "clean_calibration",
    "constants_moved",
    "partly_resolved",
    "resolved_errors",
    "resolved_masks",
    "resolved_refit",
    "undragged",
    "velocity_resolution",
]
