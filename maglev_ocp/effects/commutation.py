"""Commutation angle offset (:class:`CommutationOffset`)."""

from __future__ import annotations

import casadi as ca

from .base import Effect, EffectParam


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
