"""The numeric design of one NMPC step: everything the stage modules bake in as constants.

:func:`make_design` turns :class:`~controllers.nmpc.settings.NMPCSettings` and a
resolved reference mode into a :class:`StepDesign`: the state layout, the
prediction model (RK4 of the shared model plus the observer's disturbance) and
its RTI Jacobians, the LQR terminal weight and fallback gain, and the observer
gain. The stage modules (:mod:`.observer`, :mod:`.planner`, :mod:`.reference`,
:mod:`.prediction`, :mod:`.admm`, :mod:`.fallback`) read the settings through
``design.settings``; nothing is renamed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg

from maglev_ocp import constants as k
from maglev_ocp.model import get_model, rk4
from maglev_ocp.observers import HighGainObserver, ObserverSettings
from maglev_ocp.params import NOMINAL

from .layout import NU, NX, StateLayout
from .settings import NMPCSettings

#: Reference modes a step is built for (``auto`` is resolved by the controller).
MODES: tuple[str, ...] = ("plan", "preview")


@dataclass(frozen=True)
class StepDesign:
    """Settings, reference mode and the derived constants of one step Function.

    Attributes
    ----------
    settings : NMPCSettings
        The controller's settings (the one source of every option).
    mode : {"plan", "preview"}
        Reference mode baked into the step.
    layout : StateLayout
        Layout of the state vector.
    model : Model
        The shared model (:func:`maglev_ocp.model.get_model`).
    F, FJ : casadi.Function
        Prediction ``F(x, u, p, w) -> x_next`` and ``FJ(x, u, p, w) -> (x_next, A, B)``.
    P, K : ndarray
        LQR terminal weight (times ``weights.terminal_scale``) and fallback gain.
    L_obs : ndarray
        Observer gain (disturbance rows zeroed without ``offset_free``).
    """

    settings: NMPCSettings
    mode: str
    layout: StateLayout
    model: Any
    F: ca.Function
    FJ: ca.Function
    P: np.ndarray
    K: np.ndarray
    L_obs: np.ndarray

    @property
    def Ts(self) -> float:
        """Control period [s] (the step is generated for the rig's 1 kHz)."""
        return k.Ts


def prediction_model(s: NMPCSettings, Ts: float = k.Ts) -> tuple[ca.Function, ca.Function]:
    """RK4 of ``f(x,u,p) + (0, w_g, 0, w_d)`` over one period, and its Jacobians (exact or Taylor)."""
    m = get_model()
    x, u, p, w = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("p", m.np_), ca.SX.sym("w", 2)
    E = ca.vertcat(0, w[0], 0, w[1])
    xk = rk4(lambda xs: m.f(xs, u, p) + E, x, Ts / s.n_sub, s.n_sub)
    F = ca.Function("nmpc_pred", [x, u, p, w], [xk])
    if s.jacobian == "exact":
        Ad, Bd = ca.jacobian(xk, x), ca.jacobian(xk, u)
    else:
        # Third-order Taylor series of the transition matrix at the node: |A_c Ts| ~ 0.04, so the
        # error is ~1e-7 relative; RTI converges to the same solution (the gaps use the exact RK4).
        Ac, Bc = m.linearization(x, u, p)
        T = Ts
        A2 = ca.mtimes(Ac, Ac)
        Ad = ca.DM.eye(NX) + Ac * T + A2 * (T**2 / 2) + ca.mtimes(A2, Ac) * (T**3 / 6)
        Bd = ca.mtimes(ca.DM.eye(NX) * T + Ac * (T**2 / 2) + A2 * (T**3 / 6), Bc)
    return F, ca.Function("nmpc_pred_jac", [x, u, p, w], [xk, Ad, Bd])


def lqr_design(s: NMPCSettings, params=NOMINAL, g0: float = 20e-3, Ts: float = k.Ts) -> tuple[np.ndarray, np.ndarray]:
    """Discrete LQR at hover (gap ``g0``, ``d = 0``): terminal weight ``P`` and fallback gain ``K``.

    Returns
    -------
    P : ndarray, shape (4, 4)
        DARE solution for the settings' ``Q`` and ``R`` (the infinite-horizon tail).
    K : ndarray, shape (2, 4)
        Gain of ``u = u_ref + K (x - x_ref)``.
    """
    m = get_model()
    p = params.vector()
    u0 = np.asarray(m.u_eq(g0, 0.0, p)).ravel()
    F = m.step(Ts, 1)
    x = ca.SX.sym("x", NX)
    u = ca.SX.sym("u", NU)
    J = ca.Function("J", [x, u], [ca.jacobian(F(x, u, p), x), ca.jacobian(F(x, u, p), u)])
    A, B = (np.asarray(M) for M in J([g0, 0, 0, 0], u0))
    Q, R = np.diag(s.Q), np.diag(s.R)
    P = scipy.linalg.solve_discrete_are(A, B, Q, R)
    K = -np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    return P, K


def observer_gain(s: NMPCSettings, Ts: float = k.Ts) -> np.ndarray:
    """Gain of the extended-state high-gain observer (:class:`~maglev_ocp.observers.HighGainObserver`)."""
    obs = HighGainObserver(NOMINAL, ObserverSettings(eps=s.observer_eps, disturbance=True), Ts)
    L = obs.L.copy()
    if not s.offset_free:
        L[2] = 0.0
    return L


def make_design(settings: NMPCSettings, mode: str) -> StepDesign:
    """The :class:`StepDesign` of ``settings`` for reference mode ``mode`` (``plan`` or ``preview``)."""
    if mode not in MODES:
        raise ValueError(f"NMPC reference mode must be 'plan' or 'preview', got {mode!r}")
    F, FJ = prediction_model(settings)
    P, K = lqr_design(settings)
    return StepDesign(
        settings=settings,
        mode=mode,
        layout=StateLayout(settings.horizon, settings.n_gap, settings.delay_samples),
        model=get_model(),
        F=F,
        FJ=FJ,
        P=P * settings.weights.terminal_scale,
        K=K,
        L_obs=observer_gain(settings),
    )


__all__ = ["MODES", "StepDesign", "lqr_design", "make_design", "observer_gain", "prediction_model"]
