"""The thirteenth law set's amplifier, commutation and eddy-drag families (issue 27, ``laws="v13"``; see
:mod:`.laws_v13`, which registers them).

Written from their sources only, without reading the diagnosis or how it fits; each source is cited in the class
docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from .laws import CommutationOffset
from .laws_new import EddyDrag
from .laws_v3 import AmplifierV3
from .laws_v4 import K_POLE
from .laws_v9 import companion
from .laws_v13_ool import _V13, G_REF, _Peaks, current_force
from .physics import shape

_TWO_PI = 2.0 * math.pi
_R2 = math.sqrt(2.0)

__all__ = ["AmplifierV13", "CommutationV13", "EddyDragV13"]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV13(_V13, AmplifierV3):
    """A current loop whose response is a Linkwitz-Riley fourth-order low-pass, or a first-order loop behind a PWM
    stage's delay in its second-order Pade form.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``linkwitz_riley4`` -- two cascaded second-order Butterworth sections (a current loop and its sensing filter
      each tuned to Q = 1/sqrt(2) at the same corner): ``1 / (s^2/w^2 + sqrt(2) s/w + 1)^2`` (Linkwitz, "Active
      crossover networks for noncoincident drivers", J. Audio Eng. Soc. 24(1), 1976); group delay ``2 sqrt(2) / w``,
      ``w = 2 pi f_c``.
    * ``pade_pwm`` -- a first-order loop of time constant ``tau_a`` behind the PWM stage's average delay ``T_d`` (half
      a switching period plus the computation; Holmes & Lipo, "Pulse Width Modulation for Power Converters", IEEE
      Press/Wiley 2003, ch. 1), the delay as its second-order Pade approximant (Pade, "Sur la representation
      approchee d'une fonction par des fractions rationnelles", Ann. Sci. ENS 9, 1892): ``(1 - s T_d/2 + s^2
      T_d^2/12) / ((1 + s T_d/2 + s^2 T_d^2/12)(1 + s tau_a))``: the delay's part all-pass with zeros in the right
      half-plane (non-minimum phase), group delay ``tau_a + T_d``.
    """

    families = ("linkwitz_riley4", "pade_pwm")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "linkwitz_riley4": {"f_c": 500.0, "delay_samples": 0.0},
        "pade_pwm": {"tau_a": 3e-4, "T_d": 2e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "linkwitz_riley4":
            return np.array([1.0]), np.array([1.0, 2 * _R2, 4.0, 2 * _R2, 1.0]), _TWO_PI * p["f_c"]
        r = p["T_d"] / p["tau_a"]
        num = np.array([1.0, -6.0 / r, 12.0 / (r * r)])
        den = np.array([1.0, 6.0 / r + 1.0, 12.0 / (r * r) + 6.0 / r, 12.0 / (r * r)])
        return num, den, 1.0 / p["tau_a"]

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
class CommutationV13(_V13, _Peaks, CommutationOffset):
    """Commutation angle errors of a Hall sensor mounted at a slant to the gap, or of two Hall heads the drive
    switches between with a hysteresis band.

    Both rotate the dq currents by the angle error at the state (hook ``rotate_at``), the rotation's force recorded
    while simulated (the rotated against the delivered currents through seed eq. (2) with nominal constants).

    * ``slanted_sensor`` -- the Hall head that gives the electrical angle rides with the gap axis on a bracket
      inclined by ``alpha`` to the gap's normal: as the gap changes by ``g - g_ref`` the sensor also moves along the
      stroke by ``(g - g_ref) tan alpha`` and reads the array's field there (Ramsden, "Hall-Effect Sensors: Theory
      and Application", 2nd ed., Newnes 2006, ch. 6 (position sensing geometry); Krishnan, "Permanent Magnet
      Synchronous and Brushless DC Motor Drives", CRC 2010, ch. 9): ``delta = delta0 + (pi / tau) tan(alpha) (g -
      g_ref)``: an error set by the gap, not the position or the speed.
    * ``head_switchover`` -- two Hall heads, each mounted with its own offset, cover the stroke; the drive takes the
      angle from head A below ``d_s`` and from head B above it, with a hysteresis band ``+-h_s`` against chatter (a
      Schmitt trigger's rule: Schmitt, "A thermionic trigger", J. Sci. Instrum. 15(1), 1938; Hall-sensor commutation
      of long-stroke linear motors: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC 2011, ch. 9):
      ``delta = delta_a`` or ``delta_b``, the switch to B when ``d > d_s + h_s``, back to A when ``d < d_s - h_s``
      (per run, at the integrator's states; head A at the start unless the run starts above the band): an error
      that depends on the direction the mover came from inside the band.
    """

    families = ("slanted_sensor", "head_switchover")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "slanted_sensor": {"delta0": 0.0, "tan_a": 0.3},
        "head_switchover": {"delta_a": 0.1, "delta_b": -0.1, "d_s": 0.0, "h_s": 0.002},
    }
    has_rotate = False
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet, no head chosen."""
        self.reset_peaks(n_runs)
        self.on_b: np.ndarray | None = None

    def head_b(self, d, on_b=None):
        """Which head gives the angle (True: B) at ``d``, from the previous choice ``on_b`` (None: the start)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        if on_b is None:
            return d > p["d_s"] + p["h_s"]
        return np.where(d > p["d_s"] + p["h_s"], True, np.where(d < p["d_s"] - p["h_s"], False, on_b))

    def angle_at(self, g, d, on_b=None):
        """Electrical angle error [rad] at gap ``g`` and position ``d`` (``head_switchover``: given the head)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "slanted_sensor":
            return p["delta0"] + K_POLE * p["tan_a"] * (g - G_REF) + 0.0 * d
        b = self.head_b(d, None) if on_b is None else np.asarray(on_b, dtype=bool)
        return np.where(b, p["delta_b"], p["delta_a"]) + 0.0 * g

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X``."""
        X = np.asarray(X, dtype=float)
        sim = X.ndim == 2 and X.shape[0] == self.n_runs
        if self.family == "head_switchover" and sim:
            self.on_b = self.head_b(X[:, 2], self.on_b)
            a = self.angle_at(X[:, 0], X[:, 2], self.on_b)
        else:
            a = self.angle_at(X[..., 0], X[..., 2])
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if sim:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


# --------------------------------------------------------------------------- eddy drag
def field_ratio(g):
    """``B(g) / B(15 mm)`` (MODEL.md's field)."""
    return shape(np.asarray(g, dtype=float)).B / float(shape(G_REF).B)


class EddyDragV13(_V13, EddyDrag):
    """Drag of an eddy circuit whose inductance delays its current, or of a sheet that sees the armature's field as
    well as the magnets'.

    * ``inductive_loop`` -- a closed conducting loop (a frame's ring, a cooling plate's rim) with resistance ``R`` and
      inductance ``L``: the motional EMF ``~ v`` drives a current through ``L/R``, so the drag follows ``-c v`` with a
      first-order lag ``tau_e = L/R`` (the lumped circuit of an eddy path: Woodson & Melcher, "Electromechanical
      Dynamics", Part I, Wiley 1968, ch. 6; Sodano, Bae & Inman, "Improved concept and model of eddy current damper",
      ASME J. Vib. Acoust. 128(3), 2006, for the drag coefficient): ``tau_e dF/dt = -(F + c v)`` per axis (``c_d``
      along d, ``c_g`` on the gap), the velocity held over each sub-step and the force averaged over it (hook
      ``held``): a drag that lags the speed, no memory of position.
    * ``armature_sheet`` -- a conducting sheet behind the stator's teeth sees, moving with the mover at its speed,
      the magnets' field and the armature reaction's field of the currents (the d current along the magnets' axis,
      the q current across it): the low-speed drag (Reitz, "Forces on moving magnets due to eddy currents", J. Appl.
      Phys. 41(5), 1970) goes as the square of the total field's amplitude (Gieras, Piech & Tomczuk, "Linear
      Synchronous Motors", 2nd ed., CRC 2011, ch. 2, armature reaction): ``F_d = -c0 b(g)^2 ((1 + kappa i_d)^2 +
      (kappa i_q)^2) d_dot``, ``b = B(g) / B(15 mm)`` (hook ``force_i``): a drag that grows with the thrust.
    """

    families = ("inductive_loop", "armature_sheet")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "inductive_loop": {"c_d": 3.0, "c_g": 1.0, "tau_e": 0.01},
        "armature_sheet": {"c0": 2.0, "kappa": 0.2},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = False
        self.has_held = self.family == "inductive_loop"
        self.has_force_i = self.family == "armature_sheet"  # type: ignore[misc]
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """No current in the loop."""
        self.F: np.ndarray | None = None

    def held(self, gd, dd, h: float):
        """``inductive_loop``: the drag over a sub-step of length ``h`` (advances the loop's current)."""
        p = self.p
        v = np.stack([np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)], axis=-1)
        if self.F is None or self.F.shape != v.shape:
            self.F = np.zeros_like(v)
        target = -np.array([p["c_g"], p["c_d"]]) * v
        e = math.exp(-h / p["tau_e"])
        mean = target + (self.F - target) * (p["tau_e"] / h) * (1.0 - e)
        self.F = target + (self.F - target) * e
        return mean[..., 0], mean[..., 1]

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """``armature_sheet``'s drag ``(F_g, F_d)`` [N] at the currents the motor carries."""
        p = self.p
        b = field_ratio(g)
        kap = p["kappa"]
        amp = (1.0 + kap * np.asarray(i_d, dtype=float)) ** 2 + (kap * np.asarray(i_q, dtype=float)) ** 2
        fd = -p["c0"] * b * b * amp * np.asarray(dd, dtype=float)
        return 0.0 * fd, fd

    def force(self, g, gd, d, dd):
        """No current-free part (``armature_sheet`` acts through ``force_i``)."""
        z = 0.0 * np.asarray(dd, dtype=float)
        return z, z
