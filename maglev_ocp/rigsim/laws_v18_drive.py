"""The eighteenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v18"``; see
:mod:`.laws_v18`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import constants as k
from .laws_new import EddyDrag
from .laws_v13_drive import AmplifierV13, CommutationV13, field_ratio
from .laws_v18_ool import _V18, current_force

__all__ = ["AmplifierV18", "CommutationV18", "EddyDragV18", "atan2_approx", "atan_linear", "yoke_reflection"]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV18(_V18, AmplifierV13):
    """A current loop whose reference passes a third-order CIC (sinc^3) interpolator, or one fed by two interleaved
    inverter legs whose loops differ in bandwidth.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``cic_reference`` -- the current reference is interpolated to the PWM rate by a cascaded integrator-comb
      filter of order 3 over a window ``T`` (Hogenauer, "An economical class of digital filters for decimation and
      interpolation", IEEE Trans. Acoust. Speech Signal Process. 29(2), 1981): its response ``((1 - e^{-sT}) /
      sT)^3``, each moving-average factor in its ``[0/2]`` Pade form ``1 / (1 + sT/2 + (sT)^2/12)`` (Baker &
      Graves-Morris, "Pade Approximants", 2nd ed., Cambridge Univ. Press 1996, ch. 1), then a first-order loop of
      bandwidth ``f_c``: ``H = 1 / ((1 + sT/2 + (sT)^2/12)^3 (1 + s / w_c))``, group delay ``3T/2 + 1/w_c``.
    * ``interleaved_legs`` -- two inverter legs in parallel share the coil's current half each, their current loops
      (first-order) at ``f_1`` and ``f_2`` (interleaving: Miwa, Otten & Schlecht, "High efficiency power factor
      correction using interleaving techniques", IEEE APEC 1992; current sharing of paralleled converters: Erickson &
      Maksimovic, "Fundamentals of Power Electronics", 2nd ed., Kluwer 2001, ch. 12): ``H = (1 / (1 + s/w_1) + 1 /
      (1 + s/w_2)) / 2``, a zero between the two poles; group delay ``(1/w_1 + 1/w_2) / 2``.
    """

    families = ("cic_reference", "interleaved_legs")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cic_reference": {"T": 1e-4, "f_c": 500.0, "delay_samples": 0.0},
        "interleaved_legs": {"f_1": 300.0, "f_2": 1200.0, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "cic_reference":
            a = 2.0 * math.pi * p["f_c"] * p["T"]  # the loop's bandwidth in units of 1 / T
            sec = np.array([1.0, 6.0, 12.0])  # 12 (1 + x/2 + x^2/12), x = s T
            den = np.polymul(np.polymul(np.polymul(sec, sec), sec), np.array([1.0, a]))
            return np.array([1728.0 * a]), den, 1.0 / p["T"]
        w1 = 2.0 * math.pi * p["f_1"]
        r = p["f_2"] / p["f_1"]
        return np.array([0.5 * (1.0 + r), r]), np.array([1.0, 1.0 + r, r]), w1


# ------------------------------------------------------------------------- commutation
def atan_linear(z, c: float):
    """The drive's arctangent on ``[0, 1]``: ``(pi / 4) z + c z (1 - z)``."""
    z = np.asarray(z, dtype=float)
    return 0.25 * math.pi * z + c * z * (1.0 - z)


def atan2_approx(y, x, c: float):
    """``atan2(y, x)`` as a drive computes it: the ratio reduced to an octant, :func:`atan_linear` there, the
    octant's symmetries back."""
    y, x = np.asarray(y, dtype=float), np.asarray(x, dtype=float)
    ax, ay = np.abs(x), np.abs(y)
    lo = ay <= ax
    z = np.where(lo, ay, ax) / np.maximum(np.where(lo, ax, ay), 1e-300)
    a = np.where(lo, atan_linear(z, c), 0.5 * math.pi - atan_linear(z, c))
    a = np.where(x < 0.0, math.pi - a, a)
    return np.where(y < 0.0, -a, a)


class CommutationV18(_V18, CommutationV13):
    """Commutation angle errors of a current regulator in the stationary frame, or of a drive that computes the angle
    from the encoder's sine and cosine with a low-order arctangent.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``stationary_pi`` -- the phase currents are regulated by PI controllers in the stator's frame, which track the
      sinusoidal references at the electrical frequency ``w_e = pi d_dot / tau`` with a phase lag (Rowan & Kerkman,
      "A new synchronous current regulator and an analysis of current-regulated PWM inverters", IEEE Trans. Ind.
      Appl. IA-22(4), 1986; Brod & Novotny, "Current control of VSI-PWM inverters", IEEE Trans. Ind. Appl. IA-21(3),
      1985): the loop ``w_c / (s + w_c)`` at ``j w_e`` lags by ``atan(w_e / w_c)``: ``delta = delta0 - atan(pi
      d_dot / (tau w_c))``, an error that saturates with the speed.
    * ``atan_approx`` -- the angle comes from sine and cosine signals (a sin/cos encoder or two Hall sensors in
      quadrature) through a fast arctangent: the ratio reduced to one octant, ``atan z ~ (pi / 4) z + c z (1 - z)``
      on ``[0, 1]`` (Rajan, Wang, Inkol & Joyal, "Efficient approximations for the arctangent function", IEEE Signal
      Process. Mag. 23(3), 2006: ``c = 0.273`` within 0.0038 rad, ``c = 0`` within 0.071 rad), the octant's
      symmetries back: ``delta = delta0 + wrap(atan2~(sin th, cos th) - th)``, ``th = pi (d - x_0) / tau``: an
      error at eight times the electrical frequency (period ``tau / 4`` along d), the same at every gap and speed.
    """

    families = ("stationary_pi", "atan_approx")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "stationary_pi": {"delta0": 0.0, "f_c": 80.0},
        "atan_approx": {"delta0": 0.0, "c": 0.1, "x_0": 0.0},
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def angle_at(self, g, d, v=None, t=None):
        """Electrical angle error [rad] at gap ``g``, position ``d`` and speed ``v`` (None: 0)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "stationary_pi":
            v = 0.0 * d if v is None else np.asarray(v, dtype=float)
            return p["delta0"] - np.arctan(math.pi * v / (k.tau * 2.0 * math.pi * p["f_c"])) + 0.0 * (g + d)
        th = math.pi * (d - p["x_0"]) / k.tau
        err = atan2_approx(np.sin(th), np.cos(th), p["c"]) - th
        return p["delta0"] + np.angle(np.exp(1j * err)) + 0.0 * g

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X`` (``[g, g_dot, d, d_dot, ...]``)."""
        X = np.asarray(X, dtype=float)
        sim = X.ndim == 2 and X.shape[0] == self.n_runs
        a = self.angle_at(X[..., 0], X[..., 2], X[..., 3], t)
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if sim:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2


# --------------------------------------------------------------------------- eddy drag
def yoke_reflection(s, mu_r: float):
    """The reflection of a travelling wave ``e^{j k (x - v t)}`` from a magnetizable conducting half-space moving at
    ``v`` under it, ``s = mu sigma v / k``: ``R = (mu_r k - gamma) / (mu_r k + gamma)``, ``gamma = k sqrt(1 + j
    s)`` (its static value ``(mu_r - 1) / (mu_r + 1)``)."""
    gam = np.sqrt(1.0 + 1j * np.asarray(s, dtype=float))
    return (mu_r - gam) / (mu_r + gam)


class EddyDragV18(_V18, EddyDrag):
    """Drag of eddy currents in a solid (unlaminated) steel yoke behind the stator, which also weakens its pull as the
    speed grows, or of an idle second winding whose inverter's freewheeling diodes rectify its back-EMF once it
    exceeds the link's voltage.

    * ``solid_yoke`` -- part of the array's flux closes through a solid steel plate (permeability ``mu_r``,
      conductivity ``sigma``) behind the stator, which pulls the array with ``F_a`` at 15 mm at rest; moving, the
      plate sees the array's wave travel and its eddy currents shield it: the wave's reflection from a magnetizable
      conducting half-space, ``R = (mu_r k - gamma) / (mu_r k + gamma)``, ``gamma^2 = k^2 + j mu sigma k v`` (the
      transfer relations of a moving magnetizable conductor: Melcher, "Continuum Electromechanics", MIT Press 1981,
      ch. 6; Stoll, "The Analysis of Eddy Currents", Clarendon 1974, ch. 2), gives the pull ``F_a b^2 Re R / R_0``
      and the drag ``F_a b^2 Im R / R_0``: ``F_g = F_a b^2 (1 - Re R / R_0)`` (the pull lost, away from the
      stator), ``F_d = F_a b^2 Im R / R_0``, ``s = d_dot / v_s``, ``v_s = k / (mu sigma)``, ``b = B(g) / B(15
      mm)``.
    * ``idle_rectifier`` -- a second (redundant) winding in the stator, its inverter idle: its back-EMF ``k_e b
      |d_dot|`` drives current into the link through the freewheeling diodes only above the link's voltage, i.e.
      above the speed ``v_th`` at 15 mm (uncontrolled generator operation: Jahns, "Uncontrolled generator operation
      of interior PM synchronous machines following high-speed inverter shutdown", IEEE Trans. Ind. Appl. 35(6),
      1999; Mohan, Undeland & Robbins, "Power Electronics", 3rd ed., Wiley 2003, ch. 5 (diode rectifiers)): ``i =
      (k_e b |v| - V_dc)_+ / R``, drag ``k_e b i``: ``F_d = -c_r b sp(b |d_dot| - v_th) sign(d_dot)``, ``sp(x) = w_s
      log(1 + e^{x / w_s})`` the diodes' knee over ``w_s = 5 mm/s``. The gap axis none.
    """

    families = ("solid_yoke", "idle_rectifier")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "solid_yoke": {"F_a": 10.0, "mu_r": 100.0, "v_s": 0.02},
        "idle_rectifier": {"c_r": 5.0, "v_th": 0.1},
    }
    W_S = 5e-3  #: the diodes' knee [m/s]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = True
        self.has_held = False

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        b = field_ratio(g)
        if self.family == "solid_yoke":
            r = yoke_reflection(dd / p["v_s"], p["mu_r"])
            r0 = (p["mu_r"] - 1.0) / (p["mu_r"] + 1.0)
            fa = p["F_a"] * b**2
            return fa * (1.0 - r.real / r0) + 0.0 * (gd + d), fa * r.imag / r0
        else:
            x = (b * np.abs(dd) - p["v_th"]) / self.W_S
            sp = self.W_S * np.where(x > 30.0, x, np.log1p(np.exp(np.minimum(x, 30.0))))
            fd = -p["c_r"] * b * sp * np.sign(dd)
            return 0.0 * fd + 0.0 * (gd + d), fd
