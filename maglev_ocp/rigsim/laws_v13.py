"""A thirteenth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v13"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v12`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v13_drive`), and two effects outside the
library (in :mod:`.laws_v13_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v13"`` in
its truth record. The source of each law (author, title, venue, year) is in its docstring and in
``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``force_i``, ``held``,
``rotate_at``, ``read_at``, ``advance``, the state-space amplifier); no hook was added. A law with a state the
recorded trajectory does not hold (a lagged overhang, a set of relays, a chosen sensor head) records its peak force
while simulated (``recorded``), at the integrator's stage states, with nominal constants.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import G_STOP_LO, Cogging, EndEffect, Friction, Law, Saturation, build_law, resolve_law
from .laws_v4 import L_ARRAY
from .laws_v12 import EFFECTS_V12, flux
from .laws_v12 import REGISTRIES as REGISTRIES_V12
from .laws_v13_drive import AmplifierV13, CommutationV13, EddyDragV13
from .laws_v13_ool import _V13, G_REF, BaseTilt, ProbeFilter, _Peaks
from .physics import NOMINAL, shape

_TWO_PI = 2.0 * math.pi


def _pull_ratio(g, g_ref: float = G_REF):
    """``f2(g) / f2(g_ref)`` (MODEL.md's ``f2``, the magnets' pull's shape)."""
    return shape(np.asarray(g, dtype=float)).f2 / float(shape(g_ref).f2)


def _factor_force(g, i_q, i_d, pull, coup):
    """Force change ``(dF_g, dF_d)`` [N] of the field factors ``km^2 = pull``, ``km kc = coup`` (seed eq. (2),
    nominal constants; ``kc^2 = coup^2 / pull``)."""
    sh, c = shape(g), NOMINAL
    kc2 = coup * coup / pull
    up = c.C2 * sh.f2 * (pull - 1) - c.C3 * sh.f3 * i_d * (coup - 1)
    up = up + c.C4 * sh.f4 * (i_q * i_q + i_d * i_d) * (kc2 - 1)
    return k.Mv * up, k.Mh * c.C1 * sh.f1 * i_q * (coup - 1)


# ----------------------------------------------------------------------------- cogging
class CoggingV13(_V13, Cogging):
    """Cogging of a stator whose slot openings give a whole series of harmonics, or of an array whose north and south
    magnets are unequal.

    Both conservative, from an energy ``W = sum_k (t1 / 2 pi k) A_k(g, d) cos theta_k``, ``theta_k = 2 pi k (d - x0) /
    t1``, each harmonic decaying with the gap as the open slot's field ``exp(-2 pi k (g - g_ref) / t1)`` (Zhu & Howe,
    "Analytical prediction of the cogging torque in radial-field permanent magnet brushless motors", IEEE Trans. Magn.
    28(2), 1992); ``F = -grad W``.

    * ``open_slot_series`` -- the slot openings, a fraction ``beta`` of the slot pitch, make a rectangular permeance
      wave whose harmonics go as ``sin(k pi beta) / (k pi beta)`` (Zhu & Howe, "Instantaneous magnetic field
      distribution in brushless permanent magnet dc motors, Part III: Effect of stator slotting", IEEE Trans. Magn.
      29(1), 1993): ``A_k = xi0 (s_k / s_1) exp(...)``, ``s_k = sinc(k beta)``, ``k = 1 ... 5``: a cogging shape that
      sharpens as the gap closes (the higher harmonics decay faster), signs alternating with ``beta``.
    * ``unequal_poles`` -- the north and south magnets differ in strength by ``+-e`` (grading tolerance), modulating
      the slot harmonic at the pole pair's period ``2 tau`` (sidebands at ``1/t1 +- 1/2tau``; Gasparin, Cernigoj,
      Markic & Fiser, "Additional cogging torque components in permanent-magnet motors due to manufacturing
      imperfections", IEEE Trans. Magn. 45(3), 2009): ``A_1 = xi0 (1 + e cos(pi (d - x_m) / tau)) exp(...)``, one
      harmonic; ``F_d = A_1 sin theta_1 + xi0 e exp(...) (t1 / 2 tau) sin(pi (d - x_m) / tau) cos theta_1``.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("open_slot_series", "unequal_poles")
    N_HARM = 5
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "open_slot_series": {"xi0": 3.0, "beta": 0.4, "x0": 0.0, "replace": 0.0},
        "unequal_poles": {"xi0": 3.0, "e": 0.2, "x_m": 0.0, "x0": 0.0, "replace": 0.0},
    }

    def weights(self) -> np.ndarray:
        """``s_k / s_1`` for ``k = 1 ... N_HARM`` (``open_slot_series``)."""
        kk = np.arange(1, self.N_HARM + 1)
        s = np.sinc(kk * self.p["beta"])  # numpy's sinc: sin(pi x) / (pi x)
        return s / s[0]

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "open_slot_series":
            fg = fd = 0.0
            for kk, w in enumerate(self.weights(), start=1):
                a = p["xi0"] * w * np.exp(-_TWO_PI * kk * (g - k.g_cog_ref) / k.t1)
                th = _TWO_PI * kk * (d - p["x0"]) / k.t1
                fd = fd + a * np.sin(th)
                fg = fg + a * np.cos(th)
            return fg + 0.0 * d, fd + 0.0 * g
        e0 = p["xi0"] * np.exp(-_TWO_PI * (g - k.g_cog_ref) / k.t1)
        ph = math.pi * (d - p["x_m"]) / k.tau
        th = _TWO_PI * (d - p["x0"]) / k.t1
        a = e0 * (1.0 + p["e"] * np.cos(ph))
        fd = a * np.sin(th) + e0 * p["e"] * (k.t1 / (2.0 * k.tau)) * np.sin(ph) * np.cos(th)
        return a * np.cos(th), fd


# ---------------------------------------------------------------------------- friction
class FrictionV13(_V13, Friction):
    """Friction of a guide loaded by the magnets' pull, or of contacts smoothed by the drive's vibration (dither).

    * ``pull_loaded`` -- the horizontal guide carries part ``kappa`` of its normal load from the magnets' pull, which
      grows as the gap closes (``f2``, MODEL.md); Coulomb's level follows the load (Amontons' law: Bowden & Tabor, "The
      Friction and Lubrication of Solids", Clarendon 1950, ch. 5): ``F_d = -(Fc_d (1 + kappa (f2(g)/f2(15 mm) - 1))
      tanh(d_dot / v_reg) + b_d d_dot)``; the gap axis' guide ``F_g = -(Fc_g tanh(g_dot / v_reg) + b_g g_dot)``.
    * ``dither_smoothed`` -- the PWM's current ripple shakes the contacts at a speed amplitude ``v_d`` far above the
      loop's bandwidth; Coulomb's ``sgn`` averaged over the fast cycle becomes ``(2 / pi) arcsin(v / v_d)`` below
      ``v_d`` (Zames & Shneydor, "Dither in nonlinear systems", IEEE Trans. Autom. Control 21(5), 1976;
      Armstrong-Helouvry, Dupont & Canudas de Wit, "A survey of models, analysis tools and compensation methods for the
      control of machines with friction", Automatica 30(7), 1994, sec. 5): ``F = -(Fc (2/pi) arcsin(clip(v / v_d))
      + b v)`` per axis: friction with a steep but finite slope through zero speed.
    """

    families = ("pull_loaded", "dither_smoothed")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "pull_loaded": {"Fc_g": 0.15, "Fc_d": 0.15, "b_g": 0.5, "b_d": 0.5, "kappa": 0.7, "v_reg": 1e-3},
        "dither_smoothed": {"Fc_g": 0.15, "Fc_d": 0.15, "b_g": 0.5, "b_d": 0.5, "v_d": 5e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def level(self, g):
        """Coulomb's level along d [N] at gap ``g`` (``pull_loaded``)."""
        p = self.p
        return p["Fc_d"] * (1.0 + p["kappa"] * (_pull_ratio(g) - 1.0))

    def smoothed(self, v):
        """``(2 / pi) arcsin(clip(v / v_d, -1, 1))`` (``dither_smoothed``)."""
        return (2.0 / math.pi) * np.arcsin(np.clip(np.asarray(v, dtype=float) / self.p["v_d"], -1.0, 1.0))

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "pull_loaded":
            fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
            fd = -(self.level(g) * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        else:
            fg = -(p["Fc_g"] * self.smoothed(gd) + p["b_g"] * gd)
            fd = -(p["Fc_d"] * self.smoothed(dd) + p["b_d"] * dd)
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
class EndEffectV13(_V13, _Peaks, EndEffect):
    """End effects whose field builds up behind the array's motion, or where the armature's field fringes past the
    stator's ends.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0`` (at ``x_p = L/2 + e_p`` and ``-x_n``), the
    array's overhang ``O(d)`` beyond them (lost: ``1 - O/L``, as the earlier sets).

    * ``delayed_entry`` -- eddy currents in the stator's solid end plates oppose the change of the flux as the array
      runs on or off the stator, so the field at the ends follows the overhang with a lag ``tau_e`` (the entry-end
      field's build-up: Yamamura, "Theory of Linear Induction Motors", Wiley 1972, ch. 2; Boldea & Nasar, "Linear
      Electric Actuators and Generators", Cambridge Univ. Press 1997, ch. 3): ``km^2 = km kc = 1 - O_e/L``, ``tau_e
      dO_e/dt = O(d) - O_e`` per control period (hooks ``factors_i``, ``advance``; size recorded while simulated).
    * ``armature_fringe`` -- the magnets' field beyond the stator's iron is lost, but the armature's current field
      fringes past the end face, decaying over ``lambda = c_a (g + hm)`` (Laplace's field at an iron edge: Hague,
      "Electromagnetic Problems in Electrical Engineering", Oxford 1929; Boldea & Nasar 1997, ch. 3): ``km^2 = 1 -
      O/L``, ``km kc = 1 - (O - lambda (1 - exp(-O / lambda))) / L`` per end: the currents' coupling falls later
      than the pull, by a length set by the gap.
    """

    families = ("delayed_entry", "armature_fringe")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "delayed_entry": {"e_p": 0.02, "e_n": 0.03, "tau_e": 0.01},
        "armature_fringe": {"e_p": 0.02, "e_n": 0.03, "c_a": 0.6},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_factors = self.family == "armature_fringe"
        self.has_factors_i = self.family == "delayed_entry"  # type: ignore[misc]
        self.has_advance = self.family == "delayed_entry"  # type: ignore[misc]
        self.reset(0)
        if self.has_advance:
            self.recorded = self.peaks

    def reset(self, n_runs: int) -> None:
        """No lagged overhang yet, no peak."""
        self.o_e: np.ndarray | None = None
        self.d_last: np.ndarray | None = None
        self.reset_peaks(n_runs)

    def overhangs(self, d):
        """``(O_p(d), O_n(d))``: the array's length beyond each stator end [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = 0.5 * L_ARRAY + self.p["e_p"], 0.5 * L_ARRAY + self.p["e_n"]
        return np.maximum(0.0, d + 0.5 * L_ARRAY - xp), np.maximum(0.0, -xn - d + 0.5 * L_ARRAY)

    def end_factors(self, g, d, o_e=None):
        """``(km^2, km kc)`` at gap ``g`` and position ``d`` (``delayed_entry``: at the lagged overhang ``o_e``)."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        op, on = self.overhangs(d)
        if self.family == "delayed_entry":
            o = op + on if o_e is None else o_e
            pull = 1.0 - o / L_ARRAY + 0.0 * g
            return pull, pull
        lam = self.p["c_a"] * (g + k.hm)
        pull = 1.0 - (op + on) / L_ARRAY + 0.0 * g
        kept = lam * (-np.expm1(-op / lam) - np.expm1(-on / lam))
        return pull, pull + kept / L_ARRAY

    def factors(self, g, d, f: list) -> None:
        """``armature_fringe``: the magnets' field and the currents' coupling at the ends."""
        pull, coup = self.end_factors(g, d)
        km = np.sqrt(pull)
        f[0] = f[0] * km
        f[1] = f[1] * coup / km

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """``delayed_entry``: the factors at the lagged overhang; the force recorded while simulated."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        run = g.ndim == 1 and g.shape[0] == self.n_runs
        o_e = None
        if run:
            if self.o_e is None or self.o_e.shape != g.shape:
                self.o_e = sum(self.overhangs(d))
            o_e = self.o_e
            self.d_last = d.copy()
        pull, coup = self.end_factors(g, d, o_e)
        km = np.sqrt(pull)
        f[0] = f[0] * km
        f[1] = f[1] * coup / km
        if run:
            self.record(*_factor_force(g, i_q, i_d, pull, coup))

    def advance(self, i, t, Ts: float) -> None:
        """``delayed_entry``: the lagged overhang relaxes towards the last period's over ``Ts``."""
        if self.o_e is None or self.d_last is None:
            return
        o = sum(self.overhangs(self.d_last))
        self.o_e = o + (self.o_e - o) * math.exp(-Ts / self.p["tau_e"])


# --------------------------------------------------------------------------- saturation
class SaturationV13(_V13, _Peaks, Saturation):
    """Saturation of iron whose permeability the magnets' pull stresses, or whose magnetization remembers its past
    through Preisach's relays.

    Both: the loss ``km = kc = 1 - l_lo x^n`` (hook ``factors_i``) at the iron's magnetization ``x``, from ``b = B(g)
    / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); the size recorded while simulated.

    * ``villari_stress`` -- the pull compresses the stator's teeth; compression lowers the permeability of iron of
      positive magnetostriction (the Villari effect: Bozorth, "Ferromagnetism", Van Nostrand 1951, ch. 13; Jiles,
      "Theory of the magnetomechanical effect", J. Phys. D 28(8), 1995), so the iron saturates earlier the harder it
      is pulled: ``x = b (1 + s_v (f2(g) / f2(g_lo) - 1))``, ``x = 1`` at the lower stop.
    * ``preisach_relays`` -- the iron's irreversible part as ``N = 8`` rectangular relays (Preisach, "Uber die
      magnetische Nachwirkung", Z. Phys. 94, 1935; Mayergoyz, "Mathematical Models of Hysteresis", Springer 1991,
      ch. 1), centred at ``b_c + w (j - 3.5) / 4``, each switching up at its centre plus ``h_w`` and down at its
      centre minus ``h_w``: ``x = b (1 + h_p m)``, ``m`` the relays' mean in ``[-1, 1]``, the relays set from the
      first gap (each up if its centre lies below ``b``) and switched once per control period (hook ``advance``).
    """

    families = ("villari_stress", "preisach_relays")
    N_RELAYS = 8
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "villari_stress": {"l_lo": 0.12, "n": 2.0, "s_v": 0.3, "target": "both"},
        "preisach_relays": {"l_lo": 0.12, "n": 2.0, "b_c": 0.7, "w": 0.1, "h_w": 0.03, "h_p": 0.2, "target": "both"},
    }
    has_factors_i: ClassVar[bool] = True  # type: ignore[misc]
    has_advance: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")
        self.has_factors = False
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """No relays set, no peak."""
        self.relays: np.ndarray | None = None
        self.g_last: np.ndarray | None = None
        self.reset_peaks(n_runs)

    def centres(self) -> np.ndarray:
        """The relays' centres in ``b`` (``preisach_relays``)."""
        j = np.arange(self.N_RELAYS)
        return self.p["b_c"] + self.p["w"] * (j - 0.5 * (self.N_RELAYS - 1)) / (0.5 * self.N_RELAYS)

    def switch(self, b, relays=None):
        """The relays' states (+-1, last axis) after the flux ``b``; from ``relays`` (None: set from ``b``)."""
        b = np.asarray(b, dtype=float)[..., None]
        c = self.centres()
        if relays is None:
            return np.where(b > c, 1.0, -1.0)
        return np.where(b > c + self.p["h_w"], 1.0, np.where(b < c - self.p["h_w"], -1.0, relays))

    def magnetization(self, g, relays=None):
        """The iron's ``x`` at gap ``g`` (``preisach_relays``: with the relays' states; None: set from ``b``)."""
        p = self.p
        b = flux(g)
        if self.family == "villari_stress":
            return b * (1.0 + p["s_v"] * (_pull_ratio(g, G_STOP_LO) - 1.0))
        r = self.switch(b) if relays is None else relays
        return b * (1.0 + p["h_p"] * np.mean(r, axis=-1))

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """The magnets' and the currents' field at the magnetization; the force recorded while simulated."""
        g = np.asarray(g, dtype=float)
        run = g.ndim == 1 and g.shape[0] == self.n_runs
        relays = None
        if run and self.family == "preisach_relays":
            if self.relays is None or self.relays.shape[0] != g.shape[0]:
                self.relays = self.switch(flux(g))
            relays = self.relays
        kk = 1.0 - self.p["l_lo"] * self.magnetization(g, relays) ** self.p["n"]
        f[0] = f[0] * kk
        f[1] = f[1] * kk
        if run:
            self.g_last = g.copy()
            self.record(*_factor_force(g, i_q, i_d, kk * kk, kk * kk))

    def advance(self, i, t, Ts: float) -> None:
        """``preisach_relays``: switch the relays at the last period's flux."""
        if self.family == "preisach_relays" and self.relays is not None and self.g_last is not None:
            self.relays = self.switch(flux(self.g_last), self.relays)

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


#: The thirteenth set: one class per effect (library families and new effects), by effect name.
V13_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV13,
        FrictionV13,
        EndEffectV13,
        SaturationV13,
        AmplifierV13,
        CommutationV13,
        EddyDragV13,
        BaseTilt,
        ProbeFilter,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V13: tuple[str, ...] = tuple(EFFECTS_V12) + tuple(n for n in V13_LAWS if n not in EFFECTS_V12)
V13_LIBRARY: tuple[str, ...] = tuple(n for n, c in V13_LAWS.items() if c.library)
V13_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V13_LAWS.items() if not c.library)
REGISTRIES = (*REGISTRIES_V12, V13_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v12, then v13)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V13)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V13)


__all__ = [
    "EFFECTS_V13",
    "V13_LAWS",
    "V13_LIBRARY",
    "V13_OUT_OF_LIBRARY",
    "AmplifierV13",
    "BaseTilt",
    "CoggingV13",
    "CommutationV13",
    "EddyDragV13",
    "EndEffectV13",
    "FrictionV13",
    "ProbeFilter",
    "SaturationV13",
    "law_class",
    "make_law",
]
