"""What a closed loop logs: the scenario trace and the rig-log columns.

Two recorders for :class:`~maglev_ocp.loop.core.ClosedLoop`:

:class:`TraceRecorder`
    everything a scenario run logs (:mod:`maglev_ocp.runner`'s ``log.csv``):
    readings, commanded and applied currents, true state, the controller's
    estimates and statistics, its computation time, the limiter flag;
:class:`RigLogRecorder`
    the columns a rig-log run adds to the plant's own log (references and
    the controller's velocity estimates), for datasets.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..blocks import Measurement
from ..plant import Plant
from ..riglog import RunLog
from .core import StepRecord

#: Statistics keys holding wall-clock times: kept apart from the deterministic statistics.
TIMING_SUFFIX = "_us"


def _stat_value(v: Any) -> Any:
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    if isinstance(v, (int, float, np.integer, np.floating)):
        return float(v)
    return str(v)


class TraceRecorder:
    """The per-step trace of a scenario run, in preallocated arrays of ``n`` rows.

    Row ``i`` holds what the controller saw and did at ``t_i``: ``Y`` the
    readings, ``X`` the true state, ``U`` the commanded currents, ``UA`` the
    currents the amplifiers carried at ``t_i``, ``XH`` the controller's state
    estimate, ``step_time_us`` its computation time, ``limited`` whether the
    plant's limiter clipped the command. Rows after the last step stay NaN
    (``limited``: 0).

    Attributes
    ----------
    stats : dict of str to list
        The controller's statistics per step (NaN where a key is missing that
        step); booleans as 0/1, numbers as floats, anything else as text.
    timings : dict of str to list
        Its wall-clock statistics (keys ending in ``_us``), kept out of ``stats``.
    """

    def __init__(self, n: int):
        self.Y = np.full((n, 2), np.nan)
        self.X = np.full((n, 4), np.nan)
        self.U = np.full((n, 2), np.nan)
        self.XH = np.full((n, 4), np.nan)
        self.UA = np.full((n, 2), np.nan)
        self.limited = np.zeros(n)
        self.step_time_us = np.full(n, np.nan)
        self.stats: dict[str, list[Any]] = {}
        self.timings: dict[str, list[float]] = {}

    def start(self, y0: Measurement) -> None:
        """Nothing to log at reset (the first row is written by the first step)."""

    def record(self, s: StepRecord) -> None:
        """Fill row ``s.i`` (see :class:`maglev_ocp.loop.core.StepRecord`)."""
        i, y, out = s.i, s.y, s.out
        self.Y[i] = y.y
        self.X[i] = y.x_true if y.x_true is not None else np.nan
        self.U[i] = s.u
        self.UA[i] = (y.info.get("i_q_applied", math.nan), y.info.get("i_d_applied", math.nan))
        if out.x_hat is not None:
            self.XH[i] = np.asarray(out.x_hat, dtype=float).reshape(4)
        self.step_time_us[i] = s.dt_us
        stats, timings = self.stats, self.timings
        for key, v in out.stats.items():
            if key.endswith(TIMING_SUFFIX):
                timings.setdefault(key, [math.nan] * i).append(float(v))
            else:
                stats.setdefault(key, [math.nan] * i).append(_stat_value(v))
        for lst in (*stats.values(), *timings.values()):  # keys missing this step
            if len(lst) < i + 1:
                lst.append(math.nan)
        self.limited[i] = float(bool(s.y_next.info.get("limited", False)))

    def stat_columns(self, done: int, taken: set[str] | frozenset[str] = frozenset()) -> dict[str, np.ndarray]:
        """The statistics of the first ``done`` steps as columns (text columns where any value is text).

        A statistic whose name is in ``taken`` (a column of the log already) gets the prefix ``stat_``.
        """
        cols: dict[str, np.ndarray] = {}
        for key, vals in self.stats.items():
            vals = vals[:done]
            if not isinstance(vals, np.ndarray) and any(isinstance(v, str) for v in vals):
                arr = np.array(["" if (isinstance(v, float) and math.isnan(v)) else str(v) for v in vals], dtype=object)
            else:
                arr = np.asarray(vals, dtype=float)
            cols[key if key not in taken else f"stat_{key}"] = arr
        return cols


class RigLogRecorder:
    """The references ``g_ref, d_ref`` and the velocity estimates ``g_dot_hat, d_dot_hat`` of each step.

    :meth:`log` appends them to the plant's own log (readings, commands after
    the limiter, true state) to make one rig-log run.
    """

    def __init__(self, n: int):
        self.extra = np.full((n, 4), np.nan)

    def start(self, y0: Measurement) -> None:
        """Nothing to log at reset."""

    def record(self, s: StepRecord) -> None:
        """Row ``s.i``: the reference and the controller's velocity estimates (NaN where it gives none)."""
        self.extra[s.i, 0], self.extra[s.i, 1] = s.ref.g, s.ref.d
        if s.out.x_hat is not None:
            self.extra[s.i, 2], self.extra[s.i, 3] = s.out.x_hat[1], s.out.x_hat[3]

    def log(self, plant: Plant, file: str, **meta: Any) -> RunLog:
        """The plant's log of the run with these columns appended, named ``file``, with ``meta``."""
        e = self.extra
        log = plant.log.with_columns(g_ref=e[:, 0], d_ref=e[:, 1], g_dot_hat=e[:, 2], d_dot_hat=e[:, 3])
        return log.renamed(file, **meta)


__all__ = ["TIMING_SUFFIX", "RigLogRecorder", "TraceRecorder"]
