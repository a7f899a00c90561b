"""Friction of the linear guides (:class:`Friction`)."""

from __future__ import annotations

from collections.abc import Mapping

import casadi as ca

from .. import constants as k
from .base import _P, Effect, EffectParam, Expr


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
