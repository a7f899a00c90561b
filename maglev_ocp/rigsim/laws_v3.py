"""A third set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v3"``).

Two families per library effect that neither :mod:`.laws` nor :mod:`.laws_new` has, and two
effects outside the library. They were written from their sources only (not from what a fitter
can fit) for the pre-registered blind check; each class carries ``new_law = True`` and
``law_set = "v3"`` in its truth record. The source of each law (author, title, journal, year,
equation) is in its docstring and in ``docs/validation/rigsim-laws.md``.

Besides the hooks of :mod:`.laws`, two hooks read more of the state (used by the simulator when a
law sets the flag):

* ``rotate_at(i_q, i_d, X, t)`` (``has_rotate_at``): currents the motor carries, given the whole
  state ``X = [g, g_dot, d, d_dot, ...]`` and the dataset time ``t`` [s];
* ``read_at(g, d, t)`` (``has_read_at``): encoder readings at the dataset time ``t``.

An amplifier law with ``lti = True`` is a linear state-space model per axis,
``x' = A x + B [u, v]``, ``i = C x`` (``v`` the axis' velocity from ``axis_velocity``, held over each
sub-step), solved
exactly by the simulator for the held input.
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
    build_law,
    resolve_law,
)
from .laws_new import ALL_EFFECTS, NEW_LAWS, EddyDrag

G_STOP_HI = k.g_stop[1]
MU0 = 4e-7 * math.pi
LAMBDA = 2.0 * k.t1  # period of the rig's cogging (seed eq. (9): sin(pi d / t1))
K_POLE = math.pi / k.tau  # wavenumber of the magnet array's fundamental (period 2 tau)


class _V3:
    """Mixin: marks a law of the third set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v3"``)."""
        return {**super().describe(), "law_set": "v3"}  # type: ignore[misc]


# ----------------------------------------------------------------------------- cogging
class CoggingV3(_V3, Cogging):
    """Cogging as the gradient of a co-energy ``W(g, d)``: a conservative force with normal and tangential parts.

    ``W = (lambda / 2 pi) sum_k A_k(g) (S_k / k) cos(2 pi k (d - d0) / lambda)``; ``F_d = -dW/dd``,
    ``F_g = -dW/dg`` (``lambda = 2 t1``, the period of seed eq. (9)).

    * ``energy_slot`` -- slot-opening permeance: Zhu & Howe, "Instantaneous magnetic field distribution in
      brushless permanent magnet DC motors, Part III: Effect of stator slotting", IEEE Trans. Magn.
      29(1), 1993: the depth of the permeance dip of a slot opening ``b0`` at gap ``g`` is
      ``beta(g) = (1 - 1/sqrt(1 + (b0 / 2 g)^2)) / 2``; the magnet's gap flux from its magnetic circuit
      ``B ~ hm / (hm + g)`` (Furlani, "Permanent Magnet and Electromechanical Devices", Academic Press
      2001, the magnet's load line). ``A_k = xi0 beta(g) B(g)^2 / (beta B^2)(g_ref)`` for every harmonic, and the
      spectrum of a slot opening ``alpha_s = b0 / lambda`` under a magnet of width ``alpha_m`` (mod the
      period): ``S_k = sin(k pi alpha_s) sin(k pi alpha_m) / k`` (Zhu & Howe, IEEE Trans. Magn. 28(2), 1992; Li &
      Slemon, "Reduction of cogging torque in permanent magnet motors", IEEE Trans. Magn. 24(6), 1988),
      normalized to ``sum |S_k| = 1``, k = 1..4.
    * ``step_skew`` -- magnets skewed in ``M`` steps of ``s lambda / M`` (Islam, Mir & Sebastian, "Issues
      in reducing the cogging torque of mass-produced permanent-magnet brushless DC motor", IEEE
      Trans. Ind. Appl. 40(3), 2004): ``K_k = sin(k pi s) / (M sin(k pi s / M))``;
      ``S_k = c_k K_k``; each harmonic decays as the Laplace solution between two iron surfaces,
      ``A_k = xi0 sinh(2 pi k g_ref / lambda) / sinh(2 pi k g / lambda)``, k = 1..3.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("energy_slot", "step_skew")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "energy_slot": {"xi0": 3.0, "b0": 4e-3, "hm": 5e-3, "alpha_m": 0.3, "d0": 0.0, "replace": 0.0},
        "step_skew": {
            "xi0": 3.0,
            "M": 3.0,
            "skew": 0.5,
            "c1": 1.0,
            "c2": 0.5,
            "c3": 0.3,
            "phi2": 0.0,
            "phi3": 0.0,
            "replace": 0.0,
        },
    }

    @staticmethod
    def carter_beta(g, b0):
        """Depth of the slot-opening permeance dip (Zhu & Howe 1993)."""
        r = b0 / (2.0 * np.asarray(g, dtype=float))
        return 0.5 * (1.0 - 1.0 / np.sqrt(1.0 + r * r))

    def spectrum(self) -> np.ndarray:
        """``S_k`` of the family (k = 1..), as in the class docstring."""
        p = self.p
        if self.family == "energy_slot":
            kk = np.arange(1, 5)
            s = np.sin(kk * math.pi * p["b0"] / LAMBDA) * np.sin(kk * math.pi * p["alpha_m"]) / kk
            return s / max(np.sum(np.abs(s)), 1e-12)
        M, sk = p["M"], p["skew"]
        out = []
        for j in (1, 2, 3):
            x = j * math.pi * sk
            ksk = 1.0 if abs(x) < 1e-12 else math.sin(x) / (M * math.sin(x / M))
            out.append(p[f"c{j}"] * ksk)
        return np.array(out)

    def amplitude(self, g, j: int):
        """``(A_j(g), dA_j/dg)`` of harmonic ``j`` [N, N/m]."""
        p = self.p
        g = np.asarray(g, dtype=float)
        if self.family == "energy_slot":
            b0, hm, gr = p["b0"], p["hm"], k.g_cog_ref
            beta, r = self.carter_beta(g, b0), b0 / (2.0 * g)
            bsq = (hm / (hm + g)) ** 2
            norm = self.carter_beta(gr, b0) * (hm / (hm + gr)) ** 2
            dbeta = -0.5 * r * r / g * (1.0 + r * r) ** -1.5
            dbsq = -2.0 * hm * hm / (hm + g) ** 3
            return p["xi0"] * beta * bsq / norm, p["xi0"] * (dbeta * bsq + beta * dbsq) / norm
        q = 2 * math.pi * j / LAMBDA
        a = p["xi0"] * math.sinh(q * k.g_cog_ref) / np.sinh(q * g)
        return a, -a * q / np.tanh(q * g)

    def force(self, g, gd, d, dd):
        """``(F_g, F_d) = -grad W`` [N] (``F_g > 0`` opens the gap)."""
        p = self.p
        S = self.spectrum()
        fg = 0.0 * np.asarray(g, dtype=float)
        fd = 0.0 * fg
        for j, s in enumerate(S, start=1):
            if s == 0.0:
                continue
            A, dA = self.amplitude(g, j)
            if self.family == "energy_slot":
                arg = 2 * math.pi * j * (d - p["d0"]) / LAMBDA
            else:
                arg = 2 * math.pi * j * d / LAMBDA + (p[f"phi{j}"] if j > 1 else 0.0)
            fd = fd + A * s * np.sin(arg)
            fg = fg - LAMBDA / (2 * math.pi) * dA * (s / j) * np.cos(arg)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV3(_V3, Friction):
    """Presliding friction laws with a true stiction regime and rate-independent memory.

    * ``elastoplastic`` -- Dupont, Hayward, Armstrong & Altpeter, "Single state elastoplastic friction
      models", IEEE Trans. Autom. Control 47(5), 2002: ``dz/dt = v (1 - alpha(z, v) z /
      z_ss(v))``, ``z_ss = s(v) sgn(v) / sigma0`` with the Stribeck curve ``s(v) = Fc + Fs exp(-(v/vs)^2)``;
      ``alpha = 0`` for ``|z| <= z_ba`` (purely elastic: no drift under small oscillation) or for
      ``z`` and ``v`` of opposite signs, ``alpha = 1`` at ``|z| >= |z_ss|``, and
      ``(1 + sin(pi (|z| - (|z_ss| + z_ba)/2) / (|z_ss| - z_ba))) / 2`` between, ``z_ba = r_ba |z_ss|``.
      ``F = -(sigma0 z + sigma1 dz/dt + b v)``.
    * ``bliman_sorine`` -- Bliman & Sorine, "Easy-to-use realistic dry friction models for automatic
      control", Proc. 3rd European Control Conf., Rome, 1995: a second-order linear system in
      the travelled path ``s`` (rate independent), ``dx1/ds = -(x1 - f1 sgn v) / (eta eps)``, ``dx2/ds =
      -(x2 + f2 sgn v) / eps``, ``F = -(x1 + x2 + b v)``; steady sliding gives ``Fc = f1 - f2`` and a
      start-up peak close to ``f1`` after ``~ eta eps`` of travel (the Stribeck effect in space).
    """

    families = ("elastoplastic", "bliman_sorine")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "elastoplastic": {
            "Fc_g": 0.2,
            "Fc_d": 0.2,
            "Fs_g": 0.1,
            "Fs_d": 0.1,
            "vs": 5e-3,
            "sigma0": 3e4,
            "sigma1": 0.0,
            "r_ba": 0.5,
            "b_g": 0.5,
            "b_d": 0.5,
        },
        "bliman_sorine": {
            "f1_g": 0.4,
            "f1_d": 0.4,
            "f2_g": 0.2,
            "f2_d": 0.2,
            "eps": 3e-5,
            "eta": 0.1,
            "b_g": 0.5,
            "b_d": 0.5,
        },
    }
    N_SUB = 8  # sub-divisions of a sub-step for the elastoplastic state (alpha frozen over each)

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force, self.has_held = False, True
        self.state = np.zeros((0, 2, 2))

    def reset(self, n_runs: int) -> None:
        """Zero the presliding states per run and axis (``z``; or ``x1, x2``)."""
        self.state = np.zeros((n_runs, 2, 2))

    def alpha(self, z, zss):
        """Dupont et al.'s ``alpha(z, v)`` for the signed steady deflection ``zss`` (sign of ``v``)."""
        a_ss = np.abs(zss)
        zba = self.p["r_ba"] * a_ss
        az = np.abs(z)
        mid = 0.5 * (1.0 + np.sin(math.pi * (az - 0.5 * (a_ss + zba)) / np.maximum(a_ss - zba, 1e-30)))
        a = np.where(az <= zba, 0.0, np.where(az >= a_ss, 1.0, mid))
        return np.where(z * zss > 0, a, 0.0)

    def held(self, gd, dd, h: float):
        """Advance the presliding states over ``h`` at the current velocities; return the held force."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            sgn = np.sign(v)
            if self.family == "bliman_sorine":
                ds = np.abs(v) * h
                x1, x2 = self.state[:, j, 0], self.state[:, j, 1]
                t1, t2 = p[f"f1_{ax}"] * sgn, -p[f"f2_{ax}"] * sgn
                x1 = t1 + (x1 - t1) * np.exp(-ds / (p["eta"] * p["eps"]))
                x2 = t2 + (x2 - t2) * np.exp(-ds / p["eps"])
                self.state[:, j, 0], self.state[:, j, 1] = x1, x2
                out.append(-(x1 + x2 + p[f"b_{ax}"] * v))
                continue
            s = p[f"Fc_{ax}"] + p[f"Fs_{ax}"] * np.exp(-((v / p["vs"]) ** 2))
            zss = s * sgn / p["sigma0"]
            z0 = self.state[:, j, 0].copy()
            z = z0.copy()
            dx = v * h / self.N_SUB
            moving = sgn != 0
            zss_safe = np.where(moving, zss, 1.0)
            for _ in range(self.N_SUB):  # exact for alpha frozen over each part of the path
                a = self.alpha(z, zss_safe) * moving
                kap = a / zss_safe
                lin = np.abs(kap * dx) < 1e-12
                zinf = np.where(lin, 0.0, 1.0 / np.where(lin, 1.0, kap))
                z = np.where(lin, z + dx, zinf + (z - zinf) * np.exp(-kap * dx))
                z = np.where(moving & (z * sgn > np.abs(zss)), zss, z)  # |z| never beyond z_ss
            self.state[:, j, 0] = z
            out.append(-(p["sigma0"] * z + p["sigma1"] * (z - z0) / h + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
class EndEffectV3(_V3, EndEffect):
    """End effects of a short mover with two different ends, the loss depending on the gap as well.

    * ``roters`` -- overhang ``x`` at each end (``x_p = max(0, d - e_p)``, ``x_n = max(0, -d - e_n)``);
      the overhanging part still couples through the fringing path of a pole edge, whose equivalent
      length is Roters' quarter-annulus permeance ``l_f(x, g) = (2 g / pi) ln(1 + pi x / (2 g))`` (Roters,
      "Electromagnetic Devices", Wiley 1941, fringing permeances): ``rho = 1 - sum_ends (x -
      l_f(x, g)) / L`` (``L`` the effective length of the magnet array). Quadratic onset
      ``pi x^2 / (4 g L)``, linear loss ``x / L`` far out or as ``g -> 0``.
    * ``pole_strip`` -- the ``pm`` magnets (width ``w_m = a_m tau``, pitch ``tau``) over a stator strip
      ``[-(L/2 + e_n), L/2 + e_p]``; the field fraction above the strip at height ``g`` is that of a
      2-D strip, ``H(x) = (arctan((S_p - x)/g) + arctan((x + S_n)/g)) / pi`` (Furlani 2001,
      field of a charged strip); each magnet couples with ``H`` averaged over its width (closed form
      through ``F(u) = u arctan u - ln(1 + u^2) / 2``), ``rho = sum_j c_j(d, g) / sum_j c_j(0, g)``:
      a staircase of magnets leaving the stator, smoothed over ``~ g``.

    Both keep :class:`.laws.EndEffect`'s pole-pitch thrust ripple.
    """

    families = ("roters", "pole_strip")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "roters": {**EndEffect._ripple, "e_p": 0.02, "e_n": 0.03, "L": 0.2},
        "pole_strip": {**EndEffect._ripple, "e_p": 0.015, "e_n": 0.03, "a_m": 0.8},
    }

    @staticmethod
    def fringe_length(x, g):
        """Roters' equivalent length of the fringing path of an overhang ``x`` at gap ``g`` [m]."""
        g = np.asarray(g, dtype=float)
        return 2 * g / math.pi * np.log1p(math.pi * np.asarray(x) / (2 * g))

    def _coupling(self, d, g):
        p = self.p
        L = k.pm * k.tau
        Sp, Sn, w = L / 2 + p["e_p"], L / 2 + p["e_n"], p["a_m"] * k.tau

        def F(u):
            return u * np.arctan(u) - 0.5 * np.log1p(u * u)

        tot = 0.0
        for j in range(k.pm):
            xc = d + (j - (k.pm - 1) / 2) * k.tau
            a, b = xc - w / 2, xc + w / 2
            # integral over [a, b] of arctan((Sp - x)/g) + arctan((x + Sn)/g), divided by pi w
            i1 = -g * (F((Sp - b) / g) - F((Sp - a) / g))
            i2 = g * (F((b + Sn) / g) - F((a + Sn) / g))
            tot = tot + (i1 + i2) / (math.pi * w)
        return tot

    def rho_g(self, d, g):
        """Fraction of the magnetic force left at ``(d, g)``."""
        p = self.p
        d, g = np.asarray(d, dtype=float), np.asarray(g, dtype=float)
        if self.family == "roters":
            xp, xn = np.maximum(d - p["e_p"], 0.0), np.maximum(-d - p["e_n"], 0.0)
            lost = xp - self.fringe_length(xp, g) + xn - self.fringe_length(xn, g)
            return 1.0 - lost / p["L"]
        return self._coupling(d, g) / self._coupling(0.0 * d, g)

    def rho(self, d):
        """Fraction left at ``d`` at the reference gap (for reports; the rig uses :meth:`rho_g`)."""
        return self.rho_g(d, k.g_cog_ref + 0.0 * np.asarray(d, dtype=float))

    def factors(self, g, d, f: list) -> None:
        """Scale every term by ``rho(d, g)`` and the thrust by the ripple."""
        f[2] = f[2] * self.rho_g(d, g)
        f[3] = f[3] * self.ripple(d)


# --------------------------------------------------------------------------- saturation
class SaturationV3(_V3, Saturation):
    """Saturation from the magnetic circuit of the PM and the iron.

    * ``brauer`` -- the iron's reluctivity ``nu(B) = k1 exp(k2 B^2) + k3`` (Brauer, "Simple equations for
      the magnetization and reluctivity curves of steel", IEEE Trans. Magn. 11(1), 1975, p. 81) in
      series with the gap. In units where the linear circuit carries ``u = 1`` at the lower stop, the
      flux solves ``u g / g_lo + s u (exp(kappa u^2) - 1) = 1`` (``s``: the iron path's share of the
      reluctance times ``k1``; ``kappa``: ``k2 B_ref^2``); the factor is the ratio to the linear flux
      ``g_lo / g``, normalized to 1 at the upper stop.
    * ``tanh`` -- hyperbolic-tangent anhysteretic curve ``M = Ms tanh(H / a)`` (Takacs, "A
      phenomenological mathematical model of hysteresis", COMPEL 20(4), 2001) driven by the
      magnet circuit's flux ``x = (hm + g_lo) / (hm + g)`` (Furlani 2001, the load line): the ratio to the
      linear law is ``tanh(a x) / (a x)``, normalized to 1 at the upper stop.

    ``target`` as in :class:`.laws.Saturation`.
    """

    families = ("brauer", "tanh")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "brauer": {"s": 0.1, "kappa": 2.0, "target": "magnet"},
        "tanh": {"a": 1.2, "hm": 5e-3, "target": "both"},
    }

    def flux(self, g):
        """Brauer circuit: the flux ``u`` solving ``u g/g_lo + s u (exp(kappa u^2) - 1) = 1`` (Newton)."""
        p = self.p
        r = np.asarray(g, dtype=float) / G_STOP_LO
        u = 1.0 / r  # the linear solution, an upper bound: Newton from above converges monotonically
        for _ in range(60):
            e = np.exp(p["kappa"] * u * u)
            fval = u * r + p["s"] * u * (e - 1.0) - 1.0
            dfu = r + p["s"] * (e - 1.0 + 2.0 * p["kappa"] * u * u * e)
            step = fval / dfu
            u = u - step
            if np.all(np.abs(step) < 1e-15):
                break
        return u

    def loss(self, g):
        """Fraction of the saturating field lost at gap ``g``."""
        p = self.p
        g = np.asarray(g, dtype=float)
        if self.family == "brauer":
            f = self.flux(g) * g / G_STOP_LO
            f_hi = self.flux(G_STOP_HI) * G_STOP_HI / G_STOP_LO
        else:

            def lr(y):
                return np.tanh(y) / y

            x, x_hi = (p["hm"] + G_STOP_LO) / (p["hm"] + g), (p["hm"] + G_STOP_LO) / (p["hm"] + G_STOP_HI)
            f, f_hi = lr(p["a"] * x), lr(p["a"] * x_hi)
        return 1.0 - f / f_hi


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV3(_V3, AmplifierLag):
    """Current amplifiers as linear state-space models, solved exactly per sub-step.

    * ``butterworth3`` -- a third-order Butterworth current response (Butterworth, "On the theory of
      filter amplifiers", Experimental Wireless 7, 1930): ``wc^3 / (s^3 + 2 wc s^2 + 2 wc^2 s + wc^3)``,
      plus a fractional transport delay ``delay_samples``; group delay at zero frequency ``2 / wc``.
    * ``pi_backemf`` -- a PI current loop on the winding ``R, L`` tuned by pole-zero cancellation
      (``Kp = wc L``, ``Ki = wc R``; Harnefors & Nee, "Model-based current control of AC machines using the
      internal model control method", IEEE Trans. Ind. Appl. 34(1), 1998), with the motional
      back-EMF ``ke v`` of each axis as a disturbance: ``L di/dt = -R i + Kp (u - i) + Ki q - ke v``,
      ``dq/dt = u - i``. The command reaches the current as ``wc / (s + wc)``; the back-EMF leaves an
      error ``-ke s v / ((L s + R)(s + wc))`` (an apparent mass ``ke Kf / (R wc)`` at low frequency).
      The thrust current (``i_q``) sees the horizontal speed, the levitation current (``i_d``) the gap
      speed, each signed as the force its current makes (:meth:`axis_velocity`), so that the back-EMF
      takes the power ``e i = F v`` out of the circuit (passive). Neither a slew-rate nor a voltage limit
      is modelled (the loop stays linear).
    """

    families = ("butterworth3", "pi_backemf")
    lti: ClassVar[bool] = True
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "butterworth3": {"bandwidth_hz": 400.0, "delay_samples": 0.5},
        "pi_backemf": {"bandwidth_hz": 300.0, "R": 2.0, "L": 10e-3, "ke_q": 15.0, "ke_d": 30.0, "delay_samples": 0.0},
    }

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` of axis ``axis`` (0: i_q, 1: i_d); inputs ``[u, v]``."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "butterworth3":
            A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(wc**3), -2 * wc**2, -2 * wc]])
            B = np.array([[0.0, 0.0], [0.0, 0.0], [wc**3, 0.0]])
            return A, B, np.array([1.0, 0.0, 0.0])
        R, L = p["R"], p["L"]
        Kp, Ki = wc * L, wc * R
        ke = p["ke_q"] if axis == 0 else p["ke_d"]
        A = np.array([[-(R + Kp) / L, Ki / L], [-1.0, 0.0]])
        B = np.array([[Kp / L, -ke / L], [1.0, 0.0]])
        return A, B, np.array([1.0, 0.0])

    def discrete(self, axis: int, tau: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)``: the exact map ``x(tau) = Ad x(0) + Bd [u, v]`` for inputs held over ``tau``."""
        from scipy.linalg import expm

        A, B, _ = self.ss(axis)
        n, m = B.shape
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        E = expm(M * tau)
        return E[:n, :n], E[:n, n:]

    def equilibrium(self, u) -> np.ndarray:
        """States ``(n_runs, 2, n)`` at rest carrying the currents ``u`` (n_runs, 2)."""
        out = []
        for ax in (0, 1):
            A, B, _ = self.ss(ax)
            x1 = -np.linalg.solve(A, B[:, 0])  # state per unit current at rest
            out.append(np.asarray(u)[:, ax, None] * x1[None, :])
        return np.stack(out, axis=1)

    def output(self, Z) -> np.ndarray:
        """Delivered currents ``(n_runs, 2)`` of the states ``Z``."""
        return np.stack([Z[:, ax, :] @ self.ss(ax)[2] for ax in (0, 1)], axis=1)

    @staticmethod
    def axis_velocity(X):
        """Velocity input of each axis ``(n_runs, 2)``: along the force its current makes.

        In seed eq. (2) ``i_q`` pushes the mover towards ``-d`` (``d_ddot = -C1 f1 i_q``) and ``i_d`` opens
        the gap (``g_ddot = C3 f3 i_d - ...``), so the motional EMFs are ``ke_q (-d_dot)`` and ``ke_d g_dot``.
        """
        return np.column_stack([-X[..., 3], X[..., 1]])

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        wc = 2 * math.pi * self.p["bandwidth_hz"]
        lag = 2.0 / wc if self.family == "butterworth3" else 1.0 / wc
        return self.p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
class CommutationV3(_V3, CommutationOffset):
    """Commutation angle errors from the commutation sensor's timing or placement.

    * ``latency`` -- the angle used by the inverse Park transform is that of the position sampled
      ``t_lat`` earlier (computation and PWM update delay): ``delta = delta0 + (pi / tau) d_dot t_lat``
      (Bae & Sul, "A compensation method for time delay of full-digital synchronous frame current
      regulator of PWM AC drives", IEEE Trans. Ind. Appl. 39(3), 2003: the angle error
      ``omega_e 1.5 Ts`` of a digital drive).
    * ``hall_interp`` -- commutation from three Hall sensors, whose edges (every 60 electrical degrees)
      are misplaced by ``eps_j`` and between which the angle is interpolated linearly (Kim, Choi, Lee &
      Lee, "An improved rotor position estimation with vector-tracking observer in PMSM drives with
      low-resolution Hall-effect sensors", IEEE Trans. Ind. Electron. 58(9), 2011): a
      piecewise-linear periodic error of period ``2 tau`` through the six edge errors (each sensor
      gives a rising and a falling edge, 180 degrees apart, with the same misplacement).
    """

    families = ("latency", "hall_interp")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "latency": {"delta0": 0.02, "t_lat": 1.5e-3},
        "hall_interp": {"delta0": 0.0, "eps1": 0.05, "eps2": -0.03, "eps3": 0.02, "x0": 0.0},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_rotate = self.family == "hall_interp"
        self.has_rotate_at = self.family == "latency"

    def edge_errors(self) -> np.ndarray:
        """Angle errors at the six Hall edges (0, 60, ..., 300 electrical degrees) [rad]."""
        p = self.p
        e = [p["eps1"], p["eps2"], p["eps3"]]
        return np.array([e[0], e[2], e[1], e[0], e[2], e[1]]) + p["delta0"]  # sensors at 0, 120, 240 deg

    def angle(self, d, dd=0.0):
        """Electrical angle error at position ``d`` (and speed ``dd`` for ``latency``)."""
        p = self.p
        if self.family == "latency":
            return p["delta0"] + math.pi / k.tau * np.asarray(dd) * p["t_lat"]
        theta = np.mod(math.pi * (np.asarray(d, dtype=float) - p["x0"]) / k.tau, 2 * math.pi)
        e = self.edge_errors()
        nodes = np.arange(7) * math.pi / 3
        return np.interp(theta, nodes, np.append(e, e[0]))

    def rotate(self, i_q, i_d, d):
        """Rotate the dq currents by ``delta(d)`` (Hall interpolation)."""
        return _rot(i_q, i_d, self.angle(d))

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by ``delta(d_dot)`` (latency)."""
        return _rot(i_q, i_d, self.angle(X[..., 2], X[..., 3]))


def _rot(i_q, i_d, a):
    c, s = np.cos(a), np.sin(a)
    return c * i_q - s * i_d, s * i_q + c * i_d


# --------------------------------------------------------------------------- eddy drag
class EddyDragV3(_V3, EddyDrag):
    """Eddy-current and iron-loss drag of the magnet array moving over the stator.

    * ``thick_plate`` -- a conducting plate of thickness ``T`` and conductivity ``sigma`` under the
      array's fundamental (wavenumber ``k = pi / tau``) moving at ``v``: with ``gamma^2 = k^2 + i mu0 sigma
      k v`` the reflection coefficient is ``R = -(gamma^2 - k^2) th / (2 k gamma + (k^2 + gamma^2) th)``,
      ``th = tanh(gamma T)`` (the skin depth enters through ``gamma``; Paudel & Bird, "General 2-D
      steady-state force and power equations for a traveling time-varying magnetic source above a
      conductive plate", IEEE Trans. Magn. 48(1), 2012; thin-plate limit ``-i(v/w) / (1
      + i v/w)``, ``w = 2 / (mu0 sigma T)``, of Reitz, J. Appl. Phys. 41(5), 1970). Lift ``F0 Re(-R)``
      (opens the gap) and drag ``F0 Im(-R)``; ``F0 = F00 exp(-2 k (g - g_ref))``.
    * ``iron_loss`` -- loss separation of the stator iron (Bertotti, "General properties of power losses
      in soft ferromagnetic materials", IEEE Trans. Magn. 24(1), 1988): classical eddy loss
      ``~ f^2 B^2`` and excess loss ``~ f^1.5 B^1.5`` at ``f = |v| / (2 tau)`` give drags ``P / v``:
      ``F_d = -(c_cl b^2 v + c_ex b^1.5 sgn(v) |v|^0.5)`` with ``b = (hm + g_ref) / (hm + g)`` the
      iron flux density relative to the reference gap (magnet circuit). ``|v|^0.5`` is regularized as
      ``v / (v^2 + v0^2)^(1/4)``. (Bertotti's hysteresis term, a Coulomb-like drag, is left out.)
    """

    families = ("thick_plate", "iron_loss")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "thick_plate": {"F00": 100.0, "T": 3e-3, "sigma": 3.5e7},
        "iron_loss": {"c_cl": 3.0, "c_ex": 0.6, "hm": 5e-3, "v0": 1e-3},
    }

    def reflection(self, v):
        """``-R`` of the plate at speed ``v`` (complex; real part lift, imaginary part drag fraction)."""
        p = self.p
        kk = K_POLE
        v = np.asarray(v, dtype=float)
        gam = np.sqrt(kk * kk + 1j * MU0 * p["sigma"] * kk * v + 0j)
        th = np.tanh(gam * p["T"])
        return (gam * gam - kk * kk) * th / (2 * kk * gam + (kk * kk + gam * gam) * th)

    def force(self, g, gd, d, dd):
        """Eddy forces ``(F_g, F_d)`` [N] at horizontal speed ``dd``."""
        p = self.p
        g, dd = np.asarray(g, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "thick_plate":
            F0 = p["F00"] * np.exp(-2 * K_POLE * (g - k.g_cog_ref))
            mr = self.reflection(dd)
            return F0 * mr.real, -F0 * mr.imag
        b = (p["hm"] + k.g_cog_ref) / (p["hm"] + g)
        sq = dd / (dd * dd + p["v0"] ** 2) ** 0.25
        return 0.0 * dd, -(p["c_cl"] * b * b * dd + p["c_ex"] * b**1.5 * sq)


# --------------------------------------------------------------------- out of the library
class SteelPreload(_V3, Law):
    """A soft-steel part near the stroke (a bracket, a screw head): the magnets attract it (not in the library).

    A soft-magnetic body of volume ``V`` in the field ``B`` of a dipole-like source has the energy
    ``U = -V chi B^2 / (2 mu0)`` (Furlani, "Permanent Magnet and Electromechanical Devices", Academic
    Press 2001: the force on a magnetizable particle ``F = (V chi / mu0) (B . grad) B``); with
    ``B ~ 1/r^3``, ``U = -U0 (r0 / r)^6`` and ``F = -grad U`` (central, attractive, ``|F| ~ 1/r^7``).
    The part is at ``d = x_s`` and ``z_s`` beyond the gap's zero (``r^2 = (d - x_s)^2 + (g + z_s)^2``), so
    it pulls the mover along d towards ``x_s`` and closes the gap. ``F_pk`` is the pull at ``d = x_s``,
    ``g = g_ref``.
    """

    name = "steel_preload"
    library = False
    families = ("dipole",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"dipole": {"F_pk": 1.0, "x_s": 0.03, "z_s": 0.02}}
    has_force = True

    def force(self, g, gd, d, dd):
        """Pull of the part ``(F_g, F_d)`` [N]."""
        p = self.p
        r_ref = p["z_s"] + k.g_cog_ref
        ex, ez = np.asarray(d) - p["x_s"], np.asarray(g) + p["z_s"]
        r = np.sqrt(ex * ex + ez * ez)
        mag = p["F_pk"] * (r_ref / r) ** 7  # |dU/dr| = 6 U0 r0^6 / r^7, scaled to F_pk at r_ref
        return -mag * ez / r, -mag * ex / r


class GapSensorDrift(_V3, Law):
    """Gap sensor with a residual bow and a warm-up drift (not in the library).

    An inductive / eddy-current gap probe responds as ``1 / (g + c)`` (the reluctance of its magnetic
    path) and is linearized over the gap band; what is left is a bow, here scaled to ``n_l`` of the
    span at its peak, ``e(g) = n_l span (lin(g) - y(g)) / max|lin - y|`` with ``y = 1/(g + c)`` and
    ``lin`` its chord between the stops (Fleming, "A review of nanometer resolution position sensors:
    operation and performance", Sens. Actuators A 190, 2013 (inductive and eddy-current sensors:
    nonlinearity and temperature sensitivity)). The probe's offset drifts with its
    temperature, ``tc dT(t)``, ``dT = rise (1 - exp(-t / tau_th))`` over the dataset's time
    (Bryan, "International status of thermal error research", CIRP Annals 39(2), 1990).
    """

    name = "gap_sensor_drift"
    library = False
    families = ("bow_warmup",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "bow_warmup": {"n_l": 2e-3, "c": 0.02, "tc": 1e-6, "rise": 15.0, "tau_th": 30.0}
    }
    has_read_at = True

    def bow(self, g):
        """Residual nonlinearity ``e(g)`` [m]."""
        p = self.p
        lo, hi = G_STOP_LO, G_STOP_HI

        def y(x):
            return 1.0 / (np.asarray(x, dtype=float) + p["c"])

        def raw(x):
            return (y(lo) + (y(hi) - y(lo)) * (np.asarray(x) - lo) / (hi - lo)) - y(x)

        # the chord's largest deviation: where y' equals the chord's slope
        slope = (y(hi) - y(lo)) / (hi - lo)
        x_pk = math.sqrt(-1.0 / slope) - p["c"]
        return p["n_l"] * (hi - lo) * raw(g) / abs(float(raw(x_pk)))

    def drift(self, t):
        """Offset of the warm-up at dataset time ``t`` [m]."""
        p = self.p
        return p["tc"] * p["rise"] * (1.0 - np.exp(-np.asarray(t, dtype=float) / p["tau_th"]))

    def read_at(self, g, d, t):
        """Readings for the true ``(g, d)`` at dataset time ``t``."""
        return np.asarray(g) + self.bow(g) + self.drift(t), d


#: The third set: one class per effect (library families and new effects), by effect name.
V3_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV3,
        FrictionV3,
        EndEffectV3,
        SaturationV3,
        AmplifierV3,
        CommutationV3,
        EddyDragV3,
        SteelPreload,
        GapSensorDrift,
    )
}
#: Every effect name in the order the simulator applies them (old and new ones first, as before).
EFFECTS_V3: tuple[str, ...] = tuple(ALL_EFFECTS) + tuple(n for n in V3_LAWS if n not in ALL_EFFECTS)
V3_LIBRARY: tuple[str, ...] = tuple(n for n, c in V3_LAWS.items() if c.library)
V3_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V3_LAWS.items() if not c.library)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, then :mod:`.laws_new`, then v3)."""
    return resolve_law(name, family, (LAWS, NEW_LAWS, V3_LAWS), EFFECTS_V3)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, (LAWS, NEW_LAWS, V3_LAWS), EFFECTS_V3)


__all__ = [
    "EFFECTS_V3",
    "V3_LAWS",
    "V3_LIBRARY",
    "V3_OUT_OF_LIBRARY",
    "AmplifierV3",
    "CoggingV3",
    "CommutationV3",
    "EddyDragV3",
    "EndEffectV3",
    "FrictionV3",
    "GapSensorDrift",
    "SaturationV3",
    "SteelPreload",
    "law_class",
    "make_law",
]
