"""The fifteenth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v15"``; see :mod:`.laws_v15`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .laws_v13_ool import G_REF, _Peaks, current_force

__all__ = ["G_REF", "_V15", "LimitSwitch", "ProbeNonlinearity", "_Peaks", "current_force"]


class _V15:
    """Mixin: marks a law of the fifteenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v15"``)."""
        return {**super().describe(), "law_set": "v15"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class LimitSwitch(_V15, Law):
    """A mechanical limit switch whose spring-loaded roller rides over a cam on the mover (not in the library).

    The switch sits at ``x_s``; the mover's cam lifts its roller by ``h_r`` over a plateau ``l_p`` long, reached by
    ramps ``l_r`` long. The roller's spring pushes on the cam with ``F_s`` (its lift ``h`` stores ``W = F_s h``, the
    spring preloaded), so the cam's slope turns it into a force along the travel, ``F_d = -F_s dh/dd`` (the cam's
    pressure angle: Norton, "Cam Design and Manufacturing Handbook", 2nd ed., Industrial Press 2009, ch. 7; roller
    lever switches: Honeywell, "Limit switches: application and technical guide", 2014): ``h = (h_r / 2) [tanh((u +
    l_p/2) / l_r) - tanh((u - l_p/2) / l_r)]``, ``u = d - x_s``: the mover is pushed back as the roller climbs a
    ramp and pushed on as it rolls down the other; on the plateau and away from the cam nothing. The gap axis none
    (the roller presses sideways). Conservative. Hook ``force``.
    """

    name = "limit_switch"
    library = False
    families = ("roller_cam",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "roller_cam": {"F_s": 1.5, "h_r": 0.003, "l_r": 0.004, "l_p": 0.008, "x_s": 0.03}
    }
    has_force = True

    def lift(self, d):
        """The roller's lift ``h`` [m] at position ``d``."""
        p = self.p
        u = np.asarray(d, dtype=float) - p["x_s"]
        return 0.5 * p["h_r"] * (np.tanh((u + 0.5 * p["l_p"]) / p["l_r"]) - np.tanh((u - 0.5 * p["l_p"]) / p["l_r"]))

    def force(self, g, gd, d, dd):
        """The roller's force ``(F_g, F_d)`` [N]."""
        p = self.p
        u = np.asarray(d, dtype=float) - p["x_s"]
        s1 = 1.0 / np.cosh((u + 0.5 * p["l_p"]) / p["l_r"]) ** 2
        s2 = 1.0 / np.cosh((u - 0.5 * p["l_p"]) / p["l_r"]) ** 2
        fd = -p["F_s"] * 0.5 * p["h_r"] / p["l_r"] * (s1 - s2)
        return 0.0 * fd + 0.0 * np.asarray(g, dtype=float), fd


class ProbeNonlinearity(_V15, Law):
    """The gap probe's calibration curve is bent: an eddy-current probe calibrated at the hover gap on a target
    material other than the one it reads (not in the library).

    An eddy-current (inductive) displacement probe's output against distance depends on the target's conductivity
    and permeability; linearized on one material and at one gap, on another target it reads with an error that
    grows quadratically away from the calibration point (Vyroubal, "Eddy-current displacement transducer with
    extended linear range and automatic tuning", IEEE Trans. Instrum. Meas. 58(9), 2009; Fleming, "A review of
    nanometer resolution position sensors: operation and performance", Sens. Actuators A 190, 2013, sec. 2.4):
    ``g_read = g + k2 (g - g_c)^2``, ``g_c`` the calibration gap. The horizontal encoder untouched. Hook
    ``read_at`` (memoryless); size: the largest reading error along g.
    """

    name = "probe_nonlinearity"
    library = False
    families = ("target_mismatch",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"target_mismatch": {"k2": 1.0, "g_c": G_REF}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` (any shape; the time is not used)."""
        g = np.asarray(g, dtype=float)
        return g + self.p["k2"] * (g - self.p["g_c"]) ** 2, d
