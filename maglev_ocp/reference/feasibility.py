"""Do a planned move's model-inverse currents fit the limits? The planner's feasibility check."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..effects import EffectSet, effect_delta_function
from ..fastcall import BufferedFunction
from ..model import get_model, model_inverse_function
from ..params import Params
from .settings import ReferenceSettings


@dataclass(frozen=True)
class PlanEffects:
    """Static effects of the controller's model file, for the planner's feasibility check.

    Attributes
    ----------
    names : tuple of str
        Effect names (:class:`maglev_ocp.effects.EffectSet`).
    theta : tuple of float
        Their parameters in the effect set's order.
    """

    names: tuple[str, ...]
    theta: tuple[float, ...]


#: Newton steps of the effect-aware inverse (from the shared model's inverse; quadratic convergence).
INVERSE_NEWTON_STEPS = 4
#: Residual of the effect-aware inverse beyond which a point counts as out of reach [m/s^2, + relative].
INVERSE_TOLERANCE = 1e-3


@functools.lru_cache(maxsize=16)
def planning_inverse_function(effects: tuple[str, ...] = ()) -> ca.Function:
    """``planning_inverse(x, a, p, theta) -> (u, unreachable)``: currents for accelerations ``a`` with the effects.

    Without effects it is the shared model's exact inverse
    (:func:`maglev_ocp.model.model_inverse_function`, ``theta`` unused). With
    effects, the shared inverse is the first guess and Newton's method on the
    model-plus-effects accelerations (the shared model's ``f`` plus
    :func:`maglev_ocp.effects.effect_delta_function`) refines it
    (:data:`INVERSE_NEWTON_STEPS`); a point counts as unreachable when the
    shared inverse says so or the residual stays beyond
    :data:`INVERSE_TOLERANCE` ``(1 + |a|)``, so a move the model cannot follow is
    never declared feasible.
    """
    m = get_model()
    x, a, p = ca.SX.sym("x", 4), ca.SX.sym("a", 2), ca.SX.sym("p", m.np_)
    es = EffectSet(effects)
    theta = ca.SX.sym("theta", max(es.n_theta, 1))
    u, unr = model_inverse_function()(x, a, p)
    if effects:
        us = ca.SX.sym("u", 2)
        f = m.f(x, us, p)
        acc = ca.vertcat(f[1], f[3]) + effect_delta_function(effects)(x, us, p, theta[: es.n_theta])
        step = us - ca.mtimes(ca.inv(ca.jacobian(acc, us)), acc - a)
        newton = ca.Function("newton", [x, a, us, p, theta], [step])
        residual = ca.Function("residual", [x, a, us, p, theta], [acc - a])
        for _ in range(INVERSE_NEWTON_STEPS):
            u = newton(x, a, u, p, theta)
        r = residual(x, a, u, p, theta)
        off = ca.fmax(
            ca.fabs(r[0]) - INVERSE_TOLERANCE * (1 + ca.fabs(a[0])),
            ca.fabs(r[1]) - INVERSE_TOLERANCE * (1 + ca.fabs(a[1])),
        )
        unr = ca.logic_or(unr, off > 0)
    return ca.Function("planning_inverse", [x, a, p, theta], [u, unr], ["x", "a", "p", "theta"], ["u", "unreachable"])


#: Rows checked per mapped call beyond one chunk: longer tables are padded to a multiple of it.
CHECK_CHUNK = 256


def _limits_ok(
    samples: np.ndarray, params: Params, lim_axes: np.ndarray, lim_amp: float, effects: PlanEffects | None = None
) -> bool:
    """Do the model-inverse currents along ``samples`` (rows of :meth:`Move.sample`) fit the limits?

    ``lim_axes``: bounds of ``|i_q|`` and ``|i_d|`` [A]; ``lim_amp``: bound of the amplitude [A];
    ``effects``: the model file's static effects (:func:`planning_inverse_function`).
    """
    if samples.shape[0] % CHECK_CHUNK and samples.shape[0] > CHECK_CHUNK:
        # pad with the last row (a repeat changes nothing) to a multiple of the chunk: one mapped Function
        # serves every table length instead of one built per length
        pad = CHECK_CHUNK - samples.shape[0] % CHECK_CHUNK
        samples = np.vstack([samples, np.repeat(samples[-1:], pad, axis=0)])
    n = samples.shape[0]
    names = effects.names if effects is not None else ()
    theta = np.asarray(effects.theta if effects is not None and effects.theta else (0.0,), dtype=float)
    inv = _mapped_inverse(n, names)
    x = np.vstack([samples[:, 0], samples[:, 1], samples[:, 3], samples[:, 4]])
    a = np.vstack([samples[:, 2], samples[:, 5]])
    P = np.tile(params.vector()[:, None], (1, n))
    u, unr = inv(x, a, P, np.tile(theta[:, None], (1, n)))  # buffer API: no DM conversions
    u = u.reshape(n, 2).T
    if np.any(np.asarray(unr) > 0) or not np.all(np.isfinite(u)):
        return False
    amp = np.hypot(u[0], u[1])
    return bool(np.all(np.abs(u) <= np.asarray(lim_axes)[:, None]) and np.all(amp <= lim_amp))


def _limits_ok_st(
    samples: np.ndarray,
    params: Params,
    st: ReferenceSettings,
    i_axis: float,
    i_amp: float,
    effects: PlanEffects | None = None,
) -> bool:
    """:func:`_limits_ok` with the settings' fractions of the axis limit ``i_axis`` and the amplitude ``i_amp``."""
    lim_axes = np.array([st.axis_limit_fraction, st.i_d_limit_fraction]) * i_axis
    return _limits_ok(samples, params, lim_axes, st.current_fraction * i_amp, effects)


@functools.lru_cache(maxsize=16)
def _mapped_inverse(n: int, effects: tuple[str, ...] = ()) -> BufferedFunction:
    return BufferedFunction(planning_inverse_function(effects).map(n))
