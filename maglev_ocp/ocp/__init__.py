"""Optimal-control problems on the shared model: the minimum-time move (bound and reference planning)."""

from .min_time import MinTimeResult, MinTimeSettings, TraverseBounds, solve_min_time, traverse_bounds

__all__ = ["MinTimeResult", "MinTimeSettings", "TraverseBounds", "solve_min_time", "traverse_bounds"]
