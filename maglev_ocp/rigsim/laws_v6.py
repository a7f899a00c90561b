"""A sixth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v6"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3`, :mod:`.laws_v4` and
:mod:`.laws_v5` has, and two effects outside the library (in :mod:`.laws_v6_ool`), for the next pre-registered
blind check. They were written from their sources only, without reading the diagnosis or how it fits; each class
carries ``new_law = True`` and ``law_set = "v6"`` in its truth record. The source of each law (author, title,
venue, year) is in its docstring and in ``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``force``, ``held``, ``rotate_at``, the state-space
amplifier); no hook was added. Laws whose force comes from a state the truth record cannot recompute
from the recorded trajectory record their own size while simulated (:meth:`recorded`, as in :mod:`.laws_v4`).
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
from .laws_v4 import K_POLE, V4_LAWS, field_ratio
from .laws_v5 import EFFECTS_V5, V5_LAWS
from .laws_v6_ool import _V6, L_ARRAY, PhaseCurrentSensor, StatorFlatness
from .physics import NOMINAL, shape

G_STOP_HI = k.g_stop[1]


# ----------------------------------------------------------------------------- cogging
def array_field(x, y):
    """``Bz`` of the ``pm`` alternating magnets (width ``taup``, height ``hm``, centred at ``(j - (pm-1)/2) tau``)
    at distance ``y`` above their top face, in units of ``Br / pi`` (2-D surface-charge model: Furlani,
    "Permanent Magnet and Electromechanical Devices", Academic Press 2001, ch. 4, the field of a rectangular
    magnet: ``atan((x + a)/y) - atan((x - a)/y)`` of the top face minus that of the bottom face at ``y + hm``)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    a = 0.5 * k.taup
    out = 0.0 * (x + y)
    for j in range(k.pm):
        u = x - (j - 0.5 * (k.pm - 1)) * k.tau
        face = np.arctan((u + a) / y) - np.arctan((u - a) / y)
        back = np.arctan((u + a) / (y + k.hm)) - np.arctan((u - a) / (y + k.hm))
        out = out + (-1.0) ** j * (face - back)
    return out


class CoggingV6(_V6, Cogging):
    """Cogging as the sum of single-slot forces on the finite magnet array, or over a stator with paired teeth.

    The cogging of a slotted machine is the superposition of the forces between the magnets and each slot opening
    alone (Zhu & Howe, "Influence of design parameters on cogging torque in permanent magnet machines", IEEE Trans.
    Energy Convers. 15(4), 2000: the single-slot method). Each opening ``s`` (centre ``x_s``, width ``b_s``) removes
    the co-energy of the field over it, ``D(d, g) = sum_s int_{slot s} Bz(x - d, g)^2 dx``, with ``Bz`` the exact
    2-D field of the rig's four alternating magnets (:func:`array_field`: their ends included, so the array's ends
    cog too); the force is ``F = -kappa grad D~`` (``D~ = D`` less its mean over a period, whose gap force is
    the mean pull's Carter correction, already in seed eq. (2)), with ``kappa`` set so that the tangential peak
    at ``G_REF = 15 mm`` (the gap band's lower edge: the slot-pitch harmonics decay fast with the gap) is
    ``xi0``. Conservative; the shape and its change with the gap come from the field, not from a fitted series.

    * ``finite_array`` -- identical openings ``b0`` at pitch ``t1`` from ``x0``: the configuration repeats every
      slot pitch, so the cogging's period is ``t1`` (half seed eq. (9)'s ``2 t1``).
    * ``paired_teeth`` -- teeth of two widths alternating (teeth pairing: Bianchi & Bolognani, "Design techniques
      for reducing the cogging torque in surface-mounted PM motors", IEEE Trans. Ind. Appl. 38(5), 2002):
      openings shifted by ``+-delta_p`` and widened / narrowed by ``+-eps_b`` alternately, so the stator repeats
      every ``2 t1`` and the cogging has both periods.

    ``D~`` is tabulated once per law on a (gap, position) grid over one period and evaluated through a bicubic
    spline (its derivatives are the forces, so they stay conservative). With ``replace = 1`` the rig's cogging is
    this law instead of seed eq. (9).
    """

    families = ("finite_array", "paired_teeth")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "finite_array": {"xi0": 2.0, "x0": 0.0, "replace": 0.0},
        "paired_teeth": {"xi0": 2.0, "x0": 0.0, "delta_p": 1.5e-3, "eps_b": 0.2, "replace": 0.0},
    }
    N_GL = 6  #: Gauss-Legendre points across each slot opening
    G_REF = 15e-3  #: gap of the tangential peak ``xi0`` [m]
    G_GRID = (6e-3, 36e-3, 46)  #: tabulated gaps

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.period = k.t1 if self.family == "finite_array" else 2.0 * k.t1
        self._spline = self._table()

    def deficit(self, g, d):
        """``D(d, g)``: the field energy over the slot openings [(Br/pi)^2 m] (before the scale ``kappa``)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        z, w = np.polynomial.legendre.leggauss(self.N_GL)
        reach = 0.5 * L_ARRAY + 0.2  # the array's field is negligible 200 mm past its ends
        n0 = math.floor((-reach - p["x0"]) / k.t1)
        n1 = math.ceil((reach - p["x0"]) / k.t1)
        out = 0.0 * (g + d)
        for n in range(n0, n1 + 1):
            xs, bs = p["x0"] + n * k.t1, k.b0
            if self.family == "paired_teeth":
                sgn = 1.0 if n % 2 == 0 else -1.0
                xs, bs = xs + sgn * p["delta_p"], k.b0 * (1.0 + sgn * p["eps_b"])
            for zi, wi in zip(z, w, strict=True):
                out = out + 0.5 * bs * wi * array_field(xs + 0.5 * bs * zi - d, g) ** 2
        return out

    def _table(self):
        from scipy.interpolate import RectBivariateSpline

        gg = np.linspace(*self.G_GRID)
        n = 48
        dd = np.arange(-n // 2, 3 * n // 2 + 1) * (self.period / n)  # one period and half a period each side
        D = self.deficit(gg[:, None], dd[None, :])
        D = D - D[:, n // 2 : n // 2 + n].mean(axis=1, keepdims=True)
        spl = RectBivariateSpline(gg, dd, D)
        # kappa: the tangential peak at G_REF is xi0
        x = np.linspace(0.0, self.period, 400)
        peak = float(np.max(np.abs(spl.ev(0 * x + self.G_REF, x, dy=1))))
        self.kappa = self.p["xi0"] / peak
        return spl

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N] (``F_g > 0`` opens the gap)."""
        g = np.clip(np.asarray(g, dtype=float), self.G_GRID[0], self.G_GRID[1])
        u = np.mod(np.asarray(d, dtype=float), self.period) + 0.0 * g
        g = g + 0.0 * u
        shp = u.shape
        fg = -self.kappa * self._spline.ev(g.ravel(), u.ravel(), dx=1).reshape(shp)
        fd = -self.kappa * self._spline.ev(g.ravel(), u.ravel(), dy=1).reshape(shp)
        return fg, fd


# ---------------------------------------------------------------------------- friction
class FrictionV6(_V6, Friction):
    """Friction that varies along the rail, or the reset-integrator law with a stiction drop.

    * ``rail_position`` -- the friction of a guide depends on the position along it (Armstrong-Helouvry, "Control
      of Machines with Friction", Kluwer 1991, position-dependent friction; Olsson, Astrom, Canudas de Wit,
      Gafvert & Lischinsky, "Friction models and friction compensation", Eur. J. Control 4(3), 1998, sec. 2): the
      preload of the carriage's balls fluctuates with their passage (period ``p_b``: the balls move at half the
      carriage's speed) and with the rail's straightness (period ``p_r``), ``Fc(d) = Fc (1 + a_b cos(2 pi d / p_b
      + ph_b) + a_r cos(2 pi d / p_r + ph_r))``, the same profile on both guides (they ride on the same rail);
      ``F = -(Fc_ax(d) tanh(v / v_reg) + b_ax v)``.
    * ``reset_integrator`` -- Haessig & Friedland, "On the modeling and simulation of friction", ASME J. Dyn. Syst.
      Meas. Control 113(3), 1991: a bristle deflection ``z`` that integrates the displacement and stops at ``+-z0``
      (``dz/dt = v`` unless ``|z| = z0`` and ``v`` pushes further), ``F = -(sigma0 z (1 + a [|z| < z0]) + b v)``,
      ``sigma0 = Fc / z0``: linear-elastic presliding up to a breakaway ``(1 + a) Fc``, then a drop to the sliding
      level ``Fc`` (advanced exactly per sub-step: ``z <- clip(z + v h, -z0, z0)``).
    """

    families = ("rail_position", "reset_integrator")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "rail_position": {
            "Fc_g": 0.2,
            "Fc_d": 0.2,
            "a_b": 0.2,
            "p_b": 8e-3,
            "ph_b": 0.0,
            "a_r": 0.2,
            "p_r": 0.08,
            "ph_r": 0.0,
            "b_g": 0.5,
            "b_d": 0.5,
            "v_reg": 1e-3,
        },
        "reset_integrator": {"Fc_g": 0.2, "Fc_d": 0.2, "z0": 1e-5, "a": 0.5, "b_g": 0.5, "b_d": 0.5},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = self.family == "rail_position"
        self.has_held = not self.has_force
        self.state = np.zeros((0, 2))

    def reset(self, n_runs: int) -> None:
        """Bristles relaxed (``z = 0``) per run and axis."""
        self.state = np.zeros((n_runs, 2))

    def profile(self, d):
        """``Fc(d) / Fc``: the relative friction level along the rail."""
        p = self.p
        d = np.asarray(d, dtype=float)
        return (
            1.0
            + p["a_b"] * np.cos(2 * math.pi * d / p["p_b"] + p["ph_b"])
            + p["a_r"] * np.cos(2 * math.pi * d / p["p_r"] + p["ph_r"])
        )

    def force(self, g, gd, d, dd):
        """Position-dependent friction on both axes [N]."""
        p = self.p
        prof = self.profile(d)
        out = []
        for v, ax in ((gd, "g"), (dd, "d")):
            v = np.asarray(v, dtype=float)
            out.append(-(p[f"Fc_{ax}"] * prof * np.tanh(v / p["v_reg"]) + p[f"b_{ax}"] * v))
        return out[0], out[1]

    def held(self, gd, dd, h: float):
        """Advance the bristles over ``h`` at the current velocities; return the held friction."""
        p = self.p
        z0 = p["z0"]
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            v = np.asarray(v, dtype=float)
            z = np.clip(self.state[:, j] + v * h, -z0, z0)
            self.state[:, j] = z
            stuck = np.abs(z) < z0 * (1.0 - 1e-12)
            out.append(-(p[f"Fc_{ax}"] / z0 * z * (1.0 + p["a"] * stuck) + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
def carter_width(w, g):
    """Width [m] an opening ``w`` takes off the gap's permeance at gap ``g``: ``gamma g``, ``gamma = (4/pi) (r
    atan r - ln sqrt(1 + r^2))``, ``r = w / 2g`` (Carter, "Note on air-gap and interpolar induction", J. IEE 29,
    1900)."""
    g = np.asarray(g, dtype=float)
    r = w / (2.0 * g)
    return (4.0 / math.pi) * (r * np.arctan(r) - 0.5 * np.log1p(r * r)) * g


def _sq_int(u):
    """``int_0^u sin^2(K u') du'`` (``K = pi / tau``)."""
    return 0.5 * u - np.sin(2 * K_POLE * u) / (4 * K_POLE)


_WPM: dict[str, np.ndarray] = {}


def pm_coenergy(g):
    """``W_pm(g) = int_g^inf P(g') dg'`` [J]: the co-energy of the magnets' pull ``P = Mv C2 f2`` (seed eq. (2),
    nominal constants), tabulated once (trapezoid rule, 0.1 mm steps up to 250 mm)."""
    if not _WPM:
        gg = np.linspace(4e-3, 0.25, 2461)
        P = NOMINAL.Mv * NOMINAL.C2 * shape(gg).f2
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(gg))])
        _WPM.update(g=gg, W=cum[-1] - cum)
    return np.interp(np.asarray(g, dtype=float), _WPM["g"], _WPM["W"])


def _overlap(x, s):
    """Overlap ``max(x, 0)`` smoothed over the fringe ``s`` (``s ln(1 + e^{x/s})``)."""
    return s * np.logaddexp(0.0, np.asarray(x, dtype=float) / s)


def yoke_flux(beta, r):
    """Flux ratio ``phi`` (to the linear circuit) through a gap in series with a yoke of Frohlich-Kennelly iron.

    The yoke's reluctance ``r R_g / (1 - Phi / Phi_s)`` (``B = mu H / (1 + mu H / B_s)``: Kennelly, "Magnetic
    reluctance", Trans. AIEE 8, 1891) in series with the gap's ``R_g``: ``(1 + r) = phi (1 + r / (1 - beta
    phi))``, ``beta`` the yoke's flux of the linear circuit over its saturation flux; the smaller root.
    """
    beta = np.maximum(np.asarray(beta, dtype=float), 1e-9)
    a = (1.0 + r) * (1.0 + beta)
    return (a - np.sqrt(a * a - 4.0 * beta * (1.0 + r))) / (2.0 * beta)


class EndEffectV6(_V6, EndEffect):
    """End effects of a stator built of modules: a joint between two modules, or saturating end yokes.

    * ``segment_joint`` -- the stator is two modules with a gap of width ``w_j`` at ``x_j`` inside the stroke (a
      stationary discontinuous primary: Kim, Watada & Dohmeki, "Reduction of the cogging force at the outlet edge
      of a stationary discontinuous primary linear synchronous motor", IEEE Trans. Magn. 43(1), 2007). The joint
      takes Carter's width ``w_e = gamma(w_j / 2g) g`` (:func:`carter_width`) off the permeance under the array,
      weighted by the array's field energy ``sin^2(pi u / tau)`` there: ``rho = 1 - int_{joint} sin^2 / (L / 2)``
      (every magnetic term), and by virtual work on the co-energy ``W_pm(g) rho`` a longitudinal force ``F_d =
      W_pm(g) d rho / dd`` (:func:`pm_coenergy`) pulls the array's strong-field regions off the joint.
    * ``yoke_step`` -- the last ``l_y`` of each stator end has a thinner back yoke (the stack's clamping ends) that
      saturates: over it the magnets' flux falls to ``phi(beta(g))`` of the linear circuit's (:func:`yoke_flux`,
      ``beta = b_lo B(g) / B(g_lo)``, MODEL.md's field) and the pull to ``phi^2``; past the stator's end (``e_p``,
      ``e_n`` beyond the array's ends at ``d = 0``) the pull is lost. ``rho = 1 - sum_ends [(1 - phi^2) o_y + o_x]
      / L`` with the overlaps smoothed over the fringe ``g``: a loss near the stroke's ends that is larger at
      small gaps (Gieras, Piech & Tomczuk, "Linear Synchronous Motors: Transportation and Automation Systems", 2nd
      ed., CRC Press 2011, the flux paths of the PM linear motor's yoke).

    Both keep :class:`.laws.EndEffect`'s pole-pitch thrust ripple.
    """

    families = ("segment_joint", "yoke_step")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "segment_joint": {**EndEffect._ripple, "x_j": 0.0, "w_j": 0.012},
        "yoke_step": {**EndEffect._ripple, "e_p": 0.02, "e_n": 0.03, "l_y": 0.02, "b_lo": 1.0, "r": 0.1},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family == "segment_joint"

    def _joint(self, d, g):
        """``(lost, d lost / du)``: the joint's share of the array's field energy and its slope in ``u = x_j - d``."""
        p = self.p
        u = p["x_j"] - np.asarray(d, dtype=float)
        half = 0.5 * carter_width(p["w_j"], g)
        a = np.clip(u - half, -0.5 * L_ARRAY, 0.5 * L_ARRAY)
        b = np.clip(u + half, -0.5 * L_ARRAY, 0.5 * L_ARRAY)
        ia, ib = np.abs(u - half) < 0.5 * L_ARRAY, np.abs(u + half) < 0.5 * L_ARRAY
        lost = (_sq_int(b) - _sq_int(a)) / (0.5 * L_ARRAY)
        slope = (np.sin(K_POLE * b) ** 2 * ib - np.sin(K_POLE * a) ** 2 * ia) / (0.5 * L_ARRAY)
        return lost, slope

    def rho_g(self, d, g):
        """Fraction of the magnetic force left at ``(d, g)``."""
        p = self.p
        d, g = np.asarray(d, dtype=float), np.asarray(g, dtype=float)
        if self.family == "segment_joint":
            return 1.0 - self._joint(d, g)[0]
        phi = yoke_flux(p["b_lo"] * field_ratio(g, G_STOP_LO), p["r"])
        lost = 0.0 * (d + g)
        for x in (d - p["e_p"], -d - p["e_n"]):  # the array's end past each stator end
            lost = lost + (1.0 - phi * phi) * (_overlap(x + p["l_y"], g) - _overlap(x, g)) + _overlap(x, g)
        return 1.0 - lost / L_ARRAY

    def rho(self, d):
        """Fraction left at ``d`` at the reference gap (for reports; the rig uses :meth:`rho_g`)."""
        return self.rho_g(d, k.g_cog_ref + 0.0 * np.asarray(d, dtype=float))

    def factors(self, g, d, f: list) -> None:
        """Scale every term by ``rho(d, g)`` and the thrust by the ripple."""
        f[2] = f[2] * self.rho_g(d, g)
        f[3] = f[3] * self.ripple(d)

    def force(self, g, gd, d, dd):
        """Longitudinal force of the joint (``segment_joint``) [N]: ``W_pm(g) d rho / dd = W_pm(g) d lost / du``."""
        _, slope = self._joint(d, g)
        fd = pm_coenergy(g) * slope
        return 0.0 * fd, fd


# --------------------------------------------------------------------------- saturation
class SaturationV6(_V6, Saturation):
    """Saturation seen through the arctangent B-H curve's two permeabilities, or tooth by tooth along the stroke.

    * ``incremental_arctan`` -- the iron's curve ``B = (2 B_s / pi) atan(pi mu_i H / (2 B_s))`` (the arctangent
      magnetization curve: Fischer & Moser, "Die Nachbildung von Magnetisierungskurven durch einfache algebraische
      oder transzendente Funktionen", Arch. Elektrotech. 42, 1956), at the flux density ``b = b_lo x(g)`` relative
      to ``B_s`` (``x = B(g) / B(g_lo)``, MODEL.md's field). The magnets' flux sees the *secant* permeability at the
      operating point, ``mu_s / mu_i = (pi b / 2) / tan(pi b / 2)``, the currents' small field the *incremental*
      one around it, ``mu_d / mu_i = cos^2(pi b / 2)`` (bias and control flux of a PM-biased magnetic circuit:
      Schweitzer & Maslen, "Magnetic Bearings", Springer 2009, ch. 2). With the iron's share ``r`` of the linear
      circuit's reluctance: ``km = (1 + r) / (1 + r mu_i / mu_s)`` (``b`` solved self-consistently, ``b = b_lo x
      km``) and ``kc = (1 + r) / (1 + r mu_i / mu_d)``, both 1 at the upper stop: the currents' force falls faster
      than the magnets' as the gap closes.
    * ``tooth_flux`` -- each stator tooth (pitch ``t1``, width ``t1 - b0``, the grid at ``x0``) carries the flux of
      the array's exact field over it (:func:`array_field`; Zhu & Howe, "Instantaneous magnetic field distribution
      in brushless permanent magnet DC motors, Part III: Effect of stator slotting", IEEE Trans. Magn. 29(1), 1993:
      the flux gathers in the teeth), ``b_t = b_lo Phi_t / Phi_ref`` relative to the tooth's knee (``Phi_ref`` the
      largest tooth flux at the lower stop), and saturates on the Frohlich-Kennelly curve ``f(b) = b / (1 + |b|)``
      (Kennelly, "Magnetic reluctance", Trans. AIEE 8, 1891). The magnets' pull follows the teeth's flux squared:
      ``km^2 = sum_t f(b_t)^2 / sum_t b_t^2`` (each tooth's share of the linear law), 1 at the upper stop: a loss
      that depends on where the teeth sit under the poles (period ``t1`` in ``d``) as well as on the gap.
      Tabulated once per law on a (gap, position) grid, bicubic spline.
    """

    families = ("incremental_arctan", "tooth_flux")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "incremental_arctan": {"b_lo": 0.7, "r": 0.15, "target": "both"},
        "tooth_flux": {"b_lo": 0.25, "x0": 0.0, "target": "magnet"},
    }
    N_FIX = 30  #: fixed-point iterations of the self-consistent operating point
    G_GRID = (6e-3, 36e-3, 31)  #: tabulated gaps (``tooth_flux``)

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        want = "both" if self.family == "incremental_arctan" else "magnet"
        if self.p["target"] != want:
            raise ValueError(f"saturation ({self.family}): target must be {want!r}")
        if self.family == "incremental_arctan" and not 0.0 < self.p["b_lo"] < 1.0:
            raise ValueError("saturation (incremental_arctan): b_lo must be in (0, 1) (below saturation)")
        self.has_factors = True
        if self.family == "incremental_arctan":
            self._hi = self._arctan(np.array([G_STOP_HI]))
        else:
            self._spline = self._table()

    def _arctan(self, g):
        """``(km, kc)`` of ``incremental_arctan`` before normalizing."""
        p = self.p
        x = p["b_lo"] * field_ratio(g, G_STOP_LO)
        km = np.ones_like(x)
        for _ in range(self.N_FIX):  # b = b_lo x km: a contraction (km falls as b grows)
            h = 0.5 * math.pi * x * km
            km = (1.0 + p["r"]) / (1.0 + p["r"] * np.tan(h) / np.maximum(h, 1e-12))
        b = x * km
        kc = (1.0 + p["r"]) / (1.0 + p["r"] / np.cos(0.5 * math.pi * b) ** 2)
        return km, kc

    def tooth_fluxes(self, g, d):
        """Flux of each tooth under the array [(Br/pi) m] at ``(g, d)`` (teeth along the last axis)."""
        g, d = np.asarray(g, dtype=float)[..., None], np.asarray(d, dtype=float)[..., None]
        z, w = np.polynomial.legendre.leggauss(6)
        wt = k.t1 - k.b0
        n = np.arange(-14, 15)
        xt = self.p["x0"] + n * k.t1 + 0.5 * k.t1  # tooth centres between the openings at x0 + n t1
        out = 0.0 * (g + d + xt)
        for zi, wi in zip(z, w, strict=True):
            out = out + 0.5 * wt * wi * array_field(xt + 0.5 * wt * zi - d, g)
        return out

    def _km2(self, g, d, ref: float):
        b = self.p["b_lo"] * self.tooth_fluxes(g, d) / ref
        f = b / (1.0 + np.abs(b))
        return np.sum(f * f, axis=-1) / np.sum(b * b, axis=-1)

    def _table(self):
        from scipy.interpolate import RectBivariateSpline

        u = np.linspace(0.0, k.t1, 25)
        ref = float(np.max(np.abs(self.tooth_fluxes(np.full_like(u, G_STOP_LO), u))))
        gg = np.linspace(*self.G_GRID)
        dd = np.arange(-12, 37) * (k.t1 / 24)
        K2 = self._km2(gg[:, None], dd[None, :], ref)
        hi = float(np.mean(self._km2(np.full_like(u, G_STOP_HI), u, ref)))
        return RectBivariateSpline(gg, dd, np.sqrt(K2 / hi))

    def loss(self, g, i_q=0.0, i_d=0.0, d=0.0):
        """Fraction of the magnets' field lost at gap ``g`` (and position ``d``, ``tooth_flux``)."""
        g = np.asarray(g, dtype=float)
        if self.family == "incremental_arctan":
            return 1.0 - self._arctan(g)[0] / self._hi[0]
        gc = np.clip(g, self.G_GRID[0], self.G_GRID[1])
        u = np.mod(np.asarray(d, dtype=float), k.t1) + 0.0 * gc
        gc = gc + 0.0 * u
        return 1.0 - self._spline.ev(gc.ravel(), u.ravel()).reshape(u.shape)

    def factors(self, g, d, f: list) -> None:
        """The magnets' field by ``km`` (and the currents' by ``kc``, ``incremental_arctan``)."""
        if self.family == "tooth_flux":
            f[0] = f[0] * (1.0 - self.loss(g, d=d))
            return
        km, kc = self._arctan(np.asarray(g, dtype=float))
        f[0] = f[0] * km / self._hi[0]
        f[1] = f[1] * kc / self._hi[1]


# ------------------------------------------------------------------- amplifier and delay
class AmplifierV6(_V6, AmplifierV3):
    """Current loops with the inverter's sine filter, or a PI loop tuned on a winding it no longer matches.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`).

    * ``sine_filter`` -- an LC output filter between the inverter and the motor (Steinke, "Use of an LC filter to
      achieve a motor-friendly performance of the PWM voltage source inverter", IEEE Trans. Energy Convers. 14(3),
      1999): the loop (``wc / (s + wc)``) regulates the inverter-side current, and the motor's current is its share
      through the filter's capacitor and the winding, ``1 / (s^2 / wr^2 + 2 zeta s / wr + 1)``: a damped resonance
      at ``wr``; group delay ``1/wc + 2 zeta / wr`` at zero frequency.
    * ``detuned_pi`` -- a PI current loop tuned by pole-zero cancellation on the winding's nominal ``R, L`` (``Kp =
      wc L^, Ki = wc R^``; Harnefors & Nee, "Model-based current control of AC machines using the internal model
      control method", IEEE Trans. Ind. Appl. 34(1), 1998), on a winding whose resistance has risen with its
      temperature and whose inductance has changed: ``rho_R = R^/R``, ``rho_L = L^/L``, ``a = R / L``: ``i / u =
      (wc rho_L s + wc rho_R a) / (s^2 + (a + wc rho_L) s + wc rho_R a)``. The cancellation fails and leaves a
      slow pole-zero pair near ``-a`` (a creeping tail of the step response); DC gain 1, group delay ``1 / (wc
      rho_R)``.
    """

    families = ("sine_filter", "detuned_pi")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "sine_filter": {"bandwidth_hz": 400.0, "fr_hz": 1200.0, "zeta": 0.25, "delay_samples": 0.0},
        "detuned_pi": {"bandwidth_hz": 400.0, "tau_w": 5e-3, "rho_R": 0.8, "rho_L": 1.0, "delay_samples": 0.0},
    }

    def ss(self, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous ``(A, B, C)`` of axis ``axis`` (controllable canonical form; inputs ``[u, v]``, ``v`` unused)."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "sine_filter":
            wr, z = 2 * math.pi * p["fr_hz"], p["zeta"]
            # (s + wc)(s^2 + 2 z wr s + wr^2) = s^3 + a2 s^2 + a1 s + a0
            den = [wc + 2 * z * wr, wr * wr + 2 * z * wr * wc, wc * wr * wr]
            num = [wc * wr * wr]
        else:
            a = 1.0 / p["tau_w"]
            den = [a + wc * p["rho_L"], wc * p["rho_R"] * a]
            num = [wc * p["rho_R"] * a, wc * p["rho_L"]]
        n = len(den)
        A = np.zeros((n, n))
        A[:-1, 1:] = np.eye(n - 1)
        A[-1, :] = -np.array(den[::-1])
        B = np.zeros((n, 2))
        B[-1, 0] = 1.0
        return A, B, np.array(num + [0.0] * (n - len(num)))

    def group_delay(self, Ts: float) -> float:
        """Low-frequency group delay [s] of the command-to-current response, transport delay included."""
        p = self.p
        wc = 2 * math.pi * p["bandwidth_hz"]
        if self.family == "sine_filter":
            lag = 1.0 / wc + 2.0 * p["zeta"] / (2 * math.pi * p["fr_hz"])
        else:
            lag = 1.0 / (wc * p["rho_R"])
        return p["delay_samples"] * Ts + lag


# ------------------------------------------------------------------------- commutation
class CommutationV6(_V6, CommutationOffset):
    """Commutation angle errors of a tracking observer, or of Hall sensors that see the armature's field.

    * ``tracking_observer`` -- the angle comes from a type-II tracking loop (a resolver-to-digital converter or the
      PLL of an analog sin/cos Hall sensor; Hanselman, "Resolver signal requirements for high accuracy
      resolver-to-digital conversion", IEEE Trans. Ind. Electron. 37(6), 1990): ``theta^ / theta = (2 zeta wn s +
      wn^2) / (s^2 + 2 zeta wn s + wn^2)``. Its error ``e = theta - theta^`` is zero at constant speed and
      ``(pi / tau) a / wn^2`` at a constant acceleration ``a``: ``e = s (pi / tau) v / (s^2 + 2 zeta wn s + wn^2)``
      (states ``[e, e' - (pi/tau) v]``, advanced exactly per sub-step for the held speed, hook ``held``); the
      currents are placed at ``theta^``: ``delta = delta0 - e`` (hook ``rotate_at``). Size recorded while simulated.
    * ``armature_field_sensor`` -- Hall sensors in the stator, ``c_s`` behind its surface, read the direction of
      the magnets' field plus the armature's (Miller, "Brushless Permanent-Magnet and Reluctance Motor Drives",
      Clarendon Press 1989, armature reaction and shaft-position sensing): the q current's field in quadrature, the
      d current's along the magnets' (weakening them for ``i_d > 0``, seed eq. (2)), against the magnets' field at
      the sensor ``B(g + c_s) / B(g_ref + c_s)`` (MODEL.md), so ``delta = delta0 + atan2(a_q i_q, B(g + c_s) /
      B(g_ref + c_s) - a_d i_d)``: an error that grows with the thrust and with the gap (the field of the delivered
      currents; the rotation it causes is a second-order correction).
    """

    families = ("tracking_observer", "armature_field_sensor")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "tracking_observer": {"delta0": 0.0, "fn_hz": 8.0, "zeta": 0.7},
        "armature_field_sensor": {"delta0": 0.0, "a_q": 0.04, "a_d": 0.005, "c_s": 5e-3},
    }
    has_rotate = False
    has_rotate_at = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_held = self.family == "tracking_observer"
        self.state = np.zeros((0, 2))
        self.peak = np.zeros(3)
        self._maps: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        if self.has_held:  # its angle comes from a state the trajectory does not hold: size recorded
            self.recorded = self._recorded

    def reset(self, n_runs: int) -> None:
        """Observer locked, at rest."""
        self.state, self.peak = np.zeros((n_runs, 2)), np.zeros(3)

    def _map(self, h: float):
        if h not in self._maps:
            from scipy.linalg import expm

            wn, z = 2 * math.pi * self.p["fn_hz"], self.p["zeta"]
            M = np.zeros((3, 3))
            M[:2, :2] = [[0.0, 1.0], [-wn * wn, -2 * z * wn]]
            M[:2, 2] = [1.0, -2 * z * wn]
            E = expm(M * h)
            self._maps[h] = (E[:2, :2], E[:2, 2])
        return self._maps[h]

    def held(self, gd, dd, h: float):
        """Advance the observer's error over ``h`` at the horizontal speed; no force."""
        Ad, Bd = self._map(float(h))
        dd = np.asarray(dd, dtype=float)
        self.state = self.state @ Ad.T + (K_POLE * dd)[:, None] * Bd[None, :]
        self.peak[0] = max(self.peak[0], float(np.max(np.abs(self.state[:, 0]), initial=0.0)))
        return np.zeros_like(dd), np.zeros_like(dd)

    def angle(self, d, dd=0.0, g=k.g_cog_ref, i_q=0.0, i_d=0.0):
        """Electrical angle error [rad] (``tracking_observer``: of the observer's present state, per run)."""
        p = self.p
        d = np.asarray(d, dtype=float)
        if self.family == "tracking_observer":
            e = self.state[:, 0] if self.state.shape[0] == d.shape[0] else np.zeros(d.shape[:1])
            return p["delta0"] - e.reshape(e.shape + (1,) * (d.ndim - 1)) + 0.0 * d
        b = field_ratio(np.asarray(g, dtype=float) + p["c_s"], k.g_cog_ref + p["c_s"])
        return p["delta0"] + np.arctan2(p["a_q"] * np.asarray(i_q, dtype=float), b - p["a_d"] * np.asarray(i_d))

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by ``delta`` at the state ``X`` (rows: runs)."""
        a = self.angle(X[..., 2], X[..., 3], X[..., 0], i_q, i_d)
        q2, d2 = _rot(i_q, i_d, a)
        if self.has_held and np.ndim(a) == 1:  # the force of the rotation, nominal constants
            sh = shape(X[..., 0])
            c = NOMINAL
            fd = c.Mh * c.C1 * sh.f1 * np.abs(q2 - i_q)
            fg = c.Mv * np.abs(c.C3 * sh.f3 * (d2 - i_d) - c.C4 * sh.f4 * (q2 * q2 + d2 * d2 - i_q * i_q - i_d * i_d))
            self.peak[1] = max(self.peak[1], float(np.max(fg, initial=0.0)))
            self.peak[2] = max(self.peak[2], float(np.max(fd, initial=0.0)))
        return q2, d2

    def _recorded(self) -> dict[str, float]:
        """Size recorded while simulated (``tracking_observer``): the peak observer error [rad] and its forces [N]."""
        pg, pd = float(self.peak[1]), float(self.peak[2])
        return {"peak_angle_error_rad": float(self.peak[0]), "peak_force_n": max(pg, pd), "peak_force_g_n": pg,
                "peak_force_d_n": pd}  # fmt: skip


# --------------------------------------------------------------------------- eddy drag
class EddyDragV6(_V6, EddyDrag):
    """Eddy drag of a conducting patch under part of the travel, or of a sheet whose currents lag the motion.

    * ``plate_patch`` -- a conducting plate on the stator over ``[x_a, x_a + l_p]`` only. Each magnet (centre ``x_j``)
      drags the plate in proportion to the field it sweeps over it, ``B(g)^2`` (MODEL.md's field) times its
      coverage; near an edge of the plate the eddy currents lose their return path, which Lee & Park ("Modeling
      eddy currents with boundary conditions by using Coulomb's law and the method of images", IEEE Trans. Magn.
      38(2), 2002) model by an image pole of opposite sign mirrored across the edge: a coverage ``eta(u) = 1 -
      exp(-2 max(u, 0) / r_p)`` at a distance ``u`` inside each edge. ``c = c0 (B(g)/B(g_ref))^2 (1/pm) sum_j
      eta(x_j - x_a) eta(x_a + l_p - x_j)``; ``F = -c (g_dot, d_dot)`` (a field swept at ``K B v`` either way).
    * ``receding_image`` -- a thin conducting sheet under the array: after any change of the motion its induced
      currents relax as Maxwell's receding image, moving away at ``w = 2 / (mu0 sigma T)``, so the array's
      fundamental (wavenumber ``K = pi / tau``) decays with ``tau_e = 1 / (K w)`` (Saslow, "Maxwell's theory of eddy
      currents in thin conducting sheets, and applications to electromagnetic shielding and MAGLEV", Am. J. Phys.
      60(8), 1992). At speeds far below ``w`` the drag follows the speed through that lag: ``tau_e z' = v - z``,
      ``F = -c0 (B(g)/B(g_ref))^2 z`` per axis (hook ``held`` advances ``z`` exactly; size recorded while simulated).
    """

    families = ("plate_patch", "receding_image")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "plate_patch": {"c0": 40.0, "x_a": -0.02, "l_p": 0.08, "r_p": 0.015},
        "receding_image": {"c0": 30.0, "tau_e": 2e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_held = self.family == "receding_image"
        self.state = np.zeros((0, 2))
        self.peak = np.zeros(2)
        if self.has_held:
            self.recorded = self._recorded

    def reset(self, n_runs: int) -> None:
        """Sheet currents at rest (``receding_image``)."""
        self.state, self.peak = np.zeros((n_runs, 2)), np.zeros(2)

    def coefficient(self, g, d):
        """Drag coefficient ``c(g, d)`` [N s/m]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        b2 = field_ratio(g, k.g_cog_ref) ** 2
        if self.family == "receding_image":
            return p["c0"] * b2 + 0.0 * d
        cov = 0.0 * (g + d)
        for j in range(k.pm):
            xj = d + (j - 0.5 * (k.pm - 1)) * k.tau
            ea = 1.0 - np.exp(-2.0 * np.maximum(xj - p["x_a"], 0.0) / p["r_p"])
            eb = 1.0 - np.exp(-2.0 * np.maximum(p["x_a"] + p["l_p"] - xj, 0.0) / p["r_p"])
            cov = cov + ea * eb
        return p["c0"] * b2 * cov / k.pm

    def held(self, gd, dd, h: float):
        """Advance the sheet's lagged speeds over ``h`` (exact for the held speeds); its force is :meth:`force`'s."""
        decay = math.exp(-h / self.p["tau_e"])
        for j, v in enumerate((gd, dd)):
            v = np.asarray(v, dtype=float)
            self.state[:, j] = v + (self.state[:, j] - v) * decay
        z = np.zeros_like(np.asarray(dd, dtype=float))
        return z, z

    def force(self, g, gd, d, dd):
        """Eddy drag ``(F_g, F_d)`` [N]."""
        c = self.coefficient(g, d)
        if self.family == "plate_patch":
            return -c * gd, -c * dd
        dd = np.asarray(dd, dtype=float)
        if self.state.shape[0] == dd.shape[0] and dd.ndim == 1:
            fg, fd = -c * self.state[:, 0], -c * self.state[:, 1]
            self.peak = np.maximum(self.peak, [float(np.max(np.abs(fg), initial=0.0)), float(np.max(np.abs(fd)))])
            return fg, fd
        return 0.0 * c, 0.0 * c  # outside a simulation: no state

    def _recorded(self) -> dict[str, float]:
        """Size recorded while simulated (``receding_image``): the peak drag [N]."""
        pg, pd = float(self.peak[0]), float(self.peak[1])
        return {"peak_force_n": max(pg, pd), "peak_force_g_n": pg, "peak_force_d_n": pd}


#: The sixth set: one class per effect (library families and new effects), by effect name.
V6_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV6,
        FrictionV6,
        EndEffectV6,
        SaturationV6,
        AmplifierV6,
        CommutationV6,
        EddyDragV6,
        PhaseCurrentSensor,
        StatorFlatness,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V6: tuple[str, ...] = tuple(EFFECTS_V5) + tuple(n for n in V6_LAWS if n not in EFFECTS_V5)
V6_LIBRARY: tuple[str, ...] = tuple(n for n, c in V6_LAWS.items() if c.library)
V6_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V6_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3, v4, v5, then v6)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V6)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V6)


__all__ = [
    "EFFECTS_V6",
    "V6_LAWS",
    "V6_LIBRARY",
    "V6_OUT_OF_LIBRARY",
    "AmplifierV6",
    "CoggingV6",
    "CommutationV6",
    "EddyDragV6",
    "EndEffectV6",
    "FrictionV6",
    "PhaseCurrentSensor",
    "SaturationV6",
    "StatorFlatness",
    "array_field",
    "carter_width",
    "law_class",
    "make_law",
    "pm_coenergy",
    "yoke_flux",
]
