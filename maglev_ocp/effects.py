"""Library of the effects that the nominal model leaves out (``shared/spec/NOTES.md``).

Each effect is a small, physically parametrized class that modifies the shared
model's acceleration contributions (``get_model().accel_terms``) with CasADi
expressions. The same code serves

* the plant simulator (numeric effect parameters, one CasADi Function per set
  of effects, see :mod:`maglev_ocp.plant`), and
* the gap diagnosis, which fits an effect's parameters as a CasADi NLP: it
  builds the modified accelerations from symbolic ``x, u, p`` and the effect
  parameter vector ``theta`` with :meth:`EffectSet.accel` (or the Function from
  :meth:`EffectSet.accel_function`), and takes names, defaults and physical
  bounds from :attr:`Effect.params`.

The nominal model (seed eq. (2) plus the spec's cogging law) is never retyped:
every effect starts from the model's terms ``a_grav, a_pm, a_id, a_rel,
a_cogn`` (vertical) and ``a_thrust, a_cogx`` (horizontal) and scales them or
adds new terms. Composition order is fixed (:data:`EFFECT_ORDER`), so a set of
effects means the same thing whatever order a user lists it in.

The amplifier lag is the one dynamic effect: its applied currents are extra
plant states and its delay is a buffer of whole samples, so it does not act in
:meth:`EffectSet.accel` (which takes the currents the motor actually carries);
use :meth:`AmplifierLag.filter_currents` to turn commanded into applied
currents offline.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import casadi as ca
import numpy as np

from . import constants as k
from .model import get_model
from .shapes import bspline, cumulative, cumulative_bspline
from .signals import PARAM_NAMES

Expr = Any  # casadi SX or MX expression

#: Model terms that are magnetic forces (scaled by saturation / end effects).
MAGNETIC_TERMS: frozenset[str] = frozenset(
    {"a_pm", "a_id", "a_rel", "a_cogn", "a_thrust", "a_cogx", "cog_extra_n", "cog_extra_x"}
)
VERTICAL_MODEL_TERMS: tuple[str, ...] = ("a_grav", "a_pm", "a_id", "a_rel", "a_cogn")
HORIZONTAL_MODEL_TERMS: tuple[str, ...] = ("a_thrust", "a_cogx")


@dataclass(frozen=True)
class EffectParam:
    """One physical parameter of an effect.

    Attributes
    ----------
    name : str
        Parameter name, unique within its effect.
    default : float
        Typical value (used when a config leaves it out, and as the NLP's start).
    lo, hi : float
        Physical bounds (inclusive), for config validation and for the NLP.
    unit : str
        SI unit.
    description : str
        What it is.
    integer : bool
        Whole numbers only (the amplifier's delay in samples).
    """

    name: str
    default: float
    lo: float
    hi: float
    unit: str
    description: str
    integer: bool = False


@dataclass
class Terms:
    """Acceleration contributions [m/s^2] of one evaluation, by axis and name.

    ``vertical`` sums to ``g_ddot``, ``horizontal`` to ``d_ddot``. Effects scale
    existing entries or add new ones (forces divided by the model's masses).
    """

    vertical: dict[str, Expr] = field(default_factory=dict)
    horizontal: dict[str, Expr] = field(default_factory=dict)

    def scale(self, names: Iterable[str], factor: Expr) -> None:
        """Multiply the named terms (on either axis) by ``factor``."""
        for name in names:
            for axis in (self.vertical, self.horizontal):
                if name in axis:
                    axis[name] = axis[name] * factor

    def g_ddot(self) -> Expr:
        """Vertical acceleration: the sum of the vertical terms."""
        return functools.reduce(operator.add, self.vertical.values())

    def d_ddot(self) -> Expr:
        """Horizontal acceleration: the sum of the horizontal terms."""
        return functools.reduce(operator.add, self.horizontal.values())


class Effect:
    """Base class of an unmodelled effect.

    Subclasses set :attr:`name`, :attr:`params` and override :meth:`currents`
    (a static transformation of the motor currents) and/or :meth:`modify`
    (changes to the acceleration terms). ``theta`` is always a dict from the
    effect's parameter names to (symbolic or numeric) values.
    """

    name: ClassVar[str] = ""
    params: ClassVar[tuple[EffectParam, ...]] = ()
    dynamic: ClassVar[bool] = False  # True if it adds plant states (amplifier lag)

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """Names of the effect's parameters, in vector order."""
        return tuple(q.name for q in cls.params)

    @classmethod
    def defaults(cls) -> dict[str, float]:
        """Default value of each parameter."""
        return {q.name: q.default for q in cls.params}

    @classmethod
    def bounds(cls) -> dict[str, tuple[float, float]]:
        """Physical bounds ``(lo, hi)`` of each parameter."""
        return {q.name: (q.lo, q.hi) for q in cls.params}

    def currents(self, u: Expr, x: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Currents the motor carries, from the currents the amplifier delivers (default: same)."""
        return u

    def modify(self, terms: Terms, x: Expr, u: Expr, p: Expr, theta: Mapping[str, Expr]) -> None:
        """Change ``terms`` in place (default: nothing)."""


def _P(p: Expr) -> dict[str, Expr]:
    return dict(zip(PARAM_NAMES, ca.vertsplit(p), strict=True))


def _smooth_abs(v: Expr, eps: float) -> Expr:
    return ca.sqrt(v**2 + eps**2)


def _abs0(v: Expr, eps: float = 1e-6) -> Expr:
    """``|v|``, smooth at 0 and exactly 0 there: ``v^2 / sqrt(v^2 + eps^2)`` (relative error ``eps^2 / 2v^2``)."""
    return v**2 / ca.sqrt(v**2 + eps**2)


# --------------------------------------------------------------------------- effects
class Cogging(Effect):
    """Cogging beyond the spec's law: harmonics in d and a different gap decay.

    Added on top of the shared model's cogging (seed eq. (9), MODEL.md), which
    stays in ``p`` (``xi0``, ``ell``). Real motors add harmonics of the slot
    pitch (NOTES.md); the seed only says the peak force is "typically inversely
    proportional to the air-gap" (section V.C), so the decay here mixes a power
    law with an exponential and a curvature of the log-decay (together a smooth
    three-parameter family of decays; ``curv = 0`` by default)::

        xi_e(g) = xi0 * (g_ref / g)^power * exp(-(g - g_ref) / ell - curv ((g - g_ref) / g_ref)^2)
        Fx      = xi_e(g) * sum_k h_k sin(k pi d / t1 + phi_k)            (k = 1, 2, 3; phi_1 = 0)
        Fn      = kn * xi_e(g) * sum_k |h_k| sin^2(k pi d / t1 + phi_k)   (attractive, reduces g)

    With the shared model's cogging switched off (``xi0 = 0`` in ``p``) and
    ``h1 = 1, h2 = h3 = 0, power = 0, kn = 1`` this is exactly the spec's law.
    """

    name = "cogging"
    params = (
        EffectParam("xi0", 1.0, 0.0, 50.0, "N", "peak extra cogging force at g = 10 mm"),
        EffectParam("ell", 4e-3, 5e-4, 0.1, "m", "exponential decay length of the peak force"),
        EffectParam("power", 0.0, 0.0, 4.0, "-", "power-law decay exponent, (g_ref/g)^power"),
        EffectParam("h1", 0.0, -2.0, 2.0, "-", "weight of the fundamental sin(pi d/t1)"),
        EffectParam("h2", 0.5, -2.0, 2.0, "-", "weight of the 2nd harmonic sin(2 pi d/t1 + phi2)"),
        EffectParam("h3", 0.25, -2.0, 2.0, "-", "weight of the 3rd harmonic sin(3 pi d/t1 + phi3)"),
        EffectParam("phi2", 0.0, -math.pi, math.pi, "rad", "phase of the 2nd harmonic"),
        EffectParam("phi3", 0.0, -math.pi, math.pi, "rad", "phase of the 3rd harmonic"),
        EffectParam("kn", 1.0, 0.0, 4.0, "-", "normal-to-tangential peak ratio"),
        EffectParam("curv", 0.0, -20.0, 20.0, "-", "curvature of the log-decay, exp(-curv ((g - g_ref)/g_ref)^2)"),
    )

    def forces(self, g: Expr, d: Expr, theta: Mapping[str, Expr]) -> tuple[Expr, Expr]:
        """Extra tangential and normal cogging forces ``(Fx, Fn)`` [N]."""
        xi = theta["xi0"] * (k.g_cog_ref / g) ** theta["power"] * ca.exp(-(g - k.g_cog_ref) / theta["ell"])
        # Law family: a quadratic term in the log-decay (exactly 1 at the default curv = 0).
        xi = xi * ca.exp(-theta["curv"] * ((g - k.g_cog_ref) / k.g_cog_ref) ** 2)
        arg = math.pi * d / k.t1
        s1, s2, s3 = ca.sin(arg), ca.sin(2 * arg + theta["phi2"]), ca.sin(3 * arg + theta["phi3"])
        Fx = xi * (theta["h1"] * s1 + theta["h2"] * s2 + theta["h3"] * s3)
        # Every harmonic's normal force is attractive (Maxwell stress grows with B^2): its weight is |h_k|,
        # so that a harmonic's sign is a phase of half its period, never a repulsive normal force.
        Fn = theta["kn"] * xi * (_abs0(theta["h1"]) * s1**2 + _abs0(theta["h2"]) * s2**2 + _abs0(theta["h3"]) * s3**2)
        return Fx, Fn

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        Fx, Fn = self.forces(x[0], x[2], theta)
        terms.vertical["cog_extra_n"] = -Fn / P["Mv"]
        terms.horizontal["cog_extra_x"] = Fx / P["Mh"]


class Friction(Effect):
    """Friction of the linear guides: Coulomb + viscous + Stribeck, per axis (NOTES.md).

    Seed section III lists friction among the unmodelled effects. The force on
    an axis with velocity ``v`` is::

        F = -[(Fc + Fs exp(-(v / v_s)^2)) tanh(v / v_reg) + b v]

    ``tanh`` regularizes the sign function so that the dynamics stay smooth
    (and differentiable for the diagnosis NLP); ``Fs`` is the static excess
    (breakaway force minus Coulomb force).
    """

    name = "friction"
    params = (
        EffectParam("coulomb_g", 0.2, 0.0, 10.0, "N", "Coulomb friction of the vertical guide"),
        EffectParam("coulomb_d", 0.1, 0.0, 10.0, "N", "Coulomb friction of the horizontal guide"),
        EffectParam("stribeck_g", 0.1, 0.0, 10.0, "N", "static excess (Stribeck) of the vertical guide"),
        EffectParam("stribeck_d", 0.05, 0.0, 10.0, "N", "static excess (Stribeck) of the horizontal guide"),
        EffectParam("v_stribeck", 2e-3, 1e-5, 0.1, "m/s", "Stribeck velocity"),
        EffectParam("viscous_g", 0.5, 0.0, 100.0, "N s/m", "viscous coefficient, vertical"),
        EffectParam("viscous_d", 0.5, 0.0, 100.0, "N s/m", "viscous coefficient, horizontal"),
        EffectParam("v_reg", 2e-4, 1e-6, 1e-2, "m/s", "tanh regularization velocity"),
    )

    @staticmethod
    def force(v: Expr, Fc: Expr, Fs: Expr, b: Expr, v_s: Expr, v_reg: Expr) -> Expr:
        """Friction force [N] at velocity ``v`` [m/s] (opposes the motion)."""
        return -((Fc + Fs * ca.exp(-((v / v_s) ** 2))) * ca.tanh(v / v_reg) + b * v)

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        t = theta
        Fg = self.force(x[1], t["coulomb_g"], t["stribeck_g"], t["viscous_g"], t["v_stribeck"], t["v_reg"])
        Fd = self.force(x[3], t["coulomb_d"], t["stribeck_d"], t["viscous_d"], t["v_stribeck"], t["v_reg"])
        terms.vertical["friction_g"] = Fg / P["Mv"]
        terms.horizontal["friction_d"] = Fd / P["Mh"]

    @staticmethod
    def stiffness(theta: Mapping[str, float], Mh: float = k.Mh, Mv: float = k.Mv) -> float:
        """Largest ``|d a / d v|`` [1/s] of the friction law (for the integrator's stability check)."""
        worst = 0.0
        for ax, M in (("g", Mv), ("d", Mh)):
            s = (theta[f"coulomb_{ax}"] + theta[f"stribeck_{ax}"]) / theta["v_reg"] + theta[f"viscous_{ax}"]
            worst = max(worst, s / M)
        return worst


#: Centres [m] of the end effect's free-profile coefficients in |d|: every 5 mm from 10 mm to the stops.
_END_KNOTS: tuple[float, ...] = tuple(round(0.01 + 0.005 * j, 4) for j in range(11))


def _knot_name(c: float) -> str:
    """Parameter name of the end effect's free-profile step at the knot ``|d| = c`` [m]: ``dloss_30``."""
    return f"dloss_{round(c * 1e3):.0f}"


class EndEffect(Effect):
    """End effects of the short stator / mover (NOTES.md; seed section III).

    Two parts:

    * force ripple with the pole pitch ``tau``: the thrust is multiplied by
      ``1 + ripple cos(2 pi d / tau + ripple_phase)``;
    * loss of force as the mover overhangs the stator: beyond ``|d| = d_edge``
      the overhanging length ``o(d) = w softplus((|d| - d_edge) / w)`` of the
      magnet array (length ``pm * tau``, Table I) produces no force, so every
      magnetic term is multiplied by ``1 - o(d) / (pm * tau)``.

    Law family (all extra parameters default to the geometric law above): a
    second ripple harmonic ``ripple2 cos(4 pi d / tau + ripple2_phase)``; a
    free overhang profile, a cubic B-spline in ``|d|`` with knots every
    :attr:`KNOT_STEP` from 10 mm to the stops (:attr:`KNOTS`; the profile is 0
    at ``d = 0``, a uniform loss would be the calibrated constants), subtracted
    from the factor; ends of their own (``edge_skew``, ``gain_skew``,
    :meth:`overhang_factor`); and
    ``edge_cog``, the share of the loss the cogging force takes (1: cogging is
    a magnetic force like the others; 0: the teeth's cogging does not see the
    overhang).
    """

    #: Centres [m] of the free profile's B-spline coefficients in ``|d|`` (the same shape at both ends).
    KNOTS: ClassVar[tuple[float, ...]] = _END_KNOTS
    #: Knot spacing [m] of the free profile (a cubic B-spline's support is four of them).
    KNOT_STEP: ClassVar[float] = 0.005

    name = "end_effect"
    params = (
        EffectParam("ripple", 0.03, 0.0, 0.5, "-", "relative thrust ripple with period tau"),
        EffectParam("ripple_phase", 0.0, -math.pi, math.pi, "rad", "phase of the ripple at d = 0"),
        EffectParam("d_edge", 0.04, 0.0, 0.2, "m", "|d| at which the mover starts to overhang the stator"),
        EffectParam("edge_width", 4e-3, 1e-4, 0.05, "m", "smoothing length of the overhang onset"),
        EffectParam("edge_gain", 1.0, 0.0, 5.0, "-", "force lost per overhanging length, relative to geometric"),
        EffectParam("edge_quad", 0.0, -20.0, 20.0, "-", "quadratic term of the loss in the overhang fraction"),
        EffectParam("ripple2", 0.0, 0.0, 0.5, "-", "relative thrust ripple with period tau / 2"),
        EffectParam("ripple2_phase", 0.0, -math.pi, math.pi, "rad", "phase of the second ripple harmonic at d = 0"),
        EffectParam("edge_cog", 1.0, 0.0, 1.0, "-", "share of the overhang loss the cogging force takes"),
        *(
            EffectParam(
                _knot_name(c),
                0.0,
                -1.0,
                1.0,
                "-",
                f"step of the lost force's B-spline coefficient at |d| = {c * 1e3:.0f} mm",
            )
            for c in _END_KNOTS
        ),
        EffectParam("edge_skew", 0.0, -0.05, 0.05, "m", "onset of the overhang loss at d > 0 later (d < 0 earlier)"),
        EffectParam("gain_skew", 0.0, -0.9, 0.9, "-", "loss per overhang at d > 0 times 1 + gain_skew (d < 0: 1 -)"),
    )

    @staticmethod
    def overhang_factor(
        d: Expr, d_edge: Expr, w: Expr, gain: Expr = 1.0, quad: Expr = 0.0, edge_skew: Expr = 0.0, gain_skew: Expr = 0.0
    ) -> Expr:
        """Fraction of the force left as the array overhangs (1 in the middle of the stroke).

        Geometric law (defaults): ``1 - o / (pm tau)``; the law family scales
        the loss (``gain``, fringe fields) and bends it (``quad``):
        ``1 - gain f - quad f^2`` with ``f = o / (pm tau)``; the two ends of a
        stator need not be alike (end teeth, a mover's fixture on one side):
        ``edge_skew`` moves the onset to ``d_edge + edge_skew`` at ``d > 0`` and
        ``d_edge - edge_skew`` at ``d < 0``, ``gain_skew`` scales the loss by
        ``1 +- gain_skew``. The side switch at ``d = 0`` acts where the
        overhang is nil, so the factor stays smooth.
        """
        side = ca.sign(d)
        z = (_smooth_abs(d, 1e-5) - d_edge - side * edge_skew) / w
        softplus = ca.if_else(z > 30, z, ca.log1p(ca.exp(ca.fmin(z, 30))))
        f = w * softplus / (k.pm * k.tau)
        return 1 - gain * (1 + side * gain_skew) * f - quad * f**2

    @classmethod
    def profile_names(cls) -> tuple[str, ...]:
        """Names of the free profile's steps (one per knot, :attr:`KNOTS`), in knot order."""
        return tuple(_knot_name(c) for c in cls.KNOTS)

    @classmethod
    def profile_loss(cls, d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The free profile's loss at ``d`` (0 with the default coefficients).

        ``sum_j c_j (B((d - d_j) / h) + B((-d - d_j) / h))`` with ``B`` the uniform cubic B-spline (support
        ``|t| < 2``, twice continuously differentiable), written with truncated powers of the clamped argument so
        that it is exactly 0 outside its support. The coefficients are cumulative, ``c_j = sum_{i <= j}
        dloss_i``: a step the data do not determine (a knot beyond the stroke the runs visit) stays near 0 and the
        profile keeps its last level there instead of falling back to no loss (P-spline practice, a penalty on
        differences). The shape is shared by both ends: runs that visit one end inform the other (a skew between
        the ends, fitted where the training runs reached one end less far than the held-out runs, extrapolated
        badly: held-out reduction 46 % against 88 % without it).
        """
        coefs = cumulative([theta[_knot_name(c)] for c in cls.KNOTS])
        return sum(bspline(side, cls.KNOTS, cls.KNOT_STEP, coefs) for side in (d, -d))

    def modify(self, terms, x, u, p, theta) -> None:
        d = x[2]
        a = 2 * math.pi * d / k.tau
        ripple = 1 + theta["ripple"] * ca.cos(a + theta["ripple_phase"])
        terms.scale(["a_thrust"], ripple + theta["ripple2"] * ca.cos(2 * a + theta["ripple2_phase"]))
        fac = self.overhang_factor(
            d, theta["d_edge"], theta["edge_width"], theta["edge_gain"], theta["edge_quad"], theta["edge_skew"],
            theta["gain_skew"],
        )  # fmt: skip
        fac = fac - self.profile_loss(d, theta)
        # Cogging comes from the magnets over the teeth; how much of it the overhang takes is a law choice.
        cog = {"a_cogn", "a_cogx", "cog_extra_n", "cog_extra_x"}
        terms.scale(MAGNETIC_TERMS - cog, fac)
        terms.scale(cog, 1 - theta["edge_cog"] * (1 - fac))


class AmplifierLag(Effect):
    """Current amplifier: first-order lag plus a transport delay of whole samples (NOTES.md).

    The applied current follows ``di/dt = 2 pi f_bw (u(t - delay Ts) - i)``
    (0.5-3 kHz bandwidth on typical linear amplifiers). In the plant the two
    applied currents are extra states integrated exactly over each ZOH period
    and the delay is a buffer of ``delay_samples`` commands.
    """

    name = "amplifier_lag"
    dynamic = True
    params = (
        EffectParam("bandwidth_hz", 2000.0, 50.0, 50000.0, "Hz", "-3 dB bandwidth of the current loop"),
        EffectParam("delay_samples", 0, 0, 10, "samples", "transport delay in control periods", integer=True),
    )

    @staticmethod
    def filter_currents(
        u_cmd: np.ndarray, theta: Mapping[str, float], Ts: float = k.Ts, i0: np.ndarray | None = None
    ) -> np.ndarray:
        """Mean applied current over each ZOH period, from the commanded sequence.

        Parameters
        ----------
        u_cmd : ndarray, shape (N, 2)
            Commanded currents; row k is held over ``[k Ts, (k+1) Ts)``.
        theta : mapping
            ``bandwidth_hz`` and ``delay_samples``.
        Ts : float
            Sample period [s].
        i0 : ndarray, shape (2,), optional
            Applied current at t = 0, and the command before it (default: the first command).

        Returns
        -------
        ndarray, shape (N, 2)
            Period-mean applied currents (exact for the first-order lag with ZOH).
        """
        u = np.asarray(u_cmd, dtype=float)
        i = u[0].copy() if i0 is None else np.asarray(i0, float).reshape(2).copy()
        n_del = round(float(theta["delay_samples"]))
        if n_del:
            # before t = 0 the amplifiers were given the current they carried (i0)
            u = np.vstack([np.repeat(i[None, :], n_del, axis=0), u])[: len(u)]
        w = 2 * math.pi * theta["bandwidth_hz"]
        a = math.exp(-w * Ts)
        mean_gain = 1 - (1 - a) / (w * Ts)  # weight of the new command in the period mean
        if len(u) == 0:
            return np.empty_like(u)
        # i[n+1] = a i[n] + (1 - a) u[n] (exact ZOH step), as one IIR filter per channel from i[0] = i
        from scipy.signal import lfilter

        nxt = lfilter([1.0 - a], [1.0, -a], u, axis=0, zi=(a * i)[None, :])[0]
        i_n = np.vstack([i[None, :], nxt[:-1]])
        return i_n + mean_gain * (u - i_n)


#: Centres [m] of the saturation's learned-loss coefficients in g: every 3 mm from 5 mm (below the lower stop, so
#: the spline is not cut there) to 23 mm (the loss vanishes above 29 mm).
_SAT_KNOTS: tuple[float, ...] = tuple(round(0.005 + 0.003 * j, 4) for j in range(7))


class Saturation(Effect):
    """Magnetic saturation of the stator iron at small gaps (NOTES.md).

    The flux density in the teeth grows as the gap shrinks; once the iron
    saturates every magnetic force falls short of the linear model. Modelled
    as a gap-dependent factor on all magnetic terms::

        k_sat(g) = 1 - loss_8mm * (1 + knee) / (knee + exp((g - 8 mm) / ell_sat))

    (``loss_8mm`` is the fractional force loss at the upper stop, g = 8 mm).
    With ``knee = 0`` (the default) the loss decays exponentially with the gap;
    with ``knee > 0`` it is a logistic step (an iron's B-H curve saturates above
    a flux density: little loss above a gap, a steep rise below it) whose knee
    lies at ``g = 8 mm + ell_sat ln(knee)`` and whose width is ``ell_sat``;
    far above the knee both decay as ``exp(-g / ell_sat)``.
    """

    name = "saturation"
    params = (
        EffectParam("loss_8mm", 0.1, 0.0, 0.8, "-", "fractional force loss at g = 8 mm"),
        EffectParam("ell_sat", 3e-3, 2e-4, 0.05, "m", "decay length of the loss with the gap"),
        EffectParam("w_pm", 1.0, -1.0, 3.0, "-", "share of the loss on the PM attraction and cogging"),
        EffectParam("w_id", 1.0, -1.0, 3.0, "-", "share of the loss on the PM-current term (C3)"),
        EffectParam("w_rel", 1.0, -1.0, 3.0, "-", "share of the loss on the reluctance term (C4)"),
        EffectParam("w_thrust", 1.0, -1.0, 3.0, "-", "share of the loss on the thrust (C1)"),
        EffectParam("knee", 0.0, 0.0, 1e4, "-", "logistic knee exp((g_knee - 8 mm) / ell_sat); 0: exponential"),
        *(
            EffectParam(
                f"sloss_{round(c * 1e3):.0f}", 0.0, 0.0, 0.5, "-", f"step of the learned loss at g = {c * 1e3:.0f} mm"
            )
            for c in _SAT_KNOTS
        ),
    )
    #: Centres [m] of the learned loss's B-spline coefficients in g (:meth:`shape_loss`).
    KNOTS: ClassVar[tuple[float, ...]] = _SAT_KNOTS
    #: Knot spacing [m] of the learned loss.
    KNOT_STEP: ClassVar[float] = 0.003
    #: Weight of each magnetic term.
    TERM_WEIGHT: ClassVar[dict[str, str]] = {
        "a_pm": "w_pm",
        "a_cogn": "w_pm",
        "a_cogx": "w_pm",
        "cog_extra_n": "w_pm",
        "cog_extra_x": "w_pm",
        "a_id": "w_id",
        "a_rel": "w_rel",
        "a_thrust": "w_thrust",
    }

    @staticmethod
    def factor(g: Expr, theta: Mapping[str, Expr], weight: Expr = 1.0) -> Expr:
        """Force factor ``k_sat(g)`` (<= 1 for a positive weight, smallest at small gaps)."""
        b = theta["knee"]
        closed = theta["loss_8mm"] * (1 + b) / (b + ca.exp((g - k.g_stop[0]) / theta["ell_sat"]))
        return 1 - weight * (closed + Saturation.shape_loss(g, theta))

    @classmethod
    def shape_names(cls) -> tuple[str, ...]:
        """Names of the learned loss's steps, one per knot (:attr:`KNOTS`), in knot order."""
        return tuple(f"sloss_{round(c * 1e3):.0f}" for c in cls.KNOTS)

    @classmethod
    def shape_loss(cls, g: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The learned loss at gap ``g`` (0 with the default steps), a non-increasing function of g.

        Cubic B-spline in g with coefficients summed from the largest gap down
        (:func:`maglev_ocp.shapes.cumulative_bspline`, ``reverse``): non-negative
        steps make the loss grow monotonically as the gap closes (the iron
        saturates more as the flux density grows), of any shape, and
        nothing above the last knot's support.
        """
        return cumulative_bspline(g, cls.KNOTS, cls.KNOT_STEP, [theta[n] for n in cls.shape_names()], reverse=True)

    def modify(self, terms, x, u, p, theta) -> None:
        for term in sorted(MAGNETIC_TERMS):
            terms.scale([term], self.factor(x[0], theta, theta[self.TERM_WEIGHT[term]]))


class CommutationOffset(Effect):
    """Commutation angle offset (NOTES.md).

    The dq frame the amplifiers commutate in is rotated by ``delta`` against the
    magnets' (seed section III: ``i_d = I_a cos(pi x3 / tau)``, ``i_q = -I_a sin(...)``
    with an encoder offset in x3). The motor carries the commanded currents
    rotated by ``delta``, which mixes thrust and normal force::

        i_q' = cos(delta) i_q - sin(delta) i_d
        i_d' = sin(delta) i_q + cos(delta) i_d

    ``drift`` lets the offset grow along the stroke, ``delta + drift * d`` (a
    commutation encoder whose scale differs from the position encoder's, or
    magnets whose pitch differs from the commutation's); 0 by default.
    """

    name = "commutation_offset"
    params = (
        EffectParam("delta", 0.035, -0.35, 0.35, "rad", "electrical angle offset (at d = 0)"),
        EffectParam("drift", 0.0, -10.0, 10.0, "rad/m", "growth of the offset along the stroke"),
    )

    def currents(self, u, x, theta):
        angle = theta["delta"] + theta["drift"] * x[2]
        c, s = ca.cos(angle), ca.sin(angle)
        return ca.vertcat(c * u[0] - s * u[1], s * u[0] + c * u[1])


def _factor(name: str, what: str, lo: float = 0.5, hi: float = 2.0) -> EffectParam:
    """A dimensionless factor (default 1, range ``[lo, hi]``) on the model's ``what``."""
    return EffectParam(name, 1.0, lo, hi, "-", f"factor on the {what}")


class ParameterError(Effect):
    """Lumped constants and masses off their nominal values (seed eq. (2), Table III).

    ``k_Ci`` multiplies the ``C_i`` term of the model; ``k_Mh`` / ``k_Mv`` scale
    the moving masses, so every force-driven term on that axis is divided by
    them (gravity is not). Applied after the other effects.
    """

    name = "parameter_error"
    params = (
        _factor("k_C1", "thrust term (C1)"),
        _factor("k_C2", "PM attraction term (C2)"),
        _factor("k_C3", "PM-current term (C3)"),
        _factor("k_C4", "reluctance term (C4)", lo=0.0, hi=5.0),
        _factor("k_Mh", "horizontal mass"),
        _factor("k_Mv", "vertical mass"),
    )

    def modify(self, terms, x, u, p, theta) -> None:
        for term, key in (("a_thrust", "k_C1"), ("a_pm", "k_C2"), ("a_id", "k_C3"), ("a_rel", "k_C4")):
            terms.scale([term], theta[key])
        for name in list(terms.vertical):
            if name != "a_grav":
                terms.vertical[name] = terms.vertical[name] / theta["k_Mv"]
        for name in list(terms.horizontal):
            terms.horizontal[name] = terms.horizontal[name] / theta["k_Mh"]


class EddyDrag(Effect):
    """Eddy-current drag in the stator laminations (NOTES.md), optional.

    Moving magnets induce eddy currents whose drag grows with the field
    squared: ``F = -c_eddy B(g)^2 d_dot`` along d (B from MODEL.md).
    """

    name = "eddy_drag"
    params = (EffectParam("c_eddy", 20.0, 0.0, 2000.0, "N s/(m T^2)", "drag coefficient per field squared"),)

    def modify(self, terms, x, u, p, theta) -> None:
        B = get_model().shape(x[0])[2]
        terms.horizontal["eddy"] = -theta["c_eddy"] * B**2 * x[3] / _P(p)["Mh"]


#: Registry of effects, in composition order (current transforms, added forces, scalings, parameter error).
EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (CommutationOffset, AmplifierLag, Cogging, Friction, EddyDrag, Saturation, EndEffect, ParameterError)
}
EFFECT_ORDER: tuple[str, ...] = tuple(EFFECTS)


def effect(name: str) -> type[Effect]:
    """The effect class called ``name`` (KeyError naming the choices otherwise)."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"unknown effect {name!r}; choose from {', '.join(EFFECT_ORDER)}") from None


class EffectSet:
    """A set of effects composed on top of the shared model.

    Parameters
    ----------
    names : iterable of str
        Effect names from :data:`EFFECTS` (any order; duplicates ignored).

    Attributes
    ----------
    effects : tuple of Effect
        Instances in composition order.
    param_names : tuple of str
        ``"<effect>.<param>"`` for every parameter, the order of ``theta``.

    Examples
    --------
    >>> es = EffectSet(["friction", "saturation"])
    >>> theta = es.vector({"friction": {"coulomb_d": 0.3}})   # others at their defaults
    >>> a = es.accel_function()(x, u, p, theta)                 # (g_ddot, d_ddot)
    """

    def __init__(self, names: Iterable[str] = ()):
        wanted = set(names)
        for n in wanted:
            effect(n)
        self.names: tuple[str, ...] = tuple(n for n in EFFECT_ORDER if n in wanted)
        self.effects: tuple[Effect, ...] = tuple(EFFECTS[n]() for n in self.names)
        self.param_names: tuple[str, ...] = tuple(f"{e.name}.{q}" for e in self.effects for q in e.param_names())
        self.n_theta = len(self.param_names)

    @property
    def has_lag(self) -> bool:
        """True if the amplifier lag is in the set (the plant then carries current states)."""
        return "amplifier_lag" in self.names

    def defaults(self) -> np.ndarray:
        """``theta`` with every parameter at its default."""
        return np.array([q.default for e in self.effects for q in e.params], dtype=float)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper physical bounds of ``theta``."""
        lo = np.array([q.lo for e in self.effects for q in e.params], dtype=float)
        hi = np.array([q.hi for e in self.effects for q in e.params], dtype=float)
        return lo, hi

    def vector(self, values: Mapping[str, Mapping[str, float]] | None = None) -> np.ndarray:
        """Build ``theta`` from ``{effect: {param: value}}``; missing entries take their defaults."""
        values = dict(values or {})
        unknown = set(values) - set(self.names)
        if unknown:
            raise KeyError(f"effects {sorted(unknown)} are not in this set {self.names}")
        out = []
        for e in self.effects:
            given = dict(values.get(e.name, {}))
            bad = set(given) - set(e.param_names())
            if bad:
                raise KeyError(f"effect {e.name!r} has no parameters {sorted(bad)}; it has {e.param_names()}")
            out.extend(float(given.get(q.name, q.default)) for q in e.params)
        return np.array(out, dtype=float)

    def split(self, theta: Expr | Sequence[float]) -> dict[str, dict[str, Expr]]:
        """``theta`` as ``{effect: {param: value}}`` (symbolic or numeric)."""
        if isinstance(theta, (ca.SX, ca.MX, ca.DM)):
            items = ca.vertsplit(theta) if self.n_theta else []
        else:
            items = list(np.asarray(theta, dtype=float).ravel())
        if len(items) != self.n_theta:
            raise ValueError(f"theta has {len(items)} entries, this effect set needs {self.n_theta}")
        out: dict[str, dict[str, Expr]] = {}
        i = 0
        for e in self.effects:
            out[e.name] = {}
            for q in e.params:
                out[e.name][q.name] = items[i]
                i += 1
        return out

    def terms(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Terms:
        """All acceleration terms with the effects applied (``u``: amplifier output currents)."""
        th = self.split(theta)
        for e in self.effects:
            u = e.currents(u, x, th[e.name])
        parts = get_model().accel_terms(x, u, p)
        names = (*VERTICAL_MODEL_TERMS, *HORIZONTAL_MODEL_TERMS)
        t = dict(zip(names, parts, strict=True))
        terms = Terms(
            vertical={n: t[n] for n in VERTICAL_MODEL_TERMS}, horizontal={n: t[n] for n in HORIZONTAL_MODEL_TERMS}
        )
        for e in self.effects:
            e.modify(terms, x, u, p, th[e.name])
        return terms

    def accel(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Expr:
        """Modified accelerations ``(g_ddot, d_ddot)`` as a 2-vector expression.

        Parameters
        ----------
        x : SX/MX (4)
            State ``(g, g_dot, d, d_dot)``.
        u : SX/MX (2)
            Currents the amplifiers deliver (after any lag).
        p : SX/MX (8)
            Model parameter vector.
        theta : SX/MX (n_theta)
            Effect parameters in :attr:`param_names` order.
        """
        terms = self.terms(x, u, p, theta)
        return ca.vertcat(terms.g_ddot(), terms.d_ddot())

    def x_dot(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Expr:
        """Continuous dynamics with the effects: ``(g_dot, g_ddot, d_dot, d_ddot)``."""
        a = self.accel(x, u, p, theta)
        return ca.vertcat(x[1], a[0], x[3], a[1])

    def accel_function(self) -> ca.Function:
        """Cached CasADi Function ``accel_<names>(x, u, p, theta) -> a`` (a = (g_ddot, d_ddot))."""
        return _accel_function(self.names)


@functools.lru_cache(maxsize=64)
def _accel_function(names: tuple[str, ...]) -> ca.Function:
    es = EffectSet(names)
    m = get_model()
    theta = ca.SX.sym("theta", es.n_theta)
    a = es.accel(m.x, m.u, m.p, theta)
    label = "_".join(names) or "none"
    return ca.Function(f"accel_{label}", [m.x, m.u, m.p, theta], [a], ["x", "u", "p", "theta"], ["a"])


@functools.lru_cache(maxsize=32)
def effect_delta_function(names: tuple[str, ...]) -> ca.Function:
    """``effect_delta(x, u, p, theta) -> (dg_ddot, dd_ddot)``: what the effects add to the model's accelerations.

    The effect library's accelerations (currents transformed, terms scaled,
    forces added, :meth:`EffectSet.accel`) minus the shared model's at the
    same state and currents: how a controller's model file
    (:mod:`maglev_ocp.controllers.model_file`) and the reference planner
    (:mod:`maglev_ocp.reference`) add fitted effects to the shared model.
    """
    m = get_model()
    es = EffectSet(names)
    x, u, p = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("p", m.np_)
    theta = ca.SX.sym("theta", es.n_theta)
    f = m.f(x, u, p)
    delta = es.accel(x, u, p, theta) - ca.vertcat(f[1], f[3])
    return ca.Function("effect_delta", [x, u, p, theta], [delta], ["x", "u", "p", "theta"], ["delta"])


__all__ = [
    "EFFECTS",
    "EFFECT_ORDER",
    "MAGNETIC_TERMS",
    "AmplifierLag",
    "Cogging",
    "CommutationOffset",
    "EddyDrag",
    "Effect",
    "EffectParam",
    "EffectSet",
    "EndEffect",
    "Friction",
    "ParameterError",
    "Saturation",
    "Terms",
    "effect",
    "effect_delta_function",
]
