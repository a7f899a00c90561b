"""The one stepping interface shared by every block (plant, observer, controller).

Every block is driven the same way, as do-mpc's ``make_step``: ``reset`` once,
then ``step`` once per 1 ms control period. Results are small dataclasses, not
tuples, so the runner can log them by name.

The closed loop (:class:`maglev_ocp.loop.ClosedLoop`) is always::

    y = plant.reset(x0)                       # Measurement at t = 0
    ctrl.reset(y, ref)
    for k in range(n):
        out = ctrl.step(y, ref(t_k))          # ControlOutput: commanded currents
        y = plant.step(out.u)                 # next Measurement, ZOH over Ts
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np


@dataclass
class Measurement:
    """What the rig's PC sees at one sample.

    Attributes
    ----------
    t : float
        Time [s].
    y : ndarray, shape (2,)
        Encoder readings ``(g, d)`` [m], quantized to the encoder resolution.
    x_true : ndarray, shape (4,) or None
        True state ``(g, g_dot, d, d_dot)`` (simulation only; ``None`` on a rig).
    info : dict
        Extra named signals (applied currents, events, ...).
    """

    t: float
    y: np.ndarray
    x_true: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)


@dataclass
class Reference:
    """Set-point for the controllers: target gap and position, and optionally their rates.

    Attributes
    ----------
    g, d : float
        Target gap and horizontal position [m].
    g_dot, d_dot, g_ddot, d_ddot : float
        Reference rates for feedforward (0 for set-point steps).
    """

    g: float
    d: float
    g_dot: float = 0.0
    d_dot: float = 0.0
    g_ddot: float = 0.0
    d_ddot: float = 0.0

    def position(self) -> np.ndarray:
        """Target ``(g, d)`` [m]."""
        return np.array([self.g, self.d])


@dataclass
class ControlOutput:
    """Result of one controller step.

    Attributes
    ----------
    u : ndarray, shape (2,)
        Commanded currents ``(i_q, i_d)`` [A], inside the limits.
    x_hat : ndarray, shape (4,) or None
        State estimate used for this step.
    stats : dict
        Named solver statistics (``status``, ``iterations``, ``fallback``, ...),
        logged as columns by the runner.
    """

    u: np.ndarray
    x_hat: np.ndarray | None = None
    stats: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class Controller(Protocol):
    """Anything that turns measurements into currents, once per period."""

    name: str

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Prepare for a new run starting at measurement ``y0``."""

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """Compute the currents to apply over the next period."""
