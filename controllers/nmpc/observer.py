"""Stage 1 of the step: the extended-state high-gain observer, symbolic.

The observer of :mod:`maglev_ocp.observers` (same gains, same predictor-corrector
update) on the quantized encoders: state and a constant acceleration disturbance
per axis, the latter used by the prediction for offset-free tracking.
"""

from __future__ import annotations

import casadi as ca

from maglev_ocp.observers import observer_update

from .design import StepDesign


def observe(d: StepDesign, S: dict, y: ca.SX, p: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """Observer update from the state pieces ``S`` and the reading ``y = (g, d)``.

    Right after reset (``fresh``) the estimate is kept (no prediction over a
    period that has not passed); a non-finite reading is skipped (prediction only).

    Returns
    -------
    fresh, xhat, dist, w : casadi.SX
        The fresh flag, the state and disturbance estimates, and the disturbance
        the prediction uses (``dist``, or zero without ``offset_free``).
    """
    fresh = S["fresh"][0] > 0.5
    # a model file's effects are part of the prediction over the period (as in FL): added to the
    # disturbance for the update, taken out after it, so ``dist`` stays the residual disturbance
    eff = d.effect_accel(S["xhat"], S["u_prev"], p) if d.effects else None
    dist_in = S["dist"] if eff is None else S["dist"] + eff
    xo, do = observer_update(
        S["xhat"], dist_in, S["u_prev"], y, p, d.L_obs, d.Ts, disturbance=True, skip_nonfinite=True
    )
    if eff is not None:
        do = do - eff
    xhat = ca.if_else(fresh, S["xhat"], xo)
    dist = ca.if_else(fresh, S["dist"], do)
    w = dist if d.settings.offset_free else ca.SX.zeros(2)
    return fresh, xhat, dist, w


__all__ = ["observe"]
