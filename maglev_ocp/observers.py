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

import casadi as ca
import numpy as np

from . import constants as k
from .fastcall import BufferedFunction
from .model import get_model
from .params import NOMINAL, Params


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
