"""A seventeenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v17"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v16`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v17_drive`), and two effects outside the
library (in :mod:`.laws_v17_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v17"`` in
its truth record. The source of each law (author, title, venue, year) is in its docstring and in
``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``force``, ``rotate_at``, ``read_at``, the state-space
amplifier); no hook was added.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Cogging, EndEffect, Friction, Law, Saturation, build_law, resolve_law
from .laws_v4 import L_ARRAY
from .laws_v12 import flux
from .laws_v13_drive import field_ratio
from .laws_v16 import EFFECTS_V16
from .laws_v16 import REGISTRIES as REGISTRIES_V16
from .laws_v17_drive import AmplifierV17, CommutationV17, EddyDragV17
from .laws_v17_ool import _V17, K_FIELD, HangingCable, ProbeTargetEdge, window, window_slope

_TWO_PI = 2.0 * math.pi
STATOR_HALF = 0.17  #: the stator's half-length over which its holes lie [m] (as the sixteenth set's tubes)


# ----------------------------------------------------------------------------- cogging
class CoggingV17(_V17, Cogging):
    """Cogging of slot openings acting as a row of line dipoles, or of the bolt holes through the stator's yoke.

    Both conservative, ``F = -grad W``.

    * ``line_dipoles`` -- each slot opening perturbs the gap's field as a line dipole ``h0`` below the teeth's face;
      a periodic row of them has the closed-form potential of a row of line sources (method of images: Binns,
      Lawrenson & Trowbridge, "The Analytical and Numerical Solution of Electric and Magnetic Fields", Wiley 1992,
      ch. 3; Hague, "Electromagnetic Problems in Electrical Engineering", Oxford 1929): the slot harmonics fall
      geometrically, ``q^n``, ``q = exp(-2 pi (g - 10 mm + h0) / t1)``, summed in closed form: ``W = -(t1 / 4 pi)
      (xi0 / q0) log(1 - 2 q cos th + q^2)``, ``F_d = (xi0 / q0) q sin th / D``, ``F_g = (xi0 / q0) q (cos th - q) /
      D``, ``D = 1 - 2 q cos th + q^2``, ``q0 = q(10 mm)``, ``th = 2 pi (d - x0) / t1``: the force peaks sharply as
      the gap closes.
    * ``yoke_holes`` -- bolt holes through the stator's yoke, ``h_y`` under its face and ``p_b`` apart, take iron
      out of the array's return path: the energy rises by ``E_h`` with the array's field squared at their depth for
      each hole under the array's footprint (its edges blurred over the hole's radius ``l_h``; Furlani, "Permanent
      Magnet and Electromechanical Devices", Academic Press 2001, ch. 3; Gieras, Piech & Tomczuk, "Linear Synchronous
      Motors", 2nd ed., CRC 2011, ch. 2 (the stator's yoke)): ``W = E_h (b(g + h_y) / b(15 mm + h_y))^2 sum_i w(x_i -
      d)``, ``E_h = 2 l_h F_h``, ``F_h`` the largest pull of one hole's edge at 15 mm: a force along d as the array's
      ends pass the holes, and a push away from the stator.
    """

    families = ("line_dipoles", "yoke_holes")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "line_dipoles": {"xi0": 3.0, "h0": 0.004, "x0": 0.0, "replace": 0.0},
        "yoke_holes": {"F_h": 0.4, "h_y": 0.02, "l_h": 0.005, "p_b": 0.06, "x_b": 0.0, "replace": 0.0},
    }

    def holes(self) -> np.ndarray:
        """The holes' places [m]: every ``p_b`` from ``x_b`` over the stator."""
        p = self.p
        n = int(STATOR_HALF / p["p_b"]) + 1
        x = p["x_b"] + p["p_b"] * np.arange(-n, n + 1)
        return x[np.abs(x) <= STATOR_HALF]

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "line_dipoles":
            q0 = math.exp(-_TWO_PI * p["h0"] / k.t1)
            q = np.exp(-_TWO_PI * (g - k.g_cog_ref + p["h0"]) / k.t1)
            th = _TWO_PI * (d - p["x0"]) / k.t1
            den = 1.0 - 2.0 * q * np.cos(th) + q * q
            a = p["xi0"] / q0 * q / den
            return a * (np.cos(th) - q), a * np.sin(th)
        h = p["h_y"]
        depth = g + h
        b2 = (field_ratio(depth) / field_ratio(0.015 + h)) ** 2
        db2 = -2.0 * K_FIELD / np.tanh(K_FIELD * (k.hm + depth)) * b2
        x = self.holes()
        u = x - d[..., None]
        s = np.sum(window(u, 0.5 * L_ARRAY, p["l_h"]), axis=-1)
        ds = -np.sum(window_slope(u, 0.5 * L_ARRAY, p["l_h"]), axis=-1)  # d/dd
        e = 2.0 * p["l_h"] * p["F_h"]
        return -e * db2 * s, -e * b2 * ds


# ---------------------------------------------------------------------------- friction
class FrictionV17(_V17, Friction):
    """Friction of a guide whose rollers are skewed to the travel, or of a greased guide whose grease has banked up
    near the stroke's turning points.

    * ``skewed_rollers`` -- the guide's rollers roll along a direction ``alpha`` off the d axis in the g-d plane:
      along it they resist with a small rolling friction ``F_r``, across it they slide with ``F_l`` (an anisotropic
      limit surface whose axes are turned: Goyal, Ruina & Papadopoulos, "Planar sliding with dry friction", Wear
      143, 1991; Johnson, "Contact Mechanics", Cambridge Univ. Press 1985, ch. 8 (creep of skewed rollers)):
      ``F = -(F_r tanh(u.v / v_reg) u + F_l tanh(n.v / v_reg) n) - (b_g g_dot, b_d d_dot)``, ``u = (cos alpha, sin
      alpha)`` in ``(d, g)``, ``n = (-sin alpha, cos alpha)``: a move along d alone drags the gap axis too.
    * ``grease_banks`` -- the carriage's seals push the grease ahead of them and leave it banked where the moves
      turn, ``x_e`` either side of the middle (channelling; Lugt, "Grease Lubrication in Rolling Bearings", Wiley
      2013, ch. 7; Harris & Kotzalas, "Rolling Bearing Analysis", 5th ed., CRC 2007, ch. 4): the viscous drag along
      d rises over the banks, ``F_d = -(Fc_d tanh(d_dot / v_reg) + (b_d + b_e (e^{-((d - x_e) / w_e)^2} +
      e^{-((d + x_e) / w_e)^2})) d_dot)``, the gap axis plain Coulomb-viscous.
    """

    families = ("skewed_rollers", "grease_banks")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "skewed_rollers": {"F_r": 0.1, "F_l": 0.4, "alpha": 0.03, "b_g": 0.5, "b_d": 0.5, "v_reg": 1e-3},
        "grease_banks": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "b_g": 0.5,
            "b_d": 0.5,
            "b_e": 5.0,
            "x_e": 0.04,
            "w_e": 0.01,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def viscous_d(self, d):
        """The viscous coefficient along d [N s/m] at ``d`` (``grease_banks``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        bank = np.exp(-(((d - p["x_e"]) / p["w_e"]) ** 2)) + np.exp(-(((d + p["x_e"]) / p["w_e"]) ** 2))
        return p["b_d"] + p["b_e"] * bank

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "skewed_rollers":
            c, s = math.cos(p["alpha"]), math.sin(p["alpha"])
            fr = p["F_r"] * np.tanh((c * dd + s * gd) / p["v_reg"])
            fl = p["F_l"] * np.tanh((-s * dd + c * gd) / p["v_reg"])
            fd = -(fr * c - fl * s) - p["b_d"] * dd
            fg = -(fr * s + fl * c) - p["b_g"] * gd
            return fg + 0.0 * (g + d), fd + 0.0 * (g + d)
        fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) + self.viscous_d(d) * dd)
        return fg + 0.0 * (d + dd), fd + 0.0 * (g + gd)


# -------------------------------------------------------------------------- end effects
class EndEffectV17(_V17, EndEffect):
    """End effects of a stator whose ends are cut obliquely across its depth, or of the magnetic poles its ends
    carry.

    The stator's ends lie ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``.

    * ``oblique_ends`` -- each stator end is cut at a slant across the depth, the end's place moving by ``s`` from
      one side of the stack to the other (a measure against the end detent: Gieras, Piech & Tomczuk, "Linear
      Synchronous Motors", 2nd ed., CRC 2011, ch. 9; Boldea & Nasar, "Linear Electric Actuators and Generators",
      Cambridge Univ. Press 1997, ch. 3): the overhanging share, averaged over the depth, grows as ``x^2 / 2 s`` over
      the cut and as ``x - s / 2`` past it, ``x`` the array end's reach past the cut's first corner. Hook
      ``factors``: ``km^2 = km kc = 1 - (loss_p + loss_n) / L``.
    * ``end_poles`` -- the flux that the array drives along the stator cannot close beyond its ends: each end face
      carries a magnetic pole, which acts on the array's nearer end pole as two parallel line poles (the 2-D field
      ``∝ 1/r``, energy ``∝ log r``: Binns, Lawrenson & Trowbridge 1992, ch. 2; Hague 1929), opposite poles
      attracting: ``W = c_e sum_ends log(r_e / r_0)``, ``r_e`` from the array's end pole (``tau / 2`` in from its end,
      ``hm / 2 + g`` above the face) to the stator end's pole (``z_e`` below the face at the end), ``c_e = F_e r_0``,
      ``F_e`` the pull at ``r_0 = tau / 2``; conservative (hook ``force``), strongest as the array's end nears a
      stator end.
    """

    families = ("oblique_ends", "end_poles")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "oblique_ends": {"e_p": 0.02, "e_n": 0.02, "s": 0.02},
        "end_poles": {"e_p": 0.02, "e_n": 0.02, "F_e": 0.5, "z_e": 0.01},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_factors = self.family == "oblique_ends"
        self.has_force = self.family == "end_poles"

    def _lost(self, x):
        """The overhang's share lost [m] at reach ``x`` past the cut's first corner."""
        s = self.p["s"]
        x = np.maximum(np.asarray(x, dtype=float), 0.0)
        return np.where(x < s, x * x / (2.0 * s), x - 0.5 * s)

    def loss(self, d):
        """The fraction of the array's field lost at ``d`` (``oblique_ends``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        return (self._lost(d - p["e_p"]) + self._lost(-d - p["e_n"])) / L_ARRAY

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field at the ends."""
        kk = np.sqrt(1.0 - self.loss(d)) + 0.0 * np.asarray(g, dtype=float)
        f[0] = f[0] * kk
        f[1] = f[1] * kk

    def force(self, g, gd, d, dd):
        """The end poles' force ``(F_g, F_d)`` [N] (``end_poles``)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        r0 = 0.5 * k.tau
        c = p["F_e"] * r0
        dz = 0.5 * k.hm + g + p["z_e"]
        fg = 0.0 * (g + d)
        fd = 0.0 * (g + d)
        for sgn, e in ((1.0, p["e_p"]), (-1.0, p["e_n"])):
            dx = sgn * (0.5 * L_ARRAY + e) - (d + sgn * (0.5 * L_ARRAY - r0))  # stator end's pole less the array's
            r2 = dx * dx + dz * dz
            fd = fd + c * dx / r2  # -dW/dd: towards the stator's end pole
            fg = fg - c * dz / r2  # -dW/dg: towards the stator
        return fg, fd


# --------------------------------------------------------------------------- saturation
def brillouin(j: float, y):
    """Brillouin's function ``B_J(y)``."""
    y = np.asarray(y, dtype=float)
    a, b = (2.0 * j + 1.0) / (2.0 * j), 1.0 / (2.0 * j)
    return a / np.tanh(a * y) - b / np.tanh(b * y)


class SaturationV17(_V17, Saturation):
    """Saturation of teeth whose flux wave is clipped at the iron's saturation, or of iron whose magnetization
    follows Brillouin's function.

    Both scale the magnets' and the currents' field by the field kept, ``k``, at the flux ``x = B(g) / B(g_lo)``
    (MODEL.md's field, 1 at the lower stop). Hook ``factors``, ``km = kc = k``.

    * ``clipped_teeth`` -- the teeth's flux density follows the array's sinusoid until it reaches the iron's
      saturation ``u_s = x(g_k)``, then stays flat: the force follows the clipped wave's fundamental, the describing
      function of a saturation (Gelb & Vander Velde, "Multiple-Input Describing Functions and Nonlinear System
      Design", McGraw-Hill 1968, ch. 2; Hanselman, "Brushless Permanent Magnet Motor Design", 2nd ed., Magna 2006,
      ch. 4): ``k = 1`` for ``x <= u_s``, else ``(2 / pi)(asin r + r sqrt(1 - r^2))``, ``r = u_s / x``; the knee at
      the gap ``g_k``.
    * ``brillouin`` -- the iron's magnetization follows Brillouin's function of its field, ``M = M_s B_J(a H)``
      (quantum number ``J`` between Ising's ``1/2``, ``tanh``, and the classical limit, Langevin's: Brillouin, "Les
      moments de rotation et le magnetisme dans la mecanique ondulatoire", J. Phys. Radium 8, 1927; Kittel,
      "Introduction to Solid State Physics", 8th ed., Wiley 2005, ch. 11): the field kept is the secant
      susceptibility over the initial one, ``k = B_J(a x) / (B_J'(0) a x)``, ``B_J'(0) = (J + 1) / 3J``, ``a`` set
      so that ``k = 1 - l_lo`` at the lower stop.
    """

    families = ("clipped_teeth", "brillouin")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "clipped_teeth": {"g_k": 0.016, "target": "both"},
        "brillouin": {"l_lo": 0.05, "J": 2.0, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")
        if self.family == "brillouin":
            lo, hi = 1e-3, 50.0  # k(1) falls with a: bisection for k(1) = 1 - l_lo
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if self._secant(mid, 1.0) > 1.0 - self.p["l_lo"] else (lo, mid)
            self._a = 0.5 * (lo + hi)

    def _secant(self, a: float, x):
        j = self.p["J"]
        y = np.maximum(a * np.asarray(x, dtype=float), 1e-6)
        return brillouin(j, y) / ((j + 1.0) / (3.0 * j) * y)

    def kept(self, g):
        """The field kept (``km = kc``) at gap ``g``."""
        x = flux(np.asarray(g, dtype=float))
        if self.family == "brillouin":
            return self._secant(self._a, x)
        r = np.minimum(float(flux(self.p["g_k"])) / x, 1.0)
        return 2.0 / math.pi * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and the current field."""
        kk = self.kept(np.asarray(g, dtype=float))
        f[0] = f[0] * kk
        f[1] = f[1] * kk


#: The seventeenth set: one class per effect (library families and new effects), by effect name.
V17_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV17,
        FrictionV17,
        EndEffectV17,
        SaturationV17,
        AmplifierV17,
        CommutationV17,
        EddyDragV17,
        HangingCable,
        ProbeTargetEdge,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V17: tuple[str, ...] = tuple(EFFECTS_V16) + tuple(n for n in V17_LAWS if n not in EFFECTS_V16)
V17_LIBRARY: tuple[str, ...] = tuple(n for n, c in V17_LAWS.items() if c.library)
V17_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V17_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V16, V17_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v16, then v17)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V17)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V17)


__all__ = [
    "EFFECTS_V17",
    "V17_LAWS",
    "V17_LIBRARY",
    "V17_OUT_OF_LIBRARY",
    "AmplifierV17",
    "CoggingV17",
    "CommutationV17",
    "EddyDragV17",
    "EndEffectV17",
    "FrictionV17",
    "HangingCable",
    "ProbeTargetEdge",
    "SaturationV17",
    "law_class",
    "make_law",
]
