"""A fifth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v5"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` and :mod:`.laws_v4`
has, and two effects outside the library (in :mod:`.laws_v5_ool`), for the next pre-registered blind check. They
were written from their sources only, without reading the diagnosis or how it fits; each class carries
``new_law = True`` and ``law_set = "v5"`` in its truth record. The source of each law (author, title, venue,
year, equation where the source numbers it) is in its docstring and in ``docs/validation/rigsim-laws.md``.

Besides the hooks of the earlier sets, one hook is used by this set (the simulator calls it for laws that set the
flag; no earlier law does):

* ``force_i(g, gd, d, dd, i_q, i_d)`` (``has_force_i``): a smooth force ``(F_g, F_d)`` [N] that also depends on
  the currents the motor carries (a cogging that follows the net field of magnets and currents, a guide friction
  loaded by the thrust).

Laws whose force comes from a state the truth record cannot recompute from the recorded trajectory record their
own size while simulated (:meth:`recorded`, as in :mod:`.laws_v4`).
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
from .laws_v3 import V3_LAWS, AmplifierV3, _rot
from .laws_v4 import EFFECTS_V4, K_POLE, L_ARRAY, LAMBDA, V4_LAWS, field_ratio
from .laws_v5_ool import _V5, CoreHysteresis, TargetRunout
from .physics import NOMINAL, shape

G_STOP_HI = k.g_stop[1]
N_CELLS = 6  #: stator cells (cogging periods) each side of the centre: the array (6 periods) plus the stroke


def net_field(g, i_q, i_d):
    """``(1 - kd i_d, kq i_q)``: the gap field of magnets and currents relative to the magnets' alone.

    From seed eq. (2) with nominal constants: the pull ``C2 f2 - C3 f3 i_d + C4 f4 |i|^2`` is ``C2 f2 |1 - kd i_d
    + j kq i_q|^2`` up to the small mismatch of the cross term, with ``kd = C3 f3 / (2 C2 f2)`` (the d-axis field
    per ampere) and ``kq = sqrt(C4 f4 / (C2 f2))`` (the q-axis field per ampere, in quadrature).
    """
    sh = shape(g)
    kd = NOMINAL.C3 * sh.f3 / (2.0 * NOMINAL.C2 * sh.f2)
    kq = np.sqrt(NOMINAL.C4 * sh.f4 / (NOMINAL.C2 * sh.f2))
    return 1.0 - kd * np.asarray(i_d, dtype=float), kq * np.asarray(i_q, dtype=float)


def nominal_pull(g, i_q, i_d):
    """Magnetic pull of seed eq. (2) with nominal constants [N] (``Mv (C2 f2 - C3 f3 i_d + C4 f4 |i|^2)``)."""
    sh = shape(g)
    i_q, i_d = np.asarray(i_q, dtype=float), np.asarray(i_d, dtype=float)
    c = NOMINAL
    return c.Mv * (c.C2 * sh.f2 - c.C3 * sh.f3 * i_d + c.C4 * sh.f4 * (i_q * i_q + i_d * i_d))


# ----------------------------------------------------------------------------- cogging
def _cell_step(x):
    """Raised-cosine step from 0 (``x <= -lambda/2``) to 1 (``x >= lambda/2``) and its derivative [1/m]."""
    z = np.clip(np.asarray(x, dtype=float) / LAMBDA, -0.5, 0.5)
    inside = np.abs(np.asarray(x, dtype=float)) < 0.5 * LAMBDA
    return 0.5 * (1.0 + np.sin(math.pi * z)), np.where(inside, 0.5 * math.pi / LAMBDA * np.cos(math.pi * z), 0.0)


class CoggingV5(_V5, Cogging):
    """Cogging under load (frozen permeability), or of a stator whose cells are not all alike.

    Both are the gradient of a co-energy ``W(g, d)`` at the carried currents (``F = -grad W``, ``F_g > 0`` opens
    the gap), with the period ``lambda = 2 t1`` of seed eq. (9) and the shape ``sum_k c_k sin(2 pi k u / lambda +
    phi_k)`` (k = 1..3, ``phi_1 = 0``, normalized to ``sum |c_k| = 1``):

    * ``on_load`` -- the cogging follows the *net* gap field of the magnets and the currents, not the magnets'
      alone (the frozen-permeability analysis of on-load cogging: Azar, Zhu & Ombach, "Influence of electric
      loading and magnetic saturation on cogging torque, back-EMF and torque ripple of PM machines", IEEE Trans.
      Magn. 48(10), 2012). The slotting modulates the energy of the net field, ``|B_pm (1 - kd i_d) + j B_pm kq
      i_q|^2`` (:func:`net_field`), i.e. seed eq. (2)'s pull ``P(g, i)``: the amplitude is ``xi_h P / (Mv G)``
      (``xi_h`` the peak at a hover), and the q-axis field turns the field pattern by ``psi = atan2(kq i_q, 1 - kd
      i_d)`` electrical, shifting the cogging wave by ``psi tau / pi`` along d. ``W = (lambda / 2 pi) xi_h P /
      (Mv G) sum_k (c_k / k) cos(...)`` (hook ``force_i``).
    * ``cell_tolerance`` -- the stator is built of cells one cogging period long, each with its own permeance
      ``1 + eps_i`` and position error ``delta_i`` (manufacturing tolerances of the stator: Gasparin, Cernigoj,
      Markic & Fiser, "Additional cogging torque components in permanent-magnet motors due to manufacturing
      imperfections", IEEE Trans. Magn. 45(3), 2009, the stator-side imperfections). Each cell interacts with the
      magnets over the array's footprint ``win(u)`` (a box of the array's length, ``6 lambda``, with raised-cosine
      edges one period wide: ``sum_i win(d - i lambda) = 6`` exactly, so an ideal stator gives the periodic
      law): ``W = (lambda / 2 pi) (A(g) / 6) sum_i (1 + eps_i) win(d - i lambda - delta_i) sum_k (c_k / k) cos(2 pi
      k (d - delta_i) / lambda + phi_k)``, ``A = xi0 exp(-(g - g_ref) / ell)`` (seed eq. (9)'s decay). The
      tolerances make the cogging's amplitude and phase change along the stroke (not periodic in d).

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("on_load", "cell_tolerance")
    _shape: ClassVar[dict[str, float]] = {"c1": 1.0, "c2": 0.4, "c3": 0.2, "phi2": 0.0, "phi3": 0.0, "replace": 0.0}
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "on_load": {"xi_h": 2.0, **_shape},
        "cell_tolerance": {
            "xi0": 3.0,
            "ell": 4e-3,
            **_shape,
            **{f"eps{j}": 0.0 for j in range(2 * N_CELLS + 1)},
            **{f"dx{j}": 0.0 for j in range(2 * N_CELLS + 1)},
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family == "cell_tolerance"
        self.has_force_i = self.family == "on_load"

    def _c(self) -> np.ndarray:
        c = np.array([self.p["c1"], self.p["c2"], self.p["c3"]])
        return c / max(float(np.sum(np.abs(c))), 1e-12)

    def wave(self, u):
        """``(S, P)``: ``sum_k c_k sin(theta_k)`` and ``sum_k (c_k / k) cos(theta_k)``, ``theta_k = 2 pi k u / lambda
        + phi_k``."""
        u = np.asarray(u, dtype=float)
        S = 0.0 * u
        P = 0.0 * u
        for j, c in enumerate(self._c(), start=1):
            th = 2 * math.pi * j * u / LAMBDA + (self.p[f"phi{j}"] if j > 1 else 0.0)
            S = S + c * np.sin(th)
            P = P + c / j * np.cos(th)
        return S, P

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """On-load cogging ``(F_g, F_d)`` [N] at the carried currents."""
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        re, im = net_field(g, i_q, i_d)
        shift = np.arctan2(im, re) * k.tau / math.pi
        S, P = self.wave(d - shift)
        scale = self.p["xi_h"] / (NOMINAL.Mv * k.G)
        h = 1e-7
        dpull = (nominal_pull(g + h, i_q, i_d) - nominal_pull(g - h, i_q, i_d)) / (2 * h)
        return -LAMBDA / (2 * math.pi) * scale * dpull * P, scale * nominal_pull(g, i_q, i_d) * S

    def amplitude(self, g):
        """``A(g) = xi0 exp(-(g - g_ref) / ell)`` of ``cell_tolerance`` [N]."""
        return self.p["xi0"] * np.exp(-(np.asarray(g, dtype=float) - k.g_cog_ref) / self.p["ell"])

    def force(self, g, gd, d, dd):
        """Cogging of the imperfect stator ``(F_g, F_d)`` [N] (``cell_tolerance``)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        W = 0.0 * (g + d)
        Fd = 0.0 * W
        n = 2 * N_CELLS + 1
        col = (n,) + (1,) * d.ndim  # every cell at once (same arithmetic as one by one), summed in order below
        dx = np.array([p[f"dx{j}"] for j in range(n)]).reshape(col)
        u = d[None, ...] - ((np.arange(n) - N_CELLS) * LAMBDA).reshape(col) - dx
        hi, lo = _cell_step(u + 3 * LAMBDA), _cell_step(u - 3 * LAMBDA)
        w, dw = hi[0] - lo[0], hi[1] - lo[1]
        S, P = self.wave(d[None, ...] - dx)
        for j in range(n):
            if not (np.any(w[j]) or np.any(dw[j])):
                continue
            wt = 1.0 + p[f"eps{j}"]
            W = W + wt * w[j] * P[j]
            Fd = Fd + wt * (w[j] * S[j] - LAMBDA / (2 * math.pi) * dw[j] * P[j])
        A = self.amplitude(g) / 6.0
        # F_g = -dW/dg with W = (lambda / 2 pi) A sum(...) and dA/dg = -A / ell
        return LAMBDA / (2 * math.pi) * A * W / p["ell"], A * Fd


# ---------------------------------------------------------------------------- friction
class FrictionV5(_V5, Friction):
    """Rolling-guide friction loaded by the thrust, or rate-and-state friction with aging.

    * ``palmgren`` -- Palmgren's rolling-bearing friction (Palmgren, "Ball and Roller Bearing Engineering", 3rd
      ed., SKF / Burbank 1959): a load-dependent part ``M1 = f1 P`` proportional to the bearing's load and a
      lubricant part ``M0 ~ (nu n)^(2/3)`` growing with the speed to the power 2/3. The vertical guide holds the
      mover against the thrust, so its load is its preload plus the thrust ``|Mh C1 f1(g) i_q|`` (seed eq. (2),
      nominal constants; hook ``force_i``); the horizontal guide carries a constant preload:
      ``F = -(Fc + mu N_mag + c_v |v|^(2/3)) tanh(v / v_reg)`` per axis (``N_mag`` the thrust on the vertical
      guide, 0 on the horizontal one).
    * ``rate_state`` -- rate-and-state friction with the aging law (Dieterich, "Modeling of rock friction: 1.
      Experimental results and constitutive equations", J. Geophys. Res. 84(B5), 1979; Ruina, "Slip instability
      and state variable friction laws", J. Geophys. Res. 88(B12), 1983, eq. (5)): ``F = -(F0 [1 + a ln((|v| +
      v_reg) / v0) + b ln(v0 theta / Dc)] tanh(v / v_reg) + b_v v)``, ``d theta / dt = 1 - |v| theta / Dc``
      (solved exactly for the sub-step's velocity): a velocity step gives a transient of ``b ln(v2 / v1)`` that
      fades over ``Dc`` of slip, and the contact heals (grows stronger) with the log of the time at rest.
      ``v_reg`` regularizes the logarithm and the sign below a presliding speed, as in :class:`.laws.Friction`;
      ``v0`` is the reference speed (``F = F0`` in steady sliding there); each run starts from that steady state.
    """

    families = ("palmgren", "rate_state")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "palmgren": {"Fc_g": 0.1, "Fc_d": 0.1, "mu": 0.005, "cv_g": 0.3, "cv_d": 0.3, "v_reg": 1e-3},
        "rate_state": {
            "F0_g": 0.2,
            "F0_d": 0.2,
            "a": 0.02,
            "b": 0.03,
            "Dc": 1e-5,
            "v0": 1e-3,
            "bv_g": 0.5,
            "bv_d": 0.5,
            "v_reg": 1e-3,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = False
        self.has_force_i = self.family == "palmgren"
        self.has_held = self.family == "rate_state"
        self.state = np.zeros((0, 2))

    def reset(self, n_runs: int) -> None:
        """State ``theta`` per run and axis at its steady value for ``v0`` (``rate_state``)."""
        self.state = np.full((n_runs, 2), self.p["Dc"] / self.p["v0"] if self.family == "rate_state" else 0.0)

    @staticmethod
    def thrust(g, i_q):
        """Magnitude of the thrust [N] (seed eq. (2), nominal constants)."""
        return np.abs(NOMINAL.Mh * NOMINAL.C1 * shape(g).f1 * np.asarray(i_q, dtype=float))

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """Palmgren friction on both axes [N]."""
        p = self.p
        out = []
        for v, ax, load in ((gd, "g", p["mu"] * self.thrust(g, i_q)), (dd, "d", 0.0)):
            v = np.asarray(v, dtype=float)
            level = p[f"Fc_{ax}"] + load + p[f"cv_{ax}"] * np.abs(v) ** (2.0 / 3.0)
            out.append(-level * np.tanh(v / p["v_reg"]))
        return out[0], out[1]

    def level(self, v, theta, ax: str):
        """Rate-and-state friction level ``F0 [1 + a ln((|v| + v_reg)/v0) + b ln(v0 theta / Dc)]`` [N] (>= 0)."""
        p = self.p
        v = np.abs(np.asarray(v, dtype=float))
        mu = 1.0 + p["a"] * np.log((v + p["v_reg"]) / p["v0"]) + p["b"] * np.log(p["v0"] * theta / p["Dc"])
        return p[f"F0_{ax}"] * np.maximum(mu, 0.0)

    def held(self, gd, dd, h: float):
        """Advance ``theta`` over ``h`` at the current velocities; return the held rate-and-state force."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            av = np.abs(v)
            th = self.state[:, j]
            moving = av > 0
            tss = p["Dc"] / np.where(moving, av, 1.0)
            th = np.where(moving, tss + (th - tss) * np.exp(-av * h / p["Dc"]), th + h)
            self.state[:, j] = th
            out.append(-(self.level(v, th, ax) * np.tanh(v / p["v_reg"]) + p[f"bv_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
def _chamfer(x, g, slope: float, length: float):
    """Force lost [m of array] by an overhang ``x`` over a chamfered stator end (see :class:`EndEffectV5`)."""
    x, g = np.asarray(x, dtype=float), np.asarray(g, dtype=float)
    a0 = K_POLE * (k.hm + g)
    u = np.minimum(x, length)
    eps = K_POLE * slope * u
    kept = np.sinh(a0) ** 2 * (1.0 / np.tanh(a0) - 1.0 / np.tanh(a0 + eps)) / (K_POLE * slope)
    return u - kept + np.maximum(x - length, 0.0)


class EndEffectV5(_V5, EndEffect):
    """End effects from the flux balance of the overlapping poles, or at chamfered stator ends.

    The magnet array (``pm`` magnets, length ``L = pm tau``, field ``sin(pi u / tau)`` along it, zero mean) overlaps
    the stator ``[-(L/2 + e_n), L/2 + e_p]`` on ``[a, b]``.

    * ``flux_balance`` -- the flux the overlapping poles drive into the stator must come back through the gap
      over the same stretch (Gauss's law for ``B``; the magnetic-circuit view of Hanselman, "Brushless Permanent
      Magnet Motor Design", 2nd ed., Magna Physics 2006, ch. 4): the net (mean) field over the overlap cannot
      cross, so the field there is ``sin - mean``, and the pull scales with its energy, ``rho = (int_a^b sin^2 -
      (int_a^b sin)^2 / (b - a)) / (L / 2)``. Besides the loss of the overhanging part, the flux imbalance of a
      part-covered pole adds a loss that comes and goes with the overhang (period ``tau``): not monotone.
    * ``chamfer`` -- the stator's end teeth are chamfered to soften the end force (Lim, Woo, Kang, Hong & Kim,
      "Detent force minimization techniques in permanent magnet linear synchronous motors", IEEE Trans. Magn.
      38(2), 2002): beyond ``e`` the iron recedes with slope ``s`` over ``c`` and then ends, so the overhanging
      magnets see the gap ``g + s u``; with MODEL.md's field ``B ~ 1 / sinh(pi (hm + g) / tau)`` the pull lost
      over an overhang ``x`` is ``int_0^min(x, c) (1 - sinh^2 a0 / sinh^2(a0 + K s u)) du + max(0, x - c)``
      (closed form, ``a0 = K (hm + g)``, ``K = pi / tau``), divided by ``L``: a quadratic onset whose curvature
      ``K s coth(a0)`` depends on the gap, then the full loss past the chamfer.

    Both keep :class:`.laws.EndEffect`'s pole-pitch thrust ripple.
    """

    families = ("flux_balance", "chamfer")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "flux_balance": {**EndEffect._ripple, "e_p": 0.02, "e_n": 0.03},
        "chamfer": {**EndEffect._ripple, "e_p": 0.02, "e_n": 0.03, "s": 0.5, "c": 0.01},
    }

    @staticmethod
    def balance(d, e_p: float, e_n: float):
        """``rho`` of ``flux_balance`` at position ``d``."""
        d = np.asarray(d, dtype=float)
        ua = np.maximum(-L_ARRAY / 2, -(L_ARRAY / 2 + e_n) - d)
        ub = np.minimum(L_ARRAY / 2, L_ARRAY / 2 + e_p - d)
        ln = np.maximum(ub - ua, 1e-12)
        sq = 0.5 * ln - (np.sin(2 * K_POLE * ub) - np.sin(2 * K_POLE * ua)) / (4 * K_POLE)
        mean = (np.cos(K_POLE * ua) - np.cos(K_POLE * ub)) / K_POLE
        return (sq - mean * mean / ln) / (L_ARRAY / 2)

    def rho_g(self, d, g):
        """Fraction of the magnetic force left at ``(d, g)``."""
        p = self.p
        d, g = np.asarray(d, dtype=float), np.asarray(g, dtype=float)
        if self.family == "flux_balance":
            return self.balance(d, p["e_p"], p["e_n"]) + 0.0 * g
        xp, xn = np.maximum(d - p["e_p"], 0.0), np.maximum(-d - p["e_n"], 0.0)
        return 1.0 - (_chamfer(xp, g, p["s"], p["c"]) + _chamfer(xn, g, p["s"], p["c"])) / L_ARRAY

    def rho(self, d):
        """Fraction left at ``d`` at the reference gap (for reports; the rig uses :meth:`rho_g`)."""
        return self.rho_g(d, k.g_cog_ref + 0.0 * np.asarray(d, dtype=float))

    def factors(self, g, d, f: list) -> None:
        """Scale every term by ``rho(d, g)`` and the thrust by the ripple."""
        f[2] = f[2] * self.rho_g(d, g)
        f[3] = f[3] * self.ripple(d)


# --------------------------------------------------------------------------- saturation
def marrocco(b, eps: float, alpha: float):
    """Marrocco's relative reluctivity ``eps + (1 - eps) b^(2 alpha) / (b^(2 alpha) + 1)`` at ``b = B / B_knee``."""
    b2a = np.abs(np.asarray(b, dtype=float)) ** (2.0 * alpha)
    return eps + (1.0 - eps) * b2a / (b2a + 1.0)


class SaturationV5(_V5, Saturation):
    """Cross saturation by the net flux vector, or the magnets' demagnetization knee.

    * ``cross_flux`` -- the iron saturates with the *magnitude* of the net flux of magnets and both current axes:
      the q-axis (thrust) current saturates the teeth as well (cross saturation: Vagati, Pastorelli, Scapino &
      Franceschini, "Impact of cross saturation in synchronous reluctance motors of the transverse-laminated type",
      IEEE Trans. Ind. Appl. 36(4), 2000). The iron's flux density, relative to its knee, is ``b = b_lo x(g) |1 -
      kd i_d + j kq i_q|`` (:func:`net_field`; ``x = B(g) / B(g_lo)``, MODEL.md's field), and the iron's reluctance
      ``r nu(b)`` in series with the gap's (Marrocco's reluctivity, ``nu = eps + (1 - eps) b^(2 alpha) /
      (b^(2 alpha) + 1)``: Marrocco, "Analyse numérique de problèmes d'électrotechnique", Ann. Sci. Math. Québec
      1(2), 1977) lowers the flux to ``f`` solving ``f (1 + r nu(f b)) = 1 + r eps`` (bisection; 1 at low field).
      ``r`` is set by the loss ``loss_lo`` at the lower stop without current. Applied to the fields ``target``
      names (hook ``factors_i``).
    * ``magnet_knee`` -- the magnets' own demagnetization knee (hot NdFeB; Campbell, "Permanent Magnet Materials and
      their Application", Cambridge Univ. Press 1994, the second-quadrant B-H curve and its knee): the magnet's
      demagnetizing field, in units of the knee's, is ``w = w_g (g / (g + hm / mu_rec) + kd(g) i_d)``: the
      self-demagnetization on the magnet's load line plus the levitation current's field (positive ``i_d`` weakens
      the magnets: seed eq. (2); ``w_g`` the magnets' coercive field over the knee's); past the knee ``w = 1`` the
      remanence falls steeply: ``km *= 1 - l_max tanh(s_k w_s
      softplus((w - 1) / w_s) / l_max)``. A loss that grows with the levitation current (unlike the iron's
      saturation, which the levitation current relieves).
    """

    families = ("cross_flux", "magnet_knee")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "cross_flux": {"loss_lo": 0.2, "b_lo": 0.9, "alpha": 3.0, "eps": 1e-3, "target": "both"},
        "magnet_knee": {"w_g": 0.95, "s_k": 1.5, "w_s": 0.03, "l_max": 0.35, "target": "magnet"},
    }
    N_BISECT = 48

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.family == "magnet_knee" and self.p["target"] != "magnet":
            raise ValueError("saturation (magnet_knee): target must be 'magnet' (the magnets' own knee)")
        self.has_factors = False
        self.has_factors_i = True
        if self.family == "cross_flux":  # constants of the circuit, computed once
            self._r = self.ratio_r()
            self._f_hi = self.flux(self.p["b_lo"] * field_ratio(G_STOP_HI, G_STOP_LO))

    def ratio_r(self) -> float:
        """Iron-to-gap reluctance ratio ``r`` giving ``loss_lo`` at the lower stop without current."""
        p = self.p
        q = 1.0 - p["loss_lo"]
        return (1.0 / q - 1.0) / float(marrocco(q * p["b_lo"], p["eps"], p["alpha"]) - p["eps"] / q)

    def flux(self, b):
        """Flux ratio ``f`` (to the linear circuit) solving ``f (1 + r nu(f b)) = 1 + r eps`` for ``b`` (bisection)."""
        p = self.p
        r = getattr(self, "_r", None) or self.ratio_r()
        b = np.asarray(b, dtype=float)
        lo, hi = np.zeros_like(b), np.ones_like(b)
        for _ in range(self.N_BISECT):  # f (1 + r nu(f b)) grows with f: one root in (0, 1]
            mid = 0.5 * (lo + hi)
            over = mid * (1.0 + r * marrocco(mid * b, p["eps"], p["alpha"])) > 1.0 + r * p["eps"]
            lo, hi = np.where(over, lo, mid), np.where(over, mid, hi)
        return 0.5 * (lo + hi)

    def loss(self, g, i_q=0.0, i_d=0.0):
        """Fraction of the saturating field lost at gap ``g`` and carried currents ``i_q``, ``i_d``."""
        p = self.p
        g = np.asarray(g, dtype=float)
        re, im = net_field(g, i_q, i_d)
        if self.family == "cross_flux":
            b = p["b_lo"] * field_ratio(g, G_STOP_LO) * np.hypot(re, im)
            return 1.0 - self.flux(b) / self._f_hi
        w = p["w_g"] * (g / (g + k.hm / k.mu_rec) + (1.0 - re))
        knee = p["w_s"] * np.logaddexp(0.0, (w - 1.0) / p["w_s"])
        return p["l_max"] * np.tanh(p["s_k"] * knee / p["l_max"])

    def factors_i(self, g, d, i_q, i_d, f: list) -> None:
        """Scale the fields ``target`` names by ``1 - loss(g, i)``."""
        kk = 1.0 - self.loss(g, i_q, i_d)
        if self.p["target"] in ("magnet", "both"):
            f[0] = f[0] * kk
        if self.p["target"] in ("current", "both"):
            f[1] = f[1] * kk


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV5(_V5, AmplifierV3):
    """Current loops with a filter in the current measurement, or with the converter's delay inside the loop.

    Both: a PI current loop tuned by pole-zero cancellation on the winding (open loop ``wc / s``), plus a
    fractional transport delay ``delay_samples`` (exact state-space solution per sub-step, as :mod:`.laws_v3`).

    * ``feedback_filter`` -- an anti-aliasing filter ``wf / (s + wf)`` in the current measurement (a prefilter
      inside the loop: Franklin, Powell & Workman, "Digital Control of Dynamic Systems", 3rd ed., Addison-Wesley
      1998, the prefilter's lag in the loop): the loop regulates the filtered current, so the true one is ``i / u
      = wc (s + wf) / (s^2 + wf s + wc wf)`` -- a zero at ``-wf`` the forward-path lag (``cascade``) does not have,
      overshoot, and a low-frequency group delay ``1/wc - 1/wf``.
    * ``loop_delay`` -- the computation and PWM delay ``Td`` inside the current loop (Buso & Mattavelli, "Digital
      Control in Power Electronics", Morgan & Claypool 2006, ch. 4: the delay of the digital current loop and its
      phase margin), ``e^{-s Td}`` as its (2, 2) Padé approximant ``P(s) / P(-s)``, ``P = 1 - s Td / 2 + (s Td)^2 /
      12``: ``i / u = wc P(s) / (s P(-s) + wc P(s))``, two right-half-plane zeros and resonance growing with ``q = wc
      Td`` (stable for ``q < sqrt(21) - 3``); group delay ``1/wc`` at zero frequency.
    """

    families = ("feedback_filter", "loop_delay")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "feedback_filter": {"bandwidth_hz": 300.0, "filter_ratio": 2.5, "delay_samples": 0.0},
        "loop_delay": {"bandwidth_hz": 400.0, "q": 0.6, "delay_samples": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        if self.family == "loop_delay" and not 0.0 < self.p["q"] < math.sqrt(21.0) - 3.0:
            raise ValueError(f"amplifier_lag (loop_delay): q = wc Td must be in (0, {math.sqrt(21.0) - 3.0:.3f})")

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` of axis ``axis`` (controllable canonical form; inputs ``[u, v]``, ``v`` unused)."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "feedback_filter":
            wf = wc * p["filter_ratio"]
            den, num = [wf, wc * wf], [wc * wf, wc]  # s^2 + wf s + wc wf; numerator b0 + b1 s
        else:
            Td = p["q"] / wc
            den = [
                6.0 / Td + wc,  # s^3 + a2 s^2 + a1 s + a0: [a2, a1, a0]
                12.0 / Td**2 * (1.0 - wc * Td / 2.0),
                12.0 * wc / Td**2,
            ]
            num = [12.0 * wc / Td**2, -6.0 * wc / Td, wc]  # b0 + b1 s + b2 s^2
        n = len(den)
        A = np.zeros((n, n))
        A[:-1, 1:] = np.eye(n - 1)
        A[-1, :] = -np.array(den[::-1])  # [-a0, -a1, (-a2)]
        B = np.zeros((n, 2))
        B[-1, 0] = 1.0
        return A, B, np.array(num + [0.0] * (n - len(num)))

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        wc = 2 * math.pi * self.p["bandwidth_hz"]
        lag = 1.0 / wc - (1.0 / (wc * self.p["filter_ratio"]) if self.family == "feedback_filter" else 0.0)
        return self.p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
class CommutationV5(_V5, CommutationOffset):
    """Commutation angle errors of a magnetoresistive angle sensor, or of a phase finding repeated per run.

    * ``sw_lag`` -- the angle is read by a magnetoresistive (free-layer) sensor over the magnet array whose
      magnetization lags the field's direction through its uniaxial anisotropy (Stoner & Wohlfarth, "A mechanism
      of magnetic hysteresis in heterogeneous alloys", Phil. Trans. R. Soc. Lond. A 240(826), 1948; for angle
      sensors: Tumanski, "Thin Film Magnetoresistive Sensors", IOP Publishing 2001): at field ``H`` and anisotropy
      field ``Hk`` the magnetization angle error ``e`` solves ``sin(-e) = (h / 2) sin(2 (psi + e))``, ``h = Hk / H``,
      ``psi`` the field's angle from the easy axis (Newton; unique for ``h < 1``). The sensor on the stator reads
      the array across the gap, so ``H ~ B(g + c_s)`` (MODEL.md's field) and ``h = h_ref B(g_ref + c_s) / B(g +
      c_s)`` *grows* as the gap opens: ``delta = delta0 + e(pi (d - x0) / tau, h(g))``, period ``tau``.
    * ``phase_finding`` -- the drive finds the commutation angle by a phase-finding routine before each run (a
      current ``I_inj`` injected along an assumed axis pulls the mover to where the thrust vanishes; Krishnan,
      "Permanent Magnet Synchronous and Brushless DC Motor Drives", CRC Press 2010, initial rotor position). The
      guide's static friction and cogging stop the mover early, within ``|F| <= F_stick``, so each run carries its
      own constant error ``delta_r = delta0 + asin(u_r F_stick / (k_f I_inj))`` (``k_f`` the thrust per ampere at
      ``g_ref``, seed eq. (2); ``u_r`` in ``[-1, 1]`` where run ``r``'s mover stopped, drawn from the law's
      ``seed``): a per-run offset, not one for the dataset.
    """

    families = ("sw_lag", "phase_finding")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "sw_lag": {"delta0": 0.0, "h_ref": 0.1, "c_s": 5e-3, "x0": 0.0, "psi_e": 0.0},
        "phase_finding": {"delta0": 0.0, "F_stick": 0.4, "I_inj": 1.5, "seed": 0.0},
    }
    has_rotate = False
    has_rotate_at = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.offsets = np.zeros(0)

    def reset(self, n_runs: int) -> None:
        """Draw the per-run stopping points ``u_r`` (``phase_finding``) from the law's own seed."""
        if self.family == "phase_finding":
            rng = np.random.default_rng(np.random.SeedSequence([int(self.p["seed"]), 0x5F1D]))
            u = rng.uniform(-1.0, 1.0, n_runs)
            kf = NOMINAL.Mh * NOMINAL.C1 * float(shape(k.g_cog_ref).f1)
            self.offsets = self.p["delta0"] + np.arcsin(np.clip(u * self.p["F_stick"] / (kf * self.p["I_inj"]), -1, 1))

    def describe(self) -> dict[str, Any]:
        """Family and parameters; for ``phase_finding`` also the angle of each run simulated last [rad]."""
        out = super().describe()
        if self.family == "phase_finding":
            out["run_offsets_rad"] = [float(x) for x in self.offsets]
        return out

    def sw_error(self, psi, h):
        """Stoner-Wohlfarth angle error ``e`` of the magnetization for field angle ``psi`` and ``h = Hk / H``."""
        psi, h = np.broadcast_arrays(np.asarray(psi, dtype=float), np.asarray(h, dtype=float))
        e = -0.5 * h * np.sin(2 * psi)
        for _ in range(8):
            fval = -np.sin(e) - 0.5 * h * np.sin(2 * (psi + e))
            e = e - fval / (-np.cos(e) - h * np.cos(2 * (psi + e)))
        return e

    def h(self, g):
        """``Hk / H`` at gap ``g``: the field at the sensor ``~ 1 / sinh(pi (hm + g + c_s) / tau)`` (MODEL.md)."""
        p = self.p
        y = np.asarray(g, dtype=float) + p["c_s"]
        return p["h_ref"] * np.sinh(K_POLE * (k.hm + y)) / math.sinh(K_POLE * (k.hm + k.g_cog_ref + p["c_s"]))

    def angle(self, d, dd=0.0, g=k.g_cog_ref):
        """Electrical angle error at position ``d`` and gap ``g`` (``sw_lag``; per run for ``phase_finding``)."""
        p = self.p
        if self.family == "phase_finding":
            off = self.offsets
            d = np.asarray(d, dtype=float)
            return (off.reshape(off.shape + (1,) * (d.ndim - 1)) if d.ndim else off) + 0.0 * d
        th = math.pi * (np.asarray(d, dtype=float) - p["x0"]) / k.tau
        return p["delta0"] + self.sw_error(th - p["psi_e"], self.h(g))

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by ``delta`` at the state ``X`` (rows: runs)."""
        return _rot(i_q, i_d, self.angle(X[..., 2], X[..., 3], X[..., 0]))


# --------------------------------------------------------------------------- eddy drag
class EddyDragV5(_V5, EddyDrag):
    """Eddy-current brakes at the ends of the stroke, or the stator iron's hysteresis drag with its lag angle.

    * ``end_brake`` -- conducting plates beside the stroke's ends (end-of-travel eddy brakes): the drag is
      proportional to the area of the array's field over the conductor, ``b = k sigma delta A B^2`` (Gosline &
      Hayward, "Eddy current brakes for haptic interfaces: design, identification, and control", IEEE/ASME Trans.
      Mechatronics 13(6), 2008), and acts on any in-plane motion (both axes). The plates start ``e_p`` / ``e_n``
      beyond the array's ends at ``d = 0`` and sit beside the array, so the field they see does not depend on the
      gap: ``c(d) = c_l (o(d - e_p) + o(-d - e_n))``, ``o(x) = s ln(1 + exp(x / s))`` the overlap smoothed over the
      field's fringe ``s``; ``F = -c(d) (g_dot, d_dot)``. A damping that depends on the position, not the gap.
    * ``hysteresis_lag`` -- the hysteresis loss of the stator iron, ``P_h ~ f B^beta`` per cycle (Steinmetz, "On the
      law of hysteresis", Trans. AIEE 9, 1892), is a drag independent of speed, ``F_h(g) = F_h0 (B(g)/B(g_ref))^beta``,
      carried by the lag of the iron's magnetization behind the moving field (Teare, "Theory of hysteresis-motor
      torque", Trans. AIEE 59, 1940: the force ``~ sin`` of the lag angle, which grows with the travel up to the
      hysteresis angle ``theta_h``): ``theta <- clip(theta + (pi / tau) v h, -theta_h, theta_h)`` (electrical) and
      ``F_d = -F_h(g) sin(theta) / sin(theta_h)`` -- elastic over ``theta_h tau / pi`` (millimetres) after a
      reversal, constant in sliding -- plus the classical eddy loss ``~ f^2 B^2``, ``-c_e (B(g)/B(g_ref))^2 v``.
    """

    families = ("end_brake", "hysteresis_lag")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "end_brake": {"c_l": 500.0, "e_p": 0.02, "e_n": 0.02, "s": 5e-3},
        "hysteresis_lag": {"F_h0": 0.2, "beta": 1.6, "theta_h": 0.4, "c_e": 2.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_held = self.family == "hysteresis_lag"
        self.state = np.zeros(0)
        self.peak = np.zeros(2)
        if self.has_held:  # its force comes from a state the trajectory does not hold: size recorded while simulated
            self.recorded = self._recorded

    def reset(self, n_runs: int) -> None:
        """Iron's lag angle zero (``hysteresis_lag``)."""
        self.state, self.peak = np.zeros(n_runs), np.zeros(2)

    def coefficient(self, d):
        """End-brake damping ``c(d)`` [N s/m]."""
        p = self.p
        d = np.asarray(d, dtype=float)
        o = p["s"] * (np.logaddexp(0.0, (d - p["e_p"]) / p["s"]) + np.logaddexp(0.0, (-d - p["e_n"]) / p["s"]))
        return p["c_l"] * o

    def held(self, gd, dd, h: float):
        """Advance the iron's lag angle over ``h`` at the horizontal speed (its force is :meth:`force`'s)."""
        dd = np.asarray(dd, dtype=float)
        th = self.p["theta_h"]
        self.state = np.clip(self.state + K_POLE * dd * h, -th, th)
        return np.zeros_like(dd), np.zeros_like(dd)

    def force(self, g, gd, d, dd):
        """Eddy / hysteresis forces ``(F_g, F_d)`` [N]."""
        p = self.p
        g, gd, dd = (np.asarray(x, dtype=float) for x in (g, gd, dd))
        if self.family == "end_brake":
            c = self.coefficient(d)
            return -c * gd, -c * dd
        b = field_ratio(g, k.g_cog_ref)
        th = self.state if self.state.shape == dd.shape else 0.0 * dd
        fd = -p["F_h0"] * b ** p["beta"] * np.sin(th) / math.sin(p["theta_h"]) - p["c_e"] * b * b * dd
        if fd.ndim == 1 and fd.size == self.state.size:
            self.peak[1] = max(self.peak[1], float(np.max(np.abs(fd), initial=0.0)))
        return 0.0 * fd, fd

    def _recorded(self) -> dict[str, float]:
        """Size recorded while simulated (``hysteresis_lag``): the peak drag [N]."""
        return {"peak_force_n": float(self.peak[1]), "peak_force_g_n": 0.0, "peak_force_d_n": float(self.peak[1])}


#: The fifth set: one class per effect (library families and new effects), by effect name.
V5_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV5,
        FrictionV5,
        EndEffectV5,
        SaturationV5,
        AmplifierV5,
        CommutationV5,
        EddyDragV5,
        CoreHysteresis,
        TargetRunout,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V5: tuple[str, ...] = tuple(EFFECTS_V4) + tuple(n for n in V5_LAWS if n not in EFFECTS_V4)
V5_LIBRARY: tuple[str, ...] = tuple(n for n, c in V5_LAWS.items() if c.library)
V5_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V5_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3, v4, then v5)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V5)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V5)


__all__ = [
    "EFFECTS_V5",
    "N_CELLS",
    "V5_LAWS",
    "V5_LIBRARY",
    "V5_OUT_OF_LIBRARY",
    "AmplifierV5",
    "CoggingV5",
    "CommutationV5",
    "CoreHysteresis",
    "EddyDragV5",
    "EndEffectV5",
    "FrictionV5",
    "SaturationV5",
    "TargetRunout",
    "law_class",
    "make_law",
    "marrocco",
    "net_field",
    "nominal_pull",
]
