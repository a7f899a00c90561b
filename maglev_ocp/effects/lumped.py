"""Lumped-constant error and eddy-current drag (:class:`ParameterError`, :class:`EddyDrag`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import casadi as ca

from .. import constants as k
from ..model import get_model
from ..shapes import bspline
from .base import _P, Effect, EffectParam, Expr

#: Centres [m] of the eddy drag's profile along d (a cubic B-spline, knots every 20 mm over the stroke and beyond).
_EDDY_D_KNOTS: tuple[float, ...] = tuple(round(-0.06 + 0.02 * j, 3) for j in range(7))


def _dprof_name(c: float) -> str:
    """Parameter name of the eddy drag's profile coefficient at ``d = c`` [m]: ``dprof_m40``, ``dprof_20``."""
    mm = round(c * 1e3)
    return f"dprof_{'m' if mm < 0 else ''}{abs(mm):.0f}"


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
    """Eddy-current drag (and lift) of the magnets moving over the conducting stator (NOTES.md), optional.

    Physical signature (issue 27): a force along d, odd in the horizontal velocity ``v``, that is
    linear at low speed and saturates and falls above a critical velocity ``v_c`` (the eddy currents'
    own field opposes the source field), with a lift that opens the gap, even in ``v``; its size
    follows the magnets' field at the conductor, so it falls as the gap opens. The law family is
    Reitz's moving-magnet law (Reitz, "Forces on moving magnets due to eddy currents", J. Appl. Phys.
    41(5), 1970: drag ``F0 w v / (v^2 + w^2)``, lift ``F0 v^2 / (v^2 + w^2)``) written
    with ``c = F0 / w`` and ``s = 1 / v_c = 1 / w``::

        F_d = -c(g) v / (1 + (s v)^2),     F_g = lift c(g) s v^2 / (1 + (s v)^2),
        c(g) = c_eddy B(g)^2 + c_ref exp(-kappa (g - g_ref)).

    ``s = 0`` is the low-speed (Sodano, Bae & Inman 2006) linear law ``F_d = -c(g) v``, the library's
    closed form ``c_eddy B(g)^2`` (B the PM field's fundamental, MODEL.md) with ``c_ref = 0``; ``lift = 1``
    is Reitz's thin-sheet ratio ``F_L / F_D = v / w``, ``lift = 0`` a drag without lift.

    Why the gap dependence is constrained: a drag coefficient that does not depend on the gap is viscous
    friction along d, an effect of its own (:class:`~maglev_ocp.effects.Friction`); a member free in ``g``
    would nest it, and no experiment could then tell the two apart (velocity sweeps at two gaps, issue 27
    item 3). The eddy currents answer the field at the conductor, whose slowest-decaying part is the
    field's fundamental pole-pitch harmonic, MODEL.md's ``B(g) ~ 1 / sinh(pi (h_m + g) / tau)``, which
    far from the magnets is ``exp(-pi g / tau)``; so the drag, quadratic in B, decays at least as
    ``exp(-2 pi g / tau)`` (a factor e every ``tau / 2 pi`` = 9.1 mm);
    higher harmonics decay faster (the third's ``B^2`` as ``exp(-6 pi g / tau)``). ``kappa`` is bounded to
    ``[2 pi / tau, 6 pi / tau]`` (:attr:`KAPPA_BOUNDS`) and ``B(g)^2`` itself decays faster than the
    fundamental's exponential (its log-slope is ``2 pi / tau coth(pi (h_m + g) / tau)``), so no coefficient
    of the conductor under the array is flat in ``g``: over the stroke 8-32 mm it falls by a factor 14 at least.

    A conductor beside the array (``c_side``, 0 by default: a side wall, a cable duct, a frame rail) sits in the
    array's leakage field at its side, and the more the mover rises, the more of its side faces the conductor:
    its drag *grows* as the gap opens, ``c_side exp(kappa_side (g - g_ref))`` with ``kappa_side`` bounded away
    from 0 (:attr:`KAPPA_SIDE_BOUNDS`), so that it is not flat in g either (a flat coefficient is viscous friction
    or, at one gap, either: issue 27 item 3's confusable pair).

    Profile along the stroke (``dprof_*``, 0 by default): the conductor under the array need not be the same
    everywhere along d: it ends with the stator (a finite plate's drag falls as the magnet nears its edge,
    Sodano, Bae & Inman 2006), and its circuits (slot wedges, parallel winding groups, a split back plate)
    close differently at each position. The coefficient is then ``c(g) (1 + p(d))`` with ``p`` a cubic B-spline
    in d (:data:`_EDDY_D_KNOTS`, coefficients >= -1, so the drag never changes sign): still falling with the
    gap as the field does, so still not viscous friction, whose coefficient depends on neither.

    Damping normal to the conductor (``c_gap``, 0 by default): when the gap changes, the flux of the magnets
    through a conductor facing them (the stator's sheet, the mover's own solid back iron) changes and its eddy
    currents oppose the change (Lenz's law), a force ``-c_n(g) g_dot`` on the gap axis whatever the motion
    along d (a magnet approaching a conducting plate is repelled in proportion to its speed: Saslow 1992, sec.
    V; Stoll, *The Analysis of Eddy Currents*, Clarendon 1974, ch. 1; solid-core suspension magnets: Sinha,
    *Electromagnetic Suspension*, IEE 1987, ch. 3). Its coefficient need not follow the drag along d (the
    conductor's extent, thickness and where its currents close differ for the two motions), so it has its own
    size and decay, ``c_n(g) = c_gap exp(-kappa_gap (g - g_ref))``, falling with the gap as the flux's change
    does, ``kappa_gap`` bounded away from 0 (:attr:`KAPPA_GAP_BOUNDS`): a flat damping of the gap is not a
    conductor's (the air under a cover, a cable's loss), and stays out of the library.
    """

    #: Centres [m] of the profile's B-spline along d.
    D_KNOTS: ClassVar[tuple[float, ...]] = _EDDY_D_KNOTS
    #: Their spacing [m].
    D_STEP: ClassVar[float] = 0.02

    #: Bounds [1/m] of the exponential coefficient's decay rate: the fundamental's B^2 to the third harmonic's.
    KAPPA_BOUNDS: ClassVar[tuple[float, float]] = (2 * math.pi / k.tau, 6 * math.pi / k.tau)

    #: Bounds [1/m] of the side conductor's growth rate with g: from a factor 1.5 over the targets' gaps 15..25 mm
    #: (a growth that sweeps at two gaps tell from a flat coefficient) to the field's fundamental (the rate at which
    #: the array's own field falls, as the side facing grows).
    KAPPA_SIDE_BOUNDS: ClassVar[tuple[float, float]] = (math.log(1.5) / 0.010, 2 * math.pi / k.tau)
    #: Its default [1/m] (a factor 1.8 over 15..25 mm), where a fit starts.
    KAPPA_SIDE_DEFAULT: ClassVar[float] = 60.0
    #: Bounds [1/m] of the normal damping's decay rate with g: from a factor 1.5 over the targets' gaps 15..25 mm
    #: (what sweeps of the gap tell from a flat damping) to the field's third harmonic squared.
    KAPPA_GAP_BOUNDS: ClassVar[tuple[float, float]] = (math.log(1.5) / 0.010, 6 * math.pi / k.tau)
    #: Its default [1/m] (the field's fundamental squared), where a fit starts.
    KAPPA_GAP_DEFAULT: ClassVar[float] = 2 * math.pi / k.tau

    name = "eddy_drag"
    params = (
        EffectParam("c_eddy", 20.0, 0.0, 2000.0, "N s/(m T^2)", "low-speed drag coefficient per field squared"),
        EffectParam("c_ref", 0.0, 0.0, 500.0, "N s/m", "low-speed drag coefficient of the exponential at g_ref"),
        EffectParam("kappa", 2 * math.pi / k.tau, *KAPPA_BOUNDS, "1/m", "decay rate of the exponential with g"),
        EffectParam("inv_vc", 0.0, 0.0, 50.0, "s/m", "inverse critical velocity (0: drag linear in velocity)"),
        EffectParam("c_side", 0.0, 0.0, 500.0, "N s/m", "low-speed drag coefficient of a side conductor at g_ref"),
        EffectParam(
            "kappa_side", KAPPA_SIDE_DEFAULT, *KAPPA_SIDE_BOUNDS, "1/m", "growth rate of a side conductor's drag with g"
        ),
        EffectParam("c_gap", 0.0, 0.0, 500.0, "N s/m", "damping coefficient of the gap's motion at g_ref"),
        EffectParam("kappa_gap", KAPPA_GAP_DEFAULT, *KAPPA_GAP_BOUNDS, "1/m", "decay rate of the gap's damping with g"),
        EffectParam("lift", 0.0, 0.0, 2.0, "-", "lift over Reitz's thin-sheet lift (opens the gap)"),
        EffectParam("c_vert", 0.0, 0.0, 2.0, "-", "vertical damping over the drag's low-speed coefficient"),
        *(
            EffectParam(_dprof_name(c), 0.0, -1.0, 3.0, "-", f"relative change of the drag at d = {c * 1e3:.0f} mm")
            for c in _EDDY_D_KNOTS
        ),
    )

    @classmethod
    def profile_names(cls) -> tuple[str, ...]:
        """Names of the profile's coefficients along d, in knot order."""
        return tuple(_dprof_name(c) for c in cls.D_KNOTS)

    @classmethod
    def profile(cls, d: Expr, theta: Mapping[str, Expr]) -> Expr:
        """The drag's factor along the stroke, ``1 + sum_j c_j B((d - d_j) / step)`` (1 with the defaults)."""
        return 1 + bspline(d, cls.D_KNOTS, cls.D_STEP, [theta.get(n, 0.0) for n in cls.profile_names()])

    @classmethod
    def coefficient(cls, g: Expr, theta: Mapping[str, Expr], d: Expr | None = None) -> Expr:
        """Low-speed drag coefficient ``c(g)`` [N s/m] at gap ``g`` [m] (decays at least as the field squared; a
        side conductor's part grows),
        times the profile along the stroke at ``d`` [m] when given (:meth:`profile`)."""
        B = get_model().shape(g)[2]
        c = theta["c_eddy"] * B**2 + theta.get("c_ref", 0.0) * ca.exp(
            -theta.get("kappa", cls.KAPPA_BOUNDS[0]) * (g - k.g_cog_ref)
        )
        # a conductor beside the array: its drag grows as the gap opens (the class docstring)
        c = c + theta.get("c_side", 0.0) * ca.exp(theta.get("kappa_side", cls.KAPPA_SIDE_DEFAULT) * (g - k.g_cog_ref))
        return c if d is None else c * cls.profile(d, theta)

    @classmethod
    def gap_coefficient(cls, g: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Damping coefficient ``c_n(g)`` [N s/m] of the gap's own motion at gap ``g`` [m] (the class docstring)."""
        return theta.get("c_gap", 0.0) * ca.exp(-theta.get("kappa_gap", cls.KAPPA_GAP_DEFAULT) * (g - k.g_cog_ref))

    @classmethod
    def forces(
        cls, g: Expr, v: Expr, theta: Mapping[str, Expr], g_dot: Expr = 0.0, d: Expr | None = None
    ) -> tuple[Expr, Expr]:
        """Eddy forces ``(F_g, F_d)`` [N] at gap ``g`` [m], horizontal velocity ``v`` and vertical velocity
        ``g_dot`` [m/s] (Reitz 1970): ``F_g`` along +g (opens the gap), ``F_d`` opposes the motion.

        A velocity normal to the conductor induces eddy currents as a tangential one does: the conductor
        then damps the gap's motion too, ``-c_vert c(g) g_dot`` (a magnet approaching a conducting plate is
        repelled in proportion to its speed: Saslow, "Maxwell's theory of eddy currents in thin conducting
        sheets", Am. J. Phys. 60(8), 1992, sec. V; Sodano, Bae & Inman, "Improved concept and model of eddy
        current damper", J. Vib. Acoust. 128(3), 2006). The ratio ``c_vert`` depends on the conductor's extent
        and thickness against the pole pitch, so it is a parameter of its own (0: a drag along d only).
        """
        c, s = cls.coefficient(g, theta, d), theta.get("inv_vc", 0.0)
        den = 1 + (s * v) ** 2
        f_g = theta.get("lift", 0.0) * c * s * v**2 / den - theta.get("c_vert", 0.0) * c * g_dot
        # the conductor's damping of the gap's own motion, its coefficient of its own (the class docstring)
        f_g = f_g - cls.gap_coefficient(g, theta) * g_dot
        return f_g, -c * v / den

    def modify(self, terms, x, u, p, theta) -> None:
        P = _P(p)
        f_g, f_d = self.forces(x[0], x[3], theta, x[1], x[2])
        terms.horizontal["eddy"] = f_d / P["Mh"]
        terms.vertical["eddy_lift"] = f_g / P["Mv"]
