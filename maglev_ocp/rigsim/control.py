"""The generator's own closed-loop controller: feedback linearization with a PID outer loop.

Written for this generator only (it shares no code with ``controllers/``). The
engineer's model is the nominal one of MODEL.md without cogging
(:mod:`.physics`); the outer loop places the closed-loop poles of each axis at
``-w`` (triple, PID with reference feedforward) and an alpha-beta observer
estimates the velocities from the quantized encoders, driven by the
commanded acceleration. Everything is vectorized over runs simulated side by
side (leading axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import constants as k
from .physics import NOMINAL, Constants, shape


@dataclass
class ControllerSettings:
    """Gains of the generator's controller.

    Attributes
    ----------
    w_g, w_d : float
        Closed-loop bandwidth per axis [rad/s] (triple pole of the PID loop).
    w_obs : float
        Observer bandwidth [rad/s] (double pole of the alpha-beta filter).
    """

    w_g: float = 45.0
    w_d: float = 35.0
    w_obs: float = 250.0


class FLController:
    """Feedback linearization (model inverse of seed eq. (2), nominal constants) with PID and an observer.

    Parameters
    ----------
    n_runs : int
        Number of runs controlled side by side.
    Ts : float
        Sample time [s].
    model : Constants
        The controller's belief of the constants (nominal by default).
    settings : ControllerSettings
        Gains.
    """

    def __init__(
        self, n_runs: int, Ts: float = k.Ts, model: Constants = NOMINAL, settings: ControllerSettings | None = None
    ):
        s = settings or ControllerSettings()
        self.Ts, self.c, self.n = Ts, model, n_runs
        w = np.array([s.w_g, s.w_d])
        self.kp, self.kd, self.ki = 3 * w * w, 3 * w, w**3
        r = math.exp(-s.w_obs * Ts)
        self.alpha, self.beta = 1 - r * r, (1 - r) ** 2 / Ts
        self.p_hat = np.zeros((n_runs, 2))
        self.v_hat = np.zeros((n_runs, 2))
        self.integ = np.zeros((n_runs, 2))
        self.a_prev = np.zeros((n_runs, 2))
        self.saturated = np.zeros(n_runs, bool)

    def reset(self, y: np.ndarray) -> None:
        """Start at rest at the readings ``y`` (n_runs, 2)."""
        self.p_hat = np.array(y, float)
        self.v_hat[:] = 0.0
        self.integ[:] = 0.0
        self.a_prev[:] = 0.0
        self.saturated[:] = False

    def inverse(self, g: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Currents that give accelerations ``a = (a_g, a_d)`` at gap ``g`` in the nominal model (no cogging).

        ``i_q`` from the horizontal equation, then ``i_d`` as the smaller-magnitude root of
        ``C4 f4 i_d^2 - C3 f3 i_d + (C4 f4 i_q^2 + C2 f2 - G + a_g) = 0``, written ``2 c0 / (b + sqrt(disc))``.
        """
        c = self.c
        sh = shape(np.maximum(g, 1e-3))
        i_q = -a[:, 1] / (c.C1 * sh.f1)
        a2, b1 = c.C4 * sh.f4, c.C3 * sh.f3
        c0 = a2 * i_q * i_q + c.C2 * sh.f2 - k.G + a[:, 0]
        disc = np.maximum(b1 * b1 - 4 * a2 * c0, 0.0)
        i_d = 2 * c0 / (b1 + np.sqrt(disc))
        return i_q, i_d

    def step(self, y: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """Currents ``(i_q, i_d)`` (n_runs, 2) for readings ``y`` and reference rows ``ref``.

        ``ref`` has shape (n_runs, 6): ``g, g_dot, g_ddot, d, d_dot, d_ddot``.
        """
        Ts = self.Ts
        # observer: predict with the commanded acceleration, correct with the reading
        p_pred = self.p_hat + Ts * self.v_hat + 0.5 * Ts * Ts * self.a_prev
        v_pred = self.v_hat + Ts * self.a_prev
        e_obs = y - p_pred
        self.p_hat = p_pred + self.alpha * e_obs
        self.v_hat = v_pred + self.beta * e_obs
        r = ref[:, [0, 3]]
        rd = ref[:, [1, 4]]
        rdd = ref[:, [2, 5]]
        err = r - y
        self.integ += np.where(self.saturated[:, None], 0.0, Ts * err)  # anti-windup: freeze when saturated
        a = rdd + self.kd * (rd - self.v_hat) + self.kp * (r - self.p_hat) + self.ki * self.integ
        i_q, i_d = self.inverse(y[:, 0], a)
        u = np.clip(np.column_stack([i_q, i_d]), -k.i_axis_max, k.i_axis_max)
        amp = np.hypot(u[:, 0], u[:, 1])
        scale = np.where(amp > k.i_amp_max, k.i_amp_max / np.maximum(amp, 1e-12), 1.0)
        u = u * scale[:, None]
        self.saturated = (scale < 1.0) | (np.abs(np.column_stack([i_q, i_d])) > k.i_axis_max).any(axis=1)
        self.a_prev = a
        return u


__all__ = ["ControllerSettings", "FLController"]
