"""Nominal physics of the 2-DOF stage, typed again from ``shared/spec/MODEL.md``.

This module shares no code with the suite's model: the shape functions of the
gap, the lumped dynamics (seed eq. (2)) and the cogging law (seed eq. (9)) are
written here in NumPy from the spec, so that datasets generated with them test
the diagnosis against a plant it was not built from. Everything is elementwise
and works on scalars and arrays alike.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from .. import constants as k

#: Lumped constants of seed Table III (eps = 0.01) and the spec's cogging defaults.
NOMINAL_C = {"C1": 14.20, "C2": 796.99, "C3": 31.04, "C4": 0.07}
NOMINAL_COG = {"xi0": 4.0, "ell": 3.6e-3}

# Field amplitude at the magnet surface without the sinh(a) of the gap (MODEL.md B(g)).
_B_COEF = (4.0 / math.pi) * k.Br * math.sin(math.pi * k.taup / (2.0 * k.tau)) * math.sinh(math.pi * k.hm / k.tau)


@dataclass(frozen=True)
class Constants:
    """The constants of one simulated rig (true values, or a controller's nominal belief).

    Attributes
    ----------
    C1, C2, C3, C4 : float
        Lumped constants of seed eq. (2) [m/s^2 per unit shape function].
    xi0 : float
        Peak cogging force at g = 10 mm [N] (seed eq. (9)).
    ell : float
        Exponential decay length of the cogging force [m].
    Mh, Mv : float
        Horizontal and vertical moving masses [kg].
    """

    C1: float = NOMINAL_C["C1"]
    C2: float = NOMINAL_C["C2"]
    C3: float = NOMINAL_C["C3"]
    C4: float = NOMINAL_C["C4"]
    xi0: float = NOMINAL_COG["xi0"]
    ell: float = NOMINAL_COG["ell"]
    Mh: float = k.Mh
    Mv: float = k.Mv

    def as_dict(self) -> dict[str, float]:
        """Plain dict of the constants."""
        return {a: float(b) for a, b in asdict(self).items()}

    def drawn(self, rng: np.random.Generator, relative: float) -> Constants:
        """Copy with every constant multiplied by ``1 + U(-relative, relative)`` (a rig off nominal)."""
        d = self.as_dict()
        return replace(self, **{n: v * (1.0 + rng.uniform(-relative, relative)) for n, v in d.items()})


NOMINAL = Constants()


@dataclass
class Shape:
    """Shape functions of the gap (MODEL.md), elementwise in g."""

    lam: np.ndarray
    Kc: np.ndarray
    B: np.ndarray
    f1: np.ndarray
    f2: np.ndarray
    f3: np.ndarray
    f4: np.ndarray


def shape(g):
    """Evaluate the slot permeance, Carter's coefficient, the PM field and f1..f4 at gap ``g`` [m].

    Parameters
    ----------
    g : float or ndarray
        Air gap [m] (positive).

    Returns
    -------
    Shape
    """
    g = np.asarray(g, dtype=float)
    lam = 1.0 - k.b0 * k.b0 / (4.0 * k.t1 * (g + 0.5 * k.b0 + k.hm / k.mu_rec))
    r = k.b0 / (2.0 * g)
    gam = (4.0 / math.pi) * (r * np.arctan(r) - 0.5 * np.log1p(r * r))  # log(sqrt(1 + r^2))
    Kc = k.t1 / (k.t1 - gam * g)
    a = math.pi * (k.hm + g) / k.tau
    sh = np.sinh(a)
    coth = np.cosh(a) / sh
    B = _B_COEF / sh
    f1 = lam / (Kc * sh)
    f2 = lam * B * B
    f3 = lam * B * coth / Kc
    f4 = lam * coth * coth / (Kc * Kc)
    return Shape(lam, Kc, B, f1, f2, f3, f4)


def cogging(g, d, c: Constants = NOMINAL):
    """Cogging of seed eq. (9) and MODEL.md: ``(Fx, Fn)`` [N], Fx along +d, Fn attractive (reduces g)."""
    xi = c.xi0 * np.exp(-(np.asarray(g) - k.g_cog_ref) / c.ell)
    s = np.sin(math.pi * np.asarray(d) / k.t1)
    return xi * s, xi * s * s


def accelerations(g, d, i_q, i_d, c: Constants = NOMINAL, with_cogging: bool = True):
    """Nominal accelerations ``(g_ddot, d_ddot)`` of seed eq. (2) [m/s^2]."""
    sh = shape(g)
    gdd = c.C3 * sh.f3 * i_d - c.C4 * sh.f4 * (i_q * i_q + i_d * i_d) - c.C2 * sh.f2 + k.G
    ddd = -c.C1 * sh.f1 * i_q
    if with_cogging:
        fx, fn = cogging(g, d, c)
        gdd = gdd - fn / c.Mv
        ddd = ddd + fx / c.Mh
    return gdd, ddd


def equilibrium_current(g, c: Constants = NOMINAL) -> np.ndarray:
    """Hover current i_d at gap ``g`` with i_q = 0, d = 0 (seed eq. (8)): the root of smaller magnitude.

    Solves ``C4 f4 i^2 - C3 f3 i + (C2 f2 - G) = 0`` as ``2 c0 / (C3 f3 + sqrt(disc))``, which is the
    smaller root written without cancellation.
    """
    sh = shape(g)
    a2, b1, c0 = c.C4 * sh.f4, c.C3 * sh.f3, c.C2 * sh.f2 - k.G
    disc = b1 * b1 - 4.0 * a2 * c0
    return 2.0 * c0 / (b1 + np.sqrt(disc))


def vertical_pole(g: float, c: Constants = NOMINAL, dg: float = 1e-7) -> float:
    """Open-loop vertical pole [rad/s] at a hover at gap ``g`` (centred difference of g_ddot in g)."""
    i = float(equilibrium_current(g, c))
    a_hi = accelerations(g + dg, 0.0, 0.0, i, c, with_cogging=False)[0]
    a_lo = accelerations(g - dg, 0.0, 0.0, i, c, with_cogging=False)[0]
    slope = float((a_hi - a_lo) / (2 * dg))
    return math.sqrt(slope) if slope > 0 else -math.sqrt(-slope)


__all__ = [
    "NOMINAL",
    "NOMINAL_C",
    "NOMINAL_COG",
    "Constants",
    "Shape",
    "accelerations",
    "cogging",
    "equilibrium_current",
    "shape",
    "vertical_pole",
]
