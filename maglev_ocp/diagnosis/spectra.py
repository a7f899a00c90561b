"""Spectra of the residuals: one Welch PSD (:func:`welch_average`) for the localization and the noise model.

:func:`welch_average` is Welch's method (Hann window, 50 % overlap, constant detrend) on each series at least one
segment long, averaged over the series weighted by their segment counts; every spectrum of the diagnosis is
built on it. :func:`spectrum` (the filtered, decimated residual: running-median baseline and peak bands, the
localization's view) and :func:`wide_spectrum` / :func:`motion_spectrum` (the wide-band residual and the
measured acceleration: the noise model's input) are its two uses.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.ndimage as ndi
import scipy.signal as sps
import scipy.stats as st

from .. import constants as k
from .residuals import Residual


def welch_average(xs: Sequence[np.ndarray], fs: float, nper: int) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Welch PSD of each series at least ``nper`` samples long, averaged weighted by its segment count.

    Parameters
    ----------
    xs : sequence of ndarray
        Series sampled at ``fs`` (each contiguous in time; shorter than ``nper`` skipped).
    fs : float
        Sample rate [Hz].
    nper : int
        Segment length [samples] (Hann window, half overlap, constant detrend).

    Returns
    -------
    (f, psd, n_segments) or None
        Frequencies [Hz], the averaged one-sided PSD [unit^2/Hz] and the number of segments averaged
        (``1 + 2 (n - nper) // nper`` per series); None when no series is long enough.
    """
    acc, wsum, f = None, 0.0, None
    for x in xs:
        if len(x) < nper:
            continue
        f, p = sps.welch(x, fs=fs, nperseg=nper, noverlap=nper // 2, detrend="constant")
        m = 1 + 2 * (len(x) - nper) // nper
        acc = p * m if acc is None else acc + p * m
        wsum += m
    if acc is None or f is None:
        return None
    return f, acc / wsum, wsum


@dataclass
class WideSpectrum:
    """Welch PSD of a channel's wide-band residual.

    Attributes
    ----------
    f, psd : ndarray
        Frequencies [Hz] and PSD [(m/s^2)^2/Hz].
    dof : float
        Degrees of freedom per bin.
    nperseg : int
        Segment length (the resolution is ``1 / (nperseg Ts)``).
    Ts : float
        Sample period [s].
    """

    f: np.ndarray
    psd: np.ndarray
    dof: float
    nperseg: int
    Ts: float

    @property
    def df(self) -> float:
        """Bin spacing [Hz]."""
        return 1.0 / (self.nperseg * self.Ts)


def wide_series(residuals: Sequence[Residual], channel: int) -> list[np.ndarray]:
    out = []
    for r in residuals:
        if r.wide is None or not r.run.valid[channel]:
            continue
        x = r.wide[:, channel]
        if np.all(np.isfinite(x)):
            out.append(x)
    return out


def welch_wide(xs: Sequence[np.ndarray], Ts: float, seg_s: float) -> WideSpectrum | None:
    """Welch PSD averaged over runs (weighted by their segment counts)."""
    if not xs:
        return None
    longest = max(len(x) for x in xs)
    nper = int(min(seg_s / Ts, longest))
    if nper < 64:
        return None
    avg = welch_average(xs, 1.0 / Ts, nper)
    if avg is None:
        return None
    f, psd, wsum = avg
    # Hann, 50 % overlap: about 1.8 effective dof per averaged segment (Welch 1967).
    return WideSpectrum(f, psd, max(2.0, 1.8 * wsum), nper, Ts)


def wide_spectrum(
    residuals: Sequence[Residual], channel: int, Ts: float = k.Ts, seg_s: float = 4.0
) -> WideSpectrum | None:
    """Welch PSD of the wide-band residuals of one channel (segments of ``seg_s`` within runs).

    Runs shorter than a segment are skipped (a segment is never longer than the longest run).
    """
    return welch_wide(wide_series(residuals, channel), Ts, seg_s)


def motion_spectrum(
    residuals: Sequence[Residual], channel: int, Ts: float = k.Ts, seg_s: float = 4.0
) -> WideSpectrum | None:
    """Welch PSD of the wide-band *measured* acceleration ``D2(y)`` of one channel (the residual's runs)."""
    xs = [r.run.d2[:, channel] for r in residuals if r.run.n and r.run.valid[channel] and len(r.run.d2)]
    return welch_wide([x for x in xs if np.all(np.isfinite(x))], Ts, seg_s)


@dataclass
class Spectrum:
    """Welch PSD of a channel's residual.

    Attributes
    ----------
    f : ndarray
        Frequencies [Hz].
    psd : ndarray
        Power spectral density [(m/s^2)^2/Hz].
    baseline : ndarray
        Running-median baseline of the PSD.
    peaks : list of dict
        Bands where the PSD exceeds the baseline significantly:
        ``{"band_hz": [lo, hi], "peak_hz", "ratio", "power_m2_s4"}``.
    dof : float
        Degrees of freedom of the Welch estimate.
    """

    f: np.ndarray
    psd: np.ndarray
    baseline: np.ndarray
    peaks: list[dict]
    dof: float


def spectrum(
    residuals: Sequence[Residual], channel: int, fs: float, fmax: float, seg_s: float = 4.0, false_alarm: float = 1e-3
) -> Spectrum | None:
    """Welch PSD (segments within runs, averaged) with peak bands above a running median.

    Parameters
    ----------
    residuals : sequence of Residual
        Residuals (all samples of a run are contiguous in time).
    channel : int
        0 vertical, 1 horizontal.
    fs : float
        Sample rate of the residual samples [Hz].
    fmax : float
        Highest frequency reported (the residual filter's cut-off) [Hz].
    seg_s : float
        Welch segment length [s].
    false_alarm : float
        Per-band false-alarm probability (Bonferroni over the bins below fmax).
    """
    nper = int(seg_s * fs)
    avg = welch_average([res.r[:, channel] for res in residuals if res.run.valid[channel]], fs, nper)
    if avg is None:
        return None
    f, psd, nseg = avg
    sel = f <= fmax
    f, psd = f[sel], psd[sel]
    dof = max(2.0, 2 * nseg * 0.9)
    width = max(5, round(2.0 / (f[1] - f[0])) | 1) if len(f) > 1 else 5
    baseline = ndi.median_filter(psd, size=width, mode="nearest")
    n_bins = max(1, int(np.sum(f > 0.5)))
    # Under H0 psd / baseline ~ chi2(dof) / dof.
    thr = st.chi2.isf(false_alarm / n_bins, dof) / dof
    over = (psd > thr * baseline) & (f > 0.5)
    peaks = []
    lab, n_lab = ndi.label(over)
    for j in range(1, n_lab + 1):
        ii = np.flatnonzero(lab == j)
        df = f[1] - f[0]
        band = [float(max(f[ii[0]] - df / 2, 0.0)), float(f[ii[-1]] + df / 2)]
        ipk = ii[np.argmax(psd[ii] / baseline[ii])]
        peaks.append(
            {
                "band_hz": band,
                "peak_hz": float(f[ipk]),
                "ratio": float(psd[ipk] / baseline[ipk]),
                "power_m2_s4": float(np.sum(psd[ii] - baseline[ii]) * df),
            }
        )
    peaks.sort(key=lambda q: -q["power_m2_s4"])
    return Spectrum(f, psd, baseline, peaks, dof)


def dominant_band(spec: Spectrum, fraction: float = 0.8) -> list[float] | None:
    """Smallest band around the PSD maximum that holds ``fraction`` of the power above the baseline median."""
    if spec is None or len(spec.f) < 3:
        return None
    ex = np.maximum(spec.psd - np.median(spec.psd), 0.0)
    tot = ex.sum()
    if tot <= 0:
        return None
    i0 = int(np.argmax(ex))
    lo, hi = i0, i0
    acc = ex[i0]
    while acc < fraction * tot:
        left = ex[lo - 1] if lo > 0 else -1
        right = ex[hi + 1] if hi < len(ex) - 1 else -1
        if left < 0 and right < 0:
            break
        if left >= right:
            lo -= 1
            acc += ex[lo]
        else:
            hi += 1
            acc += ex[hi]
    df = spec.f[1] - spec.f[0]
    return [float(max(spec.f[lo] - df / 2, 0.0)), float(spec.f[hi] + df / 2)]


__all__ = [
    "Spectrum",
    "WideSpectrum",
    "dominant_band",
    "motion_spectrum",
    "spectrum",
    "welch_average",
    "welch_wide",
    "wide_series",
    "wide_spectrum",
]
