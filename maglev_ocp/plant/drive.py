"""Driving the plant: closed loop with a controller, or open loop with a current sequence.

Small loops that produce one :class:`~maglev_ocp.riglog.RunLog` each; enough for
``maglev simulate`` and the seed's data-generation experiments. (The full
scenario runner with metrics is a later issue's; it uses the same
``reset`` / ``step`` interface of :mod:`maglev_ocp.blocks`.)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict

import numpy as np
from tqdm import tqdm

from ..blocks import Controller, Reference
from ..riglog import RunLog
from .plant import Plant

_PROGRESS_CHUNK = 500  # steps between progress-bar updates


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
        Anything with ``reset(y0, ref)`` and ``step(y, ref) -> ControlOutput``.
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
        Show a tqdm progress bar.
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
    y = plant.reset(x0, lock=lock)
    controller.reset(y, r0)
    extra = np.full((n, 4), np.nan)
    with tqdm(total=n, disable=not progress, desc=desc or file, unit="step", leave=False) as bar:
        for i in range(n):
            r = reference(i * Ts) if i else r0
            out = controller.step(y, r)
            extra[i, 0], extra[i, 1] = r.g, r.d
            if out.x_hat is not None:
                extra[i, 2], extra[i, 3] = out.x_hat[1], out.x_hat[3]
            y = plant.step(out.u)
            if (i + 1) % _PROGRESS_CHUNK == 0:
                bar.update(_PROGRESS_CHUNK)
        bar.update(n % _PROGRESS_CHUNK)
    log = plant.log.with_columns(g_ref=extra[:, 0], d_ref=extra[:, 1], g_dot_hat=extra[:, 2], d_dot_hat=extra[:, 3])
    return log.renamed(
        file, controller=getattr(controller, "name", type(controller).__name__), stop_events=_events(plant)
    )


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
    plant.reset(x0, u0, lock=lock)
    with tqdm(total=n, disable=not progress, desc=desc or file, unit="step", leave=False) as bar:
        for i in range(n):
            plant.step(seq[i])
            if (i + 1) % _PROGRESS_CHUNK == 0:
                bar.update(_PROGRESS_CHUNK)
        bar.update(n % _PROGRESS_CHUNK)
    return plant.log.renamed(file, controller="open-loop", stop_events=_events(plant))


def _events(plant: Plant) -> list[dict[str, float | str]]:
    return [asdict(e) for e in plant.events]


__all__ = ["run_closed_loop", "run_open_loop"]
