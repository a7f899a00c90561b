"""Magnetic saturation of the stator iron (:class:`Saturation`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from ..shapes import cumulative_bspline
from .base import MAGNETIC_TERMS, Effect, EffectParam, Expr

#: Centres [m] of the saturation's learned-loss coefficients in g: every 3 mm from 5 mm (below the lower stop, so
#: the spline is not cut there) to 23 mm (the loss vanishes above 29 mm).
_SAT_KNOTS: tuple[float, ...] = tuple(round(0.005 + 0.003 * j, 4) for j in range(7))
#: Centres [A] of the current loss's B-spline in the current magnitude ``|i|``: every 2 A from -2 A (the first two
#: held at 0, so that the spline is a partition of unity from 0 A on) to 12 A (beyond the 8 A amplitude limit).
_SAT_I_KNOTS: tuple[float, ...] = tuple(-2.0 + 2.0 * j for j in range(8))


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

    The iron saturates on the total flux, the magnets' and the winding's: the winding's own flux (the slot
    leakage through the tooth tips, the armature reaction) saturates its paths as the current grows, whatever
    the gap (Pyrhonen, Jokinen & Hrabovcova, *Design of Rotating Electrical Machines*, 2nd ed., 2014, ch. 3-4).
    A **current loss** ``L_i(|i|)`` adds to the loss of every term: a cubic B-spline in the current magnitude
    ``|i| = sqrt(i_q^2 + i_d^2)`` with non-negative steps (``iloss_*``), non-decreasing in ``|i|`` and 0 at no
    current (:meth:`current_loss`), weighted by the terms' shares as the gap loss is (the current terms'
    shares: the thrust and the PM-current term lose ``L_i``, the reluctance term, quadratic in the currents'
    field, twice that).
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
        *(
            EffectParam(f"iloss_{c:.0f}", 0.0, 0.0, 0.5, "-", f"step of the current loss at |i| = {c:.0f} A")
            for c in _SAT_I_KNOTS[2:]
        ),
    )
    #: Centres [A] of the current loss's B-spline in ``|i|`` (:meth:`current_loss`).
    I_KNOTS: ClassVar[tuple[float, ...]] = _SAT_I_KNOTS
    #: Their spacing [A].
    I_STEP: ClassVar[float] = 2.0
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
        "end_x": "w_pm",
        "a_id": "w_id",
        "a_rel": "w_rel",
        "a_thrust": "w_thrust",
    }

    @staticmethod
    def loss(g: Expr, theta: Mapping[str, Expr], i_mag: Expr | None = None) -> Expr:
        """The loss of a term of unit share at gap ``g`` [m] and current magnitude ``i_mag`` [A] (None: no current
        loss): the closed form, the learned loss in g and the current loss."""
        b = theta["knee"]
        closed = theta["loss_8mm"] * (1 + b) / (b + ca.exp((g - k.g_stop[0]) / theta["ell_sat"]))
        loss = closed + Saturation.shape_loss(g, theta)
        if i_mag is not None:
            loss = loss + Saturation.current_loss(i_mag, theta)
        return loss

    @staticmethod
    def factor(g: Expr, theta: Mapping[str, Expr], weight: Expr = 1.0, i_mag: Expr | None = None) -> Expr:
        """Force factor ``k_sat(g, |i|) = 1 - weight * loss`` (<= 1 for a positive weight, smallest at small gaps
        and large currents; ``i_mag`` the current magnitude [A], None: no current loss; :meth:`loss`)."""
        return 1 - weight * Saturation.loss(g, theta, i_mag)

    @classmethod
    def current_names(cls) -> tuple[str, ...]:
        """Names of the current loss's steps (knots from 2 A on, :attr:`I_KNOTS`), in knot order."""
        return tuple(f"iloss_{c:.0f}" for c in cls.I_KNOTS[2:])

    @classmethod
    def current_loss(cls, i_mag: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The current loss at ``|i| = i_mag`` [A]: non-decreasing in ``|i|``, 0 at no current (0 with the default
        steps). A cumulative cubic B-spline (non-negative steps, :func:`~maglev_ocp.shapes.cumulative_bspline`)
        whose first two coefficients (knots -2 A and 0 A) are 0, less its value at 0 A; level above 10 A."""
        steps = [0.0, 0.0, *(theta.get(n, 0.0) for n in cls.current_names())]
        # the basis sums to one up to the last knot but one: held level beyond it (a current above 10 A)
        i_mag = ca.fmin(i_mag, cls.I_KNOTS[-2])
        return cumulative_bspline(i_mag, cls.I_KNOTS, cls.I_STEP, steps) - cumulative_bspline(
            0.0, cls.I_KNOTS, cls.I_STEP, steps
        )

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
        # |i| smoothed at 1 mA so that the factor stays differentiable at no current
        i_mag = ca.sqrt(u[0] ** 2 + u[1] ** 2 + 1e-6)
        loss = self.loss(x[0], theta, i_mag)  # one expression for every term (only the shares differ)
        for term in sorted(MAGNETIC_TERMS):
            terms.scale([term], 1 - theta[self.TERM_WEIGHT[term]] * loss)
