"""The eighteenth law set's mark and its two effects outside the library (issue 27, ``laws="v18"``; see
:mod:`.laws_v18`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .laws_v16_ool import G_REF, K_FIELD, _Peaks, current_force, window, window_slope

__all__ = [
    "G_REF",
    "K_FIELD",
    "_V18",
    "ExpandingScale",
    "SpringReel",
    "_Peaks",
    "current_force",
    "window",
    "window_slope",
]


class _V18:
    """Mixin: marks a law of the eighteenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v18"``)."""
        return {**super().describe(), "law_set": "v18"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class SpringReel(_V18, Law):
    """A cable paid out from a spring-loaded reel fixed on the base, held taut to the mover (not in the library).

    A retracting reel keeps its cable taut with a spiral (clock) spring; a nearly constant-force (negator) spring
    gives a tension that rises a little with the length paid out, ``T = T0 + k_s (l - l0)`` (Votta, "The theory and
    design of long-deflection constant-force spring elements", Trans. ASME 74, 1952; Budynas & Nisbett, "Shigley's
    Mechanical Engineering Design", 9th ed., McGraw-Hill 2011, ch. 10 (spiral springs)). The straight cable runs from
    the reel's outlet, ``x_r`` along the stroke and ``h_r`` above the mover's attachment at 15 mm (negative: below,
    on the base; the gap grows downwards, away from the stator above), to the mover: ``l = sqrt((x_r - d)^2 + (h_r +
    g - 15 mm)^2)``, ``l0`` its length at ``(15 mm, 0)``; the energy ``T0 l + k_s
    (l - l0)^2 / 2``, the force ``-T grad l``: along the cable, towards the reel. Hook ``force`` (conservative).
    """

    name = "spring_reel"
    library = False
    families = ("negator",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"negator": {"T0": 0.6, "k_s": 5.0, "x_r": 0.2, "h_r": -0.03}}
    has_force = True

    def length(self, g, d):
        """The cable's free length [m] at ``(g, d)``."""
        p = self.p
        return np.hypot(p["x_r"] - np.asarray(d, dtype=float), p["h_r"] + np.asarray(g, dtype=float) - G_REF)

    def force(self, g, gd, d, dd):
        """The cable's pull on the mover ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        dx, dz = p["x_r"] - d, p["h_r"] + g - G_REF
        ln = np.hypot(dx, dz)
        t = p["T0"] + p["k_s"] * (ln - float(np.hypot(p["x_r"], p["h_r"])))
        return -t * dz / ln, t * dx / ln


class ExpandingScale(_V18, Law):
    """The position encoder's scale warms up and expands from its fixed clamp (not in the library).

    A scale clamped at one point ``x_f`` and free elsewhere grows by ``alpha dT (x - x_f)`` as it warms; the head
    reads the scale's graduation, so the position reads short by that much (Bryan, "International status of thermal
    error research", CIRP Annals 39(2), 1990; Slocum, "Precision Machine Design", Prentice Hall 1992, ch. 2
    (thermal expansion errors)). The scale warms from the motor's heat as a first-order thermal body over the whole
    dataset (the runs' times one after the other): ``dT(t) = dT_inf (1 - e^{-t / tau_th})``; ``d_read = d - c_e (1 -
    e^{-t / tau_th}) (d - x_f)``, ``c_e = alpha dT_inf``; ``g`` read untouched. Hook ``read_at``; size: the largest
    reading error of the position.
    """

    name = "expanding_scale"
    library = False
    families = ("warming_scale",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"warming_scale": {"c_e": 1.5e-4, "tau_th": 30.0, "x_f": 0.1}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def error(self, d, t):
        """The position reading's error [m] at ``d`` and time ``t`` (None: the scale warm)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        warm = 1.0 if t is None else 1.0 - np.exp(-np.asarray(t, dtype=float) / p["tau_th"])
        return -p["c_e"] * warm * (d - p["x_f"])

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` (any shape; ``t`` the time since the first run's start, or None)."""
        return np.asarray(g, dtype=float) + 0.0 * np.asarray(d, dtype=float), d + self.error(d, t)
