"""Reference generator: point-to-point moves that the current limits allow.

A set-point step of 100 mm would ask any controller for an acceleration the
8 A amplifiers cannot give, and a saturated loop on an open-loop unstable axis
is a poor way to move. This module plans, for each target of a scenario, a
smooth rest-to-rest move of the shortest duration whose *model-inverse*
currents stay within a fraction of the limits along the whole path:

- the shape is a jerk-limited bang-bang profile (trapezoidal acceleration,
  ``ramp_fraction`` of the move spent ramping; 0 gives pure bang-bang, the
  time-optimal profile of a double integrator);
- both axes share one duration ``T`` (a straight line in the ``(g, d)`` plane);
  with ``d_timing: free`` the horizontal axis may accelerate for less or more
  than half of it (:func:`split_profile`), with ``gap_timing: free`` the gap may
  change in a part of it, each placed where the move is shortest (a move that
  changes the gap by several mm is then a few per cent shorter: it accelerates
  at the smaller gap, where the thrust per ampere is larger);
- ``T`` is the smallest duration (bisection) for which the currents of the
  controller's model's exact inverse (cogging included, see
  :func:`maglev_ocp.model.model_inverse_function`; with the static effects of
  the controller's model file, :func:`planning_inverse_function`) along the
  planned states and accelerations satisfy ``|i_q|, |i_d| <= f * 8 A`` and
  ``sqrt(i_q^2 + i_d^2) <= f * 8 A`` with ``f = current_fraction``. So the
  acceleration is the one the limits allow *at the gaps the move passes*
  (larger at small gaps, where ``L1 = C1 f1`` is larger, and less when the
  hover current already takes part of the amplitude).

The remaining fraction ``1 - f`` of the current is the feedback's margin.
The same plan serves every controller: the runner hands each controller
:meth:`ReferencePlan.at` at every step (positions and velocities at the
sample, accelerations averaged over the coming 1 ms period, which is what a
zero-order-held current can deliver), and a controller with a horizon can
read ahead with :meth:`ReferencePlan.sample` (the runner calls a controller's
``set_reference_plan(plan)`` if it has one).

``shaping: min_time`` (the NMPC's default) plans instead the minimum-time move
within the fractions of the limits (:mod:`.min_time`): by default the
time-optimal parameterization of a few paths (:mod:`.profile_plan`, a few
milliseconds per move, within 1 % of the minimum-time NLP), or the NLP itself
(``min_time_solver: nlp``).

Modules: :mod:`.settings` (the ``reference:`` block), :mod:`.profiles` (the
jerk-limited unit move, :class:`Move`, :class:`TabulatedMove`),
:mod:`.feasibility` (the model-inverse check of a move's currents),
:mod:`.trajectory` (``shaping: trajectory``), :mod:`.min_time` and
:mod:`.profile_plan` (``shaping: min_time``), :mod:`.plan` (a scenario's
:class:`ReferencePlan`).
"""

from .feasibility import PlanEffects, planning_inverse_function
from .min_time import MIN_TIME_TABLE_STEP, plan_min_time_move
from .plan import ReferencePlan, Target, plan_targets
from .profiles import Move, TabulatedMove, peak_acceleration_factor, split_profile, unit_profile
from .settings import D_SPLITS, GAP_PLACES, GAP_SHARES, GAP_SPLITS, ReferenceSettings
from .trajectory import plan_move

__all__ = [
    "D_SPLITS",
    "GAP_PLACES",
    "GAP_SHARES",
    "GAP_SPLITS",
    "MIN_TIME_TABLE_STEP",
    "Move",
    "PlanEffects",
    "ReferencePlan",
    "ReferenceSettings",
    "TabulatedMove",
    "Target",
    "peak_acceleration_factor",
    "plan_min_time_move",
    "plan_move",
    "plan_targets",
    "planning_inverse_function",
    "split_profile",
    "unit_profile",
]
