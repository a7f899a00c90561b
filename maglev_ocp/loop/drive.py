"""Rig-log runs on the plant: closed loop with a controller, or open loop with a current sequence.

Both are :class:`~maglev_ocp.loop.core.ClosedLoop` runs that return one
:class:`~maglev_ocp.riglog.RunLog` (the plant's log, plus references and
velocity estimates in closed loop), for ``maglev simulate``, the seed's
calibration experiments (:mod:`.experiments`) and the diagnosis datasets. An
open-loop run is the same loop with a controller that replays the currents.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from ..blocks import Controller, ControlOutput, Measurement, Reference
from ..plant import Plant
from ..riglog import RunLog
from .core import ClosedLoop
from .recorders import RigLogRecorder


def _n_steps(duration: float, Ts: float) -> int:
    n = round(duration / Ts)
    if n < 2:
        raise ValueError(f"duration {duration} s is shorter than two periods of {Ts} s")
    return n


def run_closed_loop(
    plant: Plant,
    controller: Controller,
    reference: Callable[[float], Reference],
    duration: float,
    *,
    x0: np.ndarray | None = None,
    lock: str | None = None,
    file: str = "run.csv",
    progress: bool = False,
    desc: str | None = None,
) -> RunLog:
    """Run ``controller`` on ``plant`` for ``duration`` seconds and return the log.

    Parameters
    ----------
    plant : Plant
        The simulated rig (its config decides lock, noise, effects).
    controller : Controller
        Anything with ``reset(y0, ref)`` and ``step(y, ref) -> ControlOutput``;
        an exception it raises goes through.
    reference : callable
        ``t -> Reference``.
    duration : float
        Run length [s] (rounded to whole periods).
    x0 : array (4,), optional
        Initial true state; default: at rest on the reference at t = 0.
    lock : {"none", "g", "d"}, optional
        Fixture for this run (overrides the plant config's; the axis is held at ``x0``).
    file : str
        File name the run gets in a dataset.
    progress : bool
        Show a progress bar.
    desc : str, optional
        Progress-bar label.

    Returns
    -------
    RunLog
        The plant's log plus ``g_ref, d_ref`` and the controller's velocity
        estimates ``g_dot_hat, d_dot_hat`` (NaN where it gives none).
    """
    Ts = plant.Ts
    n = _n_steps(duration, Ts)
    r0 = reference(0.0)
    if x0 is None:
        x0 = np.array([r0.g, 0.0, r0.d, 0.0])
    rec = RigLogRecorder(n)
    loop = ClosedLoop(plant, controller, [rec], on_error="raise")
    loop.reset(x0, r0, lock=lock)
    loop.run(lambda i: reference(i * Ts) if i else r0, n, progress=progress, desc=desc or file)
    return rec.log(
        plant, file, controller=getattr(controller, "name", type(controller).__name__), stop_events=_events(plant)
    )


class CurrentSequence:
    """A "controller" that replays currents, one row per period (open loop).

    Parameters
    ----------
    currents : array (N, 2)
        ``(i_q, i_d)`` per period [A].
    """

    name = "open-loop"

    def __init__(self, currents: np.ndarray):
        self.currents = currents
        self._k = 0

    def reset(self, y0: Measurement, ref: Any) -> None:
        """Back to the first row."""
        self._k = 0

    def step(self, y: Measurement, ref: Any) -> ControlOutput:
        """The next row, whatever the measurement."""
        u = self.currents[self._k]
        self._k += 1
        return ControlOutput(u=u)


def run_open_loop(
    plant: Plant,
    currents: np.ndarray | Callable[[float], tuple[float, float]],
    duration: float | None = None,
    *,
    x0: np.ndarray | None = None,
    u0: np.ndarray | None = None,
    lock: str | None = None,
    file: str = "run.csv",
    progress: bool = False,
    desc: str | None = None,
) -> RunLog:
    """Apply a current sequence to ``plant`` (no feedback) and return the log.

    Parameters
    ----------
    plant : Plant
        The simulated rig; an unlocked gap falls to a stop, which is recorded as an event.
    currents : array (N, 2) or callable
        ``(i_q, i_d)`` per period, or ``t -> (i_q, i_d)``.
    duration : float, optional
        Run length [s]; default: the length of the array.
    x0 : array (4,), optional
        Initial true state (default: the plant's, hovering at 20 mm).
    u0 : array (2,), optional
        Current the amplifiers carry at t = 0 (default: the hover currents).
    lock, file, progress, desc
        As for :func:`run_closed_loop`.
    """
    Ts = plant.Ts
    if callable(currents):
        if duration is None:
            raise ValueError("duration is needed when currents is a function of time")
        n = _n_steps(duration, Ts)
        seq = np.array([currents(i * Ts) for i in range(n)], dtype=float).reshape(n, 2)
    else:
        seq = np.asarray(currents, dtype=float)
        if seq.ndim != 2 or seq.shape[1] != 2:
            raise ValueError(f"currents must have shape (N, 2), got {seq.shape}")
        n = len(seq) if duration is None else _n_steps(duration, Ts)
        if n > len(seq):
            raise ValueError(f"{len(seq)} current samples do not cover {duration} s")
    loop = ClosedLoop(plant, CurrentSequence(seq), on_error="raise")
    loop.reset(x0, None, u0=u0, lock=lock)
    loop.run(lambda i: None, n, progress=progress, desc=desc or file)
    return plant.log.renamed(file, controller="open-loop", stop_events=_events(plant))


def _events(plant: Plant) -> list[dict[str, float | str]]:
    return [asdict(e) for e in plant.events]


__all__ = ["CurrentSequence", "run_closed_loop", "run_open_loop"]
