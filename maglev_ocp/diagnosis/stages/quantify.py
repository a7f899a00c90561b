"""Stage 7, quantify: the final model's residuals, what stays unexplained, and each effect's consequence.

:func:`quantify` (residuals and views of the final model, remaining regions, simulated trajectories on the
held-out runs), :func:`unexplained_stage` (what the final model leaves beyond the noise model, with where),
:func:`consequence_stage` (force in N, delay in µs, closed-loop error, the model files). Each returns its
findings and, where it adds to the verdict, a new verdict.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from tqdm import tqdm

from ...constants import encoder_resolution
from ...params import NOMINAL, Params
from ..consequence import EffectSize, effect_in_model, effect_size, plant_effects, plant_file
from ..fit import residuals_with
from ..localize import Region
from ..peaks import NoiseCheck, SpectralPeak, noise_check
from ..residuals import CHANNELS, Residual
from ..result import ChannelView, Consequences, NoiseFindings
from ..settings import DiagnoseSettings
from ..simulate_compare import TrajectoryComparison, compare_trajectories
from ..spectra import wide_spectrum
from ..verdict import EffectSets, Verdict
from .baseline import Baseline, prior_sd
from .localization import Localization, regions, views
from .models import Attribution
from .split import Split


@dataclass(frozen=True)
class Quantification:
    """Stage 7: the final model's residuals and views, regions, simulated trajectories; where a gap stays."""

    residuals_after: list[Residual]
    views_after: dict[str, ChannelView]
    regions: list[Region]
    remaining_regions: list[Region]
    trajectories: TrajectoryComparison | None
    reasons: tuple[str, ...] = ()  # for an unexplained verdict: where its gap is


def quantify(
    split: Split,
    base: Baseline,
    loc: Localization,
    att: Attribution,
    st: DiagnoseSettings,
    rng: np.random.Generator,
) -> Quantification:
    """Residuals of the final model, remaining regions, short-window simulations on held-out runs; for an
    ``unexplained`` verdict, where its gap is (a reason the caller adds to the verdict)."""
    spec, fit = att.final_spec, att.final_fit
    all_after = residuals_with(spec, fit, split.train, base.p, split.u_train) + residuals_with(
        spec, fit, split.test, base.p, split.u_test
    )
    views_after = views(all_after, base.fvec, loc.infl, loc.fs, st.fc_hz, rng, st.n_null)
    regions_ = regions(loc.views, base.floors) if loc.gap_detected else []
    rem = att.remaining
    remaining_regions = regions(views_after, rem) if any(f.significant for f in rem.values()) else []
    reasons = []
    if att.verdict.sets.unexplained:
        # Where the unexplained gap is (the baseline's: no candidate closes it).
        regions_unexpl = remaining_regions or regions_
        if regions_unexpl:
            reasons.append(
                "unexplained gap: "
                + "; ".join(
                    f"{r.channel} g {r.g_range_m[0] * 1e3:.1f}..{r.g_range_m[1] * 1e3:.1f} mm, d "
                    f"{r.d_range_m[0] * 1e3:.0f}..{r.d_range_m[1] * 1e3:.0f} mm"
                    + (f", {r.freq_band_hz[0]:.2f}..{r.freq_band_hz[1]:.2f} Hz" if r.freq_band_hz else "")
                    for r in regions_unexpl[:3]
                )
            )
    traj = None
    if st.simulate:
        models = {"baseline": (base.spec, None)}
        pvecs = {"baseline": base.p}
        if fit is not None:
            models["augmented"] = (spec, fit)
            pvecs["augmented"] = base.p
        traj = compare_trajectories(split.test_in, models, pvecs, horizon=st.horizon_s)
    return Quantification(all_after, views_after, regions_, remaining_regions, traj, tuple(reasons))


@dataclass(frozen=True)
class Unexplained:
    """What the final model leaves beyond the noise model (:func:`unexplained_stage`).

    Attributes
    ----------
    checks_after : dict
        Noise-model check of the final model's residual per channel.
    remaining_peaks : list of SpectralPeak
        The baseline's confirmed peaks that keep at least half their power.
    unexplained : list of dict
        What stays unexplained, with channel, band / peak / damping and region.
    verdict : Verdict
        The verdict after this stage (``none`` with a remaining peak becomes ``unexplained``).
    """

    checks_after: dict[str, NoiseCheck]
    remaining_peaks: list[SpectralPeak]
    unexplained: list[dict]
    verdict: Verdict


def unexplained_stage(
    split: Split, base: Baseline, verdict: Verdict, q: Quantification, noise: NoiseFindings, st: DiagnoseSettings
) -> Unexplained:
    """What the final model leaves beyond the noise model, with where; ``none`` becomes ``unexplained``.

    A confirmed peak whose band keeps at least half its power under the final
    model, or a filtered residual still above 1.5x the model floor and not
    white, is listed in ``noise.unexplained`` with channel, band / peak /
    damping and region. A ``none`` verdict with such a remainder becomes
    ``unexplained``; an effect verdict keeps its effects, says what stays
    unexplained and, with a remaining peak, is partly explained (``a+unexplained``).
    Returns its findings and the verdict (a new one when it changes).
    """
    after = q.residuals_after
    checks_after: dict[str, NoiseCheck] = {}
    remaining_peaks: list[SpectralPeak] = []
    unexplained: list[dict] = []
    q_res = noise.resolution(encoder_resolution)
    for c, ch in enumerate(CHANNELS):
        nc = noise_check(after, c, split.filt.w_y, split.filt.w_a, q_res, split.filt.Ts, st.seed)
        if nc is not None:
            checks_after[ch] = nc
    for pk in noise.peaks:
        c = CHANNELS.index(pk.channel)
        sb, sa = wide_spectrum(base.b_train + base.b_test, c, split.filt.Ts), wide_spectrum(after, c, split.filt.Ts)
        if sb is None or sa is None:
            continue
        w = max(pk.damping * pk.freq_hz, sb.df)
        sel = (sb.f >= pk.freq_hz - w) & (sb.f <= pk.freq_hz + w)
        left = float(np.sum(sa.psd[sel]) / max(np.sum(sb.psd[sel]), 1e-300))
        if left >= 0.5:
            remaining_peaks.append(pk)
            unexplained.append(
                {
                    "channel": pk.channel,
                    "kind": pk.kind,
                    "freq_hz": pk.freq_hz,
                    "damping": pk.damping,
                    "band_hz": pk.band_hz,
                    "rms_m_s2": pk.rms_m_s2,
                    "rms_m": pk.rms_m,
                    "g_range_m": pk.g_range_m,
                    "d_range_m": pk.d_range_m,
                    "power_left": left,
                    "what": pk.describe(),
                }
            )
    for ch, nc in checks_after.items():
        if nc.excess_ratio > 1.5 and not nc.whiteness.white and not any(u["channel"] == ch for u in unexplained):
            regs = [r for r in (q.remaining_regions or q.regions) if r.channel == ch]
            g_r = regs[0].g_range_m if regs else []
            d_r = regs[0].d_range_m if regs else []
            band = regs[0].freq_band_hz if regs else None
            unexplained.append(
                {
                    "channel": ch,
                    "kind": "excess",
                    "rms_over_model_floor": nc.excess_ratio,
                    "band_hz": band,
                    "g_range_m": g_r,
                    "d_range_m": d_r,
                    "what": f"{ch} residual {nc.excess_ratio:.1f}x the noise-model floor, not white"
                    + (f", g {g_r[0] * 1e3:.1f}..{g_r[1] * 1e3:.1f} mm" if g_r else "")
                    + (f", d {d_r[0] * 1e3:.0f}..{d_r[1] * 1e3:.0f} mm" if d_r else "")
                    + (f", band {band[0]:.2f}..{band[1]:.2f} Hz" if band else ""),
                }
            )
    peaks_left = [u for u in unexplained if u["kind"] in ("resonance", "line")]
    v = verdict
    if peaks_left:
        v = replace(v, selected=list(v.selected), reasons=list(v.reasons))
    if not v.named and not v.sets.unexplained and peaks_left:
        v.sets, v.selected, v.gap_detected = EffectSets.gap_unexplained(), [], True
        v.reasons.append("the noise model leaves spectral peaks the data-based floor had absorbed: unexplained")
    if v.named and peaks_left:
        # The effects found and a gap they leave, located: partly explained (``a+unexplained``).
        v.sets = v.sets.partly()
    if peaks_left:
        v.reasons.append("unexplained: " + "; ".join(u["what"] for u in peaks_left))
    return Unexplained(checks_after, remaining_peaks, unexplained, v)


#: A constant further than this many prior standard deviations from the prior's centre marks a model file
#: untrusted (the prior, :func:`.baseline.prior_sd`, is the project's statement of how far a rig's constants
#: may lie from nominal; beyond it a constant has most likely absorbed an effect the model lacks).
TRUST_PRIOR_SDS: float = 4.0


def model_trust(sets: EffectSets, params: dict[str, float], ref: Params, sd: dict[str, float] | None) -> list[str]:
    """Why a model file cannot be trusted (empty: nothing known against it).

    Two findings of the diagnosis make a model file one that a controller
    should not be handed as if it were good: a gap the library did not account
    for (``unexplained``, or partly explained: the constants were fitted with
    that gap in the data, and may have absorbed it), and a constant further than
    :data:`TRUST_PRIOR_SDS` prior standard deviations from the prior's centre
    (nominal, or the ``params`` the diagnosis was given): on a rig whose
    commutation error grew along the stroke, ``unexplained`` with C1 at 2.84
    against the nominal 14.1 (-80 %, 8 sd), which took every controller off its
    targets.
    """
    why = []
    if sets.unexplained or sets.gap:
        what = "the library does not account for the gap" if sets.unexplained else "a located gap stays unexplained"
        why.append(f"verdict {sets}: {what}, and the constants were fitted with it in the data")
    refd = ref.as_dict()
    for name, rel in (sd or {}).items():
        c, v = refd.get(name), params.get(name)
        if c is None or v is None or c == 0 or rel <= 0:
            continue
        dev = (v / c - 1.0) / rel
        if abs(dev) > TRUST_PRIOR_SDS:
            why.append(
                f"{name} = {v:.4g} is {100 * (v / c - 1):+.0f} % from the prior's {c:.4g} "
                f"({abs(dev):.1f} prior sd; at most {TRUST_PRIOR_SDS:g} trusted)"
            )
    return why


def trust_marked(data: dict, why: Sequence[str]) -> dict:
    """A model file's mapping with ``trusted: false`` and the reasons first, when there are any."""
    return {"trusted": False, "untrusted_because": list(why), **data} if why else data


def consequence_stage(
    split: Split,
    base: Baseline,
    att: Attribution,
    verdict: Verdict,
    st: DiagnoseSettings,
    ref: Params | None = None,
    progress: bool = False,
) -> tuple[Consequences, Verdict]:
    """Force, delay and closed-loop consequence of every effect of the verdict; the model files.

    ``ref`` is the centre of the calibration's prior (the ``params`` the diagnosis
    was given; default nominal): the model files are marked untrusted
    (:func:`model_trust`) where the verdict or the constants say so. Returns the
    consequences and the verdict with what matters for the 0.1 mm goal among its reasons; ``progress``: a bar
    over the effects (each one's closed-loop consequence is simulated with the shipped controllers).
    """
    v = replace(verdict, selected=list(verdict.selected), reasons=list(verdict.reasons))
    names = list(v.sets.names)
    runs = split.train + split.test
    u_runs = split.u_train + split.u_test
    sizes: list[EffectSize] = []
    for n in tqdm(names, desc="consequence", disable=not progress, leave=False):
        if n not in att.fits:
            continue
        # The size of the effect in the model the user loads (the joint model), else of its single fit.
        inside = effect_in_model(att.specs[n], att.model, base.p) if att.model is not None else None
        spec, fit, p = inside if inside is not None else (att.specs[n], att.fits[n], base.p)
        sizes.append(effect_size(n, spec, fit, runs, u_runs, p, simulate=st.simulate and st.consequence))
    matters = [s.name for s in sizes if s.matters]
    negligible = [s.name for s in sizes if s.matters is False]
    if sizes and v.named:
        if matters:
            v.reasons.append(f"matters for the 0.1 mm goal: {', '.join(matters)}")
        if negligible:
            v.reasons.append(f"detectable but negligible for the 0.1 mm goal: {', '.join(negligible)}")
    p_b, e_b, _ = plant_effects(base.spec, None, base.p)
    spec = att.final_spec or base.spec
    p_m, e_m, dropped = plant_effects(spec, att.model, base.p)
    label = spec.name if att.final_fit is not None else "baseline"
    ref = ref if ref is not None else NOMINAL
    sd = prior_sd(st)
    why_m = model_trust(v.sets, p_m, ref, sd)
    why_b = model_trust(v.sets, p_b, ref, sd)
    if why_m:
        v.reasons.append("model.yaml marked untrusted: " + "; ".join(why_m))
    return Consequences(
        sizes,
        matters,
        negligible,
        trust_marked(plant_file(p_m, e_m), why_m),
        trust_marked(plant_file(p_b, e_b), why_b),
        dropped,
        label,
    ), v


__all__ = [
    "TRUST_PRIOR_SDS",
    "Quantification",
    "Unexplained",
    "consequence_stage",
    "model_trust",
    "quantify",
    "trust_marked",
    "unexplained_stage",
]
