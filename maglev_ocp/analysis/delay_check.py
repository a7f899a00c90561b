"""Delay margin by simulation: the smallest added input delay at which the closed loop starts to oscillate.

The computed delay margin (:func:`maglev_ocp.analysis.margins.loop_margins`) comes from the linearized
loop; this check closes the nonlinear loop (the controller's own ``step``, the analysis plant of
:mod:`.plant_model`) with an extra delay on one current channel, a whole number of samples plus a
fraction (the zero-order-held command switches inside the period, :class:`DelayedPlantSim`), kicks it
with a small reference step on the axis, and measures the growth rate of the oscillation while it is
small (near the margin the nonlinear loop ends in a limit cycle, so a grown oscillation counts as
unstable before it saturates). Bisection on the delay finds where the growth rate changes sign.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..blocks import Controller, Measurement, Reference
from .controller_map import settle
from .margins import AXIS_INPUT, AXIS_OUTPUT
from .plant_model import AnalysisPlant, DelayedPlantSim


@dataclass
class DelayRun:
    """One closed-loop run with an added delay: its envelope growth rate [1/s] (> 0: unstable)."""

    delay_samples: float
    growth_per_s: float
    diverged: bool

    @property
    def unstable(self) -> bool:
        """The oscillation grows (or the run left the linear range)."""
        return self.diverged or self.growth_per_s > 0


def growth_rate(err: np.ndarray, Ts: float, window_s: float = 0.04, skip: int = 2, floor: float = 1e-15) -> float:
    """Exponential growth rate [1/s] of the oscillation in ``err``: slope of log of the window maxima.

    The first difference of ``err`` is used, so a constant offset or a slow drift does not hide the
    oscillation near the crossover frequency. The first ``skip`` windows (the kick's transient) are
    left out, and so is everything after the oscillation has decayed to rounding (``floor`` [m]).
    """
    de = np.abs(np.diff(np.asarray(err, dtype=float)))
    n = max(round(window_s / Ts), 2)
    m = len(de) // n
    peaks = de[: m * n].reshape(m, n).max(axis=1)[skip:]
    if peaks.size < 2:
        raise ValueError("run too short for a growth rate")
    low = np.nonzero(peaks < floor)[0]
    if low.size:
        if low[0] < 2:  # gone to rounding within the first windows: strongly damped
            return -math.inf
        peaks = peaks[: low[0]]
    t = (np.arange(peaks.size) + 0.5) * n * Ts
    return float(np.polyfit(t, np.log(peaks), 1)[0])


def run_with_delay(
    controller: Controller,
    plant: AnalysisPlant,
    g: float,
    d: float,
    axis: str,
    delay_samples: float,
    *,
    kick: float = 2e-6,
    duration_s: float = 1.0,
    limit: float = 50.0,
    settle_steps: int = 400,
) -> DelayRun:
    """Closed loop at hover ``(g, d)`` with ``delay_samples`` added to the current channel of ``axis``.

    The controller settles without the added delay first (so observer and integrators sit at the
    fixed point), then runs with the delay after a reference step of ``kick`` [m] on ``axis``; the run
    is unstable if the error grows past ``limit * kick``, else its growth rate decides.
    """
    xa, y, u = settle(controller, plant, g, d, n_steps=settle_steps)
    extra = np.zeros(2)
    extra[AXIS_INPUT[axis]] = delay_samples
    sim = DelayedPlantSim(plant, extra)
    y = sim.reset(xa, u)
    ref = Reference(g + (kick if axis == "g" else 0.0), d + (kick if axis == "d" else 0.0))
    target = ref.position()[AXIS_OUTPUT[axis]]
    n = round(duration_s / plant.Ts)
    err = np.empty(n)
    t0 = settle_steps * plant.Ts
    for i in range(n):
        out = controller.step(Measurement(t0 + i * plant.Ts, y.copy()), ref)
        uk = np.asarray(out.u, dtype=float)
        if not np.all(np.isfinite(uk)):
            return DelayRun(delay_samples, math.inf, True)
        y = sim.step(uk)
        err[i] = y[AXIS_OUTPUT[axis]] - target
        if abs(err[i]) > limit * kick:  # grown far past the kick: unstable (and soon out of the linear range)
            return DelayRun(delay_samples, math.inf, True)
    return DelayRun(delay_samples, growth_rate(err, plant.Ts), False)


@dataclass
class SimulatedDelayMargin:
    """Result of :func:`simulated_delay_margin`: the bracket and the runs made."""

    delay_samples: float
    stable_below: float
    unstable_above: float
    runs: list[DelayRun]


def simulated_delay_margin(
    make_controller,
    plant: AnalysisPlant,
    g: float,
    d: float,
    axis: str,
    guess_samples: float,
    *,
    rel_tol: float = 0.005,
    max_runs: int = 16,
    **kw,
) -> SimulatedDelayMargin:
    """Smallest added delay [samples] on ``axis`` that destabilizes the loop (bisection on growth rate).

    Parameters
    ----------
    make_controller : callable
        ``make_controller() -> Controller``: a fresh controller for each run.
    guess_samples : float
        Where to start looking (e.g. the computed margin); the bracket is widened until it holds.
    rel_tol : float
        Stop when the bracket is narrower than ``rel_tol`` times its midpoint.
    """
    runs: list[DelayRun] = []

    def unstable(tau: float) -> bool:
        r = run_with_delay(make_controller(), plant, g, d, axis, tau, **kw)
        runs.append(r)
        return r.unstable

    lo, hi = 0.0, max(guess_samples, 0.25) * 1.3
    while not unstable(hi):
        lo, hi = hi, hi * 1.6
        if len(runs) >= max_runs:
            return SimulatedDelayMargin(math.inf, lo, math.inf, runs)
    if unstable(0.0):
        return SimulatedDelayMargin(0.0, 0.0, 0.0, runs)
    lo = max(lo, 0.0)
    mid = max(guess_samples * 0.8, lo)
    if lo < mid < hi:  # a first cut near the guess saves steps
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    while hi - lo > rel_tol * 0.5 * (hi + lo) and len(runs) < max_runs:
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    return SimulatedDelayMargin(0.5 * (lo + hi), lo, hi, runs)


__all__ = ["DelayRun", "SimulatedDelayMargin", "growth_rate", "run_with_delay", "simulated_delay_margin"]
