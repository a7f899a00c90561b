"""Friction of the linear guides (:class:`Friction`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import casadi as ca
import numpy as np

from .. import constants as k
from ..shapes import bspline
from .base import _P, Effect, EffectParam, Expr

#: Centres of the learned friction profile's B-spline in the warped speed ``s = |v| / (|v| + v0)`` (0 at rest, 1
#: at infinite speed): uniform in ``s``, so the knots are dense at the low speeds where Stribeck and pre-sliding
#: friction change and span any velocity range a run visits (``s = 0.5`` at ``|v| = v0``).
_FRIC_KNOTS: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
#: Gap [m] at which a load-dependent friction has its nominal levels (the middle of the 15..25 mm envelope).
_G_LOAD_REF: float = 20e-3
#: Gap [m] of the lower stop's side (8 mm) below the reference: the largest load factor the stiffness bound uses.
_LOAD_SPAN: float = 12e-3


class Friction(Effect):
    """Friction of the linear guides: Coulomb + viscous + Stribeck, per axis (NOTES.md).

    Seed section III lists friction among the unmodelled effects. The force on
    an axis with velocity ``v`` is::

        F = -[(Fc + Fs exp(-(v / v_s)^2)) tanh(v / v_reg) + b v]

    ``tanh`` regularizes the sign function so that the dynamics stay smooth
    (and differentiable for the diagnosis NLP); ``Fs`` is the static excess
    (breakaway force minus Coulomb force).

    Learned profile (flexible member): the magnitude gains a cubic B-spline in
    the warped speed ``s = |v| / (|v| + v0)`` (:attr:`KNOTS`, :attr:`V0`) with
    non-negative coefficients ``fshape_<axis>_<j>`` [N], so the force is an odd
    function of the velocity whose magnitude ``h(|v|) = Fc + Fs exp(-(v/v_s)^2)
    + b |v| + sum_j c_j B((s - s_j) / ds) >= 0`` may take any smooth shape
    (a Stribeck dip of any exponent, a friction that levels off); with all
    ``c_j = 0`` (the default) it is the closed-form law, which it nests.

    Direction (``dir_<axis>`` [N], 0 by default): a seal lip or a preloaded wiper rubs harder in one sliding
    direction than in the other (Muller & Nau, *Fluid Sealing Technology*, 1998; direction-dependent friction,
    Armstrong-Helouvry, Dupont & Canudas de Wit, Automatica 30(7), 1994). The force gains ``-dir tanh(v /
    v_reg)^2``, even in the velocity and nil at rest: the levels moving forward and backward are ``Fc + dir``
    and ``Fc - dir``. Not constrained to ``|dir| <= Fc`` (the bounds are physical sizes; a fit that breaks
    dissipation shows in its value).

    Load (``load_<axis>`` [1/m], 0 by default): dry friction is proportional to the normal load on the contact
    (Amontons-Coulomb; rolling friction too: Johnson, *Contact Mechanics*, 1985, ch. 8), and on a levitated stage
    the load on a guide may follow the gap: a spring-preloaded roller compressed as the mover rises, a guide
    taking a share of a pull that grows as the gap closes. The dry part (Coulomb, Stribeck, the learned profile,
    the directional level) is scaled by ``exp(load (g_ref - g))``, ``g_ref`` = 20 mm (:data:`_G_LOAD_REF`): a
    positive ``load`` rubs harder as the gap closes. The viscous part (the lubricant's shear) is not.
    """

    #: Centres of the learned profile's B-spline in the warped speed ``s`` (:data:`_FRIC_KNOTS`).
    KNOTS: ClassVar[tuple[float, ...]] = _FRIC_KNOTS
    #: Knot spacing in ``s``.
    KNOT_STEP: ClassVar[float] = 0.25
    #: Speed [m/s] at which the warped speed is 1/2 (the middle knot): the guides' Stribeck velocities are a
    #: few mm/s (Armstrong-Helouvry et al., Automatica 30(7), 1994).
    V0: ClassVar[float] = 5e-3

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
        EffectParam("dir_g", 0.0, -10.0, 10.0, "N", "directional friction, vertical (forward level minus Coulomb)"),
        EffectParam("dir_d", 0.0, -10.0, 10.0, "N", "directional friction, horizontal (forward level minus Coulomb)"),
        EffectParam("load_g", 0.0, -80.0, 80.0, "1/m", "dry friction load rate, vertical guide"),
        EffectParam("load_d", 0.0, -80.0, 80.0, "1/m", "dry friction load rate, horizontal guide"),
        *(
            EffectParam(f"fshape_{ax}_{j}", 0.0, 0.0, 10.0, "N", f"learned friction coefficient {j}, axis {ax}")
            for ax in ("g", "d")
            for j in range(len(_FRIC_KNOTS))
        ),
    )

    @classmethod
    def shape_names(cls, axis: str) -> tuple[str, ...]:
        """Names of the learned profile's coefficients of ``axis`` (``"g"`` or ``"d"``), in knot order."""
        return tuple(f"fshape_{axis}_{j}" for j in range(len(cls.KNOTS)))

    @classmethod
    def shape_force(cls, v: Expr, coefs: list[Expr], v_reg: Expr) -> Expr:
        """The learned profile's part of the friction force [N] at velocity ``v`` (0 with zero coefficients).

        ``-tanh(v / v_reg) sum_j c_j B((s - s_j) / ds)`` with ``s = |v| / (|v| + V0)``; ``|v|`` is smoothed at
        ``v_reg`` like the sign, so the force stays smooth and odd.
        """
        speed = ca.sqrt(v**2 + v_reg**2) - v_reg
        s = speed / (speed + cls.V0)
        return -ca.tanh(v / v_reg) * bspline(s, cls.KNOTS, cls.KNOT_STEP, coefs)

    @classmethod
    def axis_force(cls, v: Expr, theta: Mapping[str, Expr], axis: str, g: Expr | None = None) -> Expr:
        """The whole friction force [N] of ``axis`` at velocity ``v``: closed-form law plus the learned profile,
        its dry part scaled by the load factor at gap ``g`` (:meth:`load_factor`; ``None``: the reference gap)."""
        t = theta
        dry = cls.force(v, t[f"coulomb_{axis}"], t[f"stribeck_{axis}"], 0.0, t["v_stribeck"], t["v_reg"])
        dry = dry + cls.shape_force(v, [t.get(n, 0.0) for n in cls.shape_names(axis)], t["v_reg"])
        dry = dry - t.get(f"dir_{axis}", 0.0) * ca.tanh(v / t["v_reg"]) ** 2
        if g is not None:
            dry = dry * cls.load_factor(g, t.get(f"load_{axis}", 0.0))
        return dry - t[f"viscous_{axis}"] * v

    @staticmethod
    def load_factor(g: Expr, load: Expr) -> Expr:
        """The dry friction's scale at gap ``g`` [m]: ``exp(load (g_ref - g))``, 1 at ``g_ref`` = 20 mm."""
        return ca.exp(load * (_G_LOAD_REF - g))

    @staticmethod
    def force(v: Expr, Fc: Expr, Fs: Expr, b: Expr, v_s: Expr, v_reg: Expr) -> Expr:
        """Friction force [N] at velocity ``v`` [m/s] (opposes the motion)."""
        return -((Fc + Fs * ca.exp(-((v / v_s) ** 2))) * ca.tanh(v / v_reg) + b * v)

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        terms.vertical["friction_g"] = self.axis_force(x[1], theta, "g", x[0]) / P["Mv"]
        terms.horizontal["friction_d"] = self.axis_force(x[3], theta, "d", x[0]) / P["Mh"]

    @staticmethod
    def stiffness(theta: Mapping[str, float], Mh: float = k.Mh, Mv: float = k.Mv) -> float:
        """Largest ``|d a / d v|`` [1/s] of the friction law (for the integrator's stability check)."""
        worst = 0.0
        for ax, M in (("g", Mv), ("d", Mh)):
            # the learned profile: at most sum c_j in size, slope at most sum c_j max|B'| / ds / V0 (max|B'| = 1/2)
            c = sum(abs(theta.get(n, 0.0)) for n in Friction.shape_names(ax))
            peak = theta[f"coulomb_{ax}"] + theta[f"stribeck_{ax}"] + c + abs(theta.get(f"dir_{ax}", 0.0))
            # the dry part at its largest load over the gaps the stage reaches
            load = float(np.exp(abs(theta.get(f"load_{ax}", 0.0)) * _LOAD_SPAN))
            s = load * (peak / theta["v_reg"] + c * 0.5 / Friction.KNOT_STEP / Friction.V0) + theta[f"viscous_{ax}"]
            worst = max(worst, s / M)
        return worst
