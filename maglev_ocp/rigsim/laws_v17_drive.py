"""The seventeenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v17"``; see
:mod:`.laws_v17`, which registers them).

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
from .laws_v17_ool import _V17, K_FIELD, current_force, window, window_slope

__all__ = ["AmplifierV17", "CommutationV17", "EddyDragV17", "harmonic_ratio"]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV17(_V17, AmplifierV13):
    """A current loop whose coil is fed through an output LC filter, or whose current sensor has a pole-zero doublet.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``output_lc`` -- the inverter's current is regulated (a first-order loop, bandwidth ``f_c``) and reaches the
      coil through an output LC filter: the coil's current is the inverter's through a current divider, ``1 / (1 +
      2 zeta s / w_r + s^2 / w_r^2)``, a lightly damped resonance at ``f_r`` (Liserre, Blaabjerg & Hansen, "Design
      and control of an LCL-filter-based three-phase active rectifier", IEEE Trans. Ind. Appl. 41(5), 2005; Mohan,
      Undeland & Robbins, "Power Electronics", 3rd ed., Wiley 2003, ch. 8): ``H = 1 / ((1 + s / w_c)(1 + 2 zeta s /
      w_r + s^2 / w_r^2))``, group delay ``1 / w_c + 2 zeta / w_r``.
    * ``sensor_doublet`` -- the current sensor's response has a slow pole-zero doublet (a shunt amplifier's
      miscompensated divider, or a closed-loop Hall transducer's core), the zero ``tau_z`` below the pole ``tau_p``,
      after a fast lag ``tau_f``: the reading first falls short, then creeps up with ``tau_p`` (Kamath, Meyer & Gray,
      "Relationship between frequency response and settling time of operational amplifiers", IEEE J. Solid-State
      Circuits 9(6), 1974): ``H = (1 + s tau_z) / ((1 + s tau_p)(1 + s tau_f))``, group delay ``tau_p + tau_f -
      tau_z``.
    """

    families = ("output_lc", "sensor_doublet")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "output_lc": {"f_c": 500.0, "f_r": 1500.0, "zeta": 0.15, "delay_samples": 0.0},
        "sensor_doublet": {"tau_p": 2e-3, "tau_z": 1.6e-3, "tau_f": 2e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "output_lc":
            wr = 2.0 * math.pi * p["f_r"]
            a = wr / (2.0 * math.pi * p["f_c"])  # the loop's time constant over 1 / w_r
            z = p["zeta"]
            return np.array([1.0 / a]), np.array([1.0, 2.0 * z + 1.0 / a, 1.0 + 2.0 * z / a, 1.0 / a]), wr
        rz, rp = p["tau_z"] / p["tau_f"], p["tau_p"] / p["tau_f"]
        return np.array([rz / rp, 1.0 / rp]), np.array([1.0, 1.0 + 1.0 / rp, 1.0 / rp]), 1.0 / p["tau_f"]


# ------------------------------------------------------------------------- commutation
def harmonic_ratio(n: int, g, h_s: float):
    """The array's ``n``-th field harmonic over its fundamental at ``h_s`` below the stator's face, gap ``g``
    (alternating magnets ``taup`` wide on the pole pitch ``tau``, ``hm`` thick; MODEL.md's 2-D field)."""
    g = np.asarray(g, dtype=float)
    c = (math.sin(n * math.pi * k.taup / (2.0 * k.tau)) / n) / math.sin(math.pi * k.taup / (2.0 * k.tau))
    layer = (1.0 - math.exp(-n * K_FIELD * k.hm)) / (1.0 - math.exp(-K_FIELD * k.hm))
    return c * layer * np.exp(-(n - 1) * K_FIELD * (g + h_s))


class CommutationV17(_V17, CommutationV13):
    """Commutation angle errors of an angle held between slow position updates, or of one two-axis Hall sensor
    reading the array's field harmonics.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``held_angle`` -- the drive's commutation angle comes from a position that reaches it only every ``T_u``
      (a serial encoder's frame, a slow bus), held in between: at time ``t`` it is the position of ``t - ((t -
      t_0) mod T_u)``, behind by ``v`` times the time since the last update (a sample-and-hold: Franklin, Powell &
      Workman, "Digital Control of Dynamic Systems", 3rd ed., Addison-Wesley 1998, ch. 3; Bae & Sul, "A compensation
      method for time delay of full-digital synchronous frame current regulator of PWM AC drives", IEEE Trans. Ind.
      Appl. 39(3), 2003): ``delta = delta0 - (pi / tau) d_dot ((t - t_0) mod T_u)``, a sawtooth in time scaled by
      the speed.
    * ``two_axis_hall`` -- one sensor at ``x_h``, ``h_s`` below the stator's face, reads both components of the
      array's field at one point and the drive takes ``atan2(B_x, B_z)``: over a periodic magnetization the two are
      in quadrature harmonic by harmonic, ``B_z + j B_x = sum b_n e^{j n th}``, ``b_n`` decaying as ``e^{-n k z}``
      (Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press 2001, ch. 4; Popovic, "Hall Effect
      Devices", 2nd ed., IOP 2004, ch. 5 (two-axis Hall sensors)): ``delta = delta0 + arg(1 + e3 e^{2j th} + e5 e^{4j
      th})``, ``e_n = b_n / b_1`` at ``g + h_s``: at twice the electrical frequency, larger at small gaps.
    """

    families = ("held_angle", "two_axis_hall")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "held_angle": {"delta0": 0.0, "T_u": 4e-3, "t_0": 0.0},
        "two_axis_hall": {"delta0": 0.0, "h_s": 0.004, "x_h": 0.0},
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def electrical_angle(self, d):
        """The sensor's electrical angle ``th`` [rad] over the array at position ``d`` (0 over the first magnet's
        middle)."""
        s = self.p.get("x_h", 0.0) - np.asarray(d, dtype=float) + 0.5 * L_ARRAY
        return math.pi * (s - 0.5 * k.tau) / k.tau

    def angle_at(self, g, d, v=None, t=None):
        """Electrical angle error [rad] at gap ``g``, position ``d``, speed ``v`` and time ``t`` (None: 0)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "held_angle":
            v = 0.0 * d if v is None else np.asarray(v, dtype=float)
            age = np.mod((0.0 if t is None else np.asarray(t, dtype=float)) - p["t_0"], p["T_u"])
            return p["delta0"] - math.pi / k.tau * v * age + 0.0 * (g + d)
        th = self.electrical_angle(d)
        z = 1.0 + harmonic_ratio(3, g, p["h_s"]) * np.exp(2j * th) + harmonic_ratio(5, g, p["h_s"]) * np.exp(4j * th)
        return p["delta0"] + np.angle(z)

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X`` (``[g, g_dot, d, d_dot, ...]``), time ``t``."""
        X = np.asarray(X, dtype=float)
        sim = X.ndim == 2 and X.shape[0] == self.n_runs
        a = self.angle_at(X[..., 0], X[..., 2], X[..., 3], t)
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if sim:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2


# --------------------------------------------------------------------------- eddy drag
class EddyDragV17(_V17, EddyDrag):
    """Drag of the stator iron's excess (domain-wall) eddy loss beside its classical one, or of a shorted search
    coil round a stator tooth.

    * ``excess_loss`` -- the stator's iron under the moving array is magnetized at the frequency ``f = v / 2 tau``;
      Bertotti's loss separation gives a classical eddy loss ``∝ B^2 f^2`` and an excess loss ``∝ B^{3/2} f^{3/2}``
      per cycle-time (Bertotti, "General properties of power losses in soft ferromagnetic materials", IEEE Trans.
      Magn. 24(1), 1988), so the drag ``P / v`` is ``F_d = -(c_c b^2 d_dot + F_x b^{3/2} s(d_dot / V1))``, ``b = B(g)
      / B(15 mm)``, ``s(x) = x / (x^2 + x0^2)^{1/4}`` (``sqrt|x|`` signed, regularized at ``x0 = 0.01``), ``V1 = 0.1
      m/s``. The gap axis none.
    * ``search_coil`` -- a search coil round a stator tooth at ``x_c`` (for flux monitoring) left shorted: its
      linkage ``Phi = Phi_0 b(g) cos(pi (d - x_c) / tau) w(x_c - d)`` (``w`` the array's footprint, edges over
      ``l_e``) changes with both coordinates, the current ``-(dPhi/dt) / R`` (the coil's ``L / R`` short against the
      motion) acts back with ``i grad Phi`` (Faraday and Lenz; Stoll, "The Analysis of Eddy Currents", Clarendon
      1974, ch. 1; Woodson & Melcher, "Electromechanical Dynamics", Wiley 1968, part I, ch. 3): ``F = -(c_s / k^2)
      grad(phi) (grad(phi) . v)``, ``phi = Phi / Phi_0``, ``k = pi / tau``: a damping of rank one, coupling the axes,
      rippling with the pole pair along d.
    """

    families = ("excess_loss", "search_coil")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "excess_loss": {"c_c": 2.0, "F_x": 0.4},
        "search_coil": {"c_s": 3.0, "x_c": 0.0, "l_e": 0.005},
    }
    V1 = 0.1  #: the excess drag's reference speed [m/s]
    X0 = 0.01  #: its regularization, over V1

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = True
        self.has_held = False

    def linkage_grad(self, g, d):
        """``(dphi/dg, dphi/dd)`` of the coil's normalized linkage (``search_coil``)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        b = field_ratio(g)
        db = -K_FIELD / np.tanh(K_FIELD * (k.hm + g)) * b
        ph = K_FIELD * (d - p["x_c"])
        w = window(p["x_c"] - d, 0.5 * L_ARRAY, p["l_e"])
        dw = -window_slope(p["x_c"] - d, 0.5 * L_ARRAY, p["l_e"])
        return db * np.cos(ph) * w, b * (-K_FIELD * np.sin(ph) * w + np.cos(ph) * dw)

    def force(self, g, gd, d, dd):
        """The drag ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "excess_loss":
            b = field_ratio(g)
            x = dd / self.V1
            fd = -(p["c_c"] * b**2 * dd + p["F_x"] * b**1.5 * x / (x * x + self.X0**2) ** 0.25)
            return 0.0 * fd + 0.0 * gd, fd
        pg, pd = self.linkage_grad(g, d)
        rate = pg * gd + pd * dd
        c = p["c_s"] / K_FIELD**2
        return -c * pg * rate, -c * pd * rate
