"""The seventeenth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v17"``; see :mod:`.laws_v17`).

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
    "_V17",
    "HangingCable",
    "ProbeTargetEdge",
    "_Peaks",
    "catenary",
    "current_force",
    "window",
    "window_slope",
]


class _V17:
    """Mixin: marks a law of the seventeenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v17"``)."""
        return {**super().describe(), "law_set": "v17"}  # type: ignore[misc]


def catenary(span, rise, length):
    """An inextensible cable of ``length`` hung between two points ``span`` apart horizontally (> 0), the upper
    ``rise`` above the lower: ``(a, x_lo)``, the catenary's parameter ``a = H / w`` [m] and the lower end's abscissa
    from the vertex over ``a`` (``sinh(u) = r u``, ``r = sqrt(S^2 - Y^2) / X``, ``a = X / 2u``; ``tanh(m) = Y / S``,
    ``x_lo = m - u``)."""
    x = np.asarray(span, dtype=float)
    y = np.asarray(rise, dtype=float)
    r = np.sqrt(length**2 - y**2) / x
    u = np.maximum(3.0, 2.0 * np.log(2.0 * r + 1.0))  # right of the root: Newton falls monotonically (convex)
    for _ in range(60):
        u = u - (np.sinh(u) - r * u) / (np.cosh(u) - r)
    return x / (2.0 * u), np.arctanh(y / length) - u


# --------------------------------------------------------------------- out of the library
class HangingCable(_V17, Law):
    """A slack cable hanging from a fixed anchor to the mover, as a catenary (not in the library).

    An untracked cable of weight ``w`` per metre and length ``S`` hangs between an anchor ``x_a`` along the stroke
    and ``h_a`` above the mover's attachment (at 15 mm; negative: below, a cable rising from a duct on the base) and
    the mover: its shape is a catenary, ``z = a cosh(x/a)``,
    ``a = H / w`` (Irvine, "Cable Structures", MIT Press 1981, ch. 1; Routh, "A Treatise on Analytical Statics",
    Cambridge Univ. Press 1896, vol. 1, ch. 10): span ``X = x_a - d``, rise ``Y = h_a + (g - 15 mm)`` (the gap
    grows downwards, away from the stator above), ``sinh(u) = r u`` with ``r = sqrt(S^2 - Y^2) / |X|``, ``a = |X| /
    2u``; the cable pulls the mover along its tangent: ``F_d = sign(X) w a`` (the horizontal tension, towards the
    anchor) and upwards by ``w a sinh(x_lo)`` (``F_g`` its negative). Conservative (the cable's weight times its
    centre of gravity's height). Hook ``force``.
    """

    name = "hanging_cable"
    library = False
    families = ("catenary",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"catenary": {"w": 1.0, "S": 0.6, "h_a": 0.25, "x_a": 0.15}}
    has_force = True

    def force(self, g, gd, d, dd):
        """The cable's pull on the mover ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        span = p["x_a"] - d
        rise = p["h_a"] + (g - G_REF)
        a, xlo = catenary(np.abs(span), rise, p["S"])
        h = p["w"] * a
        return -h * np.sinh(xlo), np.sign(span) * h


class ProbeTargetEdge(_V17, Law):
    """The gap probe's spot runs off its target's edge near one end of the stroke (not in the library).

    An eddy-current gap probe needs a target a few spot diameters wide; where its spot (growing with the standoff)
    overhangs the target's edge, less conductor faces it and it reads the gap too large (Nabavi & Nihtianov, "Design
    strategies for eddy-current displacement sensor systems: review and recommendations", IEEE Sensors J. 12(12),
    2012; Vyroubal, "Eddy-current displacement transducer with extended linear range and automatic tuning", IEEE
    Trans. Instrum. Meas. 58(9), 2009): ``g_read = g + e_m (g / 15 mm)^2 (1 + tanh(s (d - d_e) / (c_s g))) / 2``,
    the edge crossed at ``d = d_e`` (the probe's offset on the mover included), ``s = +-1`` its side; ``d`` read
    untouched. Hook ``read_at`` (memoryless); size: the largest reading error of the gap.
    """

    name = "probe_target_edge"
    library = False
    families = ("spot_overhang",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "spot_overhang": {"e_m": 5e-5, "d_e": 0.03, "side": 1.0, "c_s": 0.5}
    }
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def error(self, g, d):
        """The gap reading's error [m] at gap ``g`` and position ``d``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        z = p["side"] * (d - p["d_e"]) / (p["c_s"] * g)
        return p["e_m"] * (g / G_REF) ** 2 * 0.5 * (1.0 + np.tanh(z))

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` (any shape; the time is not used)."""
        return np.asarray(g, dtype=float) + self.error(g, d), d
