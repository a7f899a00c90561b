"""The thirteenth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v13"``; see :mod:`.laws_v13`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law
from .laws_v12_ool import G_REF, _Peaks, _Warming, current_force, smoothstep

__all__ = [
    "G_REF",
    "_V13",
    "BaseTilt",
    "ProbeFilter",
    "_Peaks",
    "_Warming",
    "current_force",
    "smoothstep",
]

#: Gravity [m/s^2].
G_EARTH = 9.81


class _V13:
    """Mixin: marks a law of the thirteenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v13"``)."""
        return {**super().describe(), "law_set": "v13"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class BaseTilt(_V13, Law):
    """The rig's base off level on compliant levelling feet (not in the library).

    The base is levelled to within ``theta0`` along the stroke; its feet (elastomer levelling mounts) give under the
    moving mover's weight, the base tilting further towards the mover by ``kappa`` radians per metre of its position
    (the structural loop's compliance and the machine's levelling: Slocum, "Precision Machine Design", Prentice
    Hall 1992, ch. 5 and 7; Rivin, "Stiffness and Damping in Mechanical Design", Marcel Dekker 1999, ch. 6 (machine
    mounts)). Gravity's component along the tilted stroke acts on the moving mass: ``F_d = -Mh g sin(theta0 + kappa
    d)`` (a tilt towards the mover: ``kappa < 0`` pulls it further out); the gap axis loses ``Mv g (1 - cos theta)``
    (second order, kept). Hook ``force``.
    """

    name = "base_tilt"
    library = False
    families = ("levelling_feet",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"levelling_feet": {"theta0": 0.01, "kappa": -0.1}}
    has_force = True

    def angle(self, d):
        """The base's tilt [rad] with the mover at ``d``."""
        return self.p["theta0"] + self.p["kappa"] * np.asarray(d, dtype=float)

    def force(self, g, gd, d, dd):
        """Gravity's components ``(F_g, F_d)`` [N] on the tilted base (the level base's weight taken out)."""
        th = self.angle(d)
        fd = -k.Mh * G_EARTH * np.sin(th)
        fg = k.Mv * G_EARTH * (1.0 - np.cos(th))  # less weight across the tilted gap: an upward remainder
        return fg + 0.0 * np.asarray(g, dtype=float), fd


class ProbeFilter(_V13, Law):
    """The gap probe's demodulator output filtered before the controller samples it (not in the library).

    An eddy-current (or inductive) gap probe demodulates its carrier and smooths the result with a low-pass filter
    of corner ``f_p`` (a few kHz down to hundreds of Hz in industrial conditioners: Fericean & Droxler, "New
    noncontacting inductive analog proximity and inductive linear displacement sensors for industrial automation",
    IEEE Sensors J. 7(11), 2007; Vyroubal, "Eddy-current displacement transducer with extended linear range and
    automatic tuning", IEEE Trans. Instrum. Meas. 58(9), 2009). The reading is the filter's output: a first-order
    lag of the true gap, ``tau_p = 1 / (2 pi f_p)``, the gap held over each sampling interval (step-invariant
    discretization: ``y_n = y_{n-1} + (1 - exp(-T / tau_p)) (g_n - y_{n-1})``, ``T`` the interval between readings),
    started at the first gap read. The horizontal encoder (digital) is untouched. Hook ``read_at`` (one reading per
    control period; along a recorded trajectory, the same recursion over its samples; size: the largest reading
    error).
    """

    name = "probe_filter"
    library = False
    families = ("demodulator_lpf",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"demodulator_lpf": {"f_p": 400.0}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """No reading yet."""
        self.y: np.ndarray | None = None
        self.t_prev: np.ndarray | None = None

    def tau(self) -> float:
        """The filter's time constant [s]."""
        return 1.0 / (2.0 * math.pi * self.p["f_p"])

    def filtered(self, g, t):
        """The recursion along the last axis of ``g`` at the times ``t`` (a recorded trajectory)."""
        g = np.asarray(g, dtype=float)
        t = np.broadcast_to(np.asarray(t, dtype=float), g.shape)
        y = np.empty_like(g)
        y[..., 0] = g[..., 0]
        a = -np.expm1(-np.diff(t, axis=-1) / self.tau())
        for n in range(1, g.shape[-1]):
            y[..., n] = y[..., n - 1] + a[..., n - 1] * (g[..., n] - y[..., n - 1])
        return y

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` at the dataset time ``t`` (no filter without a time)."""
        g = np.asarray(g, dtype=float)
        if t is None:
            return g, d
        if g.ndim == 2:  # a recorded trajectory (runs, samples)
            return self.filtered(g, t), d
        t = np.asarray(t, dtype=float).reshape(-1)
        if self.y is None or self.y.shape != g.shape or self.t_prev is None:
            self.y = g.copy()
        else:
            a = -np.expm1(-np.maximum(t - self.t_prev, 0.0) / self.tau())
            self.y = self.y + a * (g - self.y)
        self.t_prev = t.copy()
        return self.y.copy(), d
