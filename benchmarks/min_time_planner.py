"""The profile planner against the minimum-time NLP: move time, planning time, feasibility on random moves.

Random rest-to-rest moves of the envelope (start and end gaps uniform in
15..25 mm, ``d`` uniform in -50..50 mm, from a fixed seed; moves of less than
1 mm are drawn again, they are planned as trajectories) with the NMPC's
planning defaults (``current_fraction`` 0.97, ``i_d_fraction`` 0.85). For each
move: the profile planner's duration (``min_time_solver: profile``,
:mod:`maglev_ocp.reference.profile_plan`, no cache) and the NLP's
(``min_time_solver: nlp``, :func:`maglev_ocp.ocp.min_time.solve_min_time` as
the planner has always solved it), both without the 3 ms smoothing; the
planning time (wall and this process's CPU time, median and p99); and the
planned move's currents on the shared model's exact inverse
(:func:`maglev_ocp.model.model_inverse_function`, not the planner's own
algebra) at every table point against the fractions of the limits (a row
beyond them is a violation)::

    python -m benchmarks.min_time_planner --moves 200 --seed 2029 --out results/benchmarks/min_time_planner.md
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from maglev_ocp import constants as k  # noqa: E402
from maglev_ocp.model import model_inverse_function  # noqa: E402
from maglev_ocp.output import atomic_write_text  # noqa: E402
from maglev_ocp.params import NOMINAL  # noqa: E402
from maglev_ocp.reference import ReferenceSettings  # noqa: E402
from maglev_ocp.reference.min_time import _min_time_table, _profile_table, unsmoothed_duration  # noqa: E402

#: The NMPC's planning defaults (:meth:`maglev_ocp.controllers.nmpc.NMPCSettings.reference_defaults`).
SETTINGS = ReferenceSettings(shaping="min_time", current_fraction=0.97, i_d_fraction=0.85)


def envelope_moves(n: int, seed: int) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """``n`` moves ``((g0, d0), (g1, d1))``: gaps uniform in 15..25 mm, ``d`` in -50..50 mm, at least 1 mm long."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        g0, g1 = rng.uniform(0.015, 0.025, 2)
        d0, d1 = rng.uniform(-0.05, 0.05, 2)
        if max(abs(g1 - g0), abs(d1 - d0)) < 1e-3:
            continue
        out.append(((float(g0), float(d0)), (float(g1), float(d1))))
    return out


def violations(rows: np.ndarray, st: ReferenceSettings = SETTINGS) -> int:
    """Table rows whose shared-model inverse currents exceed the settings' fractions of the limits (or none exist)."""
    n = rows.shape[0]
    x = np.vstack([rows[:, 0], rows[:, 1], rows[:, 3], rows[:, 4]])
    a = np.vstack([rows[:, 2], rows[:, 5]])
    u, unr = model_inverse_function().map(n)(x, a, np.tile(NOMINAL.vector()[:, None], (1, n)))
    u, unr = np.asarray(u), np.asarray(unr).ravel()
    bad = (
        (unr > 0)
        | ~np.all(np.isfinite(u), axis=0)
        | (np.abs(u[0]) > st.axis_limit_fraction * k.i_axis_max)
        | (np.abs(u[1]) > st.i_d_limit_fraction * k.i_axis_max)
        | (np.hypot(u[0], u[1]) > st.current_fraction * k.i_amp_max)
    )
    return int(np.count_nonzero(bad))


def kinematic_error(tau: np.ndarray, rows: np.ndarray) -> tuple[float, float]:
    """How far a table is from a motion: ``(velocity error / peak velocity, position error [m])``, worst axis.

    The velocities are compared with the integral of the accelerations and the
    positions with the integral of the velocities (trapezoid rule on the table's
    own times): a table whose rows are not the derivatives of each other would
    ask the model for accelerations the move does not have.
    """

    def cumtrapz(y: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(tau))])

    ev, ep = 0.0, 0.0
    for j in (0, 3):
        v_peak = max(float(np.max(np.abs(rows[:, j + 1]))), 1e-6)
        ev = max(ev, float(np.max(np.abs(rows[0, j + 1] + cumtrapz(rows[:, j + 2]) - rows[:, j + 1]))) / v_peak)
        ep = max(ep, float(np.max(np.abs(rows[0, j] + cumtrapz(rows[:, j + 1]) - rows[:, j]))))
    return ev, ep


def measure(moves, st: ReferenceSettings = SETTINGS) -> dict[str, np.ndarray]:
    """Per move: durations [s], planning wall and CPU times [s], violating rows, NLP solved, kinematic errors."""
    pvec = tuple(NOMINAL.vector().tolist())
    lims = (st.axis_limit_fraction * k.i_axis_max, st.i_d_limit_fraction * k.i_axis_max)
    amp = st.current_fraction * k.i_amp_max
    _profile_table.__wrapped__(moves[0][0], moves[0][1], pvec, *lims, amp)  # build the CasADi Functions once
    res: dict[str, list] = {k: [] for k in ("T_profile", "T_nlp", "wall", "cpu", "viol", "nlp_ok", "ev", "ep")}
    for p0, p1 in tqdm(moves, desc="moves (profile + NLP)", unit="move"):
        c0, t0 = time.process_time(), time.perf_counter()
        tab = _profile_table.__wrapped__(p0, p1, pvec, *lims, amp)  # uncached
        res["wall"].append(time.perf_counter() - t0)
        res["cpu"].append(time.process_time() - c0)
        res["T_profile"].append(np.inf if tab is None else unsmoothed_duration(tab))
        res["viol"].append(-1 if tab is None else violations(tab[2], st))
        ev, ep = (np.nan, np.nan) if tab is None else kinematic_error(tab[1], tab[2])
        res["ev"].append(ev)
        res["ep"].append(ep)
        ref = _min_time_table.__wrapped__(p0, p1, pvec, st.current_fraction, st.axis_limit_fraction, st.i_d_fraction)
        res["nlp_ok"].append(ref is not None)
        res["T_nlp"].append(np.nan if ref is None else unsmoothed_duration(ref))
    return {key: np.asarray(v) for key, v in res.items()}


def report(r: dict[str, np.ndarray], moves: int, seed: int, command: str) -> str:
    """Markdown table of the measurements."""
    ok = r["nlp_ok"] & np.isfinite(r["T_profile"])
    rel = (r["T_profile"][ok] / r["T_nlp"][ok] - 1.0) * 100.0
    try:
        commit = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except OSError:
        commit = "?"
    load = os.getloadavg()
    lines = [
        "# Profile planner vs the minimum-time NLP",
        "",
        f"`{command}` (commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} CPUs).",
        "",
        f"{moves} random moves (seed {seed}): gaps 15..25 mm, d -50..50 mm, NMPC planning defaults "
        "(current_fraction 0.97, i_d_fraction 0.85); durations without the 3 ms smoothing both moves get.",
        "",
        "| quantity | median | p99 | max | min |",
        "|---|---|---|---|---|",
        f"| move time, profile / NLP - 1 [%] | {np.median(rel):+.3f} | {np.percentile(rel, 99):+.3f} "
        f"| {rel.max():+.3f} | {rel.min():+.3f} |",
        f"| \\|profile / NLP - 1\\| [%] | {np.median(np.abs(rel)):.3f} | {np.percentile(np.abs(rel), 99):.3f} "
        f"| {np.abs(rel).max():.3f} | {np.abs(rel).min():.3f} |",
        f"| planning wall time [ms] | {np.median(r['wall']) * 1e3:.2f} | {np.percentile(r['wall'], 99) * 1e3:.2f} "
        f"| {r['wall'].max() * 1e3:.2f} | {r['wall'].min() * 1e3:.2f} |",
        f"| planning CPU time [ms] | {np.median(r['cpu']) * 1e3:.2f} | {np.percentile(r['cpu'], 99) * 1e3:.2f} "
        f"| {r['cpu'].max() * 1e3:.2f} | {r['cpu'].min() * 1e3:.2f} |",
        "",
        f"- moves compared: {int(ok.sum())} of {moves} (NLP not solved: {int((~r['nlp_ok']).sum())}, "
        f"profile not planned: {int((~np.isfinite(r['T_profile'])).sum())}); "
        f"profile slower than the NLP by more than 1 %: {int((rel > 1.0).sum())}; "
        f"faster than the NLP: {int((rel < 0).sum())} (the NLP is a local solve from a straight start; "
        "every profile move is checked on the model below)",
        f"- table rows beyond the limits on the shared model's inverse (all profile moves): "
        f"{int(r['viol'][r['viol'] >= 0].sum())}",
        f"- tables against their own integrals (velocity vs the integral of the acceleration, position vs the "
        f"integral of the velocity): worst velocity error {np.nanmax(r['ev']) * 100:.3f} % of the peak velocity, "
        f"worst position error {np.nanmax(r['ep']) * 1e6:.3f} um",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=200)
    ap.add_argument("--seed", type=int, default=2029)
    ap.add_argument("--out", default=None, metavar="FILE", help="write the markdown table here")
    a = ap.parse_args(argv)
    if a.moves < 1:
        print("--moves: at least 1", file=sys.stderr)
        return 2
    r = measure(envelope_moves(a.moves, a.seed))
    command = "python -m benchmarks.min_time_planner " + " ".join(argv if argv is not None else sys.argv[1:])
    text = report(r, a.moves, a.seed, command.strip())
    print(text)
    if a.out:
        out = Path(a.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
