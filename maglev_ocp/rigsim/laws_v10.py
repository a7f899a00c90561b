"""A tenth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v10"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v9`
has, and two effects outside the library (in :mod:`.laws_v10_ool`), for the next pre-registered blind check. They
were written from their sources only, without reading the diagnosis or how it fits; each class carries ``new_law =
True`` and ``law_set = "v10"`` in its truth record. The source of each law (author, title, venue, year) is in its
docstring and in ``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``rotate_at``, ``read_at``,
``advance``, the state-space amplifier); no hook was added. A law with a state the recorded trajectory does not hold
(a warm-up, a lag, a play) records its peak force while simulated (``recorded``), at the integrator's stage states,
with nominal constants.
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
from .laws_v4 import K_POLE, L_ARRAY, V4_LAWS
from .laws_v5 import V5_LAWS
from .laws_v6 import V6_LAWS
from .laws_v7 import V7_LAWS
from .laws_v8 import V8_LAWS
from .laws_v9 import EFFECTS_V9, V9_LAWS, companion
from .laws_v10_ool import _V10, G_REF, InverterDeadtime, MoverPitch, _Peaks, current_force, dq_to_abc
from .physics import NOMINAL, shape

_TWO_PI = 2.0 * math.pi


def flux(g):
    """``b = B(g) / B(g_lo)``: MODEL.md's field over its value at the lower stop."""
    return shape(g).B / float(shape(G_STOP_LO).B)


def field_slope(g):
    """``(B(g), dB/dg)`` of MODEL.md's field (``B ~ 1 / sinh(pi (hm + g) / tau)``)."""
    g = np.asarray(g, dtype=float)
    a = math.pi * (k.hm + g) / k.tau
    B = shape(g).B
    return B, -B * (math.pi / k.tau) * np.cosh(a) / np.sinh(a)


def _overlap(a0, a1, b0, b1):
    """Length of the overlap of the intervals ``[a0, a1]`` and ``[b0, b1]`` (elementwise, >= 0)."""
    return np.maximum(0.0, np.minimum(a1, b1) - np.maximum(a0, b0))


# ----------------------------------------------------------------------------- cogging
class CoggingV10(_V10, Cogging):
    """Cogging of slots closed by saturable steel bridges, or of an array whose back iron saturates.

    * ``saturable_bridge`` -- each slot's mouth is closed by a thin steel bridge (a closed slot) that the magnets'
      field saturates: a saturated bridge acts like air (the slot is open), an unsaturated one like iron (no slot).
      The bridge over slot ``s`` is open by ``phi(q) = q^n / (1 + q^n)``, ``q = B(g) |sin psi_s| / B_b`` its share of
      the saturating field, ``psi_s = pi (s t1 - d + x0) / tau`` the slot's place under the array's fundamental
      (closed slots and their bridges: Pyrhonen, Jokinen & Hrabovcova, "Design of Rotating Electrical Machines", 2nd
      ed., Wiley 2014, ch. 3 (closed slots); Hanselman, "Brushless Permanent Magnet Motor Design", 2nd ed., Magna
      Physics 2006, ch. 7; saturation of the bridges: Ostovic, "Dynamics of Saturated Electric Machines", Springer
      1989). The open slots' energy, ``W = C B^2 sum_{s=0..5} sin^2 psi_s phi(q_s)`` (six slots per electrical
      period, ``tau = 3 t1``), minus its mean over d (the mean is the slots' share of the pull, in MODEL.md's
      ``lam``); ``F = -grad W``, conservative. With fully open slots (``phi = 1``) the fundamental's energy is the
      same at every d (no cogging): the cogging comes from the bridges' nonlinearity, through the bridges that are
      half open; its fall with the gap is not an open slot's exponential (slower towards the lower stop, where the
      bridges near the poles' transitions open too; at the rig's gaps the slot pitch's fundamental is nearly all of
      it). ``xi0`` is the peak ``F_d`` over d at ``G_NORM`` (12 mm).
    * ``backiron_knee`` -- the slot-pitch harmonics ``a_k = xi0 c_k exp(-2 pi k (g - g_ref) / t1) m(g) / m(g_ref)``
      (k = 1, 2, ``c_1 = 1 - |c2|``) scaled by the share of the slot permeance ripple the flux still follows when the
      array's back iron saturates: the back iron's incremental permeability ``(1 - b / b_s)^2`` (Frohlich's curve,
      ``b = B(g) / B(g_lo)``) in series with the gap, ``m = mu_i / (mu_i + r_i)`` (incremental permeability in the
      magnetic circuit: Bozorth, "Ferromagnetism", Van Nostrand 1951; saturation and cogging: Azar, Zhu &
      Ombach, "Influence of electric loading and magnetic saturation on cogging torque, back-EMF and torque ripple of
      PM machines", IEEE Trans. Magn. 48(10), 2012; Frohlich-Kennelly: Kennelly, "Magnetic reluctance", Trans. AIEE
      8, 1891). ``W = (t1 / 2 pi) sum_k (a_k / k) cos theta_k``, ``F = -grad W``: the exponential growth towards the
      lower stop flattens (or turns) where the back iron saturates.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("saturable_bridge", "backiron_knee")
    G_NORM = 12e-3  #: gap at which ``saturable_bridge``'s peak F_d is ``xi0`` [m]
    N_SLOTS = 6
    N_MEAN = 192  #: points of the periodic trapezoid rule for the energy's mean over d
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "saturable_bridge": {"xi0": 2.0, "b_b": 0.8, "n": 2.0, "x0": 0.0, "replace": 0.0},
        "backiron_knee": {"xi0": 3.0, "c2": 0.2, "phi2": 0.0, "b_s": 1.3, "r_i": 0.15, "x0": 0.0, "replace": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.C = 1.0
        if self.family == "saturable_bridge":  # the energy's scale: the peak F_d over d at G_NORM is xi0
            d = np.linspace(0.0, k.t1, 1024, endpoint=False)
            self.C = self.p["xi0"] / float(np.max(np.abs(self.force(0 * d + self.G_NORM, 0.0, d, 0.0)[1])))

    # saturable_bridge
    def _h(self, c, B):
        """``h = B^2 c^2 phi(q)`` and its partial derivatives in ``c`` and ``B``."""
        p = self.p
        n, Bb = p["n"], p["b_b"] * float(shape(G_REF).B)
        q = B * np.abs(c) / Bb
        qn = q**n
        phi = qn / (1.0 + qn)
        dphi = n * np.where(q > 0, qn / np.maximum(q, 1e-300), 0.0) / (1.0 + qn) ** 2
        h = B * B * c * c * phi
        dh_dc = 2 * B * B * c * phi + B * B * c * c * dphi * B * np.sign(c) / Bb
        dh_dB = 2 * B * c * c * phi + B * B * c * c * dphi * np.abs(c) / Bb
        return h, dh_dc, dh_dB

    def energy(self, g, d):
        """The bridges' energy ``W`` minus its mean over d [J] (``saturable_bridge``)."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        B = shape(g).B
        w = 0.0
        for s in range(self.N_SLOTS):
            w = w + self._h(np.sin(math.pi * (s * k.t1 - d + self.p["x0"]) / k.tau), B)[0]
        psi = (np.arange(self.N_MEAN) + 0.5) * _TWO_PI / self.N_MEAN
        mean = self.N_SLOTS * np.mean(self._h(np.sin(psi), np.asarray(B)[..., None])[0], axis=-1)
        return self.C * (w - mean)

    # backiron_knee
    def knee(self, g):
        """``(m(g), dm/dg)``: the share of the ripple the flux follows (``backiron_knee``)."""
        p = self.p
        B, dB = field_slope(g)
        b0 = float(shape(G_STOP_LO).B)
        u = 1.0 - B / (b0 * p["b_s"])
        mu = u * u
        m = mu / (mu + p["r_i"])
        dmu = -2.0 * u * dB / (b0 * p["b_s"])
        return m, dmu * p["r_i"] / (mu + p["r_i"]) ** 2

    def amplitudes(self, g):
        """``[(k, a_k(g), da_k/dg, phi_k)]`` (``backiron_knee``)."""
        p = self.p
        g = np.asarray(g, dtype=float)
        m, dm = self.knee(g)
        m_ref = float(self.knee(k.g_cog_ref)[0])
        out = []
        for kk, c, ph in ((1, 1.0 - abs(p["c2"]), 0.0), (2, p["c2"], p["phi2"])):
            rate = -_TWO_PI * kk / k.t1
            e = p["xi0"] * c * np.exp(rate * (g - k.g_cog_ref)) / m_ref
            out.append((kk, e * m, e * (rate * m + dm), ph))
        return out

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        if self.family == "backiron_knee":
            fg = fd = 0.0
            for kk, a, da, ph in self.amplitudes(g):
                th = _TWO_PI * kk * (d - self.p["x0"]) / k.t1 + ph
                fd = fd + a * np.sin(th)
                fg = fg - k.t1 / (_TWO_PI * kk) * da * np.cos(th)
            return fg + 0.0 * d, fd + 0.0 * g
        B, dB = field_slope(g)
        fd = fg = 0.0
        for s in range(self.N_SLOTS):
            psi = math.pi * (s * k.t1 - d + self.p["x0"]) / k.tau
            _, hc, hb = self._h(np.sin(psi), B)
            fd = fd + hc * (math.pi / k.tau) * np.cos(psi)  # -dW/dd, dc/dd = -(pi/tau) cos psi
            fg = fg - hb * dB
        psi = (np.arange(self.N_MEAN) + 0.5) * _TWO_PI / self.N_MEAN
        fg = fg + self.N_SLOTS * np.mean(self._h(np.sin(psi), np.asarray(B)[..., None])[2], axis=-1) * dB
        return self.C * fg + 0.0 * d, self.C * fd + 0.0 * g


# ---------------------------------------------------------------------------- friction
class FrictionV10(_V10, Friction):
    """Friction of a spring-loaded guide roller whose load follows the gap, or of guides whose oil warms up.

    * ``spring_guide`` -- a guide roller on a preloading spring, mounted on the frame, bears on the mover: as the
      mover rises (the gap closes) the spring is compressed more, its load ``N = N_ref (1 + kappa (G_REF - g))`` (a
      linear spring, the roller's own contact much stiffer; spring-preloaded guides: Slocum, "Precision Machine
      Design", Prentice Hall 1992, ch. 8), and the roller's friction with it (rolling friction proportional to the
      load: Johnson, "Contact Mechanics", Cambridge Univ. Press 1985, ch. 8): ``F = -(Fc L(g) tanh(v / v_reg) + b
      v)`` per axis, ``L = max(0, 1 + kappa (G_REF - g))``, ``Fc`` the level at 15 mm.
    * ``warmup_viscous`` -- the guides' oil film warms with the motor over the dataset's time (runs recorded one after
      the other) and its viscosity falls exponentially with the temperature (Reynolds' viscosity law; Harnoy,
      "Bearing Design in Machinery: Engineering Tribology and Lubrication", Marcel Dekker 2002, ch. 2; a machine's
      warm-up as a first-order response: Bryan, "International status of thermal error research", CIRP Annals 39(2),
      1990): ``F = -(Fc tanh(v / v_reg) + b(t) v)``, ``b(t) = b_cold exp(-s (1 - exp(-t / tau_th)))``, ``s = beta
      dT`` the viscosity's log-drop when warm. The dataset time of each run's period is held over the period (hook
      ``advance``); the peak force is recorded while simulated.
    """

    families = ("spring_guide", "warmup_viscous")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "spring_guide": {"Fc_g": 0.2, "Fc_d": 0.2, "kappa": 60.0, "b_g": 0.5, "b_d": 0.5, "v_reg": 1e-3},
        "warmup_viscous": {
            "Fc_g": 0.1,
            "Fc_d": 0.1,
            "b_g": 3.0,
            "b_d": 3.0,
            "s": 0.8,
            "tau_th": 30.0,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False
        self.has_advance = self.family == "warmup_viscous"
        self.t = np.zeros(0)
        self.reset_peaks(0)
        if self.has_advance:
            self.recorded = self.peaks  # a time the recorded trajectory does not hold: the law's own record

    def reset(self, n_runs: int) -> None:
        """Cold (dataset time 0), no peak."""
        self.t = np.zeros(n_runs)
        self.reset_peaks(n_runs)

    reset_peaks = _Peaks.reset_peaks
    record = _Peaks.record
    peaks = _Peaks.peaks

    def advance(self, i, t, Ts: float) -> None:
        """Hold the dataset time of the period (``warmup_viscous``)."""
        self.t = np.array(t, dtype=float, copy=True).reshape(-1)

    def load(self, g):
        """``L(g)``: the roller's load over its value at 15 mm (``spring_guide``)."""
        return np.maximum(0.0, 1.0 + self.p["kappa"] * (G_REF - np.asarray(g, dtype=float)))

    def thinning(self, t):
        """``b(t) / b_cold`` (``warmup_viscous``)."""
        p = self.p
        return np.exp(-p["s"] * -np.expm1(-np.asarray(t, dtype=float) / p["tau_th"]))

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "spring_guide":
            lv = self.load(g)
            fg = -(p["Fc_g"] * lv * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
            fd = -(p["Fc_d"] * lv * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
            return fg + 0.0 * dd, fd + 0.0 * gd
        run = gd.ndim == 1 and gd.shape[0] == self.t.shape[0] == self.n_runs
        th = self.thinning(self.t) if run else 1.0
        fg = -(p["Fc_g"] * np.tanh(gd / p["v_reg"]) + p["b_g"] * th * gd)
        fd = -(p["Fc_d"] * np.tanh(dd / p["v_reg"]) + p["b_d"] * th * dd)
        if run:
            self.record(fg, fd)
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
class EndEffectV10(_V10, EndEffect):
    """End effects: solid end plates whose flux lags the overlap, or slotless end teeth past the winding.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``: at ``x_p = L/2 + e_p`` and ``-x_n``; the
    array over ``[d - L/2, d + L/2]``, its overhang beyond the stator ``O(d)``.

    * ``plate_lag`` -- the last ``l_p`` of each stator end is a solid (unlaminated) steel clamping plate: the flux the
      array drives into it builds up and decays through the plate's eddy currents, a first-order lag ``tau_e`` (the
      flux diffusion in solid iron: Stoll, "The Analysis of Eddy Currents", Clarendon Press 1974; one time
      constant: Feeley, "A simple dynamic model for eddy currents in a magnetic actuator", IEEE Trans. Magn. 32(2),
      1996; stator end plates: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC Press 2011). The
      covered plate length the field sees, ``z``, follows the covered length ``T_p(d)``: ``tau_e z' = T_p - z``
      (exact per control period, the position of the period's last stage; hook ``advance``); every magnetic term
      scales with ``rho = 1 - (O + T_p - z) / L`` (hook ``factors_i``): at rest the plain overhang loss, moving onto
      a plate a loss that trails it, moving off it a pull that lingers. Size recorded while simulated.
    * ``wide_end_teeth`` -- the last ``l_t = f_t e`` of each stator end is a wide end tooth without slots (a usual
      end of a PM linear motor's stator: Inoue & Sato, "An approach to a suitable stator length for minimizing the
      detent force of permanent magnet linear synchronous motors", IEEE Trans. Magn. 36(4), 2000; Gieras, Piech &
      Tomczuk 2011): over it the slots' permeance dip is absent, the magnets' pull there larger by ``1 / lam(g)``
      (MODEL.md's slot permeance factor; Carter, "Note on air-gap and interpolar induction", J. IEE 29, 1900): pull
      ``km^2 = 1 + (1/lam(g) - 1) T(d)/L - O(d)/L`` (``T`` the array's overlap with the end teeth), the currents'
      coupling ``km kc = 1 - O(d)/L`` (hook ``factors``): a pull that first grows, by a share that grows as the gap
      closes, as the array reaches the end teeth, then is lost beyond them.
    """

    families = ("plate_lag", "wide_end_teeth")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "plate_lag": {"e_p": 0.02, "e_n": 0.03, "l_p": 0.015, "tau_e": 0.03},
        "wide_end_teeth": {"e_p": 0.02, "e_n": 0.03, "f_t": 0.8},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_factors = self.family == "wide_end_teeth"
        self.has_factors_i = self.has_advance = self.family == "plate_lag"
        self.reset(0)
        if self.has_advance:
            self.recorded = self.peaks

    reset_peaks = _Peaks.reset_peaks
    record = _Peaks.record
    peaks = _Peaks.peaks

    def reset(self, n_runs: int) -> None:
        """No lag state yet (set at the first stage), no peak."""
        self.z: np.ndarray | None = None
        self.d_last: np.ndarray | None = None
        self.reset_peaks(n_runs)

    def ends(self) -> tuple[float, float]:
        """``(x_p, x_n)`` [m]."""
        return 0.5 * L_ARRAY + self.p["e_p"], 0.5 * L_ARRAY + self.p["e_n"]

    def overhang(self, d):
        """``O(d)``: the array's length beyond the stator's ends [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = self.ends()
        return np.maximum(0.0, d + 0.5 * L_ARRAY - xp) + np.maximum(0.0, -xn - d + 0.5 * L_ARRAY)

    def covered(self, d, lp: float, ln: float):
        """The array's overlap with the last ``lp`` (positive end) and ``ln`` (negative end) of the stator [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = self.ends()
        a0, a1 = d - 0.5 * L_ARRAY, d + 0.5 * L_ARRAY
        return _overlap(a0, a1, xp - lp, xp) + _overlap(a0, a1, -xn, -xn + ln)

    def plate(self, d):
        """``T_p(d)``: the covered plate length (``plate_lag``)."""
        return self.covered(d, self.p["l_p"], self.p["l_p"])

    def rho(self, d, z=None):  # type: ignore[override]
        """``plate_lag``'s factor at ``d`` with the lagged plate length ``z`` (default: settled, ``z = T_p``)."""
        tp = self.plate(d)
        return 1.0 - (self.overhang(d) + tp - (tp if z is None else z)) / L_ARRAY

    def tooth_factors(self, g, d):
        """``(km, kc)`` of ``wide_end_teeth``."""
        p = self.p
        t = self.covered(d, p["f_t"] * p["e_p"], p["f_t"] * p["e_n"])
        o = self.overhang(d)
        lam = shape(g).lam
        pull = 1.0 + (1.0 / lam - 1.0) * t / L_ARRAY - o / L_ARRAY
        km = np.sqrt(pull)
        return km, (1.0 - o / L_ARRAY) / km

    def factors(self, g, d, f: list) -> None:
        """``wide_end_teeth``: the magnets' field and the currents' coupling."""
        km, kc = self.tooth_factors(g, d)
        f[0] = f[0] * km
        f[1] = f[1] * kc

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """``plate_lag``: every term by ``rho`` with the lagged plate length; its force recorded while simulated."""
        d = np.asarray(d, dtype=float)
        run = d.ndim == 1 and d.shape[0] == self.n_runs
        if run and self.z is None:
            self.z = self.plate(d)
        r = self.rho(d, self.z if run else None)
        f[2] = f[2] * r
        if run:
            self.d_last = d.copy()
            sh, c = shape(g), NOMINAL
            up = c.C2 * sh.f2 - c.C3 * sh.f3 * i_d + c.C4 * sh.f4 * (i_q * i_q + i_d * i_d)
            self.record(k.Mv * (r - 1.0) * up, k.Mh * (r - 1.0) * c.C1 * sh.f1 * i_q)

    def advance(self, i, t, Ts: float) -> None:
        """``plate_lag``: the lagged plate length over the last period, towards the plate length it ended at."""
        if self.z is not None and self.d_last is not None:
            tp = self.plate(self.d_last)
            self.z = tp + (self.z - tp) * math.exp(-Ts / self.p["tau_e"])


# --------------------------------------------------------------------------- saturation
class SaturationV10(_V10, _Peaks, Saturation):
    """Saturation with memory: iron whose saturation follows the flux through a play, or a solid yoke's lag.

    Both: the loss of the field ``l(x) = l_lo x^n`` at the flux ``x`` the iron holds, ``km = kc = 1 - l(x)`` (hook
    ``factors_i``), the flux ``b = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); ``x`` advanced once per
    control period from the gap of the period's last stage (hook ``advance``); the size recorded while simulated.

    * ``flux_play`` -- the iron's magnetization holds its level until the flux has moved by ``w`` either way (the
      rate-independent hysteresis of a play operator: Krasnosel'skii & Pokrovskii, "Systems with Hysteresis",
      Springer 1989; the iron's hysteresis: Bertotti, "Hysteresis in Magnetism", Academic Press 1998):
      ``x <- clip(x, b - w, b + w)``: closing the gap, the loss trails the flux by ``w``; opening it, the loss stays
      until the flux has fallen by ``2 w``.
    * ``yoke_lag`` -- the saturating part is a solid (unlaminated) yoke whose eddy currents delay its flux, ``tau_s
      x' = b - x`` (exact per period; magnetic diffusion in solid iron: Stoll, "The Analysis of Eddy Currents",
      Clarendon Press 1974; dynamic saturation: Zirka, Moroz, Marketos & Moses, "Dynamic hysteresis modelling",
      Physica B 343, 2004): a loss that lags the gap's motion.
    """

    families = ("flux_play", "yoke_lag")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "flux_play": {"l_lo": 0.15, "n": 2.0, "w": 0.05, "target": "both"},
        "yoke_lag": {"l_lo": 0.15, "n": 2.0, "tau_s": 0.03, "target": "both"},
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
        """No flux state yet (set at the first stage), no peak."""
        self.x: np.ndarray | None = None
        self.g_last: np.ndarray | None = None
        self.reset_peaks(n_runs)

    def loss(self, x):
        """Fraction of the magnets' pull lost at the held flux ``x``."""
        return 1.0 - (1.0 - self.p["l_lo"] * np.asarray(x, dtype=float) ** self.p["n"]) ** 2

    def step(self, x, b, Ts: float):
        """The held flux after one period at the flux ``b``."""
        if self.family == "flux_play":
            return np.clip(x, b - self.p["w"], b + self.p["w"])
        return b + (x - b) * math.exp(-Ts / self.p["tau_s"])

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """The magnets' and the currents' field at the held flux (the settled flux ``b`` outside a simulation)."""
        g = np.asarray(g, dtype=float)
        run = g.ndim == 1 and g.shape[0] == self.n_runs
        if run and self.x is None:
            self.x = flux(g)
        x = self.x if run else flux(g)
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
        """The held flux over the last period, from the gap it ended at."""
        if self.x is not None and self.g_last is not None:
            self.x = self.step(self.x, flux(self.g_last), Ts)

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


# ------------------------------------------------------------------- amplifier and delay
def papoulis_poles(n: int = 3) -> np.ndarray:
    """Poles of the normalized third-order optimum-L (Papoulis) low-pass, ``|H|^2 = 1 / (1 + L3(w^2))``, ``L3(x) =
    3x^3 - 3x^2 + x``: the left-half-plane roots of ``1 + L3(-s^2) = 0``."""
    if n != 3:
        raise ValueError("only the third order is tabulated")
    r = np.roots([3.0, 0.0, 3.0, 0.0, 1.0, 0.0, -1.0])
    return r[r.real < 0]


class AmplifierV10(_V10, AmplifierV3):
    """An optimum-L (Papoulis) current response, or a Smith-predictor current loop with a mismatched delay model.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``papoulis3`` -- the current response tuned for the steepest roll-off with a monotonic pass band: Papoulis's
      optimum "L" filter of order 3, ``|H(j w)|^2 = 1 / (1 + L3((w / w_c)^2))``, ``L3(x) = 3x^3 - 3x^2 + x`` (Papoulis,
      "Optimum filters with monotonic response", Proc. IRE 46(3), 1958; Fukada, "Optimum filters of even orders with
      monotonic response", IRE Trans. Circuit Theory 6(3), 1959): -3 dB at ``f_c``, flat to ``x = 1/3``, poles the
      left-half-plane roots of ``3 s^6 + 3 s^4 + s^2 - 1``.
    * ``smith_mismatch`` -- a digital current loop (``wc / s`` after pole-zero cancellation) whose computation and PWM
      delay ``T`` is compensated by a Smith predictor with a delay model ``T_m = T (1 + m)`` (Smith, "Closer control
      of loops with dead time", Chem. Eng. Prog. 53(5), 1957; delay compensation in current loops: Buso &
      Mattavelli, "Digital Control in Power Electronics", Morgan & Claypool 2006, ch. 4): ``i/u = wc P / (s + wc +
      wc (P - P_m))``, each delay as its first-order Pade form ``P = (1 - sT/2) / (1 + sT/2)``: with a true model the
      response is ``wc/(s + wc)`` delayed by ``T``; a mismatch leaves a resonance.
    """

    families = ("papoulis3", "smith_mismatch")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "papoulis3": {"f_c": 500.0, "delay_samples": 0.0},
        "smith_mismatch": {"bandwidth_hz": 500.0, "T": 1.5e-4, "m": 0.5, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "papoulis3":
            den = np.real(np.poly(papoulis_poles(3)))
            return np.array([den[-1]]), den, _TWO_PI * p["f_c"]
        wc = _TWO_PI * p["bandwidth_hz"]
        h, hm = 0.5 * p["T"] * wc, 0.5 * p["T"] * (1.0 + p["m"]) * wc
        n1, d1, n2, d2 = [-h, 1.0], [h, 1.0], [-hm, 1.0], [hm, 1.0]
        num = np.polymul(n1, d2)
        den = np.polyadd(np.polymul([1.0, 1.0], np.polymul(d1, d2)), np.polysub(num, np.polymul(n2, d1)))
        return num / den[0], den / den[0], wc

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` (inputs ``[u, v]``, the second unused): the companion form in ``s / w0``."""
        num, den, w0 = self.polynomials()
        A, B, C = companion(num, den)
        return A * w0, B * w0, C

    def dc_gain(self) -> float:
        """Static gain of the command-to-current response."""
        num, den, _ = self.polynomials()
        return float(num[-1] / den[-1])

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s], transport delay included: ``den'(0)/den(0) - num'(0)/num(0)``."""
        num, den, w0 = self.polynomials()
        lag = den[-2] / den[-1] - (num[-2] / num[-1] if num.size > 1 else 0.0)
        return self.p["delay_samples"] * Ts + float(lag) / w0


# ------------------------------------------------------------------------- commutation
def array_bz(u, y, strength=(1.0, 1.0, 1.0, 1.0)):
    """``Bz`` [units ``Br / pi``] of the four alternating magnets at ``u`` from the array's centre and a height ``y``
    above their faces, magnet ``j`` (centre ``(j - 1.5) tau``, sign ``(-1)^j``) scaled by ``strength[j]``: each
    magnet's faces uniformly charged strips (Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press
    2001, ch. 4)."""
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    tot = 0.0
    w = 0.5 * k.taup
    for j in range(k.pm):
        x = u - (j - 1.5) * k.tau
        for yy, sg in ((y, 1.0), (y + k.hm, -1.0)):
            tot = tot + strength[j] * (-1.0) ** j * sg * (np.arctan((x + w) / yy) - np.arctan((x - w) / yy))
    return tot


class CommutationV10(_V10, _Peaks, CommutationOffset):
    """Commutation angle errors of Hall sensors on the power stage's ground, or reading an array with a weak magnet.

    Both from sin/cos Hall signals through ``atan2``, the rotation's force recorded while simulated (the rotated
    against the delivered currents through seed eq. (2) with nominal constants; hook ``rotate_at``).

    * ``ground_bounce`` -- the Hall sensors' ground shares a conductor with the phase currents' return (common
      impedance coupling: Ott, "Electromagnetic Compatibility Engineering", Wiley 2009, ch. 3; Hall sensor signals:
      Ramsden, "Hall-Effect Sensors: Theory and Application", 2nd ed., Elsevier 2006, ch. 4): the sin and cos
      channels pick up ``r_s i_a`` and ``r_c i_b`` (relative to the signals' amplitude; the phase currents from the
      delivered dq currents at the true angle ``th = pi d / tau + theta0``): ``delta = delta0 + atan2(sin th + r_s
      i_a, cos th + r_c i_b) - th``: an error that grows with the currents and ripples along d with the phases.
    * ``weak_magnet`` -- a Hall board at ``x_h`` on the stator, its two sensors ``tau / 2`` apart, ``c_s`` behind the
      stator's surface, reads the exact field of the four magnets, magnet ``j_w`` weaker by ``eps`` (irreversible
      loss of a magnet: Campbell, "Permanent Magnet Materials and their Application", Cambridge Univ. Press 1994; the
      array's field: Furlani 2001, ch. 4): the angle ``atan2(-Bz_A, Bz_B) - pi/4``, linearized by a table
      over d and g recorded at commissioning with every magnet sound (it takes out the array's harmonics and ends),
      plus ``delta0``: an error local to where the weak magnet passes the board, that grows as the gap opens (the
      sensors then see more of the neighbouring magnets' field).
    """

    families = ("ground_bounce", "weak_magnet")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "ground_bounce": {"delta0": 0.0, "r_s": 0.01, "r_c": -0.01, "theta0": 0.0},
        "weak_magnet": {"delta0": 0.0, "j_w": 1.0, "eps": 0.1, "x_h": 0.0, "c_s": 4e-3},
    }
    has_rotate = False
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset_peaks(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.reset_peaks(n_runs)

    def _sensed(self, g, d, weak: bool = True):
        """The Hall board's angle error against the array's place (``weak_magnet``; ``weak=False``: all sound)."""
        p = self.p
        st = [1.0 - p["eps"] if weak and j == round(p["j_w"]) else 1.0 for j in range(k.pm)]
        y = np.asarray(g, dtype=float) + p["c_s"]
        d = np.asarray(d, dtype=float)
        ba = array_bz(p["x_h"] - 0.25 * k.tau - d, y, st)
        bb = array_bz(p["x_h"] + 0.25 * k.tau - d, y, st)
        e = np.arctan2(-ba, bb) - 0.25 * math.pi - K_POLE * (d - p["x_h"])
        return np.mod(e + math.pi, _TWO_PI) - math.pi

    def angle_at(self, g, d, i_q=0.0, i_d=0.0):
        """Electrical angle error [rad] at gap ``g``, position ``d`` and delivered currents ``(i_q, i_d)``."""
        p = self.p
        if self.family == "weak_magnet":  # against the table recorded with every magnet sound
            e = self._sensed(g, d) - self._sensed(g, d, weak=False)
            return p["delta0"] + np.mod(e + math.pi, _TWO_PI) - math.pi
        th = K_POLE * np.asarray(d, dtype=float) + p["theta0"]
        ia, ib, _ = dq_to_abc(np.asarray(i_q, dtype=float), np.asarray(i_d, dtype=float), th)
        e = np.arctan2(np.sin(th) + p["r_s"] * ia, np.cos(th) + p["r_c"] * ib) - th
        return p["delta0"] + np.mod(e + math.pi, _TWO_PI) - math.pi

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X``."""
        X = np.asarray(X, dtype=float)
        a = self.angle_at(X[..., 0], X[..., 2], i_q, i_d)
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


# --------------------------------------------------------------------------- eddy drag
class EddyDragV10(_V10, _Peaks, EddyDrag):
    """Drag of the third-harmonic current circulating in a delta winding, or of a copper cladding warmed by the coils.

    * ``delta_circulating`` -- the winding is connected in delta: the third harmonics of the three phases' back-EMFs
      are in phase, add up around the delta and drive a circulating current the line currents do not see (Hanselman,
      "Brushless Permanent Magnet Motor Design", 2nd ed., Magna Physics 2006 (winding connections); Miller,
      "Brushless Permanent-Magnet and Reluctance Motor Drives", Clarendon Press 1989). With the phases' summed
      third-harmonic linkage ``Lambda(g, d) = h3(g) sin(3 pi (d - x0) / tau)``, ``h3 ~ 1 / sinh(3 pi (hm + g) /
      tau)`` (MODEL.md's field's third harmonic), the loop's EMF is ``-dLambda/dt`` and, resistive at the rig's
      electrical frequencies, its current ``-dLambda/dt / R``: ``F = -kappa (grad Lambda . v) grad Lambda`` (a
      rank-one damping tensor over (g, d)), ``kappa`` such that the mean ``C_dd`` over d at 15 mm is ``c0``. It
      ripples as ``cos^2`` with period ``tau / 3`` along d and falls with the gap three times as fast as the
      fundamental's field.
    * ``heated_cladding`` -- a copper cladding on the stator's face under the array drags the magnets, viscous at the
      rig's speeds (far below the sheet's critical speed), ``F_d = -c0 (B(g) / B(15 mm))^2 / (1 + alpha dT) d_dot``
      (Reitz, "Forces on moving magnets due to eddy currents", J. Appl. Phys. 41(5), 1970; the low-speed limit),
      its conductivity falling as the coils' copper loss ``1.5 R_c (i_q^2 + i_d^2)`` warms it through a first-order
      thermal path (``dT_w`` kelvin per watt, ``tau_th``; copper's ``alpha = 0.0039 /K``; heat from the winding:
      Mayr et al., "Thermal issues in machine tools", CIRP Annals 61(2), 2012): each run starts warmed as if the
      dataset's earlier runs had drawn its first period's loss (runs recorded one after the other), then follows its
      own currents (hook ``advance``). Size recorded while simulated.
    """

    families = ("delta_circulating", "heated_cladding")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "delta_circulating": {"c0": 1.0, "x0": 0.0},
        "heated_cladding": {"c0": 5.0, "R_c": 3.0, "dT_w": 2.0, "tau_th": 40.0, "alpha": 0.0039},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_advance = self.family == "heated_cladding"
        self.reset(0)
        if self.has_advance:
            self.recorded = self.peaks

    def reset(self, n_runs: int) -> None:
        """Cold, no peak."""
        self.dT: np.ndarray | None = None
        self.reset_peaks(n_runs)

    @staticmethod
    def h3(g):
        """``(h3(g) / h3(G_REF), d/dg)``: the third harmonic's field at the gap over its value at 15 mm."""
        g = np.asarray(g, dtype=float)
        a3 = 3 * math.pi / k.tau
        h = math.sinh(a3 * (k.hm + G_REF)) / np.sinh(a3 * (k.hm + g))
        return h, -a3 * h * np.cosh(a3 * (k.hm + g)) / np.sinh(a3 * (k.hm + g))

    def linkage_gradient(self, g, d):
        """``(dLambda/dg, dLambda/dd)`` of the normalized third-harmonic linkage (``delta_circulating``)."""
        h, dh = self.h3(g)
        ps = 3 * math.pi * (np.asarray(d, dtype=float) - self.p["x0"]) / k.tau
        return dh * np.sin(ps), h * (3 * math.pi / k.tau) * np.cos(ps)

    def conductance(self):
        """``1 / (1 + alpha dT)`` per run (``heated_cladding``; 1 before the first period)."""
        return 1.0 if self.dT is None else 1.0 / (1.0 + self.p["alpha"] * self.dT)

    def advance(self, i, t, Ts: float) -> None:
        """``heated_cladding``: the cladding's temperature rise over the period from the delivered currents."""
        p = self.p
        i = np.asarray(i, dtype=float).reshape(-1, 2)
        target = p["dT_w"] * 1.5 * p["R_c"] * np.sum(i * i, axis=1)
        if self.dT is None or self.dT.shape != target.shape:
            self.dT = target * -np.expm1(-np.asarray(t, dtype=float).reshape(-1) / p["tau_th"])
        else:
            self.dT = target + (self.dT - target) * math.exp(-Ts / p["tau_th"])

    def force(self, g, gd, d, dd):
        """Drag ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "delta_circulating":
            lg, ld = self.linkage_gradient(g, d)
            kappa = 2.0 * p["c0"] / (3 * math.pi / k.tau) ** 2
            rate = lg * gd + ld * dd
            return -kappa * rate * lg, -kappa * rate * ld
        b = shape(g).B / float(shape(G_REF).B)
        run = dd.ndim == 1 and self.dT is not None and dd.shape[0] == self.dT.shape[0] == self.n_runs
        fd = -p["c0"] * b * b * (self.conductance() if run else 1.0) * dd
        if run:
            self.record(0.0, fd)
        return 0.0 * fd, fd


#: The tenth set: one class per effect (library families and new effects), by effect name.
V10_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV10,
        FrictionV10,
        EndEffectV10,
        SaturationV10,
        AmplifierV10,
        CommutationV10,
        EddyDragV10,
        InverterDeadtime,
        MoverPitch,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V10: tuple[str, ...] = tuple(EFFECTS_V9) + tuple(n for n in V10_LAWS if n not in EFFECTS_V9)
V10_LIBRARY: tuple[str, ...] = tuple(n for n, c in V10_LAWS.items() if c.library)
V10_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V10_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS, V7_LAWS, V8_LAWS, V9_LAWS, V10_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v9, then v10)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V10)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V10)


__all__ = [
    "EFFECTS_V10",
    "G_REF",
    "V10_LAWS",
    "V10_LIBRARY",
    "V10_OUT_OF_LIBRARY",
    "AmplifierV10",
    "CoggingV10",
    "CommutationV10",
    "EddyDragV10",
    "EndEffectV10",
    "FrictionV10",
    "InverterDeadtime",
    "MoverPitch",
    "SaturationV10",
    "array_bz",
    "field_slope",
    "flux",
    "law_class",
    "make_law",
    "papoulis_poles",
]
