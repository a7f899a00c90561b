"""The sixteenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v16"``; see
:mod:`.laws_v16`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy.signal import ellipap

from .. import constants as k
from .laws_new import EddyDrag
from .laws_v4 import L_ARRAY
from .laws_v13_drive import AmplifierV13, CommutationV13, field_ratio
from .laws_v16_ool import _V16, K_FIELD, current_force, window

_TWO_PI = 2.0 * math.pi

__all__ = ["RC_LADDER3", "AmplifierV16", "CommutationV16", "EddyDragV16", "second_harmonic_ratio"]

#: Three equal RC sections in a ladder, each loading the one before: ``1 / (x^3 + 5 x^2 + 6 x + 1)``, ``x = s R C``.
RC_LADDER3 = np.array([1.0, 5.0, 6.0, 1.0])


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV16(_V16, AmplifierV13):
    """A current loop seen through a third-order elliptic (Cauer) anti-aliasing filter, or through a passive ladder
    of three equal RC sections.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``cauer3`` -- the current sensor's anti-aliasing filter is a third-order elliptic low-pass (equiripple in the
      pass band, ``r_p`` dB, and in the stop band, ``r_s`` dB down; a pair of zeros on the imaginary axis): Cauer,
      "Synthesis of Linear Communication Networks", McGraw-Hill 1958; Zverev, "Handbook of Filter Synthesis", Wiley
      1967, ch. 2; poles and zeros as ``scipy.signal.ellipap`` gives them, scaled by the pass band's edge ``2 pi f_p``.
    * ``rc_ladder3`` -- the sensor's passive filter is three equal RC sections in a ladder, each loaded by the next
      (not isolated lags): the ladder's chain matrix gives ``1 / (x^3 + 5 x^2 + 6 x + 1)``, ``x = s R C``
      (Van Valkenburg, "Analog Filter Design", Holt, Rinehart & Winston 1982, ch. 3; Horowitz & Hill, "The Art of
      Electronics", 3rd ed., Cambridge Univ. Press 2015, ch. 1), three real poles (about ``-0.198``, ``-1.555``,
      ``-3.247`` in ``x``), group delay ``6 R C``.
    """

    families = ("cauer3", "rc_ladder3")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cauer3": {"f_p": 600.0, "r_p": 0.5, "r_s": 40.0, "delay_samples": 0.0},
        "rc_ladder3": {"rc": 1e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "rc_ladder3":
            return np.array([1.0]), RC_LADDER3.copy(), 1.0 / p["rc"]
        z, poles, gain = ellipap(3, p["r_p"], p["r_s"])
        den = np.real(np.poly(poles))
        num = np.real(gain * np.poly(z))
        num = num * den[-1] / num[-1]  # odd order: DC gain exactly 1
        return num, den, _TWO_PI * p["f_p"]


# ------------------------------------------------------------------------- commutation
def second_harmonic_ratio(g, m_a: float):
    """The second field harmonic over the fundamental at the stator's face, gap ``g``, for north magnets ``1 + m_a``
    and south ``1 - m_a`` times the nominal magnetization (magnets ``taup`` wide on the pole pitch ``tau``, ``hm``
    thick)."""
    g = np.asarray(g, dtype=float)
    c21 = m_a * math.cos(math.pi * k.taup / (2.0 * k.tau))  # (sin(pi w / tau) / 2) / sin(pi w / 2 tau)
    thick = 1.0 + math.exp(-K_FIELD * k.hm)  # (1 - e^{-2 K hm}) / (1 - e^{-K hm})
    return c21 * thick * np.exp(-K_FIELD * g)


class CommutationV16(_V16, CommutationV13):
    """Commutation angle errors of Hall heads reading an array whose north and south magnets differ in strength, or
    reading it through a conducting shield that delays the field.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants). Two
    heads on the stator at ``x_h``, a quarter period apart, read the array above them at ``s = x_h - d + L/2`` along
    it, the electrical angle ``th = pi (s - tau/2) / tau`` (0 over the first magnet's middle).

    * ``pole_strength_hall`` -- the north magnets are ``1 + m_a`` and the south ``1 - m_a`` times the nominal
      magnetization (magnets of two grades or batches): the magnetization gains an even harmonic, ``c_2 / c_1 = m_a
      cos(pi taup / 2 tau)``, whose field decays twice as fast with the distance (Furlani, "Permanent Magnet and
      Electromechanical Devices", Academic Press 2001, ch. 4, the 2-D field of a periodic magnetization; magnet
      tolerances: Gasparin, Cernigoj, Markic & Fiser, IEEE Trans. Magn. 45(3), 2009): at the heads ``eps(g) = (c_2 /
      c_1) (1 + e^{-pi hm / tau}) e^{-pi g / tau}``; head A reads ``cos th + eps cos 2 th``, head B ``sin th - eps cos
      2 th``, and the drive's ``atan2`` errs by ``delta = delta0 + atan2(B, A) - th``: at twice the electrical
      frequency, larger at small gaps.
    * ``shield_lag`` -- the heads read the array through the stator's copper cooling plate (or a conducting shield):
      the moving field diffuses through the sheet with the time constant ``tau_s = mu0 sigma t / (2 k)`` (a thin
      sheet's transmission ``1 / (1 + j w tau_s)``; Stoll, "The Analysis of Eddy Currents", Clarendon 1974, ch. 3;
      Mayergoyz & Bedrosian, "On calculation of 3-D eddy currents in conducting and magnetic shells", IEEE Trans.
      Magn. 31(3), 1995), ``w = pi v / tau`` the electrical frequency of the motion: the heads' angle lags by
      ``delta = delta0 - atan(pi v tau_s / tau)``, odd in the speed, saturating. The rotation reads the speed
      ``d_dot`` from the state.
    """

    families = ("pole_strength_hall", "shield_lag")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "pole_strength_hall": {"delta0": 0.0, "m_a": 0.1, "x_h": 0.0},
        "shield_lag": {"delta0": 0.0, "tau_s": 2e-3},
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def electrical_angle(self, d):
        """The heads' electrical angle ``th`` [rad] over the array at position ``d``."""
        s = self.p.get("x_h", 0.0) - np.asarray(d, dtype=float) + 0.5 * L_ARRAY
        return math.pi * (s - 0.5 * k.tau) / k.tau

    def angle_at(self, g, d, v=None):
        """Electrical angle error [rad] at gap ``g``, position ``d`` and speed ``v`` (``shield_lag``; 0 if None)."""
        p = self.p
        g = np.asarray(g, dtype=float)
        d = np.asarray(d, dtype=float)
        if self.family == "shield_lag":
            v = 0.0 * d if v is None else np.asarray(v, dtype=float)
            return p["delta0"] - np.arctan(math.pi * v * p["tau_s"] / k.tau) + 0.0 * (g + d)
        th = self.electrical_angle(d)
        eps = second_harmonic_ratio(g, p["m_a"])
        c2 = eps * np.cos(2.0 * th)
        err = np.arctan2(np.sin(th) - c2, np.cos(th) + c2) - th
        return p["delta0"] + np.angle(np.exp(1j * err))

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X`` (``[g, g_dot, d, d_dot, ...]``)."""
        X = np.asarray(X, dtype=float)
        sim = X.ndim == 2 and X.shape[0] == self.n_runs
        a = self.angle_at(X[..., 0], X[..., 2], X[..., 3])
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if sim:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2


# --------------------------------------------------------------------------- eddy drag
class EddyDragV16(_V16, EddyDrag):
    """Drag of conducting slot wedges closing the stator's slots, or of the copper cooling tubes under its teeth.

    * ``slot_wedges`` -- aluminium wedges close the slot openings at the stator's face; each sees the array's field
      change as the mover moves along d (``|dB/dt| = k B |d_dot|``, ``k = pi / tau``) and as the gap changes
      (``|dB/dg| |g_dot| = k coth(k (hm + g)) B |g_dot|``, MODEL.md's field), and dissipates ``∝ (dB/dt)^2`` (Stoll,
      "The Analysis of Eddy Currents", Clarendon 1974, ch. 1; conducting wedges: Pyrhonen, Jokinen & Hrabovcova,
      "Design of Rotating Electrical Machines", 2nd ed., Wiley 2014, ch. 4): ``F_d = -c_w S(d) b(g)^2 d_dot``,
      ``F_g = -c_w S(d) b(g)^2 coth^2(k (hm + g)) g_dot``, ``b = B(g) / B(15 mm)``, ``S`` the array's share over the
      wedged stator (ends ``e_p``, ``e_n`` past the array's at ``d = 0``): one coefficient for both axes, their ratio
      fixed by the field.
    * ``cooling_tubes`` -- copper cooling tubes run across the stator ``h_t`` under its face, ``p_t`` apart; each
      under the array drags with the square of the field at its depth, ``b(g + h_t)^2`` (Reitz, "Forces on moving
      magnets due to eddy currents", J. Appl. Phys. 41(5), 1970, low-speed limit; Sodano, Bae & Inman, ASME J. Vib.
      Acoust. 128(3), 2006, for a conductor's drag coefficient), the array's footprint blurred over ``g + h_t``:
      ``F_d = -c_t (p_t / L) sum_i w(x_i - d) (b(g + h_t) / b(15 mm + h_t))^2 d_dot``: a drag that ripples with the
      tubes' pitch as they enter and leave the footprint, and falls slowly with the gap. The gap axis none.
    """

    families = ("slot_wedges", "cooling_tubes")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "slot_wedges": {"c_w": 3.0, "e_p": 0.02, "e_n": 0.02, "l_e": 0.005},
        "cooling_tubes": {"c_t": 4.0, "h_t": 0.01, "p_t": 0.05, "x_t": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = True
        self.has_held = False

    def share(self, d):
        """The array's share over the wedged stator (``slot_wedges``), its ends blurred over ``l_e``: the window's
        mean over the array, ``int tanh = l_e log cosh``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        lo, hi, e = -(0.5 * L_ARRAY + p["e_n"]), 0.5 * L_ARRAY + p["e_p"], p["l_e"]

        def lc(z):  # log cosh, without overflow
            z = np.abs(z)
            return z + np.log1p(np.exp(-2.0 * z)) - math.log(2.0)

        a, b = d - 0.5 * L_ARRAY, d + 0.5 * L_ARRAY
        inner = lc((b - lo) / e) - lc((a - lo) / e) - lc((b - hi) / e) + lc((a - hi) / e)
        return 0.5 * e * inner / L_ARRAY

    def tubes(self) -> np.ndarray:
        """The tubes' places [m]: every ``p_t`` from ``x_t`` over the stator (``+-0.17 m``)."""
        p = self.p
        n = int(0.17 / p["p_t"]) + 1
        x = p["x_t"] + p["p_t"] * np.arange(-n, n + 1)
        return x[np.abs(x) <= 0.17]

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "slot_wedges":
            c = p["c_w"] * self.share(d) * field_ratio(g) ** 2
            coth = 1.0 / np.tanh(K_FIELD * (k.hm + g))
            return -c * coth**2 * gd, -c * dd
        depth = g + p["h_t"]
        b2 = (field_ratio(depth) / field_ratio(0.015 + p["h_t"])) ** 2
        x = self.tubes()
        w = window(x - d[..., None], 0.5 * L_ARRAY, np.asarray(depth)[..., None])
        fd = -p["c_t"] * (p["p_t"] / L_ARRAY) * np.sum(w, axis=-1) * b2 * dd
        return 0.0 * fd + 0.0 * gd, fd
