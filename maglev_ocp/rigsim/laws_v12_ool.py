"""The twelfth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v12"``; see :mod:`.laws_v12`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .laws_v11_ool import G_REF, _Peaks, _Warming, current_force, smoothstep

__all__ = [
    "G_REF",
    "_V12",
    "EndBumpers",
    "MainsHum",
    "_Peaks",
    "_Warming",
    "current_force",
    "smoothstep",
]


class _V12:
    """Mixin: marks a law of the twelfth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v12"``)."""
        return {**super().describe(), "law_set": "v12"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class MainsHum(_V12, Law):
    """Mains hum picked up by the gap probe's analog signal through a ground loop (not in the library).

    The probe's analog output and the controller's input share a ground with the drive's mains supply; the loop's
    area picks up the mains field and the ground currents drop a voltage along the shield, at the mains frequency
    and its odd harmonics (a rectifier load's third above all) (Ott, "Electromagnetic Compatibility Engineering",
    Wiley 2009, ch. 3 (ground loops) and ch. 2 (cable shielding); Morrison, "Grounding and Shielding: Circuits and
    Interference", 5th ed., Wiley 2007). The reading, not the gap, carries it: ``g_read = g + a_g (sin(2 pi f_m t +
    phi) + h3 sin(6 pi f_m t + phi3))``, the horizontal encoder (digital) untouched, ``t`` the dataset time (hook
    ``read_at``; size: the largest reading error).
    """

    name = "mains_hum"
    library = False
    families = ("ground_loop",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "ground_loop": {"a_g": 1e-5, "f_m": 50.0, "phi": 0.0, "h3": 0.3, "phi3": 0.0}
    }
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def hum(self, t):
        """The reading error on the gap [m] at the dataset time ``t`` [s]."""
        p = self.p
        w = 2 * math.pi * p["f_m"] * np.asarray(t, dtype=float)
        return p["a_g"] * (np.sin(w + p["phi"]) + p["h3"] * np.sin(3 * w + p["phi3"]))

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` at the dataset time ``t`` (no hum without a time)."""
        g = np.asarray(g, dtype=float)
        if t is None:
            return g, d
        return g + self.hum(t), d


class EndBumpers(_V12, Law):
    """Elastomer bumpers at the stroke's ends that the mover touches on its longest moves (not in the library).

    Each end of the horizontal stroke has a rubber bumper before the hard stop, its contact at ``x_p`` and ``-x_n``;
    the contact force of a compliant body with damping proportional to the indentation (Hunt & Crossley,
    "Coefficient of restitution interpreted as damping in vibroimpact", ASME J. Appl. Mech. 42(2), 1975; the
    Hertzian exponent 3/2: Johnson, "Contact Mechanics", Cambridge Univ. Press 1985, ch. 4; its use for contact
    dynamics: Gilardi & Sharf, "Literature survey of contact dynamics modelling", Mech. Mach. Theory 37(10), 2002):
    ``F = k_b delta^1.5 (1 + 1.5 alpha delta_dot)``, never pulling (``F >= 0``), ``delta`` the indentation. Along d
    only; zero inside the bumpers' span.
    """

    name = "end_bumpers"
    library = False
    families = ("hunt_crossley",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "hunt_crossley": {"x_p": 0.042, "x_n": 0.042, "k_b": 5e4, "alpha": 0.3}
    }
    has_force = True

    def contact(self, delta, rate):
        """Hunt-Crossley force [N] (>= 0) at the indentation ``delta`` [m] growing at ``rate`` [m/s]."""
        p = self.p
        dl = np.maximum(np.asarray(delta, dtype=float), 0.0)
        return np.maximum(p["k_b"] * dl**1.5 * (1.0 + 1.5 * p["alpha"] * np.asarray(rate, dtype=float)), 0.0)

    def force(self, g, gd, d, dd):
        """The bumpers' push ``(F_g, F_d)`` [N]."""
        d, dd = np.asarray(d, dtype=float), np.asarray(dd, dtype=float)
        fd = -self.contact(d - self.p["x_p"], dd) + self.contact(-self.p["x_n"] - d, -dd)
        return 0.0 * fd + 0.0 * np.asarray(g, dtype=float), fd
