"""A sixteenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v16"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v15`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v16_drive`), and two effects outside the
library (in :mod:`.laws_v16_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v16"`` in
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
from .laws_v15 import EFFECTS_V15
from .laws_v15 import REGISTRIES as REGISTRIES_V15
from .laws_v16_drive import AmplifierV16, CommutationV16, EddyDragV16
from .laws_v16_ool import _V16, K_FIELD, FerrousDebris, ScaleJoint

_TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- cogging
class CoggingV16(_V16, Cogging):
    """Cogging of magnets with shaped (bread-loaf) edges, or a detent from the stator iron's remanence.

    Both conservative, ``F = -grad W``.

    * ``bread_loaf`` -- the magnets' edges are shaped (thinned over ``w_c`` at each edge), so each edge's step in
      the gap's permeance becomes a ramp ``w_c`` long: the edge's slot harmonics, falling as ``1/n`` for a sharp
      edge, are each multiplied by ``sinc(n w_c / t1)`` (a ramp is a step averaged over its length; Bianchi &
      Bolognani, "Design techniques for reducing the cogging torque in surface-mounted PM motors", IEEE Trans. Ind.
      Appl. 38(5), 2002; Zhu & Howe, "Influence of design parameters on cogging torque in permanent magnet machines",
      IEEE Trans. Energy Convers. 15(4), 2000): ``a_n = sinc(n w_c / t1) / (n sinc(w_c / t1))``, ``e_n =
      exp(-2 pi n (g - 10 mm) / t1)``, ``W = (t1 / 2 pi) xi0 sum_{n<=3} a_n e_n cos(n th) / n``, ``F_d = xi0 sum a_n
      e_n sin(n th)``, ``F_g = xi0 sum a_n e_n cos(n th)``, ``th = 2 pi (d - x0) / t1``.
    * ``stator_remanence`` -- the stator's yoke keeps a remanent magnetization at the array's pole pitch (left by a
      fault current or by the array parked over it; Bozorth, "Ferromagnetism", Van Nostrand 1951, ch. 11;
      Chikazumi, "Physics of Ferromagnetism", 2nd ed., Oxford 1997, ch. 18): its poles hold the array's poles with
      the energy ``W = -(tau / pi) xi_r r(g) cos(pi (d - x_r) / tau)``, ``r = B(g) / B(15 mm)`` the array's
      fundamental at the gap: a detent at the pole pair's period ``2 tau``, ``F_d = -xi_r r sin(pi (d - x_r) /
      tau)``, ``F_g = -(tau / pi) xi_r k coth(k (hm + g)) r cos(...)`` (towards the stator where the poles face).
    """

    families = ("bread_loaf", "stator_remanence")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "bread_loaf": {"xi0": 3.0, "w_c": 0.005, "x0": 0.0, "replace": 0.0},
        "stator_remanence": {"xi_r": 0.5, "x_r": 0.0, "replace": 0.0},
    }

    def harmonics(self) -> np.ndarray:
        """``a_1 .. a_3`` (``bread_loaf``)."""
        n = np.arange(1, 4)
        return np.sinc(n * self.p["w_c"] / k.t1) / (n * np.sinc(self.p["w_c"] / k.t1))

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "bread_loaf":
            th = _TWO_PI * (d - p["x0"]) / k.t1
            fg = 0.0 * (g + th)
            fd = 0.0 * (g + th)
            for n, a in enumerate(self.harmonics(), start=1):
                e = p["xi0"] * a * np.exp(-_TWO_PI * n * (g - k.g_cog_ref) / k.t1)
                fd = fd + e * np.sin(n * th)
                fg = fg + e * np.cos(n * th)
            return fg, fd
        ph = math.pi * (d - p["x_r"]) / k.tau
        r = field_ratio(g)
        fd = -p["xi_r"] * r * np.sin(ph)
        fg = -(k.tau / math.pi) * p["xi_r"] * K_FIELD / np.tanh(K_FIELD * (k.hm + g)) * r * np.cos(ph)
        return fg, fd


# ---------------------------------------------------------------------------- friction
def _softplus(x, w: float):
    """``w log(1 + exp(x / w))``: a smooth ``max(x, 0)`` over ``w``."""
    return w * np.logaddexp(0.0, np.asarray(x, dtype=float) / w)


class FrictionV16(_V16, Friction):
    """Friction of a wiper lip pressed against the stator's face, or of a guide on a bowed rail.

    * ``lip_wiper`` -- an elastomer wiper on the mover rubs the stator's face; it touches below the gap ``h_w`` and
      is compressed by ``c = max(h_w - g, 0)`` (smoothed over 0.5 mm), pushing the gap open with ``k_w c`` and
      rubbing along d with Amontons' ``mu_w k_w c`` (seal and wiper friction: Muller & Nau, "Fluid Sealing
      Technology", Marcel Dekker 1998, ch. 9; Bowden & Tabor, "The Friction and Lubrication of Solids", Clarendon
      1950, ch. 5): ``F_g = k_w c - (Fc_g tanh(g_dot / v_reg) + b_g g_dot)``, ``F_d = -((Fc_d + mu_w k_w c)
      tanh(d_dot / v_reg) + b_d d_dot)``; the lip's push is conservative, its rub is not.
    * ``bowed_rail`` -- the guide's rail is bowed (its mounting face not flat) with a sagitta over its half-length
      ``l_b``: the carriage's interference and so its preload follow the bow, ``P(d) = 1 + kappa (1 - ((d - x_b) /
      l_b)^2)``, and the balls' Hertzian load goes as the interference to the 3/2 (Johnson, "Contact Mechanics",
      Cambridge Univ. Press 1985, ch. 4; mounting-surface errors of profile rail guides: Slocum, "Precision Machine
      Design", Prentice Hall 1992, ch. 8): ``F_d = -(Fc_d P^{3/2} tanh(d_dot / v_reg) + b_d d_dot)``, the gap axis
      plain Coulomb-viscous.
    """

    families = ("lip_wiper", "bowed_rail")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "lip_wiper": {
            "Fc_g": 0.1,
            "Fc_d": 0.1,
            "b_g": 0.5,
            "b_d": 0.5,
            "k_w": 80.0,
            "mu_w": 0.5,
            "h_w": 0.018,
            "v_reg": 1e-3,
        },
        "bowed_rail": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "b_g": 0.5,
            "b_d": 0.5,
            "kappa": 0.5,
            "x_b": 0.0,
            "l_b": 0.1,
            "v_reg": 1e-3,
        },
    }
    W_LIP = 5e-4  #: the lip's contact smoothed over 0.5 mm [m]

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def compression(self, g):
        """The lip's compression [m] at gap ``g`` (``lip_wiper``)."""
        return _softplus(self.p["h_w"] - np.asarray(g, dtype=float), self.W_LIP)

    def preload(self, d):
        """The carriage's relative preload at ``d`` (``bowed_rail``), at least 0."""
        p = self.p
        u = (np.asarray(d, dtype=float) - p["x_b"]) / p["l_b"]
        return np.maximum(1.0 + p["kappa"] * (1.0 - u * u), 0.0)

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        if self.family == "lip_wiper":
            c = self.compression(g)
            fg = fg + p["k_w"] * c
            fd = -((p["Fc_d"] + p["mu_w"] * p["k_w"] * c) * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        else:
            fd = -(p["Fc_d"] * self.preload(d) ** 1.5 * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        return fg + 0.0 * (d + dd), fd + 0.0 * (g + gd)


# -------------------------------------------------------------------------- end effects
class EndEffectV16(_V16, EndEffect):
    """End effects of an array whose end poles are weaker than its inner ones, or of steel end frames that pull the
    array's end magnets by their image.

    The stator's ends lie ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``.

    * ``weak_end_poles`` -- an array's end magnets have one neighbour only, so part of their flux closes round the
      array's end instead of through the stator: along the array the field's weight is ``w(s) = 1 - lam (e^{-pi s
      / tau} + e^{-pi (L - s) / tau})`` (the end's disturbance decaying as the fundamental; Furlani, "Permanent
      Magnet and Electromechanical Devices", Academic Press 2001, ch. 4; Boldea & Nasar, "Linear Electric Actuators
      and Generators", Cambridge Univ. Press 1997, ch. 3): the share lost when the array overhangs a stator end is
      the overhanging part's weight over the whole's, ``loss = int_off w / int_0^L w``, less than the plain overhang's
      share. Hook ``factors``: ``km^2 = km kc = 1 - loss``.
    * ``frame_image`` -- steel end frames stand ``a45`` beyond the array's ends when the mover is at ``+-45 mm``; the
      end magnet's field magnetizes the frame, which pulls it by its image with ``F ∝ (a + c)^-4`` (a dipole's image
      in a permeable plane, ``c`` the magnet's size softening the near field; Jackson, "Classical Electrodynamics",
      3rd ed., Wiley 1999, ch. 5; Furlani 2001, ch. 3): ``F_d = F_e (((a45 + c) / (a_p + c))^4 - ((a45 + c) / (a_n +
      c))^4)``, ``a_p = a45 + 45 mm - d``, ``a_n = a45 + 45 mm + d``. Conservative, along d only (the frames stand
      across the travel). Hook ``force``.
    """

    families = ("weak_end_poles", "frame_image")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "weak_end_poles": {"e_p": 0.02, "e_n": 0.02, "lam": 0.3},
        "frame_image": {"F_e": 0.5, "a45": 0.025, "c": 0.02},
    }
    D45 = 0.045  #: the position at which the frames' distance is given [m]

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_factors = self.family == "weak_end_poles"
        self.has_force = self.family == "frame_image"

    def _weight_integral(self, s):
        """``int_0^s w``, ``w`` the field's weight along the array."""
        lam, c = self.p["lam"], k.tau / math.pi
        s = np.asarray(s, dtype=float)
        return s + lam * c * (np.exp(-s / c) - 1.0) - lam * c * (np.exp(-(L_ARRAY - s) / c) - math.exp(-L_ARRAY / c))

    def loss(self, d):
        """The fraction of the array's field lost at ``d`` (``weak_end_poles``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        whole = self._weight_integral(L_ARRAY)
        off_p = whole - self._weight_integral(np.clip(L_ARRAY + p["e_p"] - d, 0.0, L_ARRAY))
        off_n = self._weight_integral(np.clip(-p["e_n"] - d, 0.0, L_ARRAY))
        return (off_p + off_n) / whole

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field at the ends."""
        kk = np.sqrt(1.0 - self.loss(d)) + 0.0 * np.asarray(g, dtype=float)
        f[0] = f[0] * kk
        f[1] = f[1] * kk

    def force(self, g, gd, d, dd):
        """The frames' pull ``(F_g, F_d)`` [N]."""
        p = self.p
        d = np.asarray(d, dtype=float)
        ref = p["a45"] + p["c"]
        ap = p["a45"] + self.D45 - d
        an = p["a45"] + self.D45 + d
        fd = p["F_e"] * ((ref / (ap + p["c"])) ** 4 - (ref / (an + p["c"])) ** 4)
        return 0.0 * fd + 0.0 * np.asarray(g, dtype=float), fd


# --------------------------------------------------------------------------- saturation
class SaturationV16(_V16, Saturation):
    """Saturation of a magnetic circuit whose iron follows Fischer and Moser's power law, or approaches its
    saturation as Akulov's law.

    Both solve the circuit's magnetomotive balance for the field kept, ``k``, at the flux ``x = B(g) / B(g_lo)``
    (MODEL.md's field, 1 at the lower stop): ``k + eps h(k x) = 1``, the gap's share ``k`` and the iron's ``eps
    h``, ``eps`` set so that ``k = 1 - l_lo`` at the lower stop (Hanselman, "Brushless Permanent Magnet Motor
    Design", 2nd ed., Magna 2006, ch. 4, the magnetic circuit with the iron's reluctance). Hook ``factors``, ``km =
    kc = k``; Newton's method from ``k = 1`` (``h`` convex: monotone).

    * ``fischer_moser`` -- the iron's field strength a power of its flux density, ``H ∝ B^n`` above its linear part
      (Fischer & Moser, "Die Nachbildung von Magnetisierungskurven durch einfache algebraische oder transzendente
      Funktionen", Arch. Elektrotech. 42(5), 1956): ``h(u) = u^n``.
    * ``akulov_approach`` -- near saturation the iron's polarization approaches ``J_s`` as ``J = J_s (1 - b / H^2)``
      (the law of approach to saturation: Akulov, "Uber den Verlauf der Magnetisierungskurve in starken Feldern",
      Z. Phys. 69, 1931; Chikazumi, "Physics of Ferromagnetism", 2nd ed., Oxford 1997, ch. 18), so ``H ∝ (1 - u /
      u_s)^{-1/2}``: ``h(u) = (1 - u / u_s)^{-1/2} - 1``, ``u_s`` the saturation flux over the lower stop's.
    """

    families = ("fischer_moser", "akulov_approach")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "fischer_moser": {"l_lo": 0.05, "n": 6.0, "target": "both"},
        "akulov_approach": {"l_lo": 0.05, "u_s": 1.4, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")
        self._eps = self.p["l_lo"] / float(self.iron(1.0 - self.p["l_lo"]))

    def iron(self, u):
        """The iron's share ``h(u)`` of the balance at flux ``u``."""
        u = np.asarray(u, dtype=float)
        if self.family == "fischer_moser":
            return u ** self.p["n"]
        return 1.0 / np.sqrt(1.0 - u / self.p["u_s"]) - 1.0

    def iron_slope(self, u):
        """``h'(u)``."""
        u = np.asarray(u, dtype=float)
        if self.family == "fischer_moser":
            return self.p["n"] * u ** (self.p["n"] - 1.0)
        return 0.5 / self.p["u_s"] * (1.0 - u / self.p["u_s"]) ** -1.5

    def kept(self, g):
        """The field kept (``km = kc``) at gap ``g``."""
        x = flux(np.asarray(g, dtype=float))
        kk = 1.0 + 0.0 * x
        for _ in range(12):
            f = kk + self._eps * self.iron(kk * x) - 1.0
            kk = kk - f / (1.0 + self._eps * x * self.iron_slope(kk * x))
        return kk

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and the current field."""
        kk = self.kept(np.asarray(g, dtype=float))
        f[0] = f[0] * kk
        f[1] = f[1] * kk


#: The sixteenth set: one class per effect (library families and new effects), by effect name.
V16_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV16,
        FrictionV16,
        EndEffectV16,
        SaturationV16,
        AmplifierV16,
        CommutationV16,
        EddyDragV16,
        FerrousDebris,
        ScaleJoint,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V16: tuple[str, ...] = tuple(EFFECTS_V15) + tuple(n for n in V16_LAWS if n not in EFFECTS_V15)
V16_LIBRARY: tuple[str, ...] = tuple(n for n, c in V16_LAWS.items() if c.library)
V16_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V16_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V15, V16_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v15, then v16)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V16)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V16)


__all__ = [
    "EFFECTS_V16",
    "V16_LAWS",
    "V16_LIBRARY",
    "V16_OUT_OF_LIBRARY",
    "AmplifierV16",
    "CoggingV16",
    "CommutationV16",
    "EddyDragV16",
    "EndEffectV16",
    "FerrousDebris",
    "FrictionV16",
    "SaturationV16",
    "ScaleJoint",
    "law_class",
    "make_law",
]
