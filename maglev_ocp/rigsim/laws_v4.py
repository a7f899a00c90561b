"""A fourth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v4"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new` and :mod:`.laws_v3` has, and two
effects outside the library, for the next pre-registered blind check. They were written from their sources
only, without reading the diagnosis or how it fits; each class carries ``new_law = True`` and
``law_set = "v4"`` in its truth record. The source of each law (author, title, venue, year, equation where the
source numbers it) is in its docstring and in ``docs/validation/rigsim-laws.md``.

Besides the hooks of :mod:`.laws` and :mod:`.laws_v3`, two hooks are used by this set (the simulator calls them
for laws that set the flag; no earlier law does):

* ``factors_i(g, d, i_q, i_d, f)`` (``has_factors_i``): multiplies the field factors like ``factors`` but also
  sees the currents the motor carries (a saturation that depends on the net flux of magnets and currents);
* ``advance(i, t, Ts)`` (``has_advance``): advances a slow state of the law once per control period from the
  delivered currents ``i`` (n_runs, 2) at the dataset time ``t`` (a thermal state).

Laws with a state that the truth record cannot recompute from the recorded trajectory (the sensor-mount
resonance, the coil heating) record their own size while simulated (:meth:`recorded`).
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
from .laws_v3 import EFFECTS_V3, V3_LAWS, AmplifierV3, _rot
from .physics import NOMINAL, shape

G_STOP_HI = k.g_stop[1]
MU0 = 4e-7 * math.pi
LAMBDA = 2.0 * k.t1  # period of the rig's cogging (seed eq. (9): sin(pi d / t1))
K_POLE = math.pi / k.tau  # wavenumber of the magnet array's fundamental (period 2 tau)
L_ARRAY = k.pm * k.tau  # length of the magnet array [m]


def _a(g):
    """``pi (hm + g) / tau``: the argument of MODEL.md's field ``B(g) ~ 1 / sinh(pi (hm + g) / tau)``."""
    return K_POLE * (k.hm + np.asarray(g, dtype=float))


def field_ratio(g, g0: float):
    """``B(g) / B(g0)`` of the magnet array's fundamental at the stator surface (MODEL.md: ``1 / sinh(a)``)."""
    return math.sinh(float(_a(g0))) / np.sinh(_a(g))


class _V4:
    """Mixin: marks a law of the fourth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v4"``)."""
        return {**super().describe(), "law_set": "v4"}  # type: ignore[misc]


# ----------------------------------------------------------------------------- cogging
class CoggingV4(_V4, Cogging):
    """Cogging of the real magnet array: imperfect / shifted magnets, or the slot-permeance wave of the pull.

    Both are conservative, ``F = -grad W(g, d)`` (``F_g > 0`` opens the gap), with ``lambda = 2 t1`` (the period
    of seed eq. (9)):

    * ``magnet_shift`` -- each of the ``pm`` magnets (at ``j tau``) cogs with the same one-magnet profile
      ``sum_k c_k sin(2 pi k x / lambda + phi_k)``; magnet ``j`` is shifted by design by ``s_j = j sigma lambda /
      pm`` (pole shifting: Bianchi, Bolognani & Cappello, "Reduction of cogging force in PM linear motors by
      pole-shifting", IEE Proc. Electr. Power Appl. 152(3), 2005), misplaced by ``e_j`` and stronger by
      ``1 + beta_j`` (manufacturing tolerances: Gasparin, Cernigoj, Markic & Fiser, "Additional cogging torque
      components in permanent-magnet motors due to manufacturing imperfections", IEEE Trans. Magn. 45(3),
      2009). Each harmonic carries the array factor ``M_k = (1/pm) sum_j (1 + beta_j)^2 exp(i 2 pi k (j tau +
      s_j + e_j) / lambda)``: with ``tau = 1.5 lambda`` the odd harmonics of a perfect array cancel and only
      the tolerances bring them back. The amplitude follows the array's field squared, ``xi(g) = xi0
      (B(g) / B(g_ref))^2`` (MODEL.md's ``B ~ 1/sinh(pi (hm + g) / tau)``). ``W = (lambda / 2 pi) xi(g) sum_k
      (c_k / k) Re(M_k e^{i theta_k})``.
    * ``permeance_wave`` -- the slotting modulates the gap permeance, ``Lambda(d) = Lambda0 (1 + sum_k eps_k
      cos(2 pi k (d - d0) / lambda + phi_k))`` (the permeance-wave method: Heller & Hamata, "Harmonic Field
      Effects in Induction Machines", Elsevier 1977), so the whole magnet attraction energy ripples:
      ``W = -W_pm(g) (1 + sum_k eps_k(g) cos(...))``, ``W_pm ~ coth(a) - 1`` the co-energy of MODEL.md's pull
      ``~ B^2`` integrated over the gap, each ``eps_k`` decaying across the gap as a Laplace harmonic,
      ``exp(-2 pi k (g - g_ref) / lambda)``. The normal ripple is of the order of the tangential one.
      ``xi0`` is the tangential peak of harmonic 1 at ``g_ref``, ``r2`` harmonic 2's relative to it.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("magnet_shift", "permeance_wave")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "magnet_shift": {
            "xi0": 3.0,
            "c1": 0.8,
            "c2": 1.0,
            "c3": 0.2,
            "phi2": 0.0,
            "phi3": 0.0,
            "sigma": 0.0,
            **{f"beta{j}": 0.0 for j in range(k.pm)},
            **{f"e{j}": 0.0 for j in range(k.pm)},
            "replace": 0.0,
        },
        "permeance_wave": {"xi0": 5.0, "r2": 0.3, "phi2": 0.0, "d0": 0.0, "replace": 0.0},
    }

    def array_factor(self) -> np.ndarray:
        """``M_k`` (k = 1..3) of the shifted, imperfect magnets (complex)."""
        p = self.p
        out = []
        for kk in (1, 2, 3):
            z = 0.0j
            for j in range(k.pm):
                x = j * k.tau + j * p["sigma"] * LAMBDA / k.pm + p[f"e{j}"]
                z += (1.0 + p[f"beta{j}"]) ** 2 * np.exp(2j * math.pi * kk * x / LAMBDA)
            out.append(z / k.pm)
        return np.array(out)

    @staticmethod
    def pull_energy(g):
        """Shape of the magnets' attraction co-energy ``coth(a) - 1`` and its derivative in g [1/m]."""
        a = _a(g)
        return 1.0 / np.tanh(a) - 1.0, -K_POLE / np.sinh(a) ** 2

    def force(self, g, gd, d, dd):
        """``(F_g, F_d) = -grad W`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        fg = 0.0 * g + 0.0 * d
        fd = 0.0 * fg
        if self.family == "magnet_shift":
            c = np.array([p["c1"], p["c2"], p["c3"]])
            c = c / max(float(np.sum(np.abs(c))), 1e-12)
            xi = p["xi0"] * field_ratio(g, k.g_cog_ref) ** 2
            wsum = 0.0 * fg
            for j, (ck, M) in enumerate(zip(c, self.array_factor(), strict=True), start=1):
                z = M * np.exp(1j * (2 * math.pi * j * d / LAMBDA + (p[f"phi{j}"] if j > 1 else 0.0)))
                fd = fd + xi * ck * z.imag
                wsum = wsum + ck / j * z.real
            # W = (lambda / 2 pi) xi(g) wsum, dxi/dg = -2 (pi / tau) coth(a) xi
            return LAMBDA / k.tau * xi / np.tanh(_a(g)) * wsum, fd
        w, dw = self.pull_energy(g)
        w_ref = float(self.pull_energy(k.g_cog_ref)[0])
        for j, amp in ((1, p["xi0"]), (2, p["xi0"] * p["r2"])):
            q = 2 * math.pi * j / LAMBDA
            e = np.exp(-q * (g - k.g_cog_ref))
            E, dE = w * e / w_ref, (dw - q * w) * e / w_ref
            th = q * (d - p["d0"]) + (p["phi2"] if j == 2 else 0.0)
            fd = fd + amp * E * np.sin(th)  # W_j = (amp / q) E cos(th): -dW/dd
            fg = fg - amp / q * dE * np.cos(th)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV4(_V4, Friction):
    """Friction with asymmetric hysteresis loops, or with frictional memory and a dwell-dependent static level.

    * ``bouc_wen`` -- Bouc-Wen hysteresis (Wen, "Method for random vibration of hysteretic systems", ASCE J.
      Eng. Mech. Div. 102(2), 1976, eq. (4) with n = 1): ``dz/dt = v - beta |v| z - gamma v |z|``, ``F = -(kappa z
      + b v)``. In the travelled path ``p``, with ``u = z sgn(v)``: ``du/dp = 1 - lambda_+ u`` while ``u >= 0``
      and ``1 - lambda_- u`` while ``u < 0`` (``lambda_+- = beta +- gamma``), solved exactly (rate independent).
      Parameters: sliding force ``Fc = kappa / lambda_+``, presliding length ``x_c = 1 / lambda_+`` and the
      ratio ``rho = lambda_- / lambda_+`` of the reversal to the loading rate (``rho = 1`` is Dahl's law).
    * ``seven_param`` -- the seven-parameter model of Armstrong-Helouvry, Dupont & Canudas de Wit, "A survey of
      models, analysis tools and compensation methods for the control of machines with friction",
      Automatica 30(7), 1994, sec. 2.4: ``F = -(Fc + Fv |v| + Fs(t_d) / (1 + (v_L / vs)^2)) sgn(v)``, the
      Stribeck part seen through frictional memory ``v_L`` (the velocity lagged by ``tau_L``; here a first-order
      lag) and the static level rising with the dwell time ``t_d`` of the last stick, ``Fs = Fs_a + (Fs_inf -
      Fs_a) t_d / (t_d + gam)``. ``sgn`` is ``tanh(v / v_reg)``; the guide sticks while ``|v| < v_reg``.
    """

    families = ("bouc_wen", "seven_param")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "bouc_wen": {"Fc_g": 0.2, "Fc_d": 0.2, "x_c": 2e-5, "rho": 0.5, "b_g": 0.5, "b_d": 0.5},
        "seven_param": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "Fv_g": 0.5,
            "Fv_d": 0.5,
            "Fs_g": 0.15,
            "Fs_d": 0.15,
            "a_ratio": 0.5,
            "gam": 0.2,
            "tau_L": 5e-3,
            "vs": 5e-3,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force, self.has_held = False, True
        self.state = np.zeros((0, 2, 3))

    def reset(self, n_runs: int) -> None:
        """Zero the states per run and axis (Bouc-Wen ``z``; or lagged velocity, dwell time, stuck flag)."""
        self.state = np.zeros((n_runs, 2, 3))
        if self.family == "seven_param":
            self.state[:, :, 2] = 1.0  # at rest when a run starts

    def bw_path(self, u0, path):
        """Bouc-Wen ``u`` after ``path`` of travel from ``u0`` (exact, both branches)."""
        p = self.p
        lp, lm = 1.0 / p["x_c"], p["rho"] / p["x_c"]
        u0, path = np.asarray(u0, dtype=float), np.asarray(path, dtype=float)
        # negative branch towards 1/lm until u = 0 (at path p0), then the positive branch from 0
        neg = u0 < 0
        p0 = np.where(neg, np.log1p(-lm * np.minimum(u0, 0.0)) / lm, 0.0)
        on_neg = neg & (path < p0)
        u_neg = 1.0 / lm + (u0 - 1.0 / lm) * np.exp(-lm * path)
        start = np.where(neg, 0.0, u0)
        rest = np.where(neg, path - p0, path)
        u_pos = 1.0 / lp + (start - 1.0 / lp) * np.exp(-lp * np.maximum(rest, 0.0))
        return np.where(on_neg, u_neg, u_pos)

    def held(self, gd, dd, h: float):
        """Advance the states over ``h`` at the current velocities; return the held force."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            if self.family == "bouc_wen":
                s = np.sign(v)
                u = self.bw_path(self.state[:, j, 0] * s, np.abs(v) * h)
                z = np.where(s != 0, u * s, self.state[:, j, 0])
                self.state[:, j, 0] = z
                out.append(-(p[f"Fc_{ax}"] / p["x_c"] * z + p[f"b_{ax}"] * v))
                continue
            st = self.state[:, j]
            stuck = np.abs(v) < p["v_reg"]
            st[:, 1] = np.where(stuck, np.where(st[:, 2] > 0, st[:, 1] + h, h), st[:, 1])  # dwell of this stick
            st[:, 2] = stuck
            st[:, 0] = v + (st[:, 0] - v) * math.exp(-h / p["tau_L"])  # frictional memory
            fs_inf = p[f"Fs_{ax}"]
            fs = fs_inf * (p["a_ratio"] + (1 - p["a_ratio"]) * st[:, 1] / (st[:, 1] + p["gam"]))
            level = p[f"Fc_{ax}"] + p[f"Fv_{ax}"] * np.abs(v) + fs / (1.0 + (st[:, 0] / p["vs"]) ** 2)
            out.append(-level * np.tanh(v / p["v_reg"]))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
def smooth_overhang(x, s):
    """``(x + sqrt(x^2 + s^2)) / 2``: the overhang ``max(0, x)`` smoothed over the fringing width ``s``."""
    return 0.5 * (x + np.sqrt(x * x + s * s))


class EndEffectV4(_V4, EndEffect):
    """End effects of a finite stator: the winding ends before the iron, or the overhang's longitudinal force.

    The overlap of the magnet array (length ``L = pm tau``) with a stator part ending ``e`` beyond the array's end
    at ``d = 0``: ``c(d, g) = 1 - (o(d - e_p) + o(-d - e_n)) / L``, the overhang ``o`` smoothed over the fringing
    width ``s = g`` (the field spreads over about one gap past an iron edge), normalized to 1 at ``d = 0``.

    * ``winding_iron`` -- the armature core reaches beyond its last coil (end slots half filled, end coils
      shorter: Gieras, Piech & Tomczuk, "Linear Synchronous Motors: Transportation and Automation Systems",
      2nd ed., CRC Press 2011, ch. on PM linear motors): the magnets' attraction to the iron (the ``C2`` term)
      scales with the iron overlap ``c_i`` (ends ``e_ip, e_in``), the force of the currents (``C1``, ``C3``) with the
      winding overlap ``c_w`` (ends ``e_ip - w_p``, ``e_in - w_n``); in the rig's factors ``rho = c_i``,
      ``kc = c_w / c_i`` (so the small ``C4`` term scales as ``c_w^2 / c_i``).
    * ``energy_overhang`` -- by virtual work the same co-energy that gives the pull gives a longitudinal force
      (Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press 2001, force from the energy):
      ``W = -W_pm(g) c(d, g)``, ``F_d = W_pm(g) dc/dd``, pulling the mover back over the stator, with
      ``W_pm(g) = Mv C2 lam(g) B0^2 (tau / pi) (coth a - 1)`` the pull of MODEL.md (nominal constants) integrated
      over the gap; the pull itself scales with ``c`` (``rho = c``; the small ``dc/dg`` term of ``F_g`` is left
      out).

    Both keep :class:`.laws.EndEffect`'s pole-pitch thrust ripple.
    """

    families = ("winding_iron", "energy_overhang")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "winding_iron": {**EndEffect._ripple, "e_ip": 0.03, "e_in": 0.035, "w_p": 0.01, "w_n": 0.015},
        "energy_overhang": {**EndEffect._ripple, "e_p": 0.025, "e_n": 0.03},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family == "energy_overhang"

    @staticmethod
    def overlap(d, g, e_p: float, e_n: float):
        """``(c, dc/dd)``: overlap fraction of the array with a stator part of ends ``e_p``, ``e_n``."""
        d, g = np.asarray(d, dtype=float), np.asarray(g, dtype=float)

        def raw(x):
            xp, xn = x - e_p, -x - e_n
            o = smooth_overhang(xp, g) + smooth_overhang(xn, g)
            do = 0.5 * (1 + xp / np.sqrt(xp * xp + g * g)) - 0.5 * (1 + xn / np.sqrt(xn * xn + g * g))
            return 1.0 - o / L_ARRAY, -do / L_ARRAY

        c0, _ = raw(0.0 * d)
        c, dc = raw(d)
        return c / c0, dc / c0

    def rho_g(self, d, g):
        """Fraction of the magnets' attraction left at ``(d, g)`` (the iron overlap)."""
        p = self.p
        if self.family == "winding_iron":
            return self.overlap(d, g, p["e_ip"], p["e_in"])[0]
        return self.overlap(d, g, p["e_p"], p["e_n"])[0]

    def rho(self, d):
        """Fraction left at ``d`` at the reference gap (for reports; the rig uses :meth:`rho_g`)."""
        return self.rho_g(d, k.g_cog_ref + 0.0 * np.asarray(d, dtype=float))

    def winding(self, d, g):
        """Overlap of the array with the winding (``winding_iron``)."""
        p = self.p
        return self.overlap(d, g, p["e_ip"] - p["w_p"], p["e_in"] - p["w_n"])[0]

    @staticmethod
    def pull_energy(g):
        """``W_pm(g)`` [J]: MODEL.md's magnet pull (nominal constants) integrated from ``g`` outwards."""
        g = np.asarray(g, dtype=float)
        sh = shape(g)
        a = _a(g)
        b0sq = (sh.B * np.sinh(a)) ** 2
        return NOMINAL.Mv * NOMINAL.C2 * sh.lam * b0sq / K_POLE * (1.0 / np.tanh(a) - 1.0)

    def factors(self, g, d, f: list) -> None:
        """Scale the terms by the overlaps and the thrust by the ripple."""
        ci = self.rho_g(d, g)
        f[2] = f[2] * ci
        if self.family == "winding_iron":
            f[1] = f[1] * self.winding(d, g) / ci
        f[3] = f[3] * self.ripple(d)

    def force(self, g, gd, d, dd):
        """Longitudinal end force ``(0, W_pm dc/dd)`` [N] (``energy_overhang``)."""
        p = self.p
        _, dc = self.overlap(d, g, p["e_p"], p["e_n"])
        return 0.0 * dc, self.pull_energy(g) * dc


# --------------------------------------------------------------------------- saturation
def _r1(y):
    """``(1 - exp(-y)) / y``, 1 at ``y = 0`` (the ratio of an exponential B-H law to its initial slope)."""
    y = np.asarray(y, dtype=float)
    small = np.abs(y) < 1e-6
    ys = np.where(small, 1.0, y)
    return np.where(small, 1.0 - 0.5 * y, -np.expm1(-ys) / ys)


class SaturationV4(_V4, Saturation):
    """Saturation by a sum of exponentials, or by the net flux of the magnets and the levitation current.

    The iron's flux density is taken proportional to MODEL.md's field of the array, ``x(g) = B(g) / B(g_lo)`` (1 at
    the lower stop); the factor is the ratio of the saturating to the linear B-H law, 1 at the upper stop.

    * ``exp_sum`` -- El-Sherbiny, "Representation of the magnetization characteristic by a sum of exponentials",
      IEEE Trans. Magn. 9(1), 1973: ``B = sum_i a_i (1 - exp(-b_i H))``; two terms, ratio to the initial slope
      ``r(x) = w1 r1(b1 x) + (1 - w1) r1(b2 x)``, ``r1(y) = (1 - e^-y) / y``; ``target`` as in
      :class:`.laws.Saturation`.
    * ``dq_flux`` -- the iron saturates with the net d-axis flux, magnets plus current (Morimoto, Sanada &
      Takeda, "Effects and compensation of magnetic saturation in flux-weakening controlled permanent magnet
      synchronous motor drives", IEEE Trans. Ind. Appl. 30(6), 1994): the levitation current ``i_d`` weakens the
      magnets' field (seed eq. (2): the pull falls with ``i_d``) by ``kappa(g) i_d``, ``kappa = C3 f3 / (2 C2 f2)``
      (the cross term of ``(B_pm - B_i)^2``, nominal constants), so ``u = x(g) |1 - kappa(g) i_d|`` and the factor
      is ``r1(a u) / r1(a x(g_hi))`` (one exponential), on the fields ``target`` names.
    """

    families = ("exp_sum", "dq_flux")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "exp_sum": {"b1": 0.4, "b2": 1.2, "w1": 0.5, "target": "magnet"},
        "dq_flux": {"a": 0.8, "target": "both"},
    }

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        self.has_factors = self.family == "exp_sum"
        self.has_factors_i = self.family == "dq_flux"

    @staticmethod
    def x(g):
        """``B(g) / B(g_lo)`` of the array's fundamental."""
        return field_ratio(g, G_STOP_LO)

    @staticmethod
    def kappa(g):
        """Field of one ampere of ``i_d`` relative to the magnets' (nominal constants, seed eq. (2)) [1/A]."""
        sh = shape(g)
        return NOMINAL.C3 * sh.f3 / (2.0 * NOMINAL.C2 * sh.f2)

    def ratio(self, u):
        """Ratio of the saturating B-H law to its initial slope at the normalized flux ``u``."""
        p = self.p
        if self.family == "exp_sum":
            return p["w1"] * _r1(p["b1"] * u) + (1 - p["w1"]) * _r1(p["b2"] * u)
        return _r1(p["a"] * u)

    def loss(self, g, i_d=0.0):
        """Fraction of the saturating field lost at gap ``g`` (and levitation current ``i_d`` for ``dq_flux``)."""
        g = np.asarray(g, dtype=float)
        u = self.x(g)
        if self.family == "dq_flux":
            u = u * np.abs(1.0 - self.kappa(g) * i_d)
        return 1.0 - self.ratio(u) / self.ratio(self.x(G_STOP_HI))

    def _apply(self, kk, f: list) -> None:
        if self.p["target"] in ("magnet", "both"):
            f[0] = f[0] * kk
        if self.p["target"] in ("current", "both"):
            f[1] = f[1] * kk

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and/or current field (``exp_sum``)."""
        self._apply(1.0 - self.loss(g), f)

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """Scale the fields by the net-flux saturation at the carried ``i_d`` (``dq_flux``)."""
        self._apply(1.0 - self.loss(g, i_d), f)


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV4(_V4, AmplifierV3):
    """Current responses with a zero, or with the diffusion lag of eddy currents in solid iron.

    * ``symmetric_optimum`` -- a PI current loop on a winding whose time constant ``L/R`` is long against the
      converter's small lag ``T`` (the plant ~ ``1 / (L s (1 + T s))``), tuned by Kessler's symmetric optimum
      (Kessler, "Das symmetrische Optimum", Regelungstechnik 6, 1958): open loop ``(1 + 4Ts) / (8 T^2 s^2 (1 +
      Ts))``, closed loop ``(1 + 4Ts) / (1 + 4Ts + 8T^2 s^2 + 8T^3 s^3)`` (about 43 % step overshoot, crossover
      ``1 / 2T``); plus a fractional transport delay. Its phase slope at zero frequency is zero (the zero
      cancels the lag to first order): its delay shows at the crossover.
    * ``eddy_diffusion`` -- eddy currents in a solid iron part of the magnetic path delay its flux by
      diffusion (Feeley, "A simple dynamic model for eddy currents in a magnetic actuator", IEEE Trans. Magn.
      32(2), 1996): a share ``m`` of the flux follows the current through a slab's response ``tanh(sqrt(s
      tau_e)) / sqrt(s tau_e)``, expanded exactly into first-order modes (Mittag-Leffler: weights
      ``8 / ((2n-1)^2 pi^2)``, time constants ``4 tau_e / ((2n-1)^2 pi^2)``; six kept, the faster ones' 1.5 % of
      weight taken as instantaneous), behind a
      current loop of bandwidth ``bandwidth_hz``; plus a transport delay. Half-order (``-45 deg``) phase above
      ``1 / tau_e``; group delay ``1/wc + m tau_e / 3`` at zero frequency.
    """

    families = ("symmetric_optimum", "eddy_diffusion")
    N_MODES = 6
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "symmetric_optimum": {"t_sigma": 3e-4, "delay_samples": 0.5},
        "eddy_diffusion": {"bandwidth_hz": 2000.0, "tau_e": 8e-3, "m": 0.3, "delay_samples": 0.0},
    }

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Weights (of the full series: they sum to a little under 1) and time constants [s] of the kept modes."""
        n = np.arange(1, self.N_MODES + 1)
        q = ((2 * n - 1) * math.pi) ** 2
        return 8.0 / q, 4.0 * self.p["tau_e"] / q

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` of axis ``axis`` (inputs ``[u, v]``; the velocity is not used)."""
        p = self.p
        if self.family == "symmetric_optimum":
            T = p["t_sigma"]
            den = 8 * T**3
            A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1 / den, -4 * T / den, -8 * T**2 / den]])
            B = np.array([[0.0, 0.0], [0.0, 0.0], [1 / den, 0.0]])
            return A, B, np.array([1.0, 4 * T, 0.0])
        wc = 2 * math.pi * p["bandwidth_hz"]
        w, taus = self.modes()
        n = 1 + self.N_MODES
        A = np.zeros((n, n))
        A[0, 0] = -wc
        A[1:, 0] = 1.0 / taus
        A[1:, 1:] = np.diag(-1.0 / taus)
        B = np.zeros((n, 2))
        B[0, 0] = wc
        return A, B, np.concatenate([[1.0 - p["m"] * float(np.sum(w))], p["m"] * w])

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        if self.family == "symmetric_optimum":
            return self.p["delay_samples"] * Ts  # a1 - b1 = 4T - 4T = 0
        w, taus = self.modes()
        lag = 1.0 / (2 * math.pi * self.p["bandwidth_hz"]) + self.p["m"] * float(np.sum(w * taus))
        return self.p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
class CommutationV4(_V4, CommutationOffset):
    """Commutation angle errors of a magnetic field-angle sensor, or of Hall switches with hysteresis.

    * ``field_angle`` -- the angle is the direction of the magnet array's field read by a 2-axis sensor across
      the gap, at distance ``y = g + c_s`` from the magnets. Above an alternating array (magnet width ``taup``,
      height ``hm``) harmonic ``n`` (odd) of the field turns with ``n theta`` and has the relative amplitude
      ``h_n = [sin(n pi taup / 2 tau) / (n sin(pi taup / 2 tau))] [(1 - e^{-n K hm}) / (1 - e^{-K hm})]
      e^{-(n - 1) K y}``, ``K = pi / tau`` (Furlani, "Permanent Magnet and Electromechanical Devices", Academic
      Press 2001, the 2-D field of a periodic magnet array); the field angle is ``theta + arg(1 + h3 e^{2 i
      theta} + h5 e^{4 i theta})``: an error of period ``tau`` (and ``tau/2``) that shrinks as the gap opens.
      ``delta = delta0 + arg(...)``, ``theta = pi (d - x0) / tau``.
    * ``hall_hysteresis`` -- Hall switches operate and release at different fields (Ramsden, "Hall-Effect
      Sensors: Theory and Application", 2nd ed., Elsevier 2006, operate/release points): each edge comes late
      by half the position hysteresis ``x_h`` in the direction of motion, so the commutation angle lags by
      ``(pi / tau) x_h / 2`` with the sign of the velocity, ``delta = delta0 + (pi x_h / 2 tau) tanh(v / v_r)``
      (the memory of the last direction smoothed over the speed ``v_r``).
    """

    families = ("field_angle", "hall_hysteresis")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "field_angle": {"delta0": 0.0, "c_s": 3e-3, "x0": 0.0},
        "hall_hysteresis": {"delta0": 0.0, "x_h": 1e-3, "v_r": 1e-3},
    }
    has_rotate = False
    has_rotate_at = True

    @staticmethod
    def harmonic(n: int, y):
        """Relative amplitude ``h_n`` of the array's field harmonic ``n`` at distance ``y`` [m] from the magnets."""
        a = math.pi * k.taup / (2 * k.tau)
        geo = math.sin(n * a) / (n * math.sin(a))
        thick = (1 - math.exp(-n * K_POLE * k.hm)) / (1 - math.exp(-K_POLE * k.hm))
        return geo * thick * np.exp(-(n - 1) * K_POLE * np.asarray(y, dtype=float))

    def angle(self, d, dd=0.0, g=k.g_cog_ref):
        """Electrical angle error at position ``d``, speed ``dd`` and gap ``g``."""
        p = self.p
        if self.family == "hall_hysteresis":
            return p["delta0"] + math.pi * p["x_h"] / (2 * k.tau) * np.tanh(np.asarray(dd) / p["v_r"])
        th = K_POLE * (np.asarray(d, dtype=float) - p["x0"])
        y = np.asarray(g, dtype=float) + p["c_s"]
        z = 1.0 + self.harmonic(3, y) * np.exp(2j * th) + self.harmonic(5, y) * np.exp(4j * th)
        return p["delta0"] + np.angle(z)

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by ``delta`` at the state ``X``."""
        return _rot(i_q, i_d, self.angle(X[..., 2], X[..., 3], X[..., 0]))


# --------------------------------------------------------------------------- eddy drag
def skin_factor(xi):
    """``F(xi) = (3 / xi) (sinh xi - sin xi) / (cosh xi - cos xi)``: the eddy loss of a plate of thickness ``xi``
    skin depths relative to its low-frequency value (1 at ``xi -> 0``, ``3 / xi`` for a thick plate)."""
    xi = np.asarray(xi, dtype=float)
    small, big = xi < 0.05, xi > 30.0
    xs = np.where(small | big, 1.0, xi)
    full = 3.0 / xs * (np.sinh(xs) - np.sin(xs)) / (np.cosh(xs) - np.cos(xs))
    return np.where(small, 1.0, np.where(big, 3.0 / np.where(big, xi, 1.0), full))


class EddyDragV4(_V4, EddyDrag):
    """Eddy-current drag of a solid iron stator with skin effect, or of a thin sheet on both axes.

    * ``solid_iron`` -- eddy loss in an unlaminated iron plate of thickness ``t_p``, permeability ``mu_r`` and
      conductivity ``sigma`` under the array's field at the electrical frequency ``f = |v| / 2 tau``: the classical
      loss ``~ f^2 B^2`` times the skin-effect factor ``F(xi) = (3/xi) (sinh xi - sin xi) / (cosh xi - cos xi)``,
      ``xi = t_p / delta``, ``delta = sqrt(2 / (omega mu sigma))`` (Stoll, "The Analysis of Eddy Currents",
      Clarendon Press 1974, loss in a lamination with skin effect; also Lammeraner & Stafl, "Eddy Currents",
      Iliffe 1964). Drag ``P / v``: ``F_d = -c0 (B(g)/B(g_ref))^2 v F(xi(v))`` -- viscous at low speed, ``~ sqrt(v)``
      once the skin depth is below the plate's thickness; ``B`` MODEL.md's ``1 / sinh(pi (hm + g) / tau)``.
    * ``sheet_2axis`` -- a thin conducting sheet (thickness ``T``, conductivity ``sigma``: ``w = 2 / (mu0 sigma T)``)
      under the array's fundamental ``B e^{-K g} cos(K x)``, ``K = pi / tau``. Moving along ``d`` it gives Reitz's
      drag and lift (Reitz, "Forces on moving magnets due to eddy currents", J. Appl. Phys. 41(5), 1970):
      ``F_d = -c w^2 v / (v^2 + w^2)``, lift ``c w v^2 / (v^2 + w^2)``; moving along ``g`` the field's amplitude
      changes at the same rate per unit speed (``|dB/dt| = K B |v|`` both ways: Faraday's law in the sheet, the
      low-speed limit of Saslow, "Maxwell's theory of eddy currents in thin conducting sheets, and applications
      to electromagnetic shielding and MAGLEV", Am. J. Phys. 60(8), 1992), so the gap is damped by ``-c g_dot``
      with the same ``c(g) = c0 exp(-2 K (g - g_ref))``.
    """

    families = ("solid_iron", "sheet_2axis")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "solid_iron": {"c0": 6.0, "t_p": 1e-2, "mu_r": 500.0, "sigma": 5e6},
        "sheet_2axis": {"c0": 6.0, "T": 3e-3, "sigma": 3.5e7},
    }

    def xi(self, v):
        """Plate thickness in skin depths at speed ``v`` (``solid_iron``)."""
        p = self.p
        omega = K_POLE * np.abs(np.asarray(v, dtype=float))
        return p["t_p"] * np.sqrt(omega * MU0 * p["mu_r"] * p["sigma"] / 2.0)

    def w(self) -> float:
        """Characteristic speed of the sheet ``2 / (mu0 sigma T)`` [m/s] (``sheet_2axis``)."""
        return 2.0 / (MU0 * self.p["sigma"] * self.p["T"])

    def force(self, g, gd, d, dd):
        """Eddy forces ``(F_g, F_d)`` [N]."""
        p = self.p
        g, gd, dd = (np.asarray(x, dtype=float) for x in (g, gd, dd))
        if self.family == "solid_iron":
            c = p["c0"] * field_ratio(g, k.g_cog_ref) ** 2
            return 0.0 * dd, -c * dd * skin_factor(self.xi(dd))
        c = p["c0"] * np.exp(-2 * K_POLE * (g - k.g_cog_ref))
        w = self.w()
        den = dd * dd + w * w
        return c * (w * dd * dd / den - gd), -c * w * w * dd / den


# --------------------------------------------------------------------- out of the library
class MountResonance(_V4, Law):
    """A flexible mount of the horizontal encoder's read head (not in the library).

    The read head sits on a bracket of the mover with one lightly damped mode (frequency ``f_hz``, damping ratio
    ``zeta``); accelerating the mover excites it, and the encoder reads the head's position: ``d_read = d + q``
    with ``q'' + 2 zeta w q' + w^2 q = -d_ddot`` (a non-collocated sensor: Schmidt, Schitter & Rankers, "The
    Design of High Performance Mechatronics", 2nd ed., IOS Press / Delft Univ. Press 2014, ch. on motion
    control with a flexible sensor mount). With ``r = q' + d_dot``: ``q' = r - d_dot``, ``r' = -w^2 q - 2 zeta w
    (r - d_dot)``, advanced exactly over each sub-step for the held velocity (no force on the mover).
    """

    name = "mount_resonance"
    library = False
    families = ("read_head",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"read_head": {"f_hz": 60.0, "zeta": 0.02}}
    has_held = True
    has_read = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.state = np.zeros((0, 2))
        self.peak = 0.0
        self._maps: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def reset(self, n_runs: int) -> None:
        """Head at rest on its mount."""
        self.state = np.zeros((n_runs, 2))
        self.peak = 0.0

    def ss(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B)`` of ``[q, r]`` with the velocity as input."""
        w, z = 2 * math.pi * self.p["f_hz"], self.p["zeta"]
        return np.array([[0.0, 1.0], [-w * w, -2 * z * w]]), np.array([-1.0, 2 * z * w])

    def _map(self, h: float):
        if h not in self._maps:
            from scipy.linalg import expm

            A, B = self.ss()
            M = np.zeros((3, 3))
            M[:2, :2], M[:2, 2] = A, B
            E = expm(M * h)
            self._maps[h] = (E[:2, :2], E[:2, 2])
        return self._maps[h]

    def held(self, gd, dd, h: float):
        """Advance the mount over ``h`` at the mover's velocity; no force on the mover."""
        Ad, Bd = self._map(float(h))
        dd = np.asarray(dd, dtype=float)
        self.state = self.state @ Ad.T + dd[:, None] * Bd[None, :]
        self.peak = max(self.peak, float(np.max(np.abs(self.state[:, 0]), initial=0.0)))
        return np.zeros_like(dd), np.zeros_like(dd)

    def read(self, g, d):
        """Readings: the head's deflection adds to ``d``."""
        return g, d + self.state[:, 0]

    def recorded(self) -> dict[str, float]:
        """Size recorded while simulated: the head's peak deflection [m]."""
        return {"peak_error_g_m": 0.0, "peak_error_d_m": self.peak}


class CoilHeating(_V4, Law):
    """The stator coils' losses warm the stator, whose growth shifts the gap reading (not in the library).

    The copper loss ``P = 1.5 R |i|^2`` (three phases, amplitude-invariant dq currents) heats the stator through a
    first-order thermal path, ``tau_th dT/dt = R_th P - T`` (the lumped thermal model of machine structures: Mayr
    et al., "Thermal issues in machine tools", CIRP Annals 61(2), 2012; Bryan, "International status of thermal
    error research", CIRP Annals 39(2), 1990); the stator's surface moves towards the mover by ``kappa T``, which
    the gap sensor on the base does not see: ``g_read = g + kappa T``. The runs are recorded one after the
    other: each starts from the warm-up its predecessors' (hover) losses left, ``T0 = R_th P0 (1 - e^{-t0 /
    tau_th})``. The state is advanced once per period from the delivered currents (hook ``advance``).
    """

    name = "coil_heating"
    library = False
    families = ("first_order",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "first_order": {"R": 3.0, "R_th": 0.4, "tau_th": 60.0, "kappa": 3e-6},
    }
    has_read = True
    has_advance = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.T = np.zeros(0)
        self.started = False
        self.peak = 0.0

    def reset(self, n_runs: int) -> None:
        """Cold state; the first :meth:`advance` sets each run's warm-up."""
        self.T, self.started, self.peak = np.zeros(n_runs), False, 0.0

    def power(self, i) -> np.ndarray:
        """Copper loss [W] of the currents ``i`` (n_runs, 2)."""
        i = np.asarray(i, dtype=float)
        return 1.5 * self.p["R"] * (i[:, 0] ** 2 + i[:, 1] ** 2)

    def advance(self, i, t, Ts: float) -> None:
        """One period at the delivered currents ``i``; ``t`` the dataset time of each run's period [s]."""
        p = self.p
        target = p["R_th"] * self.power(i)
        if not self.started:
            self.T = target * (1.0 - np.exp(-np.asarray(t, dtype=float) / p["tau_th"]))
            self.started = True
        else:
            self.T = target + (self.T - target) * math.exp(-Ts / p["tau_th"])
        self.peak = max(self.peak, float(np.max(np.abs(self.T), initial=0.0)))

    def read(self, g, d):
        """Readings: the stator's growth adds to ``g``."""
        return g + self.p["kappa"] * self.T, d

    def recorded(self) -> dict[str, float]:
        """Size recorded while simulated: the peak reading error [m] and temperature rise [K]."""
        return {"peak_error_g_m": self.p["kappa"] * self.peak, "peak_error_d_m": 0.0, "peak_rise_k": self.peak}


#: The fourth set: one class per effect (library families and new effects), by effect name.
V4_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV4,
        FrictionV4,
        EndEffectV4,
        SaturationV4,
        AmplifierV4,
        CommutationV4,
        EddyDragV4,
        MountResonance,
        CoilHeating,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V4: tuple[str, ...] = tuple(EFFECTS_V3) + tuple(n for n in V4_LAWS if n not in EFFECTS_V3)
V4_LIBRARY: tuple[str, ...] = tuple(n for n, c in V4_LAWS.items() if c.library)
V4_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V4_LAWS.items() if not c.library)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3, then v4)."""
    return resolve_law(name, family, (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS), EFFECTS_V4)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS), EFFECTS_V4)


__all__ = [
    "EFFECTS_V4",
    "V4_LAWS",
    "V4_LIBRARY",
    "V4_OUT_OF_LIBRARY",
    "AmplifierV4",
    "CoggingV4",
    "CoilHeating",
    "CommutationV4",
    "EddyDragV4",
    "EndEffectV4",
    "FrictionV4",
    "MountResonance",
    "SaturationV4",
    "field_ratio",
    "law_class",
    "make_law",
    "skin_factor",
    "smooth_overhang",
]
