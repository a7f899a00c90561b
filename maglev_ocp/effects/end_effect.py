"""End effects of the short stator / mover (:class:`EndEffect`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from ..shapes import bspline, cumulative
from .base import _P, MAGNETIC_TERMS, Effect, EffectParam, Expr, _smooth_abs

#: Centres [m] of the end effect's free-profile coefficients in |d|: every 5 mm from 10 mm to the stops.
_END_KNOTS: tuple[float, ...] = tuple(round(0.01 + 0.005 * j, 4) for j in range(11))


#: Gap at which the end force's size is given [m] (the model's nominal gap, MODEL.md).
_G_END_REF = 10e-3


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

    * an **end force** (``end_force``, 0 by default): the co-energy of the magnets over the stator iron falls
      with the overlap, so an overhanging array is pulled back, ``F_d = -dW/dd`` (virtual work; Furlani,
      *Permanent Magnet and Electromechanical Devices*, 2001, ch. 4; the end detent force of PM linear motors,
      Zhu, Xia, Shi et al., IEEE Trans. Magn. 2009): a force along ``-sign(d)`` that rises with the same smooth
      onset as the loss (its derivative: the logistic of the overhang argument, each end with its own onset and
      size through ``edge_skew`` and ``gain_skew``) to ``end_force`` at ``g = 10 mm``, falling as the gap opens
      with ``end_ell``. The loss of the vertical pull is the same co-energy's ``-dW/dg``, already the factor.
    * a **winding end force** (``end_i2``, 0 by default): the armature's own inductance changes where the mover's
      back iron leaves the winding at a stator end, and the co-energy ``(1/2) L(d) (3/2) |i|^2`` of the three
      phases pulls along d with ``F_d = (3/4) |i|^2 dL/dd`` (Fitzgerald, Kingsley & Umans, *Electric
      Machinery*, 6th ed., 2003, ch. 3; the armature-reaction part of a PMLSM's end force, Gieras, Piech &
      Tomczuk, *Linear Synchronous Motors*, 2nd ed., 2011): a force quadratic in the currents, localized at each
      end with the same onset as the loss, ``-sign(d) end_i2 |i|^2 s(z) (1 + sign(d) gain_skew)`` (signed:
      the inductance may fall or rise over the end).

    Law family (all extra parameters default to the geometric law above): a
    second ripple harmonic ``ripple2 cos(4 pi d / tau + ripple2_phase)``; a
    free overhang profile, a cubic B-spline in ``|d|`` with knots every
    :attr:`KNOT_STEP` from 10 mm to the stops (:attr:`KNOTS`; the profile is 0
    at ``d = 0``, a uniform loss would be the calibrated constants), subtracted
    from the factor; ends of their own (``edge_skew``, ``gain_skew``,
    :meth:`overhang_factor`); and
    ``edge_cog``, the share of the loss the cogging force takes (1: cogging is
    a magnetic force like the others; 0: the teeth's cogging does not see the
    overhang); ``edge_pm``, the share the magnets' pull takes (1: the field over the
    iron is lost with the overlap; 0: only the currents' linkage is lost at the ends,
    the iron and its pull whole: the end coils of a winding, a double-layer winding's
    half-filled end slots, Pyrhonen, Jokinen & Hrabovcova, *Design of Rotating
    Electrical Machines*, 2nd ed., 2014, ch. 2).
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
        EffectParam("edge_pm", 1.0, 0.0, 1.0, "-", "share of the overhang loss the magnets' pull takes"),
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
        EffectParam("end_force", 0.0, 0.0, 20.0, "N", "restoring end force once the array overhangs, at g = 10 mm"),
        EffectParam("end_ell", 5e-3, 1e-3, 0.05, "m", "decay length of the end force in the gap"),
        EffectParam("end_i2", 0.0, -1.0, 1.0, "N/A^2", "winding end force per squared current, where it overhangs"),
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
    def end_force_x(cls, d: Expr, g: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The end force along ``d`` [N] (0 with ``end_force = 0``): ``-sign(d) F_end exp(-(g - 10 mm) / end_ell)
        s(z) (1 + sign(d) gain_skew)`` with ``s`` the logistic of the overhang argument of :meth:`overhang_factor`
        (the derivative of its softplus: the end force is where the overlap changes)."""
        side = ca.sign(d)
        onset = cls.onset(d, theta)
        decay = ca.exp(-(g - _G_END_REF) / theta["end_ell"])
        return -side * theta["end_force"] * decay * onset * (1 + side * theta["gain_skew"])

    @staticmethod
    def onset(d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The logistic onset of the overhang at ``d`` (0 inside the stator, 1 once the array overhangs), the
        derivative of :meth:`overhang_factor`'s softplus: where the overlap changes."""
        side = ca.sign(d)
        z = (_smooth_abs(d, 1e-5) - theta["d_edge"] - side * theta["edge_skew"]) / theta["edge_width"]
        return 1 / (1 + ca.exp(-ca.fmax(ca.fmin(z, 30), -30)))

    @classmethod
    def winding_force_x(cls, d: Expr, i_q: Expr, i_d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The winding end force along ``d`` [N] (0 with ``end_i2 = 0``): ``-sign(d) end_i2 (i_q^2 + i_d^2)
        s(z) (1 + sign(d) gain_skew)``, the co-energy of the winding's inductance at the stator's ends."""
        side = ca.sign(d)
        i2 = i_q**2 + i_d**2
        return -side * theta["end_i2"] * i2 * cls.onset(d, theta) * (1 + side * theta["gain_skew"])

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

    @classmethod
    def force_factor(cls, d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Fraction of the magnetic terms left at ``d`` (1 in the middle of the stroke): the overhang factor
        (:meth:`overhang_factor`) less the free profile's loss (:meth:`profile_loss`)."""
        fac = cls.overhang_factor(
            d, theta["d_edge"], theta["edge_width"], theta["edge_gain"], theta["edge_quad"], theta["edge_skew"],
            theta["gain_skew"],
        )  # fmt: skip
        return fac - cls.profile_loss(d, theta)

    def modify(self, terms, x, u, p, theta) -> None:
        d = x[2]
        a = 2 * math.pi * d / k.tau
        ripple = 1 + theta["ripple"] * ca.cos(a + theta["ripple_phase"])
        terms.scale(["a_thrust"], ripple + theta["ripple2"] * ca.cos(2 * a + theta["ripple2_phase"]))
        fac = self.force_factor(d, theta)
        # Cogging comes from the magnets over the teeth; how much of it the overhang takes is a law choice.
        cog = {"a_cogn", "a_cogx", "cog_extra_n", "cog_extra_x"}
        terms.scale(MAGNETIC_TERMS - cog - {"a_pm"}, fac)
        terms.scale(cog, 1 - theta["edge_cog"] * (1 - fac))
        # The magnets' pull (B^2) is lost with the field over the iron; the currents' terms with the winding's
        # linkage, which the ends of a winding lose on their own (edge_pm < 1: the pull keeps its share).
        terms.scale({"a_pm"}, 1 - theta["edge_pm"] * (1 - fac))
        # The end force: the overlap's co-energy pulled along d (a magnetic force, which a saturation scales).
        terms.horizontal["end_x"] = self.end_force_x(d, x[0], theta) / _P(p)["Mh"]
        # The winding's end force: the currents' own co-energy, not the magnets' (no saturation of the field
        # scales it; a separate term).
        terms.horizontal["end_i2"] = self.winding_force_x(d, u[0], u[1], theta) / _P(p)["Mh"]
