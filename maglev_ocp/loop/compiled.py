"""What a compiled closed loop needs from the plant, as arrays, and how its results become a trace.

A scenario can run as one C function (``run_loop`` of
:mod:`maglev_ocp.codegen.loop_c`) that steps the plant's code-generated step
Function and the controller's compiled step ``n`` times. Everything the
Python :class:`~maglev_ocp.plant.Plant` decides while it steps is decided here
beforehand, with the very same code and draws:

* :func:`plant_inputs` resets the plant (as :class:`~maglev_ocp.loop.ClosedLoop`
  does) and reads off its run: initial state, reading and delay buffer, the
  pre-drawn noise of its seeded streams (:meth:`Plant.draw_noise`), the limiter,
  stops, lock and quantization, and the scheduled disturbances on the control
  grid (force pulses and steps summed per period in the plant's order, the
  true parameters per period with the payload put on so far, the cables'
  settings, whose force depends on the state and so is computed in C);
* :func:`compiled_trace` turns the loop's output arrays into the
  :class:`~maglev_ocp.loop.TraceRecorder` the Python loop would have filled,
  and the new stop impacts into :class:`~maglev_ocp.plant.StopEvent` s.

This module is numeric Python only: compiling and calling the C lives in
:mod:`maglev_ocp.codegen.loop_c` (above this layer).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..plant import Plant, StopEvent
from ..plant.disturbances import Cable, ForcePulse, ForceStep, with_payload
from .recorders import TraceRecorder

#: Fields of one cable row (``CABLE_FIELDS`` order) in the C loop's ``cables`` array.
CABLE_FIELDS = ("weight_g", "stiffness_g", "rest_g", "damping_g", "stiffness_d", "rest_d", "damping_d")

_SIDES = (("g", "lower"), ("g", "upper"), ("d", "lower"), ("d", "upper"))


@dataclass
class PlantInputs:
    """One run of a plant, decided beforehand (see the module docstring).

    Attributes
    ----------
    n : int
        Steps.
    xa : ndarray
        Initial state (plus the amplifier currents if the lag is on).
    y0 : ndarray (2,)
        Reading at t = 0.
    ia0 : ndarray (2,)
        Applied currents at t = 0.
    queue : ndarray (delay, 2)
        The delay buffer at t = 0 (oldest first).
    p_seq : ndarray (n, n_params)
        True parameters over each period (the payload put on so far).
    theta, free, lim : ndarray
        Effect parameters, 1/0 per free/locked axis, stops ``(g_lo, g_hi, d_lo, d_hi)``.
    noise : dict of str to ndarray
        Pre-drawn standard-normal draws (:meth:`Plant.draw_noise`).
    std : ndarray (3, 2)
        Standard deviations of the process force, current and measurement noise.
    flags : dict of str to int or float
        ``lim_on, i_axis, i_amp, proc_on, cur_on, meas_on, lock_g, lock_d, q, stops_on, has_force, has_payload``.
    contact : ndarray (4,)
        At each stop at t = 0.
    f_time : ndarray (n, 2)
        Force pulses and steps over each period [N].
    cables : ndarray (n_cables, 7)
        Cable settings (:data:`CABLE_FIELDS`).
    cable_start : ndarray (n_cables,) of int64
        First step at which each cable pulls.
    """

    n: int
    xa: np.ndarray
    y0: np.ndarray
    ia0: np.ndarray
    queue: np.ndarray
    p_seq: np.ndarray
    theta: np.ndarray
    free: np.ndarray
    lim: np.ndarray
    noise: dict[str, np.ndarray]
    std: np.ndarray
    flags: dict[str, Any]
    contact: np.ndarray
    f_time: np.ndarray
    cables: np.ndarray
    cable_start: np.ndarray


def _forces_on_grid(items: list, n: int, Ts: float) -> np.ndarray:
    """Force pulses and steps per period, summed in the plant's order (``DisturbanceSchedule.force``)."""
    out = np.zeros((n, 2))
    t = np.arange(n) * Ts
    for f in items:
        if isinstance(f, ForcePulse):
            on = (f.start <= t + 1e-12) & (t + 1e-12 < f.start + f.duration)
        elif isinstance(f, ForceStep):
            on = f.start <= t + 1e-12
        else:
            continue
        col = 0 if f.axis == "g" else 1
        out[on, col] = out[on, col] + f.amplitude
    return out


def plant_inputs(plant: Plant, n: int, x0: np.ndarray, *, lock: str | None = None) -> PlantInputs:
    """Reset ``plant`` at ``x0`` and decide its run of ``n`` steps (the noise it draws is consumed).

    Parameters
    ----------
    plant : Plant
        The plant (its next run's seed stream is used, as :meth:`Plant.reset` would).
    n : int
        Steps.
    x0 : array (4,)
        Initial true state.
    lock : {"none", "g", "d"}, optional
        Fixture of this run (as :meth:`Plant.reset`).
    """
    y = plant.reset(x0, lock=lock)
    Ts = plant.Ts
    noise = plant.draw_noise(n)
    cfg = plant.config
    dist = plant.disturbances
    t = np.arange(n) * Ts
    if dist.has_payload:
        masses = [dist.mass_at(float(tk)) for tk in t]
        cache: dict[float, np.ndarray] = {}
        p_seq = np.empty((n, len(plant._p)))
        for i, m in enumerate(masses):
            if m not in cache:
                cache[m] = with_payload(plant.true_params, m).vector()
            p_seq[i] = cache[m]
    else:
        p_seq = np.tile(plant._p, (n, 1))
    cables = [c for c in cfg.disturbances if isinstance(c, Cable)]
    cab = np.array([[getattr(c, f) for f in CABLE_FIELDS] for c in cables], dtype=float).reshape(len(cables), 7)
    start = np.array([int(np.argmax(np.append(c.start <= t + 1e-12, True))) for c in cables], dtype=np.int64)
    lock_now = plant._lock
    flags = {
        "lim_on": int(plant._lim_on),
        "i_axis": float(plant._i_axis),
        "i_amp": float(plant._i_amp),
        "proc_on": int(plant._proc_on),
        "cur_on": int(plant._cur_on),
        "meas_on": int(plant._meas_on),
        "lock_g": int(lock_now == "g"),
        "lock_d": int(lock_now == "d"),
        "q": float(plant._q),
        "stops_on": int(plant._stops_on),
        "has_force": int(dist.has_force),
        "has_payload": int(dist.has_payload),
    }
    queue = np.array(list(plant._queue), dtype=float).reshape(len(plant._queue), 2)
    return PlantInputs(
        n=n,
        xa=plant._xa.copy(),
        y0=np.asarray(y.y, dtype=float).copy(),
        ia0=np.array([y.info["i_q_applied"], y.info["i_d_applied"]], dtype=float),
        queue=queue,
        p_seq=np.ascontiguousarray(p_seq),
        theta=plant._th.copy(),
        free=plant._free.copy(),
        lim=plant._lim.copy(),
        noise={k: np.ascontiguousarray(v) for k, v in noise.items()},
        std=np.array([plant._proc_std, plant._cur_std, plant._meas_std], dtype=float),
        flags=flags,
        contact=np.array(plant._contact, dtype=float),
        f_time=_forces_on_grid(list(cfg.disturbances), n, Ts),
        cables=cab,
        cable_start=start,
    )


def stop_events(impacts: np.ndarray, done: int, Ts: float) -> list[StopEvent]:
    """Stop events from the loop's new-impact array (``n x 4``, speed where a stop was newly hit, else 0)."""
    ev = []
    rows, cols = np.nonzero(impacts[:done] > 0)
    for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
        axis, side = _SIDES[j]
        ev.append(StopEvent((i + 1) * Ts, axis, side, float(impacts[i, j])))
    return ev


def compiled_trace(
    n: int,
    arrays: dict[str, np.ndarray],
    x_hat: np.ndarray | None,
    stats: dict[str, Any],
    timings: dict[str, np.ndarray],
) -> TraceRecorder:
    """The :class:`TraceRecorder` of a compiled run (rows after the last step stay NaN, as in Python).

    Parameters
    ----------
    n : int
        Rows (steps planned).
    arrays : dict
        ``Y, X, U, UA`` (``done x 2/4/2/2``), ``limited`` (``done``), ``step_time_us`` (``done``).
    x_hat : ndarray (done, 4) or None
        The controller's state estimate per step.
    stats, timings : dict
        The controller's statistics per step (columns of ``done`` values).
    """
    tr = TraceRecorder(n)
    done = len(arrays["limited"])
    tr.Y[:done], tr.X[:done], tr.U[:done], tr.UA[:done] = arrays["Y"], arrays["X"], arrays["U"], arrays["UA"]
    tr.limited[:done] = arrays["limited"]
    tr.step_time_us[:done] = arrays["step_time_us"]
    if x_hat is not None:
        tr.XH[:done] = x_hat
    tr.stats = dict(stats)
    tr.timings = {k: list(v) for k, v in timings.items()}
    return tr


__all__ = ["CABLE_FIELDS", "PlantInputs", "compiled_trace", "plant_inputs", "stop_events"]
