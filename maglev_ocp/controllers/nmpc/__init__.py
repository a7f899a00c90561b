"""Nonlinear MPC of the stage: RTI multiple shooting on the shared model, one Function per step.

Read top-down:

settings
    :class:`NMPCSettings`, the one settings layer (every option's name, default, meaning).
controller
    :class:`NMPC` (the Controller protocol) and the evaluator injection
    (:class:`StepEvaluators`, :func:`casadi_evaluators`).
step
    The step Function assembled from its stages:
    observer (:mod:`.observer`) -> reference (:mod:`.planner`, :mod:`.reference`) ->
    RTI linearization (:mod:`.prediction`) -> QP by ADMM (:mod:`.admm`, with
    :mod:`.riccati` or the dense :mod:`.qp`) -> fallback and shift (:mod:`.fallback`).
design, layout
    The constants baked into a step (:class:`~.design.StepDesign`) and the
    layout of its packed state, measurement and statistics vectors (with their port table).
"""

from __future__ import annotations

from .controller import NMPC, Evaluator, StepEvaluators, StepFunctions, casadi_evaluators
from .layout import STATS_NAMES, StateLayout
from .settings import ADMMOptions, NMPCSettings, NMPCWeights, PlanOptions, SoftGap
from .step import StepBuilder, step_functions

__all__ = [
    "NMPC",
    "STATS_NAMES",
    "ADMMOptions",
    "Evaluator",
    "NMPCSettings",
    "NMPCWeights",
    "PlanOptions",
    "SoftGap",
    "StateLayout",
    "StepBuilder",
    "StepEvaluators",
    "StepFunctions",
    "casadi_evaluators",
    "step_functions",
]
