"""A seventh set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v7"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3`, :mod:`.laws_v4`,
:mod:`.laws_v5` and :mod:`.laws_v6` has, and two effects outside the library (in :mod:`.laws_v7_ool`), for the next
pre-registered blind check. They were written from their sources only, without reading the diagnosis or how it
fits; each class carries ``new_law = True`` and ``law_set = "v7"`` in its truth record. The source of each law
(author, title, venue, year) is in its docstring and in ``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``force_i``, ``held``,
``rotate``, ``rotate_at``, the state-space amplifier); no hook was added. Each family differs from the earlier ones
in what it depends on: cogging that lags the motion or whose slot energy saturates, friction with a power-law
lubricant or a frictional memory, the phases' share of the winding under the array and the winding's inductance at
the stator's ends, a knee in the current alone or an air gap lengthened by the iron, a current loop with an
inductance feedforward or without an integrator, a damaged commutation tape or the errors of a sin/cos sensor,
a damper cage in the slot openings or parallel winding paths.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import (
    G_STOP_LO,
    LAWS,
    Cogging,
    CommutationOffset,
    EndEffect,
    Friction,
    Law,
    Saturation,
    build_law,
    resolve_law,
)
from .laws_new import NEW_LAWS, EddyDrag
from .laws_v3 import V3_LAWS, AmplifierV3
from .laws_v4 import K_POLE, L_ARRAY, V4_LAWS, field_ratio
from .laws_v5 import V5_LAWS
from .laws_v6 import EFFECTS_V6, V6_LAWS, array_field
from .laws_v7_ool import _V7, FlexiblePayload, PayloadSwap
from .physics import shape

G_REF = 15e-3  #: reference gap of this set's eddy drags (the gap band's lower edge) [m]
TWO_PI_3 = 2.0 * math.pi / 3.0


def _logistic(u):
    """``1 / (1 + e^{-u})``, written without overflow."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(u, dtype=float)))


# ----------------------------------------------------------------------------- cogging
class CoggingV7(_V7, Cogging):
    """Cogging whose flux pattern lags the motion in lossy teeth, or whose slot energy saturates in the tooth tips.

    Both start from the slot-pitch harmonics of the slot openings' energy (the array of ``pm = 4`` poles over three
    slots per pole cogs with the slot pitch ``t1``: Zhu & Howe, "Influence of design parameters on cogging torque in
    permanent magnet machines", IEEE Trans. Energy Convers. 15(4), 2000), each harmonic decaying across the gap as
    a Laplace field of its wavenumber: ``a_k(g) = xi0 c_k exp(-2 pi k (g - g_ref) / t1)``, ``theta_k = 2 pi k (d -
    x0) / t1 + phi_k`` (``c_1 = 1 - |c2|``, ``phi_1 = 0``; ``xi0`` the sum of the harmonics' tangential amplitudes
    at ``g_ref = 10 mm``, their peak where they align, as seed eq. (9)'s peak; the first harmonic falls to 0.19 of it
    at 15 mm, the second to 0.04). The static law is ``W = (t1 / 2 pi) sum_k (a_k / k) cos theta_k``: ``F_d =
    sum_k a_k sin theta_k``, ``F_g = sum_k a_k cos theta_k`` (``F = -grad W``; ``F_g > 0`` opens the gap).

    * ``lossy_teeth`` -- the stator's tooth tips are solid (unlaminated) iron, whose eddy currents delay the flux's
      change by ``tau_e = mu sigma w^2 / 12`` (the low-frequency lag of the classical eddy field in a plate of
      width ``w``: Bertotti, "Hysteresis in Magnetism", Academic Press 1998, ch. 12), so each harmonic of the
      cogging pattern follows the position through a first-order lag at its frequency ``omega_k = 2 pi k v /
      t1``: ``sin theta -> (sin theta - omega_k tau_e cos theta) / (1 + (omega_k tau_e)^2)`` and ``cos theta ->
      (cos theta + omega_k tau_e sin theta) / (1 + (omega_k tau_e)^2)`` (the steady-state response at the
      speed ``v = d_dot``; the static law at rest). The pattern shifts back along the motion and shrinks as the
      speed grows; the loss itself (second order in the flux) is left out.
    * ``tip_saturation`` -- the tooth tips saturate where the slot openings' energy is largest (magnetic
      saturation flattens the cogging: Azar, Zhu & Ombach, "Influence of electric loading and magnetic saturation
      on cogging torque, back-EMF and torque ripple of PM machines", IEEE Trans. Magn. 48(10), 2012); the energy's
      variation saturates on a hyperbolic-tangent curve of level ``xi_s`` (the tanh magnetization curve: Takacs,
      "A phenomenological mathematical model of hysteresis", COMPEL 20(4), 2001): ``u = sum_k (a_k / k) cos
      theta_k``, ``W = (t1 / 2 pi) xi_s tanh(u / xi_s)``, so ``F = sech^2(u / xi_s) F_static``: the static law
      for ``xi_s >> u`` (large gaps), a force squeezed towards the energy's zero crossings as the gap closes.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("lossy_teeth", "tip_saturation")
    _common: ClassVar[dict[str, float]] = {"xi0": 4.0, "c2": 0.3, "phi2": 0.0, "x0": 0.0, "replace": 0.0}
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "lossy_teeth": {**_common, "tau_e": 3e-3},
        "tip_saturation": {**_common, "xi_s": 3.0},
    }

    def harmonics(self, g, d):
        """``[(a_k, theta_k, omega_k per unit speed)]`` for k = 1, 2."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        out = []
        for kk, c, ph in ((1, 1.0 - abs(p["c2"]), 0.0), (2, p["c2"], p["phi2"])):
            a = p["xi0"] * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1)
            out.append((a, 2 * math.pi * kk * (d - p["x0"]) / k.t1 + ph, 2 * math.pi * kk / k.t1))
        return out

    def static(self, g, d):
        """``(F_g, F_d, u)`` of the static law (``u`` the energy variable of ``tip_saturation``) [N]."""
        fg = fd = u = 0.0
        for kk, (a, th, _) in enumerate(self.harmonics(g, d), start=1):
            fg, fd, u = fg + a * np.cos(th), fd + a * np.sin(th), u + a * np.cos(th) / kk
        return fg, fd, u

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        if self.family == "tip_saturation":
            fg, fd, u = self.static(g, d)
            s2 = 1.0 / np.cosh(u / self.p["xi_s"]) ** 2
            return s2 * fg, s2 * fd
        v = np.asarray(dd, dtype=float)
        fg = fd = 0.0
        for a, th, w in self.harmonics(g, d):
            x = w * v * self.p["tau_e"]
            den = 1.0 + x * x
            s, c = np.sin(th), np.cos(th)
            fd, fg = fd + a * (s - x * c) / den, fg + a * (c + x * s) / den
        return fg + 0.0 * v, fd + 0.0 * v


# ---------------------------------------------------------------------------- friction
class FrictionV7(_V7, Friction):
    """Friction of greased guides with a power-law lubricant, or with frictional memory.

    * ``power_law`` -- the grease between the balls and their grooves and in the carriage's seals is a
      shear-thinning (power-law, Ostwald-de Waele) fluid, shear stress ``~ (shear rate)^n`` with ``n < 1`` (Harnoy,
      "Bearing Design in Machinery: Engineering Tribology and Lubrication", Marcel Dekker 2002, ch. on non-Newtonian
      lubricants): the viscous part grows as ``|v|^n``, not ``v``. ``F = -(Fc tanh(v / v_reg) + F1 v (v^2 +
      v0^2)^((n - 1)/2) / V1^n)``, ``F1`` the viscous part at ``V1 = 0.1 m/s`` (``v0`` rounds the power law off
      below 1 mm/s), per axis.
    * ``frictional_memory`` -- the friction of a lubricated contact follows its Stribeck curve with a time lag:
      after a change of speed the film takes ``tau_L`` to rebuild (Hess & Soom, "Friction at a lubricated line
      contact operating at oscillating sliding velocities", ASME J. Tribol. 112(1), 1990). The level is the
      Stribeck curve at a lagged speed ``w``, ``tau_L w' = v - w`` (exact per sub-step for the held speed), the
      sign the present speed's: ``F = -((Fc + Fs exp(-(w / vs)^2)) tanh(v / v_reg) + b v)`` -- a start from rest
      meets the static level for ``tau_L``, and the friction of a speed sweep traces a loop (hook ``held``).
    """

    families = ("power_law", "frictional_memory")
    V1 = 0.1  #: speed of the power law's reference level [m/s]
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "power_law": {"Fc_g": 0.2, "Fc_d": 0.2, "F1_g": 0.1, "F1_d": 0.1, "n": 0.6, "v0": 1e-3, "v_reg": 1e-3},
        "frictional_memory": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "Fs_g": 0.15,
            "Fs_d": 0.15,
            "vs": 5e-3,
            "tau_L": 0.02,
            "b_g": 0.5,
            "b_d": 0.5,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "power_law"
        self.has_held = not self.has_force
        self.state = np.zeros((0, 2))

    def reset(self, n_runs: int) -> None:
        """Lagged speeds at rest per run and axis."""
        self.state = np.zeros((n_runs, 2))

    def force(self, g, gd, d, dd):
        """Power-law friction on both axes [N]."""
        p = self.p
        out = []
        for v, ax in ((gd, "g"), (dd, "d")):
            v = np.asarray(v, dtype=float)
            visc = p[f"F1_{ax}"] * v * (v * v + p["v0"] ** 2) ** (0.5 * (p["n"] - 1.0)) / self.V1 ** p["n"]
            out.append(-(p[f"Fc_{ax}"] * np.tanh(v / p["v_reg"]) + visc))
        return out[0], out[1]

    def held(self, gd, dd, h: float):
        """Advance the lagged speeds over ``h``; return the friction held over it."""
        p = self.p
        decay = math.exp(-h / p["tau_L"])
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            w = v + (self.state[:, j] - v) * decay
            self.state[:, j] = w
            level = p[f"Fc_{ax}"] + p[f"Fs_{ax}"] * np.exp(-((w / p["vs"]) ** 2))
            out.append(-(level * np.tanh(v / p["v_reg"]) + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
def belt_length(r: int, x, x_w: float):
    """Length [m] of the slots of phase residue ``r`` (slot ``n`` holds residue ``n mod 3``) in ``[x_w, x)``
    (negative below ``x_w``): slots of width ``t1`` from ``x_w`` on."""
    u = (np.asarray(x, dtype=float) - x_w) / k.t1
    m = np.floor(u / 3.0)
    return k.t1 * (m + np.clip(u - 3.0 * m - r, 0.0, 1.0))


class EndEffectV7(_V7, EndEffect):
    """End effects of the finite stator on the phases: a winding that ends under the array, or its inductance.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0`` (overhang ``d - e_p`` and ``-d -
    e_n``).

    * ``phase_unbalance`` -- the static end effect of a short winding: where the array overhangs a stator end, the
      slots that would lie under it are missing, and which phase they belong to depends on the position, so the
      three phases' force constants differ (Boldea & Nasar, "Linear Electric Actuators and Generators", Cambridge
      Univ. Press 1997, the static end effect's unbalanced phases; Gieras, Piech & Tomczuk, "Linear Synchronous
      Motors", 2nd ed., CRC Press 2011). Slot ``n`` (width ``t1``, from ``x_w``) holds phase ``n mod 3`` (a, c, b:
      the sequence ``a, -c, b, -a, c, -b`` of one slot per pole and phase); phase ``j`` loses the share ``eps_j =
      (its slot length in the overhang) / (L / 3)`` of its force constant, and the overhanging magnets lose their
      pull on the iron, ``rho = 1 - (overhang) / L`` (every magnetic term, hook ``factors``; ``rho`` is the phases'
      mean ``1 - eps_j``). The dq currents go to the phases at the electrical angle ``theta = pi (d - x_w - t1/2) /
      tau`` (phase a's axis at its slot's centre), are scaled by ``(1 - eps_j) / rho`` and come back
      (amplitude-invariant Park transforms), so that with ``rho`` each phase keeps ``1 - eps_j`` of its force: the
      motor carries those (hook ``rotate_at``). Inside the stator (no overhang) nothing changes.
    * ``armature_reluctance`` -- the winding's inductance falls where the mover's back iron leaves it at a stator
      end, ``L(d) = L0 - dL_p S((d - e_p) / w) - dL_n S((-d - e_n) / w)`` (``S`` logistic over the fringe ``w``),
      and the co-energy ``(1/2) L (3/2) |i|^2`` of the three phases (amplitude-invariant dq currents) gives a
      longitudinal reluctance force ``F_d = (3/4) |i|^2 dL/dd`` that pulls the array back over the winding
      (Fitzgerald, Kingsley & Umans, "Electric Machinery", 6th ed., McGraw-Hill 2003, ch. 3: the force from the
      co-energy ``(1/2) L(x) i^2``). It grows with the current squared, not with the magnets' field (hook
      ``force_i``, the carried currents).
    """

    families = ("phase_unbalance", "armature_reluctance")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "phase_unbalance": {"e_p": 0.02, "e_n": 0.03, "x_w": 0.0},
        "armature_reluctance": {"e_p": 0.02, "e_n": 0.03, "dL_p": 2e-3, "dL_n": 2e-3, "w": 8e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_factors = self.family == "phase_unbalance"
        self.has_rotate_at = self.family == "phase_unbalance"
        self.has_force_i = self.family == "armature_reluctance"

    def shares(self, d):
        """``eps_j`` (phases a, b, c along the last axis): each phase's share of its slots missing."""
        p = self.p
        d = np.asarray(d, dtype=float)[..., None]
        hi_p, lo_n = 0.5 * L_ARRAY + p["e_p"], -0.5 * L_ARRAY - p["e_n"]
        top = np.maximum(d + 0.5 * L_ARRAY, hi_p)  # overhang past the + end: [hi_p, top)
        bot = np.minimum(d - 0.5 * L_ARRAY, lo_n)  # past the - end: [bot, lo_n)
        out = []
        for r in (0, 2, 1):  # phase a, b, c hold residues 0, 2, 1
            miss = belt_length(r, top, p["x_w"]) - belt_length(r, hi_p, p["x_w"])
            miss = miss + belt_length(r, lo_n, p["x_w"]) - belt_length(r, bot, p["x_w"])
            out.append(miss / (L_ARRAY / 3.0))
        return np.concatenate(out, axis=-1)

    def rho(self, d):
        """Fraction of the magnets over the stator: ``1 - (overhang) / L``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        return 1.0 - (np.maximum(d - p["e_p"], 0.0) + np.maximum(-d - p["e_n"], 0.0)) / L_ARRAY

    def factors(self, g, d, f: list) -> None:
        """Every magnetic term by ``rho(d)`` (``phase_unbalance``)."""
        f[2] = f[2] * self.rho(d)

    def carried(self, i_q, i_d, d):
        """Currents ``(i_q, i_d)`` that, with :meth:`rho`, give each phase ``1 - eps_j`` of its force at ``d``."""
        i_q, i_d, d = (np.asarray(x, dtype=float) for x in (i_q, i_d, d))
        th = math.pi * (d - self.p["x_w"] - 0.5 * k.t1) / k.tau
        eps, rho = self.shares(d), self.rho(d)
        q2 = d2 = 0.0
        for j, sh in enumerate((0.0, -TWO_PI_3, TWO_PI_3)):
            c, s = np.cos(th + sh), np.sin(th + sh)
            ij = (i_d * c - i_q * s) * (1.0 - eps[..., j]) / rho
            d2, q2 = d2 + (2.0 / 3.0) * ij * c, q2 - (2.0 / 3.0) * ij * s
        return q2, d2

    def rotate_at(self, i_q, i_d, X, t):
        """Currents the motor carries at the state ``X`` (rows: runs)."""
        return self.carried(i_q, i_d, X[..., 2])

    def inductance_slope(self, d):
        """``dL/dd`` [H/m] of the winding's inductance at the stator's ends."""
        p = self.p
        d = np.asarray(d, dtype=float)
        sp, sn = _logistic((d - p["e_p"]) / p["w"]), _logistic((-d - p["e_n"]) / p["w"])
        return (-p["dL_p"] * sp * (1.0 - sp) + p["dL_n"] * sn * (1.0 - sn)) / p["w"]

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """Reluctance force of the winding's ends ``(0, F_d)`` [N] for the carried currents."""
        fd = 0.75 * (np.asarray(i_q) ** 2 + np.asarray(i_d) ** 2) * self.inductance_slope(d)
        return 0.0 * fd, fd


# --------------------------------------------------------------------------- saturation
class SaturationV7(_V7, Saturation):
    """Saturation of the tooth tips by the currents' own leakage flux, or an air gap lengthened by the iron.

    * ``leakage_knee`` -- the slot-leakage flux of the winding saturates the tooth tips above a current knee, which
      the magnets' flux (crossing the gap, not the slot) does not load (Pyrhonen, Jokinen & Hrabovcova, "Design of
      Rotating Electrical Machines", 2nd ed., Wiley 2014, ch. 4: the saturation of the leakage paths at high
      currents): the currents' field ``kc *= (1 + (|i| / i_k)^p)^(-1/p)``, ``|i|`` the carried dq current's
      magnitude (a knee of sharpness ``p``, linear below ``i_k``, ``~ i_k / |i|`` above it). It does not depend on
      the gap or the magnets (hook ``factors_i``).
    * ``saturation_factor`` -- the iron's magnetic voltage, counted as an extra air gap: ``g_eff = k_sat g``,
      ``k_sat = 1 + U_fe / U_g`` (the saturation factor of machine design: Pyrhonen et al. 2014, ch. 3), with the
      iron's curve above its knee a power law ``H ~ B^(n+1)`` (Trutt, Erdelyi & Hopkins, "Representation of the
      magnetization characteristic of DC machines for computer use", IEEE Trans. Power App. Syst. 87(3), 1968), so
      ``U_fe / U_g = k_lo (B(g) / B(g_lo))^n`` (``k_lo`` at the lower stop; ``B`` MODEL.md's field of the linear
      circuit). Every magnetic term of seed eq. (2) is evaluated at ``g_eff`` (hook ``factors``: ``km = sqrt(f2(g_eff)
      / f2(g))``, ``kc = f3(g_eff) / (f3(g) km)``, ``thrust = f1(g_eff) / (f1(g) km kc)``; the small ``C4`` term
      keeps ``f4(g) kc^2``): the loss changes the terms' gap dependence, not only their size.
    """

    families = ("leakage_knee", "saturation_factor")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "leakage_knee": {"i_k": 8.0, "p": 3.0, "target": "current"},
        "saturation_factor": {"k_lo": 0.1, "n": 3.0, "target": "both"},
    }

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        want = "current" if self.family == "leakage_knee" else "both"
        if self.p["target"] != want:
            raise ValueError(f"saturation ({self.family}): target must be {want!r}")
        self.has_factors = self.family == "saturation_factor"
        self.has_factors_i = not self.has_factors

    def knee(self, i_q, i_d):
        """``kc`` of ``leakage_knee`` at the carried currents."""
        p = self.p
        a = np.hypot(np.asarray(i_q, dtype=float), np.asarray(i_d, dtype=float)) / p["i_k"]
        return (1.0 + a ** p["p"]) ** (-1.0 / p["p"])

    def effective_gap(self, g):
        """``g_eff`` [m] of ``saturation_factor``."""
        g = np.asarray(g, dtype=float)
        return g * (1.0 + self.p["k_lo"] * field_ratio(g, G_STOP_LO) ** self.p["n"])

    def loss(self, g, i_q=0.0, i_d=0.0):
        """Fraction of the saturating field lost: the currents' (``leakage_knee``), the pull's share (the other)."""
        if self.family == "leakage_knee":
            return 1.0 - self.knee(i_q, i_d) + 0.0 * np.asarray(g, dtype=float)
        g = np.asarray(g, dtype=float)
        return 1.0 - np.sqrt(shape(self.effective_gap(g)).f2 / shape(g).f2)

    def factors(self, g, d, f: list) -> None:
        """Every term at the effective gap (``saturation_factor``)."""
        g = np.asarray(g, dtype=float)
        s0, s1 = shape(g), shape(self.effective_gap(g))
        km = np.sqrt(s1.f2 / s0.f2)
        kc = s1.f3 / (s0.f3 * km)
        f[0] = f[0] * km
        f[1] = f[1] * kc
        f[3] = f[3] * s1.f1 / (s0.f1 * km * kc)

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """The currents' field by the knee (``leakage_knee``)."""
        f[1] = f[1] * self.knee(i_q, i_d)


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV7(_V7, AmplifierV3):
    """Current loops with an inductance feedforward, or a proportional loop without an integrator.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`).

    * ``feedforward`` -- the loop adds the reference's voltage ``L^ di*/dt`` (through a derivative filter ``wf``)
      to a loop of bandwidth ``wc`` (feedforward of the winding model: Briz, Degner & Lorenz, "Analysis and design
      of current regulators using complex vectors", IEEE Trans. Ind. Appl. 36(3), 2000). With ``alpha = L^ / L``:
      ``i / u = wf (alpha s + wc) / ((s + wc)(s + wf))``: a lead for ``alpha > 1`` (the model's inductance too
      large), a lag below; DC gain 1, group delay ``(1 - alpha) / wc + 1 / wf`` (negative for a strong lead).
    * ``proportional_loop`` -- an analog transconductance amplifier with a proportional loop ``Kp`` on the winding
      ``R, L`` and the motional back-EMF ``ke v`` (Leonhard, "Control of Electrical Drives", 3rd ed., Springer
      2001, ch. 5: the current loop without integral action): ``L di/dt = -R i + Kp (u - i) - ke v``, ``i / u =
      kappa wc / (s + wc)`` with ``wc = (R + Kp) / L`` and the static gain ``kappa = 1 / (1 + rho)``, ``rho = R /
      Kp``; at a steady speed the back-EMF leaves the error ``-ke v / (wc L)`` (no integrator removes it), the
      levitation current seeing the gap speed and the thrust current the horizontal one (:meth:`axis_velocity`).
      Group delay ``1 / wc``.
    """

    families = ("feedforward", "proportional_loop")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "feedforward": {"bandwidth_hz": 300.0, "alpha": 1.2, "ff_hz": 2000.0, "delay_samples": 0.0},
        "proportional_loop": {
            "bandwidth_hz": 300.0,
            "rho": 0.04,
            "L": 10e-3,
            "ke_q": 15.0,
            "ke_d": 30.0,
            "delay_samples": 0.0,
        },
    }

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` of axis ``axis`` (inputs ``[u, v]``)."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "proportional_loop":
            ke = p["ke_q"] if axis == 0 else p["ke_d"]
            A = np.array([[-wc]])
            B = np.array([[wc / (1.0 + p["rho"]), -ke / p["L"]]])
            return A, B, np.array([1.0])
        wf = 2 * math.pi * p["ff_hz"]
        # s^2 + (wc + wf) s + wc wf; numerator wf wc + wf alpha s (controllable canonical form)
        A = np.array([[0.0, 1.0], [-wc * wf, -(wc + wf)]])
        B = np.array([[0.0, 0.0], [1.0, 0.0]])
        return A, B, np.array([wf * wc, wf * p["alpha"]])

    def dc_gain(self) -> float:
        """Static gain of the command-to-current response."""
        return 1.0 / (1.0 + self.p["rho"]) if self.family == "proportional_loop" else 1.0

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "proportional_loop":
            lag = 1.0 / wc
        else:
            lag = (1.0 - p["alpha"]) / wc + 1.0 / (2 * math.pi * p["ff_hz"])
        return p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
class CommutationV7(_V7, CommutationOffset):
    """Commutation angle errors of a damaged magnetic commutation tape, or of a sin/cos sensor's signal errors.

    * ``tape_defect`` -- the angle is counted from a magnetic tape of pole pitch ``p_t`` read by a magnetoresistive
      sensor (Lenz & Edelstein, "Magnetic sensors and their applications", IEEE Sensors J. 6(3), 2006); at a
      damaged (demagnetized) patch ``x_j`` the sensor misses (``m_j = +1``) or adds (``m_j = -1``) one tape period
      each time it crosses it, forwards and backwards alike, so the count is off by ``m_j p_t`` on the far side of
      the patch from where the drive found its angle: ``delta = delta0 + (pi / tau) p_t sum_j m_j S((d - x_j) /
      w)`` (``S`` logistic, ``w`` the patch's width): steps along d, not a drift.
    * ``sincos_heydemann`` -- the angle is ``atan2`` of a sin/cos magnetic sensor over the array whose channels
      carry offsets ``p``, ``q``, a gain mismatch ``r`` and a quadrature error ``alpha`` (Heydemann,
      "Determination and correction of quadrature fringe measurement errors in interferometers", Appl. Opt.
      20(19), 1981): ``u_c = cos theta + p``, ``u_s = (1 + r) sin(theta + alpha) + q``, ``theta = pi d / tau +
      theta0``, ``delta = delta0 + wrap(atan2(u_s, u_c) - theta)``: an error with the electrical period (the
      offsets) and half of it (gain and quadrature).
    """

    families = ("tape_defect", "sincos_heydemann")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "tape_defect": {"delta0": 0.0, "p_t": 2e-3, "x_1": 0.01, "m_1": 1.0, "x_2": -0.03, "m_2": 0.0, "w": 3e-4},
        "sincos_heydemann": {"delta0": 0.0, "p": 0.02, "q": -0.01, "r": 0.02, "alpha": 0.02, "theta0": 0.0},
    }

    def angle(self, d):
        """Electrical angle error [rad] at position ``d``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        if self.family == "tape_defect":
            steps = p["m_1"] * _logistic((d - p["x_1"]) / p["w"]) + p["m_2"] * _logistic((d - p["x_2"]) / p["w"])
            return p["delta0"] + K_POLE * p["p_t"] * steps
        th = K_POLE * d + p["theta0"]
        est = np.arctan2((1.0 + p["r"]) * np.sin(th + p["alpha"]) + p["q"], np.cos(th) + p["p"])
        return p["delta0"] + np.angle(np.exp(1j * (est - th)))


# --------------------------------------------------------------------------- eddy drag
class EddyDragV7(_V7, EddyDrag):
    """Eddy drag of a damper cage in the slot openings, or of circulating currents in parallel winding paths.

    Both act along d (``F_g = 0``), at low speed (the circuits' ``L / R`` lag is left out), ``F_d = -c(d, g)
    d_dot``.

    * ``damper_bars`` -- conducting slot wedges joined at their ends form a damper cage (the amortisseur of a
      synchronous machine: Kimbark, "Power System Stability, Vol. III: Synchronous Machines", Wiley 1956): the
      array's field sweeping past bar ``b`` (at ``x0 + b t1``, length ``LA``) induces ``Bz LA v`` and drives
      ``Bz LA v / R_b`` through it, whose force is ``Bz^2 LA^2 v / R_b``: ``c = c0 sum_b Bz(x_b - d, g)^2 / Q``,
      ``Bz`` the exact 2-D field of the four magnets (:func:`.laws_v6.array_field`, ends included) and ``Q`` that
      sum's mean over d at ``G_REF = 15 mm``: a drag that ripples with the slot pitch and fades at the array's
      ends.
    * ``parallel_paths`` -- each phase is two coil groups in parallel, split at ``x_m``; where the array covers
      them unequally their back-EMFs differ and a current circulates between them that the current loop does not
      see (circulating currents of parallel paths: Dorrell, Hsieh & Guo, "Unbalanced magnet pull in large
      brushless rare-earth permanent magnet motors with rotor eccentricity", IEEE Trans. Magn. 45(10), 2009). With
      the array's fundamental ``cos(pi (x - d) / tau)`` over its length and phase ``j``'s conductors ``sin(pi (x -
      x_j) / tau)`` (``x_j = x_a + j 2 tau / 3``), each group's force constant is the integral over its part of the
      array (closed form), ``dK_j = K_A - K_B``, and ``c = c0 (B(g) / B(G_REF))^2 (2/3) sum_j (dK_j / K0)^2``
      (``K0`` a phase's whole force constant; ``c0`` the drag of a completely unequal cover): zero where the
      array is centred on the split, growing to either side.
    """

    families = ("damper_bars", "parallel_paths")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "damper_bars": {"c0": 15.0, "x0": 0.0},
        "parallel_paths": {"c0": 8.0, "x_m": 0.0, "x_a": 0.0},
    }
    N_BARS = 14  #: bars each side of the centre (the array's reach over the stroke)

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        if self.family == "damper_bars":
            u = np.linspace(0.0, k.t1, 64, endpoint=False)
            self._q = float(np.mean(self._bars(np.full_like(u, G_REF), u)))

    def _bars(self, g, d):
        xb = self.p["x0"] + np.arange(-self.N_BARS, self.N_BARS + 1) * k.t1
        g, d = np.asarray(g, dtype=float)[..., None], np.asarray(d, dtype=float)[..., None]
        return np.sum(array_field(xb - d, g + 0.0 * d) ** 2, axis=-1)

    def imbalance(self, d):
        """``(2/3) sum_j (dK_j / K0)^2`` of ``parallel_paths`` at ``d``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        lo, hi = d - 0.5 * L_ARRAY, d + 0.5 * L_ARRAY
        mid = np.clip(p["x_m"], lo, hi)
        out = 0.0
        for j in range(3):
            xj = p["x_a"] + j * 2.0 * k.tau / 3.0

            def part(a, b, xj=xj):
                # int_a^b sin(K (x - xj)) cos(K (x - d)) dx
                osc = -(np.cos(K_POLE * (2 * b - xj - d)) - np.cos(K_POLE * (2 * a - xj - d))) / (2 * K_POLE)
                return 0.5 * (osc + (b - a) * np.sin(K_POLE * (d - xj)))

            dk = (part(lo, mid) - part(mid, hi)) / (0.5 * L_ARRAY)
            out = out + dk * dk
        return (2.0 / 3.0) * out

    def coefficient(self, g, d):
        """Drag coefficient ``c(d, g)`` [N s/m]."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "damper_bars":
            return self.p["c0"] * self._bars(g, d) / self._q
        return self.p["c0"] * field_ratio(g, G_REF) ** 2 * self.imbalance(d)

    def force(self, g, gd, d, dd):
        """Eddy drag ``(0, F_d)`` [N]."""
        fd = -self.coefficient(g, d) * np.asarray(dd, dtype=float)
        return 0.0 * fd, fd


#: The seventh set: one class per effect (library families and new effects), by effect name.
V7_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV7,
        FrictionV7,
        EndEffectV7,
        SaturationV7,
        AmplifierV7,
        CommutationV7,
        EddyDragV7,
        PayloadSwap,
        FlexiblePayload,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V7: tuple[str, ...] = tuple(EFFECTS_V6) + tuple(n for n in V7_LAWS if n not in EFFECTS_V6)
V7_LIBRARY: tuple[str, ...] = tuple(n for n, c in V7_LAWS.items() if c.library)
V7_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V7_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS, V7_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v6, then v7)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V7)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V7)


__all__ = [
    "EFFECTS_V7",
    "G_REF",
    "V7_LAWS",
    "V7_LIBRARY",
    "V7_OUT_OF_LIBRARY",
    "AmplifierV7",
    "CoggingV7",
    "CommutationV7",
    "EddyDragV7",
    "EndEffectV7",
    "FlexiblePayload",
    "FrictionV7",
    "PayloadSwap",
    "SaturationV7",
    "belt_length",
    "law_class",
    "make_law",
]
