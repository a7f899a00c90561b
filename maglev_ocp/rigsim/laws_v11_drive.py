"""The eleventh law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v11"``; see
:mod:`.laws_v11`, which registers them).

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
from .laws_v4 import K_POLE
from .laws_v9 import companion
from .laws_v11_ool import _V11, G_REF, _Peaks, current_force, smoothstep

_TWO_PI = 2.0 * math.pi
I_REF = 3.0  #: reference current of the MMF harmonics' drag [A]

__all__ = ["I_REF", "AmplifierV11", "CommutationV11", "EddyDragV11"]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV11(_V11, AmplifierV3):
    """A current response in the ITAE standard form, or a PI loop on a winding with a core-loss branch.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``itae3`` -- the current loop tuned to the third-order standard form that minimizes the integral of time
      times absolute error of the step response (Graham & Lathrop, "The synthesis of 'optimum' transient response:
      criteria and standard forms", Trans. AIEE 72(5), Part II, 1953): ``w^3 / (s^3 + 1.75 w s^2 + 2.15 w^2 s +
      w^3)``; group delay ``2.15 / w``.
    * ``iron_loss_branch`` -- a PI loop tuned by pole-zero cancellation on the winding's resistance and total
      inductance (``C = wc (L s + R) / s``; Harnefors & Nee, "Model-based current control of AC machines using the
      internal model control method", IEEE Trans. Ind. Appl. 34(1), 1998) on a winding whose inductance is a leakage
      part ``(1 - m) L`` in series with a magnetizing part ``m L`` shunted by the core-loss resistance ``R_fe``
      (Slemon, "Electric Machines and Drives", Addison-Wesley 1992 (equivalent circuit with core loss); in the d-q
      model: Morimoto, Tong, Takeda & Hirasa, "Loss minimization control of permanent magnet synchronous motor
      drives", IEEE Trans. Ind. Electron. 41(5), 1994). The loop regulates the terminal current; the force follows
      the magnetizing branch's current ``i / (1 + s tau_fe)``, ``tau_fe = m L / R_fe``: ``i_m / u = wc (s + a) /
      ((1 - m) tau_fe s^3 + (1 + a tau_fe + wc tau_fe) s^2 + (a + wc (1 + a tau_fe)) s + wc a)``, ``a = R / L``;
      group delay ``1 / wc + tau_fe``.
    """

    families = ("itae3", "iron_loss_branch")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "itae3": {"f_n": 500.0, "delay_samples": 0.0},
        "iron_loss_branch": {"bandwidth_hz": 500.0, "a_r": 200.0, "m": 0.6, "tau_fe": 2e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "itae3":
            return np.array([1.0]), np.array([1.0, 1.75, 2.15, 1.0]), _TWO_PI * p["f_n"]
        wc, a, m, tau = _TWO_PI * p["bandwidth_hz"], p["a_r"], p["m"], p["tau_fe"]
        den = np.array([(1 - m) * tau * wc**3, (1 + a * tau + wc * tau) * wc**2, (a + wc * (1 + a * tau)) * wc, wc * a])
        num = np.array([wc * wc, wc * a])
        return num / den[0], den / den[0], wc

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
class CommutationV11(_V11, _Peaks, CommutationOffset):
    """Commutation angle errors of a back-EMF observer with a resistance error, or of Hall sensors that clip.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``emf_observer`` -- above a speed the angle comes from the back-EMF vector a voltage model estimates, ``e^ = u
      - R^ i - L di/dt`` (sensorless operation: Matsui, "Sensorless PM brushless DC motor drives", IEEE Trans. Ind.
      Electron. 43(2), 1996); with the winding's resistance off by ``dR`` the estimate is ``e - dR i`` (the accuracy
      of voltage-model observers: Jansen & Lorenz, "A physically insightful approach to the design and accuracy
      assessment of flux observers for field oriented induction machine drives", IEEE Trans. Ind. Appl. 30(1),
      1994). With the true EMF ``e = -j ke v`` (in ``i_d + j i_q``; ``i_q`` pushes towards ``-d``): ``delta =
      arg(e^ conj(e)) = atan2(-dR i_d sgn v, ke |v| + dR i_q sgn v)``, faded in from the Hall sensors' angle (no
      error) between ``v_lo`` and ``v_hi`` by a smoothstep: an error that grows with the levitation current and
      falls with the speed (to first order the rotated thrust current takes the power ``1.5 dR i_d^2`` from the
      motion).
    * ``clipped_halls`` -- linear Hall sensors (sin and cos channels, ``c_s`` behind the stator's surface) whose
      outputs saturate as the field exceeds their linear range, ``tanh(beta x)`` (Ramsden, "Hall-Effect Sensors:
      Theory and Application", 2nd ed., Elsevier 2006, ch. 4; Popovic, "Hall Effect Devices", 2nd ed., IOP 2004),
      ``beta = beta0 B(g + c_s) / B(15 mm + c_s)`` (MODEL.md's field): ``delta = delta0 + atan2(tanh(beta sin th),
      tanh(beta cos th)) - th``, ``th = pi d / tau + theta0``: an error of period ``tau / 2`` along d that grows as the
      gap closes.
    """

    families = ("emf_observer", "clipped_halls")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "emf_observer": {"delta0": 0.0, "dR": 0.1, "ke": 9.4, "v_lo": 0.1, "v_hi": 0.25},
        "clipped_halls": {"delta0": 0.0, "beta0": 1.0, "c_s": 4e-3, "theta0": 0.0},
    }
    has_rotate = False
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset_peaks(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.reset_peaks(n_runs)

    def beta(self, g):
        """``beta(g)``: the field at the sensors over their linear range (``clipped_halls``)."""
        from .physics import shape

        p = self.p
        return p["beta0"] * shape(np.asarray(g, dtype=float) + p["c_s"]).B / float(shape(G_REF + p["c_s"]).B)

    def angle_at(self, g, d, v=0.0, i_q=0.0, i_d=0.0):
        """Electrical angle error [rad] at gap ``g``, position ``d``, speed ``v`` and delivered ``(i_q, i_d)``."""
        p = self.p
        if self.family == "clipped_halls":
            th = K_POLE * np.asarray(d, dtype=float) + p["theta0"]
            b = self.beta(g)
            e = np.arctan2(np.tanh(b * np.sin(th)), np.tanh(b * np.cos(th))) - th
            return p["delta0"] + np.mod(e + math.pi, _TWO_PI) - math.pi
        v = np.asarray(v, dtype=float)
        sg = np.sign(v)
        e = np.arctan2(-p["dR"] * np.asarray(i_d, dtype=float) * sg, p["ke"] * np.abs(v) + p["dR"] * i_q * sg)
        return p["delta0"] + smoothstep((np.abs(v) - p["v_lo"]) / (p["v_hi"] - p["v_lo"])) * e

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X``."""
        X = np.asarray(X, dtype=float)
        a = self.angle_at(X[..., 0], X[..., 2], X[..., 3], i_q, i_d)
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


# --------------------------------------------------------------------------- eddy drag
class EddyDragV11(_V11, EddyDrag):
    """Drag of the winding's MMF space harmonics on the mover's conductors, or of a side wall in the magnets' leakage.

    * ``mmf_harmonics`` -- the winding's field has space harmonics besides the fundamental (orders 5 and 7 of a
      three-phase winding) that move against the mover, which runs with the fundamental: they induce eddy currents
      in the magnets and the mover's conducting parts at six times the electrical frequency (Atallah, Howe, Mellor &
      Stone, "Rotor loss in permanent-magnet brushless AC machines", IEEE Trans. Ind. Appl. 36(6), 2000; Toda, Xia,
      Wang, Atallah & Howe, "Rotor eddy-current loss in permanent magnet brushless machines", IEEE Trans. Magn.
      40(4), 2004). Resistance-limited, the loss is ``~ (6 w_e)^2 |i|^2 B_nu(g)^2`` and the drag ``F_d = -c0 (|i| /
      I_ref)^2 h(g) d_dot``, ``h = sum_nu (1/nu^2) (sinh(nu pi (h_c + G_REF)/tau) / sinh(nu pi (h_c + g)/tau))^2``
      normalized to 1 at 15 mm (``I_ref = 3 A``; the carried currents, hook ``force_i``): a drag that grows with the
      currents, none without current.
    * ``side_wall`` -- a conducting side wall of the frame beside the array sits in the magnets' leakage field,
      which grows as the gap opens (the leakage permeance ``1 / l_l`` against the gap's ``1 / (g + hm / mu_rec)``:
      Roters, "Electromagnetic Devices", Wiley 1941 (leakage permeances)); viscous at the rig's speeds (Reitz,
      "Forces on moving magnets due to eddy currents", J. Appl. Phys. 41(5), 1970, the low-speed limit): ``F_d = -c0
      (s(g) / s(15 mm))^2 d_dot``, ``s = (g + hm/mu_rec) / (g + hm/mu_rec + l_l)`` the leakage share: a drag that grows
      as the gap opens.
    """

    families = ("mmf_harmonics", "side_wall")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "mmf_harmonics": {"c0": 1.5, "h_c": 2e-3},
        "side_wall": {"c0": 3.0, "l_l": 0.01},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family == "side_wall"
        self.has_force_i = self.family == "mmf_harmonics"

    def harmonic_gain(self, g):
        """``h(g)`` (``mmf_harmonics``)."""
        hc = self.p["h_c"]
        g = np.asarray(g, dtype=float)
        tot, ref = 0.0, 0.0
        for nu in (5, 7):
            a = nu * math.pi / k.tau
            tot = tot + (math.sinh(a * (hc + G_REF)) / np.sinh(a * (hc + g))) ** 2 / nu**2
            ref = ref + 1.0 / nu**2
        return tot / ref

    def leakage_share(self, g):
        """``s(g)``: the magnets' leakage share (``side_wall``)."""
        x = np.asarray(g, dtype=float) + k.hm / k.mu_rec
        return x / (x + self.p["l_l"])

    def force(self, g, gd, d, dd):
        """``side_wall``'s drag ``(F_g, F_d)`` [N]."""
        dd = np.asarray(dd, dtype=float)
        s = self.leakage_share(g) / float(self.leakage_share(G_REF))
        fd = -self.p["c0"] * s * s * dd
        return 0.0 * fd, fd

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """``mmf_harmonics``' drag ``(F_g, F_d)`` [N] with the carried currents."""
        dd = np.asarray(dd, dtype=float)
        cur = (np.asarray(i_q, dtype=float) ** 2 + np.asarray(i_d, dtype=float) ** 2) / I_REF**2
        fd = -self.p["c0"] * cur * self.harmonic_gain(g) * dd
        return 0.0 * fd, fd
