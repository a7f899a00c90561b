"""The random draws every law set's draw functions share (one stream each; the same calls give the same bytes)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

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


def pick_effects(
    rng: np.random.Generator, kind: str, n: int, library: Sequence[str], out_of_library: Sequence[str]
) -> list[str]:
    """The effects of a scenario: ``n`` distinct ones of ``library``, or one of ``out_of_library`` for that kind."""
    names = [str(x) for x in rng.choice(library, size=n, replace=False)]
    if kind == "out_of_library":
        names = [str(rng.choice(out_of_library))]
    return names


def draw_effects(
    rng: np.random.Generator,
    kind: str,
    n: int,
    library: Sequence[str],
    out_of_library: Sequence[str],
    draws: Mapping[str, Callable[[np.random.Generator], dict[str, Any]]],
    order: Sequence[str],
    new_law: bool,
) -> dict[str, dict[str, Any]]:
    """A law set's scenario effects (:func:`pick_effects`), each drawn by ``draws`` in ``order``, marked ``new_law``."""
    names = pick_effects(rng, kind, n, library, out_of_library)
    return {nm: {**draws[nm](rng), "new_law": new_law} for nm in sorted(names, key=list(order).index)}
