"""Bounds, starts and scales of every parameter the diagnosis's candidates fit (:data:`FREE`).

One definition per key, ``"effect.param"`` (or ``"p.const"`` for a calibrated constant of the shared model):
``(lo, hi, start, scale)`` in physical units, as :class:`.library.Free` takes them. The specs of :mod:`.library`
pick theirs by key; an effect's own bounds (:meth:`maglev_ocp.effects.Effect.bounds`) are used where the fit
needs no narrower ones.
"""

from __future__ import annotations

import math

from .. import constants as k
from ..effects import EFFECTS, Cogging, CommutationOffset, EddyDrag, EndEffect, Friction, Saturation
from ..effects.cogging import ENERGY_DECAY_RANGE


def _eb(effect: str, param: str) -> tuple[float, float]:
    return EFFECTS[effect].bounds()[param]


_TWO_PI = 2 * math.pi
# Shared rows of :data:`FREE`: (lo, hi, start, scale) of parameters of the same kind.
_PHASE = (-_TWO_PI, _TWO_PI, 0.3, 1.0)  # a phase [rad]: any angle
_HARMONIC = (-2.0, 2.0, 0.05, 0.2)  # a cogging harmonic relative to xi0
_COGGING_PEAK = (0.0, 50.0, 1.0, 4.0)  # xi0 [N]
_GUIDE_FORCE = (0.0, 10.0, 0.05, 0.2)  # a Coulomb or Stribeck force of a guide [N]
_VISCOUS = (0.0, 100.0, 0.5, 1.0)  # a viscous coefficient [N s/m]
_TERM_WEIGHT = (0.0, 0.8, 0.05, 0.1)  # a magnetic term's share of the saturation loss (a loss: >= 0)
_FACTOR = (0.5, 2.0, 1.0, 0.05)  # a factor on a model term

#: Every parameter a candidate fits: key -> (lo, hi, start, scale) in physical units (see :class:`Free`).
#: One definition per key; the specs of :mod:`.library` pick theirs by key.
FREE: dict[str, tuple[float, float, float, float]] = {
    # cogging: the seed's law (in p), harmonics, and the free-decay law's own amplitude, decay and shape
    "p.xi0": _COGGING_PEAK,
    "p.ell": (1e-3, 0.03, 4e-3, 4e-3),
    "cogging.h2": _HARMONIC,
    "cogging.h3": _HARMONIC,
    "cogging.phi2": _PHASE,
    "cogging.phi3": _PHASE,
    "cogging.xi0": _COGGING_PEAK,
    "cogging.ell": (1e-3, 0.05, 4e-3, 4e-3),
    "cogging.power": (0.0, 4.0, 0.0, 1.0),
    "cogging.curv": (-20.0, 20.0, 0.0, 2.0),
    "cogging.kn": (0.0, 4.0, 1.0, 0.5),
    # friction
    "friction.coulomb_g": _GUIDE_FORCE,
    "friction.coulomb_d": _GUIDE_FORCE,
    "friction.viscous_g": _VISCOUS,
    "friction.viscous_d": _VISCOUS,
    "friction.stribeck_g": _GUIDE_FORCE,
    "friction.stribeck_d": _GUIDE_FORCE,
    "friction.v_stribeck": (5e-4, 0.05, 5e-3, 5e-3),
    "friction.dir_g": (-10.0, 10.0, 0.0, 0.1),  # a guide's forward level minus its Coulomb level [N]
    "friction.dir_d": (-10.0, 10.0, 0.0, 0.1),
    "friction.load_g": (-80.0, 80.0, 0.0, 20.0),  # the dry friction's log-change per m of gap [1/m]
    "friction.load_d": (-80.0, 80.0, 0.0, 20.0),
    # end effect
    "end_effect.ripple": (0.0, 0.5, 0.02, 0.05),
    "end_effect.ripple_phase": _PHASE,
    "end_effect.ripple2": (0.0, 0.5, 0.02, 0.05),
    "end_effect.ripple2_phase": _PHASE,
    "end_effect.d_edge": (0.0, 0.2, 0.04, 0.02),
    "end_effect.edge_width": (1e-3, 0.05, 5e-3, 5e-3),
    "end_effect.edge_gain": (0.0, 5.0, 1.0, 0.5),
    "end_effect.edge_quad": (-20.0, 20.0, 0.0, 2.0),
    "end_effect.edge_cog": (0.0, 1.0, 1.0, 0.5),
    "end_effect.edge_pm": (0.0, 1.0, 1.0, 0.5),
    "end_effect.edge_skew": (-0.05, 0.05, 0.0, 0.005),
    "end_effect.gain_skew": (-0.9, 0.9, 0.0, 0.2),
    "end_effect.end_force": (0.0, 20.0, 0.5, 1.0),  # the end force at g = 10 mm [N]
    "end_effect.end_ell": (1e-3, 0.05, 5e-3, 3e-3),
    # the winding's end force per squared current [N/A^2]: (3/4) dL/dd, a few mH over a fringe of 5-20 mm
    "end_effect.end_i2": (-1.0, 1.0, 0.0, 0.05),
    # the free profile's steps of its B-spline coefficients: a loss of force of a few 10 % at most on a real
    # stroke; the weak ridge at 0 holds a step whose knot the data do not reach (the profile keeps its level).
    # No step is negative: an overhang only loses force, and more of it the farther the magnets overhang (a
    # B-spline with non-decreasing coefficients is non-decreasing), so the profile cannot take up a force that
    # grows or oscillates along the stroke (an encoder scale error's commutation drift, seed 3 #15).
    **{f"end_effect.{n}": (0.0, 1.0, 0.0, 0.1) for n in EndEffect.profile_names()},
    # saturation
    "saturation.loss_8mm": (0.0, 0.8, 0.05, 0.1),
    "saturation.ell_sat": (5e-4, 0.05, 3e-3, 3e-3),
    "saturation.w_pm": _TERM_WEIGHT,
    "saturation.w_id": _TERM_WEIGHT,
    "saturation.w_rel": _TERM_WEIGHT,
    "saturation.w_thrust": _TERM_WEIGHT,
    # 0: exponential; knee at 8 mm + ell_sat ln(knee), at most 4.6 ell_sat above the stop: a knee far above the
    # gaps visited makes the loss a constant factor, which the calibrated C1..C4 already are.
    "saturation.knee": (0.0, 100.0, 1.0, 10.0),
    # saturation's learned loss: non-negative steps (a loss non-increasing in g), start 0.01 per step
    **{f"saturation.{n}": (0.0, 0.5, 0.01, 0.05) for n in Saturation.shape_names()},
    # the current loss's steps in |i| (every 2 A): a loss of a few % per 2 A at most on a real winding
    **{f"saturation.{n}": (0.0, 0.5, 0.005, 0.02) for n in Saturation.current_names()},
    # learned shapes (flexible members): friction's non-negative profile coefficients [N] per axis, cogging's
    # co-energy harmonics (coefficients [N at g_e = 20 mm], each harmonic's decay rate over its wavenumber within
    # the physical range of Cogging, a shared log-curvature), the commutation offset's spline [rad]
    **{f"friction.{n}": (0.0, 10.0, 0.01, 0.1) for ax in "gd" for n in Friction.shape_names(ax)},
    **{f"cogging.{n}": (-20.0, 20.0, 0.0, 0.5) for n in Cogging.energy_names() if n[2] in "cs"},
    **{f"cogging.{n}": (*ENERGY_DECAY_RANGE, 1.0, 0.5) for n in Cogging.energy_names() if n[2] == "r"},
    "cogging.e_curv": (-4.0, 1.0, 0.0, 1.0),
    **{f"cogging.{n}": (-20.0, 20.0, 0.0, 0.5) for n in Cogging.pole_names() if n[3] in "cs"},
    **{f"cogging.{n}": (*ENERGY_DECAY_RANGE, 1.0, 0.5) for n in Cogging.pole_names() if n[3] == "r"},
    **{f"commutation_offset.{n}": (-0.35, 0.35, 0.0, 0.05) for n in CommutationOffset.shape_names()},
    # the commutation offset's electrical harmonics [rad] and their growth rate with the gap [1/m] (the array's
    # fundamental falls by pi / tau = 55 /m; a sensor's error grows as the field it reads weakens)
    **{f"commutation_offset.{n}": (-0.35, 0.35, 0.0, 0.02) for n in CommutationOffset.harmonic_names()[:4]},
    "commutation_offset.harm_gap": (-300.0, 300.0, 0.0, 50.0),
    # the angle's latency [s]: it lags by the electrical angle travelled meanwhile (a sensor's, a shield's delay)
    "commutation_offset.latency": (*_eb("commutation_offset", "latency"), 0.0, 1e-3),
    # one-parameter effects (the effect's own bounds)
    "commutation_offset.delta": (*_eb("commutation_offset", "delta"), 0.0, 0.05),
    "commutation_offset.drift": (*_eb("commutation_offset", "drift"), 0.0, 1.0),
    "eddy_drag.c_eddy": (*_eb("eddy_drag", "c_eddy"), 10.0, 50.0),
    # eddy drag's Reitz law: coefficient at g_ref [N s/m], its decay rate with g (bounded between the field's
    # fundamental and third harmonic, EddyDrag.KAPPA_BOUNDS: never flat in g), inverse critical velocity, lift
    "eddy_drag.c_ref": (*_eb("eddy_drag", "c_ref"), 10.0, 20.0),
    "eddy_drag.kappa": (*EddyDrag.KAPPA_BOUNDS, 4 * math.pi / k.tau, 50.0),
    "eddy_drag.inv_vc": (*_eb("eddy_drag", "inv_vc"), 5.0, 5.0),
    "eddy_drag.lift": (*_eb("eddy_drag", "lift"), 0.5, 0.5),
    # vertical eddy damping over the drag's coefficient (a normal velocity induces eddy currents too)
    "eddy_drag.c_vert": (*_eb("eddy_drag", "c_vert"), 0.5, 0.5),
    # the drag's relative change along the stroke, per knot (>= -1: the drag never changes sign)
    **{f"eddy_drag.{n}": (-1.0, 3.0, 0.0, 0.5) for n in EddyDrag.profile_names()},
    # a conductor beside the array: its coefficient at g_ref [N s/m] and its growth rate with the gap (never flat)
    "eddy_drag.c_side": (*_eb("eddy_drag", "c_side"), 5.0, 10.0),
    "eddy_drag.kappa_side": (*EddyDrag.KAPPA_SIDE_BOUNDS, EddyDrag.KAPPA_SIDE_DEFAULT, 20.0),
    # a conductor's damping of the gap's own motion: its coefficient at g_ref [N s/m] and its decay rate with the
    # gap (never flat: a flat damping of the gap is not a conductor's)
    "eddy_drag.c_gap": (*_eb("eddy_drag", "c_gap"), 20.0, 20.0),
    "eddy_drag.kappa_gap": (*EddyDrag.KAPPA_GAP_BOUNDS, EddyDrag.KAPPA_GAP_DEFAULT, 30.0),
    # parameter error: factors on C1..C4 (C4, a small term, may be off by more)
    "parameter_error.k_C1": _FACTOR,
    "parameter_error.k_C2": _FACTOR,
    "parameter_error.k_C3": _FACTOR,
    "parameter_error.k_C4": (0.0, 5.0, 1.0, 0.5),
}

__all__ = ["FREE"]
