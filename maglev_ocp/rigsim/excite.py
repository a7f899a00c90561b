"""Excitation of the generator: point-to-point moves at varied speeds plus a small dither.

Each axis follows its own sequence of minimum-jerk moves (quintic in time) to
random targets, with random move times (slow and fast) and dwells, so the data
visit the gap band and the stroke at many speeds and in both directions; a
faded-in sum of sines adds current rates and small velocities. Each run of a
dataset sweeps its own gap band; the bands overlap and together cover
``g_range``. References are computed on the whole time grid at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ExcitationSettings:
    """What the excitation visits.

    Attributes
    ----------
    g_range : tuple of float
        Gap band of the dataset [m].
    d_amplitude : float
        Largest |d| of the targets [m].
    move_time : tuple of float
        Range of the duration of one move [s].
    dwell : tuple of float
        Range of the rest between moves [s].
    dither_g, dither_d : float
        Peak amplitude of the dither per axis [m].
    fade_in : float
        Time over which the dither fades in, and before the first move [s].
    """

    g_range: tuple[float, float] = (12e-3, 25e-3)
    d_amplitude: float = 45e-3
    move_time: tuple[float, float] = (0.3, 2.0)
    dwell: tuple[float, float] = (0.0, 0.4)
    dither_g: float = 0.3e-3
    dither_d: float = 1.5e-3
    fade_in: float = 0.8
    extra: dict = field(default_factory=dict)


def _moves(t: np.ndarray, x0: float, lo: float, hi: float, s: ExcitationSettings, rng: np.random.Generator):
    """Minimum-jerk moves from ``x0`` to random targets in [lo, hi]: position, velocity, acceleration on ``t``."""
    x, v, a = np.full_like(t, x0), np.zeros_like(t), np.zeros_like(t)
    t0, cur, T_end = s.fade_in, x0, t[-1]
    while t0 < T_end:
        T = float(rng.uniform(*s.move_time))
        tgt = lo + (hi - lo) * float(rng.beta(0.6, 0.6))  # arcsine-like: the band's ends are visited often
        D = tgt - cur
        m = (t >= t0) & (t < t0 + T)
        tau = (t[m] - t0) / T
        x[m] = cur + D * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
        v[m] = D / T * (30 * tau**2 - 60 * tau**3 + 30 * tau**4)
        a[m] = D / T**2 * (60 * tau - 180 * tau**2 + 120 * tau**3)
        x[t >= t0 + T] = tgt
        cur = tgt
        t0 += T + float(rng.uniform(*s.dwell))
    return x, v, a


def _dither(t: np.ndarray, amp: float, f_lo: float, f_hi: float, fade: float, rng: np.random.Generator):
    """Faded-in sum of three sines of total peak ``amp``: position, velocity, acceleration."""
    x, v, a = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    if amp <= 0:
        return x, v, a
    # fade-in e(t) = sin^2(pi t / (2 fade)) for t < fade, then 1 (C1-smooth)
    arg = np.clip(t / fade, 0.0, 1.0) * (math.pi / 2)
    inside = t < fade
    e = np.sin(arg) ** 2
    ed = np.where(inside, (math.pi / (2 * fade)) * np.sin(2 * arg), 0.0)
    edd = np.where(inside, 2 * (math.pi / (2 * fade)) ** 2 * np.cos(2 * arg), 0.0)
    for f in rng.uniform(f_lo, f_hi, 3):
        w, ph = 2 * math.pi * f, rng.uniform(0, 2 * math.pi)
        s, c = np.sin(w * t + ph) - math.sin(ph), np.cos(w * t + ph)
        A = amp / 3
        x += A * e * s
        v += A * (ed * s + e * w * c)
        a += A * (edd * s + 2 * ed * w * c - e * w * w * (s + math.sin(ph)))
    return x, v, a


def references(n_runs: int, n_steps: int, Ts: float, s: ExcitationSettings, rng: np.random.Generator) -> np.ndarray:
    """Reference rows of every run, shape (n_runs, n_steps, 6): ``g, g_dot, g_ddot, d, d_dot, d_ddot``."""
    t = np.arange(n_steps) * Ts
    lo, hi = s.g_range
    half = max(0.35 * (hi - lo), 2.5e-3)
    centers = np.linspace(lo + half, hi - half, n_runs) if n_runs > 1 else np.array([(lo + hi) / 2])
    out = np.empty((n_runs, n_steps, 6))
    for i in rng.permutation(n_runs):
        c = float(centers[i])
        g_lo, g_hi = max(lo, c - half), min(hi, c + half)
        g = _moves(t, c, g_lo, g_hi, s, rng)
        d = _moves(t, 0.0, -s.d_amplitude, s.d_amplitude, s, rng)
        gd = _dither(t, s.dither_g, 1.0, 6.0, s.fade_in, rng)
        dd = _dither(t, s.dither_d, 0.8, 4.0, s.fade_in, rng)
        for j in range(3):
            out[i, :, j] = g[j] + gd[j]
            out[i, :, 3 + j] = d[j] + dd[j]
    return out


__all__ = ["ExcitationSettings", "references"]
