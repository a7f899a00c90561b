"""A twelfth set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v12"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v11`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v12_drive`), and two effects outside the
library (in :mod:`.laws_v12_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v12"`` in
its truth record. The source of each law (author, title, venue, year) is in its docstring and in
``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``held``, ``rotate_at``,
``read_at``, ``advance``, the state-space amplifier); no hook was added. A law with a state the recorded trajectory
does not hold (a temperature, an aging permeability, a hysteretic magnetization) records its peak force while
simulated (``recorded``), at the integrator's stage states, with nominal constants.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import G_STOP_LO, LAWS, Cogging, EndEffect, Friction, Law, Saturation, build_law, resolve_law
from .laws_new import NEW_LAWS
from .laws_v3 import V3_LAWS
from .laws_v4 import L_ARRAY, V4_LAWS
from .laws_v5 import V5_LAWS
from .laws_v6 import V6_LAWS
from .laws_v7 import V7_LAWS
from .laws_v8 import V8_LAWS
from .laws_v9 import V9_LAWS
from .laws_v10 import V10_LAWS
from .laws_v11 import EFFECTS_V11, V11_LAWS
from .laws_v12_drive import AmplifierV12, CommutationV12, EddyDragV12
from .laws_v12_ool import _V12, G_REF, EndBumpers, MainsHum, _Peaks, _Warming
from .physics import NOMINAL, shape

_TWO_PI = 2.0 * math.pi


def flux(g):
    """``b = B(g) / B(g_lo)``: MODEL.md's field over its value at the lower stop."""
    return shape(g).B / float(shape(G_STOP_LO).B)


def _overlap(a0, a1, b0, b1):
    """Length of the overlap of the intervals ``[a0, a1]`` and ``[b0, b1]`` (elementwise, >= 0)."""
    return np.maximum(0.0, np.minimum(a1, b1) - np.maximum(a0, b0))


def _f2_ratio(g, h: float = 1e-7):
    """``(f2(g) / f2(15 mm), its derivative in g)`` (MODEL.md's ``f2``, the pull's shape)."""
    g = np.asarray(g, dtype=float)
    ref = float(shape(G_REF).f2)
    return shape(g).f2 / ref, (shape(g + h).f2 - shape(g - h).f2) / (2 * h * ref)


# ----------------------------------------------------------------------------- cogging
class CoggingV12(_V12, _Peaks, _Warming, Cogging):
    """Cogging of magnets that warm with the coils, or of tooth tips that flex under the magnets' pull.

    Both conservative at each instant, from an energy ``W = (t1 / 2 pi) sum_k (a_k / k) cos theta_k`` of the slot
    pitch's harmonics k = 1, 2 (``theta_k = 2 pi k (d - x0) / t1 + phi_k``, ``c_1 = 1 - |c2|``; ``F = -grad W``) with
    the open slot's decay ``exp(-2 pi k (g - g_ref) / t1)`` (Zhu & Howe, "Analytical prediction of the cogging torque
    in radial-field permanent magnet brushless motors", IEEE Trans. Magn. 28(2), 1992).

    * ``warm_magnets`` -- the cogging energy goes as the magnets' remanence squared, ``Br(T) = Br (1 - alpha_B dT)``
      (NdFeB's reversible temperature coefficient: Campbell, "Permanent Magnet Materials and their Application",
      Cambridge Univ. Press 1994, ch. 5; Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press
      2001, ch. 2); the magnets across the gap warm with the coils' copper loss, a first-order thermal path (Mayr et
      al., "Thermal issues in machine tools", CIRP Annals 61(2), 2012): ``a_k = xi0 c_k (1 - alpha_B dT)^2 exp(...)``,
      a cogging that weakens over the dataset's time (hook ``advance``; size recorded while simulated).
    * ``flexing_tips`` -- the teeth's tips (cantilevers over the slot openings) bend towards the array under the
      magnets' pull, ``~ f2(g)`` (MODEL.md), by ``delta_t`` at 15 mm (Gere & Timoshenko, "Mechanics of Materials",
      4th ed., PWS 1997, ch. 9; the tooth tips' load: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed.,
      CRC 2011): the slots' harmonics see ``g_e = g - delta_t f2(g) / f2(15 mm)``, ``a_k = xi0 c_k exp(-2 pi k (g_e -
      g_ref) / t1)``, ``F_g = -dW/dg_e (1 - delta_t f2'(g) / f2(15 mm))``: a cogging that grows faster than the
      exponential as the gap closes.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("warm_magnets", "flexing_tips")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "warm_magnets": {
            "xi0": 3.0,
            "c2": 0.2,
            "phi2": 0.0,
            "x0": 0.0,
            "alpha_B": 1.1e-3,
            "R_c": 3.0,
            "dT_w": 0.3,
            "tau_th": 40.0,
            "replace": 0.0,
        },
        "flexing_tips": {"xi0": 3.0, "c2": 0.2, "phi2": 0.0, "x0": 0.0, "delta_t": 5e-5, "replace": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_advance = self.family == "warm_magnets"
        self.reset(0)
        if self.has_advance:
            self.recorded = self.peaks  # a temperature the recorded trajectory does not hold: the law's own record

    def reset(self, n_runs: int) -> None:
        """Cold, no peak."""
        self.warm_reset()
        self.reset_peaks(n_runs)

    def advance(self, i, t, Ts: float) -> None:
        """``warm_magnets``: the magnets' temperature rise over the period."""
        self.warm_advance(i, t, Ts)

    def gain(self, run: bool):
        """``(1 - alpha_B dT)^2`` per run (``warm_magnets``; 1 cold or outside a simulation)."""
        if self.family != "warm_magnets" or not run or self.dT is None:
            return 1.0
        return (1.0 - self.p["alpha_B"] * self.dT) ** 2

    def seen_gap(self, g):
        """``(g_e, dg_e/dg)``: the gap the slots' harmonics see."""
        g = np.asarray(g, dtype=float)
        if self.family != "flexing_tips":
            return g, 1.0 + 0.0 * g
        r, dr = _f2_ratio(g)
        return g - self.p["delta_t"] * r, 1.0 - self.p["delta_t"] * dr

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        run = g.ndim == 1 and self.dT is not None and g.shape[0] == self.dT.shape[0] == self.n_runs
        gain = self.gain(run)
        ge, dge = self.seen_gap(g)
        fg = fd = 0.0
        for kk, c, ph in ((1, 1.0 - abs(p["c2"]), 0.0), (2, p["c2"], p["phi2"])):
            rate = -_TWO_PI * kk / k.t1
            a = gain * p["xi0"] * c * np.exp(rate * (ge - k.g_cog_ref))
            th = _TWO_PI * kk * (d - p["x0"]) / k.t1 + ph
            fd = fd + a * np.sin(th)
            fg = fg - k.t1 / (_TWO_PI * kk) * rate * a * dge * np.cos(th)
        fg, fd = fg + 0.0 * d, fd + 0.0 * g
        if run:
            self.record(fg, fd)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV12(_V12, Friction):
    """Friction of a rail with debris on it, or of a rolling contact with Iwan's distributed presliding.

    * ``debris_spots`` -- wear particles and dirt caught at a few places on the horizontal rail raise the rolling
      resistance there (third bodies in the contact: Godet, "The third-body approach: a mechanical view of wear",
      Wear 100, 1984; Rabinowicz, "Friction and Wear of Materials", 2nd ed., Wiley 1995, ch. 4): ``F_d = -(Fc_d (1 +
      sum_j a_j exp(-((d - x_j) / w_j)^2)) tanh(d_dot / v_reg) + b_d d_dot)``, three spots; the gap axis' guide
      clean, ``F_g = -(Fc_g tanh(g_dot / v_reg) + b_g g_dot)``.
    * ``iwan_presliding`` -- the contact as a continuum of elasto-slip elements with yield displacements spread
      uniformly over ``[0, x_max]`` (Iwan, "A distributed-element model for hysteresis and its steady-state dynamic
      response", ASME J. Appl. Mech. 33(4), 1966; presliding in rolling guides: Al-Bender & Symens,
      "Characterization of frictional hysteresis in ball-bearing guideways", Wear 258, 2005): from rest the force
      follows the parabola ``F = k x - k x^2 / (2 x_max)``, ``k = 2 Fc / x_max``, up to ``Fc`` at ``x_max``, and every
      reversal Masing's rule (the virgin curve doubled in both scales); ``N = 24`` equal elements stand for the
      continuum, each advanced exactly per sub-step and its force averaged over it (hook ``held``), plus a viscous
      ``b v``.
    """

    families = ("debris_spots", "iwan_presliding")
    N_EL = 24
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "debris_spots": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "b_g": 0.5,
            "b_d": 0.5,
            "a_1": 2.0,
            "x_1": -0.02,
            "w_1": 2e-3,
            "a_2": 1.0,
            "x_2": 0.01,
            "w_2": 3e-3,
            "a_3": 1.5,
            "x_3": 0.03,
            "w_3": 1.5e-3,
            "v_reg": 1e-3,
        },
        "iwan_presliding": {"Fc_g": 0.15, "Fc_d": 0.15, "b_g": 0.5, "b_d": 0.5, "x_max": 3e-5},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "debris_spots"
        self.has_held = self.family == "iwan_presliding"
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """Every element relaxed (at rest)."""
        self.z = np.zeros((n_runs, 2, self.N_EL))

    def spots(self, d):
        """``1 + sum_j a_j exp(-((d - x_j) / w_j)^2)`` (``debris_spots``)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        return 1.0 + sum(p[f"a_{j}"] * np.exp(-(((d - p[f"x_{j}"]) / p[f"w_{j}"]) ** 2)) for j in (1, 2, 3))

    def force(self, g, gd, d, dd):
        """``debris_spots``' friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        fd = -(p["Fc_d"] * self.spots(d) * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        return fg + 0.0 * dd, fd + 0.0 * gd

    def yields(self) -> np.ndarray:
        """The elements' yield displacements ``x_j = x_max (j - 1/2) / N`` [m] (``iwan_presliding``)."""
        return self.p["x_max"] * (np.arange(self.N_EL) + 0.5) / self.N_EL

    def held(self, gd, dd, h: float):
        """``iwan_presliding``: the force over a sub-step of length ``h`` (advances the elements)."""
        p = self.p
        v = np.stack([np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)], axis=-1)
        if self.z.shape[:-1] != v.shape:
            self.z = np.zeros((*v.shape, self.N_EL))
        xj = self.yields()
        vv = v[..., None]
        end = np.clip(self.z + vv * h, -xj, xj)
        # each element moves at v until it reaches its yield, then slips there: its mean displacement over h
        target = np.sign(vv) * xj
        with np.errstate(divide="ignore", invalid="ignore"):
            t_hit = np.where(vv != 0.0, (target - self.z) / vv, np.inf)
        t_hit = np.clip(t_hit, 0.0, h)
        mean = (self.z * t_hit + 0.5 * vv * t_hit * t_hit + end * (h - t_hit)) / h
        self.z = end
        fc = np.array([p["Fc_g"], p["Fc_d"]])
        stiff = (2.0 * fc / p["x_max"]) / self.N_EL  # k / N per element
        f = -(stiff * np.sum(mean, axis=-1) + np.array([p["b_g"], p["b_d"]]) * v)
        return f[..., 0], f[..., 1]


# -------------------------------------------------------------------------- end effects
class EndEffectV12(_V12, EndEffect):
    """End effects: a double-layer winding's half-filled end slots, or a stack whose depth tapers at its ends.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``: at ``x_p = L/2 + e_p`` and ``-x_n``; the
    array over ``[d - L/2, d + L/2]``, its overhang beyond the stator ``O(d)`` (lost: ``1 - O/L`` as the earlier
    sets). Both through hook ``factors``: ``km^2`` scales the pull, ``km kc`` the currents' terms.

    * ``half_filled_slots`` -- in a double-layer winding the last ``n_h`` slots of each end hold one coil side
      instead of two (Pyrhonen, Jokinen & Hrabovcova, "Design of Rotating Electrical Machines", 2nd ed., Wiley 2014,
      ch. 2 (double-layer windings); for a linear motor's ends: Gieras, Piech & Tomczuk, "Linear Synchronous Motors",
      2nd ed., CRC 2011; Boldea & Nasar, "Linear Electric Actuators and Generators", Cambridge Univ. Press 1997): the
      iron is there, the pull whole, the currents' linkage over those slots half: ``km^2 = 1 - O/L``, ``km kc = 1 -
      O/L - sum_e c_h / (2 L)``, ``c_h`` the array's overlap with the last ``n_h t1``: a loss of the currents'
      coupling only, independent of the gap.
    * ``tapered_stack`` -- the stack's depth narrows linearly over the last ``l_t`` of each end, to ``1 - r_t`` of
      ``LA`` at the end (a stepped stack against the end force); the field couples over the depth plus a fringe of
      ``c_f g`` past each side face (Carter's fringing: Carter, "Note on air-gap and interpolar induction", J. IEE 29,
      1900; Hanselman, "Brushless Permanent Magnet Motor Design", 2nd ed., Magna Physics 2006, ch. 4): the local share
      ``(LA w(x) + 2 c_f g) / (LA + 2 c_f g)``; ``km^2 = km kc = 1 - O/L - sum_e (r_t / (2 l_t L)) ((b - x0)^2 - (a -
      x0)^2) LA / (LA + 2 c_f g)`` over the covered part ``[a, b]`` of the taper (``x0`` its start): a loss at the
      ends that grows as the gap closes.
    """

    families = ("half_filled_slots", "tapered_stack")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "half_filled_slots": {"e_p": 0.02, "e_n": 0.03, "n_h": 2.0},
        "tapered_stack": {"e_p": 0.02, "e_n": 0.03, "l_t": 0.03, "r_t": 0.4, "c_f": 0.6},
    }

    def ends(self) -> tuple[float, float]:
        """``(x_p, x_n)`` [m]."""
        return 0.5 * L_ARRAY + self.p["e_p"], 0.5 * L_ARRAY + self.p["e_n"]

    def overhangs(self, d):
        """``(O_p(d), O_n(d))``: the array's length beyond each stator end [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = self.ends()
        return np.maximum(0.0, d + 0.5 * L_ARRAY - xp), np.maximum(0.0, -xn - d + 0.5 * L_ARRAY)

    def end_factors(self, g, d):
        """``(km^2, km kc)`` at gap ``g`` and position ``d``."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        xp, xn = self.ends()
        a0, a1 = d - 0.5 * L_ARRAY, d + 0.5 * L_ARRAY
        o = sum(self.overhangs(d))
        pull = 1.0 - o / L_ARRAY + 0.0 * g
        if self.family == "half_filled_slots":
            lh = p["n_h"] * k.t1
            ch = _overlap(a0, a1, xp - lh, xp) + _overlap(a0, a1, -xn, -xn + lh)
            return pull, pull - 0.5 * ch / L_ARRAY
        lt = p["l_t"]
        lost = 0.0
        # positive end: the taper from xp - lt (full depth) to xp; negative end mirrored
        for lo, hi, x0, sgn in ((xp - lt, xp, xp - lt, 1.0), (-xn, -xn + lt, -xn + lt, -1.0)):
            a, b = np.maximum(a0, lo), np.minimum(a1, hi)
            b = np.maximum(a, b)
            ua, ub = sgn * (a - x0), sgn * (b - x0)
            lost = lost + np.abs(ub * ub - ua * ua) * p["r_t"] / (2 * lt)
        share = k.LA / (k.LA + 2 * p["c_f"] * g)
        pull = pull - lost * share / L_ARRAY
        return pull, pull

    def factors(self, g, d, f: list) -> None:
        """The magnets' field and the currents' coupling at the ends."""
        pull, coup = self.end_factors(g, d)
        km = np.sqrt(pull)
        f[0] = f[0] * km
        f[1] = f[1] * coup / km


# --------------------------------------------------------------------------- saturation
class SaturationV12(_V12, _Peaks, Saturation):
    """Saturation whose iron ages after demagnetization, or whose magnetization follows Rayleigh's loops.

    Both: the loss of the field at the iron's magnetization ``x``, ``km = kc = 1 - l_lo x^n`` (hook ``factors_i``),
    from ``b = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); a state advanced once per control period
    (hook ``advance``); the size recorded while simulated.

    * ``disaccommodation`` -- the iron's permeability falls after it was last demagnetized (the session's start),
      logarithmically in time (Snoek, "Time effects in magnetization", Physica 5, 1938; Chikazumi, "Physics of
      Ferromagnetism", 2nd ed., Oxford 1997, ch. 20): the iron's magnetic voltage at a flux grows as ``1 + D ln(1 +
      t / t0)``, ``x = b (1 + D ln(1 + t / t0))``, ``t`` the dataset time (runs one after the other).
    * ``rayleigh_loop`` -- at the iron's moderate fields its magnetization follows Rayleigh's law (Rayleigh, "On the
      behaviour of iron and steel under the operation of feeble magnetic forces", Phil. Mag. 23, 1887; Bertotti,
      "Hysteresis in Magnetism", Academic Press 1998, ch. 7): with ``mu = 1 - rho``, ``eta = rho`` (``x(1) = 1`` on
      the initial curve ``mu b + eta b^2``), every branch from the last reversal ``(b_r, x_r)`` is ``x = x_r + mu u +
      (eta / 2) u |u|``, ``u = b - b_r``; the iron starts on its initial curve at its first gap, a reversal is taken
      when ``b`` turns between control periods (the last reversal only).
    """

    families = ("disaccommodation", "rayleigh_loop")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "disaccommodation": {"l_lo": 0.12, "n": 2.0, "D": 0.02, "t0": 1.0, "target": "both"},
        "rayleigh_loop": {"l_lo": 0.12, "n": 2.0, "rho": 0.35, "target": "both"},
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
        """No time yet, no reversal, no peak."""
        self.t: np.ndarray | None = None
        self.br: np.ndarray | None = None  # last reversal: b_r, x_r; the branch's direction; the last period's b
        self.xr: np.ndarray | None = None
        self.dirn: np.ndarray | None = None
        self.b_prev: np.ndarray | None = None
        self.g_last: np.ndarray | None = None
        self.reset_peaks(n_runs)

    def loss(self, x):
        """Fraction of the magnets' pull lost at the magnetization ``x``."""
        return 1.0 - (1.0 - self.p["l_lo"] * np.asarray(x, dtype=float) ** self.p["n"]) ** 2

    def initial(self, b):
        """Rayleigh's initial curve ``(1 - rho) b + rho b^2`` (``rayleigh_loop``)."""
        r = self.p["rho"]
        return (1.0 - r) * b + r * b * b

    def branch(self, b, br, xr):
        """Rayleigh's branch from the reversal ``(br, xr)`` at ``b`` (``rayleigh_loop``)."""
        r = self.p["rho"]
        u = b - br
        return xr + (1.0 - r) * u + 0.5 * r * u * np.abs(u)

    def held_flux(self, g, run: bool):
        """The magnetization ``x`` (the initial curve, or no aging, outside a simulation)."""
        p = self.p
        b = flux(g)
        if self.family == "disaccommodation":
            if run and self.t is not None:
                return b * (1.0 + p["D"] * np.log1p(self.t / p["t0"]))
            return b
        if not run:
            return self.initial(b)
        if self.br is None:
            b0 = np.asarray(b, dtype=float).copy()
            self.br, self.xr, self.b_prev = b0, self.initial(b0), b0.copy()
            self.dirn = np.zeros_like(b0)
        return self.branch(b, self.br, self.xr)

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """The magnets' and the currents' field at the magnetization; the force recorded while simulated."""
        g = np.asarray(g, dtype=float)
        run = g.ndim == 1 and g.shape[0] == self.n_runs
        x = self.held_flux(g, run)
        kk = 1.0 - self.p["l_lo"] * x ** self.p["n"]
        f[0] = f[0] * kk
        f[1] = f[1] * kk
        if run:
            self.g_last = g.copy()
            sh, c = shape(g), NOMINAL
            up = c.C2 * sh.f2 * (kk * kk - 1) - c.C3 * sh.f3 * i_d * (kk * kk - 1)
            up = up + c.C4 * sh.f4 * (i_q * i_q + i_d * i_d) * (kk * kk - 1)
            self.record(k.Mv * up, k.Mh * c.C1 * sh.f1 * i_q * (kk * kk - 1))

    def advance(self, i, t, Ts: float) -> None:
        """The dataset time (aging), or a reversal of the flux between periods (Rayleigh)."""
        if self.family == "disaccommodation":
            self.t = np.asarray(t, dtype=float).reshape(-1).copy()
            return
        if self.br is None or self.g_last is None:
            return
        b = np.asarray(flux(self.g_last), dtype=float)
        step = np.sign(b - self.b_prev)
        turn = (step != 0.0) & (self.dirn != 0.0) & (step != self.dirn)
        if np.any(turn):  # the last period's flux becomes the reversal point
            x_prev = self.branch(self.b_prev, self.br, self.xr)
            self.br = np.where(turn, self.b_prev, self.br)
            self.xr = np.where(turn, x_prev, self.xr)
        self.dirn = np.where(step != 0.0, step, self.dirn)
        self.b_prev = b

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


#: The twelfth set: one class per effect (library families and new effects), by effect name.
V12_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV12,
        FrictionV12,
        EndEffectV12,
        SaturationV12,
        AmplifierV12,
        CommutationV12,
        EddyDragV12,
        MainsHum,
        EndBumpers,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V12: tuple[str, ...] = tuple(EFFECTS_V11) + tuple(n for n in V12_LAWS if n not in EFFECTS_V11)
V12_LIBRARY: tuple[str, ...] = tuple(n for n, c in V12_LAWS.items() if c.library)
V12_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V12_LAWS.items() if not c.library)
REGISTRIES = (
    LAWS,
    NEW_LAWS,
    V3_LAWS,
    V4_LAWS,
    V5_LAWS,
    V6_LAWS,
    V7_LAWS,
    V8_LAWS,
    V9_LAWS,
    V10_LAWS,
    V11_LAWS,
    V12_LAWS,
)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v11, then v12)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V12)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V12)


__all__ = [
    "EFFECTS_V12",
    "G_REF",
    "V12_LAWS",
    "V12_LIBRARY",
    "V12_OUT_OF_LIBRARY",
    "AmplifierV12",
    "CoggingV12",
    "CommutationV12",
    "EddyDragV12",
    "EndBumpers",
    "EndEffectV12",
    "FrictionV12",
    "MainsHum",
    "SaturationV12",
    "flux",
    "law_class",
    "make_law",
]
