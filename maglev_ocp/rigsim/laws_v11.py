"""An eleventh set of law families of the rig's effects, written from the physics literature (issue 27,
``laws="v11"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v10`
has (the amplifier, commutation and eddy-drag families in :mod:`.laws_v11_drive`), and two effects outside the
library (in :mod:`.laws_v11_ool`), for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and ``law_set = "v11"`` in
its truth record. The source of each law (author, title, venue, year) is in its docstring and in
``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``factors_i``, ``force``, ``force_i``, ``held``,
``rotate_at``, ``advance``, the state-space amplifier); no hook was added. A law with a state the recorded
trajectory does not hold (a temperature, a relaxing flux) records its peak force while simulated (``recorded``), at
the integrator's stage states, with nominal constants.
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
from .laws_v10 import EFFECTS_V10, V10_LAWS
from .laws_v11_drive import AmplifierV11, CommutationV11, EddyDragV11
from .laws_v11_ool import _V11, G_REF, AirCushion, DcLinkRipple, _Peaks, _Warming
from .physics import NOMINAL, shape

_TWO_PI = 2.0 * math.pi
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


def flux(g):
    """``b = B(g) / B(g_lo)``: MODEL.md's field over its value at the lower stop."""
    return shape(g).B / float(shape(G_STOP_LO).B)


def _overlap(a0, a1, b0, b1):
    """Length of the overlap of the intervals ``[a0, a1]`` and ``[b0, b1]`` (elementwise, >= 0)."""
    return np.maximum(0.0, np.minimum(a1, b1) - np.maximum(a0, b0))


# ----------------------------------------------------------------------------- cogging
class CoggingV11(_V11, Cogging):
    """Cogging of an array of segmented magnets, or of magnets that overhang the stack in depth.

    Both conservative, from an energy ``W = (t1 / 2 pi) sum_k (a_k(g) / k) cos theta_k`` of the slot-pitch harmonics
    (``F = -grad W``: ``F_d = sum_k a_k sin theta_k``, ``F_g = -(t1 / 2 pi k) a_k' cos theta_k``).

    * ``segmented_magnets`` -- each of the four magnets is cut along d into ``n_s`` segments with insulating gaps
      ``w_s`` (segmentation against the magnets' eddy loss: Atallah, Howe, Mellor & Stone, "Rotor loss in
      permanent-magnet brushless AC machines", IEEE Trans. Ind. Appl. 36(6), 2000; Ede, Atallah, Jewell, Wang & Howe,
      "Effect of axial segmentation of permanent magnets on rotor loss in modular permanent-magnet brushless
      machines", IEEE Trans. Ind. Appl. 43(5), 2007). The cogging energy is the overlap of the magnets' squared field
      with the slot permeance (Gieras, "Analytical approach to cogging torque calculation of PM brushless motors",
      IEEE Trans. Ind. Appl. 40(5), 2004; Zhu & Howe, "Analytical prediction of the cogging torque in radial-field
      permanent magnet brushless motors", IEEE Trans. Magn. 28(2), 1992): harmonic k (k = 1, 2, 3 of the slot pitch)
      carries the slot opening's ``sin(k pi b0 / t1) / k`` times the array's ``S_k = sum_segments int exp(-i 2 pi k x
      / t1) dx`` (the squared field as one over each segment), ``a_k = xi0 |c_k| exp(-2 pi k (g - g_ref) / t1)``,
      ``theta_k = 2 pi k (d - x0) / t1 - arg c_k``, ``c_k`` normalized to ``sum |c_k| = 1`` (``xi0``: the harmonics'
      sum at 10 mm). Whole magnets (``n_s = 1``, the magnet 1.5 slot pitches wide) have no second harmonic; the gaps
      bring it back.
    * ``axial_overhang`` -- the magnets are deeper than the stack (``LA`` against ``LA - 2 o_z``): the overhanging
      strips reach the teeth's side edges over ``r = sqrt(g^2 + y^2)`` (``y`` the distance past the stack's side
      face), each harmonic decaying as ``exp(-2 pi k r / t1)`` (Laplace's equation in a harmonic of the slot pitch;
      magnet overhang: Hanselman, "Brushless Permanent Magnet Motor Design", 2nd ed., Magna Physics 2006; the field of
      a magnet strip: Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press 2001, ch. 4): ``a_k =
      xi0 c_k exp(-2 pi k (g - g_ref) / t1) Q_k(g) / Q_k(g_ref)``, ``Q_k = 1 + (2 / LA) int_0^o_z exp(-2 pi k (r -
      g) / t1) dy`` (k = 1, 2, ``c_1 = 1 - |c2|``): the overhang's share grows as the gap opens, so the cogging falls
      more slowly than an open slot's exponential.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("segmented_magnets", "axial_overhang")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "segmented_magnets": {"xi0": 3.0, "n_s": 2.0, "w_s": 1e-3, "x0": 0.0, "replace": 0.0},
        "axial_overhang": {"xi0": 3.0, "c2": 0.2, "phi2": 0.0, "o_z": 5e-3, "x0": 0.0, "replace": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self._c = self.spectrum() if self.family == "segmented_magnets" else None
        if self.family == "axial_overhang":
            self._q_ref = [float(self.overhang_gain(k.g_cog_ref, kk)[0]) for kk in (1, 2)]

    def spectrum(self) -> np.ndarray:
        """``c_k`` (k = 1, 2, 3), normalized to ``sum |c_k| = 1`` (``segmented_magnets``)."""
        p = self.p
        n = round(p["n_s"])
        w = p["w_s"]
        sw = (k.taup - (n - 1) * w) / n
        out = []
        for kk in (1, 2, 3):
            kap = _TWO_PI * kk / k.t1
            tot = 0j
            for j in range(k.pm):
                a = (j - 1.5) * k.tau - 0.5 * k.taup
                for m in range(n):
                    xc = a + m * (sw + w) + 0.5 * sw
                    tot += np.exp(-1j * kap * xc) * sw * np.sinc(kap * sw / (2 * math.pi))
            out.append(math.sin(kk * math.pi * k.b0 / k.t1) / kk * tot)
        c = np.array(out)
        return c / np.sum(np.abs(c))

    def overhang_gain(self, g, kk: int):
        """``(Q_k(g), dQ_k/dg)`` (``axial_overhang``)."""
        g = np.asarray(g, dtype=float)[..., None]
        oz = self.p["o_z"]
        y = 0.5 * oz * (_GL_X + 1.0)
        r = np.sqrt(g * g + y * y)
        kap = _TWO_PI * kk / k.t1
        e = np.exp(-kap * (r - g))
        w = 0.5 * oz * _GL_W
        q = 1.0 + (2.0 / k.LA) * np.sum(w * e, axis=-1)
        dq = (2.0 / k.LA) * np.sum(w * e * -kap * (g / r - 1.0), axis=-1)
        return q, dq

    def amplitudes(self, g):
        """``[(k, a_k(g), da_k/dg, phase_k)]``."""
        p = self.p
        g = np.asarray(g, dtype=float)
        out = []
        if self.family == "segmented_magnets":
            for kk, c in zip((1, 2, 3), self._c, strict=True):
                rate = -_TWO_PI * kk / k.t1
                a = p["xi0"] * abs(c) * np.exp(rate * (g - k.g_cog_ref))
                out.append((kk, a, rate * a, -float(np.angle(c))))
            return out
        for kk, c, ph in ((1, 1.0 - abs(p["c2"]), 0.0), (2, p["c2"], p["phi2"])):
            rate = -_TWO_PI * kk / k.t1
            q, dq = self.overhang_gain(g, kk)
            e = p["xi0"] * c * np.exp(rate * (g - k.g_cog_ref)) / self._q_ref[kk - 1]
            out.append((kk, e * q, e * (rate * q + dq), ph))
        return out

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        fg = fd = 0.0
        for kk, a, da, ph in self.amplitudes(g):
            th = _TWO_PI * kk * (d - self.p["x0"]) / k.t1 + ph
            fd = fd + a * np.sin(th)
            fg = fg - k.t1 / (_TWO_PI * kk) * da * np.cos(th)
        return fg + 0.0 * d, fd + 0.0 * g


# ---------------------------------------------------------------------------- friction
class FrictionV11(_V11, _Peaks, _Warming, Friction):
    """Friction of a thixotropic grease, or of guides whose preload grows as the coils warm the rails.

    * ``thixotropic_grease`` -- the grease's structure ``lam`` (1 built, 0 broken down) breaks down with the shear
      and rebuilds at rest (Moore's kinetic model of thixotropy: Moore, "The rheology of ceramic slips and bodies",
      Trans. Brit. Ceram. Soc. 58, 1959; Mewis & Wagner, "Thixotropy", Adv. Colloid Interface Sci. 147-148, 2009):
      ``lam' = (1 - lam) / tau_r - lam |v| / s_b`` per axis (solved exactly per sub-step, hook ``held``), ``F = -(Fc
      (1 + a_s lam) tanh(v / v_reg) + b (1 + beta lam) v)``, ``lam`` the mean over the sub-step: a start-up
      friction after a rest that fades over ``s_b`` of travel and returns over ``tau_r`` of rest.
    * ``thermal_preload`` -- the guides' rails on the stator warm with the coils' copper loss (a first-order thermal
      path; heat from the winding: Mayr et al., "Thermal issues in machine tools", CIRP Annals 61(2), 2012) and
      their expansion grows the carriages' preload interference by ``kappa dT`` of itself; the Hertzian load grows
      as the interference to the 3/2 (Johnson, "Contact Mechanics", Cambridge Univ. Press 1985, ch. 4; preloaded
      guides: Slocum, "Precision Machine Design", Prentice Hall 1992, ch. 8) and the rolling friction with the load:
      ``F = -(Fc (1 + kappa dT)^1.5 tanh(v / v_reg) + b v)`` (hook ``advance``; size recorded while simulated).
    """

    families = ("thixotropic_grease", "thermal_preload")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "thixotropic_grease": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "a_s": 1.0,
            "b_g": 1.0,
            "b_d": 1.0,
            "beta": 2.0,
            "s_b": 0.01,
            "tau_r": 2.0,
            "v_reg": 1e-3,
        },
        "thermal_preload": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "b_g": 0.5,
            "b_d": 0.5,
            "kappa": 0.02,
            "R_c": 3.0,
            "dT_w": 0.4,
            "tau_th": 40.0,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "thermal_preload"
        self.has_held = self.family == "thixotropic_grease"
        self.has_advance = self.family == "thermal_preload"
        self.reset(0)
        if self.has_advance:
            self.recorded = self.peaks  # a temperature the recorded trajectory does not hold: the law's own record

    def reset(self, n_runs: int) -> None:
        """Structure built (at rest), cold, no peak."""
        self.lam = np.ones((n_runs, 2))
        self.warm_reset()
        self.reset_peaks(n_runs)

    def advance(self, i, t, Ts: float) -> None:
        """``thermal_preload``: the rails' temperature rise over the period."""
        self.warm_advance(i, t, Ts)

    def structure(self, lam, v, h: float):
        """``(lam(h), mean lam over h)`` from ``lam`` at the speed ``v`` held over ``h`` (``thixotropic_grease``)."""
        p = self.p
        r = 1.0 / p["tau_r"] + np.abs(v) / p["s_b"]
        lam_inf = (1.0 / p["tau_r"]) / r
        e = np.exp(-r * h)
        return lam_inf + (lam - lam_inf) * e, lam_inf + (lam - lam_inf) * -np.expm1(-r * h) / (r * h)

    def held(self, gd, dd, h: float):
        """``thixotropic_grease``: the force over a sub-step of length ``h`` (advances the structure)."""
        p = self.p
        v = np.stack([np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)], axis=-1)
        if self.lam.shape != v.shape:
            self.lam = np.ones_like(v)
        self.lam, lm = self.structure(self.lam, v, h)
        fc = np.array([p["Fc_g"], p["Fc_d"]]) * (1.0 + p["a_s"] * lm)
        b = np.array([p["b_g"], p["b_d"]]) * (1.0 + p["beta"] * lm)
        f = -(fc * np.tanh(v / p["v_reg"]) + b * v)
        return f[..., 0], f[..., 1]

    def level(self):
        """``(1 + kappa dT)^1.5`` per run (``thermal_preload``; 1 before the first period)."""
        return 1.0 if self.dT is None else (1.0 + self.p["kappa"] * self.dT) ** 1.5

    def force(self, g, gd, d, dd):
        """``thermal_preload``'s friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        run = gd.ndim == 1 and self.dT is not None and gd.shape[0] == self.dT.shape[0] == self.n_runs
        lv = self.level() if run else 1.0
        fg = -(p["Fc_g"] * lv * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        fd = -(p["Fc_d"] * lv * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        if run:
            self.record(fg, fd)
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
class EndEffectV11(_V11, EndEffect):
    """End effects: a stator end that sags under the magnets' pull, or end teeth that saturate with the overhang's flux.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``: at ``x_p = L/2 + e_p`` and ``-x_n``; the
    array over ``[d - L/2, d + L/2]``, its overhang beyond the stator ``O(d)`` (lost: ``1 - O/L`` as the earlier
    sets). Both through hook ``factors``: ``km^2`` scales the pull, ``km kc`` the currents' terms.

    * ``cantilever_end`` -- the last ``l_c`` of each stator end reaches past its last support (a cantilever): the pull
      on its covered part ``c_e(d)`` bends it away from the array (the deflection of a cantilever under a load near
      its tip grows with the load and the loaded length: Gere & Timoshenko, "Mechanics of Materials", 4th ed., PWS
      1997, ch. 9; stator mounting: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed., CRC 2011): its mean
      gap grows by ``delta_e = delta (f2(g) / f2(15 mm)) (c_e / l_c)^2`` (the pull ``~ C2 f2``, MODEL.md) and the
      field over it falls to ``r_e = B(g + delta_e) / B(g)``: ``km^2 = 1 - O/L - sum_e (c_e / L)(1 - r_e^2)``, ``km kc
      = 1 - O/L - sum_e (c_e / L)(1 - r_e)``.
    * ``end_tooth_saturation`` -- the last tooth of each end (width ``w_t``) carries its covered part's flux and the
      fringing flux of the overhang beyond it, ``f = r_f g (1 - exp(-O_e / (r_f g)))``: its flux density ``b_t = b
      (c_t + f) / w_t`` (``b = B(g) / B(g_lo)``) saturates it, Frohlich's ``m = 1 / (1 + b_t / b_s)`` (Ostovic,
      "Dynamics of Saturated Electric Machines", Springer 1989; Pyrhonen, Jokinen & Hrabovcova, "Design of Rotating
      Electrical Machines", 2nd ed., Wiley 2014, ch. 3; end teeth: Inoue & Sato, "An approach to a suitable stator
      length for minimizing the detent force of permanent magnet linear synchronous motors", IEEE Trans. Magn. 36(4),
      2000): ``km^2 = 1 - O/L - sum_e (c_t / L)(1 - m^2)``, ``km kc = 1 - O/L - sum_e (c_t / L)(1 - m)``: a loss at
      the ends that grows as the gap closes and as the array overhangs.
    """

    families = ("cantilever_end", "end_tooth_saturation")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cantilever_end": {"e_p": 0.02, "e_n": 0.03, "l_c": 0.03, "delta": 1e-3},
        "end_tooth_saturation": {"e_p": 0.02, "e_n": 0.03, "w_t": 0.01, "b_s": 4.0, "r_f": 2.0},
    }

    def ends(self) -> tuple[float, float]:
        """``(x_p, x_n)`` [m]."""
        return 0.5 * L_ARRAY + self.p["e_p"], 0.5 * L_ARRAY + self.p["e_n"]

    def overhangs(self, d):
        """``(O_p(d), O_n(d))``: the array's length beyond each stator end [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = self.ends()
        return np.maximum(0.0, d + 0.5 * L_ARRAY - xp), np.maximum(0.0, -xn - d + 0.5 * L_ARRAY)

    def covered(self, d, length: float):
        """``(c_p, c_n)``: the array's overlap with the last ``length`` of each stator end [m]."""
        d = np.asarray(d, dtype=float)
        xp, xn = self.ends()
        a0, a1 = d - 0.5 * L_ARRAY, d + 0.5 * L_ARRAY
        return _overlap(a0, a1, xp - length, xp), _overlap(a0, a1, -xn, -xn + length)

    def end_factors(self, g, d):
        """``(km^2, km kc)`` at gap ``g`` and position ``d``."""
        p = self.p
        g = np.asarray(g, dtype=float)
        o = sum(self.overhangs(d))
        pull, coup = 1.0 - o / L_ARRAY, 1.0 - o / L_ARRAY
        if self.family == "cantilever_end":
            load = shape(g).f2 / float(shape(G_REF).f2)
            for c in self.covered(d, p["l_c"]):
                r = shape(g + p["delta"] * load * (c / p["l_c"]) ** 2).B / shape(g).B
                pull = pull - (c / L_ARRAY) * (1.0 - r * r)
                coup = coup - (c / L_ARRAY) * (1.0 - r)
            return pull, coup
        b = flux(g)
        for c, oe in zip(self.covered(d, p["w_t"]), self.overhangs(d), strict=True):
            reach = p["r_f"] * g
            m = 1.0 / (1.0 + b * (c + reach * -np.expm1(-oe / reach)) / (p["w_t"] * p["b_s"]))
            pull = pull - (c / L_ARRAY) * (1.0 - m * m)
            coup = coup - (c / L_ARRAY) * (1.0 - m)
        return pull, coup

    def factors(self, g, d, f: list) -> None:
        """The magnets' field and the currents' coupling at the ends."""
        pull, coup = self.end_factors(g, d)
        km = np.sqrt(pull)
        f[0] = f[0] * km
        f[1] = f[1] * coup / km


# --------------------------------------------------------------------------- saturation
class SaturationV11(_V11, _Peaks, _Warming, Saturation):
    """Saturation whose flux relaxes by magnetic viscosity, or whose knee falls as the coils warm the iron.

    Both: the loss of the field at the flux ``x`` the iron holds, ``km = kc = 1 - l_lo x^n`` (hook ``factors_i``),
    ``b = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop); the state advanced once per control period
    (hook ``advance``) from the gap of the period's last stage or the delivered currents; the size recorded while
    simulated.

    * ``magnetic_viscosity`` -- the iron's magnetization follows a change of the field partly at once and partly by
      thermal activation over a wide spread of time constants, a log-time creep (Street & Woolley, "A study of
      magnetic viscosity", Proc. Phys. Soc. A 62, 1949; Bertotti, "Hysteresis in Magnetism", Academic Press 1998):
      ``x = (1 - m_v) b + m_v mean_j x_j``, ``tau_j x_j' = b - x_j``, five ``tau_j`` log-spaced over ``[tau_1,
      tau_2]`` (a log-uniform spread; exact per period).
    * ``warm_iron`` -- the iron's saturation flux falls as it warms (Bloch's ``T^(3/2)`` law: Bloch, "Zur Theorie des
      Ferromagnetismus", Z. Physik 61, 1930; Chikazumi, "Physics of Ferromagnetism", 2nd ed., Oxford 1997), by
      ``kappa_B`` per kelvin near room temperature; the stator's temperature a first-order response to the coils'
      copper loss (Mayr et al., CIRP Annals 61(2), 2012): ``x = b / (1 - kappa_B dT)``.
    """

    families = ("magnetic_viscosity", "warm_iron")
    N_TAU = 5
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "magnetic_viscosity": {"l_lo": 0.15, "n": 2.0, "m_v": 0.5, "tau_1": 0.02, "tau_2": 5.0, "target": "both"},
        "warm_iron": {
            "l_lo": 0.15,
            "n": 2.0,
            "kappa_B": 5e-4,
            "R_c": 3.0,
            "dT_w": 1.0,
            "tau_th": 40.0,
            "target": "both",
        },
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
        """No flux state yet (set at the first stage), cold, no peak."""
        self.xj: np.ndarray | None = None
        self.g_last: np.ndarray | None = None
        self.warm_reset()
        self.reset_peaks(n_runs)

    def taus(self) -> np.ndarray:
        """The viscosity's time constants [s] (``magnetic_viscosity``)."""
        return np.geomspace(self.p["tau_1"], self.p["tau_2"], self.N_TAU)

    def loss(self, x):
        """Fraction of the magnets' pull lost at the held flux ``x``."""
        return 1.0 - (1.0 - self.p["l_lo"] * np.asarray(x, dtype=float) ** self.p["n"]) ** 2

    def held_flux(self, g, run: bool):
        """The flux ``x`` the iron holds (the settled ``x`` outside a simulation)."""
        p = self.p
        b = flux(g)
        if self.family == "warm_iron":
            return b / (1.0 - p["kappa_B"] * self.dT) if run and self.dT is not None else b
        if not run:
            return b
        if self.xj is None:
            self.xj = np.repeat(np.asarray(b, dtype=float)[:, None], self.N_TAU, axis=1)
        return (1.0 - p["m_v"]) * b + p["m_v"] * np.mean(self.xj, axis=1)

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """The magnets' and the currents' field at the held flux; the force recorded while simulated."""
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
        """The held flux over the last period (viscosity), or the iron's temperature (warming)."""
        if self.family == "warm_iron":
            self.warm_advance(i, t, Ts)
        elif self.xj is not None and self.g_last is not None:
            b = np.asarray(flux(self.g_last))[:, None]
            self.xj = b + (self.xj - b) * np.exp(-Ts / self.taus())[None, :]

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return self.peaks()


#: The eleventh set: one class per effect (library families and new effects), by effect name.
V11_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV11,
        FrictionV11,
        EndEffectV11,
        SaturationV11,
        AmplifierV11,
        CommutationV11,
        EddyDragV11,
        DcLinkRipple,
        AirCushion,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V11: tuple[str, ...] = tuple(EFFECTS_V10) + tuple(n for n in V11_LAWS if n not in EFFECTS_V10)
V11_LIBRARY: tuple[str, ...] = tuple(n for n, c in V11_LAWS.items() if c.library)
V11_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V11_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS, V7_LAWS, V8_LAWS, V9_LAWS, V10_LAWS, V11_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v10, then v11)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V11)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V11)


__all__ = [
    "EFFECTS_V11",
    "G_REF",
    "V11_LAWS",
    "V11_LIBRARY",
    "V11_OUT_OF_LIBRARY",
    "AirCushion",
    "AmplifierV11",
    "CoggingV11",
    "CommutationV11",
    "DcLinkRipple",
    "EddyDragV11",
    "EndEffectV11",
    "FrictionV11",
    "SaturationV11",
    "flux",
    "law_class",
    "make_law",
]
