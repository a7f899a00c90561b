"""Loop analysis over a grid of operating points: margins table, figures and the delay cross-check.

For each controller and each hover point ``(g, d)`` of the grid:

1. settle the controller on the noise-free analysis plant (:func:`.controller_map.settle`);
2. linearize it (:func:`.controller_map.linearize_controller`, minus the memory its command never
   sees) and the plant with its lag and delay (:meth:`.plant_model.AnalysisPlant.linearize`);
3. break the loop on each axis at the plant input and at the output (:func:`.margins.broken_loop`)
   and compute the margins (:func:`.margins.loop_margins`).

:func:`write_report` writes ``margins.csv``, ``margins.json``, ``margins.md`` and the figures
(Bode, Nyquist, ``|S|`` and ``|T|`` per controller, every operating point overlaid).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..blocks import Controller, Reference
from ..markdown import md_table
from .controller_map import linearize_controller, minimal_part, settle
from .delay_check import SimulatedDelayMargin, simulated_delay_margin
from .margins import (
    AXIS_INPUT,
    AXIS_OUTPUT,
    LoopMargins,
    broken_loop,
    closed_loop_matrix,
    frequency_grid,
    loop_margins,
    loop_response,
)
from .plant_model import AnalysisPlant

#: Axes and where their loops are broken.
AXES: tuple[str, ...] = ("g", "d")
BREAKS: tuple[str, ...] = ("input", "output")


def _loop_columns(controller: str, g: float, d: float, axis: str) -> dict[str, object]:
    """The columns of a table row that say which loop it is: controller, operating point [mm], axis."""
    return {"controller": controller, "g_mm": round(g * 1e3, 3), "d_mm": round(d * 1e3, 3), "axis": axis}


@dataclass
class LoopResult:
    """One broken loop at one operating point: margins and the frequency response of ``L``."""

    controller: str
    g: float
    d: float
    axis: str
    at: str
    margins: LoopMargins
    omega: np.ndarray = field(repr=False)
    L: np.ndarray = field(repr=False)

    def row(self, Ts: float) -> dict[str, object]:
        """One row of the margins table (SI units plus the usual dB / deg / ms)."""
        m = self.margins
        db = lambda x: 20 * math.log10(x) if 0 < x < math.inf else (math.inf if x == math.inf else -math.inf)  # noqa: E731
        return {
            **_loop_columns(self.controller, self.g, self.d, self.axis),
            "at": self.at,
            "gm_upper_db": db(m.gm_upper),
            "gm_lower_db": db(m.gm_lower) if m.gm_lower > 0 else -math.inf,
            "pm_deg": m.pm_deg,
            "w_gc_rad_s": m.w_gc,
            "delay_margin_ms": m.delay_margin_s * 1e3,
            "delay_margin_samples": m.delay_margin_s / Ts,
            "disk_alpha": m.disk_alpha,
            "disk_gm_db": m.disk_gm_db,
            "disk_pm_deg": m.disk_pm_deg,
            "s_peak_db": m.s_peak_db,
            "t_peak_db": m.t_peak_db,
            "bandwidth_hz": m.bandwidth_rad_s / (2 * math.pi),
            "stable": m.closed_loop_stable,
        }


@dataclass
class PointResult:
    """Every loop of one controller at one operating point, and how the fixed point was found."""

    controller: str
    g: float
    d: float
    loops: list[LoopResult]
    u0: np.ndarray
    residual: float
    n_memory: int
    method: str
    closed_loop_radius: float


def analyze_point(
    make_controller: Callable[[], Controller],
    plant: AnalysisPlant,
    g: float,
    d: float,
    *,
    name: str | None = None,
    omega: np.ndarray | None = None,
    paths: Sequence[str] | None = None,
) -> PointResult:
    """Margins of every loop of one controller at the hover point ``(g, d)``.

    Parameters
    ----------
    make_controller : callable
        ``make_controller() -> Controller`` (a fresh controller: its memory is settled here).
    plant : AnalysisPlant
        Plant (lag, delay) the loop is closed on.
    g, d : float
        Operating point [m].
    name : str, optional
        Controller label (default: its ``name``).
    omega : ndarray, optional
        Frequency grid [rad/s] (default :func:`.margins.frequency_grid`).
    paths : sequence of str, optional
        Memory attribute paths of a controller the suite does not know.
    """
    ctrl = make_controller()
    label = name or getattr(ctrl, "name", type(ctrl).__name__)
    xa, y, u = settle(ctrl, plant, g, d)
    lc = minimal_part(linearize_controller(ctrl, y, Reference(g, d), paths=paths))
    lp = plant.linearize(xa, u)
    radius = float(np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(lp, lc)))))
    w = frequency_grid(plant.Ts) if omega is None else omega
    loops = []
    for axis in AXES:
        for at in BREAKS:
            ch = AXIS_INPUT[axis] if at == "input" else AXIS_OUTPUT[axis]
            L = broken_loop(lp, lc, at, ch)
            resp = loop_response(L, w)
            loops.append(LoopResult(label, g, d, axis, at, loop_margins(L, w, resp), w, resp))
    return PointResult(label, g, d, loops, u, lc.residual, lc.A.shape[0], lc.method, radius)


def analyze_grid(
    controllers: dict[str, Callable[[], Controller]],
    plant: AnalysisPlant,
    gaps: Sequence[float],
    positions: Sequence[float],
    *,
    progress: Callable[[str], None] | None = None,
) -> list[PointResult]:
    """:func:`analyze_point` for every controller and every ``(g, d)`` of the grid."""
    out = []
    for name, make in controllers.items():
        for g in gaps:
            for d in positions:
                out.append(analyze_point(make, plant, g, d, name=name))
                if progress:
                    progress(f"{name}: g = {g * 1e3:.1f} mm, d = {d * 1e3:.1f} mm done")
    return out


@dataclass
class DelayCheck:
    """Computed vs simulated delay margin of one loop (input break)."""

    controller: str
    g: float
    d: float
    axis: str
    computed_samples: float
    simulated: SimulatedDelayMargin

    @property
    def rel_error(self) -> float:
        """``|simulated - computed| / computed``."""
        return abs(self.simulated.delay_samples - self.computed_samples) / self.computed_samples

    def row(self) -> dict[str, object]:
        """One row of the cross-check table."""
        return {
            **_loop_columns(self.controller, self.g, self.d, self.axis),
            "computed_samples": self.computed_samples,
            "simulated_samples": self.simulated.delay_samples,
            "bracket": [self.simulated.stable_below, self.simulated.unstable_above],
            "runs": len(self.simulated.runs),
            "rel_error": self.rel_error,
        }


def delay_cross_check(
    make_controller: Callable[[], Controller], plant: AnalysisPlant, point: PointResult, axis: str
) -> DelayCheck:
    """Simulated delay margin of ``axis`` at ``point`` next to the computed one (input break)."""
    loop = next(lr for lr in point.loops if lr.axis == axis and lr.at == "input")
    computed = loop.margins.delay_margin_s / plant.Ts
    sim = simulated_delay_margin(make_controller, plant, point.g, point.d, axis, computed)
    return DelayCheck(point.controller, point.g, point.d, axis, computed, sim)


# ------------------------------------------------------------------------------------------ output
_COLUMNS = (
    ("g_mm", "g [mm]", "{:.0f}"),
    ("d_mm", "d [mm]", "{:.0f}"),
    ("axis", "axis", "{}"),
    ("gm_upper_db", "GM+ [dB]", "{:.1f}"),
    ("gm_lower_db", "GM- [dB]", "{:.1f}"),
    ("pm_deg", "PM [deg]", "{:.1f}"),
    ("w_gc_rad_s", "w_gc [rad/s]", "{:.0f}"),
    ("delay_margin_ms", "DM [ms]", "{:.2f}"),
    ("disk_alpha", "disk alpha", "{:.2f}"),
    ("disk_gm_db", "disk GM [dB]", "{:.1f}"),
    ("disk_pm_deg", "disk PM [deg]", "{:.1f}"),
    ("s_peak_db", "max|S| [dB]", "{:.1f}"),
    ("t_peak_db", "max|T| [dB]", "{:.1f}"),
    ("bandwidth_hz", "BW [Hz]", "{:.0f}"),
    ("stable", "stable", "{}"),
)


def markdown_table(rows: Sequence[dict[str, object]]) -> str:
    """Markdown table of margins rows (one controller, one break point)."""
    return md_table(
        [h for _, h, _ in _COLUMNS],
        ([f.format(r[key]) for key, _, f in _COLUMNS] for r in rows),
        align=["r"] * len(_COLUMNS),
    )


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def write_report(
    results: Sequence[PointResult],
    out_dir: str | os.PathLike,
    *,
    Ts: float,
    setup: dict[str, object],
    checks: Sequence[DelayCheck] = (),
    figures: bool = True,
) -> dict[str, str]:
    """Write ``margins.csv``, ``margins.json``, ``margins.md`` and the figures; return their paths."""
    import csv

    os.makedirs(out_dir, exist_ok=True)
    rows = [lr.row(Ts) for pr in results for lr in pr.loops]
    paths = {}
    p_csv = os.path.join(out_dir, "margins.csv")
    with open(p_csv, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    paths["csv"] = p_csv
    points = [
        {
            "controller": pr.controller,
            "g_mm": pr.g * 1e3,
            "d_mm": pr.d * 1e3,
            "u0": pr.u0.tolist(),
            "fixed_point_residual": pr.residual,
            "controller_states": pr.n_memory,
            "linearization": pr.method,
            "closed_loop_spectral_radius": pr.closed_loop_radius,
        }
        for pr in results
    ]
    doc = {"setup": setup, "margins": rows, "points": points, "delay_checks": [c.row() for c in checks]}
    p_json = os.path.join(out_dir, "margins.json")
    with open(p_json, "w") as fh:
        json.dump(doc, fh, indent=1, default=_json_default)
    paths["json"] = p_json
    p_md = os.path.join(out_dir, "margins.md")
    with open(p_md, "w") as fh:
        fh.write(markdown_report(results, Ts=Ts, setup=setup, checks=checks))
    paths["md"] = p_md
    if figures:
        paths.update(plot_figures(results, out_dir))
    return paths


def markdown_report(
    results: Sequence[PointResult], *, Ts: float, setup: dict[str, object], checks: Sequence[DelayCheck] = ()
) -> str:
    """The whole report as Markdown: setup, one table per controller and break point, the delay check."""
    lines = ["# Loop analysis (`maglev analyze`)", ""]
    lines += [f"- {k_}: {v}" for k_, v in setup.items()]
    lines += [
        "",
        "Loop-at-a-time margins: each axis' loop broken at the plant input (its current) or output (its reading),",
        "the other loop closed. GM+/GM-: stable for loop gains between GM- and GM+ (GM- > -inf dB: the open loop",
        "is unstable, lowering the gain destabilizes too). DM = PM / w_gc. Disk margin: balanced (skew 0).",
        "",
    ]
    for name in dict.fromkeys(pr.controller for pr in results):
        for at in BREAKS:
            rows = [lr.row(Ts) for pr in results if pr.controller == name for lr in pr.loops if lr.at == at]
            lines += [f"## {name}: loop broken at the plant {at}", "", markdown_table(rows), ""]
    if checks:
        lines += [
            "## Delay margin: computed vs simulated (input break, added delay on that channel)",
            "",
            "Simulated: nonlinear closed loop with a delay of whole samples plus a fraction added to that current",
            "channel, bisection on the growth rate of the oscillation; 'simulated' is the middle of the bracket.",
            "",
        ]
        head = ["controller", "g [mm]", "d [mm]", "axis", "computed [samples]", "simulated: stable at"]
        head += ["unstable at", "simulated [samples]", "error"]
        body = []
        for c in checks:
            r = c.row()
            body.append(
                [
                    *(r["controller"], f"{r['g_mm']:.0f}", f"{r['d_mm']:.0f}", r["axis"]),
                    *(f"{r['computed_samples']:.3f}", f"{r['bracket'][0]:.3f}", f"{r['bracket'][1]:.3f}"),
                    *(f"{r['simulated_samples']:.3f}", f"{100 * r['rel_error']:.1f} %"),
                ]
            )
        lines += [md_table(head, body, align=["", "r", "r", "", "r", "r", "r", "r", "r"]), ""]
    return "\n".join(lines)


def plot_figures(results: Sequence[PointResult], out_dir: str | os.PathLike) -> dict[str, str]:
    """Bode, Nyquist and ``|S|``/``|T|`` figures per controller (input breaks, all operating points overlaid)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = {}
    for name in dict.fromkeys(pr.controller for pr in results):
        prs = [pr for pr in results if pr.controller == name]
        loops = {axis: [lr for pr in prs for lr in pr.loops if lr.axis == axis and lr.at == "input"] for axis in AXES}
        # Bode
        fig, ax = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
        for j, axis in enumerate(AXES):
            for lr in loops[axis]:
                lab = f"g={lr.g * 1e3:.0f} d={lr.d * 1e3:.0f} mm"
                ax[0, j].semilogx(lr.omega, 20 * np.log10(np.abs(lr.L)), lw=0.8, label=lab)
                ax[1, j].semilogx(lr.omega, _phase_deg(lr.L), lw=0.8)
            ax[0, j].axhline(0, color="k", lw=0.5)
            ax[1, j].axhline(-180, color="k", lw=0.5)
            ax[0, j].set_title(f"{name}: L of the {axis} loop (broken at its current)")
            ax[0, j].set_ylabel("|L| [dB]")
            ax[1, j].set_ylabel("phase of L [deg]")
            ax[1, j].set_xlabel("frequency [rad/s]")
            ax[0, j].grid(True, which="both", lw=0.3)
            ax[1, j].grid(True, which="both", lw=0.3)
        ax[0, 0].legend(fontsize=6, ncol=2)
        fig.tight_layout()
        paths[f"bode_{name}"] = _save(fig, out_dir, f"bode_{name}.png")
        # Nyquist
        fig, ax = plt.subplots(1, 2, figsize=(11, 5))
        th = np.linspace(0, 2 * np.pi, 200)
        for j, axis in enumerate(AXES):
            for lr in loops[axis]:
                ax[j].plot(lr.L.real, lr.L.imag, lw=0.8)
                ax[j].plot(lr.L.real, -lr.L.imag, lw=0.4, ls="--", color=ax[j].lines[-1].get_color())
            ax[j].plot(-1, 0, "r+", ms=12)
            ax[j].plot(np.cos(th) - 1, np.sin(th), "k:", lw=0.5)  # distance 1 from -1 (|S| = 1)
            ax[j].set_xlim(-4, 2)
            ax[j].set_ylim(-3, 3)
            ax[j].set_aspect("equal")
            ax[j].set_title(f"{name}: Nyquist of L, {axis} loop")
            ax[j].set_xlabel("Re L [-]")
            ax[j].set_ylabel("Im L [-]")
            ax[j].grid(True, lw=0.3)
        fig.tight_layout()
        paths[f"nyquist_{name}"] = _save(fig, out_dir, f"nyquist_{name}.png")
        # S and T
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
        for j, axis in enumerate(AXES):
            for lr in loops[axis]:
                S = 1 / (1 + lr.L)
                ln = ax[j].semilogx(lr.omega, 20 * np.log10(np.abs(S)), lw=0.8)
                ax[j].semilogx(lr.omega, 20 * np.log10(np.abs(lr.L * S)), lw=0.8, ls="--", color=ln[0].get_color())
            ax[j].axhline(0, color="k", lw=0.5)
            ax[j].set_ylim(-40, 15)
            ax[j].set_title(f"{name}: |S| (solid) and |T| (dashed), {axis} loop")
            ax[j].set_xlabel("frequency [rad/s]")
            ax[j].set_ylabel("magnitude [dB]")
            ax[j].grid(True, which="both", lw=0.3)
        fig.tight_layout()
        paths[f"sensitivity_{name}"] = _save(fig, out_dir, f"sensitivity_{name}.png")
    return paths


def _phase_deg(L: np.ndarray) -> np.ndarray:
    """Unwrapped phase [deg], shifted by whole turns so that it lies in (-360, 0] at the gain crossover."""
    ph = np.rad2deg(np.unwrap(np.angle(L)))
    cross = np.nonzero(np.abs(L) < 1)[0]
    ref = ph[cross[0]] if cross.size else ph[0]
    return ph - 360.0 * math.ceil(ref / 360.0)


def _save(fig, out_dir, name: str) -> str:
    import matplotlib.pyplot as plt

    path = os.path.join(out_dir, name)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


__all__ = [
    "AXES",
    "BREAKS",
    "DelayCheck",
    "LoopResult",
    "PointResult",
    "analyze_grid",
    "analyze_point",
    "delay_cross_check",
    "markdown_report",
    "markdown_table",
    "plot_figures",
    "write_report",
]
