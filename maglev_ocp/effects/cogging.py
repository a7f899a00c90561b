"""Cogging beyond the spec's law (:class:`Cogging`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from ..shapes import fourier
from .base import _P, Effect, EffectParam, Expr, _abs0

#: Slot harmonics of the learned cogging (:meth:`Cogging.learned_forces`): periods t1 / k, k = 1..K.
_COG_K = 4


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

    Learned shape (flexible member, :meth:`learned_forces`): Fourier series of
    harmonics ``k = 1..K`` of the slot pitch (phase ``2 pi d / t1``, periods
    ``t1 / k``, the periods of the cogging signature in
    :mod:`maglev_ocp.diagnosis.signatures`; the seed's own law, period ``2 t1``,
    stays in ``p``), tangential and normal parts with coefficients of their own
    [N at g = 10 mm], times a positive amplitude ``A(g) = exp(a1 z + a2 z^2)``,
    ``z = (g - g_ref) / g_ref`` (an exponential decay is ``a1 = -g_ref / ell``,
    a power law is close to a quadratic in ``z``). Zero coefficients (the
    default) add nothing.
    """

    #: Number of slot harmonics of the learned shape.
    HARMONICS: ClassVar[int] = _COG_K

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
        EffectParam("cog_a1", 0.0, -30.0, 10.0, "-", "learned amplitude's log-slope in (g - g_ref) / g_ref"),
        EffectParam("cog_a2", 0.0, -30.0, 30.0, "-", "learned amplitude's log-curvature in (g - g_ref) / g_ref"),
        *(
            EffectParam(
                f"cog_{part}{trig}{j}", 0.0, -20.0, 20.0, "N", f"learned {what} cogging, {trig}({2 * j} pi d/t1)"
            )
            for part, what in (("x", "tangential"), ("n", "normal"))
            for trig in ("cos", "sin")
            for j in range(1, _COG_K + 1)
        ),
    )

    @classmethod
    def shape_names(cls, part: str, trig: str) -> tuple[str, ...]:
        """Names of the learned coefficients of ``part`` (``"x"`` tangential, ``"n"`` normal), ``"cos"``/``"sin"``."""
        return tuple(f"cog_{part}{trig}{j}" for j in range(1, cls.HARMONICS + 1))

    @classmethod
    def learned_forces(cls, g: Expr, d: Expr, theta: Mapping[str, Expr]) -> tuple[Expr, Expr]:
        """The learned shape's tangential and normal forces ``(Fx, Fn)`` [N] (0 with the default coefficients; a
        ``theta`` written before the learned shape existed, without its keys, means zero coefficients)."""
        z = (g - k.g_cog_ref) / k.g_cog_ref
        amp = ca.exp(theta.get("cog_a1", 0.0) * z + theta.get("cog_a2", 0.0) * z**2)
        phase = 2 * math.pi * d / k.t1
        parts = []
        for part in ("x", "n"):
            cos_c = [theta.get(n, 0.0) for n in cls.shape_names(part, "cos")]
            sin_c = [theta.get(n, 0.0) for n in cls.shape_names(part, "sin")]
            parts.append(amp * fourier(phase, cos_c, sin_c))
        return parts[0], parts[1]

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
        Lx, Ln = self.learned_forces(g, d, theta)
        return Fx + Lx, Fn + Ln

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        Fx, Fn = self.forces(x[0], x[2], theta)
        terms.vertical["cog_extra_n"] = -Fn / P["Mv"]
        terms.horizontal["cog_extra_x"] = Fx / P["Mh"]
