"""The fifteenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v15"``; see
:mod:`.laws_v15`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import constants as k
from .laws_new import EddyDrag
from .laws_v4 import L_ARRAY
from .laws_v13_drive import AmplifierV13, CommutationV13, field_ratio
from .laws_v15_ool import _V15, G_REF

_TWO_PI = 2.0 * math.pi

__all__ = ["AmplifierV15", "CommutationV15", "EddyDragV15", "gaussian3_poles", "tbt3_poles"]

#: The third-order Bessel-Thomson poles (unit delay at DC): the roots of ``s^3 + 6 s^2 + 15 s + 15``, by imaginary
#: part, the real one made exactly real.
_THOMSON3 = np.sort_complex(np.roots([1.0, 6.0, 15.0, 15.0]) * (1 + 0j))[[1, 0, 2]]
_THOMSON3[1] = _THOMSON3[1].real
#: The third-order Butterworth poles (unit corner), by imaginary part.
_BUTTER3 = np.array([np.exp(-2j * np.pi / 3), -1.0 + 0j, np.exp(2j * np.pi / 3)])


def gaussian3_poles() -> np.ndarray:
    """Poles of the third-order Gaussian low-pass (scale 1 rad/s): ``|H(jw)|^-2 = 1 + w^2 + w^4/2! + w^6/3!``, the
    Maclaurin series of ``exp(w^2)`` to third order, factored; the left half-plane roots of ``1 - s^2 + s^4/2 -
    s^6/6``."""
    r = np.roots([-1.0 / 6.0, 0.0, 0.5, 0.0, -1.0, 0.0, 1.0])
    return np.sort_complex(r[r.real < 0])


def tbt3_poles(m: float) -> np.ndarray:
    """Poles of the third-order transitional Butterworth-Thomson low-pass: magnitudes ``r_B^m r_T^(1-m)``, angles
    ``m th_B + (1 - m) th_T`` between the Butterworth (``m = 1``) and the Bessel-Thomson (``m = 0``) poles, the real
    pole with the real one, each complex pole with its own half-plane's."""
    b, t = _BUTTER3, _THOMSON3
    r = np.abs(b) ** m * np.abs(t) ** (1.0 - m)
    th = m * np.angle(b) + (1.0 - m) * np.angle(t)
    return r * np.exp(1j * th)


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV15(_V15, AmplifierV13):
    """A current loop seen through a third-order Gaussian filter, or through a transitional Butterworth-Thomson one.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input; all-pole, ``prod(-p_k) / prod(s - p_k)``, poles scaled by ``w0 =
    2 pi f``.

    * ``gaussian3`` -- the current sensor's conditioning shaped as a Gaussian filter (a step response close to the
      error function, 0.06 % overshoot): ``|H(jw)|^-2`` the third-order Maclaurin series of ``exp(w^2)`` (Dishal,
      "Gaussian-response filter design", Electr. Commun. 36(1), 1959; Williams & Taylor, "Electronic Filter Design
      Handbook", 4th ed., McGraw-Hill 2006, ch. 2 (Gaussian)).
    * ``tbt3`` -- a transitional Butterworth-Thomson response of parameter ``m`` (0 Bessel-Thomson, 1 Butterworth):
      each pole's magnitude and angle interpolated geometrically (Peless & Murakami, "Analysis and synthesis of
      transitional Butterworth-Thomson filters and bandpass amplifiers", RCA Rev. 18(1), 1957; Zverev, "Handbook
      of Filter Synthesis", Wiley 1967, ch. 2).
    """

    families = ("gaussian3", "tbt3")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "gaussian3": {"f_g": 600.0, "delay_samples": 0.0},
        "tbt3": {"f_c": 700.0, "m": 0.5, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "gaussian3":
            poles, w0 = gaussian3_poles(), _TWO_PI * p["f_g"]
        else:
            poles, w0 = tbt3_poles(p["m"]), _TWO_PI * p["f_c"]
        den = np.real(np.poly(poles))
        return np.array([den[-1]]), den, w0


# ------------------------------------------------------------------------- commutation
class CommutationV15(_V15, CommutationV13):
    """Commutation angle errors of Hall heads fixed on the stator that read the moving array near its end, or that
    read magnets magnetized off their axis.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants). The
    heads sit on the stator at ``x_h`` and read the array above them, at ``s = x_h - d + L/2`` along it (0 at its
    negative end).

    * ``stator_hall_end`` -- near an end of the array the field is no longer the infinite array's sinusoid: the
      truncation adds an end wave decaying as ``exp(-pi u / tau)`` with the distance ``u`` from the end (the
      fundamental's decay away from a discontinuity of the magnetization: Furlani, "Permanent Magnet and
      Electromechanical Devices", Academic Press 2001, ch. 4; heads reading a finite array: Ramsden, "Hall-Effect
      Sensors: Theory and Application", 2nd ed., Newnes 2006, ch. 6): ``delta = delta0 + a_e (exp(-pi s / tau) -
      exp(-pi (L - s) / tau))``.
    * ``magnetization_tilt`` -- each of the ``pm = 4`` magnets is magnetized ``eps_j`` off its axis (the tolerance of
      the magnetization direction of sintered magnets, +-1-3 degrees); the tilt's tangential component adds the
      field a quarter period on, shifting the phase the heads read over magnet ``j`` by ``eps_j``, blended over the
      gap ``g`` across each joint (Furlani 2001, ch. 4; magnet tolerances: Gasparin, Cernigoj, Markic & Fiser,
      "Additional cogging torque components in permanent-magnet motors due to manufacturing imperfections", IEEE
      Trans. Magn. 45(3), 2009): ``delta = delta0 + sum_j eps_j (S((s - j tau) / g) - S((s - (j+1) tau) / g))``,
      ``S(z) = (1 + tanh z) / 2``.
    """

    families = ("stator_hall_end", "magnetization_tilt")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "stator_hall_end": {"delta0": 0.0, "a_e": 0.3, "x_h": -0.04},
        "magnetization_tilt": {"delta0": 0.0, "eps0": 0.03, "eps1": -0.03, "eps2": 0.02, "eps3": -0.02, "x_h": 0.0},
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def along(self, d):
        """The heads' place ``s`` along the array [m] at position ``d``."""
        return self.p["x_h"] - np.asarray(d, dtype=float) + 0.5 * L_ARRAY

    def angle_at(self, g, d, on_b=None):
        """Electrical angle error [rad] at gap ``g`` and position ``d``."""
        p = self.p
        g = np.asarray(g, dtype=float)
        s = self.along(d)
        if self.family == "stator_hall_end":
            end = np.exp(-math.pi * s / k.tau) - np.exp(-math.pi * (L_ARRAY - s) / k.tau)
            return p["delta0"] + p["a_e"] * end + 0.0 * g
        out = p["delta0"] + 0.0 * (g + s)
        for j in range(4):
            lo, hi = np.tanh((s - j * k.tau) / g), np.tanh((s - (j + 1) * k.tau) / g)
            out = out + p[f"eps{j}"] * 0.5 * (lo - hi)
        return out


# --------------------------------------------------------------------------- eddy drag
def flux_slope_ratio(g):
    """``(dB/dg)(g) / (dB/dg)(15 mm)`` of MODEL.md's field ``B ∝ 1 / sinh(pi (hm + g) / tau)``."""
    a = math.pi * (k.hm + np.asarray(g, dtype=float)) / k.tau
    a0 = math.pi * (k.hm + G_REF) / k.tau
    return (np.cosh(a) / np.sinh(a) ** 2) / (math.cosh(a0) / math.sinh(a0) ** 2)


class EddyDragV15(_V15, EddyDrag):
    """Drag of a conducting plate under the array and a conducting cover above it, or the squeeze damping of the
    mover's solid back iron.

    * ``cover_plate`` -- besides the conducting sheet on the stator (at the gap ``g``), the stage's aluminium dust
      cover lies ``h_c`` above the stator's face; the array's back field (its back iron's leakage) reaches it across
      ``h_c - g``; each conductor drags with the square of the field it sees at low speed (Reitz, "Forces on moving
      magnets due to eddy currents", J. Appl. Phys. 41(5), 1970; Saslow, "Maxwell's theory of eddy currents in thin
      conducting sheets, and applications to electromagnetic shielding and MAGLEV", Am. J. Phys. 60(8), 1992):
      ``F_d = -(c_s b(g)^2 + c_c b(h_c - g)^2) d_dot``, ``b = B(.) / B(15 mm)``: the drag falls as the gap opens on
      the stator's side and rises on the cover's. The gap axis none.
    * ``back_iron_squeeze`` -- the mover's back iron is solid steel: when the gap changes, the magnets' flux through it
      changes and eddy currents oppose the change (Lenz's law), a damping of the gap's motion with the square of the
      flux's slope; moving along d changes nothing in it (Stoll, "The Analysis of Eddy Currents", Clarendon 1974,
      ch. 1; solid cores in suspension magnets: Sinha, "Electromagnetic Suspension: Dynamics and Control", Peter
      Peregrinus / IEE 1987, ch. 3): ``F_g = -c_g r(g)^2 g_dot``, ``r = (dB/dg)(g) / (dB/dg)(15 mm)``; along d none.
    """

    families = ("cover_plate", "back_iron_squeeze")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cover_plate": {"c_s": 2.0, "c_c": 6.0, "h_c": 0.05},
        "back_iron_squeeze": {"c_g": 20.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = True
        self.has_held = False

    def coefficient(self, g):
        """The drag coefficient [N s/m] at gap ``g`` (along d for ``cover_plate``, along g otherwise)."""
        p = self.p
        g = np.asarray(g, dtype=float)
        if self.family == "cover_plate":
            return p["c_s"] * field_ratio(g) ** 2 + p["c_c"] * field_ratio(p["h_c"] - g) ** 2
        return p["c_g"] * flux_slope_ratio(g) ** 2

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        c = self.coefficient(g)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "cover_plate":
            fd = -c * dd
            return 0.0 * fd + 0.0 * gd, fd
        fg = -c * gd
        return fg, 0.0 * fg + 0.0 * dd
