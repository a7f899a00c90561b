"""Figures of a closed-loop run: positions with the 0.1 mm band, currents with limits, solver time.

All figures use the Agg backend and are written atomically
(:func:`maglev_ocp.output.atomic_write_bytes`); labels carry units.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from . import constants as k
from .output import atomic_write_bytes


def _target_track(t: np.ndarray, plan: Any) -> np.ndarray:
    """Active target (g, d) at each time."""
    idx = np.clip(np.searchsorted(plan.switch_times, t, side="right") - 1, 0, len(plan.targets) - 1)
    return np.array([[plan.targets[i].g, plan.targets[i].d] for i in idx]).reshape(len(t), 2)


def _finish(fig, path: str | os.PathLike, title: str) -> None:
    """Title, layout, atomic PNG write, close."""
    fig.suptitle(title)
    fig.tight_layout()
    atomic_write_bytes(path, fig)
    plt.close(fig)


def plot_positions(
    path: str | os.PathLike, cols: dict[str, np.ndarray], plan: Any, tolerance: float, title: str = ""
) -> None:
    """Positions (true, encoder, reference, target) and the errors with the tolerance band.

    Top row: ``g`` and ``d`` [mm] with the planned reference and the target;
    bottom row: the true error to the active target [µm] with the ``±tolerance``
    band shaded (the 0.1 mm band, visible at this scale).
    """
    t = cols["t"]
    tgt = _target_track(t, plan)
    fig, ax = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    for j, (name, col) in enumerate((("g", 0), ("d", 1))):
        a = ax[0, j]
        a.plot(t, cols[name] * 1e3, color="0.6", lw=0.8, label="encoder")
        a.plot(t, cols[f"{name}_true"] * 1e3, color="tab:blue", lw=1.0, label="true")
        a.plot(t, cols[f"{name}_ref"] * 1e3, color="tab:orange", lw=1.0, ls="--", label="reference")
        a.fill_between(
            t,
            (tgt[:, col] - tolerance) * 1e3,
            (tgt[:, col] + tolerance) * 1e3,
            step="post",
            color="tab:green",
            alpha=0.25,
            label=f"target ±{tolerance * 1e3:g} mm",
        )
        a.set_ylabel(f"{name} [mm]")
        a.grid(True, alpha=0.3)
        a.legend(loc="best", fontsize=8)
        e = ax[1, j]
        err = (cols[f"{name}_true"] - tgt[:, col]) * 1e6
        e.plot(t, err, color="tab:blue", lw=0.8, label="true - target")
        e.axhspan(-tolerance * 1e6, tolerance * 1e6, color="tab:green", alpha=0.2, label="tolerance band")
        e.set_ylim(-3 * tolerance * 1e6, 3 * tolerance * 1e6)
        e.set_ylabel(f"{name} error [µm]")
        e.set_xlabel("t [s]")
        e.grid(True, alpha=0.3)
        e.legend(loc="best", fontsize=8)
        for ts in plan.switch_times:
            ax[0, j].axvline(ts, color="0.85", lw=0.6, zorder=0)
            e.axvline(ts, color="0.85", lw=0.6, zorder=0)
    _finish(fig, path, title or "positions")


def plot_currents(
    path: str | os.PathLike,
    cols: dict[str, np.ndarray],
    title: str = "",
    i_axis_max: float = k.i_axis_max,
    i_amp_max: float = k.i_amp_max,
) -> None:
    """Commanded currents ``i_q``, ``i_d`` and their amplitude [A] with the amplifier limits."""
    t = cols["t"]
    fig, ax = plt.subplots(2, 1, figsize=(12, 6), sharex=True)
    ax[0].plot(t, cols["i_q"], lw=0.9, label="i_q")
    ax[0].plot(t, cols["i_d"], lw=0.9, label="i_d")
    for s in (-1, 1):
        ax[0].axhline(s * i_axis_max, color="tab:red", ls="--", lw=0.8, label="axis limit" if s > 0 else None)
    ax[0].set_ylabel("current [A]")
    ax[0].legend(loc="best", fontsize=8)
    ax[0].grid(True, alpha=0.3)
    ax[1].plot(t, np.hypot(cols["i_q"], cols["i_d"]), color="tab:purple", lw=0.9, label="|i| = sqrt(i_q²+i_d²)")
    ax[1].axhline(i_amp_max, color="tab:red", ls="--", lw=0.8, label="amplitude limit")
    ax[1].set_ylabel("amplitude [A]")
    ax[1].set_xlabel("t [s]")
    ax[1].set_ylim(0, i_amp_max * 1.15)
    ax[1].legend(loc="best", fontsize=8)
    ax[1].grid(True, alpha=0.3)
    _finish(fig, path, title or "currents")


def plot_solver_time(
    path: str | os.PathLike, t: np.ndarray, step_time_us: np.ndarray, title: str = "", period_us: float = k.Ts * 1e6
) -> None:
    """Controller computation time per step [µs] over time and its histogram, with the 1 ms period."""
    fig, ax = plt.subplots(1, 2, figsize=(12, 4), gridspec_kw={"width_ratios": [3, 1]})
    ax[0].plot(t, step_time_us, lw=0.6)
    ax[0].axhline(period_us, color="tab:red", ls="--", lw=0.8, label="control period")
    ax[0].set_xlabel("t [s]")
    ax[0].set_ylabel("step time [µs]")
    ax[0].set_yscale("log")
    ax[0].grid(True, alpha=0.3, which="both")
    ax[0].legend(loc="best", fontsize=8)
    finite = step_time_us[np.isfinite(step_time_us)]
    if finite.size:
        ax[1].hist(
            finite,
            bins=np.geomspace(max(finite.min(), 1.0), max(finite.max(), 2.0), 40),
            orientation="horizontal",
            color="tab:blue",
        )
        for q, ls in ((50, "-"), (99, "--")):
            ax[1].axhline(np.percentile(finite, q), color="k", ls=ls, lw=0.8, label=f"p{q}")
    ax[1].set_yscale("log")
    ax[1].set_xlabel("steps [-]")
    ax[1].set_ylabel("step time [µs]")
    ax[1].legend(loc="best", fontsize=8)
    _finish(fig, path, title or "controller computation time (Python, this machine)")


def plot_run(
    out_dir: str | os.PathLike,
    cols: dict[str, np.ndarray],
    step_time_us: np.ndarray,
    plan: Any,
    tolerance: float,
    name: str,
) -> list[Path]:
    """All figures of a run into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    paths = [out / "positions.png", out / "currents.png", out / "solver_time.png"]
    plot_positions(paths[0], cols, plan, tolerance, f"{name}: positions and errors")
    plot_currents(paths[1], cols, f"{name}: commanded currents")
    plot_solver_time(paths[2], cols["t"], step_time_us, f"{name}: controller computation time")
    return paths


__all__ = ["plot_currents", "plot_positions", "plot_run", "plot_solver_time"]
