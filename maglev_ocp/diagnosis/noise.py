"""A noise floor that a structured residual cannot inflate; whiteness; spectral peaks with damping.

The floor of :mod:`.localize` is measured on the residual itself (what
binned maps of the state cannot predict). Anything without state structure —
a lightly damped structural resonance, a vibration — then *becomes* the floor
and a gap disappears into it. This module derives the floor from a **model of
the noise** instead, and checks the residual against it:

- **noise model** of the wide-band residual ``r = D2(y) - K a`` (see
  :mod:`.residuals`): white position noise of variance ``var_y`` on the encoder
  reading (quantization ``q^2 / 12`` at least, plus encoder noise) seen through
  the second difference, and white acceleration noise of variance ``var_a`` per
  period (process force and current noise) seen through ``K = [1/2, 1/2]``.
  Its one-sided PSD is

  ``S(f) = 2 Ts [var_y (4 sin^2(pi f Ts) / Ts^2)^2 + var_a cos^2(pi f Ts)]``.

  The two levels are fitted to the Welch PSD above the residual filter's
  cut-off (the library's effects live below it) in the log domain with a
  robust loss, bins of a peak excluded and ``var_y >= q^2 / 12`` (the encoder
  resolution gives the quantization part exactly). A narrow peak, being
  excluded and smoothed over by two broad shapes, cannot raise the levels.
- **floor**: that noise propagated analytically through the residual filter:
  ``floor^2 = var_y ||h * D2||^2 + var_a ||h * K||^2`` (the filtered
  residual's rms if it were only noise).
- **whiteness**: the residual whitened by the noise model (its spectrum
  divided by ``sqrt(S)``) must be white: Ljung-Box over the first lags, and
  the spectral flatness of ``PSD / S`` against its chi-square null.
- **peaks**: bands where the PSD exceeds a running median (and the model) at
  a Bonferroni-corrected chi-square level; each is fitted with a second-order
  resonance ``A f^4 / ((f0^2 - f^2)^2 + (2 zeta f0 f)^2)`` (acceleration
  response of a mode to a white force) convolved with the Welch window's
  spectral kernel, which gives its frequency ``f0`` and damping ``zeta``; a
  peak narrower than the resolution is a *line* (a sinusoid), with an upper
  bound on its damping.
- **region** of a peak: where in gap and position its band-passed power lives.

This module holds the noise model and the whiteness test; the peaks, the
fitted levels that peaks cannot raise (:func:`.peaks.fit_noise_model`), the
channel check and the lag's resonance guard are :mod:`.peaks`; the Welch PSD
is :mod:`.spectra`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.special as spc
import scipy.stats as st

from .residuals import Residual
from .spectra import WideSpectrum, welch_wide, wide_series, wide_spectrum


# ------------------------------------------------------------------- noise model
def noise_psd(f: np.ndarray, Ts: float, var_y: float, var_a: float) -> np.ndarray:
    """One-sided PSD of the wide-band residual under white position and acceleration noise [(m/s^2)^2/Hz]."""
    s = np.sin(math.pi * np.asarray(f, float) * Ts)
    d2 = (4.0 * s**2 / Ts**2) ** 2
    return 2.0 * Ts * (var_y * d2 + var_a * (1.0 - s**2))


@dataclass
class NoiseModel:
    """Fitted noise model of one channel (see the module docstring).

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    Ts : float
        Sample period [s].
    q : float
        Encoder resolution [m].
    var_y : float
        Position noise variance on the reading [m^2] (at least ``q^2 / 12``).
    var_a : float
        Acceleration noise variance per period [(m/s^2)^2].
    band_hz : list of float
        Band the levels were fitted on [Hz].
    """

    channel: str
    Ts: float
    q: float
    var_y: float
    var_a: float
    band_hz: list[float]

    def psd(self, f: np.ndarray) -> np.ndarray:
        """Model PSD at ``f`` [(m/s^2)^2/Hz]."""
        return noise_psd(f, self.Ts, self.var_y, self.var_a)

    def floor(self, w_y: np.ndarray, w_a: np.ndarray) -> float:
        """Rms of the filtered residual due to this noise alone, ``sqrt(var_y ||w_y||^2 + var_a ||w_a||^2)``.

        Parameters
        ----------
        w_y, w_a : ndarray
            The residual filter on the encoder reading (``h * D2``) and on the
            per-period accelerations (``h * K``); :class:`~.residuals.ZeroPhaseFilter`'s
            ``w_y`` and ``w_a``.
        """
        return math.sqrt(self.var_y * float(w_y @ w_y) + self.var_a * float(w_a @ w_a))

    def quantization_floor(self, w_y: np.ndarray) -> float:
        """The quantization part alone, ``q / sqrt(12) ||w_y||`` [m/s^2]."""
        return self.q / math.sqrt(12.0) * float(np.linalg.norm(w_y))

    def to_dict(self) -> dict:
        """JSON-ready view (standard deviations rather than variances)."""
        return {
            "position_noise_m": math.sqrt(self.var_y),
            "quantization_m": self.q / math.sqrt(12.0),
            "accel_noise_m_s2": math.sqrt(self.var_a),
            "fit_band_hz": self.band_hz,
        }


def log_bias(dof: float) -> float:
    """Mean of ``log(chi2(dof) / dof)``: a log-domain fit of a noisy PSD is biased low by this."""
    return float(spc.digamma(dof / 2.0) - math.log(dof / 2.0))


def noise_levels(
    spec: WideSpectrum, p: np.ndarray, q: float, f_lo: float, tau: float, exclude: np.ndarray | None = None
) -> tuple[float, float, list[float]]:
    """Robust noise levels from a PSD ``p``: ``var_y`` from the top of the band, ``var_a`` from a low quantile.

    Structure only ever *adds* power, so a low quantile of the per-bin estimates
    of the acceleration-noise level (corrected for the chi-square quantile) is
    not raised by anything that covers fewer than ``1 - tau`` of the bins. The
    bins are those below 15 Hz, or below the frequency where the acceleration
    noise stops dominating the quantization if that is higher; ``exclude``
    masks the bands of peaks already found.
    """
    fs = 1.0 / spec.Ts
    f = spec.f
    vq = q**2 / 12.0
    s_y = noise_psd(f, spec.Ts, 1.0, 0.0)
    s_a = noise_psd(f, spec.Ts, 0.0, 1.0)
    med_bias = st.chi2.ppf(0.5, spec.dof) / spec.dof
    q_bias = st.chi2.ppf(tau, spec.dof) / spec.dof
    top = (f >= 0.2 * fs) & (f <= 0.45 * fs)
    var_y = max(vq, float(np.median(p[top] / s_y[top])) / med_bias) if top.any() else vq
    ok = (f >= f_lo) & (f <= 0.45 * fs)
    if exclude is not None:
        ok &= ~exclude
    f_hi = 15.0
    var_a = 1e-12
    for _ in range(2):
        use = ok & (f <= f_hi)
        if use.sum() < 8:
            use = ((f >= f_lo) & (f <= 0.45 * fs)) & (f <= max(f_hi, f_lo + 8 * spec.df))
        est = (p[use] / q_bias - var_y * s_y[use]) / s_a[use]
        var_a = max(float(np.quantile(est, tau)), 1e-12)
        band = [float(f[use][0]), float(f[use][-1])]
        cross = f[(f > 0) & (var_y * s_y > var_a * s_a)]
        fx = float(cross[0]) if len(cross) else 0.45 * fs
        if fx <= f_hi * 1.05:
            break
        f_hi = fx
    return var_y, var_a, band


@dataclass
class Whiteness:
    """Whiteness of a residual relative to its noise model.

    Attributes
    ----------
    ljung_box_q : float
        Ljung-Box statistic of the whitened residual over ``lags`` lags (runs pooled).
    ljung_box_p : float
        Its p-value (chi-square with ``lags`` times the number of runs dof).
    lags : int
        Lags tested per run.
    flatness : float
        Spectral flatness (geometric / arithmetic mean) of ``PSD / model`` over the band.
    flatness_null : float
        The flatness that noise drawn from the model (same run lengths, same Welch
        estimate) exceeds in all but about 1 in 10^4 draws (mean - 4 sd of the draws).
    excess_ratio : float
        Mean of ``PSD / model`` over the band (1 for noise alone).
    white : bool
        Flatness at least its null level (the effect size; with tens of thousands
        of samples the Ljung-Box p-value rejects any model misfit, so it is reported, not decisive).
    """

    ljung_box_q: float
    ljung_box_p: float
    lags: int
    flatness: float
    flatness_null: float
    excess_ratio: float
    white: bool

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return dict(self.__dict__)


def _whiten(x: np.ndarray, model: NoiseModel) -> np.ndarray:
    n = len(x)
    X = np.fft.rfft(x - np.mean(x))
    f = np.fft.rfftfreq(n, model.Ts)
    S = np.maximum(model.psd(f), 1e-300)
    return np.fft.irfft(X / np.sqrt(S), n)


def whiteness(
    residuals: Sequence[Residual],
    channel: int,
    model: NoiseModel,
    spec: WideSpectrum,
    lags: int = 20,
    f_lo: float = 1.0,
    seed: int = 0,
    n_null: int = 12,
) -> Whiteness:
    """Ljung-Box and spectral-flatness checks of the residual whitened by ``model``."""
    q_tot, dof_tot = 0.0, 0
    for x in wide_series(residuals, channel):
        if len(x) < 4 * lags:
            continue
        e = _whiten(x, model)
        e = e - e.mean()
        n = len(e)
        v = float(e @ e)
        if v <= 0:
            continue
        rho = np.array([float(e[j:] @ e[:-j]) / v for j in range(1, lags + 1)])
        q_tot += n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, lags + 1))))
        dof_tot += lags
    p_lb = float(st.chi2.sf(q_tot, dof_tot)) if dof_tot else math.nan
    flat, mean_ratio = _flatness(spec, model, f_lo)
    # Null: noise drawn from the model with the runs' lengths, through the same Welch estimate.
    rng = np.random.default_rng(seed)
    lens = [len(x) for x in wide_series(residuals, channel)]
    null = []
    for _ in range(n_null):
        xs = [_colored(n, model, rng) for n in lens]
        sp = welch_wide(xs, spec.Ts, spec.nperseg * spec.Ts)
        if sp is not None:
            null.append(_flatness(sp, model, f_lo)[0])
    thr = float(np.mean(null) - 4 * np.std(null, ddof=1)) if len(null) > 2 else math.nan
    return Whiteness(q_tot, p_lb, lags, flat, thr, mean_ratio, bool(not flat < thr))


def _flatness(spec: WideSpectrum, model: NoiseModel, f_lo: float) -> tuple[float, float]:
    """Spectral flatness and mean of ``PSD / model`` over ``f_lo .. 0.45 fs``."""
    sel = (spec.f >= f_lo) & (spec.f <= 0.45 / spec.Ts)
    if not sel.any():
        return math.nan, math.nan
    ratio = np.maximum(spec.psd[sel] / np.maximum(model.psd(spec.f[sel]), 1e-300), 1e-300)
    return float(np.exp(np.mean(np.log(ratio))) / np.mean(ratio)), float(np.mean(ratio))


def _colored(n: int, model: NoiseModel, rng: np.random.Generator) -> np.ndarray:
    """A series of ``n`` samples of Gaussian noise with the model's PSD."""
    f = np.fft.rfftfreq(n, model.Ts)
    X = np.fft.rfft(rng.standard_normal(n)) * np.sqrt(model.psd(f) / (2 * model.Ts))
    return np.fft.irfft(X, n)


# -------------------------------------------------------------------------- peaks

__all__ = [
    "NoiseModel",
    "Whiteness",
    "WideSpectrum",
    "log_bias",
    "noise_levels",
    "noise_psd",
    "whiteness",
    "wide_spectrum",
]
