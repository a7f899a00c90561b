"""The sixteenth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v16"``; see :mod:`.laws_v16`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law
from .laws_v13_drive import field_ratio
from .laws_v13_ool import G_REF, _Peaks, current_force

__all__ = ["G_REF", "K_FIELD", "_V16", "FerrousDebris", "ScaleJoint", "_Peaks", "current_force", "window"]

#: The field's wavenumber ``pi / tau`` [1/m] (MODEL.md's ``B ∝ 1 / sinh(pi (hm + g) / tau)``).
K_FIELD = math.pi / k.tau


def window(x, half: float, edge: float):
    """A smooth window: 1 over ``|x| < half``, falling over ``edge`` at each end (``tanh`` steps)."""
    x = np.asarray(x, dtype=float)
    return 0.5 * (np.tanh((x + half) / edge) - np.tanh((x - half) / edge))


def window_slope(x, half: float, edge: float):
    """``d window / d x``."""
    x = np.asarray(x, dtype=float)
    return 0.5 / edge * (1.0 / np.cosh((x + half) / edge) ** 2 - 1.0 / np.cosh((x - half) / edge) ** 2)


class _V16:
    """Mixin: marks a law of the sixteenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v16"``)."""
        return {**super().describe(), "law_set": "v16"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class FerrousDebris(_V16, Law):
    """A steel chip lying on the stator's face, pulled by the magnet array while under it (not in the library).

    A small soft-iron body of volume ``V`` in the field ``B`` is pulled with ``F = (V chi_eff / 2 mu0) grad |B|^2``
    (Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press 2001, ch. 3, force on a magnetizable
    body; Jackson, "Classical Electrodynamics", 3rd ed., Wiley 1999, ch. 5): over an array's fundamental ``|B|^2``
    does not depend on the position along the array (its two components are in quadrature), so the chip's energy is
    ``W = -E_c b(g)^2 w(x_c - d)``, ``b = B(g) / B(15 mm)``, ``w`` the array's footprint (1 under it, falling over
    ``l_c`` at its ends, ``L/2`` from its middle). The reaction on the mover: a pull towards the stator while the
    chip is under the array, ``F_g = E_c d(b^2)/dg w``, and a force along d as an end of the array passes over the
    chip, ``F_d = E_c b^2 dw/dd``. ``E_c`` set by the pull ``F_c`` at 15 mm. Conservative; hook ``force``.
    """

    name = "ferrous_debris"
    library = False
    families = ("steel_chip",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"steel_chip": {"F_c": 0.8, "x_c": 0.1, "l_c": 0.006}}
    has_force = True

    def energy_scale(self) -> float:
        """``E_c`` [J]: ``F_c`` over ``|d(b^2)/dg|`` at 15 mm."""
        return self.p["F_c"] / (2.0 * K_FIELD / math.tanh(K_FIELD * (k.hm + G_REF)))

    def force(self, g, gd, d, dd):
        """The chip's reaction on the mover ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        half = 0.5 * k.pm * k.tau
        b2 = field_ratio(g) ** 2
        db2 = -2.0 * K_FIELD / np.tanh(K_FIELD * (k.hm + g)) * b2
        e = self.energy_scale()
        w = window(p["x_c"] - d, half, p["l_c"])
        dw = -window_slope(p["x_c"] - d, half, p["l_c"])  # d w / d d
        return e * db2 * w, e * b2 * dw


class ScaleJoint(_V16, Law):
    """The linear encoder's scale is made of two butt-joined sections whose joint is off by ``s_j`` (not in the
    library).

    Long scales are laid in sections; a butt joint adds the error of the sections' relative placement to every
    reading past it, blended over the read head's reading window ``w_h`` as the head crosses the joint (Heidenhain,
    "Linear encoders for numerically controlled machine tools", 2019 (mounting of multi-section scales); Slocum,
    "Precision Machine Design", Prentice Hall 1992, ch. 2 (sensor errors)): ``d_read = d + s_j (1 + tanh((d - x_j) /
    w_h)) / 2``. The gap probe untouched. Hook ``read_at`` (memoryless); size: the largest reading error along d.
    """

    name = "scale_joint"
    library = False
    families = ("butt_joint",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"butt_joint": {"s_j": 4e-5, "x_j": 0.015, "w_h": 0.001}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` (any shape; the time is not used)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        return g, d + p["s_j"] * 0.5 * (1.0 + np.tanh((d - p["x_j"]) / p["w_h"]))
