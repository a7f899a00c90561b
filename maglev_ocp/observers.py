"""Velocity (and disturbance) observers from 10 um quantized encoders.

A finite difference of a 10 um quantized position at 1 kHz has a noise of the
order of 10 mm/s (NOTES.md), so every controller and the estimator use these
observers instead. The observer is a discrete high-gain observer in
predictor-corrector form on the shared model: the prediction integrates the
model with the applied currents (so the model's acceleration is fed forward),
and the correction places all error poles at ``z = exp(-Ts/eps)``, the discrete
image of the continuous high-gain observer's ``s = -1/eps``. With
``disturbance=True`` each axis carries an extra constant-acceleration state
(an extended-state observer) whose estimate the controllers use for
offset-free tracking.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import casadi as ca
import numpy as np
from pydantic import Field, field_validator

from . import constants as k
from .config import Strict
from .fastcall import BufferedFunction
from .model import get_model
from .params import NOMINAL, Params
from .signals import PARAM_NAMES


@dataclass
class ObserverSettings:
    """Tuning of :class:`HighGainObserver`.

    Attributes
    ----------
    eps : float
        Time constant of the error dynamics [s] (all poles at ``-1/eps``).
        Smaller is faster and noisier; 4 ms filters 10 um quantization to a
        velocity noise well below 1 mm/s.
    disturbance : bool
        Also estimate a constant acceleration disturbance per axis.
    """

    eps: float = 4e-3
    disturbance: bool = True


class HighGainObserver:
    """Discrete high-gain observer on the shared model (one per controller).

    Parameters
    ----------
    params : Params
        Model parameters used for the prediction.
    settings : ObserverSettings
        Tuning.
    Ts : float
        Sample period [s].

    Notes
    -----
    State per axis: position, velocity (and disturbance acceleration). The
    prediction step uses ``model.step(Ts)`` with the previous current plus the
    disturbance estimate times Ts^2/2 (position) and Ts (velocity); the
    correction uses the innovation of the quantized position.
    """

    def __init__(self, params: Params = NOMINAL, settings: ObserverSettings | None = None, Ts: float = k.Ts):
        self.settings = settings or ObserverSettings()
        self.Ts = Ts
        self.params = params
        self._p = params.vector()
        self._F = BufferedFunction(get_model().step(Ts, 1))
        n = 3 if self.settings.disturbance else 2
        F = np.eye(n)
        F[0, 1] = Ts
        if n == 3:
            F[0, 2] = Ts**2 / 2
            F[1, 2] = Ts
        rho = float(np.exp(-Ts / self.settings.eps))
        H = np.zeros((1, n))
        H[0, 0] = 1.0
        self.L = self._gain(F, H, rho)
        self.n_axis = n
        self.x_hat = np.zeros(4)
        self.dist = np.zeros(2)

    @staticmethod
    def _gain(F: np.ndarray, H: np.ndarray, rho: float) -> np.ndarray:
        # Error e+ = (I - L H) F e; its poles are those of F^T - F^T H^T L^T,
        # a state-feedback problem on (F^T, F^T H^T) solved by Ackermann.
        n = F.shape[0]
        A = F.T
        B = (F.T @ H.T).reshape(n, 1)
        C = np.hstack([np.linalg.matrix_power(A, i) @ B for i in range(n)])
        coeffs = np.poly(np.full(n, rho))
        phi = sum(c * np.linalg.matrix_power(A, n - i) for i, c in enumerate(coeffs))
        en = np.zeros((1, n))
        en[0, -1] = 1.0
        K = en @ np.linalg.solve(C, phi)
        return K.ravel()

    def reset(self, y0: np.ndarray, x0: np.ndarray | None = None) -> None:
        """Start at rest at the encoder reading ``y0 = (g, d)`` (or at ``x0``)."""
        y0 = np.asarray(y0, dtype=float)
        self.x_hat = np.array([y0[0], 0.0, y0[1], 0.0]) if x0 is None else np.asarray(x0, float).copy()
        self.dist = np.zeros(2)

    def predict(self, u_prev: np.ndarray) -> np.ndarray:
        """Model prediction one period ahead with the applied current and the disturbance."""
        (x,) = self._F(self.x_hat, u_prev, self._p)
        if self.settings.disturbance:
            Ts = self.Ts
            x[0] += self.dist[0] * Ts**2 / 2
            x[1] += self.dist[0] * Ts
            x[2] += self.dist[1] * Ts**2 / 2
            x[3] += self.dist[1] * Ts
        return x

    def step(self, y: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """Update with reading ``y`` taken after ``u_prev`` was held for one period.

        Returns
        -------
        ndarray, shape (4,)
            ``x_hat = (g, g_dot, d, d_dot)``.
        """
        xp = self.predict(np.asarray(u_prev, dtype=float))
        y = np.asarray(y, dtype=float)
        for axis, (ip, iv) in enumerate(((0, 1), (2, 3))):
            e = y[axis] - xp[ip]
            xp[ip] += self.L[0] * e
            xp[iv] += self.L[1] * e
            if self.settings.disturbance:
                self.dist[axis] += self.L[2] * e
        self.x_hat = xp
        return xp.copy()

    @property
    def disturbance(self) -> np.ndarray:
        """Estimated acceleration disturbance ``(a_g, a_d)`` [m/s^2] (zeros if disabled)."""
        return self.dist.copy()


def observer_update(x_hat, dist, u_prev, y, p, L, Ts: float, disturbance: bool, skip_nonfinite: bool = False):
    """Symbolic predictor-corrector update of :class:`HighGainObserver` (SX or MX).

    :func:`observer_update_innovation` without the innovation (see there for the parameters).

    Returns
    -------
    x_next, dist_next : casadi.SX
        Updated estimate and disturbance.
    """
    x_next, d_next, _ = observer_update_innovation(x_hat, dist, u_prev, y, p, L, Ts, disturbance, skip_nonfinite)
    return x_next, d_next


def observer_update_innovation(
    x_hat, dist, u_prev, y, p, L, Ts: float, disturbance: bool, skip_nonfinite: bool = False
):
    """Symbolic predictor-corrector update of :class:`HighGainObserver` (SX or MX).

    The one symbolic form of the observer, used by the code generator, the
    NMPC step Function and the vectorized offline observer of the estimator.
    The arithmetic is in the same order as :meth:`HighGainObserver.step`, so
    the numeric and symbolic observers agree to rounding (bit for bit in practice).

    Parameters
    ----------
    x_hat : casadi.SX, shape (4,)
        Estimate after the previous update ``(g, g_dot, d, d_dot)``.
    dist : casadi.SX, shape (2,)
        Acceleration disturbance estimate ``(a_g, a_d)`` [m/s^2] (ignored without ``disturbance``).
    u_prev : casadi.SX, shape (2,)
        Currents ``(i_q, i_d)`` held over the last period [A].
    y : casadi.SX, shape (2,)
        Encoder readings ``(g, d)`` [m].
    p : casadi.SX
        Model parameter vector.
    L : array_like
        Observer gain (position, velocity[, disturbance]), :attr:`HighGainObserver.L`.
    Ts : float
        Sample period [s].
    disturbance : bool
        Extended-state observer (a constant acceleration disturbance per axis).
    skip_nonfinite : bool
        Treat a non-finite (or absurd, > 1 km) reading as missing: prediction only.

    Returns
    -------
    x_next, dist_next : casadi.SX
        Updated estimate and disturbance.
    innovation : casadi.SX, shape (2,)
        The readings minus the predicted positions ``(e_g, e_d)`` [m] (zero for a skipped reading).
    """
    xp = get_model().step(Ts, 1)(x_hat, u_prev, p)
    if disturbance:
        # constant-acceleration disturbance over one period: Ts^2/2 on position, Ts on velocity
        xp = xp + ca.vertcat(dist[0] * Ts**2 / 2, dist[0] * Ts, dist[1] * Ts**2 / 2, dist[1] * Ts)
    e_g = y[0] - xp[0]
    e_d = y[1] - xp[2]
    if skip_nonfinite:
        ok = ca.fabs(y[0]) + ca.fabs(y[1]) < 1e3
        e_g = ca.if_else(ok, e_g, 0)
        e_d = ca.if_else(ok, e_d, 0)
    x_next = ca.vertcat(xp[0] + L[0] * e_g, xp[1] + L[1] * e_g, xp[2] + L[0] * e_d, xp[3] + L[1] * e_d)
    if disturbance:
        d_next = ca.vertcat(dist[0] + L[2] * e_g, dist[1] + L[2] * e_d)
    else:
        d_next = dist * 0 if isinstance(dist, ca.MX) else ca.SX.zeros(2)
    return x_next, d_next, ca.vertcat(e_g, e_d)


# ----------------------------------------------------------------------------- adaptive observer
#: Constants an adaptive observer can estimate (they enter the model linearly, ``model.linear_split``).
ADAPTABLE: tuple[str, ...] = ("C1", "C2", "C3", "C4")


class AdaptSettings(Strict):
    """Settings of the adaptive observer a controller runs (:func:`adapt_constants`), shared by FL and the NMPC.

    Attributes
    ----------
    adapt : list of str
        Constants (of :data:`ADAPTABLE`) whose relative error the observer estimates from the moves;
        ``[]`` turns it off.
    adapt_prior : float
        Prior standard deviation of the relative errors.
    adapt_noise : float or None
        Standard deviation of the innovation [m]; None: measured online (:func:`innovation_noise`).
    adapt_noise_floor, adapt_noise_time : float
        Least measured standard deviation [m] and the measurement's time constant [s].
    adapt_window : float
        How long after a move the constants are still updated [s].
    adapt_bound : float
        Largest relative correction.
    """

    adapt: list[Literal["C1", "C2", "C3", "C4"]] = Field(
        default_factory=lambda: ["C1", "C3", "C4"],
        description="model constants whose relative error the observer estimates online (adaptive observer, "
        "maglev_ocp.observers.adapt_constants): the controller's model (observer, prediction or predictor, "
        "feed-forward or inversion) uses the corrected constants, so the disturbance estimate no longer carries "
        "a move's current-proportional mismatch into the hold ([]: off; needs the disturbance estimate)",
    )
    adapt_prior: float = Field(
        0.1, gt=0, le=1, description="prior standard deviation of an adapted constant's relative error"
    )
    adapt_noise: float | None = Field(
        None,
        gt=0,
        description="standard deviation of the encoder innovation the constants' estimate assumes [m] (None: "
        "measured online, the running RMS of the innovation while the constants are not updated, per axis, "
        "never below adapt_noise_floor). A fixed 10 um, three times the default rig's 3.3 um, shrank the "
        "NMPC's estimate of the weakly excited C4 towards zero (-3.9 % for a -9.2 % error after two moves)",
    )
    adapt_noise_floor: float = Field(
        k.encoder_resolution / 12**0.5,
        gt=0,
        description="least innovation standard deviation the measured one may take [m]: the encoder's "
        "quantization error during a move (resolution / sqrt(12)); at rest a constant reading can make the "
        "innovation vanish",
    )
    adapt_noise_time: float = Field(
        0.2, gt=0, description="time constant of the running mean square of the innovation (adapt_noise: None) [s]"
    )
    adapt_window: float = Field(
        0.05,
        ge=0,
        description="the constants are updated only while the reference moves and this long after [s]: a "
        "planned move's currents are the excitation; a push, or the quantization at rest, would bias them",
    )
    adapt_bound: float = Field(
        0.25, gt=0, lt=0.9, description="largest relative correction of an adapted constant (projection)"
    )

    @field_validator("adapt")
    @classmethod
    def _adapt_unique(cls, v: list[str]) -> list[str]:
        if len(set(v)) != len(v):
            raise ValueError(f"adapt lists a constant twice: {v}; allowed: each of C1, C2, C3, C4 at most once")
        return v


def corrected_params(p, theta, names: tuple[str, ...]):
    """The parameter vector with the adapted constants corrected: ``p_j (1 + theta_j)`` (SX or MX).

    ``names`` are the adapted constants (of :data:`ADAPTABLE`), ``theta`` their
    relative errors in that order; ``p`` itself without ``names``.
    """
    if not names:
        return p
    scale = [1] * p.shape[0]
    for j, n in enumerate(names):
        scale[PARAM_NAMES.index(n)] = 1 + theta[j]
    return p * ca.vertcat(*scale)


def adapt_gate(since, age, moving, fresh, window: int):
    """When an adaptive observer may update its constants; ``(ok, since_next, age_next)`` (SX).

    ``since`` counts the periods since the reference last moved (``moving`` 1
    while it moves), ``age`` those since the reset; the constants are updated
    only within ``window`` periods of a move (the planned move's currents are
    the excitation: a push while holding, or the quantization's limit cycle at
    rest, moves the current too but would bias the constants, e.g. a 100 N pull
    drove C3 and C4 to -18 % and +25 % without the window), not right after the
    reset (``fresh``) and not within ``window`` of it (the observer's own
    start-up transient is no model error).
    """
    since_next = ca.if_else(moving, 0, ca.fmin(since + 1, 1e6))
    age_next = ca.fmin(age + 1, 1e6)
    ok = ca.logic_and(ca.logic_and(ca.logic_not(fresh), since_next <= window), age_next > window)
    return ok, since_next, age_next


def noise_gate(ok, age, fresh, y, window: int):
    """When the innovation's noise is measured (:func:`innovation_noise`), SX: the observer past its start-up
    (not ``fresh``, ``age`` beyond ``window``), the constants not being updated (not ``ok``, :func:`adapt_gate`)
    and the reading ``y`` finite (as :func:`observer_update_innovation`'s skip)."""
    started = ca.logic_and(ca.logic_not(fresh), age > window)
    finite = ca.fabs(y[0]) + ca.fabs(y[1]) < 1e3
    return ca.logic_and(ca.logic_and(started, ca.logic_not(ok)), finite)


def adapt_constants(x_prior, u_prev, p, ups, theta, cov, e, ok, names: tuple[str, ...], L, Ts: float, r2, bound):
    """One update of an adaptive observer's constants (SX); ``(dtheta, ups_plus, theta_next, cov_next)``.

    The discrete form of the adaptive observer of Q. Zhang (IEEE TAC 47(3),
    2002) on the extended-state observer of :func:`observer_update_innovation`:
    per axis the error of ``(pos, vel, a_dist)`` is ``eps = eta + Ups theta_err``
    with ``eta`` decaying by the observer's error dynamics ``(I - L H) F`` and the
    sensitivity ``Ups`` propagated as ``Ups^- = F Ups + G b``, ``Ups^+ = (I - L H) Ups^-``,
    ``b`` the acceleration per unit relative error (the constant's column of
    :meth:`maglev_ocp.model.MaglevModel.linear_split` times its value). The
    innovation ``e = H Ups^- theta_err`` (plus a decaying term) is a linear
    regression on ``phi = H Ups^-``, solved by recursive least squares
    (``K = P phi^T (phi P phi^T + R)^-1``) with projection onto ``|theta| <= bound``.

    Parameters
    ----------
    x_prior : casadi.SX, shape (4,)
        The estimate before the update (where the regressors are taken).
    u_prev : casadi.SX, shape (2,)
        Currents applied over the last period [A].
    p : casadi.SX
        Model parameter vector (uncorrected).
    ups : casadi.SX, shape (6 n,)
        Sensitivities, column-major ``6 x n``: rows ``(g, g_dot, a_g, d, d_dot, a_d)``.
    theta, cov : casadi.SX
        Relative errors (n) and their covariance (``n x n``, flattened).
    e : casadi.SX, shape (2,)
        Innovation ``(e_g, e_d)`` [m].
    ok : casadi.SX
        Update allowed (:func:`adapt_gate`); else ``dtheta = 0`` and ``cov`` kept.
    names : tuple of str
        The adapted constants.
    L : array_like
        Observer gain (position, velocity, disturbance).
    Ts : float
        Sample period [s].
    r2 : casadi.SX or float
        Variance of the innovation per axis [m^2] (shape 2, or one value for both; :func:`innovation_noise`).
    bound : float
        Largest ``|theta|``.

    Returns
    -------
    dtheta, ups_plus, theta_next, cov_next : casadi.SX
        The step of ``theta`` (the estimate moves by ``ups_plus dtheta``), the
        propagated sensitivities (``6 x n``), the new ``theta`` and ``cov`` (flattened).
    """
    n = len(names)
    A, _ = get_model().linear_split(names)(x_prior, u_prev, p)
    pj = ca.vertcat(*[p[PARAM_NAMES.index(nm)] for nm in names])
    ups = ca.reshape(ups, 6, n)
    cols, phis = [], []
    for j in range(n):
        col = []
        for axis, row in ((0, 1), (1, 3)):
            b = A[row, j] * pj[j]
            u_pos, u_vel, u_w = ups[3 * axis, j], ups[3 * axis + 1, j], ups[3 * axis + 2, j]
            # Ups^- = F Ups + G b (double integrator with the disturbance state, as the observer's gain design)
            m_pos = u_pos + Ts * u_vel + Ts**2 / 2 * (u_w + b)
            m_vel = u_vel + Ts * (u_w + b)
            phis.append(m_pos)
            # Ups^+ = (I - L H) Ups^-
            col += [m_pos - L[0] * m_pos, m_vel - L[1] * m_pos, u_w - L[2] * m_pos]
        cols.append(ca.vertcat(*col))
    ups_plus = ca.horzcat(*cols)
    Phi = ca.reshape(ca.vertcat(*phis), 2, n)  # rows (g, d), one column per constant
    # recursive least squares (a Kalman filter on constant parameters): the innovation's noise
    # (quantization, process noise) weighs each period's evidence; P shrinks as the moves inform theta
    P = ca.reshape(cov, n, n)
    Sm = ca.mtimes(ca.mtimes(Phi, P), Phi.T) + ca.diag(r2 * ca.DM.ones(2))
    K = ca.mtimes(ca.mtimes(P, Phi.T), ca.inv(Sm))
    P_new = P - ca.mtimes(ca.mtimes(K, Phi), P)
    P_new = 0.5 * (P_new + P_new.T)
    theta_new = ca.fmin(ca.fmax(theta + ca.mtimes(K, e), -bound), bound)
    dtheta = ca.if_else(ok, theta_new - theta, ca.SX.zeros(n))
    cov_next = ca.if_else(ok, ca.vec(P_new), cov)
    return dtheta, ups_plus, theta + dtheta, cov_next


def innovation_noise(
    noise, age, e, measure, fixed: float | None, window: int, Ts: float, time_const: float, floor: float
):
    """The innovation's variance per axis an adaptive update assumes, and the next ``noise`` state (SX).

    With ``fixed`` (a standard deviation [m]) its square. Else measured: the
    running mean square of the innovation ``e`` over the periods ``measure``
    (the constants not updated, the observer past its start-up, a finite
    reading), an average over the first periods and an exponential one of time
    constant ``time_const`` after; the update takes it no lower than
    ``floor^2``. The innovation there is the encoders' noise and quantization
    plus the rig's unmodelled forces at rest, which are what the least squares
    must weigh each period's evidence against: an assumed noise three times too
    large keeps a weakly excited constant (C4 on a gap move) at a fraction of
    its error for many moves (the prior's pull to zero).
    """
    if fixed is not None:
        return ca.DM.ones(2) * fixed**2, noise
    n_rest = ca.fmax(age - window, 1)  # a bound on the periods measured so far
    a = ca.fmax(1 / n_rest, Ts / time_const)
    noise_next = ca.if_else(measure, noise + a * (e**2 - noise), noise)
    return ca.fmax(noise, floor**2), noise_next


def adapt_shift(ups_plus, dtheta):
    """How the estimate moves with the constants' step: ``eps = eta + Ups theta_err``; ``(dx (4), ddist (2))``."""
    corr = ca.mtimes(ups_plus, dtheta)
    return ca.vertcat(corr[0], corr[1], corr[3], corr[4]), ca.vertcat(corr[2], corr[5])
