"""The sixth law set's mark and its two effects outside the library (issue 27, ``laws="v6"``; see :mod:`.laws_v6`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law
from .physics import shape

SQRT3 = math.sqrt(3.0)
L_ARRAY = k.pm * k.tau  # length of the magnet array [m]


class _V6:
    """Mixin: marks a law of the sixth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v6"``)."""
        return {**super().describe(), "law_set": "v6"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class PhaseCurrentSensor(_V6, Law):
    """A gain and offset error of the amplifier's phase-current sensors (not in the library).

    The current loop regulates the *measured* phase currents: two sensors (phases a and b; ``i_c = -i_a - i_b``)
    read ``i_m = (1 + eps) i + o``, so the loop delivers ``i = (i_m - o) / (1 + eps)`` where the dq command asks
    for ``i_m``. In the dq frame a gain mismatch between the phases leaves a ripple at twice the electrical angle
    and an offset a ripple at the electrical angle, both along the stroke (Chung & Sul, "Analysis and compensation
    of current measurement error in vector-controlled AC motor drives", IEEE Trans. Ind. Appl. 34(2), 1998). The
    electrical angle is ``theta = pi d / tau + theta0`` (``theta0`` the poles' angle at ``d = 0``); Clarke and
    Park transforms amplitude-invariant, ``d`` axis (the rig's ``i_d``, levitation) along ``theta``, ``q`` (the
    rig's ``i_q``, thrust) 90 degrees ahead. Hook ``rotate_at`` (the whole state: ``d``).
    """

    name = "phase_current_sensor"
    library = False
    families = ("gain_offset",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "gain_offset": {"eps_a": 0.02, "eps_b": 0.0, "off_a": 0.03, "off_b": 0.0, "theta0": 0.0}
    }
    has_rotate_at = True

    def carried(self, i_q, i_d, d):
        """Currents ``(i_q, i_d)`` the motor carries when the loop delivers ``(i_q, i_d)`` as measured, at ``d``."""
        p = self.p
        th = math.pi * np.asarray(d, dtype=float) / k.tau + p["theta0"]
        c, s = np.cos(th), np.sin(th)
        i_q, i_d = np.asarray(i_q, dtype=float), np.asarray(i_d, dtype=float)
        al, be = i_d * c - i_q * s, i_d * s + i_q * c  # inverse Park (measured)
        ia = (al - p["off_a"]) / (1.0 + p["eps_a"])  # phase a, b as the sensors' errors leave them
        ib = (0.5 * (-al + SQRT3 * be) - p["off_b"]) / (1.0 + p["eps_b"])
        al2, be2 = ia, (ia + 2.0 * ib) / SQRT3  # Clarke (i_c = -i_a - i_b), then Park
        return -al2 * s + be2 * c, al2 * c + be2 * s

    def rotate_at(self, i_q, i_d, X, t):
        """Currents the motor carries at the state ``X`` (rows: runs)."""
        return self.carried(i_q, i_d, X[..., 2])


class StatorFlatness(_V6, Law):
    """The stator's surface is not flat or not parallel to the guide (not in the library).

    The gap probe measures the mover against the base, but the magnetic gap is measured to the stator's surface,
    which deviates from its nominal plane by ``e(x)`` (positive towards the mover): a tilt against the guide, a bow
    of the base it is bolted to, and a height step between its lamination stacks (the straightness and flatness of
    machine ways and mounting surfaces: Slocum, "Precision Machine Design", Prentice Hall 1992, ch. 2 and 7; the
    track irregularity as a disturbance of an electromagnetic suspension: Sinha, "Electromagnetic Suspension:
    Dynamics and Control", Peter Peregrinus / IEE 1987). The array integrates the field over its length ``L``, so
    it sees the average ``E(d) = (1/L) int_{d - L/2}^{d + L/2} e(x) dx`` (closed form):
    ``e = t x + b ((x / 60 mm)^2 - 1/3) + sum_j h_j [x > x_j]`` (stacks of length ``ls`` from ``x_0``), and every
    magnetic term of seed eq. (2) is evaluated at ``g_m = g - E(d)`` (hook ``factors``: ``km = sqrt(f2(g_m) /
    f2(g))``, ``kc = f3(g_m) / (f3(g) km)``, ``thrust = f1(g_m) / (f1(g) km kc)``; the small ``C4`` term keeps
    ``f4(g) kc^2``). No reading error.
    """

    name = "stator_flatness"
    library = False
    families = ("tilt_bow_steps",)
    N_STEPS = 4  #: stack joints in the stroke's reach
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "tilt_bow_steps": {"tilt": 2e-4, "bow": 2e-5, "ls": 0.08, "x0": -0.16, **{f"h{j}": 0.0 for j in range(4)}}
    }
    has_factors = True

    def mean_error(self, d):
        """``E(d)`` [m]: the stator's deviation averaged over the array."""
        p = self.p
        d = np.asarray(d, dtype=float)
        x2 = (d * d + L_ARRAY**2 / 12.0) / 0.06**2  # mean of (x / 60 mm)^2 over the array
        out = p["tilt"] * d + p["bow"] * (x2 - 1.0 / 3.0)
        for j in range(self.N_STEPS):  # the part of the array past joint j
            xj = p["x0"] + (j + 1) * p["ls"]
            out = out + p[f"h{j}"] * np.clip((d + L_ARRAY / 2 - xj) / L_ARRAY, 0.0, 1.0)
        return out

    def factors(self, g, d, f: list) -> None:
        """Evaluate the field factors at the magnetic gap ``g - E(d)``."""
        g = np.asarray(g, dtype=float)
        s0, s1 = shape(g), shape(g - self.mean_error(d))
        km = np.sqrt(s1.f2 / s0.f2)
        kc = s1.f3 / (s0.f3 * km)
        f[0] = f[0] * km
        f[1] = f[1] * kc
        f[3] = f[3] * s1.f1 / (s0.f1 * km * kc)


__all__ = ["L_ARRAY", "PhaseCurrentSensor", "StatorFlatness"]
