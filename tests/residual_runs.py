"""A residual of the diagnosis built from features and a residual written in a test (shared by the signature tests)."""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as spa

from maglev_ocp.diagnosis.residuals import PreparedRun, Residual


def feature_residual(name: str, feat: dict[str, np.ndarray], force, noise: float,
                     rng: np.random.Generator) -> Residual:  # fmt: skip
    """A held-out-like run's residual ``force(feat, channel) + noise`` (white, rms ``noise``) at the features
    ``feat`` (the keys of :attr:`PreparedRun.feat`), with the current rates added as the features' gradients."""
    t = feat["t"]
    feat["di_q"] = np.gradient(feat["i_q"], t)
    feat["di_d"] = np.gradient(feat["i_d"], t)
    n = len(t)
    r = np.column_stack([force(feat, 0), force(feat, 1)]) + noise * rng.standard_normal((n, 2))
    run = PreparedRun(name, (), np.array([True, True]), np.zeros((n, 8)), spa.csr_matrix((n, n)), r, np.arange(n),
                      feat)  # fmt: skip
    return Residual(run, r, np.zeros_like(r))


def clipped_sweeps(rng: np.random.Generator, n: int, d_amp: float,
                   freq: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """One run's time, gap and position ``(t, g, d)`` at 250 Hz: a sweep along d of amplitude ``d_amp`` and one of
    the gap over 13..23 mm, each a sine clipped at 80 % of its amplitude (it dwells at rest at its turning
    points), frequencies uniform in ``freq`` [Hz], phases uniform."""
    t = np.arange(n) * 4e-3
    f1, f2 = rng.uniform(*freq, 2)
    ph = rng.uniform(0, 2 * math.pi, 2)
    d = d_amp * np.clip(1.25 * np.sin(2 * math.pi * f1 * t + ph[0]), -1, 1)
    g = 0.018 + 0.005 * np.clip(1.25 * np.sin(2 * math.pi * f2 * t + ph[1]), -1, 1)
    return t, g, d


def swept_runs(force, seed: int, floor: float, n_runs: int = 3, n: int = 2500) -> list[Residual]:
    """Held-out-like runs of ``force`` plus white noise of rms ``floor``: sweeps along d (+-47 mm) and of the gap
    (13..23 mm) dwelling at their turning points (:func:`clipped_sweeps`); the levitation current follows the gap,
    the thrust current the acceleration, each with a dither of its own, as a closed loop's do."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n_runs):
        t, g, d = clipped_sweeps(rng, n, 0.047, (0.3, 0.7))
        d_dot, g_dot = np.gradient(d, t), np.gradient(g, t)
        dither = np.convolve(rng.standard_normal((n + 24,)), np.ones(25) / 5.0, mode="valid")[:n]
        i_q = 0.1 * np.gradient(d_dot, t) + 0.3 * dither
        i_d = 1.0 + 150.0 * (g - 0.015) + 0.3 * np.roll(dither, n // 3)
        feat = {"t": t, "g": g, "d": d, "g_dot": g_dot, "d_dot": d_dot, "i_q": i_q, "i_d": i_d}
        out.append(feature_residual(f"run{i}", feat, force, floor, rng))
    return out


def still_current_runs(
    force, seed: int, floor: float, n_runs: int = 3, n: int = 2500, d_amp: float = 0.045
) -> list[Residual]:
    """Held-out-like runs of ``force`` plus white noise of rms ``floor``: sweeps along d (+-``d_amp``, by default
    the rig's +-45 mm) and of the gap (13..23 mm) dwelling at their turning points (:func:`clipped_sweeps`), no
    thrust current and a levitation current that follows the gap alone (laws of the velocities and the gap,
    without the currents' dither)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n_runs):
        t, g, d = clipped_sweeps(rng, n, d_amp, (0.4, 0.8))
        feat = {"t": t, "g": g, "d": d, "g_dot": np.gradient(g, t), "d_dot": np.gradient(d, t),
                "i_q": np.zeros(n), "i_d": 1.0 + 150.0 * (g - 0.015)}  # fmt: skip
        out.append(feature_residual(f"run{i}", feat, force, floor, rng))
    return out
