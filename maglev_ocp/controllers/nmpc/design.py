"""The numeric design of one NMPC step: everything the stage modules bake in as constants.

:func:`make_design` turns :class:`~maglev_ocp.controllers.nmpc.settings.NMPCSettings` and a
resolved reference mode into a :class:`StepDesign`: the state layout, the
prediction model (RK4 of the shared model plus the observer's disturbance) and
its RTI Jacobians, the LQR terminal weight and fallback gain, and the observer
gain. The stage modules (:mod:`.observer`, :mod:`.planner`, :mod:`maglev_ocp.controllers.nmpc.reference`,
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
from maglev_ocp.params import NOMINAL, Params

from ..model_file import effect_delta_function, load_controller_model
from .layout import NU, NX, StateLayout
from .settings import NMPCSettings

#: Reference modes a step is built for (``auto`` is resolved by the controller).
MODES: tuple[str, ...] = ("plan", "preview")
#: Gaps at which the LQR fallback gain is designed; the step interpolates it at the reference gap [m].
LQR_GAP_GRID: tuple[float, ...] = tuple(float(g) for g in np.linspace(10e-3, 30e-3, 9))


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
        LQR terminal weight (times ``weights.terminal_scale``) and fallback
        gain at the design gap (20 mm), on the controller's own parameters
        (the step uses them without ``lqr_schedule``).
    L_obs : ndarray
        Observer gain (disturbance rows zeroed without ``offset_free``).
    K_grid : ndarray, shape (len(LQR_GAP_GRID), 2, 4)
        Fallback gains at the gaps of :data:`LQR_GAP_GRID` (the step interpolates
        them at the reference gap, :func:`scheduled_gain`).
    P_grid : ndarray, shape (len(LQR_GAP_GRID), 4, 4)
        Terminal weights at the same gaps (times ``weights.terminal_scale``); the
        step interpolates them at the terminal stage's reference gap
        (:func:`terminal_weight`).
    effects : tuple of str
        Static effects of the model file (``settings.model``) in the prediction,
        the observer and the feed-forward (empty: the shared model alone).
    theta : ndarray
        Their parameters (baked into the step as constants).
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
    K_grid: np.ndarray | None = None
    P_grid: np.ndarray | None = None
    effects: tuple[str, ...] = ()
    theta: np.ndarray | None = None

    def effect_accel(self, x: ca.SX, u: ca.SX, p: ca.SX) -> ca.SX:
        """What the model file's effects add to the accelerations ``(g_ddot, d_ddot)`` (zeros without effects)."""
        return effect_accel(self.effects, self.theta, x, u, p)

    @property
    def Ts(self) -> float:
        """Control period [s] (the step is generated for the rig's 1 kHz)."""
        return k.Ts


def model_effects(s: NMPCSettings) -> tuple[tuple[str, ...], np.ndarray | None]:
    """The static effects of the settings' model file and their parameters (``((), None)`` without one)."""
    if not s.model:
        return (), None
    cm = load_controller_model(s.model)
    return (cm.effects, cm.theta) if cm.effects else ((), None)


def effect_accel(effects: tuple[str, ...], theta: np.ndarray | None, x: ca.SX, u: ca.SX, p: ca.SX) -> ca.SX:
    """Accelerations ``(dg_ddot, dd_ddot)`` the effects add at ``(x, u)``: the effect library's own
    expressions minus the shared model's (:func:`maglev_ocp.controllers.model_file.effect_delta_function`)."""
    if not effects:
        return ca.SX.zeros(2)
    return effect_delta_function(effects)(x, u, p, ca.DM(theta))


def effect_substeps(effects: tuple[str, ...], theta: np.ndarray | None, p: np.ndarray, Ts: float = k.Ts) -> int:
    """RK4 sub-steps that keep the effects' velocity feedback inside RK4's stability interval.

    Friction's regularized sign (``tanh(v / v_reg)``, :class:`maglev_ocp.effects.Friction`) and eddy
    drag are stiff in the velocity: ``|d a / d v|`` up to ``(F_c + F_s) / (v_reg M)``; RK4 is stable
    for ``h |d a / d v| < 2.78``, so the period is split until ``h |d a / d v| <= 2``.
    """
    if not effects:
        return 1
    x, u = ca.SX.sym("x", NX), ca.SX.sym("u", NU)
    J = ca.Function("dv", [x, u], [ca.jacobian(effect_accel(effects, theta, x, u, ca.DM(p)), x)])
    worst = 0.0
    for g in (12e-3, 20e-3, 28e-3):
        for d in (-0.05, 0.0, 0.05):
            u0 = np.nan_to_num(np.asarray(get_model().u_eq(g, d, p), dtype=float).ravel())
            Jv = np.asarray(J([g, 0.0, d, 0.0], u0))
            worst = max(worst, abs(Jv[0, 1]), abs(Jv[1, 3]))
    return max(1, int(np.ceil(worst * Ts / 2.0)))


def prediction_model(
    s: NMPCSettings,
    Ts: float = k.Ts,
    effects: tuple[str, ...] = (),
    theta: np.ndarray | None = None,
    n_sub: int | None = None,
) -> tuple[ca.Function, ca.Function]:
    """RK4 of ``f(x,u,p) + (0, w_g, 0, w_d)`` over one period, and its Jacobians (exact or Taylor).

    With ``effects`` (a model file's static effects, parameters ``theta``) the
    right-hand side also carries what they add (:func:`effect_accel`), over
    ``n_sub`` RK4 sub-steps (default ``settings.n_sub``), and the Jacobians are
    the Taylor series with the effects' sensitivities to position and current
    (:func:`_effect_sensitivities`).
    """
    m = get_model()
    x, u, p, w = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("p", m.np_), ca.SX.sym("w", 2)
    E = ca.vertcat(0, w[0], 0, w[1])
    n = n_sub or s.n_sub

    def rhs(xs: ca.SX) -> ca.SX:
        if not effects:
            return m.f(xs, u, p) + E
        a = effect_accel(effects, theta, xs, u, p)
        return m.f(xs, u, p) + E + ca.vertcat(0, a[0], 0, a[1])

    xk = rk4(rhs, x, Ts / n, n)
    F = ca.Function("nmpc_pred", [x, u, p, w], [xk])
    if s.jacobian == "exact" and not effects:
        Ad, Bd = ca.jacobian(xk, x), ca.jacobian(xk, u)
    else:
        # Third-order Taylor series of the transition matrix at the node: |A_c Ts| ~ 0.04, so the
        # error is ~1e-7 relative; RTI converges to the same solution (the gaps use the exact RK4).
        Ac, Bc = m.linearization(x, u, p)
        if effects:
            Ac, Bc = _effect_sensitivities(effects, theta, x, u, p, Ac, Bc)
        T = Ts
        A2 = ca.mtimes(Ac, Ac)
        Ad = ca.DM.eye(NX) + Ac * T + A2 * (T**2 / 2) + ca.mtimes(A2, Ac) * (T**3 / 6)
        Bd = ca.mtimes(ca.DM.eye(NX) * T + Ac * (T**2 / 2) + A2 * (T**3 / 6), Bc)
    return F, ca.Function("nmpc_pred_jac", [x, u, p, w], [xk, Ad, Bd])


def _effect_sensitivities(effects, theta, x, u, p, Ac, Bc) -> tuple[ca.SX, ca.SX]:
    """The model's continuous Jacobians plus the effects' sensitivities to position and current.

    The effects' dependence on the velocities is left out of the QP's
    linearization (an inexact RTI Jacobian; the shooting gaps keep the exact
    RK4 with the effects): friction's regularized sign has ``|d a / d v|`` of
    thousands per second at rest, and linearized there it tells the QP that a
    force hardly moves the mover, which it then over-drives at every start and
    stop of a move (measured: tracking RMS on a friction rig 14.5 um with it,
    against 11.4 um blind).
    """
    a = effect_accel(effects, theta, x, u, p)
    ea = ca.vertcat(0, a[0], 0, a[1])
    Jx = ca.jacobian(ea, x)
    Jx[:, 1] = 0
    Jx[:, 3] = 0
    return Ac + Jx, Bc + ca.jacobian(ea, u)


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


def scheduled_gain(grid: np.ndarray, g: ca.SX) -> ca.SX:
    """A gain designed on :data:`LQR_GAP_GRID`, linearly interpolated at gap ``g`` (SX, branch-free).

    Hat-function weights ``max(0, 1 - |g - g_i| / h)`` on the clamped gap: the
    weights sum to one, so between two grid gaps the gain is their linear blend.
    """
    gs = np.asarray(LQR_GAP_GRID)
    h = float(gs[1] - gs[0])
    gc = ca.fmin(ca.fmax(g, gs[0]), gs[-1])
    out = ca.SX.zeros(grid.shape[1], grid.shape[2])
    for gi, Mi in zip(gs, grid, strict=True):
        out += ca.fmax(0, 1 - ca.fabs(gc - gi) / h) * ca.DM(Mi)
    return out


def terminal_weight(d: StepDesign, g: ca.SX) -> ca.SX:
    """Terminal weight of the QP at the terminal stage's reference gap ``g`` (SX).

    With ``lqr_schedule`` the DARE solutions on :data:`LQR_GAP_GRID` (the
    controller's own parameters, times ``weights.terminal_scale``) interpolated
    at ``g`` like the fallback gain (:func:`scheduled_gain`): the infinite-horizon
    tail the terminal cost stands for is the one of the operating point the
    horizon ends at. Without it, the constant 20 mm design ``d.P``.
    """
    if d.P_grid is None:
        return ca.SX(ca.DM(d.P))
    return scheduled_gain(d.P_grid, g)


def fn_terminal_weight(d: StepDesign) -> ca.Function:
    """``nmpc_terminal_weight(g) -> P`` (SX Function of :func:`terminal_weight`)."""
    g = ca.SX.sym("g")
    return ca.Function("nmpc_terminal_weight", [g], [terminal_weight(d, g)], ["g"], ["P"], {"cse": True})


def observer_gain(s: NMPCSettings, Ts: float = k.Ts) -> np.ndarray:
    """Gain of the extended-state high-gain observer (:class:`~maglev_ocp.observers.HighGainObserver`)."""
    obs = HighGainObserver(NOMINAL, ObserverSettings(eps=s.observer_eps, disturbance=True), Ts)
    L = obs.L.copy()
    if not s.offset_free:
        L[2] = 0.0
    return L


def adapted(s: NMPCSettings) -> tuple[str, ...]:
    """The constants the observer adapts (none without the disturbance estimate it works with)."""
    return tuple(s.adapt) if s.offset_free else ()


def make_design(settings: NMPCSettings, mode: str, params: Params | None = None) -> StepDesign:
    """The :class:`StepDesign` of ``settings`` for reference mode ``mode`` (``plan`` or ``preview``).

    ``params``: the controller's model (as the step receives it, cogging already
    dropped if ``use_cogging`` is off); the LQR terminal weight and fallback
    gains are designed on it (``None``: the nominal constants, as before
    ``lqr_schedule``). With ``settings.lqr_schedule`` the fallback gain is
    designed on a grid of gaps and interpolated at the reference gap.
    """
    if mode not in MODES:
        raise ValueError(f"NMPC reference mode must be 'plan' or 'preview', got {mode!r}")
    effects, theta = model_effects(settings)
    n_sub = None
    if effects:
        n_sub = max(settings.n_sub, effect_substeps(effects, theta, (params or NOMINAL).vector()))
    F, FJ = prediction_model(settings, effects=effects, theta=theta, n_sub=n_sub)
    own = params if (params is not None and settings.lqr_schedule) else NOMINAL
    P, K = lqr_design(settings, own)
    K_grid = P_grid = None
    if settings.lqr_schedule:
        PK = [lqr_design(settings, own, g0=g) for g in LQR_GAP_GRID]
        P_grid = np.stack([P_ for P_, _ in PK]) * settings.weights.terminal_scale
        K_grid = np.stack([K_ for _, K_ in PK])
    return StepDesign(
        settings=settings,
        mode=mode,
        layout=StateLayout(settings.horizon, settings.n_gap, settings.delay_samples, len(adapted(settings))),
        model=get_model(),
        F=F,
        FJ=FJ,
        P=P * settings.weights.terminal_scale,
        K=K,
        L_obs=observer_gain(settings),
        K_grid=K_grid,
        P_grid=P_grid,
        effects=effects,
        theta=theta,
    )


__all__ = [
    "LQR_GAP_GRID",
    "MODES",
    "StepDesign",
    "adapted",
    "effect_accel",
    "effect_substeps",
    "fn_terminal_weight",
    "lqr_design",
    "make_design",
    "model_effects",
    "observer_gain",
    "prediction_model",
    "scheduled_gain",
    "terminal_weight",
]
