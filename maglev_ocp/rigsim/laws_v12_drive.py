"""The twelfth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v12"``; see
:mod:`.laws_v12`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .. import constants as k
from .laws import CommutationOffset
from .laws_new import EddyDrag
from .laws_v3 import AmplifierV3
from .laws_v4 import K_POLE, L_ARRAY
from .laws_v9 import companion
from .laws_v12_ool import _V12, G_REF, _Peaks, current_force, smoothstep
from .physics import shape

_TWO_PI = 2.0 * math.pi

__all__ = ["AmplifierV12", "CommutationV12", "EddyDragV12"]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV12(_V12, AmplifierV3):
    """A PI current loop with set-point weighting, or a loop tuned by Manabe's coefficient diagram method.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``setpoint_weight`` -- a PI loop on the winding ``R, L`` (``Kp = wc L``, ``Ki = wc R``, pole-zero cancellation)
      whose proportional part acts on ``b r - y`` instead of the error (set-point weighting, a two-degree-of-freedom
      PI: Astrom & Hagglund, "PID Controllers: Theory, Design, and Tuning", 2nd ed., ISA 1995, sec. 3.4; Harnefors &
      Nee, IEEE Trans. Ind. Appl. 34(1), 1998, for the loop): ``i / u = wc (b s + a) / ((s + wc)(s + a))``, ``a = R /
      L``: a fast part ``b`` and a slow creep over ``1 / a`` for the rest; group delay ``1 / wc + (1 - b) / a``.
    * ``cdm3`` -- a third-order loop whose characteristic polynomial has Manabe's standard stability indices
      ``gamma_1 = 2.5``, ``gamma_2 = 2`` (Manabe, "The coefficient diagram method", 14th IFAC Symposium on Automatic
      Control in Aerospace, 1998; Manabe, "Importance of coefficient diagram in polynomial method", IEEE CDC 2003):
      ``1 / (tau^3 s^3 / 12.5 + tau^2 s^2 / 2.5 + tau s + 1)``, ``tau`` the equivalent time constant; group delay
      ``tau``.
    """

    families = ("setpoint_weight", "cdm3")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "setpoint_weight": {"bandwidth_hz": 500.0, "a_r": 250.0, "b": 0.92, "delay_samples": 0.0},
        "cdm3": {"tau_e": 6e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "cdm3":
            return np.array([12.5]), np.array([1.0, 5.0, 12.5, 12.5]), 1.0 / p["tau_e"]
        wc = _TWO_PI * p["bandwidth_hz"]
        r = p["a_r"] / wc
        return np.array([p["b"], r]), np.array([1.0, 1.0 + r, r]), wc

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` (inputs ``[u, v]``, the second unused): the companion form in ``s / w0``."""
        num, den, w0 = self.polynomials()
        A, B, C = companion(num, den)
        return A * w0, B * w0, C

    def dc_gain(self) -> float:
        """Static gain of the command-to-current response."""
        num, den, _ = self.polynomials()
        return float(num[-1] / den[-1])

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s], transport delay included: ``den'(0)/den(0) - num'(0)/num(0)``."""
        num, den, w0 = self.polynomials()
        lag = den[-2] / den[-1] - (num[-2] / num[-1] if num.size > 1 else 0.0)
        return self.p["delay_samples"] * Ts + float(lag) / w0


# ------------------------------------------------------------------------- commutation
class CommutationV12(_V12, _Peaks, CommutationOffset):
    """Commutation angle errors of a drive set up with a wrong pole pitch, or of a flux estimator whose integrator
    is a low-pass filter.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``pole_pitch_mismatch`` -- the drive turns the incremental encoder's counts into the electrical angle with a
      pole pitch ``tau / (1 + eps)`` (a parameter set off, or a magnet track of another pitch), the angle found at
      ``d_h`` (commutation from an incremental encoder after phase finding: Krishnan, "Permanent Magnet Synchronous
      and Brushless DC Motor Drives", CRC 2010, ch. 9; Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd
      ed., CRC 2011): ``delta = delta0 + (pi / tau) eps (d - d_h)``, growing along the stroke without a period.
    * ``lpf_flux_integrator`` -- above a speed the angle comes from the stator flux estimated by integrating the
      back-EMF, the pure integrator replaced by a low-pass filter of corner ``w_c`` against drift (Hu & Wu, "New
      integration algorithms for estimating motor flux over a wide speed range", IEEE Trans. Power Electron. 13(5),
      1998): the estimate leads the true flux by ``atan(w_c / w_e)``, ``w_e = pi v / tau`` the electrical speed, in
      the direction of motion; faded in from the Halls' angle (no error) between ``v_lo`` and ``v_hi`` (a
      smoothstep): ``delta = delta0 + S(|v|) atan(w_c / |w_e|) sgn v``, largest just above ``v_lo``, independent of
      the currents.
    """

    families = ("pole_pitch_mismatch", "lpf_flux_integrator")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "pole_pitch_mismatch": {"delta0": 0.0, "eps": 0.01, "d_h": 0.0},
        "lpf_flux_integrator": {"delta0": 0.0, "w_c": 1.0, "v_lo": 0.1, "v_hi": 0.25},
    }
    has_rotate = False
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset_peaks(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.reset_peaks(n_runs)

    def angle_at(self, g, d, v=0.0):
        """Electrical angle error [rad] at gap ``g``, position ``d`` and speed ``v``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        if self.family == "pole_pitch_mismatch":
            return p["delta0"] + K_POLE * p["eps"] * (d - p["d_h"]) + 0.0 * np.asarray(v, dtype=float)
        v = np.asarray(v, dtype=float)
        we = K_POLE * np.abs(v)
        lead = np.arctan2(p["w_c"], we) * np.sign(v)
        return p["delta0"] + smoothstep((np.abs(v) - p["v_lo"]) / (p["v_hi"] - p["v_lo"])) * lead + 0.0 * d

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X``."""
        X = np.asarray(X, dtype=float)
        a = self.angle_at(X[..., 0], X[..., 2], X[..., 3])
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


# --------------------------------------------------------------------------- eddy drag
def _field_ratio(g):
    """``B(g) / B(15 mm)`` (MODEL.md's field) and its derivative in ``g`` [1/m]."""
    g = np.asarray(g, dtype=float)
    b = shape(g).B / float(shape(G_REF).B)
    return b, -K_POLE * b / np.tanh(K_POLE * (k.hm + g))


class EddyDragV12(_V12, EddyDrag):
    """Drag of a shorted turn in the stator winding, or of a conducting sheet mounted off parallel to the stroke.

    * ``interturn_short`` -- an inter-turn short in one coil (full pitch ``tau``, centred at ``x_s``) closes a loop
      that links the array's field: its flux ``Phi = Phi_m b(g) cos(pi (d - x_s) / tau) W(d - x_s)`` (``b = B(g) /
      B(15 mm)``, ``W`` the coil's coverage by the array: 1 while the coil is under it, falling to 0 over a pole
      pitch by a smoothstep as it leaves), the motional EMF ``-grad Phi . v`` drives a resistance-limited current
      and the loop's force is ``-grad Phi`` times it (Romeral, Urresty, Riba Ruiz & Garcia Espinosa, "Modeling of
      surface-mounted permanent magnet synchronous motors with stator winding interturn faults", IEEE Trans. Ind.
      Electron. 58(5), 2011; the force on a circuit from its flux linkage: Woodson & Melcher, "Electromechanical
      Dynamics", Part I, Wiley 1968, ch. 3): ``F = -c0 (tau / pi)^2 (grad b_phi . v) grad b_phi``, ``b_phi = Phi /
      Phi_m``, ``c0`` the largest drag along d at 15 mm: on both axes, a ripple of period ``tau`` along d, only while
      the array covers the coil, dissipative.
    * ``tilted_sheet`` -- a conducting sheet beside the array, mounted with a slope ``s_t`` to the stroke: its
      distance to the magnets grows along d, their field at it falling as ``exp(-pi h / tau)`` (the fundamental's
      decay in Laplace's equation), the eddy drag viscous at the rig's speeds (Reitz, "Forces on moving magnets due to
      eddy currents", J. Appl. Phys. 41(5), 1970, the low-speed limit; Sodano, Bae & Inman, "Improved concept and
      model of eddy current damper", ASME J. Vib. Acoust. 128(3), 2006): ``F_d = -c0 (B(g) / B(15 mm))^2 exp(-2 pi
      s_t d / tau) d_dot``: a drag that grows or falls monotonically along the stroke.
    """

    families = ("interturn_short", "tilted_sheet")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "interturn_short": {"c0": 3.0, "x_s": 0.0},
        "tilted_sheet": {"c0": 3.0, "s_t": 0.1},
    }
    has_force = True

    def coverage(self, u):
        """``(W(u), W'(u))``: the coil's coverage by the array at ``u = d - x_s`` (``interturn_short``)."""
        u = np.asarray(u, dtype=float)
        inner = 0.5 * L_ARRAY - 0.5 * k.tau
        x = (inner + k.tau - np.abs(u)) / k.tau
        xc = np.clip(x, 0.0, 1.0)
        w = xc * xc * (3.0 - 2.0 * xc)
        dw = np.where((x > 0.0) & (x < 1.0), 6.0 * xc * (1.0 - xc), 0.0) * -np.sign(u) / k.tau
        return w, dw

    def linkage(self, g, d):
        """``(b_phi, d b_phi / dg, d b_phi / dd)`` (``interturn_short``)."""
        u = np.asarray(d, dtype=float) - self.p["x_s"]
        b, db = _field_ratio(g)
        w, dw = self.coverage(u)
        c, s = np.cos(K_POLE * u), np.sin(K_POLE * u)
        return b * c * w, db * c * w, b * (c * dw - K_POLE * s * w)

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "tilted_sheet":
            b, _ = _field_ratio(g)
            fd = -p["c0"] * b * b * np.exp(-_TWO_PI * p["s_t"] * np.asarray(d, dtype=float) / k.tau) * dd
            return 0.0 * fd, fd
        _, pg, pd = self.linkage(g, d)
        emf = pg * gd + pd * dd
        c = p["c0"] / (K_POLE * K_POLE)
        return -c * emf * pg, -c * emf * pd
