"""A ninth set of law families of the rig's effects, written from the physics literature (issue 27, ``laws="v9"``).

Two families per library effect that none of :mod:`.laws`, :mod:`.laws_new`, :mod:`.laws_v3` ... :mod:`.laws_v8`
has, and two effects outside the library (in :mod:`.laws_v9_ool`), for the next pre-registered blind check. They
were written from their sources only, without reading the diagnosis or how it fits; each class carries ``new_law =
True`` and ``law_set = "v9"`` in its truth record. The source of each law (author, title, venue, year) is in its
docstring and in ``docs/validation/rigsim-laws.md``.

The set uses the simulator's hooks as they are (``factors``, ``force``, ``force_i``, ``rotate_at``, ``read_at``,
``advance``, the state-space amplifier); no hook was added.
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
from .laws_v6 import V6_LAWS, array_field
from .laws_v7 import V7_LAWS
from .laws_v8 import EFFECTS_V8, V8_LAWS
from .laws_v9_ool import _V9, G_REF, PurgeAir, SensorEMI
from .physics import NOMINAL, shape

#: Composite Gauss-Legendre rule on [0, 1] (6 panels of 32 points) for the field integrals of ``field_overhang``.
_N_PANELS = 6
_gx, _gw = np.polynomial.legendre.leggauss(32)
_GX = ((np.arange(_N_PANELS)[:, None] + 0.5 * (_gx + 1.0)) / _N_PANELS).ravel()
_GW = np.tile(0.5 * _gw / _N_PANELS, _N_PANELS)
#: Reach of the array's field integrals from the array's centre [m] (the field energy of the four alternating
#: magnets beyond it is below 1e-4 of the total at the upper stop).
U_FAR = 0.5 * L_ARRAY + 0.12


def _softplus(z):
    return np.logaddexp(0.0, z)


def _sigmoid(z):
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(z, dtype=float)))


def carter(g, b0):
    """Carter's coefficient and the slot permeance factor ``(Kc, lam)`` of MODEL.md for an opening ``b0`` [m]."""
    g, b0 = np.asarray(g, dtype=float), np.asarray(b0, dtype=float)
    lam = 1.0 - b0 * b0 / (4.0 * k.t1 * (g + 0.5 * b0 + k.hm / k.mu_rec))
    r = b0 / (2.0 * g)
    gam = (4.0 / math.pi) * (r * np.arctan(r) - 0.5 * np.log1p(r * r))
    return k.t1 / (k.t1 - gam * g), lam


# ----------------------------------------------------------------------------- cogging
class CoggingV9(_V9, Cogging):
    """Cogging of teeth with notches in their faces, or of slots closed by magnetic wedges.

    Both are the slot-pitch harmonics of the slot openings' energy, each decaying across the gap as a Laplace field
    of its wavenumber, ``W = (t1 / 2 pi) sum_k (a_k(g) / k) cos theta_k``, ``theta_k = 2 pi k (d - x0) / t1 +
    phi_k``; ``F_d = sum_k a_k sin theta_k``, ``F_g = -dW/dg`` (``F_g > 0`` opens the gap), conservative.

    * ``notched_teeth`` -- each tooth face carries ``n`` dummy notches of width ``b_n``, spaced ``t1 / (n + 1)``
      from the slots and each other, so that the stator looks to the magnets like ``n + 1`` openings per slot pitch
      (teeth notching: Bianchi & Bolognani, "Design techniques for reducing the cogging torque in surface-mounted PM
      motors", IEEE Trans. Ind. Appl. 38(5), 2002, sec. on dummy slots; Hanselman, "Brushless Permanent Magnet
      Motor Design", 2nd ed., Magna Physics 2006, ch. 7). An opening of width ``b`` contributes ``S_k(b) =
      sin(k pi b / t1) / k`` to harmonic ``k``, so ``c_k = S_k(b0) + S_k(b_n) sum_{j=1..n} cos(2 pi k j / (n + 1))``
      (the sum is ``n`` where ``n + 1`` divides ``k``, ``-1`` elsewhere): the harmonics at multiples of ``n + 1`` grow,
      the others shrink. These are the surface's amplitudes; across the gap ``a_k(g) = A c_k exp(-2 pi k g / t1)``,
      ``A`` such that the amplitudes at ``g_ref = 10 mm`` sum to ``xi0``, k = 1 ... 6, ``phi_k = 0`` (the notches
      symmetric in the tooth): at the rig's gaps the fundamental, ``S_1(b0) - S_1(b_n)``, and the second harmonic
      are left, the raised harmonics of the notches only near the lower stop.
    * ``wedge_bridge`` -- the slots' mouths are closed by semi-magnetic wedges (thickness ``h_w``, relative
      permeability ``mu_w``): over a slot the flux crosses the gap and the wedge, ``g + e``, ``e = h_w / mu_w``,
      instead of the open slot's deep path, so the slot's permeance dip is ``1/g - 1/(g + e)`` against the open
      slot's ``1/g``: the cogging keeps the share ``e / (g + e)`` (semi-magnetic slot wedges and Carter's factor:
      Pyrhonen, Jokinen & Hrabovcova, "Design of Rotating Electrical Machines", 2nd ed., Wiley 2014, ch. 3; Carter,
      "Note on air-gap and interpolar induction", J. IEE 29, 1900). Normalized at ``g_ref``: ``a_k = xi0 c_k
      exp(-2 pi k (g - g_ref) / t1) (g_ref + e) / (g + e)``, k = 1, 2, ``c_1 = 1 - |c2|``: the exponential decay
      of the open slot times an algebraic one that is steeper the thinner (or the more permeable) the wedge.

    With ``replace = 1`` the rig's cogging is this law instead of seed eq. (9).
    """

    families = ("notched_teeth", "wedge_bridge")
    N_HARM = 6
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "notched_teeth": {"xi0": 3.0, "n": 1.0, "b_n": 4e-3, "x0": 0.0, "replace": 0.0},
        "wedge_bridge": {"xi0": 3.0, "c2": 0.2, "phi2": 0.0, "e": 1e-3, "x0": 0.0, "replace": 0.0},
    }

    def coefficients(self) -> list[tuple[int, float, float]]:
        """``[(k, amplitude at g_ref, phi_k)]``."""
        p = self.p
        if self.family == "wedge_bridge":
            return [(1, p["xi0"] * (1.0 - abs(p["c2"])), 0.0), (2, p["xi0"] * p["c2"], p["phi2"])]
        n = round(p["n"])

        def s_k(kk, b):
            return math.sin(kk * math.pi * b / k.t1) / kk

        cs = []
        for kk in range(1, self.N_HARM + 1):  # the openings' spectrum at the stator's surface, decayed to g_ref
            notch = n if kk % (n + 1) == 0 else -1.0
            decay = math.exp(-2 * math.pi * kk * k.g_cog_ref / k.t1)
            cs.append((s_k(kk, k.b0) + s_k(kk, p["b_n"]) * notch) * decay)
        tot = sum(abs(c) for c in cs)
        return [(kk, p["xi0"] * c / tot, 0.0) for kk, c in enumerate(cs, start=1)]

    def amplitudes(self, g):
        """``[(k, a_k(g), da_k/dg, phi_k)]``."""
        g = np.asarray(g, dtype=float)
        out = []
        for kk, a0, ph in self.coefficients():
            rate = -2 * math.pi * kk / k.t1
            a = a0 * np.exp(rate * (g - k.g_cog_ref))
            da = rate * a
            if self.family == "wedge_bridge":
                e = self.p["e"]
                m = (k.g_cog_ref + e) / (g + e)
                a, da = a * m, da * m - a * m / (g + e)
            out.append((kk, a, da, ph))
        return out

    def force(self, g, gd, d, dd):
        """Cogging ``(F_g, F_d)`` [N]."""
        d = np.asarray(d, dtype=float)
        fg = fd = 0.0
        for kk, a, da, ph in self.amplitudes(g):
            th = 2 * math.pi * kk * (d - self.p["x0"]) / k.t1 + ph
            fd = fd + a * np.sin(th)
            fg = fg - k.t1 / (2 * math.pi * kk) * da * np.cos(th)
        return fg + 0.0 * d, fd + 0.0 * np.asarray(g, dtype=float)


# ---------------------------------------------------------------------------- friction
class FrictionV9(_V9, Friction):
    """Friction of guides whose preload changes along the stroke, or of one contact sliding in the plane.

    * ``preload_taper`` -- the guide rails are not quite parallel, so the carriage's rolling elements are squeezed
      more at one end of the stroke: their interference grows linearly along d, ``delta = delta0 (1 + kappa (d -
      x_p))``, their Hertzian load as ``delta^(3/2)`` (Johnson, "Contact Mechanics", Cambridge Univ. Press 1985, ch.
      4; rail parallelism and preload: Slocum, "Precision Machine Design", Prentice Hall 1992, ch. 8), and the
      rolling friction with the load: ``F = -(Fc P(d) tanh(v / v_reg) + b v)`` per axis, ``P = max(0, 1 + kappa (d -
      x_p))^(3/2)``.
    * ``planar_coulomb`` -- one dry contact (a guide pad) sliding in the plane of the two axes: the friction opposes
      the sliding velocity as a vector, of magnitude ``Fc`` whatever its direction (the isotropic limit surface:
      Goyal, Ruina & Papadopoulos, "Planar sliding with dry friction. Part 1. Limit surface and moment function",
      Wear 143(2), 1991): ``F = -Fc v / sqrt(|v|^2 + v_reg^2) - b v`` with ``v = (g_dot, d_dot)``. Sliding fast
      along d, the friction against a slow gap motion becomes viscous, ``Fc g_dot / |d_dot|``: the axes are coupled.
    """

    families = ("preload_taper", "planar_coulomb")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "preload_taper": {"Fc_g": 0.2, "Fc_d": 0.2, "kappa": 6.0, "x_p": 0.0, "b_g": 0.5, "b_d": 0.5, "v_reg": 1e-3},
        "planar_coulomb": {"Fc": 0.25, "b_g": 0.5, "b_d": 0.5, "v_reg": 1e-3},
    }

    def __init__(self, family: str | None = None, **params: float):
        Law.__init__(self, family, **params)
        self.has_force = True
        self.has_held = False

    def preload(self, d):
        """``P(d)``: the rolling elements' load over its value at ``x_p`` (``preload_taper``)."""
        return np.maximum(0.0, 1.0 + self.p["kappa"] * (np.asarray(d, dtype=float) - self.p["x_p"])) ** 1.5

    def force(self, g, gd, d, dd):
        """Friction ``(F_g, F_d)`` [N]."""
        p = self.p
        gd, dd = np.asarray(gd, dtype=float), np.asarray(dd, dtype=float)
        if self.family == "planar_coulomb":
            s = p["Fc"] / np.sqrt(gd * gd + dd * dd + p["v_reg"] ** 2)
            return -(s * gd + p["b_g"] * gd), -(s * dd + p["b_d"] * dd)
        pl = self.preload(d)
        fg = -(p["Fc_g"] * pl * np.tanh(gd / p["v_reg"]) + p["b_g"] * gd)
        fd = -(p["Fc_d"] * pl * np.tanh(dd / p["v_reg"]) + p["b_d"] * dd)
        return fg + 0.0 * dd, fd + 0.0 * gd


# -------------------------------------------------------------------------- end effects
def field_energy(u1, u2, g):
    """``int_{u1}^{u2} Bz(u, g)^2 du`` of :func:`.laws_v6.array_field` (units squared times m), ``u1 <= u2``, by
    composite Gauss-Legendre quadrature (6 x 32 points; elementwise in the arrays' shapes)."""
    u1, u2, g = (np.asarray(x, dtype=float)[..., None] for x in (u1, u2, g))
    u = u1 + (u2 - u1) * _GX
    return np.sum(array_field(u, g) ** 2 * _GW, axis=-1) * (u2 - u1)[..., 0]


class EndEffectV9(_V9, EndEffect):
    """End effects: the pull lost with the field energy beyond the stator's ends, or the winding's co-energy.

    The stator ends ``e_p`` and ``e_n`` beyond the array's ends at ``d = 0``: at ``x_p = L/2 + e_p`` and ``-x_n``.

    * ``field_overhang`` -- the magnets' attraction to the stator is the field energy over the iron (Maxwell stress
      ``Bz^2 / 2 mu0`` over its surface), so the share that is left as the array overhangs an end is the energy of
      the array's exact field over the stator against the same at ``d = 0``: ``rho(d, g) = E(d, g) / E(0, g)``, ``E =
      int_{-x_n}^{x_p} Bz(x - d, g)^2 dx`` with the exact 2-D field of the four alternating magnets (their ends'
      fringes included: :func:`.laws_v6.array_field`; Furlani, "Permanent Magnet and Electromechanical Devices",
      Academic Press 2001, ch. 4; finite stators: Gieras, Piech & Tomczuk, "Linear Synchronous Motors", 2nd ed.,
      CRC Press 2011). Every magnetic term scales with ``rho`` (hook ``factors``): a loss that sets in smoothly as an
      end magnet's fringe crosses the face, earlier at large gaps (the fringe is broader), with a slight ripple as
      the poles pass the faces.
    * ``cross_coenergy`` -- the levitation winding's flux linkage with the magnets, ``psi(g) = -Mv C3 int_g^inf f3``
      (seed eq. (2)'s cross term ``Mv C3 f3 i_d = i_d dpsi/dg`` with nominal constants), is lost where the array
      overhangs the winding, partly (share ``eta``: the end coils' fringe keeps the rest): ``W' = psi(g) i_d (1 - eta
      (1 - o(d)))``, ``o = 1 - (w softplus((d - e_p)/w) + w softplus((-d - e_n)/w)) / L``. By virtual work (the
      co-energy of a winding linked with a magnet: Woodson & Melcher, "Electromechanical Dynamics, Part I", Wiley
      1968, ch. 3; Gieras, Piech & Tomczuk 2011) the currents' terms scale by ``1 - eta (1 - o)`` (hook ``factors``:
      ``kc``) and the levitation current pulls along d at the ends, ``F_d = eta psi(g) i_d o'(d)`` (hook
      ``force_i``): a thrust of the levitation current, pushing the array out where it overhangs.
    """

    families = ("field_overhang", "cross_coenergy")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "field_overhang": {"e_p": 0.02, "e_n": 0.03},
        "cross_coenergy": {"e_p": 0.02, "e_n": 0.03, "eta": 0.4, "w": 5e-3},
    }
    _PSI_S = 0.5 * (np.polynomial.legendre.leggauss(32)[0] + 1.0)
    _PSI_W = 0.5 * np.polynomial.legendre.leggauss(32)[1]
    PSI_REACH = 0.25  #: the linkage integral up to ``g + 0.25 m`` (``f3`` has fallen by ~1e-5 there)

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_factors = True
        self.has_force_i = self.family == "cross_coenergy"

    # field_overhang
    def energy_share(self, g, d):
        """``rho = E(d, g) / E(0, g)`` (``field_overhang``)."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        xp, xn = 0.5 * L_ARRAY + p["e_p"], 0.5 * L_ARRAY + p["e_n"]

        def over_stator(dd):  # the energy over the stator, in the array's frame u = x - d (within U_FAR)
            return field_energy(np.clip(-xn - dd, -U_FAR, U_FAR), np.clip(xp - dd, -U_FAR, U_FAR), g)

        return over_stator(d) / over_stator(0.0 * d)

    # cross_coenergy
    def overlap(self, d):
        """``o(d)`` and ``do/dd``."""
        p = self.p
        w = p["w"]
        d = np.asarray(d, dtype=float)
        o = 1.0 - w * (_softplus((d - p["e_p"]) / w) + _softplus((-d - p["e_n"]) / w)) / L_ARRAY
        do = -(_sigmoid((d - p["e_p"]) / w) - _sigmoid((-d - p["e_n"]) / w)) / L_ARRAY
        return o, do

    def linkage(self, g):
        """``psi(g) = -Mv C3 int_g^inf f3`` [N/A m] (nominal constants, 32-point Gauss-Legendre over 0.25 m)."""
        g = np.asarray(g, dtype=float)[..., None]
        f3 = shape(g + self.PSI_REACH * self._PSI_S).f3
        return -k.Mv * NOMINAL.C3 * self.PSI_REACH * np.sum(f3 * self._PSI_W, axis=-1)

    def factors(self, g, d, f: list) -> None:
        """``field_overhang``: ``rho``; ``cross_coenergy``: the currents' field ``kc``."""
        if self.family == "field_overhang":
            f[2] = f[2] * self.energy_share(g, d)
            return
        o, _ = self.overlap(d)
        f[1] = f[1] * (1.0 - self.p["eta"] * (1.0 - o))

    def force_i(self, g, gd, d, dd, i_q, i_d):
        """``(0, F_d)`` [N]: the levitation current's pull at the ends (``cross_coenergy``)."""
        _, do = self.overlap(d)
        fd = self.p["eta"] * self.linkage(g) * np.asarray(i_d, dtype=float) * do
        return 0.0 * fd, fd


# --------------------------------------------------------------------------- saturation
class SaturationV9(_V9, Saturation):
    """Tooth tips that saturate and widen the slots' openings, or a stator stacked of two steel grades.

    * ``tip_carter`` -- the tooth tips beside each slot opening carry the fringing flux and saturate first; a
      saturated tip acts like air, so the opening is magnetically wider, ``b0_eff = b0 + w_t s_w softplus((b -
      b_k) / s_w)``, ``b = B(g) / B(g_lo)`` (MODEL.md's field, 1 at the lower stop): Carter's coefficient grows
      and the slot permeance factor falls (the saturation of tooth tips in Carter's factor: Ostovic, "Dynamics of
      Saturated Electric Machines", Springer 1989, ch. 2; Pyrhonen, Jokinen & Hrabovcova 2014, ch. 3). Every term
      of seed eq. (2) through MODEL.md's ``lam`` and ``Kc`` (:func:`carter`) at ``b0_eff``: ``km = sqrt(lam_e /
      lam)``, ``kc = km Kc / Kc_e`` (hook ``factors``): the currents' terms lose more than the magnets' pull.
    * ``mixed_grade`` -- the stator is built of two stacks of different steel, the part beyond ``x_j`` (on side
      ``side``) of a grade that saturates earlier (magnetization curves of steel grades: Bozorth, "Ferromagnetism",
      Van Nostrand 1951, ch. 2; modular stators: Gieras, Piech & Tomczuk 2011): that grade loses ``l(g) = l_lo
      b^n`` of the field (``b`` as above), the array's share over it ``w(d) = clip((side (d - x_j) + L/2) / L, 0,
      1)``: ``km = kc = 1 - l(g) w(d)``: a saturation that depends on where the mover is.
    """

    families = ("tip_carter", "mixed_grade")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "tip_carter": {"w_t": 6e-3, "b_k": 0.5, "s_w": 0.05, "target": "both"},
        "mixed_grade": {"l_lo": 0.25, "n": 2.0, "x_j": 0.0, "side": 1.0, "target": "both"},
    }

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] != "both":
            raise ValueError(f"saturation ({self.family}): target must be 'both'")

    @staticmethod
    def flux(g):
        """``b = B(g) / B(g_lo)``."""
        return shape(g).B / float(shape(G_STOP_LO).B)

    def opening(self, g):
        """``b0_eff`` [m] (``tip_carter``)."""
        p = self.p
        return k.b0 + p["w_t"] * p["s_w"] * _softplus((self.flux(g) - p["b_k"]) / p["s_w"])

    def share(self, d):
        """``w(d)`` (``mixed_grade``)."""
        p = self.p
        return np.clip((p["side"] * (np.asarray(d, dtype=float) - p["x_j"]) + 0.5 * L_ARRAY) / L_ARRAY, 0.0, 1.0)

    def field_factors(self, g, d):
        """``(km, kc)``."""
        g = np.asarray(g, dtype=float)
        if self.family == "tip_carter":
            kc0, lam0 = carter(g, k.b0)
            kce, lame = carter(g, self.opening(g))
            km = np.sqrt(lame / lam0)
            return km, km * kc0 / kce
        kk = 1.0 - self.p["l_lo"] * self.flux(g) ** self.p["n"] * self.share(d)
        return kk, kk

    def loss(self, g, d=0.0):
        """Fraction of the magnets' pull lost at gap ``g`` (and position ``d`` for ``mixed_grade``)."""
        return 1.0 - self.field_factors(g, d)[0] ** 2

    def factors(self, g, d, f: list) -> None:
        """The magnets' and the currents' field."""
        km, kc = self.field_factors(g, d)
        f[0] = f[0] * km
        f[1] = f[1] * kc


# ------------------------------------------------------------------- amplifier and delay
def companion(num, den):
    """``(A, B, C)`` of ``num(s) / den(s)`` (coefficients highest first, ``den`` monic, ``deg num < deg den``) in the
    controllable companion form; ``B`` has a second (unused) input column."""
    den = np.asarray(den, dtype=float)
    n = den.size - 1
    num = np.concatenate([np.zeros(n - len(num)), np.asarray(num, dtype=float)])
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -den[:0:-1]
    B = np.zeros((n, 2))
    B[-1, 0] = 1.0
    return A, B, num[::-1].copy()


def chebyshev_poles(n: int, ripple_db: float) -> np.ndarray:
    """Poles of the normalized Chebyshev (type I) low-pass of order ``n`` and pass-band ripple ``ripple_db``."""
    eps = math.sqrt(10 ** (ripple_db / 10.0) - 1.0)
    a = math.asinh(1.0 / eps) / n
    th = (2 * np.arange(1, n + 1) - 1) * math.pi / (2 * n)
    return -math.sinh(a) * np.sin(th) + 1j * math.cosh(a) * np.cos(th)


class AmplifierV9(_V9, AmplifierV3):
    """A Chebyshev current response, or a current loop with PWM delay and a current-sense filter in its loop.

    Both: a fractional transport delay ``delay_samples`` besides (exact state-space solution per sub-step, as
    :mod:`.laws_v3`); DC gain 1; no back-EMF input.

    * ``chebyshev3`` -- the current loop and its output filter tuned for the steepest roll-off with a pass-band
      ripple: a third-order Chebyshev (type I) response of ripple ``ripple_db`` and ripple bandwidth ``f_c``
      (Williams & Taylor, "Electronic Filter Design Handbook", 4th ed., McGraw-Hill 2006, ch. 2; Zverev, "Handbook
      of Filter Synthesis", Wiley 1967): ``H = prod(-p_k) / prod(s - p_k)``, ``p_k = wc (-sinh a sin th_k + i cosh a
      cos th_k)``; odd order: its gain ripples between 1 (at DC) and ``-ripple_db`` inside the band, and its group
      delay peaks near the band's edge.
    * ``pwm_sense_loop`` -- a PI loop tuned by pole-zero cancellation (``wc / s`` in the loop) whose feedback runs
      through the current sensor's filter ``wf / (s + wf)`` and whose output through the PWM's sample-and-hold,
      the delay ``T`` as its first-order Pade form ``P = (1 - sT/2) / (1 + sT/2)`` (Holmes & Lipo, "Pulse Width
      Modulation for Power Converters", IEEE Press / Wiley 2003, ch. on sampled PWM; Buso & Mattavelli, "Digital
      Control in Power Electronics", Morgan & Claypool 2006, ch. 4): ``i/u = wc P (s + wf) / (s (s + wf) + wc wf
      P)``: a right-half-plane zero, a resonance from the filter inside the loop, group delay ``1/wc - 1/wf``.
    """

    families = ("chebyshev3", "pwm_sense_loop")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "chebyshev3": {"f_c": 500.0, "ripple_db": 0.5, "delay_samples": 0.0},
        "pwm_sense_loop": {"bandwidth_hz": 400.0, "filter_ratio": 4.0, "T": 1e-4, "delay_samples": 0.0},
    }

    def polynomials(self) -> tuple[np.ndarray, np.ndarray, float]:
        """``(num, den, w0)``: the response in ``sigma = s / w0`` (``den`` monic), ``w0`` the scale [rad/s]."""
        p = self.p
        if self.family == "chebyshev3":
            poles = chebyshev_poles(3, p["ripple_db"])
            den = np.real(np.poly(poles))
            return np.array([den[-1]]), den, 2 * math.pi * p["f_c"]
        wc = 2 * math.pi * p["bandwidth_hz"]
        r, h = p["filter_ratio"], 0.5 * p["T"] * wc  # wf = r wc; sT/2 = sigma h
        num = np.polymul([-h, 1.0], [1.0, r])
        den = np.polyadd(np.polymul(np.polymul([1.0, 0.0], [1.0, r]), [h, 1.0]), r * np.array([-h, 1.0]))
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
        """Low-frequency group delay [s] of the command-to-current response, transport delay included:
        ``den'(0)/den(0) - num'(0)/num(0)``."""
        num, den, w0 = self.polynomials()
        lag = den[-2] / den[-1] - (num[-2] / num[-1] if num.size > 1 else 0.0)
        return self.p["delay_samples"] * Ts + float(lag) / w0


# ------------------------------------------------------------------------- commutation
class CommutationV9(_V9, CommutationOffset):
    """Commutation angle errors of a warming Hall sensor, or of Hall sensors in a stray field.

    * ``warmup_drift`` -- the Hall sensors' offsets drift as the motor warms them up (the offset voltage's
      temperature coefficient: Ramsden, "Hall-Effect Sensors: Theory and Application", 2nd ed., Elsevier 2006, ch. 4;
      a machine's warm-up as a first-order thermal response: Bryan, "International status of thermal error
      research", CIRP Annals 39(2), 1990): ``delta = delta0 + delta_T (1 - exp(-t / tau_th))``, ``t`` the dataset's
      time (the runs recorded one after the other; hook ``rotate_at``). The angle error changes during the dataset,
      not along the stroke.
    * ``stray_field_hall`` -- sin/cos Hall sensors ``c_s`` behind the stator's surface read the array's field plus a
      constant stray field (the stator iron's remanence, the earth's field, a neighbouring magnet): offsets
      ``beta_s``, ``beta_c`` against the array's field at ``G_REF``, so against the field at the gap ``g`` they are
      ``beta / bh(g)``, ``bh = B(g + c_s) / B(G_REF + c_s)`` (MODEL.md's field): ``delta = delta0 + atan2(sin th +
      beta_s / bh, cos th + beta_c / bh) - th``, ``th = pi d / tau + th0`` (stray fields and offsets of Hall
      sensors: Ramsden 2006, ch. 4; Lenz & Edelstein, "Magnetic sensors and their applications", IEEE Sensors J.
      6(3), 2006): an error of period 2 tau along d that grows as the gap opens (hook ``rotate_at``).

    For both, the force of the rotation (the rotated against the delivered currents through seed eq. (2) with
    nominal constants) is recorded while simulated, at the integrator's stage states.
    """

    families = ("warmup_drift", "stray_field_hall")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "warmup_drift": {"delta0": 0.0, "delta_T": 0.05, "tau_th": 20.0},
        "stray_field_hall": {"delta0": 0.0, "beta_s": 0.03, "beta_c": -0.02, "c_s": 5e-3, "theta0": 0.0},
    }
    has_rotate = False
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.peak = np.zeros(2)
        self.n_runs = 0

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.peak = np.zeros(2)
        self.n_runs = n_runs

    def angle_at(self, g, d, t):
        """Electrical angle error [rad] at gap ``g``, position ``d`` and dataset time ``t``."""
        p = self.p
        if self.family == "warmup_drift":
            t = np.asarray(t, dtype=float)
            return p["delta0"] + p["delta_T"] * -np.expm1(-t / p["tau_th"])
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        bh = shape(g + p["c_s"]).B / float(shape(G_REF + p["c_s"]).B)
        th = K_POLE * d + p["theta0"]
        e = np.arctan2(np.sin(th) + p["beta_s"] / bh, np.cos(th) + p["beta_c"] / bh) - th
        return p["delta0"] + np.mod(e + math.pi, 2 * math.pi) - math.pi

    def rotate_at(self, i_q, i_d, X, t):
        """Rotate the dq currents by the angle error at the state ``X`` and time ``t``."""
        X = np.asarray(X, dtype=float)
        if self.family == "warmup_drift" and t is None:  # outside a simulation (no time): the angle at t = 0
            t = np.zeros(X.shape[:-1])
        a = self.angle_at(X[..., 0], X[..., 2], t)
        c, s = np.cos(a), np.sin(a)
        iq2, id2 = c * i_q - s * i_d, s * i_q + c * i_d
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            sh = shape(X[:, 0])  # the force of the rotation, seed eq. (2) with nominal constants, while simulated
            c0 = NOMINAL
            dfg = k.Mv * (c0.C3 * sh.f3 * (id2 - i_d))  # |i| is kept: the C4 term does not change
            dfd = -k.Mh * c0.C1 * sh.f1 * (iq2 - i_q)
            self.peak = np.maximum(self.peak, [float(np.max(np.abs(dfg))), float(np.max(np.abs(dfd)))])
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return {
            "peak_force_n": float(max(self.peak)),
            "peak_force_g_n": float(self.peak[0]),
            "peak_force_d_n": float(self.peak[1]),
        }


# --------------------------------------------------------------------------- eddy drag
class EddyDragV9(_V9, EddyDrag):
    """Eddy drag of the magnets' own eddy currents under the slot ripple, or of a ladder conductor beside the track.

    * ``magnet_slot_eddy`` -- the sintered magnets conduct (``sigma ~ 0.7 MS/m``); moving over the slots, they see
      the slot permeance ripple of the field at the slot frequency ``v / t1``, which drives eddy currents in them,
      with a loss ``~ sigma (omega B_s)^2`` (the magnets' eddy-current loss from the slot harmonics: Polinder &
      Hoeijmakers, "Eddy-current losses in the segmented surface-mounted magnets of a PM machine", IEE Proc.
      Electr. Power Appl. 146(3), 1999; Atallah, Howe, Mellor & Stone, "Rotor loss in permanent-magnet brushless AC
      machines", IEEE Trans. Ind. Appl. 36(6), 2000). Far below the skin-effect frequency (the skin depth at the
      slot frequency is decimetres) the drag is viscous, its coefficient ``~ B_s^2``; the ripple of the magnets'
      operating point follows the slot permeance wave at their face, ``B_s ~ Br exp(-2 pi g / t1)``: ``F_d = -c0
      exp(-4 pi (g - g_r) / t1) d_dot``, ``g_r = 12 mm`` (the gap band's lower end): large only at small gaps.
    * ``ladder_rungs`` -- a ladder-shaped conductor (rungs of pitch ``p_r`` between two rails, as the secondary of a
      linear induction brake) along the track under the array's fringe: the rungs' currents have an inductive lag,
      so the drag follows the induction machine's slip curve (Kloss's formula: Fitzgerald, Kingsley & Umans,
      "Electric Machinery", 6th ed., McGraw-Hill 2003, ch. 6; ladder secondaries: Laithwaite, "Induction Machines
      for Special Purposes", Newnes 1966), ``F_d = -F_m 2 (v/v_m) / (1 + (v/v_m)^2)``, with ``F_m`` scaled by the
      field at the conductor ``(B(g)/B(G_REF))^2``, and ripples as the rungs pass the poles, ``(1 + a_r cos(2 pi (d -
      x_r) / p_r))``. Low-speed coefficient ``c0 = 2 F_m / v_m`` at ``G_REF``.
    """

    families = ("magnet_slot_eddy", "ladder_rungs")
    G_R = 12e-3
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "magnet_slot_eddy": {"c0": 4.0},
        "ladder_rungs": {"c0": 6.0, "v_m": 0.25, "a_r": 0.3, "p_r": 8e-3, "x_r": 0.0},
    }

    def coefficient(self, g, d=0.0):
        """Low-speed drag coefficient [N s/m] at gap ``g`` (and position ``d``)."""
        p = self.p
        g = np.asarray(g, dtype=float)
        if self.family == "magnet_slot_eddy":
            return p["c0"] * np.exp(-4 * math.pi * (g - self.G_R) / k.t1)
        b = shape(g).B / float(shape(G_REF).B)
        return p["c0"] * b * b * (1.0 + p["a_r"] * np.cos(2 * math.pi * (np.asarray(d) - p["x_r"]) / p["p_r"]))

    def force(self, g, gd, d, dd):
        """Drag ``(0, F_d)`` [N]."""
        dd = np.asarray(dd, dtype=float)
        c = self.coefficient(g, d)
        if self.family == "magnet_slot_eddy":
            fd = -c * dd
        else:
            vm = self.p["v_m"]
            fd = -c * dd / (1.0 + (dd / vm) ** 2)  # = -F_m 2 (v/v_m) / (1 + (v/v_m)^2), F_m = c v_m / 2
        return 0.0 * fd, fd


#: The ninth set: one class per effect (library families and new effects), by effect name.
V9_LAWS: dict[str, type[Law]] = {
    c.name: c  # type: ignore[misc]
    for c in (
        CoggingV9,
        FrictionV9,
        EndEffectV9,
        SaturationV9,
        AmplifierV9,
        CommutationV9,
        EddyDragV9,
        PurgeAir,
        SensorEMI,
    )
}
#: Every effect name in the order the simulator applies them (the earlier sets' first, as before).
EFFECTS_V9: tuple[str, ...] = tuple(EFFECTS_V8) + tuple(n for n in V9_LAWS if n not in EFFECTS_V8)
V9_LIBRARY: tuple[str, ...] = tuple(n for n, c in V9_LAWS.items() if c.library)
V9_OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in V9_LAWS.items() if not c.library)
REGISTRIES = (LAWS, NEW_LAWS, V3_LAWS, V4_LAWS, V5_LAWS, V6_LAWS, V7_LAWS, V8_LAWS, V9_LAWS)


def law_class(name: str, family: str | None) -> type[Law]:
    """The class that implements ``family`` of effect ``name`` (first laws, :mod:`.laws_new`, v3 ... v8, then v9)."""
    return resolve_law(name, family, REGISTRIES, EFFECTS_V9)


def make_law(name: str, spec: Mapping[str, Any] | None = None) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` (any law set; defaults for the rest)."""
    return build_law(name, spec, REGISTRIES, EFFECTS_V9)


__all__ = [
    "EFFECTS_V9",
    "G_REF",
    "U_FAR",
    "V9_LAWS",
    "V9_LIBRARY",
    "V9_OUT_OF_LIBRARY",
    "AmplifierV9",
    "CoggingV9",
    "CommutationV9",
    "EddyDragV9",
    "EndEffectV9",
    "FrictionV9",
    "PurgeAir",
    "SaturationV9",
    "SensorEMI",
    "carter",
    "chebyshev_poles",
    "companion",
    "field_energy",
    "law_class",
    "make_law",
]
