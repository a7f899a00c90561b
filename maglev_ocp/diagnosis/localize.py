"""Where the residual lives: binning against a floor, spectrum, period scan, regions.

Everything here works on the filtered residual samples of :mod:`.residuals`
and their smoothed features (gap, position, velocities, currents, current
rates). The statistics account for the residual's autocorrelation: a bin of
``n`` samples carries ``n / inflation`` independent ones, with
``inflation = 1 + 2 sum rho_k`` measured on the residual itself.

- **noise floor**: from the data, not from a noise model. The systematic part
  of a residual is what the state predicts; the floor is the rms of what is
  left after an additive binned map (gap x position, velocities, currents,
  current rates) fitted on the *training* runs is subtracted on the *held-out*
  runs. It is an upper bound of the pure-noise rms (it includes any
  systematic part the maps miss), which makes "exceeds the floor" a
  conservative statement. The quantization-only floor of the filter is
  reported beside it. Anything without state structure (a resonance, a
  vibration) enters this floor; :mod:`.noise` gives the floor of a noise
  model that such a residual cannot inflate, and its spectral peaks.
- **structure test**: the held-out gain of those maps, ``1 - SSE(r - m) /
  SSE(r) = (2 r.m - m.m) / r.r`` with ``m`` the training maps' prediction on
  the held-out samples. Without state structure ``m`` is fitted noise,
  independent of the held-out ``r``: the gain's mean is ``-m.m / r.r < 0`` and
  the spread of ``2 r.m`` is ``2 |m| sigma sqrt(inflation)``, so
  ``z = gain / (2 rms(m) sigma sqrt(inflation / n) / rms(r)^2)`` is
  conservative (``sigma`` and the inflation from ``r - m``, the held-out
  residual without its structure). A gap needs a
  significant *and* positive gain (at least 1 % of the held-out variance
  predicted).
- **spectrum**: Welch PSD per channel; narrow peaks above a running-median
  baseline are reported as bands.
- **period scan**: least-squares fit of ``a cos(2 pi d / P) + b sin(2 pi d / P)``
  over a grid of periods ``P`` (not an FFT over +-50 mm, which could not
  resolve a 19 mm period in a 100 mm stroke). Its threshold is the 1 - 1e-3
  quantile of the best fraction on residuals circularly shifted within their
  runs, scanned over the same grid, from an extreme-value law fitted to many
  such draws (a mean + 4 sd of 8 draws on a 3x coarser grid called 1-2 % of
  the channels without structure periodic, measured on a rig residual).
- **regions**: bins of the gap x position map whose mean exceeds
  ``z_crit`` standard errors (Bonferroni over the bins), grouped into
  connected boxes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.ndimage as ndi
import scipy.stats as st

from .. import constants as k
from ..estimation.ident import autocorr_factor
from .residuals import CHANNELS, Residual
from .spectra import Spectrum, dominant_band, spectrum

#: Features used for 1-D maps and binned views, with plot units scale.
FEATURES_1D: tuple[str, ...] = ("g", "d", "g_dot", "d_dot", "i_q", "i_d", "di_q", "di_d")
#: Reference periods of the stage [m] (slot pitch, its double and half, pole pitch, its half).
KNOWN_PERIODS: dict[str, float] = {
    "t1/2": k.t1 / 2,
    "t1": k.t1,
    "2 t1": 2 * k.t1,
    "tau/2": k.tau / 2,
    "tau": k.tau,
}


# ------------------------------------------------------------------ data gathering
@dataclass
class Samples:
    """Residual samples of one channel, pooled over runs, with their features.

    Attributes
    ----------
    r : ndarray
        Residual [m/s^2].
    feat : dict of ndarray
        Features at the same samples.
    run : ndarray of int
        Index of the run of each sample (for circular shifts within runs).
    """

    r: np.ndarray
    feat: dict[str, np.ndarray]
    run: np.ndarray

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.r)


def pool(residuals: Sequence[Residual], channel: int) -> Samples:
    """Pool the valid samples of one channel over runs."""
    rs, fs, idx = [], {n: [] for n in FEATURES_1D}, []
    for i, res in enumerate(residuals):
        if res.run.n == 0 or not res.run.valid[channel]:
            continue
        rs.append(res.r[:, channel])
        for n in FEATURES_1D:
            fs[n].append(res.run.feat[n])
        idx.append(np.full(res.run.n, i))
    if not rs:
        return Samples(np.zeros(0), {n: np.zeros(0) for n in FEATURES_1D}, np.zeros(0, int))
    return Samples(np.concatenate(rs), {n: np.concatenate(v) for n, v in fs.items()}, np.concatenate(idx))


# ------------------------------------------------------------------------ binning
@dataclass
class BinStats:
    """Binned residual of one channel over one or two features.

    Attributes
    ----------
    names : tuple of str
        Feature names (1 or 2).
    edges : list of ndarray
        Bin edges per feature.
    mean, se, count : ndarray
        Bin mean [m/s^2], its standard error (the bin's floor) and sample count;
        NaN / 0 for empty bins.
    z : ndarray
        ``mean / se``.
    """

    names: tuple[str, ...]
    edges: list[np.ndarray]
    mean: np.ndarray
    se: np.ndarray
    count: np.ndarray
    z: np.ndarray

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            "features": list(self.names),
            "edges": [e.tolist() for e in self.edges],
            "mean_m_s2": np.where(np.isfinite(self.mean), self.mean, None).tolist(),
            "floor_m_s2": np.where(np.isfinite(self.se), self.se, None).tolist(),
            "count": self.count.astype(int).tolist(),
        }


def edges_for(x: np.ndarray, n_bins: int) -> np.ndarray:
    """Equal-width bin edges over the 1..99 % range of ``x`` (robust to outliers)."""
    if len(x) == 0:
        return np.linspace(0.0, 1.0, n_bins + 1)
    lo, hi = np.percentile(x, [1, 99])
    if not hi > lo:
        lo, hi = lo - 1e-9, hi + 1e-9
    return np.linspace(lo, hi, n_bins + 1)


def _index(x: np.ndarray, e: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(e, x, side="right") - 1, 0, len(e) - 2)


def bin_stats(
    s: Samples, names: Sequence[str], edges: Sequence[np.ndarray], sigma: float, inflation: float, min_count: int = 20
) -> BinStats:
    """Bin means of the residual over features, with standard errors from ``sigma`` and ``inflation``.

    Parameters
    ----------
    s : Samples
        Pooled residual.
    names, edges : sequences
        Features and their bin edges.
    sigma : float
        Noise rms (the floor) [m/s^2].
    inflation : float
        Autocorrelation inflation of the residual.
    min_count : int
        Bins with fewer samples are reported empty.
    """
    shape = tuple(len(e) - 1 for e in edges)
    idx = np.ravel_multi_index([_index(s.feat[n], e) for n, e in zip(names, edges, strict=True)], shape)
    size = int(np.prod(shape))
    cnt = np.bincount(idx, minlength=size).astype(float)
    sm = np.bincount(idx, weights=s.r, minlength=size)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(cnt >= min_count, sm / cnt, np.nan)
        se = np.where(cnt >= min_count, sigma * np.sqrt(inflation / cnt), np.nan)
        z = mean / se
    return BinStats(
        tuple(names),
        [np.asarray(e) for e in edges],
        mean.reshape(shape),
        se.reshape(shape),
        cnt.reshape(shape),
        z.reshape(shape),
    )


# --------------------------------------------------------------- additive maps
MAP_GROUPS: tuple[tuple[str, ...], ...] = (("g", "d"), ("g_dot",), ("d_dot",), ("i_q",), ("i_d",), ("di_q",), ("di_d",))


@dataclass
class AdditiveMap:
    """Additive binned model of a residual: a 2-D gap x position map plus 1-D maps.

    Fitted by backfitting on training samples; predicts the residual's
    systematic part from the features alone.
    """

    edges: dict[tuple[str, ...], list[np.ndarray]]
    tables: dict[tuple[str, ...], np.ndarray] = field(default_factory=dict)

    @classmethod
    def fit(
        cls,
        s: Samples,
        n_bins_g: int = 8,
        n_bins_d: int = 18,
        n_bins_1d: int = 12,
        sweeps: int = 4,
        min_count: int = 15,
    ) -> AdditiveMap:
        """Backfit the maps on ``s`` (the d bins resolve a slot pitch over the stroke: 5 mm for +-45 mm)."""
        edges = {}
        for grp in MAP_GROUPS:
            if len(grp) == 2:
                edges[grp] = [edges_for(s.feat["g"], n_bins_g), edges_for(s.feat["d"], n_bins_d)]
            else:
                edges[grp] = [edges_for(s.feat[grp[0]], n_bins_1d)]
        m = cls(edges)
        if s.n == 0:
            return m
        idx = {grp: m._flat(s, grp) for grp in MAP_GROUPS}
        sizes = {grp: int(np.prod([len(e) - 1 for e in edges[grp]])) for grp in MAP_GROUPS}
        m.tables = {grp: np.zeros(sizes[grp]) for grp in MAP_GROUPS}
        pred = {grp: np.zeros(s.n) for grp in MAP_GROUPS}
        total = np.zeros(s.n)
        for _ in range(sweeps):
            for grp in MAP_GROUPS:
                part = s.r - (total - pred[grp])
                cnt = np.bincount(idx[grp], minlength=sizes[grp])
                sm = np.bincount(idx[grp], weights=part, minlength=sizes[grp])
                # Shrink thin bins towards zero (James-Stein like): cnt / (cnt + min_count).
                tab = np.where(cnt > 0, sm / np.maximum(cnt, 1), 0.0) * cnt / (cnt + min_count)
                m.tables[grp] = tab
                new = tab[idx[grp]]
                total += new - pred[grp]
                pred[grp] = new
        return m

    def _flat(self, s: Samples, grp: tuple[str, ...]) -> np.ndarray:
        e = self.edges[grp]
        shape = tuple(len(x) - 1 for x in e)
        return np.ravel_multi_index([_index(s.feat[n], x) for n, x in zip(grp, e, strict=True)], shape)

    def predict(self, s: Samples) -> np.ndarray:
        """Predicted systematic residual at the samples of ``s``."""
        out = np.zeros(s.n)
        if not self.tables or s.n == 0:
            return out
        for grp in MAP_GROUPS:
            out += self.tables[grp][self._flat(s, grp)]
        return out


def _shift(s: Samples, rng: np.random.Generator) -> Samples:
    """``s`` with the residual circularly shifted within each run (features unchanged): the period scan's null."""
    r = s.r.copy()
    for i in np.unique(s.run):
        sel = np.flatnonzero(s.run == i)
        n = len(sel)
        if n > 4:
            r[sel] = np.roll(r[sel], int(rng.integers(n // 4, n - n // 4)))
    return Samples(r, s.feat, s.run)


def _gain(train: Samples, test: Samples, max_lag: int = 200) -> tuple[float, float, AdditiveMap]:
    """Held-out gain of the training maps and its z-score (see the module docstring)."""
    m = AdditiveMap.fit(train)
    pred = m.predict(test)
    sse0 = float(test.r @ test.r)
    if sse0 <= 0:
        return 0.0, 0.0, m
    e = test.r - pred
    gain = 1.0 - float(e @ e) / sse0
    n = len(test.r)
    rm = float(np.sqrt(np.mean(pred**2)))
    # Noise level and autocorrelation from what the maps leave (the structure itself would inflate both).
    sig = float(np.sqrt(np.mean(e**2)))
    sd = 2 * rm * sig * math.sqrt(autocorr_factor(e, max_lag) / n) / (sse0 / n) if rm > 0 else math.inf
    return gain, gain / sd, m


@dataclass
class ChannelFloor:
    """Noise floor and structure test of one channel.

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    rms : float
        Held-out rms of the residual [m/s^2].
    floor : float
        Noise floor rms: held-out rms after the training maps are subtracted [m/s^2].
    quantization : float
        Rms due to 10 um quantization alone, for reference [m/s^2].
    inflation : float
        Autocorrelation inflation ``n / n_eff``.
    gain : float
        Held-out gain of the maps.
    z : float
        Significance of the gain (see the module docstring).
    significant : bool
        The residual has state structure beyond the floor (``z > z_crit``).
    n : int
        Held-out samples.
    """

    channel: str
    rms: float
    floor: float
    quantization: float
    inflation: float
    gain: float
    z: float
    significant: bool
    n: int

    @property
    def excess(self) -> float:
        """Rms of the residual above the floor, ``sqrt(max(rms^2 - floor^2, 0))`` [m/s^2]."""
        return math.sqrt(max(self.rms**2 - self.floor**2, 0.0))

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            "rms_m_s2": self.rms,
            "floor_m_s2": self.floor,
            "quantization_m_s2": self.quantization,
            "excess_m_s2": self.excess,
            "autocorr_inflation": self.inflation,
            "map_gain": self.gain,
            "z": self.z,
            "significant": self.significant,
            "n_samples": self.n,
        }


def channel_floor(
    train: Sequence[Residual],
    test: Sequence[Residual],
    channel: int,
    quantization: float,
    z_crit: float = 4.0,
    min_gain: float = 0.01,
    max_lag: int = 200,
) -> ChannelFloor | None:
    """Noise floor and structure test of one channel (None if the channel has no data).

    Parameters
    ----------
    train, test : sequences of Residual
        Training and held-out residuals.
    channel : int
        0 vertical, 1 horizontal.
    quantization : float
        Quantization-only rms of the filter.
    z_crit : float
        Threshold on the gain's z-score.
    min_gain : float
        The maps must also predict at least this fraction of the held-out
        variance: structure that does not predict held-out runs is no gap
        (the null's mean gain is negative, the price of fitting noise).
    max_lag : int
        Longest lag of the noise's autocorrelation (samples). The noise of a
        filtered residual is correlated over about the filter's main lobe
        (``2 fs / fc``); longer correlations belong to structure the maps
        missed and would wrongly inflate the noise.
    """
    tr, te = pool(train, channel), pool(test, channel)
    if tr.n < 50 or te.n < 50:
        return None
    gain, z, m = _gain(tr, te, max_lag)
    rms = float(np.sqrt(np.mean(te.r**2)))
    e = te.r - m.predict(te)
    floor = float(np.sqrt(np.mean(e**2)))
    infl = autocorr_factor(e, max_lag)
    return ChannelFloor(
        CHANNELS[channel], rms, min(floor, rms), quantization, infl, gain, z, bool(z > z_crit and gain > min_gain), te.n
    )


# -------------------------------------------------------------------- period scan
@dataclass
class PeriodScan:
    """Least-squares period scan of a channel's residual over the position ``d``.

    Attributes
    ----------
    periods : ndarray
        Scanned periods [m].
    explained : ndarray
        Fraction of the (gap-detrended) residual variance explained by a
        sinusoid of each period.
    best_period, best_amplitude, best_explained : float
        The best period [m], its amplitude [m/s^2] and explained fraction.
    threshold : float
        Explained fraction that noise alone exceeds with probability
        :data:`PERIOD_FALSE_ALARM`: the extreme-value quantile of the best
        fraction over circularly shifted residuals (:func:`gumbel_threshold`).
    significant : bool
        ``best_explained > threshold``.
    match : str or None
        Name of a reference period within 4 % (``t1``, ``2 t1``, ``tau``, ...).
    """

    periods: np.ndarray
    explained: np.ndarray
    best_period: float
    best_amplitude: float
    best_explained: float
    threshold: float
    significant: bool
    match: str | None

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {
            "best_period_m": self.best_period,
            "amplitude_m_s2": self.best_amplitude,
            "explained_fraction": self.best_explained,
            "noise_threshold": self.threshold,
            "significant": self.significant,
            "matches": self.match,
        }


#: False-alarm probability of the period scan per channel (on a residual without structure in ``d``).
PERIOD_FALSE_ALARM: float = 1e-3


@dataclass
class _ScanDesign:
    """The cosines and sines of ``d`` at every scanned period, and their Gram entries (shared by all draws)."""

    C: np.ndarray
    S: np.ndarray
    cc: np.ndarray
    ss: np.ndarray
    cs: np.ndarray

    @classmethod
    def of(cls, d: np.ndarray, periods: np.ndarray) -> _ScanDesign:
        """The design of positions ``d`` [m] at ``periods`` [m]."""
        ph = (2 * math.pi / np.asarray(periods, float))[:, None] * np.asarray(d, float)[None, :]
        C, S = np.cos(ph), np.sin(ph)
        return cls(C, S, np.einsum("ij,ij->i", C, C), np.einsum("ij,ij->i", S, S), np.einsum("ij,ij->i", C, S))

    def explained(self, r: np.ndarray) -> np.ndarray:
        """Fraction of ``r @ r`` explained by the least-squares ``a cos + b sin`` at each period.

        ``r`` of shape ``(n,)`` gives ``(n_periods,)``; ``(n, m)`` (m residuals at once) gives ``(n_periods, m)``.
        """
        tot = np.einsum("i...,i...->...", r, r)
        a, b = self.C @ r, self.S @ r
        det = self.cc * self.ss - self.cs**2
        ok = det > 1e-12 * self.cc * self.ss
        if r.ndim == 2:
            det, ok = det[:, None], ok[:, None]
            cc, ss, cs = self.cc[:, None], self.ss[:, None], self.cs[:, None]
        else:
            cc, ss, cs = self.cc, self.ss, self.cs
        num = ss * a * a - 2 * cs * a * b + cc * b * b
        return np.where(ok, num / np.maximum(det, 1e-300), 0.0) / np.maximum(tot, 1e-300)


def gumbel_threshold(maxima: np.ndarray, false_alarm: float) -> float:
    """Level a maximum over many (weakly dependent) noise statistics exceeds with probability ``false_alarm``.

    The maximum of many weakly dependent, light-tailed statistics follows the
    extreme-value (Gumbel) law; its location and scale are fitted by moments to
    the null ``maxima`` (scale ``sd sqrt(6) / pi``, location ``mean - gamma scale``)
    and the threshold is its ``1 - false_alarm`` quantile. (At 1e-3 that is
    the null mean plus 4.9 null standard deviations.)
    """
    m = np.asarray(maxima, float)
    if len(m) < 3:
        return float(np.max(m)) if len(m) else math.inf
    beta = float(np.std(m, ddof=1)) * math.sqrt(6.0) / math.pi
    mu = float(np.mean(m)) - np.euler_gamma * beta
    return mu - beta * math.log(-math.log1p(-false_alarm))


def period_scan(
    s: Samples,
    rng: np.random.Generator,
    p_min: float = 4e-3,
    p_max: float | None = None,
    n_periods: int = 300,
    n_null: int = 100,
    max_samples: int = 6000,
    false_alarm: float = PERIOD_FALSE_ALARM,
) -> PeriodScan | None:
    """Scan periods in ``d`` (after removing the residual's gap dependence by bin means).

    The threshold is the ``1 - false_alarm`` quantile of the best explained
    fraction on residuals circularly shifted within their runs (same
    autocorrelation, no relation to ``d``), scanned over the *same* period
    grid (a coarser grid would make the null's maximum smaller than the
    data's), from an extreme-value law fitted to ``n_null`` such draws
    (:func:`gumbel_threshold`).

    Parameters
    ----------
    s : Samples
        Pooled residual of one channel.
    rng : numpy Generator
        For subsampling and the null distribution.
    p_min, p_max : float
        Scanned range [m] (``p_max`` defaults to the travelled span of ``d``, at most 120 mm).
    n_periods : int
        Log-spaced grid size.
    n_null : int
        Circular shifts for the threshold.
    max_samples : int
        Subsample for speed (the residual is low-passed, so little is lost).
    false_alarm : float
        Probability that a residual without structure in ``d`` is called periodic.
    """
    if s.n < 100:
        return None
    d = s.feat["d"]
    span = float(np.percentile(d, 99) - np.percentile(d, 1))
    if span < 2 * p_min:
        return None
    p_max = min(p_max or span, 0.12, max(span, 2 * p_min))
    # Remove the gap dependence (a smooth function of g is not a period in d).
    e = edges_for(s.feat["g"], 12)
    gi = _index(s.feat["g"], e)
    gm = np.bincount(gi, weights=s.r, minlength=len(e) - 1) / np.maximum(np.bincount(gi, minlength=len(e) - 1), 1)
    r = s.r - gm[gi]
    sel = np.arange(s.n)
    if s.n > max_samples:
        sel = np.sort(rng.choice(s.n, max_samples, replace=False))
    periods = np.geomspace(p_min, p_max, n_periods)
    design = _ScanDesign.of(d[sel], periods)
    expl = design.explained(r[sel])
    sub = Samples(r, s.feat, s.run)
    null_max = np.zeros(0)
    if n_null > 0:
        shifted = np.column_stack([_shift(sub, rng).r[sel] for _ in range(n_null)])
        null_max = np.max(design.explained(shifted), axis=0)
    thr = gumbel_threshold(null_max, false_alarm)
    j = int(np.argmax(expl))
    P = float(periods[j])
    ph = 2 * math.pi * d / P
    X = np.column_stack([np.cos(ph), np.sin(ph)])
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    match = None
    for name, ref in KNOWN_PERIODS.items():
        if abs(P / ref - 1) < 0.04:
            match = name
    return PeriodScan(periods, expl, P, float(np.hypot(*coef)), float(expl[j]), thr, bool(expl[j] > thr), match)


# ------------------------------------------------------------------------ regions
@dataclass
class Region:
    """A region of the gap x position plane where a channel's residual exceeds its floor.

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    g_range_m, d_range_m : list of float
        Bounding box [m].
    freq_band_hz : list of float or None
        Band of the residual's excess power (spectrum) in this channel.
    excess_over_floor : float
        Size of the gap there relative to the noise: rms of the region's bin means (or the
        amplitude of a spectral line) divided by the channel's noise floor rms.
    mean_abs_m_s2 : float
        Mean ``|bin mean|`` in the region [m/s^2].
    n_bins : int
        Bins in the region (0 for a spectral line, which has no place in gap x position).
    z : float
        Significance: rms of the bins' mean / standard error (for a line, the PSD ratio).
    period_m : float or None
        Period in d of the channel's residual, when the period scan finds one.
    """

    channel: str
    g_range_m: list[float]
    d_range_m: list[float]
    freq_band_hz: list[float] | None
    excess_over_floor: float
    mean_abs_m_s2: float
    n_bins: int
    z: float = math.nan
    period_m: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready view (the issue's ``regions`` entries)."""
        return {
            "channel": self.channel,
            "g_range_m": self.g_range_m,
            "d_range_m": self.d_range_m,
            "freq_band_hz": self.freq_band_hz,
            "excess_over_floor": self.excess_over_floor,
            "mean_abs_m_s2": self.mean_abs_m_s2,
            "n_bins": self.n_bins,
            "z": self.z,
            "period_m": self.period_m,
        }


def regions_from_map(
    bs: BinStats, channel: str, band: list[float] | None, floor: float, alpha: float = 0.01, max_regions: int = 6
) -> list[Region]:
    """Connected groups (8-neighbourhood) of bins whose mean exceeds the floor (``|z|`` above a Bonferroni bound)."""
    finite = np.isfinite(bs.z)
    n_bins = max(int(finite.sum()), 1)
    z_crit = float(st.norm.isf(alpha / (2 * n_bins)))
    sig = finite & (np.abs(np.where(finite, bs.z, 0.0)) > z_crit)
    lab, n_lab = ndi.label(sig, structure=np.ones((3, 3), int))
    out = []
    for j in range(1, n_lab + 1):
        ii, jj = np.nonzero(lab == j)
        eg, ed = bs.edges
        zz = bs.z[ii, jj]
        mm = bs.mean[ii, jj]
        out.append(
            Region(
                channel,
                [float(eg[ii.min()]), float(eg[ii.max() + 1])],
                [float(ed[jj.min()]), float(ed[jj.max() + 1])],
                band,
                float(np.sqrt(np.mean(mm**2)) / floor),
                float(np.mean(np.abs(mm))),
                len(ii),
                float(np.sqrt(np.mean(zz**2))),
            )
        )
    out.sort(key=lambda r_: -(r_.excess_over_floor**2) * r_.n_bins)
    return out[:max_regions]


__all__ = [
    "FEATURES_1D",
    "KNOWN_PERIODS",
    "PERIOD_FALSE_ALARM",
    "AdditiveMap",
    "BinStats",
    "ChannelFloor",
    "PeriodScan",
    "Region",
    "Samples",
    "Spectrum",
    "bin_stats",
    "channel_floor",
    "dominant_band",
    "edges_for",
    "gumbel_threshold",
    "period_scan",
    "pool",
    "regions_from_map",
    "spectrum",
]
