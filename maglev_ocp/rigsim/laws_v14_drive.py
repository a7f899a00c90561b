"""The fourteenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v14"``; see
:mod:`.laws_v14`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import constants as k
from .laws_new import EddyDrag
from .laws_v4 import K_POLE
from .laws_v13_drive import AmplifierV13, CommutationV13, field_ratio
from .laws_v14_ool import _V14, G_REF

_TWO_PI = 2.0 * math.pi

__all__ = ["AmplifierV14", "CommutationV14", "EddyDragV14", "inverse_chebyshev_poles"]


def inverse_chebyshev_poles(a_s: float, n: int = 3) -> np.ndarray:
    """Poles of the inverse Chebyshev (type II) low-pass of order ``n``, stopband edge 1 rad/s, stopband attenuation
    ``a_s`` dB: the reciprocals of the Chebyshev type I poles of ripple ``eps = 1/sqrt(10^(a_s/10) - 1)``."""
    eps = 1.0 / math.sqrt(10.0 ** (a_s / 10.0) - 1.0)
    mu = math.asinh(1.0 / eps) / n
    th = (2 * np.arange(1, n + 1) - 1) * math.pi / (2 * n)
    p1 = -math.sinh(mu) * np.sin(th) + 1j * math.cosh(mu) * np.cos(th)
    return 1.0 / p1


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV14(_V14, AmplifierV13):
    """A current loop seen through an inverse Chebyshev anti-aliasing filter, or through three equal first-order lags.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``inverse_chebyshev3`` -- the current's response shaped by a third-order inverse Chebyshev (type II) low-pass:
      flat in the pass band, a pair of transmission zeros at ``s = +-j w_s / cos(pi / 6)`` past the stopband edge
      ``w_s = 2 pi f_s``, stopband ``a_s`` dB down (Daniels, "Approximation Methods for Electronic Filter Design",
      McGraw-Hill 1974, ch. 5; Williams & Taylor, "Electronic Filter Design Handbook", 4th ed., McGraw-Hill 2006,
      ch. 2): ``K (s^2 + w_z^2) / prod(s - p_k)``, poles the reciprocals of the Chebyshev I poles of ripple ``eps =
      1/sqrt(10^(a_s/10) - 1)``, scaled by ``w_s``; group delay ``-sum(1/p_k)``.
    * ``triple_lag`` -- three equal first-order lags (the current loop's bandwidth, the current sensor's RC filter and
      the PWM's averaging tuned to the same corner; a critically damped cascade: Zumbahlen (ed.), "Linear Circuit
      Design Handbook", Newnes 2008, ch. 8): ``1 / (1 + s / w)^3``, ``w = 2 pi f_c``; group delay ``3 / w``, no
      overshoot.
    """

    families = ("inverse_chebyshev3", "triple_lag")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "inverse_chebyshev3": {"f_s": 1500.0, "a_s": 30.0, "delay_samples": 0.0},
        "triple_lag": {"f_c": 1000.0, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "triple_lag":
            return np.array([1.0]), np.array([1.0, 3.0, 3.0, 1.0]), _TWO_PI * p["f_c"]
        den = np.real(np.poly(inverse_chebyshev_poles(p["a_s"])))
        wz2 = 1.0 / math.cos(math.pi / 6.0) ** 2
        return np.array([1.0, 0.0, wz2]) * (den[-1] / wz2), den, _TWO_PI * p["f_s"]


# ------------------------------------------------------------------------- commutation
class CommutationV14(_V14, CommutationV13):
    """Commutation angle errors of a Hall sensor that sees the stator's slotting, or the array's third harmonic.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``slot_ripple_hall`` -- the Hall head sits near the stator's slotted surface; the slot openings modulate the
      field it reads at the slot pitch ``t1``, decaying away from the slots with the slot harmonic (Zhu & Howe,
      "Instantaneous magnetic field distribution in brushless permanent magnet dc motors, Part III: Effect of stator
      slotting", IEEE Trans. Magn. 29(1), 1993; Ramsden, "Hall-Effect Sensors: Theory and Application", 2nd ed.,
      Newnes 2006, ch. 6): ``delta = delta0 + a_s exp(-2 pi (g - 10 mm) / t1) sin(2 pi (d - x_s) / t1)``.
    * ``hall_third_harmonic`` -- two Hall heads a quarter of the pole pair apart read the array's field with its
      third space harmonic, ``h3`` of the fundamental at 15 mm and falling with the gap as ``exp(-2 pi (g - 15 mm) /
      tau)`` (the n-th harmonic decays as ``exp(-n pi y / tau)``: Furlani, "Permanent Magnet and Electromechanical
      Devices", Academic Press 2001, ch. 4); ``atan2(sin th + h sin 3th, cos th - h cos 3th)`` is ``th + h sin 4th``
      to first order (Ramsden 2006, ch. 6): ``delta = delta0 + h3 exp(-2 pi (g - 15 mm) / tau) sin(4 (pi (d - x_h) /
      tau))``.
    """

    families = ("slot_ripple_hall", "hall_third_harmonic")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "slot_ripple_hall": {"delta0": 0.0, "a_s": 0.05, "x_s": 0.0},
        "hall_third_harmonic": {"delta0": 0.0, "h3": 0.05, "x_h": 0.0},
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def angle_at(self, g, d, on_b=None):
        """Electrical angle error [rad] at gap ``g`` and position ``d``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "slot_ripple_hall":
            amp = p["a_s"] * np.exp(-_TWO_PI * (g - k.g_cog_ref) / k.t1)
            return p["delta0"] + amp * np.sin(_TWO_PI * (d - p["x_s"]) / k.t1)
        amp = p["h3"] * np.exp(-_TWO_PI * (g - G_REF) / k.tau)
        return p["delta0"] + amp * np.sin(4.0 * K_POLE * (d - p["x_h"]))


# --------------------------------------------------------------------------- eddy drag
class EddyDragV14(_V14, EddyDrag):
    """Drag of a conducting plate built of strips, or of a closed ring round the stator that the array's ends cross.

    * ``segmented_plate`` -- the conducting plate under the stator is made of strips of pitch ``p_s`` (separate
      cooling plates or a slit plate); where the array's poles straddle a slit the eddy loops are cut and the drag
      falls by up to ``r`` (a finite-width conductor's edge factor: Russell & Norsworthy, "Eddy currents and wall
      losses in screened-rotor induction motors", Proc. IEE 105A(20), 1958; the low-speed drag ``∝ B^2 v``: Reitz,
      "Forces on moving magnets due to eddy currents", J. Appl. Phys. 41(5), 1970): ``F_d = -c0 b(g)^2 (1 - r (1 +
      cos(2 pi (d - x_s) / p_s)) / 2) d_dot``, ``b = B(g) / B(15 mm)``; the gap axis none.
    * ``end_ring`` -- a closed conducting ring (the stator's clamping frame) at ``x_r`` past each end of the array at
      ``d = 0``; the array's flux through it changes only while one of the array's ends passes over it (Faraday's law
      on one turn, the drag of its current ``-(dPhi/dx)^2 v / R``: Woodson & Melcher, "Electromechanical Dynamics",
      Part I, Wiley 1968, ch. 6): ``F_d = -c0 b(g)^2 (exp(-((d - x_r)/w_r)^2) + exp(-((d + x_r)/w_r)^2)) d_dot``,
      the end's fringe over ``w_r``; the gap axis none.
    """

    families = ("segmented_plate", "end_ring")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "segmented_plate": {"c0": 3.0, "r": 0.5, "p_s": 0.03, "x_s": 0.0},
        "end_ring": {"c0": 6.0, "x_r": 0.02, "w_r": 0.008},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = True
        self.has_held = False

    def coefficient(self, g, d):
        """The drag coefficient [N s/m] at gap ``g`` and position ``d``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        b2 = field_ratio(g) ** 2
        if self.family == "segmented_plate":
            return p["c0"] * b2 * (1.0 - 0.5 * p["r"] * (1.0 + np.cos(_TWO_PI * (d - p["x_s"]) / p["p_s"])))
        u = np.exp(-(((d - p["x_r"]) / p["w_r"]) ** 2)) + np.exp(-(((d + p["x_r"]) / p["w_r"]) ** 2))
        return p["c0"] * b2 * u

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        fd = -self.coefficient(g, d) * np.asarray(dd, dtype=float)
        return 0.0 * fd + 0.0 * np.asarray(gd, dtype=float), fd
