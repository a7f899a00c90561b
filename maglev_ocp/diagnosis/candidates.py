"""The candidate library and its fitter under their former module name.

The catalogue (effect specs, bounds, law-family members) is :mod:`.library`; the bounded least-squares fitter,
the lag search and the fit results are :mod:`.fit`. This module re-exports both for the callers of the former
``candidates`` module.
"""

from __future__ import annotations

from .fit import (
    CONVERGED,
    CandidateFitter,
    Dataset,
    FitResult,
    _accel_function,
    _accel_jac_function,
    accel_series,
    evaluate,
    fit_candidate,
    lag_features,
    lag_theta,
    lag_Z,
    residuals_with,
    resolution_spread,
)
from .library import PRIOR_SD, CandidateSpec, Free, calibration_free, combine, family_specs, library_specs

__all__ = [
    "CONVERGED",
    "PRIOR_SD",
    "CandidateFitter",
    "CandidateSpec",
    "Dataset",
    "FitResult",
    "Free",
    "_accel_function",
    "_accel_jac_function",
    "accel_series",
    "calibration_free",
    "combine",
    "evaluate",
    "family_specs",
    "fit_candidate",
    "lag_Z",
    "lag_features",
    "lag_theta",
    "library_specs",
    "residuals_with",
    "resolution_spread",
]
