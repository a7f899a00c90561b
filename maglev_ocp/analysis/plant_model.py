"""The plant the loop analysis linearizes and simulates: the shared model, the amplifier lag and a delay.

One CasADi Function integrates the shared model (:func:`maglev_ocp.model.get_model`, seed eq. (2) with
the spec's cogging) over one control period with the amplifier's first-order current lag
``di/dt = 2 pi f_bw (u(t - tau) - i)`` (NOTES.md, :class:`maglev_ocp.effects.AmplifierLag`) as two extra
states. The transport delay ``tau = (n + f) Ts`` is a buffer of ``n`` whole commands plus a switch at
``f Ts`` inside the period from the previous command to the next one, per channel, so a delay that is
not a whole number of samples is simulated exactly (the zero-order-held command is shifted in time,
not interpolated). With ``f = 0`` the Function is the plain zero-order-hold step whose Jacobians give
the discrete linear plant (:meth:`AnalysisPlant.linearize`); the whole delay samples become shift
register states there.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .. import constants as k
from ..model import get_model, rk4
from ..params import NOMINAL, Params

#: RK4 steps per piece of a period (the lag's pole at 2 pi 2 kHz needs h < 2.8 / omega: 10 steps are 4x inside).
N_SUB = 10


@functools.lru_cache(maxsize=8)
def plant_step_function(lag: bool, Ts: float = k.Ts, n_sub: int = N_SUB) -> ca.Function:
    """One period of the analysis plant, with a per-channel switch time of the command.

    ``step(xa, u_old, u_new, frac, p, wc) -> xa_next``: ``xa = (g, g_dot, d, d_dot[, i_q, i_d])`` (the
    applied currents are states when ``lag``); the amplifier input is ``u_old[c]`` on ``[0, frac[c] Ts)``
    and ``u_new[c]`` after, for each channel ``c``; ``wc`` is the lag's bandwidth [rad/s].
    The period is integrated in three pieces split at the two switch times, ``n_sub`` RK4 steps each.
    """
    m = get_model()
    nxa = 6 if lag else 4
    xa = ca.SX.sym("xa", nxa)
    u_old, u_new, frac = ca.SX.sym("u_old", 2), ca.SX.sym("u_new", 2), ca.SX.sym("frac", 2)
    p, wc = ca.SX.sym("p", m.np_), ca.SX.sym("wc")
    t1 = ca.fmin(frac[0], frac[1]) * Ts
    t2 = ca.fmax(frac[0], frac[1]) * Ts
    # between the switches the channel with the earlier switch already carries its new command
    first = ca.vertcat(frac[0] <= frac[1], frac[1] < frac[0])
    u_mid = ca.vertcat(*[ca.if_else(first[c], u_new[c], u_old[c]) for c in range(2)])

    def rhs_for(u_in: ca.SX):
        def rhs(xs: ca.SX) -> ca.SX:
            if lag:
                i_app = xs[4:6]
                return ca.vertcat(m.f(xs[0:4], i_app, p), wc * (u_in - i_app))
            return m.f(xs, u_in, p)

        return rhs

    x = xa
    for u_in, length in ((u_old, t1), (u_mid, t2 - t1), (u_new, Ts - t2)):
        x = rk4(rhs_for(u_in), x, length / n_sub, n_sub)
    name = f"analysis_plant_{'lag' if lag else 'nolag'}"
    return ca.Function(
        name, [xa, u_old, u_new, frac, p, wc], [x], ["xa", "u_old", "u_new", "frac", "p", "wc"], ["xa_next"]
    )


@dataclass
class LinearPlant:
    """Discrete linear plant around a hover point: ``x+ = A x + B u``, ``y = C x`` (no feedthrough).

    The state is the mechanical state, the applied currents (with the lag) and the delayed commands
    (newest first); ``u`` is the command the controller computes at sample ``k`` and ``y`` the
    positions ``(g, d)`` read at sample ``k``. Deviations from the hover point.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    Ts: float


@dataclass
class AnalysisPlant:
    """Noise-free plant for the loop analysis: shared model, amplifier lag, transport delay.

    Parameters
    ----------
    params : Params
        The plant's true model parameters.
    lag_hz : float or None
        Amplifier bandwidth [Hz] (``None``: no lag).
    delay_samples : int
        Whole control periods between a command and the amplifier input (the rig's computation delay).
    Ts : float
        Control period [s].
    """

    params: Params = NOMINAL
    lag_hz: float | None = 2000.0
    delay_samples: int = 0
    Ts: float = k.Ts
    _fn: ca.Function = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.delay_samples < 0:
            raise ValueError(f"delay_samples must be >= 0, got {self.delay_samples}")
        self._fn = plant_step_function(self.lag_hz is not None, self.Ts)
        self._p = self.params.vector()
        self._wc = 2 * math.pi * self.lag_hz if self.lag_hz is not None else 0.0

    @property
    def nxa(self) -> int:
        """Number of plant states (mechanical plus applied currents)."""
        return 6 if self.lag_hz is not None else 4

    def hover(self, g: float, d: float) -> tuple[np.ndarray, np.ndarray]:
        """Hover state ``xa`` and currents at ``(g, d)`` (seed eq. (8) with cogging)."""
        u = np.asarray(get_model().u_eq(g, d, self._p), dtype=float).ravel()
        if not np.all(np.isfinite(u)):
            raise ValueError(f"the plant cannot hover at g = {g * 1e3:.2f} mm, d = {d * 1e3:.2f} mm")
        x = np.array([g, 0.0, d, 0.0])
        return (np.concatenate([x, u]) if self.lag_hz is not None else x), u

    def step(self, xa: np.ndarray, u_old: np.ndarray, u_new: np.ndarray, frac: np.ndarray) -> np.ndarray:
        """One period from ``xa``: the amplifier input switches from ``u_old`` to ``u_new`` at ``frac Ts``."""
        return np.asarray(self._fn(xa, u_old, u_new, frac, self._p, self._wc), dtype=float).ravel()

    def linearize(self, xa: np.ndarray, u: np.ndarray) -> LinearPlant:
        """Discrete linearization at ``(xa, u)`` with the delay as ``delay_samples`` command states.

        The Jacobians of the zero-order-hold step (``frac = 0``) are exact (CasADi AD of the RK4 map).
        """
        xs, us = ca.SX.sym("xs", self.nxa), ca.SX.sym("us", 2)
        z2 = ca.DM.zeros(2)
        xn = self._fn(xs, us, us, z2, self._p, self._wc)
        jac = ca.Function("plant_jacobians", [xs, us], [ca.jacobian(xn, xs), ca.jacobian(xn, us)])
        Ad, Bd = (np.asarray(v, dtype=float) for v in jac(xa, u))
        n, N = self.nxa, self.delay_samples
        C = np.zeros((2, n + 2 * N))
        C[0, 0] = C[1, 2] = 1.0
        if N == 0:
            return LinearPlant(Ad, Bd, C, self.Ts)
        # buffer (u_{k-1}, ..., u_{k-N}); the amplifier gets u_{k-N}
        A = np.zeros((n + 2 * N, n + 2 * N))
        B = np.zeros((n + 2 * N, 2))
        A[:n, :n] = Ad
        A[:n, n + 2 * (N - 1) : n + 2 * N] = Bd
        B[n : n + 2] = np.eye(2)
        for j in range(1, N):
            A[n + 2 * j : n + 2 * j + 2, n + 2 * (j - 1) : n + 2 * j] = np.eye(2)
        return LinearPlant(A, B, C, self.Ts)


class DelayedPlantSim:
    """The analysis plant stepped in a loop, with an extra input delay per channel (whole plus fraction).

    Parameters
    ----------
    plant : AnalysisPlant
        The plant (its own ``delay_samples`` are part of the delay).
    extra_delay : array_like (2,)
        Added delay per channel ``(i_q, i_d)`` [samples], any non-negative real.
    """

    def __init__(self, plant: AnalysisPlant, extra_delay: np.ndarray | tuple[float, float] = (0.0, 0.0)):
        self.plant = plant
        tau = plant.delay_samples + np.asarray(extra_delay, dtype=float).reshape(2)
        if np.any(tau < 0):
            raise ValueError(f"delays must be >= 0, got {tau}")
        self._n = [int(v) for v in np.floor(tau)]
        self._frac = tau - np.floor(tau)
        self.xa = np.zeros(plant.nxa)
        self._buf: list[deque[float]] = [deque(), deque()]

    def reset(self, xa: np.ndarray, u0: np.ndarray) -> np.ndarray:
        """Start at ``xa`` with the amplifier having carried ``u0`` for ever; return the reading ``(g, d)``."""
        self.xa = np.asarray(xa, dtype=float).copy()
        # per channel: the last n + 1 commands (oldest first)
        self._buf = [deque([float(u0[c])] * (self._n[c] + 1), maxlen=self._n[c] + 2) for c in range(2)]
        return self.xa[[0, 2]].copy()

    def step(self, u: np.ndarray) -> np.ndarray:
        """Apply command ``u`` of this sample; return the reading one period later."""
        u_old, u_new = np.zeros(2), np.zeros(2)
        for c in range(2):
            b = self._buf[c]
            b.append(float(u[c]))
            # command of sample k - n (new) and k - n - 1 (old): the input switches at frac Ts
            u_new[c], u_old[c] = b[-1 - self._n[c]], b[-2 - self._n[c]]
        self.xa = self.plant.step(self.xa, u_old, u_new, self._frac)
        return self.xa[[0, 2]].copy()


__all__ = ["N_SUB", "AnalysisPlant", "DelayedPlantSim", "LinearPlant", "plant_step_function"]
