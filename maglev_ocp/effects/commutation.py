"""Commutation angle offset (:class:`CommutationOffset`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from ..shapes import bspline
from .base import Effect, EffectParam, Expr

#: Centres [m] of the learned offset's B-spline in d: every 30 mm from -90 to 90 mm, so that on the stroke
#: (+-60 mm) the basis sums to one and reproduces a constant and a linear drift exactly (de Boor, ch. IX).
_COMM_KNOTS: tuple[float, ...] = tuple(round(-0.09 + 0.03 * j, 3) for j in range(7))


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
    )

    @classmethod
    def shape_names(cls) -> tuple[str, ...]:
        """Names of the learned offset's coefficients, in knot order."""
        return tuple(f"cshape_{j}" for j in range(len(cls.KNOTS)))

    @classmethod
    def angle(cls, d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Electrical offset angle [rad] at position ``d`` [m]: ``delta + drift d`` plus the learned spline."""
        learned = bspline(d, cls.KNOTS, cls.KNOT_STEP, [theta.get(n, 0.0) for n in cls.shape_names()])
        return theta["delta"] + theta["drift"] * d + learned

    def currents(self, u, x, theta):
        angle = self.angle(x[2], theta)
        c, s = ca.cos(angle), ca.sin(angle)
        return ca.vertcat(c * u[0] - s * u[1], s * u[0] + c * u[1])
