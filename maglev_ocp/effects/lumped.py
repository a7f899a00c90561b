"""Lumped-constant error and eddy-current drag (:class:`ParameterError`, :class:`EddyDrag`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from ..model import get_model
from ..shapes import bspline
from .base import _P, Effect, EffectParam, Expr


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

    Learned shape (flexible member): the coefficient gains a cubic B-spline in
    ``g`` with non-negative coefficients ``eshape_<j>`` [N s/m] (:attr:`KNOTS`),
    ``F = -(c_eddy B(g)^2 + sum_j c_j B((g - g_j) / h)) d_dot``: a drag
    coefficient of any smooth non-negative shape in the gap. 0 by default.
    """

    #: Centres [m] of the learned coefficient's B-spline in g: every 6 mm from 2 to 38 mm (the gap's stroke,
    #: 8-32 mm, inside the region where the basis sums to one).
    KNOTS: ClassVar[tuple[float, ...]] = tuple(round(0.002 + 0.006 * j, 3) for j in range(7))
    #: Knot spacing [m].
    KNOT_STEP: ClassVar[float] = 0.006

    name = "eddy_drag"
    params = (
        EffectParam("c_eddy", 20.0, 0.0, 2000.0, "N s/(m T^2)", "drag coefficient per field squared"),
        *(
            EffectParam(f"eshape_{j}", 0.0, 0.0, 500.0, "N s/m", f"learned drag coefficient at g = {2 + 6 * j} mm")
            for j in range(7)
        ),
    )

    @classmethod
    def shape_names(cls) -> tuple[str, ...]:
        """Names of the learned coefficient's B-spline coefficients, in knot order."""
        return tuple(f"eshape_{j}" for j in range(len(cls.KNOTS)))

    @classmethod
    def coefficient(cls, g: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Drag coefficient [N s/m] at gap ``g`` [m]: the B^2 law plus the learned spline (>= 0 within bounds)."""
        B = get_model().shape(g)[2]
        return theta["c_eddy"] * B**2 + bspline(
            g, cls.KNOTS, cls.KNOT_STEP, [theta.get(n, 0.0) for n in cls.shape_names()]
        )

    def modify(self, terms, x, u, p, theta) -> None:
        terms.horizontal["eddy"] = -self.coefficient(x[0], theta) * x[3] / _P(p)["Mh"]
