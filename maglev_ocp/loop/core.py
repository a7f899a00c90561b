"""The closed loop: a controller and a plant stepped together, one control period at a time.

Every closed-loop run of the suite (a scenario of :mod:`maglev_ocp.runner`, a
campaign run, the diagnosis' datasets and closed-loop view, the seed's
calibration experiments, ``maglev simulate``) is this loop::

    y = plant.reset(x0)                       # Measurement at t = 0
    ctrl.reset(y, ref(0))
    for k in range(n):
        out = ctrl.step(y, ref(k))            # timed: the controller's computation
        y_next = plant.step(out.u)            # ZOH over one period; delays and limits inside the plant
        recorder.record(k, y, ref, out, ...)  # what each caller logs
        y = y_next

What differs between callers is only what they log, so logging is pluggable:
a :class:`Recorder` sees every step (:mod:`.recorders` has the scenario trace
and the rig-log columns). What happens when the controller fails is a policy
of the loop: ``on_error="raise"`` lets the exception through (a data
generator must not write half a run silently); ``on_error="stop"`` ends the run
and keeps the message in :attr:`ClosedLoop.error` (a scenario run is then
failed, never lost).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from tqdm.auto import tqdm

from ..blocks import Controller, ControlOutput, Measurement, Reference
from ..plant import Plant

#: Steps between progress-bar updates (an update costs more than a fast controller's step).
PROGRESS_EVERY = 64


@dataclass(frozen=True, slots=True)
class StepRecord:
    """What happened in one control period of a :class:`ClosedLoop` (what a :class:`Recorder` sees).

    Attributes
    ----------
    i : int
        Step index (time ``i Ts``).
    y : Measurement
        The measurement the controller saw.
    ref : Reference or None
        The reference it was given.
    out : ControlOutput
        What it returned.
    u : ndarray (2,)
        The commanded currents handed to the plant (``out.u`` as floats).
    dt_us : float
        The controller's computation time [µs] (wall clock).
    y_next : Measurement
        The plant's measurement one period later (its ``info`` tells what the
        limiter did and which current the amplifiers carried).
    """

    i: int
    y: Measurement
    ref: Reference | None
    out: ControlOutput
    u: np.ndarray
    dt_us: float
    y_next: Measurement


class Recorder(Protocol):
    """What a caller logs of each step of a :class:`ClosedLoop`."""

    def start(self, y0: Measurement) -> None:
        """A run starts at measurement ``y0``."""

    def record(self, s: StepRecord) -> None:
        """Step ``s.i`` is done."""


class ClosedLoop:
    """A controller and a plant stepped together, with recorders logging each step.

    Parameters
    ----------
    plant : Plant
        The simulated rig.
    controller : Controller
        Anything with ``reset(y0, ref)`` and ``step(y, ref) -> ControlOutput``.
    recorders : sequence of Recorder
        What to log (may be empty: the plant keeps its own rig log).
    on_error : {"raise", "stop"}
        A controller that raises or returns non-finite currents: let the error
        through, or end the run and keep the message in :attr:`error`.

    Attributes
    ----------
    y : Measurement
        The latest measurement.
    steps : int
        Steps done since :meth:`reset`.
    error : str or None
        Why the run ended early (``on_error="stop"`` only).
    """

    def __init__(
        self,
        plant: Plant,
        controller: Controller,
        recorders: Sequence[Recorder] = (),
        *,
        on_error: str = "raise",
    ):
        if on_error not in ("raise", "stop"):
            raise ValueError(f"on_error must be 'raise' or 'stop', got {on_error!r}")
        self.plant = plant
        self.controller = controller
        self.recorders = tuple(recorders)
        self.on_error = on_error
        self.y: Measurement | None = None
        self.steps = 0
        self.error: str | None = None

    @property
    def Ts(self) -> float:
        """Control period [s] (the plant's)."""
        return self.plant.Ts

    def reset(
        self,
        x0: np.ndarray | None,
        ref0: Reference | None,
        *,
        u0: np.ndarray | None = None,
        lock: str | None = None,
    ) -> Measurement:
        """Start a run: reset the plant at ``x0`` (see :meth:`Plant.reset`), then the controller on ``ref0``."""
        y = self.plant.reset(x0, u0, lock=lock)
        self.controller.reset(y, ref0)
        for rec in self.recorders:
            rec.start(y)
        self.y, self.steps, self.error = y, 0, None
        return y

    def step(self, ref: Reference | None) -> bool:
        """One control period: controller step (timed), plant step, recorders.

        Returns
        -------
        bool
            ``False`` if the run ended here (``on_error="stop"`` and the controller failed).
        """
        y, i = self.y, self.steps
        if y is None:
            raise RuntimeError("call ClosedLoop.reset() before ClosedLoop.step()")
        perf = time.perf_counter
        try:
            t0 = perf()
            out = self.controller.step(y, ref)
            dt_us = (perf() - t0) * 1e6
            u = np.asarray(out.u, dtype=float).reshape(2)
        except Exception as err:  # a controller bug or a solver crash
            if self.on_error == "raise":
                raise
            self.error = f"controller raised at t = {i * self.Ts:.3f} s: {type(err).__name__}: {err}"
            return False
        if self.on_error == "stop" and not np.all(np.isfinite(u)):
            self.error = f"controller returned non-finite currents {u.tolist()} at t = {i * self.Ts:.3f} s"
            return False
        y_next = self.plant.step(u)  # raises on non-finite currents (on_error="raise")
        rec_step = StepRecord(i, y, ref, out, u, dt_us, y_next)
        for rec in self.recorders:
            rec.record(rec_step)
        self.y, self.steps = y_next, i + 1
        return True

    def run(
        self, reference: Callable[[int], Reference | None], n: int, *, progress: bool = False, desc: str | None = None
    ) -> int:
        """Step ``n`` periods (or until the controller fails); ``reference(i)`` is the reference of step ``i``.

        Returns
        -------
        int
            Steps done.
        """
        bar = tqdm(total=n, desc=desc, unit="step", disable=not progress, mininterval=0.5, leave=False)
        for i in range(n):
            if not self.step(reference(i)):
                break
            if progress and (i & (PROGRESS_EVERY - 1)) == 0:
                bar.update(i + 1 - bar.n)
        bar.update(self.steps - bar.n)
        bar.close()
        return self.steps


__all__ = ["PROGRESS_EVERY", "ClosedLoop", "Recorder", "StepRecord"]
