"""An eighth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v8"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v7`
has, and two effects outside the library (in :mod:`.laws_v8_ool`), for the next pre-registered blind check. They
were written from their sources only, without reading the diagnosis or how it fits; each class carries ``new_law =
True`` and ``law_set = "v8"`` in its truth record. The source of each law (author, title, venue, year) is in its
docstring and in ``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``force_i``, ``held``,
``rotate``, ``advance``, the state-space amplifier); no hook was added. Each family differs from the earlier ones in
what it depends on: cogging whose pattern trails the motion by a hysteretic play, or with the array's two ends'
detents decaying algebraically with the gap; friction of grease that channels with the travelled path, or of seals
that rub harder one way; the stator's end faces pulling on the passing poles, or the overhang attracting the base
plate; iron whose permeability peaks at a middle flux, or a two-slope magnetization curve; a Bessel current
response or a notch in the command path; a quantized commutation table or stator modules mounted off; shorted coil
formers damping both axes through a full damping tensor, or a plate under the coils dragged by the magnets' and the
currents' field together.
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
from .laws_v6 import V6_LAWS, array_field
from .laws_v7 import EFFECTS_V7, V7_LAWS
from .laws_v8_ool import _V8, DragChain, FloorVibration, per_run
from .physics import NOMINAL, cogging

G_REF = 15e-3  #: reference gap of this set's field-scaled laws (the gap band's lower part) [m]
N_LOOPS = 13  #: shorted formers each side of the centre (the array's reach over the stroke: 248 mm)


def _sinh_a(g):
    """``sinh(pi (hm + g) / tau)``: MODEL.md's field of the array's fundamental is ``~ 1 / sinh``."""
    return np.sinh(K_POLE * (k.hm + np.asarray(g, dtype=float)))


def overhang(d, e_p: float, e_n: float):
    """Length [m] of the array past the stator's ends (``e_p``, ``e_n`` past the array's ends at ``d = 0``)."""
    d = np.asarray(d, dtype=float)
    return np.maximum(d - e_p, 0.0) + np.maximum(-d - e_n, 0.0)


# ----------------------------------------------------------------------------- cogging
class CoggingV8(_V8, Cogging):
    """Cogging whose pattern trails the motion through the teeth's hysteresis, or the detents of the array's ends.

    Both start from the slot-pitch harmonics of the slot openings' energy (the ``pm = 4`` poles over three slots
    per pole cog with the slot pitch ``t1``: Zhu & Howe, "Influence of design parameters on cogging torque in
    permanent magnet machines", IEEE Trans. Energy Convers. 15(4), 2000), each decaying across the gap as a Laplace
    field of its wavenumber: ``a_k(g) = xi0 c_k exp(-2 pi k (g - g_ref) / t1)`` at ``g_ref = 10 mm``, ``W = (t1 / 2
    pi) sum_k (a_k / k) cos theta_k``, ``theta_k = 2 pi k (x - x0) / t1 + phi_k``, ``F_d = sum_k a_k sin theta_k``,
    ``F_g = sum_k a_k cos theta_k`` (``F = -grad W``; ``F_g > 0`` opens the gap).

    * ``hysteretic_teeth`` -- harmonics k = 1, 2, 3 (``c_1 = 1 - |c2| - |c3|``). The teeth's flux follows the
      magnets through the iron's rate-independent hysteresis: the pattern sits at a lagged position ``x = d -
      z``, ``z`` a play of half-width ``delta_h`` (the play operator of hysteresis: Krasnosel'skii & Pokrovskii,
      "Systems with Hysteresis", Springer 1989; the flux's hysteretic lag in soft iron: Bertotti, "Hysteresis in
      Magnetism", Academic Press 1998, ch. 1-2): ``z <- clip(z + v h, -delta_h, delta_h)`` per sub-step (hook
      ``held``). In steady motion the pattern trails by ``delta_h`` against the motion; after a reversal it
      crosses over in ``2 delta_h`` of travel; a small dither does not move it. The static law where ``z = 0``.
    * ``end_pair`` -- the interior harmonics (k = 1, 2, ``c_1 = 1 - |c2|``) plus the detents of the array's two
      ends, each a slot-pitch force of its own amplitude and phase (the detent of a finite part as the sum of its
      two ends' forces: Inoue & Sato, "An approach to a suitable stator length for minimizing the detent force of
      permanent magnet linear synchronous motors", IEEE Trans. Magn. 36(4), 2000). An end's fringe field is that
      of a line of magnetic charge, falling as ``1 / r`` (Furlani, "Permanent Magnet and Electromechanical
      Devices", Academic Press 2001, ch. 4), so its energy falls as ``A_e(g) = xi_e ((g_ref + h_e) / (g +
      h_e))^2``, far slower than the interior harmonics: ``W_e = (t1 / 2 pi) A_e cos(theta_1 + psi_e)`` per end
      ``e = p, n`` (``F_d = A_e sin(...)``, ``F_g = (t1 / 2 pi) 2 A_e / (g + h_e) cos(...)``), conservative.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("hysteretic_teeth", "end_pair")
    _common: ClassVar[dict[str, float]] = {"xi0": 4.0, "c2": 0.3, "phi2": 0.0, "x0": 0.0, "replace": 0.0}
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "hysteretic_teeth": {**_common, "c3": 0.1, "phi3": 0.0, "delta_h": 1e-3},
        "end_pair": {**_common, "xi_p": 0.8, "xi_n": 0.6, "psi_p": 0.0, "psi_n": 1.0, "h_e": 5e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_held = self.family == "hysteretic_teeth"
        self.state = np.zeros(0)
        self.peak = np.zeros(2)

    def reset(self, n_runs: int) -> None:
        """Plays at rest in their middle; no peak yet."""
        self.state = np.zeros(n_runs)
        self.peak = np.zeros(2)

    def harmonics(self, g):
        """``[(k, a_k(g), phi_k)]`` of the family's interior harmonics."""
        p = self.p
        g = np.asarray(g, dtype=float)
        if self.family == "hysteretic_teeth":
            cs = ((1, 1.0 - abs(p["c2"]) - abs(p["c3"]), 0.0), (2, p["c2"], p["phi2"]), (3, p["c3"], p["phi3"]))
        else:
            cs = ((1, 1.0 - abs(p["c2"]), 0.0), (2, p["c2"], p["phi2"]))
        return [(kk, p["xi0"] * c * np.exp(-2 * math.pi * kk * (g - k.g_cog_ref) / k.t1), ph) for kk, c, ph in cs]

    def static(self, g, x):
        """``(F_g, F_d)`` of the interior harmonics with the pattern at position ``x`` [N]."""
        fg = fd = 0.0
        for kk, a, ph in self.harmonics(g):
            th = 2 * math.pi * kk * (np.asarray(x, dtype=float) - self.p["x0"]) / k.t1 + ph
            fg, fd = fg + a * np.cos(th), fd + a * np.sin(th)
        return fg, fd

    def ends(self, g, d):
        """``(F_g, F_d)`` of the two ends' detents (``end_pair``) [N]."""
        p = self.p
        g = np.asarray(g, dtype=float)
        th = 2 * math.pi * (np.asarray(d, dtype=float) - p["x0"]) / k.t1
        fg = fd = 0.0
        for e in ("p", "n"):
            a = p[f"xi_{e}"] * ((k.g_cog_ref + p["h_e"]) / (g + p["h_e"])) ** 2
            fd = fd + a * np.sin(th + p[f"psi_{e}"])
            fg = fg + k.t1 / math.pi * a / (g + p["h_e"]) * np.cos(th + p[f"psi_{e}"])
        return fg, fd

    def held(self, gd, dd, h: float):
        """Advance the play over ``h`` at the horizontal speed; no force of its own."""
        dd = np.asarray(dd, dtype=float)
        if self.state.shape == dd.shape:
            self.state = np.clip(self.state + dd * h, -self.p["delta_h"], self.p["delta_h"])
        return 0.0 * dd, 0.0 * dd

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        d = np.asarray(d, dtype=float)
        if self.family == "hysteretic_teeth":
            fg, fd = self.static(g, d - per_run(self.state, d))
        else:
            fg, fd = self.static(g, d)
            eg, ed = self.ends(g, d)
            fg, fd = fg + eg, fd + ed
        fg, fd = fg + 0.0 * d, fd + 0.0 * np.asarray(g, dtype=float)
        if self.state.shape == d.shape:  # the effect's force against the rig without it, recorded while simulated
            rg, rd = fg, fd
            if self.p["replace"]:
                nx, nn = cogging(g, d, NOMINAL)
                rg, rd = rg + nn, rd - nx
            self.peak = np.maximum(self.peak, [float(np.max(np.abs(rg))), float(np.max(np.abs(rd)))])
        return fg, fd

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (seed eq. (9)'s taken off when replaced, nominal constants)."""
        return {
            "peak_force_n": float(max(self.peak)),
            "peak_force_g_n": float(self.peak[0]),
            "peak_force_d_n": float(self.peak[1]),
        }


# ---------------------------------------------------------------------------- friction
class FrictionV8(_V8, Friction):
    """Friction of grease that channels with the travelled path, or of seals that rub harder one way.

    * ``grease_churning`` -- a freshly greased guide first churns the grease that lies in the balls' path, then
      the grease is pushed aside into channels and the friction falls to its channelled level over the travelled
      path (the churning and channelling phases of grease lubrication: Lugt, "Grease Lubrication in Rolling
      Bearings", Wiley 2013, ch. 4). ``F = -(Fc (1 + a exp(-s / s_c)) tanh(v / v_reg) + b v)``, ``s`` the path
      travelled on the axis since the run began (``s <- s + |v| h`` per sub-step, hook ``held``; the grease flows
      back between runs, so each run starts churning): a friction that falls during the run, not with the speed.
    * ``seal_asymmetric`` -- a lip seal or wiper on the carriage rubs with a contact-pressure profile that is
      steeper on one side of the lip, so its friction depends on the direction of sliding (Muller & Nau, "Fluid
      Sealing Technology: Principles and Applications", Marcel Dekker 1998, ch. 5; direction-dependent friction:
      Armstrong-Helouvry, "Control of Machines with Friction", Kluwer 1991): ``F = -(tanh(v / v_reg) (F_p S(v) +
      F_n (1 - S(v))) + b v)``, ``S(v) = (1 + tanh(v / v_reg)) / 2``: ``-F_p`` sliding towards +, ``+F_n``
      towards -, zero at rest: an even part of the friction in the speed.
    """

    families = ("grease_churning", "seal_asymmetric")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "grease_churning": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "a_g": 1.0,
            "a_d": 1.0,
            "s_c": 0.05,
            "b_g": 0.5,
            "b_d": 0.5,
            "v_reg": 1e-3,
        },
        "seal_asymmetric": {
            "Fp_g": 0.2,
            "Fn_g": 0.1,
            "Fp_d": 0.1,
            "Fn_d": 0.25,
            "b_g": 0.5,
            "b_d": 0.5,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "seal_asymmetric"
        self.has_held = not self.has_force
        self.state = np.zeros((0, 2))

    def reset(self, n_runs: int) -> None:
        """No path travelled yet."""
        self.state = np.zeros((n_runs, 2))

    def force(self, g, gd, d, dd):
        """Direction-dependent friction on both axes [N]."""
        p = self.p
        out = []
        for v, ax in ((gd, "g"), (dd, "d")):
            v = np.asarray(v, dtype=float)
            sg = np.tanh(v / p["v_reg"])
            level = p[f"Fp_{ax}"] * 0.5 * (1.0 + sg) + p[f"Fn_{ax}"] * 0.5 * (1.0 - sg)
            out.append(-(level * sg + p[f"b_{ax}"] * v))
        return out[0], out[1]

    def held(self, gd, dd, h: float):
        """Advance the travelled paths over ``h``; return the friction held over it (at the sub-step's mid path)."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            ok = v.ndim == 1 and self.state.shape[0] == v.shape[0]
            s0 = self.state[:, j] if ok else np.zeros_like(v)
            s_mid = s0 + 0.5 * np.abs(v) * h
            if ok:
                self.state[:, j] = s0 + np.abs(v) * h
            level = p[f"Fc_{ax}"] * (1.0 + p[f"a_{ax}"] * np.exp(-s_mid / p["s_c"]))
            out.append(-(level * np.tanh(v / p["v_reg"]) + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
class EndEffectV8(_V8, EndEffect):
    """End effects: the stator's end faces pulling on the passing poles, or the overhang attracting the base plate.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``: at ``x_p = L/2 + e_p`` and ``-x_n``,
    ``x_n = L/2 + e_n`` (``L`` the array's length).

    * ``end_face`` -- the energy of the array's field over the stator iron, ``W = -c int_{-x_n}^{x_p} Bz(x - d,
      g)^2 dx``, with ``Bz`` the exact 2-D field of the four alternating magnets (:func:`.laws_v6.array_field`,
      their ends included) gives a longitudinal force at each end face, ``F_d = -dW/dd = -c (Bz(x_p - d, g)^2 -
      Bz(-x_n - d, g)^2)``, that pulls the array back over the stator and ripples with the poles as they pass the
      face (``Bz^2`` dips between magnets): the end detent of a finite stator (Gieras, Piech & Tomczuk, "Linear
      Synchronous Motors", 2nd ed., CRC Press 2011, ch. on detent force; field: Furlani 2001, ch. 4). ``c`` is
      set by ``F_e``, the force at a face with the field's peak over it at ``G_REF = 15 mm``; the face's share of
      the pull is left out (``F_g = 0``).
    * ``base_plate`` -- beyond the stator's ends the overhanging magnets do not lose all their pull: they attract
      the steel base plate the stator stands on, ``h_f`` below the stator's surface (the pull of a magnet on a
      steel plate ``~ B^2`` at the plate: Furlani 2001, ch. 4; MODEL.md's field ``~ 1/sinh(pi (hm + g)/tau)``).
      With ``o = 1 - (overhang) / L``: the magnets' pull ``P = o + (1 - o) r(g)``, ``r = (sinh a(g) / sinh a(g +
      h_f))^2``, the currents' force (no winding over the plate) ``o`` (hook ``factors``: ``rho = o``, ``km =
      sqrt(P / o)``, ``kc = 1 / km``; the small ``C4`` term keeps ``o / km^2``): a loss that the plate makes
      smaller at large gaps, where its extra distance matters less.
    """

    families = ("end_face", "base_plate")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "end_face": {"e_p": 0.02, "e_n": 0.03, "F_e": 1.5},
        "base_plate": {"e_p": 0.02, "e_n": 0.03, "h_f": 0.01},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_factors = self.family == "base_plate"
        self.has_force = self.family == "end_face"
        u = np.linspace(0.0, 0.5 * L_ARRAY + 0.02, 2001)
        self._b2 = float(np.max(array_field(u, G_REF) ** 2))

    def face_force(self, g, d):
        """``F_d`` [N] of ``end_face``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        xp, xn = 0.5 * L_ARRAY + p["e_p"], 0.5 * L_ARRAY + p["e_n"]
        b2 = array_field(xp - d, g) ** 2 - array_field(-xn - d, g) ** 2
        return -p["F_e"] * b2 / self._b2

    def force(self, g, gd, d, dd):
        """End faces' pull ``(0, F_d)`` [N] (``end_face``)."""
        fd = self.face_force(g, d)
        return 0.0 * fd, fd

    def overlap(self, d):
        """``o = 1 - (overhang) / L``."""
        return 1.0 - overhang(d, self.p["e_p"], self.p["e_n"]) / L_ARRAY

    def plate_ratio(self, g):
        """``r(g)``: the pull of a magnet over the plate against over the stator."""
        return (_sinh_a(g) / _sinh_a(np.asarray(g, dtype=float) + self.p["h_f"])) ** 2

    def pull(self, g, d):
        """The magnets' pull as a fraction of the full stator's: ``o + (1 - o) r(g)``."""
        o = self.overlap(d)
        return o + (1.0 - o) * self.plate_ratio(g)

    def factors(self, g, d, f: list) -> None:
        """``rho = o``, ``km = sqrt(P / o)``, ``kc = 1 / km`` (``base_plate``)."""
        o = self.overlap(d)
        km = np.sqrt(self.pull(g, d) / o)
        f[0] = f[0] * km
        f[1] = f[1] / km
        f[2] = f[2] * o


# --------------------------------------------------------------------------- saturation
class SaturationV8(_V8, Saturation):
    """Iron whose permeability peaks at a middle flux, or a two-slope magnetization curve.

    * ``permeability_peak`` -- the stator iron's relative permeability is not monotone in the flux density: it
      rises from its initial value at low fields (Rayleigh, "On the behaviour of iron and steel under the operation
      of feeble magnetic forces", Phil. Mag. 23, 1887), peaks, and falls into saturation (Bozorth, "Ferromagnetism",
      Van Nostrand 1951, ch. 2: the permeability curve); a log-normal bump ``mu(b) = exp(-(ln(b / b_m))^2 / (2
      s^2))`` (peak 1 at ``b_m``; ``s = s_lo`` below it, the gentle rise, ``s = s_hi`` above, the fall into
      saturation) for the iron's flux ``b = B(g) / B(g_lo)`` (MODEL.md's field of the magnets,
      1 at the lower stop). The iron's reluctance ``r / mu`` in series with the gap's: ``km = kc = (1 + r) / (1 +
      r / mu(b))`` (hook ``factors``): 1 at the gap where the iron is best, a loss towards the lower stop
      (saturation) and towards the upper one (low permeability): not monotone in the gap.
    * ``two_slope`` -- the iron's magnetization curve as its two-slope (piecewise-linear) approximation: the
      iron carries the flux with a negligible magnetic voltage up to its knee ``b_s`` and beyond it only with the
      incremental slope ``m`` of the saturated material (the linear-plus-saturated approximation of the
      magnetization curve: Slemon, "Electric Machines and Drives", Addison-Wesley 1992, ch. 1; Fitzgerald,
      Kingsley & Umans, "Electric Machinery", 6th ed., McGraw-Hill 2003, ch. 1), the corner rounded over ``w_s``:
      ``t(b) = b - (1 - m) w_s ln(1 + exp((b - b_s) / w_s))``, ``b = B(g) / B(g_lo)``; the field through the
      iron is ``t(b)``, ``km = kc = t(b) / b`` (hook ``factors``). Nothing is lost above the knee's gap; below it
      the flux grows only with the slope ``m``, so the pull ``~ t(b)^2`` flattens towards a ceiling (no plateau
      of the fractional loss, which keeps growing as the gap closes).
    """

    families = ("permeability_peak", "two_slope")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "permeability_peak": {"r": 0.04, "b_m": 0.5, "s_lo": 0.6, "s_hi": 0.55, "target": "both"},
        "two_slope": {"b_s": 0.7, "m": 0.3, "w_s": 0.03, "target": "both"},
    }

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")

    def permeability(self, b):
        """``mu(b)`` relative to its peak (``permeability_peak``)."""
        p = self.p
        u = np.log(np.asarray(b, dtype=float) / p["b_m"])
        s = np.where(u < 0.0, p["s_lo"], p["s_hi"])
        return np.exp(-(u**2) / (2.0 * s**2))

    def iron_flux(self, b):
        """``t(b)`` of ``two_slope``."""
        p = self.p
        b = np.asarray(b, dtype=float)
        return b - (1.0 - p["m"]) * p["w_s"] * np.logaddexp(0.0, (b - p["b_s"]) / p["w_s"])

    def field_factor(self, g):
        """``km = kc`` at gap ``g``."""
        b = field_ratio(g, G_STOP_LO)
        if self.family == "two_slope":
            return self.iron_flux(b) / b
        r = self.p["r"]
        return (1.0 + r) / (1.0 + r / self.permeability(b))

    def loss(self, g):
        """Fraction of the magnets' pull lost at gap ``g``."""
        return 1.0 - self.field_factor(g) ** 2

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field through the iron."""
        kk = self.field_factor(g)
        f[0] = f[0] * kk
        f[1] = f[1] * kk


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV8(_V8, AmplifierV3):
    """A current response with a maximally flat delay, or a current loop with a notch filter in its command path.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``bessel4`` -- the current loop and its output filter designed for a flat group delay: a fourth-order
      Bessel (Thomson) response, ``105 / (T^4 s^4 + 10 T^3 s^3 + 45 T^2 s^2 + 105 T s + 105)`` (Thomson, "Delay
      networks having maximally flat frequency characteristics", Proc. IEE 96(44), 1949): its group delay is
      ``T`` and stays flat up to near its -3 dB frequency ``~ 2.11 / (2 pi T)``; it looks like a pure delay with a
      soft roll-off.
    * ``notch_filtered`` -- a first-order loop ``wc / (s + wc)`` behind a notch filter that the integrator put in
      the command path to keep a structural resonance out of the currents (Ellis, "Control System Design Guide",
      4th ed., Butterworth-Heinemann 2012, ch. 9): ``(s^2 + 2 zeta_z wn s + wn^2) / (s^2 + 2 zeta_p wn s +
      wn^2)``, a dip of depth ``zeta_z / zeta_p`` at ``wn``; group delay ``1 / wc + 2 (zeta_p - zeta_z) / wn``.
    """

    families = ("bessel4", "notch_filtered")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "bessel4": {"T": 6e-4, "delay_samples": 0.0},
        "notch_filtered": {
            "bandwidth_hz": 300.0,
            "notch_hz": 150.0,
            "zeta_p": 0.3,
            "zeta_z": 0.03,
            "delay_samples": 0.0,
        },
    }

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` (inputs ``[u, v]``, the second unused), in well-scaled states.

        ``bessel4``: the companion form of the normalized polynomial ``s^4 + 10 s^3 + 45 s^2 + 105 s + 105`` in the
        time ``t / T`` (``A = A_n / T``, ``B = B_n / T``). ``notch_filtered``: the notch as ``1 + 2 (zeta_z -
        zeta_p) wn s / (s^2 + 2 zeta_p wn s + wn^2)`` (states ``x1' = wn x2``, ``x2' = -wn x1 - 2 zeta_p wn x2 +
        wn u``) into the lag ``x3' = wc (u + 2 (zeta_z - zeta_p) x2 - x3)``, output ``x3``.
        """
        p = self.p
        if self.family == "bessel4":
            T = p["T"]
            A = np.zeros((4, 4))
            A[:-1, 1:] = np.eye(3)
            A[-1, :] = [-105.0, -105.0, -45.0, -10.0]
            B = np.zeros((4, 2))
            B[-1, 0] = 1.0
            return A / T, B / T, np.array([105.0, 0.0, 0.0, 0.0])
        wc, wn = 2 * math.pi * p["bandwidth_hz"], 2 * math.pi * p["notch_hz"]
        dz = 2.0 * (p["zeta_z"] - p["zeta_p"])
        A = np.array([[0.0, wn, 0.0], [-wn, -2 * p["zeta_p"] * wn, 0.0], [0.0, wc * dz, -wc]])
        B = np.array([[0.0, 0.0], [wn, 0.0], [wc, 0.0]])
        return A, B, np.array([0.0, 0.0, 1.0])

    def dc_gain(self) -> float:
        """Static gain of the command-to-current response."""
        return 1.0

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        p = self.p
        if self.family == "bessel4":
            lag = p["T"]
        else:
            lag = 1.0 / (2 * math.pi * p["bandwidth_hz"]) + 2.0 * (p["zeta_p"] - p["zeta_z"]) / (
                2 * math.pi * p["notch_hz"]
            )
        return p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
def smooth_saw(w, r: float):
    """``round(w) - w``, the Fourier series ``(1/pi) sum_n sin(n x) / n`` with ``x = 2 pi (w + 1/2)``, each term
    damped by ``r^n`` and summed in closed form: ``(1/pi) atan2(r sin x, 1 - r cos x)`` (the exact sawtooth for
    ``r -> 1``; ``r < 1`` rounds its steps)."""
    x = 2 * math.pi * (np.asarray(w, dtype=float) + 0.5)
    return np.arctan2(r * np.sin(x), 1.0 - r * np.cos(x)) / math.pi


class CommutationV8(_V8, CommutationOffset):
    """Commutation angle errors of a quantized commutation table, or of stator modules mounted off their places.

    * ``angle_table`` -- the drive looks the electrical angle up in a table of ``N`` entries per electrical period
      (or a coarse angle counter): the angle used is ``(2 pi / N) Q(N theta / 2 pi)``, ``Q`` rounding to the
      nearest entry (``m = 0``) or truncating (``m = 1``), ``theta = pi d / tau + theta0`` (the position sensor's
      resolution as a source of force ripple: Jahns & Soong, "Pulsating torque minimization techniques for
      permanent magnet AC motor drives - a review", IEEE Trans. Ind. Electron. 43(2), 1996). ``delta = delta0 +
      (2 pi / N) (saw(u - m/2) - m/2)``, ``u = N theta / 2 pi``, ``saw(w) = round(w) - w`` smoothed at the steps
      (:func:`smooth_saw`, ``r_s``): a sawtooth of period ``2 tau / N`` and peak ``pi / N`` (mean ``-pi / N`` when
      truncating).
    * ``module_offsets`` -- a long stator built of modules of length ``l_m`` (boundaries ``x_b + j l_m``), each
      mounted ``e_j`` off its place along d, so its coils' electrical angle is off by ``eps_j = (pi / tau) e_j``
      (modular stators of long PMLSMs: Gieras, Piech & Tomczuk 2011); the array's force is the sum over the modules
      under it, so the angle error is their mean weighted by the array's overlap with each: ``delta = delta0 +
      sum_j eps_j |[d - L/2, d + L/2] cap module_j| / L``: piecewise linear along d, with breaks where the array's
      ends cross module joints, no period.
    """

    families = ("angle_table", "module_offsets")
    N_MOD = 6  #: modules ``j = 0 .. 5`` from ``x_b - 3 l_m`` (covering the array over the stroke)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "angle_table": {"delta0": 0.0, "N": 48.0, "m": 0.0, "theta0": 0.0, "r_s": 0.95},
        "module_offsets": {
            "delta0": 0.0,
            "l_m": 2 * k.tau,
            "x_b": 0.0,
            **{f"eps_{j}": e for j, e in enumerate((0.03, -0.01, 0.02, -0.03, 0.01, 0.0))},
        },
    }

    def weights(self, d):
        """Overlap of the array with each module over ``L`` (last axis: modules)."""
        p = self.p
        d = np.asarray(d, dtype=float)[..., None]
        lo = p["x_b"] + (np.arange(self.N_MOD) - 3) * p["l_m"]
        a = np.maximum(d - 0.5 * L_ARRAY, lo)
        b = np.minimum(d + 0.5 * L_ARRAY, lo + p["l_m"])
        return np.maximum(b - a, 0.0) / L_ARRAY

    def angle(self, d):
        """Electrical angle error [rad] at position ``d``."""
        p = self.p
        d = np.asarray(d, dtype=float)
        if self.family == "angle_table":
            n, m = p["N"], p["m"]
            u = n * (K_POLE * d + p["theta0"]) / (2 * math.pi)
            return p["delta0"] + 2 * math.pi / n * (smooth_saw(u - 0.5 * m, p["r_s"]) - 0.5 * m)
        eps = np.array([p[f"eps_{j}"] for j in range(self.N_MOD)])
        return p["delta0"] + self.weights(d) @ eps


# --------------------------------------------------------------------------- eddy drag
def _g_prim(s, y):
    """``int atan(s / y) ds = s atan(s / y) - (y / 2) ln(s^2 + y^2)``."""
    return s * np.arctan(s / y) - 0.5 * y * np.log(s * s + y * y)


def array_flux(x1, x2, y):
    """``int_{x1}^{x2} Bz(x, y) dx`` of :func:`.laws_v6.array_field` (its units times m), in closed form."""
    a = 0.5 * k.taup
    out = 0.0
    for j in range(k.pm):
        c = (j - 0.5 * (k.pm - 1)) * k.tau
        for yy, sgn in ((y, 1.0), (y + k.hm, -1.0)):
            for x, sx in ((x2, 1.0), (x1, -1.0)):
                u = x - c
                out = out + (-1.0) ** j * sgn * sx * (_g_prim(u + a, yy) - _g_prim(u - a, yy))
    return out


def array_flux_dy(x1, x2, y):
    """``d/dy`` of :func:`array_flux` (``d/dy int atan(s/y) ds = -1 - ln(s^2 + y^2) / 2``; the -1 cancels)."""
    a = 0.5 * k.taup
    out = 0.0
    for j in range(k.pm):
        c = (j - 0.5 * (k.pm - 1)) * k.tau
        for yy, sgn in ((y, 1.0), (y + k.hm, -1.0)):
            for x, sx in ((x2, 1.0), (x1, -1.0)):
                u = x - c
                out = out - 0.5 * (-1.0) ** j * sgn * sx * (
                    np.log((u + a) ** 2 + yy * yy) - np.log((u - a) ** 2 + yy * yy)
                )
    return out


class EddyDragV8(_V8, EddyDrag):
    """Eddy drag of shorted coil formers (both axes, a full damping tensor), or of a plate under the coils.

    Low speed (the circuits' ``L / R`` lag left out).

    * ``shorted_formers`` -- each coil is wound on a conducting (aluminium) former, a shorted turn around a pole
      pitch of the stator, ``[x0 + b t1, x0 + b t1 + tau]`` for every slot ``b``. The array's flux through former
      ``b``, ``phi_b(d, g) = LA int Bz dx`` (the exact 2-D field, :func:`array_flux`, closed form), changes with
      both coordinates, drives ``(grad phi_b . v) / R_b`` round it, and the current's force is ``-(grad phi_b)
      (grad phi_b . v) / R_b`` (lumped electromechanics of a shorted circuit with flux linkage ``lambda(x)``:
      Woodson & Melcher, "Electromechanical Dynamics, Part I", Wiley 1968, ch. 3): ``F = -C v``, ``C = (c0 / Q)
      sum_b grad phi_b grad phi_b^T`` a symmetric 2x2 tensor that depends on ``d`` and ``g``: a gap speed makes a
      force along d and the reverse. ``Q`` normalizes so that ``c0`` is ``C_dd``'s mean over ``d`` at ``G_REF``.
    * ``armature_plate`` -- a conducting plate (a cooling plate) under the coils, at depth ``h_p`` below the
      stator's surface, sees the magnets' field and the armature's, both travelling with the mover (the dq currents
      are synchronous with it), so its eddy drag grows with their vector sum (the travelling armature field over a
      conducting secondary: Boldea & Nasar, "Linear Electric Actuators and Generators", Cambridge Univ. Press 1997;
      the thin sheet's low-speed drag ``~ sigma t B^2 v``: Reitz, J. Appl. Phys. 41(5), 1970): ``F_d = -c0 ((b(g) -
      kappa_d i_d)^2 + (kappa_q i_q)^2) d_dot``, ``b = sinh a(G_REF + h_p) / sinh a(g + h_p)`` (the magnets' part
      falls with the gap, the currents' does not); ``i_d`` along the magnets' axis (it weakens the pull in seed eq.
      (2)), ``i_q`` across it (hook ``force_i``, carried currents).
    """

    families = ("shorted_formers", "armature_plate")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "shorted_formers": {"c0": 10.0, "x0": 0.0},
        "armature_plate": {"c0": 8.0, "h_p": 0.01, "kappa_d": 0.08, "kappa_q": 0.08},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family == "shorted_formers"
        self.has_force_i = not self.has_force
        if self.has_force:
            u = np.linspace(0.0, k.t1, 64, endpoint=False)
            self._q = float(np.mean(np.sum(self.gradients(np.full_like(u, G_REF), u)[1] ** 2, axis=-1)))

    def gradients(self, g, d):
        """``(dphi/dg, dphi/dd)`` of every former (last axis), in :func:`.laws_v6.array_field`'s units times m."""
        g, d = np.asarray(g, dtype=float)[..., None], np.asarray(d, dtype=float)[..., None]
        x1 = self.p["x0"] + np.arange(-N_LOOPS, N_LOOPS + 1) * k.t1
        x2 = x1 + k.tau
        y = g + 0.0 * d
        pd = -(array_field(x2 - d, y) - array_field(x1 - d, y))
        pg = array_flux_dy(x1 - d, x2 - d, y)
        return pg, pd

    def tensor(self, g, d):
        """``C`` [N s/m] as ``((C_gg, C_gd), (C_dg, C_dd))``."""
        pg, pd = self.gradients(g, d)
        c = self.p["c0"] / self._q
        cgg, cgd, cdd = (c * np.sum(x, axis=-1) for x in (pg * pg, pg * pd, pd * pd))
        return (cgg, cgd), (cgd, cdd)

    def force(self, g, gd, d, dd):
        """Drag ``(F_g, F_d) = -C v`` [N] (``shorted_formers``)."""
        (cgg, cgd), (_, cdd) = self.tensor(g, d)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        return -(cgg * gd + cgd * dd), -(cgd * gd + cdd * dd)

    def coefficient(self, g, i_q, i_d):
        """Drag coefficient [N s/m] of ``armature_plate``."""
        p = self.p
        b = _sinh_a(G_REF + p["h_p"]) / _sinh_a(np.asarray(g, dtype=float) + p["h_p"])
        return p["c0"] * ((b - p["kappa_d"] * np.asarray(i_d)) ** 2 + (p["kappa_q"] * np.asarray(i_q)) ** 2)

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """Drag ``(0, F_d)`` [N] for the carried currents (``armature_plate``)."""
        fd = -self.coefficient(g, i_q, i_d) * np.asarray(dd, dtype=float)
        return 0.0 * fd, fd


#: The eighth set: one class per effect (library families and new effects), by effect name.
V8_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV8,
        FrictionV8,
        EndEffectV8,
        SaturationV8,
        AmplifierV8,
        CommutationV8,
        EddyDragV8,
        FloorVibration,
        DragChain,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V8: tuple[str, ...] = tuple(EFFECTS_V7) + tuple(n for n in V8_LAWS if n not in EFFECTS_V7)
V8_LIBRARY: tuple[str, ...] = tuple(n for n, c in V8_LAWS.items() if c.library)
V8_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V8_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS, V7_LAWS, V8_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v7, then v8)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V8)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V8)


__all__ = [
    "EFFECTS_V8",
    "G_REF",
    "V8_LAWS",
    "V8_LIBRARY",
    "V8_OUT_OF_LIBRARY",
    "AmplifierV8",
    "CoggingV8",
    "CommutationV8",
    "DragChain",
    "EddyDragV8",
    "EndEffectV8",
    "FloorVibration",
    "FrictionV8",
    "SaturationV8",
    "array_flux",
    "array_flux_dy",
    "law_class",
    "make_law",
    "overhang",
    "smooth_saw",
]
