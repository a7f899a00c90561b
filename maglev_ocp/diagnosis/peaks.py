"""Spectral peaks of the residual beyond the noise model: lines and resonances with frequency and damping.

:func:`find_peaks` (bands whose Welch PSD exceeds the noise model's, :mod:`.noise`), :func:`fit_resonance`
(a second-order mode's frequency and damping), :func:`noise_check` (floor, whiteness and peaks of a channel),
:func:`confirm_peaks` (peaks every part of the data shows), and the lag's :func:`resonance_guard` (a lag whose
improvement lies in a narrow resonance is not counted).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.ndimage as ndi
import scipy.optimize as so
import scipy.signal as sps
import scipy.stats as st

from .. import constants as k
from .noise import NoiseModel, Whiteness, log_bias, noise_levels, whiteness
from .residuals import CHANNELS, Residual
from .spectra import WideSpectrum, motion_spectrum, wide_spectrum


@dataclass
class SpectralPeak:
    """A peak of a channel's wide-band residual spectrum, fitted with a second-order resonance.

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    band_hz : list of float
        Band where the PSD exceeds its baseline [Hz].
    peak_hz : float
        Frequency of the largest bin [Hz].
    freq_hz : float
        Fitted natural frequency ``f0`` [Hz].
    damping : float
        Fitted damping ratio ``zeta`` (for a line: the resolution's upper bound).
    resolved : bool
        The peak is wider than the spectral resolution (a resonance); else a line (a sinusoid).
    ratio : float
        PSD over baseline at the peak.
    power_m2_s4 : float
        Power above the baseline in the band [(m/s^2)^2].
    rms_m_s2 : float
        ``sqrt(power)``: rms acceleration of the peak [m/s^2].
    rms_m : float
        The same as a displacement, ``rms_m_s2 / (2 pi f0)^2`` [m].
    g_range_m, d_range_m : list of float
        Where in gap and position the band's power lives (the visited range if it is uniform).
    """

    channel: str
    band_hz: list[float]
    peak_hz: float
    freq_hz: float
    damping: float
    resolved: bool
    ratio: float
    power_m2_s4: float
    rms_m_s2: float
    rms_m: float
    g_range_m: list[float] = field(default_factory=list)
    d_range_m: list[float] = field(default_factory=list)
    shape: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def kind(self) -> str:
        """``resonance`` (resolved width) or ``line``."""
        return "resonance" if self.resolved else "line"

    def to_dict(self) -> dict:
        """JSON-ready view."""
        out = {kk: v for kk, v in self.__dict__.items() if kk != "shape"}
        out["kind"] = self.kind
        return out

    def describe(self) -> str:
        """One-line description."""
        z = f"damping {self.damping:.3f}" if self.resolved else f"damping < {self.damping:.3f} (width not resolved)"
        where = ""
        if self.g_range_m:
            where = f", g {self.g_range_m[0] * 1e3:.1f}..{self.g_range_m[1] * 1e3:.1f} mm"
        if self.d_range_m:
            where += f", d {self.d_range_m[0] * 1e3:.0f}..{self.d_range_m[1] * 1e3:.0f} mm"
        return (
            f"{self.channel} {self.kind} at {self.freq_hz:.2f} Hz ({z}), band {self.band_hz[0]:.2f}.."
            f"{self.band_hz[1]:.2f} Hz, {self.rms_m_s2:.3g} m/s^2 rms ({self.rms_m * 1e6:.2f} um){where}"
        )


def _window_kernel(nper: int, over: int) -> np.ndarray:
    """Power response of the Hann window on a grid ``over`` times finer than the bins (unit sum)."""
    w = sps.get_window("hann", nper)
    W = np.abs(np.fft.fft(w, nper * over)) ** 2
    W = np.fft.fftshift(W)
    c = len(W) // 2
    half = 4 * over
    ker = W[c - half : c + half + 1]
    return ker / ker.sum()


@dataclass
class Resonance:
    """A second-order resonance fitted to a spectral peak.

    Attributes
    ----------
    f0, zeta, amplitude : float
        Natural frequency [Hz], damping ratio, and the level ``A`` of
        ``A f^4 / ((f0^2 - f^2)^2 + (2 zeta f0 f)^2)``.
    shape : ndarray
        The fitted peak's PSD (window included) on the spectrum's bins.
    """

    f0: float
    zeta: float
    amplitude: float
    shape: np.ndarray


def fit_resonance(spec: WideSpectrum, background: np.ndarray, peak_hz: float, width_hz: float) -> Resonance:
    """Fit a second-order resonance to the PSD around ``peak_hz`` (Welch window included).

    Parameters
    ----------
    spec : WideSpectrum
        The spectrum.
    background : ndarray
        PSD without the peak (same bins); a free factor scales it in the fit.
    peak_hz, width_hz : float
        Largest bin and the band's width (start values).
    """
    df = spec.df
    half = max(8 * df, 4 * width_hz, 0.25 * peak_hz)
    sel = (spec.f >= peak_hz - half) & (spec.f <= peak_hz + half) & (spec.f > 0)
    f, p, b = spec.f[sel], spec.psd[sel], np.maximum(background[sel], 1e-300)
    over = 8
    ker = _window_kernel(spec.nperseg, over)

    def shape_at(fq: np.ndarray, f0: float, zeta: float) -> np.ndarray:
        fine = np.arange(fq[0] - 4 * df, fq[-1] + 4 * df + df / (2 * over), df / over)
        den = (f0**2 - fine**2) ** 2 + (2 * zeta * f0 * fine) ** 2
        sm = np.convolve(fine**4 / np.maximum(den, 1e-300), ker, mode="same")
        return np.interp(fq, fine, sm)

    def res(th: np.ndarray) -> np.ndarray:
        m = math.exp(th[3]) * b + math.exp(th[2]) * shape_at(f, th[0], math.exp(th[1]))
        # Log-domain residual: the bins' chi-square scatter is multiplicative.
        return np.log(np.maximum(p, 1e-300)) - np.log(m)

    z0 = max(width_hz / (2 * peak_hz), df / (2 * peak_hz))
    s0 = shape_at(f, peak_hz, z0)
    a0 = max(float(np.max(p - b)) / max(float(np.max(s0)), 1e-300), 1e-300)
    x0 = np.array([peak_hz, math.log(z0), math.log(a0), 0.0])
    lo = np.array([peak_hz - 2 * max(width_hz, df), math.log(1e-4), x0[2] - 40, -3.0])
    hi = np.array([peak_hz + 2 * max(width_hz, df), math.log(0.5), x0[2] + 40, 3.0])
    sol = so.least_squares(res, np.clip(x0, lo + 1e-9, hi - 1e-9), bounds=(lo, hi), x_scale=[df, 1.0, 1.0, 1.0])
    f0, zeta, amp = float(sol.x[0]), float(math.exp(sol.x[1])), float(math.exp(sol.x[2]))
    full = np.zeros_like(spec.f)
    win = (spec.f > 0) & (spec.f >= f0 - 40 * max(zeta * f0, df)) & (spec.f <= f0 + 40 * max(zeta * f0, df))
    if win.sum() >= 2:
        full[win] = amp * shape_at(spec.f[win], f0, zeta)
    return Resonance(f0, zeta, amp, full)


def _band_region(
    residuals: Sequence[Residual], channel: int, band: list[float], Ts: float
) -> tuple[list[float], list[float]]:
    """Gap and position range holding the band-passed residual's power (bins above half the largest)."""
    lo, hi = max(band[0], 0.2), min(band[1], 0.49 / Ts)
    if not hi > lo:
        return [], []
    sos = sps.butter(2, [lo, hi], btype="bandpass", fs=1.0 / Ts, output="sos")
    pw, gg, dd = [], [], []
    for r in residuals:
        if r.wide is None or not r.run.valid[channel] or len(r.wide) < 64:
            continue
        x = r.wide[:, channel]
        if not np.all(np.isfinite(x)):
            continue
        e = sps.sosfiltfilt(sos, x)
        pw.append(e**2)
        gg.append(r.run.Z[1:, 0])
        dd.append(r.run.Z[1:, 2])
    if not pw:
        return [], []
    p, g, d = np.concatenate(pw), np.concatenate(gg), np.concatenate(dd)
    out = []
    for x in (g, d):
        e = np.linspace(*np.percentile(x, [1, 99]), 11)
        if not e[-1] > e[0]:
            out.append([float(e[0]), float(e[-1])])
            continue
        i = np.clip(np.searchsorted(e, x, side="right") - 1, 0, 9)
        cnt = np.bincount(i, minlength=10)
        m = np.where(cnt > 20, np.bincount(i, weights=p, minlength=10) / np.maximum(cnt, 1), np.nan)
        # A place only where the power is significantly uneven: a bin's mean power of a band-limited
        # process over n samples carries about n_eff = 2 B Ts n independent ones (relative error sqrt(2 / n_eff)).
        rel = np.sqrt(2.0 / np.maximum(cnt * 2.0 * (hi - lo) * Ts, 1.0))
        med = float(np.nanmedian(m)) if np.any(np.isfinite(m)) else 0.0
        high = np.isfinite(m) & (m > 2.0 * med) & (m > med * (1.0 + 4.0 * rel)) & (m >= 0.5 * np.nanmax(m))
        ok = np.flatnonzero(high)
        out.append([float(e[ok.min()]), float(e[ok.max() + 1])] if len(ok) else [float(e[0]), float(e[-1])])
    return out[0], out[1]


def _log_median(f: np.ndarray, p: np.ndarray, df: float, rel: float = 0.35) -> np.ndarray:
    """Geometric running median over ``f / (1 + rel) .. f (1 + rel)`` (at least +-2 Hz).

    A window proportional to frequency: a resonance of damping ``zeta`` spans about
    ``2 zeta f0``, a small part of the window for a lightly damped one, so the
    median stays on the noise under it (a fixed few-Hz window would follow the peak).
    """
    lp = np.log(np.maximum(p, 1e-300))
    out = np.empty_like(lp)
    lo = np.searchsorted(f, np.minimum(f / (1 + rel), f - 2.0))
    hi = np.searchsorted(f, np.maximum(f * (1 + rel), f + 2.0), side="right")
    for i in range(len(f)):
        out[i] = np.median(lp[lo[i] : max(hi[i], lo[i] + 1)])
    return np.exp(out)


def find_peaks(
    spec: WideSpectrum,
    model: NoiseModel,
    channel: int = 0,
    f_lo: float = 1.0,
    false_alarm: float = 1e-3,
    max_peaks: int = 4,
) -> list[SpectralPeak]:
    """Peaks of the PSD above both a running median and the noise model, each fitted as a resonance.

    Parameters
    ----------
    spec : WideSpectrum
        The channel's spectrum.
    model : NoiseModel
        Its noise model.
    channel : int
        0 vertical, 1 horizontal.
    f_lo : float
        Lowest frequency searched [Hz].
    false_alarm : float
        Per-spectrum false-alarm probability (Bonferroni over the bins).
    max_peaks : int
        Largest peaks kept (by power).
    """
    f, p = spec.f, spec.psd
    med = _log_median(f, p, spec.df) * math.exp(-log_bias(spec.dof))
    base = np.maximum(med, model.psd(f))
    sel = (f >= f_lo) & (f <= 0.45 / spec.Ts)
    n_bins = max(int(sel.sum()), 1)
    thr = st.chi2.isf(false_alarm / n_bins, spec.dof) / spec.dof
    over = sel & (p > thr * base)
    lab, n_lab = ndi.label(over)
    out = []
    for j in range(1, n_lab + 1):
        ii = np.flatnonzero(lab == j)
        band = [float(max(f[ii[0]] - spec.df / 2, 0.0)), float(f[ii[-1]] + spec.df / 2)]
        ipk = ii[np.argmax(p[ii] / base[ii])]
        # The peak's power: everything above the baseline over the band widened by its skirts.
        lo_i, hi_i = max(ii[0] - 3, 0), min(ii[-1] + 3, len(f) - 1)
        power = float(np.sum(np.maximum(p[lo_i : hi_i + 1] - base[lo_i : hi_i + 1], 0.0)) * spec.df)
        fit = fit_resonance(spec, model.psd(f), float(f[ipk]), band[1] - band[0])
        f0, zeta = fit.f0, fit.zeta
        # Half-power bandwidth 2 zeta f0 against the bin spacing (the Hann window's own width is in the fit).
        resolved = 2 * zeta * f0 > 0.75 * spec.df
        if not band[0] - 2 * spec.df <= f0 <= band[1] + 2 * spec.df:
            # The resonance shape does not fit this peak (e.g. an effect's content at a drive frequency):
            # report the peak bin and bound the damping by the band's width.
            f0, resolved = float(f[ipk]), False
            zeta = max(band[1] - band[0], spec.df) / (2 * f0)
        elif not resolved:
            zeta = 0.75 * spec.df / (2 * max(f0, 1e-9))
        rms = math.sqrt(max(power, 0.0))
        pk = SpectralPeak(
            CHANNELS[channel] if channel < 2 else str(channel),
            band,
            float(f[ipk]),
            f0,
            zeta,
            bool(resolved),
            float(p[ipk] / base[ipk]),
            power,
            rms,
            rms / (2 * math.pi * max(f0, 1e-9)) ** 2,
            shape=fit.shape,
        )
        out.append(pk)
    out.sort(key=lambda q: -q.power_m2_s4)
    kept: list[SpectralPeak] = []
    for pk in out:
        # A weaker peak on a stronger one's skirt is part of it.
        if not any(abs(pk.freq_hz - o.freq_hz) < max(6 * o.damping * o.freq_hz, 3 * spec.df) for o in kept):
            kept.append(pk)
    return kept[:max_peaks]


# ----------------------------------------------------------------- channel summary
def fit_noise_model(
    spec: WideSpectrum,
    channel: str,
    q: float = k.encoder_resolution,
    f_lo: float = 1.0,
    tau: float = 0.2,
    false_alarm: float = 1e-3,
) -> tuple[NoiseModel, list[SpectralPeak]]:
    """Noise levels that peaks cannot raise, and the peaks (their fitted shapes removed before the refit).

    Parameters
    ----------
    spec : WideSpectrum
        The channel's wide-band spectrum.
    channel : str
        Channel name.
    q : float
        Encoder resolution [m] (``var_y >= q^2 / 12``).
    f_lo : float
        Lowest frequency used [Hz].
    tau : float
        Quantile of the acceleration-noise estimates.
    false_alarm : float
        Peak detection level (see :func:`find_peaks`).

    Returns
    -------
    model : NoiseModel
    peaks : list of SpectralPeak
        Peaks with their fitted resonance (no regions yet).
    """
    p = spec.psd.copy()
    peaks: list[SpectralPeak] = []
    model = None
    exclude = np.zeros(len(spec.f), bool)
    for _ in range(3):
        var_y, var_a, band = noise_levels(spec, p, q, f_lo, tau, exclude)
        model = NoiseModel(channel, spec.Ts, q, var_y, var_a, band)
        peaks = find_peaks(spec, model, CHANNELS.index(channel), f_lo=f_lo, false_alarm=false_alarm)
        cleaned = spec.psd - sum((pk.shape for pk in peaks), np.zeros_like(spec.psd))
        # Never below half the measured PSD: the fitted shapes remove the skirts, not the noise.
        cleaned = np.maximum(cleaned, 0.5 * spec.psd)
        for pk in peaks:
            w = max(5 * pk.damping * pk.freq_hz, 2 * spec.df)
            exclude |= (spec.f >= min(pk.band_hz[0], pk.freq_hz - w)) & (spec.f <= max(pk.band_hz[1], pk.freq_hz + w))
        if np.allclose(cleaned, p, rtol=1e-3):
            break
        p = cleaned
    assert model is not None
    return model, peaks


# ---------------------------------------------------------------------- whiteness
@dataclass
class NoiseCheck:
    """Noise model, model floor, whiteness and peaks of one channel's residual.

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    model : NoiseModel
        Fitted noise model.
    floor : float
        The model's floor of the filtered residual [m/s^2].
    quantization : float
        Its quantization part [m/s^2].
    rms : float
        Rms of the filtered residual (all runs given) [m/s^2].
    whiteness : Whiteness
        Whiteness checks.
    peaks : list of SpectralPeak
        Peaks of the wide-band spectrum.
    spectrum : WideSpectrum
        The spectrum (for figures).
    """

    channel: str
    model: NoiseModel
    floor: float
    quantization: float
    rms: float
    whiteness: Whiteness
    peaks: list[SpectralPeak]
    spectrum: WideSpectrum

    @property
    def excess_ratio(self) -> float:
        """Rms of the filtered residual over the model floor (1 for noise alone)."""
        return self.rms / self.floor if self.floor > 0 else math.inf

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            "noise_model": self.model.to_dict(),
            "model_floor_m_s2": self.floor,
            "quantization_m_s2": self.quantization,
            "rms_m_s2": self.rms,
            "rms_over_model_floor": self.excess_ratio,
            "whiteness": self.whiteness.to_dict(),
            "peaks": [p.to_dict() for p in self.peaks],
        }


def noise_check(
    residuals: Sequence[Residual],
    channel: int,
    w_y: np.ndarray,
    w_a: np.ndarray,
    q: float = k.encoder_resolution,
    Ts: float = k.Ts,
    seed: int = 0,
) -> NoiseCheck | None:
    """Noise model, model floor, whiteness and peaks of one channel (None without wide-band data)."""
    spec = wide_spectrum(residuals, channel, Ts)
    if spec is None:
        return None
    model, peaks = fit_noise_model(spec, CHANNELS[channel], q)
    for pk in peaks:
        band = [pk.freq_hz * (1 - 3 * pk.damping), pk.freq_hz * (1 + 3 * pk.damping)]
        pk.g_range_m, pk.d_range_m = _band_region(residuals, channel, band, Ts)
    fl = model.floor(w_y, w_a)
    r = [x.r[:, channel] for x in residuals if x.run.n and x.run.valid[channel]]
    rms = float(np.sqrt(np.mean(np.concatenate(r) ** 2))) if r else math.nan
    wh = whiteness(residuals, channel, model, spec, seed=seed)
    return NoiseCheck(CHANNELS[channel], model, fl, model.quantization_floor(w_y), rms, wh, peaks, spec)


def confirm_peaks(
    peaks: Sequence[SpectralPeak],
    parts: Sequence[Sequence[Residual]],
    model: NoiseModel,
    channel: int,
    false_alarm: float = 1e-2,
) -> list[SpectralPeak]:
    """Peaks that every part of the data (e.g. training and held-out runs) shows on its own.

    In each part the mean of ``PSD / model`` over the peak's half-power band must
    exceed the chi-square level of that band's pooled bins (``false_alarm`` per
    peak and part). A peak of one run only (a transient) is not confirmed.
    """
    specs = [wide_spectrum(p, channel, model.Ts) for p in parts]
    out = []
    for pk in peaks:
        ok = True
        for sp in specs:
            if sp is None:
                ok = False
                break
            w = max(pk.damping * pk.freq_hz, sp.df)
            sel = (sp.f >= pk.freq_hz - w) & (sp.f <= pk.freq_hz + w)
            if not sel.any():
                ok = False
                break
            ratio = float(np.mean(sp.psd[sel] / np.maximum(model.psd(sp.f[sel]), 1e-300)))
            # Pooled bins of a Hann Welch estimate overlap by about half: count half of them.
            dof = sp.dof * max(1.0, sel.sum() / 2.0)
            if ratio < st.chi2.isf(false_alarm, dof) / dof:
                ok = False
                break
        if ok:
            out.append(pk)
    return out


def consistent_peaks(a: Sequence[SpectralPeak], b: Sequence[SpectralPeak]) -> list[SpectralPeak]:
    """Peaks of ``a`` that ``b`` also shows (overlapping bands or frequencies within 5 %)."""
    out = []
    for pa in a:
        for pb in b:
            if (
                pa.band_hz[0] <= pb.peak_hz <= pa.band_hz[1]
                or pb.band_hz[0] <= pa.peak_hz <= pb.band_hz[1]
                or abs(pa.freq_hz / max(pb.freq_hz, 1e-9) - 1) < 0.05
            ):
                out.append(pa)
                break
    return out


# ------------------------------------------------------------------ resonance guard
#: Name of the flag the verdict reads: a candidate that only closes a narrow resonance is no evidence.
GUARD_FLAG = "absorbs_resonance"


@dataclass
class ResonanceGuard:
    """Whether a candidate's improvement is a narrow resonance it cannot explain.

    A lag (or a delay) scales the residual's content by a factor that varies
    smoothly with frequency; it cannot produce a narrow peak. If most of what
    it removes from the residual (weighted by the residual filter, i.e. what
    its held-out score sees) lies inside the bands of the residual's peaks,
    its score comes from the resonance, not from a lag.

    Attributes
    ----------
    candidate : str
        Candidate name.
    absorbs_resonance : bool
        Most of its improvement lies in the peaks' bands (the flag :data:`GUARD_FLAG`).
    fraction_in_peaks : float
        Share of its (filter-weighted) PSD reduction inside the peaks' bands.
    peak_left : float
        Power left in the peaks' bands after the candidate, over before (1: untouched).
    peaks_hz : list of float
        Frequencies of the peaks checked [Hz].
    outside_reduction : float
        Share of the (filter-weighted) residual power half an octave or more away from every peak that the
        candidate removes (its broadband effect).
    explains_peaks : bool
        The candidate is the model of the peaks: it removes them (``peak_left`` at most ``explain_left``) and
        most of the residual outside them too (``outside_reduction`` at least ``outside_min``). A lag that the
        loop turns into a lightly damped closed-loop mode leaves a line in the baseline residual that the lag
        model predicts, with the lag's broadband signature around it; a resonance the lag merely absorbs leaves
        the rest of the residual untouched, or the line standing. Such a candidate is not flagged.
    """

    candidate: str
    absorbs_resonance: bool
    fraction_in_peaks: float
    peak_left: float
    peaks_hz: list[float]
    outside_reduction: float = 0.0
    explains_peaks: bool = False
    forced_hz: list[float] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return dict(self.__dict__)


def _channel_pairs(
    peaks: Sequence[SpectralPeak],
    first: Callable[[int], WideSpectrum | None],
    second: Callable[[int], WideSpectrum | None],
) -> Iterator[tuple[list[SpectralPeak], WideSpectrum, WideSpectrum]]:
    """Per channel with peaks: its peaks and two spectra on the same frequency grid (channels without skipped)."""
    for c, ch in enumerate(CHANNELS):
        pks = [p for p in peaks if p.channel == ch]
        if not pks:
            continue
        sa, sb = first(c), second(c)
        if sa is not None and sb is not None and len(sa.f) == len(sb.f):
            yield pks, sa, sb


def forced_peaks(
    peaks: Sequence[SpectralPeak], residuals: Sequence[Residual], Ts: float = k.Ts, forced_max: float = 0.5
) -> list[SpectralPeak]:
    """The peaks that are the model's error on a line of the motion, not a mode the model lacks.

    The measured acceleration ``D2(y)`` is the model's acceleration plus the
    residual. At a structural resonance the model predicts (almost) nothing, so
    the residual carries (almost) all of the measured power in the peak's band.
    At a line of the excitation (a dither or the moves' own frequencies) the
    model predicts most of the motion, and the residual's peak is the model's
    error on that forced response, which any effect that changes the model's
    response there (a lag, a saturation) may legitimately reduce. A peak is
    forced when the residual holds at most ``forced_max`` of the measured
    power in its band.
    """
    out = []
    pairs = _channel_pairs(
        peaks, lambda c: wide_spectrum(residuals, c, Ts), lambda c: motion_spectrum(residuals, c, Ts)
    )
    for pks, sr, sm in pairs:
        for p in pks:
            w = max(p.damping * p.freq_hz, sr.df)
            sel = (sr.f >= min(p.band_hz[0], p.freq_hz - w)) & (sr.f <= max(p.band_hz[1], p.freq_hz + w))
            if sel.any() and float(np.sum(sr.psd[sel])) <= forced_max * float(np.sum(sm.psd[sel])):
                out.append(p)
    return out


def resonance_guard(
    candidate: str,
    before: Sequence[Residual],
    after: Sequence[Residual],
    peaks: Sequence[SpectralPeak],
    h: np.ndarray,
    Ts: float = k.Ts,
    share: float = 0.5,
    explain_left: float = 0.25,
    outside_min: float = 0.5,
) -> ResonanceGuard:
    """Check a candidate's improvement against the residual's resonance peaks (see :class:`ResonanceGuard`).

    Parameters
    ----------
    candidate : str
        Candidate name.
    before, after : sequences of Residual
        The same runs under the baseline and under the candidate (wide-band residuals present).
    peaks : sequence of SpectralPeak
        The baseline residual's peaks (any channel).
    h : ndarray
        The residual filter's kernel (its power response weights the reduction).
    Ts : float
        Sample period [s].
    share : float
        The candidate absorbs a resonance when more than this share of its reduction lies in the peaks (unless
        it explains them, see :class:`ResonanceGuard`).
    explain_left, outside_min : float
        The candidate explains the peaks when at most ``explain_left`` of their power is left and it removes at
        least ``outside_min`` of the filter-weighted residual power outside them (held-out runs).
    """
    # Lines of the motion that the model mostly predicts are no resonance (:func:`forced_peaks`).
    forced = forced_peaks(peaks, before, Ts)
    f_hz = [p.freq_hz for p in forced]
    peaks = [p for p in peaks if p not in forced]
    if not peaks:
        return ResonanceGuard(candidate, False, 0.0, 1.0, [], forced_hz=f_hz)
    tot, inside, pb, pa, ob, oa = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for pks, sb, sa in _channel_pairs(
        peaks, lambda c: wide_spectrum(before, c, Ts), lambda c: wide_spectrum(after, c, Ts)
    ):
        H2 = np.abs(np.fft.rfft(h, 2 * (len(sb.f) - 1))) ** 2
        H2 = np.interp(sb.f, np.fft.rfftfreq(2 * (len(sb.f) - 1), Ts), H2)
        red = (sb.psd - sa.psd) * H2
        mask = np.zeros(len(sb.f), bool)
        for p in pks:
            w = max(3 * p.damping * p.freq_hz, sb.df)
            mask |= (sb.f >= min(p.band_hz[0], p.freq_hz - w)) & (sb.f <= max(p.band_hz[1], p.freq_hz + w))
        tot += float(np.sum(np.maximum(red, 0.0)))
        inside += float(np.sum(np.maximum(red[mask], 0.0)))
        pb += float(np.sum(sb.psd[mask]))
        pa += float(np.sum(sa.psd[mask]))
        # Outside: half an octave away from every peak (a lightly damped mode's skirts are not broadband content).
        far = np.ones(len(sb.f), bool)
        for p in pks:
            far &= (sb.f < min(p.band_hz[0], p.freq_hz) / math.sqrt(2.0)) | (
                sb.f > max(p.band_hz[1], p.freq_hz) * math.sqrt(2.0)
            )
        ob += float(np.sum(sb.psd[far] * H2[far]))
        oa += float(np.sum(sa.psd[far] * H2[far]))
    frac = inside / tot if tot > 0 else 0.0
    left = pa / pb if pb > 0 else 1.0
    outside = 1.0 - oa / ob if ob > 0 else 0.0
    explains = bool(left <= explain_left and outside >= outside_min)
    absorbs = bool(tot > 0 and frac > share and not explains)
    return ResonanceGuard(candidate, absorbs, frac, left, [p.freq_hz for p in peaks], outside, explains, f_hz)


__all__ = [
    "GUARD_FLAG",
    "NoiseCheck",
    "Resonance",
    "ResonanceGuard",
    "SpectralPeak",
    "confirm_peaks",
    "consistent_peaks",
    "find_peaks",
    "fit_noise_model",
    "fit_resonance",
    "forced_peaks",
    "noise_check",
    "resonance_guard",
]
