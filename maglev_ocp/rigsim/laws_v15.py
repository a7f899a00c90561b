"""A fifteenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v15"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v14`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v15_drive`), and two effects outside the
library (in :mod:`.laws_v15_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v15"`` in
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
from scipy.special import ndtr

from .. import constants as k
from .laws import Cogging, EndEffect, Friction, Law, Saturation, build_law, resolve_law
from .laws_v4 import L_ARRAY
from .laws_v12 import flux
from .laws_v13_drive import field_ratio
from .laws_v14 import EFFECTS_V14
from .laws_v14 import REGISTRIES as REGISTRIES_V14
from .laws_v15_drive import AmplifierV15, CommutationV15, EddyDragV15
from .laws_v15_ool import _V15, G_REF, LimitSwitch, ProbeNonlinearity

_TWO_PI = 2.0 * math.pi
#: The magnets' recoil permeability (sintered NdFeB), for the effective gap ``g + hm / mu_r``.
MU_R = 1.05


def relative_permeance_depth(g, b0: float):
    """Zhu & Howe's depth ``beta(g) = (1 - 1 / sqrt(1 + (b0 / (2 g_e))^2)) / 2`` of the slot opening's permeance dip,
    ``g_e = g + hm / mu_r`` the effective gap, ``b0`` the slot opening [m]."""
    u = b0 / (2.0 * (np.asarray(g, dtype=float) + k.hm / MU_R))
    return 0.5 * (1.0 - 1.0 / np.sqrt(1.0 + u * u))


# ----------------------------------------------------------------------------- cogging
class CoggingV15(_V15, Cogging):
    """Cogging set by the magnets' width against the slot pitch, or decaying with the gap as the slot opening's
    relative permeance.

    Both conservative, ``F = -grad W``, ``th = 2 pi (d - x0) / t1``.

    * ``arc_ratio`` -- each magnet's two edges, ``beta`` slot pitches apart (its width modulo the slot pitch), cog
      alike, each edge's slot harmonics falling as ``1/k``; the magnet sums them as ``2 sin(k pi beta)`` (Li &
      Slemon, "Reduction of cogging torque in permanent magnet motors", IEEE Trans. Magn. 24(6), 1988; Zhu & Howe,
      "Influence of design parameters on cogging torque in permanent magnet machines", IEEE Trans. Energy Convers.
      15(4), 2000): three harmonics ``c_k = sin(k pi beta) / (k sin(pi beta))`` (``c_1 = 1``), each decaying as
      ``e_k = exp(-2 pi k (g - 10 mm) / t1)``: ``W = (t1 / 2 pi) xi0 sum_k c_k e_k cos(k th) / k``, ``F_d = xi0
      sum_k c_k e_k sin(k th)``, ``F_g = xi0 sum_k c_k e_k cos(k th)``.
    * ``carter_permeance`` -- the slot opening ``b0`` modulates the gap's permeance with Zhu & Howe's depth ``beta(g)
      = (1 - 1/sqrt(1 + (b0 / 2 g_e)^2)) / 2`` (Zhu & Howe, "Instantaneous magnetic field distribution in brushless
      permanent magnet dc motors, Part III: Effect of stator slotting", IEEE Trans. Magn. 29(1), 1993, from Carter's
      conformal map: Carter, "Note on air-gap and interpolar induction", J. IEE 29(146), 1900): ``W = (t1 / 2 pi)
      xi0 (beta(g) / beta(10 mm)) cos th``: a cogging that falls with the gap algebraically, not exponentially.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("arc_ratio", "carter_permeance")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "arc_ratio": {"xi0": 3.0, "beta": 0.4, "x0": 0.0, "replace": 0.0},
        "carter_permeance": {"xi0": 2.0, "b0": 0.005, "x0": 0.0, "replace": 0.0},
    }

    def harmonics(self) -> np.ndarray:
        """``c_1 .. c_3`` (``arc_ratio``)."""
        b = self.p["beta"]
        kk = np.arange(1, 4)
        return np.sin(kk * math.pi * b) / (kk * math.sin(math.pi * b))

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        th = _TWO_PI * (d - p["x0"]) / k.t1
        if self.family == "arc_ratio":
            fg = 0.0 * (g + th)
            fd = 0.0 * (g + th)
            for kk, c in enumerate(self.harmonics(), start=1):
                e = p["xi0"] * c * np.exp(-_TWO_PI * kk * (g - k.g_cog_ref) / k.t1)
                fd = fd + e * np.sin(kk * th)
                fg = fg + e * np.cos(kk * th)
            return fg, fd
        b0 = p["b0"]
        ref = float(relative_permeance_depth(k.g_cog_ref, b0))
        ge = g + k.hm / MU_R
        u = b0 / (2.0 * ge)
        dbeta = -0.5 * u * u / (ge * (1.0 + u * u) ** 1.5)  # d beta / d g
        fd = p["xi0"] * relative_permeance_depth(g, b0) / ref * np.sin(th)
        fg = -(k.t1 / _TWO_PI) * p["xi0"] * dbeta / ref * np.cos(th)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV15(_V15, Friction):
    """Friction of a caged guide whose cage reaches its stop, or of polymer rollers whose hysteresis loss peaks at
    a speed.

    * ``cage_creep`` -- the guide's ball cage travels at half the carriage's speed and is free over ``+-x_s`` of the
      stroke round ``x_c``; beyond, it rests on its stop and the balls slide instead of rolling, raising the Coulomb
      level by ``k_s`` (cage creep of rolling linear guides: Slocum, "Precision Machine Design", Prentice Hall 1992,
      ch. 8; Harnoy, "Bearing Design in Machinery", Marcel Dekker 2002, ch. 12): ``F_d = -(Fc_d (1 + k_s S) tanh(d_dot
      / v_reg) + b_d d_dot)``, ``S = (1 + tanh((|d - x_c| - x_s) / w_s)) / 2``; the gap axis plain Coulomb-viscous.
    * ``viscoelastic_peak`` -- the guide's polymer-tyred rollers lose energy by the tyre's viscoelastic hysteresis,
      largest when the contact's deformation rate matches the polymer's relaxation (a Maxwell element's loss peak;
      Grosch, "The relation between the friction and visco-elastic properties of rubber", Proc. R. Soc. A 274(1356),
      1963; Greenwood, Minshall & Tabor, "Hysteresis losses in rolling and sliding friction", Proc. R. Soc. A
      259(1299), 1961): ``F = -(Fc tanh(v / v_reg) + 2 F_h (v / v_h) / (1 + (v / v_h)^2))`` per axis, the loss term
      ``F_h`` at its peak ``v = v_h`` and falling beyond.
    """

    families = ("cage_creep", "viscoelastic_peak")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cage_creep": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "b_g": 0.5,
            "b_d": 0.5,
            "k_s": 1.0,
            "x_c": 0.0,
            "x_s": 0.025,
            "w_s": 0.004,
            "v_reg": 1e-3,
        },
        "viscoelastic_peak": {"Fc_g": 0.1, "Fc_d": 0.1, "Fh_g": 0.1, "Fh_d": 0.1, "v_h": 0.01, "v_reg": 1e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def level(self, d):
        """Coulomb's level along d [N] at ``d`` (``cage_creep``)."""
        p = self.p
        s = 0.5 * (1.0 + np.tanh((np.abs(np.asarray(d, dtype=float) - p["x_c"]) - p["x_s"]) / p["w_s"]))
        return p["Fc_d"] * (1.0 + p["k_s"] * s)

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "cage_creep":
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
            fd = -(self.level(d) * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        else:
            ug, ud = gd / p["v_h"], dd / p["v_h"]
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + 2.0 * p["Fh_g"] * ug / (1.0 + ug * ug))
            fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) + 2.0 * p["Fh_d"] * ud / (1.0 + ud * ud))
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
def _ramp_integral(z):
    """``int_{-inf}^{z} Phi(x) dx = z Phi(z) + phi(z)`` (Phi, phi: the standard normal's distribution, density)."""
    z = np.asarray(z, dtype=float)
    return z * ndtr(z) + np.exp(-0.5 * z * z) / math.sqrt(_TWO_PI)


class EndEffectV15(_V15, EndEffect):
    """End effects of a stator whose laminations end raggedly, or of an array whose steel end brackets are pulled
    by the stator while over it.

    The stator's nominal ends lie ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``.

    * ``ragged_ends`` -- the laminations of each stack end at scattered positions (blanking tolerance and the
      stack's misalignment), normal about the nominal end with deviation ``s_r``: the iron's share at ``x`` beyond
      it is ``1 - Phi((x - x_e) / s_r)`` (stacking tolerances: Pyrhonen, Jokinen & Hrabovcova, "Design of Rotating
      Electrical Machines", 2nd ed., Wiley 2014, ch. 3; the array's field lost with the iron under it: Boldea &
      Nasar, "Linear Electric Actuators and Generators", Cambridge Univ. Press 1997, ch. 3): the array loses ``s_r
      G(z) / L`` per end, ``G(z) = z Phi(z) + phi(z)``, ``z`` the array end's reach past the nominal end over
      ``s_r`` (``O`` as ``s_r -> 0``). Hook ``factors``: ``km^2 = km kc = 1 - loss``.
    * ``end_brackets`` -- steel brackets ``l_b`` long clamp the array's ends; over the stator's iron the end magnets'
      fringe magnetizes them and they are pulled towards it, with the field's energy ``W = -E0 b(g)^2 (c_p + c_n)``,
      ``c`` each bracket's share over the stator (``clip``, 0 ... 1), ``E0`` set by the pull ``F_b`` of one whole
      bracket at 15 mm (Roters, "Electromagnetic Devices", Wiley 1941, ch. 5 (pull of an iron part in a fringing
      field); Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC 2011, ch. 2 (end forces)):
      ``F_g = E0 d(b^2)/dg (c_p + c_n)`` (towards the stator), ``F_d = E0 b^2 d(c_p + c_n)/dd`` as a bracket crosses
      a stator end. Hook ``force``.
    """

    families = ("ragged_ends", "end_brackets")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "ragged_ends": {"e_p": 0.025, "e_n": 0.025, "s_r": 0.004},
        "end_brackets": {"e_p": 0.02, "e_n": 0.02, "l_b": 0.01, "F_b": 1.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_factors = self.family == "ragged_ends"
        self.has_force = self.family == "end_brackets"

    def loss(self, d):
        """The fraction of the array's field lost at ``d`` (``ragged_ends``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        zp = (d + 0.5 * L_ARRAY - (0.5 * L_ARRAY + p["e_p"])) / p["s_r"]
        zn = (-d + 0.5 * L_ARRAY - (0.5 * L_ARRAY + p["e_n"])) / p["s_r"]
        return p["s_r"] * (_ramp_integral(zp) + _ramp_integral(zn)) / L_ARRAY

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field at the ends."""
        kk = np.sqrt(1.0 - self.loss(d)) + 0.0 * np.asarray(g, dtype=float)
        f[0] = f[0] * kk
        f[1] = f[1] * kk

    def shares(self, d) -> tuple[np.ndarray, np.ndarray]:
        """``(c_p, c_n)``: each bracket's share over the stator (``end_brackets``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        cp = np.clip((p["e_p"] - d) / p["l_b"], 0.0, 1.0)
        cn = np.clip((p["e_n"] + d) / p["l_b"], 0.0, 1.0)
        return cp, cn

    def energy_scale(self) -> float:
        """``E0`` [J]: the pull of one whole bracket at 15 mm over ``|d(b^2)/dg|`` there."""
        a0 = math.pi * (k.hm + G_REF) / k.tau
        return self.p["F_b"] / (2.0 * (math.pi / k.tau) / math.tanh(a0))

    def force(self, g, gd, d, dd):
        """The brackets' pull ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        b2 = field_ratio(g) ** 2
        a = math.pi * (k.hm + g) / k.tau
        db2 = -2.0 * (math.pi / k.tau) / np.tanh(a) * b2  # d(b^2)/dg
        cp, cn = self.shares(d)
        dcp = np.where((cp > 0.0) & (cp < 1.0), -1.0 / p["l_b"], 0.0)
        dcn = np.where((cn > 0.0) & (cn < 1.0), 1.0 / p["l_b"], 0.0)
        e0 = self.energy_scale()
        return e0 * db2 * (cp + cn), e0 * b2 * (dcp + dcn)


# --------------------------------------------------------------------------- saturation
class SaturationV15(_V15, Saturation):
    """Saturation of teeth whose knees are spread, or of iron whose reluctivity follows Marrocco's law.

    Both on the iron's flux ``x = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); hook ``factors``, ``km =
    kc``.

    * ``spread_knees`` -- the teeth (and the laminations in them) saturate at scattered fluxes, normal about ``x_k``
      with deviation ``w`` (the spread of the grade's saturation polarization and of the teeth's widths; Bertotti,
      "Hysteresis in Magnetism", Academic Press 1998, ch. 12; Bozorth, "Ferromagnetism", Van Nostrand 1951, ch. 18):
      the share saturated is ``Phi((x - x_k) / w)``, ``km = kc = 1 - l_lo Phi((x - x_k) / w) / Phi((1 - x_k) /
      w)``.
    * ``marrocco`` -- the iron's reluctivity rises with ``B^2`` as Marrocco's rational law, ``nu = k1 + (c - k1)
      B^(2a) / (B^(2a) + t)`` (Marrocco, "Analyse numerique de problemes d'electrotechnique", Ann. Sci. Math. Quebec
      1(2), 1977; Hecht & Marrocco, in Silvester & Chari (eds.), "Finite Elements in Electrical and Magnetic Field
      Problems", Wiley 1980): the field lost in proportion, ``km = kc = 1 - l_lo (1 + t) x^(2a) / (x^(2a) + t)``.
    """

    families = ("spread_knees", "marrocco")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "spread_knees": {"l_lo": 0.05, "x_k": 0.7, "w": 0.15, "target": "both"},
        "marrocco": {"l_lo": 0.05, "a": 2.0, "t": 1.0, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")

    def kept(self, g):
        """The field kept (``km = kc``) at gap ``g``."""
        p = self.p
        x = flux(g)
        if self.family == "spread_knees":
            return 1.0 - p["l_lo"] * ndtr((x - p["x_k"]) / p["w"]) / ndtr((1.0 - p["x_k"]) / p["w"])
        x2a = x ** (2.0 * p["a"])
        return 1.0 - p["l_lo"] * (1.0 + p["t"]) * x2a / (x2a + p["t"])

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and the current field."""
        kk = self.kept(np.asarray(g, dtype=float))
        f[0] = f[0] * kk
        f[1] = f[1] * kk


#: The fifteenth set: one class per effect (library families and new effects), by effect name.
V15_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV15,
        FrictionV15,
        EndEffectV15,
        SaturationV15,
        AmplifierV15,
        CommutationV15,
        EddyDragV15,
        LimitSwitch,
        ProbeNonlinearity,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V15: tuple[str, ...] = tuple(EFFECTS_V14) + tuple(n for n in V15_LAWS if n not in EFFECTS_V14)
V15_LIBRARY: tuple[str, ...] = tuple(n for n, c in V15_LAWS.items() if c.library)
V15_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V15_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V14, V15_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v14, then v15)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V15)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V15)


__all__ = [
    "EFFECTS_V15",
    "V15_LAWS",
    "V15_LIBRARY",
    "V15_OUT_OF_LIBRARY",
    "AmplifierV15",
    "CoggingV15",
    "CommutationV15",
    "EddyDragV15",
    "EndEffectV15",
    "FrictionV15",
    "LimitSwitch",
    "ProbeNonlinearity",
    "SaturationV15",
    "law_class",
    "make_law",
]
