"""A fourteenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v14"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v13`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v14_drive`), and two effects outside the
library (in :mod:`.laws_v14_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v14"`` in
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
from .laws_v13 import EFFECTS_V13
from .laws_v13 import REGISTRIES as REGISTRIES_V13
from .laws_v14_drive import AmplifierV14, CommutationV14, EddyDragV14
from .laws_v14_ool import _V14, BellowsOffload, EncoderLatency

_TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- cogging
class CoggingV14(_V14, Cogging):
    """Cogging of a stator whose slot openings sit off the teeth's centres, or of a stator of two stacks joined with a
    phase error.

    Both conservative, from an energy ``W`` of the slot harmonics, each decaying with the gap as the open slot's field
    ``exp(-2 pi k (g - 10 mm) / t1)`` (Zhu & Howe, "Analytical prediction of the cogging torque in radial-field
    permanent magnet brushless motors", IEEE Trans. Magn. 28(2), 1992); ``F = -grad W``.

    * ``offset_openings`` -- slot openings displaced from the tooth's axis (a design measure against cogging:
      Bianchi & Bolognani, "Design techniques for reducing the cogging torque in surface-mounted PM motors", IEEE
      Trans. Ind. Appl. 38(5), 2002) break the tooth's symmetry: the second harmonic shifted by ``phi2``, ``W = (t1 /
      2 pi) xi0 [e1 cos th + (a2 / 2) e2 cos(2 th - phi2)]``, ``th = 2 pi (d - x0) / t1``, ``e_k = exp(-2 pi k (g - 10
      mm) / t1)``: ``F_d = xi0 (e1 sin th + a2 e2 sin(2 th - phi2))``, ``F_g = xi0 (e1 cos th + a2 e2 cos(2 th -
      phi2))``: a cogging whose rise and fall along d differ.
    * ``stack_joint`` -- the stator is two stacks butted at ``x_j`` whose slot patterns are out of step by ``psi``
      (a joint of a modular long stator: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC 2011,
      ch. 9 (modular stators)); the array's share ``w(d)`` over the first stack cogs with it, the rest with the second:
      ``W = (t1 / 2 pi) xi0 e1 [w cos th + (1 - w) cos(th + psi)]``, ``w = clip((x_j - d) / L + 1/2, 0, 1)``:
      ``F_d`` with ``dw/dd = -1/L`` over the joint's crossing, its phase moving from one stack's to the other's.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("offset_openings", "stack_joint")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "offset_openings": {"xi0": 3.0, "a2": 0.4, "phi2": 1.0, "x0": 0.0, "replace": 0.0},
        "stack_joint": {"xi0": 3.0, "psi": 1.5, "x_j": 0.0, "x0": 0.0, "replace": 0.0},
    }

    def share(self, d):
        """The array's share over the first stack (``stack_joint``)."""
        return np.clip((self.p["x_j"] - np.asarray(d, dtype=float)) / L_ARRAY + 0.5, 0.0, 1.0)

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        e1 = p["xi0"] * np.exp(-_TWO_PI * (g - k.g_cog_ref) / k.t1)
        th = _TWO_PI * (d - p["x0"]) / k.t1
        if self.family == "offset_openings":
            e2 = p["xi0"] * np.exp(-2 * _TWO_PI * (g - k.g_cog_ref) / k.t1)
            fd = e1 * np.sin(th) + p["a2"] * e2 * np.sin(2 * th - p["phi2"])
            fg = e1 * np.cos(th) + p["a2"] * e2 * np.cos(2 * th - p["phi2"])
            return fg, fd
        w = self.share(d)
        inside = (w > 0.0) & (w < 1.0)
        c1, c2 = np.cos(th), np.cos(th + p["psi"])
        dw = np.where(inside, -1.0 / L_ARRAY, 0.0)
        fd = e1 * (w * np.sin(th) + (1 - w) * np.sin(th + p["psi"])) - e1 * (k.t1 / _TWO_PI) * dw * (c1 - c2)
        fg = e1 * (w * c1 + (1 - w) * c2)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV14(_V14, Friction):
    """Friction of a grease whose shear stress follows Eyring's law, or of a guide worn smooth over the stroke's
    busiest part.

    * ``eyring_grease`` -- the contacts' lubricant film shears by stress-activated flow: its stress grows as the
      inverse hyperbolic sine of the shear rate (Eyring, "Viscosity, plasticity, and diffusion as examples of absolute
      reaction rates", J. Chem. Phys. 4(4), 1936; Bair & Winer, "A rheological model for elastohydrodynamic contacts
      based on primary laboratory data", J. Lubr. Technol. 101(3), 1979): ``F = -(Fc tanh(v / v_reg) + F_e asinh(v /
      v_e))`` per axis: viscous below ``v_e``, logarithmic in the speed above it.
    * ``worn_track`` -- the guide's track is run in (polished) where the stage works most, round ``x_w``; Coulomb's
      level there is lower by ``w`` over a width ``s_w`` (Archard, "Contact and rubbing of flat surfaces", J. Appl.
      Phys. 24(8), 1953; Rabinowicz, "Friction and Wear of Materials", 2nd ed., Wiley 1995, ch. 4 (run-in)):
      ``F_d = -(Fc_d (1 - w exp(-((d - x_w) / s_w)^2)) tanh(d_dot / v_reg) + b_d d_dot)``, the gap axis plain
      Coulomb-viscous.
    """

    families = ("eyring_grease", "worn_track")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "eyring_grease": {"Fc_g": 0.1, "Fc_d": 0.1, "Fe_g": 0.05, "Fe_d": 0.05, "v_e": 3e-3, "v_reg": 1e-3},
        "worn_track": {
            "Fc_g": 0.15,
            "Fc_d": 0.2,
            "b_g": 0.5,
            "b_d": 0.5,
            "w": 0.4,
            "x_w": 0.0,
            "s_w": 0.02,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def level(self, d):
        """Coulomb's level along d [N] at ``d`` (``worn_track``)."""
        p = self.p
        return p["Fc_d"] * (1.0 - p["w"] * np.exp(-(((np.asarray(d, dtype=float) - p["x_w"]) / p["s_w"]) ** 2)))

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "eyring_grease":
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["Fe_g"] * np.arcsinh(gd / p["v_e"]))
            fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) + p["Fe_d"] * np.arcsinh(dd / p["v_e"]))
        else:
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
            fd = -(self.level(d) * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
class EndEffectV14(_V14, EndEffect):
    """End effects of a stator whose ends are stepped, or whose end laminations splay open.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``; the array's overhang beyond them lost
    (``1 - O/L``, as the earlier sets). Hook ``factors``: ``km^2 =
    km kc = 1 - loss``.

    * ``stepped_ends`` -- each end of the stack cut in two steps, half its width ending ``s`` earlier (stepped or
      staggered stator ends against the end force: Inoue & Sato, "An approach to a suitable stator length for
      minimizing the detent force of permanent magnet linear synchronous motors", IEEE Trans. Magn. 36(4), 2000):
      ``loss = (O(e) + O(e - s)) / (2 L)`` per end: the loss grows at half the rate over the step, then at the full.
    * ``splayed_laminations`` -- the last ``z`` of each stack, unclamped by the end plate, splays open: its stacking
      factor falls linearly from 1 to ``1 - s_f`` at the end face (Pyrhonen, Jokinen & Hrabovcova, "Design of
      Rotating Electrical Machines", 2nd ed., Wiley 2014, ch. 3 (stacking factor); Boldea & Nasar, "Linear Electric
      Actuators and Generators", Cambridge Univ. Press 1997, ch. 3): the array's reach ``u`` into the splayed zone
      loses ``s_f u^2 / (2 z)`` (``u <= z``; ``s_f z / 2`` once the array passes the end face), besides the
      overhang: a loss whose onset is quadratic.
    """

    families = ("stepped_ends", "splayed_laminations")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "stepped_ends": {"e_p": 0.025, "e_n": 0.025, "s": 0.01},
        "splayed_laminations": {"e_p": 0.025, "e_n": 0.025, "z": 0.01, "s_f": 0.3},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)

    def overhangs(self, d, shift: float = 0.0):
        """``(O_p, O_n)``: the array's length beyond each stator end moved in by ``shift`` [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = 0.5 * L_ARRAY + self.p["e_p"] - shift, 0.5 * L_ARRAY + self.p["e_n"] - shift
        return np.maximum(0.0, d + 0.5 * L_ARRAY - xp), np.maximum(0.0, -xn - d + 0.5 * L_ARRAY)

    def loss(self, d):
        """The fraction of the array's field lost at ``d``."""
        p = self.p
        op, on = self.overhangs(d)
        if self.family == "stepped_ends":
            sp, sn = self.overhangs(d, p["s"])
            return 0.5 * (op + on + sp + sn) / L_ARRAY
        z = p["z"]
        zp, zn = self.overhangs(d, z)
        q = p["s_f"] * ((zp - op) ** 2 + (zn - on) ** 2) / (2.0 * z)  # the reach into each splayed zone, <= z
        return (op + on + q) / L_ARRAY

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field at the ends."""
        kk = np.sqrt(1.0 - self.loss(d)) + 0.0 * np.asarray(g, dtype=float)
        f[0] = f[0] * kk
        f[1] = f[1] * kk


# --------------------------------------------------------------------------- saturation
class SaturationV14(_V14, Saturation):
    """Saturation of grain-oriented laminations, or of laminations whose punched edges saturate first.

    Both on the iron's flux ``x = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); hook ``factors``.

    * ``grain_oriented`` -- the teeth's laminations are grain-oriented along the pull's path and hard across it
      (Moses, "Electrical steels: past, present and future developments", IEE Proc. A 137(5), 1990; Bozorth,
      "Ferromagnetism", Van Nostrand 1951, ch. 12): the currents' field, crossing the grain, saturates less than the
      magnets' pull, ``km = 1 - l_lo x^n``, ``kc = 1 - r_c l_lo x^n`` (``r_c < 1``).
    * ``punched_edges`` -- a band of the teeth's width next to each punched edge has lost its permeability by the
      cutting stress and saturates at a small flux (Schoppa, Schneider & Wuppermann, "Influence of the manufacturing
      process on the magnetic properties of non-oriented electrical steels", J. Magn. Magn. Mater. 215-216, 2000):
      ``km = kc = 1 - l_lo x^n - l_e tanh(x / x_e)``: a loss that rises early (the damaged band, ``l_e`` at most)
      and then with the bulk's power law.
    """

    families = ("grain_oriented", "punched_edges")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "grain_oriented": {"l_lo": 0.12, "n": 2.0, "r_c": 0.5, "target": "both"},
        "punched_edges": {"l_lo": 0.08, "n": 2.5, "l_e": 0.04, "x_e": 0.4, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")

    def kept(self, g):
        """``(km, kc)``: the magnets' and the currents' field kept at gap ``g``."""
        p = self.p
        x = flux(g)
        bulk = p["l_lo"] * x ** p["n"]
        if self.family == "grain_oriented":
            return 1.0 - bulk, 1.0 - p["r_c"] * bulk
        kk = 1.0 - bulk - p["l_e"] * np.tanh(x / p["x_e"])
        return kk, kk

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and the current field."""
        km, kc = self.kept(np.asarray(g, dtype=float))
        f[0] = f[0] * km
        f[1] = f[1] * kc


#: The fourteenth set: one class per effect (library families and new effects), by effect name.
V14_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV14,
        FrictionV14,
        EndEffectV14,
        SaturationV14,
        AmplifierV14,
        CommutationV14,
        EddyDragV14,
        BellowsOffload,
        EncoderLatency,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V14: tuple[str, ...] = tuple(EFFECTS_V13) + tuple(n for n in V14_LAWS if n not in EFFECTS_V13)
V14_LIBRARY: tuple[str, ...] = tuple(n for n, c in V14_LAWS.items() if c.library)
V14_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V14_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V13, V14_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v13, then v14)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V14)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V14)


__all__ = [
    "EFFECTS_V14",
    "V14_LAWS",
    "V14_LIBRARY",
    "V14_OUT_OF_LIBRARY",
    "AmplifierV14",
    "BellowsOffload",
    "CoggingV14",
    "CommutationV14",
    "EddyDragV14",
    "EncoderLatency",
    "EndEffectV14",
    "FrictionV14",
    "SaturationV14",
    "law_class",
    "make_law",
]
