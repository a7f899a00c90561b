"""The random draws every law set's draw functions share (one stream each; the same calls give the same bytes)."""

from __future__ import annotations

import math

import numpy as np


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Uniform in ``[lo, hi)``."""
    return float(rng.uniform(lo, hi))


def _pm(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A random sign times a uniform magnitude in ``[lo, hi)``."""
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def _log(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform in ``[lo, hi)``."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
