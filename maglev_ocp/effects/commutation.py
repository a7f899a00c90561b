"""Commutation angle offset (:class:`CommutationOffset`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from ..shapes import bspline
from .base import Effect, EffectParam, Expr

#: Centres [m] of the learned offset's B-spline in d: every 30 mm from -90 to 90 mm, so that on the stroke
#: (+-60 mm) the basis sums to one and reproduces a constant and a linear drift exactly (de Boor, ch. IX).
_COMM_KNOTS: tuple[float, ...] = tuple(round(-0.09 + 0.03 * j, 3) for j in range(7))

#: Gap [m] at which the electrical harmonics' amplitudes are given (the middle of the targets' gap band).
_G_HARM_REF = 20e-3


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

    Learned shape (flexible member): a cubic B-spline in ``d`` added to the
    angle (:attr:`KNOTS`, coefficients ``cshape_<j>`` [rad]), which nests the
    constant and the drift exactly on the stroke (a commutation pitch error
    that is not uniform, an encoder scale that wanders). 0 by default.

    Electrical harmonics (``harm1_c``, ``harm1_s``, ``harm2_c``, ``harm2_s`` [rad], ``harm_gap`` [1/m]; 0 by
    default): an angle error periodic in the electrical angle ``theta_e = pi d / tau`` (seed section III),
    ``exp(harm_gap (g - 20 mm)) sum_k (harmk_c cos k theta_e + harmk_s sin k theta_e)``. A commutation angle read
    from Hall sensors or interpolated between them errs periodically with the electrical angle (a sensor's
    offset or a stray field added to the array's field it reads shifts the angle by its ratio to that field;
    a misplaced sensor or a field that is not sinusoidal, by its second harmonic: Ramsden, *Hall-Effect
    Sensors*, 2nd ed., 2006, ch. 4; Lenz & Edelstein, IEEE Sensors J. 6(3), 2006), and the error grows where
    the field it reads is weaker, at a gap-dependent rate (``harm_gap``; the array's fundamental weakens by
    ``pi / tau`` per metre of gap, MODEL.md).

    Latency (``latency`` [s], 0 by default): an angle read some time before the currents are applied lags the
    magnets by the electrical angle travelled meanwhile, ``-(pi / tau) latency d_dot`` (seed section III's
    electrical angle ``pi d / tau``): a sensor's or a filter's delay, the field read through a conducting shield or
    cooling plate (a thin sheet's transmission ``1 / (1 + j w tau_s)`` delays the field by ``tau_s`` at low
    frequency: Stoll, *The Analysis of Eddy Currents*, Clarendon 1974, ch. 3), a commutation computed a sample
    before it acts. The rotation then follows the speed: a drag or push ``C1 i_d sin(delta)`` along d that grows
    with the levitation current (with the gap), where an eddy drag falls with the gap as the field does.
    """

    #: Centres [m] of the learned offset's B-spline in d.
    KNOTS: ClassVar[tuple[float, ...]] = _COMM_KNOTS
    #: Knot spacing [m].
    KNOT_STEP: ClassVar[float] = 0.03

    name = "commutation_offset"
    params = (
        EffectParam("delta", 0.035, -0.35, 0.35, "rad", "electrical angle offset (at d = 0)"),
        EffectParam("drift", 0.0, -10.0, 10.0, "rad/m", "growth of the offset along the stroke"),
        *(
            EffectParam(f"cshape_{j}", 0.0, -0.35, 0.35, "rad", f"learned offset's coefficient at d = {c * 1e3:.0f} mm")
            for j, c in enumerate(_COMM_KNOTS)
        ),
        EffectParam("harm1_c", 0.0, -0.35, 0.35, "rad", "cos(theta_e) amplitude of the angle error at g = 20 mm"),
        EffectParam("harm1_s", 0.0, -0.35, 0.35, "rad", "sin(theta_e) amplitude of the angle error at g = 20 mm"),
        EffectParam("harm2_c", 0.0, -0.35, 0.35, "rad", "cos(2 theta_e) amplitude of the angle error at g = 20 mm"),
        EffectParam("harm2_s", 0.0, -0.35, 0.35, "rad", "sin(2 theta_e) amplitude of the angle error at g = 20 mm"),
        EffectParam("harm_gap", 0.0, -300.0, 300.0, "1/m", "growth rate of the harmonics' amplitude with the gap"),
        EffectParam("latency", 0.0, -0.01, 0.01, "s", "age of the angle when the currents act (lags with the speed)"),
    )

    @classmethod
    def shape_names(cls) -> tuple[str, ...]:
        """Names of the learned offset's coefficients, in knot order."""
        return tuple(f"cshape_{j}" for j in range(len(cls.KNOTS)))

    @classmethod
    def harmonic_names(cls) -> tuple[str, ...]:
        """Names of the electrical harmonics' amplitudes and their gap rate."""
        return ("harm1_c", "harm1_s", "harm2_c", "harm2_s", "harm_gap")

    @classmethod
    def angle(cls, d: Expr, theta: Mapping[str, Expr], g: Expr | None = None, v: Expr | None = None) -> Expr:
        """Electrical offset angle [rad] at position ``d`` [m], gap ``g`` [m] (20 mm if not given) and speed ``v``
        [m/s] (0 if not given): ``delta + drift d`` plus the learned spline plus the electrical harmonics, less
        the latency's lag ``(pi / tau) latency v``."""
        learned = bspline(d, cls.KNOTS, cls.KNOT_STEP, [theta.get(n, 0.0) for n in cls.shape_names()])
        out = theta["delta"] + theta["drift"] * d + learned
        if v is not None:  # the electrical angle travelled during the latency (the class docstring)
            out = out - (math.pi / k.tau) * theta.get("latency", 0.0) * v
        h1c, h1s, h2c, h2s = (theta.get(n, 0.0) for n in cls.harmonic_names()[:4])
        th = math.pi * d / k.tau  # the electrical angle (seed section III)
        grow = ca.exp(theta.get("harm_gap", 0.0) * ((_G_HARM_REF if g is None else g) - _G_HARM_REF))
        return out + grow * (h1c * ca.cos(th) + h1s * ca.sin(th) + h2c * ca.cos(2 * th) + h2s * ca.sin(2 * th))

    def currents(self, u, x, theta):
        angle = self.angle(x[2], theta, x[0], x[3])
        c, s = ca.cos(angle), ca.sin(angle)
        return ca.vertcat(c * u[0] - s * u[1], s * u[0] + c * u[1])
