"""New law families of the rig's effects, written from the physics literature (issue 27's pre-registered check).

Every class here is another member of an effect's family (same ``name`` as the law in
:mod:`.laws`, so the same library verdict) or a new effect outside the library; all carry
``new_law = True`` so that the truth record and the blind self-check can tell them from the laws
the diagnosis was developed against. They use the same hooks as :mod:`.laws` (``factors``,
``force``, ``held``, ``rotate``, ``read``; the amplifier through ``transition``). The source of
each law (author, title, year, equation) is in its docstring and in the table of
``docs/validation`` ("New law families").
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
    AmplifierLag,
    Cogging,
    CommutationOffset,
    EndEffect,
    Friction,
    Law,
    Saturation,
    _expm2,
    build_law,
    resolve_law,
)

G_STOP_HI = k.g_stop[1]


# ----------------------------------------------------------------------------- cogging
class CoggingNew(Cogging):
    """Cogging from the slot-permeance (energy) method and the end detent of a short mover.

    * ``slot_harmonic`` -- Zhu & Howe, "Analytical prediction of the cogging torque in radial-field
      permanent magnet brushless motors", IEEE Trans. Magn. 28(2), 1992, eq. (9)-(12): the force is
      a Fourier series in the slot pitch ``lambda = 2 t1``; each harmonic ``k`` carries the skew factor
      ``Ksk_k = sin(k pi s) / (k pi s)`` (skew ``s`` in slot pitches; Bianchi & Bolognani, "Design
      techniques for reducing the cogging torque in surface-mounted PM motors", IEEE Trans. Ind. Appl.
      38(5), 2002, eq. (6)) and decays with the gap as the slot-permeance harmonic of a Laplace field,
      ``exp(-2 pi k (g - g_ref) / lambda)``:
      ``Fx = xi0 sum_k c_k Ksk_k exp(-2 pi k (g - g_ref)/lambda) sin(2 pi k d / lambda + phi_k)``.
    * ``end_detent`` -- Zhu, Xia, Howe & Mellor, "Reduction of cogging force in slotless linear
      permanent magnet motors", IEE Proc. Electr. Power Appl. 144(4), 1997, eq. (1): the two ends of the
      iron produce a detent force periodic in the *pole* pitch ``tau``,
      ``Fx = xi0 (g_ref / g)^n sum_{j=1,2} a_j sin(2 pi j d / tau + psi_j)``.

    Both exert the attractive normal force ``Fn = kn sum |F_k| sin^2(...)`` as :class:`.laws.Cogging`.
    """

    new_law = True
    families = ("slot_harmonic", "end_detent")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "slot_harmonic": {
            "xi0": 3.0,
            "c1": 1.0,
            "c2": 0.4,
            "c3": 0.2,
            "phi2": 0.5,
            "phi3": -0.8,
            "skew": 0.1,
            "kn": 1.0,
            "replace": 0.0,
        },
        "end_detent": {"xi0": 2.0, "n": 2.0, "a1": 1.0, "a2": 0.3, "psi1": 0.0, "psi2": 1.0, "kn": 1.0, "replace": 0.0},
    }

    def force(self, g, gd, d, dd):
        """Tangential force along d and normal force (as F_g, negative = closes the gap)."""
        p = self.p
        fx = 0.0
        fn = 0.0
        if self.family == "slot_harmonic":
            lam = 2.0 * k.t1
            for j in (1, 2, 3):
                x = j * math.pi * p["skew"]
                ksk = math.sin(x) / x if x > 1e-12 else 1.0
                amp = p["xi0"] * p[f"c{j}"] * ksk * np.exp(-2 * math.pi * j * (g - k.g_cog_ref) / lam)
                s = np.sin(2 * math.pi * j * d / lam + (p[f"phi{j}"] if j > 1 else 0.0))
                fx = fx + amp * s
                fn = fn + np.abs(amp) * s * s
        else:
            xi = p["xi0"] * (k.g_cog_ref / g) ** p["n"]
            for j in (1, 2):
                s = np.sin(2 * math.pi * j * d / k.tau + p[f"psi{j}"])
                fx = fx + xi * p[f"a{j}"] * s
                fn = fn + xi * abs(p[f"a{j}"]) * s * s
        return -p["kn"] * fn, fx


# ---------------------------------------------------------------------------- friction
class FrictionNew(Friction):
    """Friction laws of the guides beyond Coulomb/Stribeck/Dahl/LuGre.

    * ``maxwell_slip`` -- Al-Bender, Lampaert & Swevers, "The generalized Maxwell-slip model: a novel
      model for friction simulation and compensation", IEEE Trans. Autom. Control 50(11), 2005,
      eq. (3)-(5): ``N = 4`` elastoplastic elements in parallel, element ``i`` a spring ``k_i`` that
      sticks while ``|F_i| < W_i`` and slips at ``W_i = w_i s(v)``, ``s(v) = Fc + Fs exp(-(v/vs)^2)``
      (the Stribeck curve in slip); ``F = -(sum F_i + b v)``. Over a sub-step at constant ``v`` each
      element is advanced exactly: ``F_i <- clip(F_i + k_i v h, -W_i, W_i)``. The weights ``w_i`` fall
      geometrically (ratio ``q``) and the stiffnesses are ``k_i = sigma w_i / x_i`` with break-away
      displacements ``x_i`` spread from ``xb/4`` to ``xb``.
    * ``karnopp`` -- Karnopp, "Computer simulation of stick-slip friction in mechanical dynamic
      systems", ASME J. Dyn. Syst. Meas. Control 107, 1985: inside the zero-velocity band
      ``|v| < dv`` the guide sticks (here: a resisting force rising to the static level ``Fs`` across
      the band, ``-Fs v / dv``), outside it slides with ``-(Fc sgn v + b v)``; the force jumps from
      ``Fs`` to ``Fc`` at the band's edge.
    """

    new_law = True
    families = ("maxwell_slip", "karnopp")
    N_EL = 4
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "maxwell_slip": {
            "Fc_g": 0.2,
            "Fc_d": 0.2,
            "Fs_g": 0.05,
            "Fs_d": 0.05,
            "vs": 5e-3,
            "xb": 2e-5,
            "q": 0.6,
            "b_g": 0.5,
            "b_d": 0.5,
        },
        "karnopp": {"Fc_g": 0.2, "Fc_d": 0.2, "Fs_g": 0.3, "Fs_d": 0.3, "dv": 1e-3, "b_g": 0.5, "b_d": 0.5},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "karnopp"
        self.has_held = not self.has_force
        self.state = np.zeros((0, 2, self.N_EL))
        q = self.p.get("q", 0.6)
        w = q ** np.arange(self.N_EL)
        self.weights = w / w.sum()
        self.x_break = self.p.get("xb", 2e-5) * np.linspace(0.25, 1.0, self.N_EL)

    def reset(self, n_runs: int) -> None:
        """Zero the element forces per run, axis and element."""
        self.state = np.zeros((n_runs, 2, self.N_EL))

    def slip_level(self, v, ax: str):
        """Slip force ``s(v)`` of the whole model [N] (Stribeck curve)."""
        p = self.p
        return p[f"Fc_{ax}"] + p[f"Fs_{ax}"] * np.exp(-((np.asarray(v) / p["vs"]) ** 2))

    def force(self, g, gd, d, dd):
        """Karnopp friction on both axes."""
        p = self.p
        out = []
        for v, ax in ((gd, "g"), (dd, "d")):
            inside = np.abs(v) < p["dv"]
            stick = -p[f"Fs_{ax}"] * v / p["dv"]
            slide = -(p[f"Fc_{ax}"] * np.sign(v) + p[f"b_{ax}"] * v)
            out.append(np.where(inside, stick, slide))
        return out[0], out[1]

    def held(self, gd, dd, h: float):
        """Advance the Maxwell-slip elements over ``h`` at the current velocities; return the held force."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            W = self.slip_level(v, ax)[:, None] * self.weights[None, :]
            kel = W / self.x_break[None, :]  # element stiffness: breaks away after x_i of travel
            F = np.clip(self.state[:, j, :] + kel * (v * h)[:, None], -W, W)
            self.state[:, j, :] = F
            out.append(-(F.sum(axis=1) + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
class EndEffectNew(EndEffect):
    """End effects of a short mover written from linear-machine theory.

    * ``entry_exp`` -- Boldea & Nasar, "Linear Electric Actuators and Generators", Cambridge Univ.
      Press, 1997, sec. 3 (longitudinal end effect): the air-gap field at the entry end builds up as
      ``1 - exp(-x / delta_e)``; the force lost grows with the overhang ``x = max(0, |d| - d_edge)`` as
      ``rho = 1 - loss (1 - exp(-x / delta))``.
    * ``fringe`` -- Carter's conformal map of a pole edge (Carter, "Note on air-gap and interpolar
      induction", J. IEE 29, 1900): the fringing field across an edge falls as
      ``1/2 - arctan(x / w) / pi``; ``rho = 1 - loss (S(|d|) - S(0)) / (1 - S(0))`` with
      ``S(x) = 1/2 + arctan((x - d_edge) / w) / pi`` (normalized so that ``rho(0) = 1``).

    Both keep :class:`.laws.EndEffect`'s pole-pitch thrust ripple.
    """

    new_law = True
    families = ("entry_exp", "fringe")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "entry_exp": {**EndEffect._ripple, "d_edge": 0.025, "delta": 0.01, "loss": 0.25},
        "fringe": {**EndEffect._ripple, "d_edge": 0.035, "w": 0.006, "loss": 0.25},
    }

    def rho(self, d):
        """Fraction of the magnetic force left at horizontal position ``d``."""
        p = self.p
        if self.family == "entry_exp":
            x = np.maximum(np.abs(d) - p["d_edge"], 0.0)
            return 1.0 - p["loss"] * (1.0 - np.exp(-x / p["delta"]))

        def S(x):
            return 0.5 + np.arctan((x - p["d_edge"]) / p["w"]) / math.pi

        s0 = S(0.0)
        return 1.0 - p["loss"] * (S(np.abs(d)) - s0) / (1.0 - s0)


# --------------------------------------------------------------------------- saturation
class SaturationNew(Saturation):
    """Saturation from a B-H law of the iron.

    The field in the iron is taken proportional to the PM circuit's flux, ``x = g_lo / g`` (1 at the
    lower stop); the factor is the ratio of the saturating to the linear B-H law, normalized to 1 at
    the upper stop ``g_hi`` (where the iron is far from saturation):

    * ``frohlich`` -- Frohlich-Kennelly law ``B = H / (a + b |H|)`` (Kennelly, "Magnetic reluctance",
      Trans. AIEE 8, 1891; in Jiles, "Introduction to Magnetism and Magnetic Materials", 1991,
      sec. 2): ratio to linear ``1 / (1 + beta x)``, so ``f = (1 + beta x_hi) / (1 + beta x)``;
    * ``langevin`` -- Langevin anhysteretic magnetization ``M = Ms (coth y - 1/y)`` (Jiles & Atherton,
      "Theory of ferromagnetic hysteresis", J. Magn. Magn. Mater. 61, 1986, eq. (4)): ratio to its
      initial slope ``Lr(y) = 3 (coth y - 1/y) / y``, ``f = Lr(a x) / Lr(a x_hi)``.

    Both tend to the linear law (``f = 1``) as the field goes to zero (``beta, a -> 0``). ``target``
    as in :class:`.laws.Saturation`.
    """

    new_law = True
    families = ("frohlich", "langevin")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "frohlich": {"beta": 0.4, "target": "magnet"},
        "langevin": {"a": 2.5, "target": "both"},
    }

    @staticmethod
    def _lr(y):
        y = np.maximum(np.asarray(y, dtype=float), 1e-6)
        small = y < 1e-3
        ys = np.where(small, 1.0, y)
        full = 3.0 * (1.0 / np.tanh(ys) - 1.0 / ys) / ys
        return np.where(small, 1.0 - y * y / 15.0, full)

    def loss(self, g):
        """Fraction of the saturating field lost at gap ``g``."""
        p = self.p
        x, x_hi = G_STOP_LO / np.asarray(g), G_STOP_LO / G_STOP_HI
        if self.family == "frohlich":
            f = (1.0 + p["beta"] * x_hi) / (1.0 + p["beta"] * x)
        else:
            f = self._lr(p["a"] * x) / self._lr(p["a"] * x_hi)
        return 1.0 - f


# ------------------------------------------------------------------- amplifier and delay
class AmplifierNew(AmplifierLag):
    """Current-loop laws built from the loop's own structure.

    * ``cascade`` -- a PI current loop on the winding's ``R-L`` tuned by pole-zero cancellation
      (``Ki / Kp = R / L``, closed-loop bandwidth ``wc = Kp / L``; Harnefors & Nee, "Model-based current
      control of AC machines using the internal model control method", IEEE Trans. Ind. Appl. 34(1),
      1998, eq. (10)) with the inverter/PWM as a first-order lag ``wf`` in the forward path: the loop
      ``wc wf / (s (s + wf))`` closes to ``wc wf / (s^2 + wf s + wc wf)``, i.e. ``wn = sqrt(wc wf)`` and
      ``zeta = sqrt(wf / wc) / 2`` (over-damped for ``wf > 4 wc``).
    * ``digital`` -- a digitally controlled loop: computation delay of ``n_comp`` samples plus the
      half-sample delay of the zero-order hold (Buso & Mattavelli, "Digital Control in Power
      Electronics", 2006, sec. 4.2: ``exp(-s Ts/2)`` for the ZOH) and the PWM's first-order lag:
      ``delay_samples = n_comp + 1/2``, a lag at ``bandwidth_hz``.
    """

    new_law = True
    families = ("cascade", "digital")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cascade": {"bandwidth_hz": 250.0, "filter_hz": 2000.0, "delay_samples": 0.0},
        "digital": {"n_comp": 1.0, "bandwidth_hz": 500.0, "delay_samples": 1.5},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        if self.family == "digital":  # the delay is the law's own: computation + ZOH
            own = float(self.p["n_comp"]) + 0.5
            if "delay_samples" in params and abs(float(params["delay_samples"]) - own) > 1e-12:
                raise ValueError(f"amplifier_lag (digital): delay_samples must be n_comp + 0.5 = {own}")
            self.p["delay_samples"] = own

    def natural(self) -> tuple[float, float]:
        """``(wn [rad/s], zeta)`` of the closed ``cascade`` loop."""
        wc, wf = 2 * math.pi * self.p["bandwidth_hz"], 2 * math.pi * self.p["filter_hz"]
        return math.sqrt(wc * wf), 0.5 * math.sqrt(wf / wc)

    def transition(self, tau: float) -> np.ndarray:
        """Matrix ``Phi(tau)`` of the amplifier state ``(i - u, i')`` after ``tau`` seconds (constant input)."""
        if tau == 0.0:
            return np.eye(2)
        if self.family == "digital":
            w = 2 * math.pi * self.p["bandwidth_hz"]
            return np.array([[math.exp(-w * tau), 0.0], [0.0, 0.0]])
        wn, z = self.natural()
        A = np.array([[0.0, 1.0], [-wn * wn, -2 * z * wn]])
        return _expm2(A * tau)

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] (phase slope at zero frequency) including the transport delay."""
        if self.family == "digital":
            return self.p["delay_samples"] * Ts + 1.0 / (2 * math.pi * self.p["bandwidth_hz"])
        wn, z = self.natural()
        return self.p["delay_samples"] * Ts + 2 * z / wn


# ------------------------------------------------------------------------- commutation
class CommutationNew(CommutationOffset):
    """Commutation angle errors that vary along the stroke or with the load.

    * ``pitch_error`` -- a magnet placement (pitch) error: the field's electrical angle is off by a
      periodic error with the magnet pair period ``2 tau``, ``delta = delta0 + a sin(pi d / tau + psi)``
      (Heydemann, "Determination and correction of quadrature fringe measurement errors in
      interferometers", Appl. Opt. 20(19), 1981, for the first-order periodic error of an
      incremental scale; here the period is the magnet pair's).
    * ``cross_saturation`` -- the d-axis shifts with the load current through cross-magnetization
      (Stumberger, Stumberger, Dolinar, Hamler & Trlep, "Evaluation of saturation and
      cross-magnetization effects in interior permanent-magnet synchronous motor", IEEE Trans. Ind.
      Appl. 39(5), 2003, eq. (3)-(4)): ``delta = delta0 + kappa_i i_q`` [rad, kappa_i in rad/A].
    """

    new_law = True
    families = ("pitch_error", "cross_saturation")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "pitch_error": {"delta0": 0.02, "a": 0.06, "psi": 0.0},
        "cross_saturation": {"delta0": 0.02, "kappa_i": 0.02},
    }

    def angle(self, d, i_q=0.0):
        """Electrical angle error at position ``d`` (and delivered thrust current ``i_q``)."""
        p = self.p
        if self.family == "pitch_error":
            return p["delta0"] + p["a"] * np.sin(math.pi * d / k.tau + p["psi"])
        return p["delta0"] + p["kappa_i"] * i_q

    def rotate(self, i_q, i_d, d):
        """Rotate the dq currents by ``delta``."""
        a = self.angle(d, i_q)
        c, s = np.cos(a), np.sin(a)
        return c * i_q - s * i_d, s * i_q + c * i_d


# --------------------------------------------------------------------------- eddy drag
class EddyDrag(Law):
    """Eddy-current drag of the magnets moving over a conducting (stator) plate -- a library effect the
    old rig laws did not have.

    * ``thin_plate`` -- Sodano, Bae & Inman, "Improved concept and model of eddy current damper",
      ASME J. Vib. Acoust. 128(3), 2006, and the thin-plate falloff of Reitz (below):
      ``F_d = -c0 v / (1 + (v / v_c)^2) exp(-2 pi (g - g_ref) / tau)`` (linear, ``-c0 v``, at low
      speed; the field's spatial harmonic at the pole pitch decays as ``exp(-2 pi g / tau)``);
    * ``reitz`` -- Reitz, "Forces on moving magnets due to eddy currents", J. Appl. Phys. 41(5), 1970,
      eq. (11)-(12): drag ``F_D = F0 w v / (v^2 + w^2)`` and lift ``F_L = F0 v^2 / (v^2 + w^2)`` (opens
      the gap), both ``F0 = F00 exp(-4 pi (g - g_ref) / tau)`` (image force of the pole-pitch harmonic).
    """

    name = "eddy_drag"
    new_law = True
    families = ("thin_plate", "reitz")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "thin_plate": {"c0": 5.0, "v_c": 0.2},
        "reitz": {"F00": 1.0, "w": 0.1},
    }
    has_force = True

    def force(self, g, gd, d, dd):
        """Eddy forces ``(F_g, F_d)`` [N] at horizontal speed ``dd``."""
        p = self.p
        if self.family == "thin_plate":
            gain = np.exp(-2 * math.pi * (g - k.g_cog_ref) / k.tau)
            return 0.0 * dd, -p["c0"] * dd / (1.0 + (dd / p["v_c"]) ** 2) * gain
        F0 = p["F00"] * np.exp(-4 * math.pi * (g - k.g_cog_ref) / k.tau)
        den = dd * dd + p["w"] ** 2
        return F0 * dd * dd / den, -F0 * p["w"] * dd / den


# --------------------------------------------------------------------- out of the library
class CableHysteresis(Law):
    """Cable slab with hysteresis (not in the library): an elastoplastic Jenkins element -- a spring
    ``k_h`` in series with a Coulomb slider ``F_y`` -- in parallel with the slab's own spring ``k0``
    along d (Iwan, "A distributed-element model for hysteresis and its steady-state dynamic
    response", ASME J. Appl. Mech. 33(4), 1966, eq. (1)-(2)):
    ``F_d = -(k0 (d - d0) + F_e)`` with, ``F_e <- clip(F_e + k_h dd h, -F_y, F_y)``.
    """

    name = "cable_hysteresis"
    library = False
    new_law = True
    families = ("jenkins",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"jenkins": {"k0": 10.0, "d0": -0.08, "k_h": 300.0, "F_y": 0.4}}
    has_held = True
    has_force = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.Fe = np.zeros(0)

    def reset(self, n_runs: int) -> None:
        """Zero the element force per run."""
        self.Fe = np.zeros(n_runs)

    def force(self, g, gd, d, dd):
        """The slab's parallel spring along d."""
        return 0.0 * g, -self.p["k0"] * (d - self.p["d0"])

    def held(self, gd, dd, h: float):
        """Advance the Jenkins element over ``h`` at the current speed; return its held force."""
        p = self.p
        dd = np.asarray(dd, dtype=float)
        self.Fe = np.clip(self.Fe + p["k_h"] * dd * h, -p["F_y"], p["F_y"])
        return np.zeros_like(dd), -self.Fe


class SensorCrosstalk(Law):
    """Cross-talk between the two encoders (not in the library): each axis reads a fraction of the
    other's motion, ``g_read = g + c_gd d`` and ``d_read = d + c_dg (g - g0)`` (the first-order
    cross-sensitivity of a position sensor; Fleming, "A review of nanometer resolution position
    sensors: operation and performance", Sens. Actuators A 190, 2013, sec. 2.3).
    """

    name = "sensor_crosstalk"
    library = False
    new_law = True
    families = ("linear",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"linear": {"c_gd": 2e-3, "c_dg": 5e-3}}
    has_read = True
    G0 = 20e-3

    def read(self, g, d):
        """Readings for the true ``(g, d)``."""
        p = self.p
        return g + p["c_gd"] * d, d + p["c_dg"] * (g - self.G0)


#: New families of each effect, by effect name.
NEW_LAWS: dict[str, type[Law]] = {
    c.name: c
    for c in (
        CoggingNew,
        FrictionNew,
        EndEffectNew,
        SaturationNew,
        AmplifierNew,
        CommutationNew,
        EddyDrag,
        CableHysteresis,
        SensorCrosstalk,
    )
}
#: Every effect name in the order the simulator applies them (old ones first, as before).
ALL_EFFECTS: tuple[str, ...] = tuple(LAWS) + tuple(n for n in NEW_LAWS if n not in LAWS)
ALL_LIBRARY: tuple[str, ...] = tuple(n for n in ALL_EFFECTS if (LAWS.get(n) or NEW_LAWS[n]).library)
ALL_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n in ALL_EFFECTS if n not in ALL_LIBRARY)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (old law first, then the new one)."""
    return resolve_law(name, family, (LAWS, NEW_LAWS), ALL_EFFECTS)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (defaults for the rest): the family picks
    the class, one of the first laws (:mod:`.laws`) or a new one (this module)."""
    return build_law(name, spec, (LAWS, NEW_LAWS), ALL_EFFECTS)


__all__ = [
    "ALL_EFFECTS",
    "ALL_LIBRARY",
    "ALL_OUT_OF_LIBRARY",
    "NEW_LAWS",
    "AmplifierNew",
    "CableHysteresis",
    "CoggingNew",
    "CommutationNew",
    "EddyDrag",
    "EndEffectNew",
    "FrictionNew",
    "SaturationNew",
    "SensorCrosstalk",
    "law_class",
    "make_law",
]
