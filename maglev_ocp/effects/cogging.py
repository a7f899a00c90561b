"""Cogging beyond the spec's law (:class:`Cogging`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from .base import _P, Effect, EffectParam, Expr, _abs0

#: Period of the co-energy shape [m]: seed eq. (9)'s ``2 t1`` (its tangential law is ``sin(pi d / t1)``), so that
#: harmonic ``k`` has period ``2 t1 / k``: the slot pitch ``t1`` itself is ``k = 2`` (MODEL.md, Table I).
ENERGY_PERIOD: float = 2 * k.t1
#: Harmonics of the co-energy shape (periods ``2 t1 / k``, k = 1..6: the slot pitch ``t1`` and its 2nd and 3rd
#: harmonics are k = 2, 4, 6).
_ENERGY_K = 6
#: Period of the pole-pair co-energy [m]: the magnet array's own period ``2 tau`` (a pole pair, MODEL.md Table I),
#: so that its harmonics ``k = 1, 2`` have periods ``2 tau`` and ``tau`` (the 3rd, ``2 tau / 3 = 2 t1``, is the
#: slot co-energy's fundamental and is left to it).
POLE_PERIOD: float = 2 * k.tau
#: Harmonics of the pole-pair co-energy.
_POLE_K = 2
#: Gap at which the co-energy shape's amplitudes are referred [m]: the centre of the tracking envelope (MODEL.md),
#: inside the gaps a rig visits, so that a fast-decaying harmonic is not extrapolated far to be referred.
G_ENERGY_REF: float = 0.5 * (k.g_envelope[0] + k.g_envelope[1])
#: Physical range of each harmonic's gap-decay rate, relative to its wavenumber ``q_k = 2 pi k / (2 t1)``. A field
#: harmonic between two iron surfaces decays as ``exp(-q_k g)`` (the Laplace solution, rate 1) and the force it
#: makes with the magnets' field as up to its square (rate 2); the magnet's load line and the slot-opening
#: permeance (Zhu & Howe 1993) slow or speed that by a factor of a few (a power law ``g^-n`` is ``n / (q_k g)``).
ENERGY_DECAY_RANGE: tuple[float, float] = (0.1, 3.0)


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

    Learned shape (flexible member, :meth:`energy_forces`): the cogging's own physical signature with a shape
    learned inside it. Cogging is the force of the magnets' stored field energy ``W(d, g)`` as the mover's
    magnets pass the stator slots (the slot-permeance / energy method: Zhu & Howe, "Analytical prediction of
    the cogging torque in radial-field permanent magnet brushless motors", IEEE Trans. Magn. 28(2), 1992;
    Bianchi & Bolognani, "Design techniques for reducing the cogging torque in surface-mounted PM motors",
    IEEE Trans. Ind. Appl. 38(5), 2002)::

        W(d, g) = sum_k (A_k(g) / q_k) (c_k cos(q_k d) + s_k sin(q_k d)),  q_k = 2 pi k / (2 t1),  k = 1..K
        A_k(g)  = exp(-rho_k q_k (g - g_e) - curv ((g - g_e) / g_e)^2)          (A_k(g_e) = 1, g_e = 20 mm)
        Fx      = -dW/dd = sum_k A_k(g) (c_k sin(q_k d) - s_k cos(q_k d))       (tangential, along +d)
        F_g     = -dW/dg,  Fn = -F_g                                            (normal, Fn > 0 closes the gap)

    so that the tangential and the normal parts are linked (one co-energy: the normal part of harmonic ``k``
    is its tangential part shifted by a quarter period and scaled by its decay rate over ``q_k``), and each
    harmonic's amplitude decays with the gap at a rate of its own within :data:`ENERGY_DECAY_RANGE` times
    ``q_k``: the ``k``-th harmonic of the gap field decays as ``exp(-q_k g)`` between iron surfaces, so higher
    harmonics fall off faster. Skewed magnets multiply harmonic ``k`` by a skew factor (a sinc of ``k`` times
    the skew; Islam, Mir & Sebastian, IEEE Trans. Ind. Appl. 40(3), 2004): the same family with other
    ``c_k, s_k``. ``curv`` bends every log-amplitude alike (a power law ``g^-n`` is ``curv ~ -n / 2``).
    There is no term independent of ``d``: the shape is periodic with zero mean in ``d`` at every gap, and
    no velocity enters it, so it can take up neither friction (odd in the velocities) nor an end effect (not
    periodic) nor a change of the magnetic forces' gap law. The seed's own law (eq. (9), ``xi0``, ``ell`` in
    ``p``) stays in the model; zero coefficients (the default) add nothing.

    Pole-pair co-energy (in :meth:`energy_forces`): the same co-energy at the magnet array's own period ``2 tau``
    (harmonics 1 and 2: periods ``2 tau`` and ``tau``), each harmonic decaying with the gap at a rate of its own
    within :data:`ENERGY_DECAY_RANGE` times its wavenumber (the array's fundamental decays as ``exp(-pi g /
    tau)``). A stator whose slots are all alike pulls on every magnet alike and its cogging has the slot pitch's
    period; a stator that is not uniform (slots or teeth of unequal width, a tooth's remanent magnetization, a
    lamination stack's joint) pulls on each pole of the array in turn, so its cogging has the array's period
    (Gasparin, Cernigoj, Fiser & Zhu, "Additional cogging torque components in permanent-magnet motors due to
    manufacturing imperfections", IEEE Trans. Magn. 45(3), 2009: stator imperfections add cogging harmonics at
    multiples of the pole number, magnet imperfections at multiples of the slot number). Over a stroke shorter
    than ``2 tau`` it is a smooth detent along ``d`` (a pull towards a position) with its normal part, still one
    co-energy: the tangential and normal parts are linked as above, so a spring, a cable or a tilt (no normal
    part that goes with them) are not its.
    """

    #: Number of harmonics of the co-energy shape.
    HARMONICS: ClassVar[int] = _ENERGY_K

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
        EffectParam("e_curv", 0.0, -4.0, 1.0, "-", "co-energy shape: log-amplitude curvature in (g - g_e) / g_e"),
        *(
            p
            for j in range(1, _ENERGY_K + 1)
            for p in (
                EffectParam(f"e_c{j}", 0.0, -20.0, 20.0, "N", f"co-energy shape: cos({j} q1 d) term of W, N at g_e"),
                EffectParam(f"e_s{j}", 0.0, -20.0, 20.0, "N", f"co-energy shape: sin({j} q1 d) term of W, N at g_e"),
                EffectParam(f"e_r{j}", 1.0, *ENERGY_DECAY_RANGE, "-", f"co-energy shape: harmonic {j}'s decay / q_{j}"),
            )
        ),
        *(
            p
            for j in range(1, _POLE_K + 1)
            for p in (
                EffectParam(f"e_pc{j}", 0.0, -20.0, 20.0, "N", f"pole-pair co-energy: cos({j} pi d / tau), N at g_e"),
                EffectParam(f"e_ps{j}", 0.0, -20.0, 20.0, "N", f"pole-pair co-energy: sin({j} pi d / tau), N at g_e"),
                EffectParam(f"e_pr{j}", 1.0, *ENERGY_DECAY_RANGE, "-", f"pole-pair co-energy: harmonic {j}'s decay"),
            )
        ),
    )

    @staticmethod
    def _waves(prefix: str, n: int, period: float) -> list[tuple[str, str, str, float]]:
        """Per harmonic ``k = 1..n`` of ``period``: the names of its ``c_k, s_k, rho_k`` and ``k / period`` [1/m]."""
        return [(f"{prefix}c{j}", f"{prefix}s{j}", f"{prefix}r{j}", j / period) for j in range(1, n + 1)]

    @classmethod
    def energy_names(cls, harmonics: int | None = None) -> tuple[str, ...]:
        """Names of the co-energy shape's coefficients ``c_k, s_k, rho_k`` of harmonics ``1..harmonics``."""
        n = cls.HARMONICS if harmonics is None else harmonics
        return tuple(name for w in cls._waves("e_", n, ENERGY_PERIOD) for name in w[:3])

    @classmethod
    def pole_names(cls) -> tuple[str, ...]:
        """Names of the pole-pair co-energy's coefficients ``c_k, s_k, rho_k`` (harmonics of ``2 tau``)."""
        return tuple(name for w in cls._waves("e_p", _POLE_K, POLE_PERIOD) for name in w[:3])

    @classmethod
    def energy_forces(cls, g: Expr, d: Expr, theta: Mapping[str, Expr]) -> tuple[Expr, Expr]:
        """The co-energy shape's tangential and normal forces ``(Fx, Fn)`` [N], ``-dW/dd`` and ``dW/dg`` (class
        docstring; 0 with the default coefficients, and for a ``theta`` written before the shape existed): the
        slot co-energy's harmonics of ``2 t1`` and the pole-pair co-energy's of ``2 tau``."""
        z = g - G_ENERGY_REF
        curv = theta.get("e_curv", 0.0)
        fx: Expr = 0.0
        fn: Expr = 0.0
        waves = cls._waves("e_", cls.HARMONICS, ENERGY_PERIOD) + cls._waves("e_p", _POLE_K, POLE_PERIOD)
        for kc, ks, kr, per in waves:
            c, s = theta.get(kc, 0.0), theta.get(ks, 0.0)
            if isinstance(c, float) and isinstance(s, float) and c == 0.0 and s == 0.0:
                continue  # numeric zeros (a member that does not free this harmonic): a term of exactly 0, not built
            q = 2 * math.pi * per
            rate = theta.get(kr, 1.0) * q
            amp = ca.exp(-rate * z - curv * (z / G_ENERGY_REF) ** 2)
            dlog = -rate - 2 * curv * z / G_ENERGY_REF**2  # d ln A_k / dg
            cq, sq = ca.cos(q * d), ca.sin(q * d)
            fx = fx + amp * (c * sq - s * cq)  # -dW_k/dd
            fn = fn + dlog * amp / q * (c * cq + s * sq)  # dW_k/dg: attraction (Fn > 0) where W grows with g
        return fx, fn

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
        Ex, En = self.energy_forces(g, d, theta)
        return Fx + Ex, Fn + En

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        Fx, Fn = self.forces(x[0], x[2], theta)
        terms.vertical["cog_extra_n"] = -Fn / P["Mv"]
        terms.horizontal["cog_extra_x"] = Fx / P["Mh"]
