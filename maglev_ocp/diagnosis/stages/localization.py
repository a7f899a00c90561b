"""Stage 3, localization: where the baseline misses, whether there is a gap at all, and the noise model.

The baseline residual binned over gap x position and each state, its spectrum and the period scan in d
(:func:`localize_gap`, :mod:`..localize`); regions of the gap x position plane (:func:`regions`); the
noise-model floor, whiteness and spectral peaks (:func:`noise_stage`, :mod:`..noise`, :mod:`..peaks`). The
result is a :class:`Localization`; the noise stage returns a new one with its evidence added, among it a
dependence of the residual on session time at a fixed state, which no library effect has (:mod:`..outside`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..localize import ChannelFloor, Region, bin_stats, edges_for, period_scan, pool, regions_from_map
from ..outside import TimeDrift, model_stiffness, time_drift
from ..peaks import NoiseCheck, SpectralPeak, confirm_peaks, noise_check
from ..residuals import CHANNELS, Residual
from ..result import ChannelView, NoiseFindings
from ..settings import DiagnoseSettings
from ..spectra import dominant_band, spectrum
from .baseline import Baseline
from .split import Split


@dataclass(frozen=True)
class Localization:
    """Stage 3: where the baseline misses, and whether there is a gap at all."""

    views: dict[str, ChannelView]
    evidence: tuple[str, ...]
    infl: np.ndarray
    fs: float
    #: Per channel, the residual's dependence on session time at a fixed state (:func:`..outside.time_drift`),
    #: significant or not (the noise stage's; empty before it).
    drifts: tuple[TimeDrift, ...] = ()

    @property
    def gap_detected(self) -> bool:
        """Any evidence of a gap beyond the floor."""
        return bool(self.evidence)

    def with_evidence(self, more: Sequence[str], drifts: Sequence[TimeDrift] = ()) -> Localization:
        """A new record with more evidence of a gap (the noise stage's), after this one's, and its drift tests."""
        return replace(self, evidence=(*self.evidence, *more), drifts=(*self.drifts, *drifts))

    @property
    def outside(self) -> tuple[TimeDrift, ...]:
        """The significant drifts: located gaps that no library effect can have caused."""
        return tuple(d for d in self.drifts if d.significant)


def views(
    res: Sequence[Residual],
    floors: np.ndarray,
    infl: np.ndarray,
    fs: float,
    fmax: float,
    rng: np.random.Generator,
    n_null: int = 12,
) -> dict[str, ChannelView]:
    """Per channel: the residual binned over gap x position and each state, its spectrum and period scan."""
    out = {}
    for c, ch in enumerate(CHANNELS):
        s = pool(res, c)
        if s.n < 50:
            continue
        eg, ed = edges_for(s.feat["g"], 10), edges_for(s.feat["d"], 10)
        mp = bin_stats(s, ("g", "d"), (eg, ed), floors[c], infl[c])
        bins = {
            n: bin_stats(s, (n,), (edges_for(s.feat[n], 16),), floors[c], infl[c])
            for n in ("g", "d", "g_dot", "d_dot", "i_q", "i_d", "di_q", "di_d")
        }
        sp = spectrum(res, c, fs, fmax)
        ps = period_scan(s, rng, n_null=n_null)
        out[ch] = ChannelView(mp, bins, sp, ps, dominant_band(sp) if sp is not None else None)
    return out


def regions(views: dict[str, ChannelView], floors: dict[str, ChannelFloor]) -> list[Region]:
    """Regions per channel: significant gap x position bins; else, for a gap the bins cannot show (a
    spectral line, a period finer than the bins, a dependence on velocity or current rate), the visited
    range with the band, the period and the excess."""
    out: list[Region] = []
    for ch, v in views.items():
        band = v.spectrum.peaks[0]["band_hz"] if v.spectrum is not None and v.spectrum.peaks else v.band
        fl = floors.get(ch)
        sigma = fl.floor if fl is not None and fl.floor > 0 else 1.0
        period = v.period.best_period if v.period is not None and v.period.significant else None
        regs = regions_from_map(v.map_gd, ch, band, sigma)
        for r in regs:
            r.period_m = period
        eg, ed = v.map_gd.edges
        whole = ([float(eg[0]), float(eg[-1])], [float(ed[0]), float(ed[-1])])
        if not regs and v.spectrum is not None and v.spectrum.peaks:
            pk = v.spectrum.peaks[0]
            amp = math.sqrt(max(pk["power_m2_s4"], 0.0))
            regs = [Region(ch, *whole, pk["band_hz"], float(amp / sigma), amp, 0, float(pk["ratio"]), period)]
        if not regs and ((fl is not None and fl.significant) or period is not None):
            exc = fl.excess if fl is not None else 0.0
            regs = [Region(ch, *whole, v.band, float(exc / sigma), exc, 0, float(fl.z) if fl else math.nan, period)]
        out += regs
    return out


def consistent_lines(train: Sequence[Residual], test: Sequence[Residual], c: int, fs: float, fmax: float) -> list[dict]:
    """Spectral lines found in both the training and the held-out residuals (each at 1 % false alarm)."""
    a = spectrum(train, c, fs, fmax, false_alarm=1e-2)
    b = spectrum(test, c, fs, fmax, false_alarm=1e-2)
    if a is None or b is None:
        return []
    out = []
    for pa in a.peaks:
        for pb in b.peaks:
            if (
                pa["band_hz"][0] <= pb["peak_hz"] <= pa["band_hz"][1]
                or pb["band_hz"][0] <= pa["peak_hz"] <= pb["band_hz"][1]
            ):
                out.append(pa)
                break
    return out


def localize_gap(split: Split, base: Baseline, st: DiagnoseSettings, rng: np.random.Generator) -> Localization:
    """Stage 3: the baseline residual over the state, its spectrum and period scan; the evidence of a gap."""
    fs = 1.0 / (split.filt.Ts * st.decimate)
    infl = np.array([base.floors[ch].inflation if ch in base.floors else 1.0 for ch in CHANNELS])
    views_ = views(base.b_train + base.b_test, base.fvec, infl, fs, st.fc_hz, rng, st.n_null)
    evidence = []
    for ch, fl in base.floors.items():
        if fl.significant:
            evidence.append(
                f"{ch}: the residual has state structure beyond the floor (held-out map gain "
                f"{fl.gain:.1%}, z = {fl.z:.1f})"
            )
    for c, ch in enumerate(CHANNELS):
        # A spectral line counts as a gap only if the training and the held-out runs both show it.
        lines = consistent_lines(base.b_train, base.b_test, c, fs, st.fc_hz)
        if lines:
            pk = lines[0]
            evidence.append(
                f"{ch}: spectral line at {pk['peak_hz']:.2f} Hz ({pk['ratio']:.0f}x the PSD around it, "
                "in training and held-out runs)"
            )
    for ch, v in views_.items():
        if v.period is not None and v.period.significant:
            evidence.append(
                f"{ch}: periodic in d with period {v.period.best_period * 1e3:.2f} mm"
                + (f" (= {v.period.match})" if v.period.match else "")
            )
    return Localization(views_, tuple(evidence), infl, fs)


def noise_stage(
    split: Split,
    base: Baseline,
    loc: Localization,
    q: float,
    seed: int = 0,
    excess_min: float = 1.5,
    drift_z: float = 4.0,
    drift_min_floor: float = 0.5,
) -> tuple[NoiseFindings, Localization]:
    """Stage 3b (noise): noise-model floors, whiteness and spectral peaks of the baseline residual (:mod:`.noise`).

    Adds to the localization's evidence of a gap what the data-based floor
    hides: peaks (resonances, lines) beyond the noise model that the training
    and the held-out runs both show, a filtered residual above
    ``excess_min`` times the noise-model floor that is not white, and a
    dependence on session time at a fixed state above the noise model's floor
    (:func:`..outside.time_drift`: no library effect depends on time, so such a
    gap is located and outside the library). Returns the findings and a new
    localization record with that evidence after its own. ``drift_z`` and ``drift_min_floor``: the drift
    test's held-out z and rms over the floor (:func:`..outside.time_drift`; a floor of 0: no test).
    """
    allr = base.b_train + base.b_test
    checks: dict[str, NoiseCheck] = {}
    evidence: list[str] = []
    peaks: list[SpectralPeak] = []
    for c, ch in enumerate(CHANNELS):
        nc = noise_check(allr, c, split.filt.w_y, split.filt.w_a, q, split.filt.Ts, seed)
        if nc is None:
            continue
        checks[ch] = nc
        conf = confirm_peaks(nc.peaks, [base.b_train, base.b_test], nc.model, c)
        peaks += conf
        for pk in conf:
            evidence.append(f"{ch}: spectral {pk.describe()}; beyond the noise model in training and held-out runs")
        if nc.excess_ratio > excess_min and not nc.whiteness.white:
            evidence.append(
                f"{ch}: filtered residual rms {nc.rms:.3g} m/s^2 is {nc.excess_ratio:.1f}x the noise-model floor "
                f"{nc.floor:.3g} m/s^2 and not white (flatness {nc.whiteness.flatness:.2f} < "
                f"{nc.whiteness.flatness_null:.2f})"
            )
    drifts: list[TimeDrift] = []
    if drift_min_floor <= 0:
        return NoiseFindings(checks, peaks), loc.with_evidence(evidence)
    stiff = model_stiffness(base.spec, base.p, split.test)
    masses = (base.params.Mv, base.params.Mh)
    for c, ch in enumerate(CHANNELS):
        fl = checks[ch].floor if ch in checks and np.isfinite(checks[ch].floor) else base.fvec[c]
        td = time_drift(base.b_train, base.b_test, c, float(fl), z_crit=drift_z, min_over_floor=drift_min_floor,
                        mass=masses[c], stiffness=float(stiff[c]))  # fmt: skip
        if td is None:
            continue
        drifts.append(td)
        if td.significant:
            evidence.append(td.describe())
    return NoiseFindings(checks, peaks), loc.with_evidence(evidence, drifts)


def noise_floor_ms(base: Baseline, noise: NoiseFindings) -> float:
    """The held-out residual's mean square if it were only noise, in units of the data-based floors ``fvec``.

    The data-based floor of a channel (:func:`.localize.channel_floor`) is what
    binned maps of the state cannot predict; a dynamic effect (friction's
    velocity sign, a lag, a resonance) is not a function of the map's states
    and stays in it, so that measured against it a candidate "closes the gap"
    while most of the effect remains. The gap a candidate closes is measured
    above the noise model's floor instead (quantization, the filter and the
    fitted noise levels, :mod:`.noise`), never above the data-based one: per
    channel ``min(noise floor / fvec, 1)^2``, averaged over the held-out samples.
    """
    num, den = 0.0, 0.0
    for c, ch in enumerate(CHANNELS):
        n = sum(r.run.n for r in base.b_test if r.run.n and r.run.valid[c])
        if not n:
            continue
        nc = noise.checks.get(ch)
        lvl = min(nc.floor / base.fvec[c], 1.0) ** 2 if nc is not None and np.isfinite(nc.floor) else 1.0
        num, den = num + n * lvl, den + n
    return num / den if den else 1.0


__all__ = ["Localization", "consistent_lines", "localize_gap", "noise_floor_ms", "noise_stage", "regions", "views"]
