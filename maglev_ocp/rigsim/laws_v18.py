"""An eighteenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v18"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v17`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v18_drive`), and two effects outside the
library (in :mod:`.laws_v18_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v18"`` in
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
from .laws_v17 import EFFECTS_V17
from .laws_v17 import REGISTRIES as REGISTRIES_V17
from .laws_v18_drive import AmplifierV18, CommutationV18, EddyDragV18
from .laws_v18_ool import _V18, ExpandingScale, SpringReel

_TWO_PI = 2.0 * math.pi


def triangle_integral(th):
    """The zero-mean integral over ``th`` of the unit triangle wave ``(2 / pi) asin(sin th)``: ``psi^2 / pi - pi /
    4`` on ``|psi| <= pi / 2`` and ``pi / 4 - (psi - pi)^2 / pi`` beyond, ``psi`` the angle wrapped to ``[-pi / 2, 3
    pi / 2)``."""
    psi = np.mod(np.asarray(th, dtype=float) + 0.5 * math.pi, _TWO_PI) - 0.5 * math.pi
    near = psi * psi / math.pi - 0.25 * math.pi
    return np.where(psi < 0.5 * math.pi, near, 0.25 * math.pi - (psi - math.pi) ** 2 / math.pi)


# ----------------------------------------------------------------------------- cogging
class CoggingV18(_V18, Cogging):
    """Cogging as the sum of magnet-edge and slot-edge encounters, a triangle wave, or cogging sized by the magnetic
    circuit's gap flux density squared.

    Both conservative, ``F = -grad W``, ``th = 2 pi (d - x0) / t1``.

    * ``edge_triangle`` -- each magnet edge crossing a tooth edge pulls with a force that grows linearly as the
      overlap of their permeances changes and reverses at the slot's middle: the cogging is a triangle wave (odd
      harmonics falling as ``1 / n^2``; Hanselman, "Brushless Permanent Magnet Motor Design", 2nd ed., Magna 2006,
      ch. 5 (cogging from edge interactions); Gieras & Wing, "Permanent Magnet Motor Technology", 2nd ed., Dekker
      2002, ch. 5): ``F_d = A(g) (2 / pi) asin(sin th)``, ``A = xi0 e^{-2 pi (g - 10 mm) / t1}``, ``W = -A (t1 / 2
      pi) I(th)`` with ``I`` the wave's zero-mean integral (piecewise parabolic), ``F_g = -A I(th)``.
    * ``recoil_circuit`` -- the cogging is the slot permeance's variation times the square of the gap's flux density,
      which the magnetic circuit gives as ``B_g = B_r hm / (hm + mu_r g)`` (the magnet's recoil permeability
      ``mu_r`` in series with the gap; Hendershot & Miller, "Design of Brushless Permanent-Magnet Motors", Magna /
      Oxford 1994, ch. 4; Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press 2001, ch. 3):
      ``W = (t1 / 2 pi) A(g) cos th``, ``A = xi0 ((hm + mu_r 10 mm) / (hm + mu_r g))^2``: ``F_d = A sin th``, ``F_g =
      (t1 / 2 pi) 2 mu_r A cos th / (hm + mu_r g)``.
    """

    families = ("edge_triangle", "recoil_circuit")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "edge_triangle": {"xi0": 3.0, "x0": 0.0, "replace": 0.0},
        "recoil_circuit": {"xi0": 3.0, "mu_r": 1.05, "x0": 0.0, "replace": 0.0},
    }

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        th = _TWO_PI * (d - p["x0"]) / k.t1
        if self.family == "edge_triangle":
            a = p["xi0"] * np.exp(-_TWO_PI * (g - k.g_cog_ref) / k.t1)
            return -a * triangle_integral(th), a * (2.0 / math.pi) * np.arcsin(np.clip(np.sin(th), -1.0, 1.0))
        m = p["mu_r"]
        den = k.hm + m * g
        a = p["xi0"] * ((k.hm + m * k.g_cog_ref) / den) ** 2
        return k.t1 / _TWO_PI * 2.0 * m * a * np.cos(th) / den, a * np.sin(th)


# ---------------------------------------------------------------------------- friction
class FrictionV18(_V18, Friction):
    """Friction of an oil-film damper pad on the gap axis, squeezed and sheared as the gap changes, or of a sliding
    contact whose friction falls as its flash temperature rises with the speed.

    * ``oil_pad`` -- an oil-filled pad rides on a face parallel to the stator, its film ``h = h_m + (g - g_lo)`` thick
      (``h_m`` at the lower stop): a move of the gap squeezes the film, which resists as the cube of its thickness,
      ``3 pi eta R^4 h_dot / 2 h^3`` (parallel plates), and a move along d shears it, ``eta A d_dot / h`` (Couette)
      (Reynolds, "On the theory of lubrication", Phil. Trans. R. Soc. 177, 1886; Hamrock, Schmid & Jacobson,
      "Fundamentals of Fluid Film Lubrication", 2nd ed., Dekker 2004, ch. 10): ``F_g = -(Fc_g tanh(g_dot / v_reg) +
      c_sq (h_15 / h)^3 g_dot)``, ``F_d = -(Fc_d tanh(d_dot / v_reg) + c_sh (h_15 / h) d_dot)``, ``h_15`` the film
      at 15 mm.
    * ``flash_temperature`` -- the frictional heat raises the real contacts' flash temperature as the square root of
      the sliding speed (a moving heat source at high Peclet number) and softens their junctions, the shear strength
      falling with it (Archard, "The temperature of rubbing surfaces", Wear 2(6), 1959; Bowden & Tabor, "The
      Friction and Lubrication of Solids", Oxford 1950, ch. 2): ``F_d = -(Fc_d tanh(d_dot / v_reg) / (1 +
      sqrt(|d_dot| / v_T)) + b_d d_dot)``, ``v_T`` the speed at which the friction has halved; the gap axis plain
      Coulomb-viscous.
    """

    families = ("oil_pad", "flash_temperature")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "oil_pad": {"Fc_g": 0.15, "Fc_d": 0.15, "c_sq": 0.4, "c_sh": 0.5, "h_m": 0.006, "v_reg": 1e-3},
        "flash_temperature": {"Fc_g": 0.15, "Fc_d": 0.2, "b_g": 0.5, "b_d": 0.5, "v_T": 0.2, "v_reg": 1e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def film(self, g):
        """The pad's film over its value at 15 mm, ``h / h_15`` (``oil_pad``)."""
        p = self.p
        return (p["h_m"] + np.asarray(g, dtype=float) - k.g_stop[0]) / (p["h_m"] + 0.015 - k.g_stop[0])

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "oil_pad":
            r = self.film(g)
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["c_sq"] / r**3 * gd)
            fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) + p["c_sh"] / r * dd)
            return fg + 0.0 * (d + dd), fd + 0.0 * (d + gd)
        soft = 1.0 / (1.0 + np.sqrt(np.abs(dd) / p["v_T"]))
        fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) * soft + p["b_d"] * dd)
        return fg + 0.0 * (d + dd), fd + 0.0 * (g + gd)


# -------------------------------------------------------------------------- end effects
class EndEffectV18(_V18, EndEffect):
    """End effects of a stator end whose fringe field spreads over a length set by the gap, or of a yoke whose
    return path near an end adds a series reluctance.

    The stator's ends lie ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``. Hook ``factors``.

    * ``gap_fringe`` -- past a stator end the gap's field does not stop short but fringes out over a length of the
      order of the gap (the fringing permeance of an iron edge: Roters, "Electromagnetic Devices", Wiley 1941, ch.
      5; Hanselman 2006, ch. 3): the overhang's share lost is a softened ramp, ``l(x) = c_f g log(1 + e^{x / (c_f
      g)})`` at reach ``x`` past the end, ``km^2 = km kc = 1 - (l(d - e_p) + l(-d - e_n)) / L``: the loss sets in
      earlier and more softly at larger gaps.
    * ``yoke_return`` -- the array's flux returns along the stator's yoke; as the array nears an end, the yoke
      beyond it is short and the return path adds a reluctance ``r_e`` times the share of the array near the end, a
      logistic in the end's distance over ``lam`` (the magnetic equivalent circuit: Hendershot & Miller 1994, ch. 4;
      Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC 2011, ch. 2): ``km = kc = (1 + r_e (u_p(0)
      + u_n(0))) / (1 + r_e (u_p(d) + u_n(d)))``, ``u_p = 1 / (1 + e^{(e_p - d) / lam})``, ``u_n = 1 / (1 + e^{(e_n +
      d) / lam})``.
    """

    families = ("gap_fringe", "yoke_return")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "gap_fringe": {"e_p": 0.03, "e_n": 0.03, "c_f": 0.5},
        "yoke_return": {"e_p": 0.03, "e_n": 0.03, "r_e": 0.15, "lam": 0.01},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_factors = True
        self.has_force = False

    def _lost(self, x, g):
        s = self.p["c_f"] * g
        z = x / s
        return s * np.where(z > 30.0, z, np.log1p(np.exp(np.minimum(z, 30.0))))

    def kept(self, g, d):
        """``(km, kc)`` at ``(g, d)``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "gap_fringe":
            kk = np.sqrt(1.0 - (self._lost(d - p["e_p"], g) + self._lost(-d - p["e_n"], g)) / L_ARRAY)
            return kk, kk

        def u(x):
            return 1.0 / (1.0 + np.exp(np.clip(x / p["lam"], -60.0, 60.0)))

        ref = 1.0 + p["r_e"] * (u(p["e_p"]) + u(p["e_n"]))
        kk = ref / (1.0 + p["r_e"] * (u(p["e_p"] - d) + u(p["e_n"] + d))) + 0.0 * g
        return kk, kk

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field at the ends."""
        km, kc = self.kept(g, d)
        f[0] = f[0] * km
        f[1] = f[1] * kc


# --------------------------------------------------------------------------- saturation
class SaturationV18(_V18, Saturation):
    """Saturation of iron whose flux follows a soft limiter of adjustable sharpness, or of iron magnetized in Weiss's
    mean field.

    Both scale the magnets' and the currents' field by the field kept, ``k``, at the flux ``x = B(g) / B(g_lo)``
    (MODEL.md's field, 1 at the lower stop). Hook ``factors``, ``km = kc = k``.

    * ``soft_limiter`` -- the flux rises linearly then bends onto its limit with a knee of sharpness ``p``: ``y = x
      / (1 + (x / x_s)^{2p})^{1 / 2p}`` (Rapp's soft limiter: Rapp, "Effects of HPA-nonlinearity on 4-DPSK/OFDM
      signal for a digital sound broadcasting system", ESA SP-332, 1991; the same curve for B(H) of soft iron:
      Jiles, "Introduction to Magnetism and Magnetic Materials", 2nd ed., Chapman & Hall 1998, ch. 5): ``k = y / x
      = (1 + (x / x_s)^{2p})^{-1 / 2p}``, ``x_s`` set so that ``k = 1 - l_lo`` at the lower stop; ``p -> inf`` a
      hard clip.
    * ``weiss_field`` -- the iron's magnetization in Weiss's molecular field, ``m = tanh(a x + lam m)`` (the field
      on a moment the applied one plus ``lam`` times the magnetization; ``lam < 1``, above the Curie point's
      ordering: Weiss, "L'hypothese du champ moleculaire et la propriete ferromagnetique", J. Phys. Theor. Appl. 6,
      1907; Kittel, "Introduction to Solid State Physics", 8th ed., Wiley 2005, ch. 11): the field kept is the
      secant susceptibility over the initial one ``a / (1 - lam)``, ``k = (1 - lam) m / (a x)``, ``a`` set so that
      ``k = 1 - l_lo`` at the lower stop.
    """

    families = ("soft_limiter", "weiss_field")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "soft_limiter": {"l_lo": 0.05, "p": 2.0, "target": "both"},
        "weiss_field": {"l_lo": 0.05, "lam": 0.5, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")
        if self.family == "weiss_field":
            lo, hi = 1e-4, 50.0  # k(1) falls with a: bisection for k(1) = 1 - l_lo
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if self._weiss(mid, 1.0) > 1.0 - self.p["l_lo"] else (lo, mid)
            self._a = 0.5 * (lo + hi)

    def _weiss(self, a: float, x):
        """``k`` for Weiss's field: ``m`` by bisection of the increasing ``m - tanh(a x + lam m)`` on ``[0, 1]``."""
        lam = self.p["lam"]
        x = np.maximum(np.asarray(x, dtype=float), 1e-9)
        lo, hi = np.zeros_like(x), np.ones_like(x)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            up = mid - np.tanh(a * x + lam * mid) > 0.0
            lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
        return (1.0 - lam) * 0.5 * (lo + hi) / (a * x)

    def kept(self, g):
        """The field kept (``km = kc``) at gap ``g``."""
        x = flux(np.asarray(g, dtype=float))
        if self.family == "weiss_field":
            return self._weiss(self._a, x)
        q = 2.0 * self.p["p"]
        xs = ((1.0 - self.p["l_lo"]) ** (-q) - 1.0) ** (-1.0 / q)
        return (1.0 + (x / xs) ** q) ** (-1.0 / q)

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and the current field."""
        kk = self.kept(np.asarray(g, dtype=float)) + 0.0 * np.asarray(d, dtype=float)
        f[0] = f[0] * kk
        f[1] = f[1] * kk


#: The eighteenth set: one class per effect (library families and new effects), by effect name.
V18_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV18,
        FrictionV18,
        EndEffectV18,
        SaturationV18,
        AmplifierV18,
        CommutationV18,
        EddyDragV18,
        SpringReel,
        ExpandingScale,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V18: tuple[str, ...] = tuple(EFFECTS_V17) + tuple(n for n in V18_LAWS if n not in EFFECTS_V17)
V18_LIBRARY: tuple[str, ...] = tuple(n for n, c in V18_LAWS.items() if c.library)
V18_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V18_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V17, V18_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v17, then v18)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V18)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V18)


__all__ = [
    "EFFECTS_V18",
    "V18_LAWS",
    "V18_LIBRARY",
    "V18_OUT_OF_LIBRARY",
    "AmplifierV18",
    "CoggingV18",
    "CommutationV18",
    "EddyDragV18",
    "EndEffectV18",
    "ExpandingScale",
    "FrictionV18",
    "SaturationV18",
    "SpringReel",
    "law_class",
    "make_law",
    "triangle_integral",
]
