"""The headline job: ``python -m maglev_ocp.main_job`` (``make run``).

``make run`` writes into ``results/``; what it writes is not tracked (``.gitignore``), so ``git status`` stays
clean, and the tracked tables beside it (``results/long/``, ``results/benchmarks/``, ...) are not touched.

Regenerates ``results/``:

``model_table.{txt,json,png}``
    The model's operating table (``maglev model``) over the gap.
``simulate/``
    A short plant simulation (the seed's excitation experiment with its PID
    regulators, 2 s) as a ``maglev-rig-log/1`` dataset with a figure.
``min_time/``
    The minimum-time bound of the 100 mm traverse at 15, 20 and 25 mm
    (optimal-control problem on the shared model, :mod:`maglev_ocp.ocp`).
``<scenario>/``
    Every headline scenario (:data:`HEADLINE`) run by :func:`maglev_ocp.runner.run_scenario`:
    ``log.csv``, ``metrics.json``, ``scenario.yaml``, figures.
``summary.md``
    One table over the headline scenarios, the traverse against the
    minimum-time bound, the cogging-aware against the cogging-blind model,
    and the disturbance scenarios NMPC against FL
    (:func:`maglev_ocp.metrics.disturbance_table`).

Scenarios run in ``--jobs`` worker processes (default 2); each folder is
written into a temporary sibling and swapped in whole
(:func:`maglev_ocp.output.replace_dir`), so a failing or interrupted task never
leaves a folder that mixes two runs, and never loses the others. Exit code 0 if
every headline scenario passes its tolerance checks, 1 if one fails, 2 on bad
input (checked before any work), 130 on an interrupt (SIGINT).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import signal
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from .interrupts import sigint_ignored
from .markdown import md_table
from .output import atomic_write_text, replace_dir

SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"

#: The headline scenarios, in the order of the summary (files ``scenarios/<name>.yaml``).
HEADLINE: tuple[str, ...] = (
    "tour_nmpc",
    "tour_fl",
    "tour_pid",
    "traverse_15mm_nmpc",
    "traverse_20mm_nmpc",
    "traverse_25mm_nmpc",
    "traverse_15mm_fl",
    "traverse_20mm_fl",
    "traverse_25mm_fl",
    "gap_steps_nmpc",
    "gap_steps_fl",
    "cogging_aware_nmpc",
    "cogging_blind_nmpc",
    "cogging_aware_fl",
    "cogging_blind_fl",
    "mismatch_nmpc",
    "mismatch_fl",
    "random_nmpc",
    "random_fl",
    "tour_nmpc_delay1",
    "tour_fl_delay1",
    "push_g_nmpc",
    "push_g_fl",
    "push_d_nmpc",
    "push_d_fl",
    "payload_nmpc",
    "payload_fl",
    "cable_nmpc",
    "cable_fl",
    "near_stops_nmpc",
    "near_stops_fl",
)

#: Disturbance scenarios (pushes, payload, cable, moves near the stops): run for the NMPC-vs-FL table in
#: ``summary.md``. Their checks are reported there like every other scenario's, but a failure is a finding
#: of the comparison (e.g. a controller that hits a stop under a payload it does not know), not a broken
#: job, so they do not set the exit code.
STRESS: frozenset[str] = frozenset(n for n in HEADLINE if n.split("_")[0] in ("push", "payload", "cable", "near"))

#: Gaps of the traverse comparison [mm].
TRAVERSE_GAPS: tuple[int, ...] = (15, 20, 25)


def _run_scenario_task(path: str, out_dir: str) -> dict[str, Any]:
    """Worker: run one scenario into ``out_dir``; never raises (errors are returned)."""
    t0 = time.perf_counter()
    try:
        from . import codegen  # noqa: F401 - registers ``backend: c`` with the runner in this worker
        from .metrics import disturbance_rows
        from .runner import run_scenario

        res = run_scenario(path, progress=False)
        with replace_dir(out_dir) as tmp:
            res.save(tmp)
        return {
            "ok": True,
            "metrics": res.metrics.to_dict(),
            "disturbances": disturbance_rows(res.scenario.name, res),
            "wall_s": time.perf_counter() - t0,
        }
    except Exception as err:
        with replace_dir(out_dir) as tmp:
            atomic_write_text(tmp / "error.txt", traceback.format_exc())
        return {"ok": False, "error": f"{type(err).__name__}: {err}", "wall_s": time.perf_counter() - t0}


def _min_time_task(out_dir: str) -> dict[str, Any]:
    """Worker: the minimum-time bound of the 100 mm traverse at each gap (IPOPT on the shared model)."""
    t0 = time.perf_counter()
    try:
        from .ocp import traverse_bounds

        b = traverse_bounds(tuple(g * 1e-3 for g in TRAVERSE_GAPS), progress=False)
        with replace_dir(out_dir) as tmp:
            b.save(tmp)
        rows = [
            {
                "g_mm": round(r.start[0] * 1e3, 3),
                "T_min_s": float(r.T),
                "success": bool(r.success),
                "status": str(r.status),
            }
            for r in b.results
        ]
        return {"ok": True, "rows": rows, "table": b.table(), "wall_s": time.perf_counter() - t0}
    except Exception as err:
        return {"ok": False, "error": f"{type(err).__name__}: {err}", "wall_s": time.perf_counter() - t0}


def _calibration_task(out_dir: str) -> dict[str, Any]:
    """Worker: the seed's calibration experiments on the default rig, then ``maglev calibrate`` on them."""
    t0 = time.perf_counter()
    try:
        from .loop.experiments import regenerate_results

        with replace_dir(out_dir) as tmp:
            res = regenerate_results(tmp, progress=False)
        return {"ok": True, "table": res.table(), "wall_s": time.perf_counter() - t0}
    except Exception as err:
        return {"ok": False, "error": f"{type(err).__name__}: {err}", "wall_s": time.perf_counter() - t0}


def _submit_all(pool: ProcessPoolExecutor, a: argparse.Namespace, out: Path, names: list[str]) -> dict:
    """Submit the job's tasks; returns future -> task name."""
    futs = {}
    if not a.no_min_time:
        futs[pool.submit(_min_time_task, str(out / "min_time"))] = "__min_time__"
    if not a.no_calibration:
        futs[pool.submit(_calibration_task, str(out / "calibration"))] = "__calibration__"
    for n in names:
        futs[pool.submit(_run_scenario_task, str(SCENARIO_DIR / f"{n}.yaml"), str(out / n))] = n
    return futs


def _ignore_sigint() -> None:
    """Worker initializer: SIGINT is the parent's to handle (workers stop when the pool shuts down)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def write_model_table(out: Path) -> str:
    """``model_table.{txt,json,png}`` via ``maglev model``'s functions; returns the text table."""
    from .cli.cmd_model import format_table, plot_table, table
    from .params import NOMINAL

    rows = table([10, 15, 20, 25], NOMINAL)
    text = format_table(rows)
    atomic_write_text(out / "model_table.txt", text + "\n")
    atomic_write_text(out / "model_table.json", json.dumps(rows, indent=2) + "\n")
    plot_table(str(out / "model_table.png"), NOMINAL)
    return text


class _SimulationFailedError(Exception):
    """``maglev simulate`` returned a non-zero code inside :func:`write_simulation` (the old folder stays)."""


def write_simulation(out: Path) -> int:
    """A 2 s plant simulation: the seed's excitation experiment (PID regulators), via ``maglev simulate``.

    ``out/simulate`` is regenerated whole (same seed, same bytes): the simulation writes into a fresh
    folder swapped in on success (``simulate`` itself never appends without ``--append``).
    """
    from .cli import main as cli_main

    try:
        with replace_dir(out / "simulate") as tmp:
            code = cli_main(
                [
                    *("simulate", "--experiment", "excitation", "--duration", "2", "--seed", "1"),
                    *("--out", str(tmp), "--plot", "--quiet"),
                ]
            )
            if code != 0:
                raise _SimulationFailedError(code)
    except _SimulationFailedError as failed:
        code = failed.args[0]
    if code == 130:  # interrupted (the CLI said so): stop the job too
        raise KeyboardInterrupt
    return code


def _fmt(v: float | None, scale: float = 1.0, nd: int = 3) -> str:
    return "–" if v is None else f"{v * scale:.{nd}f}"


def summary_markdown(
    results: dict[str, dict[str, Any]],
    bounds: dict[str, Any] | None,
    out: Path,
    wall_s: float,
    calibrated: bool = True,
) -> str:
    """The ``summary.md`` text (tables with units, links to the figures, the commands); ``calibrated``: the
    calibration task ran (else the summary says it was skipped instead of linking its folder)."""
    lines = [
        "# Headline results",
        "",
        "Regenerated by `make run` (`python -m maglev_ocp.main_job --out results`; not tracked by git). "
        "Plant: the `default` rig "
        "profile (process and current noise, 10 µm encoders, ±8 A / 8 A limits, stops, guide friction, "
        "2 kHz amplifier lag, random C1..C4 mismatch). Errors are on the plant's TRUE state; the encoder "
        "versions are in each `metrics.json`. Settle time: from the target switch until both axes stay "
        "within 0.1 mm for the rest of the hold; RMS over that settled part once the planned move has arrived. "
        "Step time: the controller's "
        "Python computation on this machine (shared, 2 cores), median / p99.",
        "",
    ]
    head = ["scenario", "ctrl", "settled", "max settle [s]", "max RMS g [µm]", "max RMS d [µm]", "stops"]
    head += ["solver fail / fallback", "max |i| [A]", "step median / p99 [µs]", "result"]
    body = []
    for name in results:
        r = results[name]
        if not r.get("ok"):
            body.append([f"[{name}]({name}/)", *[""] * 9, f"ERROR: {r.get('error', '')}"])
            continue
        m = r["metrics"]
        n_ok = sum(bool(t["settled"]) for t in m["targets"])
        st = m["step_time_us"]
        tm = "–" if st["median"] is None else f"{st['median']:.0f} / {st['p99']:.0f}"
        body.append(
            [
                *(f"[{name}]({name}/positions.png)", m["controller"], f"{n_ok}/{len(m['targets'])}"),
                *(_fmt(m["max_settle_time_s"]), _fmt(m["max_rms_error_g_m"], 1e6, 2)),
                *(_fmt(m["max_rms_error_d_m"], 1e6, 2), m["stop_hits"], f"{m['solver_failures']} / {m['fallbacks']}"),
                *(f"{m['max_current_A']:.2f}", tm, "PASS" if m["passed"] else "FAIL"),
            ]
        )
    lines.append(md_table(head, body))
    # Traverse against the minimum-time bound.
    lines += [
        "",
        "## 100 mm traverse against the minimum-time bound",
        "",
        "Settle time of each direction of the traverse (d = −50 → +50 → −50 mm) and the minimum time "
        "of the same move from the optimal-control problem on the shared model (`min_time/`).",
        "",
    ]
    tmin, body = {}, []
    if bounds and bounds.get("ok"):
        tmin = {round(r["g_mm"]): r["T_min_s"] for r in bounds["rows"] if r["success"]}
    for g in TRAVERSE_GAPS:
        cells = [f"{g}", _fmt(tmin.get(g))]
        for c in ("nmpc", "fl"):
            r = results.get(f"traverse_{g}mm_{c}", {})
            ts = [t["settle_time_s"] for t in r.get("metrics", {}).get("targets", [])] if r.get("ok") else []
            worst = None if not ts or any(v is None for v in ts) else max(ts)
            cells.append(" / ".join(_fmt(v) for v in ts) if ts else "–")
            cells.append("–" if worst is None or g not in tmin else f"{worst / tmin[g]:.2f}")
        body.append(cells)
    head = ["gap [mm]", "minimum time [s]", "NMPC settle [s]", "NMPC / bound", "FL settle [s]", "FL / bound"]
    lines.append(md_table(head, body))
    if bounds and not bounds.get("ok"):
        lines.append(f"\nminimum-time bound failed: {bounds.get('error')}")
    # Cogging-aware against cogging-blind.
    lines += [
        "",
        "## Cogging in the controller's model (g = 15..16 mm, d at odd multiples of t1/2)",
        "",
        "Steady-state RMS over the settled part once the plan has arrived, and tracking RMS against the "
        "planned reference over the whole hold (moves included), true state.",
        "",
    ]
    body = []
    for c in ("nmpc", "fl"):
        for mdl in ("aware", "blind"):
            r = results.get(f"cogging_{mdl}_{c}", {})
            if not r.get("ok"):
                continue
            tg = r["metrics"]["targets"]
            rg = [t["rms_error_g_m"] for t in tg if t["rms_error_g_m"] is not None]
            rd = [t["rms_error_d_m"] for t in tg if t["rms_error_d_m"] is not None]
            mean = lambda v: sum(v) / len(v) if v else None  # noqa: E731
            trk = [
                mean([t.get(f"rms_tracking_error_{a}_m") for t in tg if t.get(f"rms_tracking_error_{a}_m") is not None])
                for a in ("g", "d")
            ]
            body.append(
                [
                    *(c, f"cogging-{mdl}", _fmt(mean(rg), 1e6, 2), _fmt(mean(rd), 1e6, 2)),
                    *(_fmt(max(rg) if rg else None, 1e6, 2), _fmt(max(rd) if rd else None, 1e6, 2)),
                    *(_fmt(trk[0], 1e6, 2), _fmt(trk[1], 1e6, 2)),
                ]
            )
    head = ["controller", "model", "mean RMS g [µm]", "mean RMS d [µm]", "max RMS g [µm]", "max RMS d [µm]"]
    lines.append(md_table([*head, "tracking RMS g [µm]", "tracking RMS d [µm]"], body))
    dist_rows = [row for r in results.values() if r.get("ok") for row in r.get("disturbances", [])]
    if dist_rows:
        from .metrics import disturbance_table

        lines += [
            "",
            "## Disturbances: NMPC against FL",
            "",
            "Each scheduled disturbance (`plant.disturbances`) with the current limits and stops active. Window: "
            "from the disturbance to the next target switch (a cable: the rest of the run). Peak error of the "
            "true state against the reference, time until both axes are back within 0.1 mm for good, stop "
            "impacts, largest current amplitude and time on a current limit in the window, RMS error after "
            "recovery.",
            "",
            disturbance_table(dist_rows, markdown=True),
        ]
    lines += [
        "",
        "Calibration on a simulated seed-calibration dataset (the seed's section V, `maglev calibrate`): "
        + ("[calibration/README.md](calibration/README.md)." if calibrated else "not run (`--no-calibration`)."),
        "",
    ]
    lines += [
        "",
        "Files: `model_table.{txt,json,png}`, `simulate/` (rig-log dataset of a 2 s excitation run), "
        "`min_time/`, and per scenario `log.csv`, `timing.csv`, `metrics.json`, `scenario.yaml`, "
        "`positions.png`, `currents.png`, `solver_time.png`.",
        "",
        "Reproduce one scenario: `maglev run scenarios/<name>.yaml --out results/run`.",
        "",
        f"Wall time of this job: {wall_s:.0f} s.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m maglev_ocp.main_job``: every failure is one line (see :func:`maglev_ocp.cli.main`)."""
    from .cli import describe_failure

    try:
        return _main(argv)
    except KeyboardInterrupt:
        print("main_job: interrupted", file=sys.stderr)
        return 130
    except Exception as err:
        text, code = describe_failure(err)
        print(f"main_job: {text}", file=sys.stderr)
        return code


def _main(argv: list[str] | None) -> int:
    """The job (see the module docstring)."""
    from .cli import OneLineParser

    ap = OneLineParser(
        prog="python -m maglev_ocp.main_job",
        description="Regenerate results/: model table, a plant simulation, the "
        "minimum-time bounds and the headline closed-loop scenarios.",
    )
    ap.add_argument(
        "--out",
        default="results",
        metavar="DIR",
        help="results folder (default: results; what the job writes there is not tracked by git)",
    )
    ap.add_argument("--jobs", type=int, default=2, help="worker processes for the scenarios (default 2)")
    ap.add_argument(
        "--scenarios",
        nargs="+",
        default=None,
        metavar="NAME",
        help=f"run only these headline scenarios (default: all {len(HEADLINE)})",
    )
    ap.add_argument("--no-min-time", action="store_true", help="skip the minimum-time OCP")
    ap.add_argument(
        "--no-calibration",
        action="store_true",
        help="skip the calibration on a simulated seed-calibration dataset (results/calibration)",
    )
    a = ap.parse_args(argv)
    from tqdm.auto import tqdm

    from .errors import UserError
    from .output import check_output_dir
    from .scenario import load_scenario

    t0 = time.perf_counter()
    out = Path(a.out)
    names = list(a.scenarios or HEADLINE)
    try:
        if a.jobs < 1:
            raise UserError(f"--jobs: {a.jobs} must be at least 1")
        check_output_dir(out, replaced=False)
        for n in names:
            load_scenario(SCENARIO_DIR / f"{n}.yaml")  # bad input: one line, exit 2, before any work
    except UserError as err:
        print(f"main_job: error: {err}", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    print(write_model_table(out))
    rc_sim = write_simulation(out)
    results: dict[str, dict[str, Any]] = {}
    bounds: dict[str, Any] | None = None
    calib: dict[str, Any] | None = None
    # fresh worker processes (spawn): a forked CasADi cannot load its IPOPT plugin here
    with ProcessPoolExecutor(
        max_workers=a.jobs, mp_context=multiprocessing.get_context("spawn"), initializer=_ignore_sigint
    ) as pool:
        with sigint_ignored():  # workers are spawned by submit(): they inherit the ignored SIGINT
            futs = _submit_all(pool, a, out, names)
        try:
            for fut in tqdm(as_completed(futs), total=len(futs), desc="headline", unit="task"):
                name = futs[fut]
                r = fut.result()
                if name == "__min_time__":
                    bounds = r
                elif name == "__calibration__":
                    calib = r
                else:
                    results[name] = r
        except KeyboardInterrupt:
            # Start nothing new; the running tasks finish their folders (each is swapped in whole).
            pool.shutdown(wait=True, cancel_futures=True)
            raise
    ordered = {n: results[n] for n in names}
    if bounds and bounds.get("ok"):
        print(bounds["table"])
    if calib is not None:
        print(calib["table"] if calib.get("ok") else f"calibration failed: {calib.get('error')}")
    from .runner import summary_table

    class _R:  # adapter: summary_table wants objects with .metrics
        def __init__(self, m):
            from types import SimpleNamespace

            ts = [SimpleNamespace(**t) for t in m["targets"]]
            self.metrics = SimpleNamespace(**{**m, "targets": ts, "passed": m["passed"]})

    print(summary_table([(n, _R(r["metrics"]) if r.get("ok") else None, r.get("error")) for n, r in ordered.items()]))
    wall = time.perf_counter() - t0
    atomic_write_text(out / "summary.md", summary_markdown(ordered, bounds, out, wall, calib is not None))
    atomic_write_text(
        out / "summary.json",
        json.dumps(
            {
                "scenarios": {n: r.get("metrics", {"error": r.get("error")}) for n, r in ordered.items()},
                "min_time": bounds,
                "wall_s": wall,
            },
            indent=1,
            default=str,
        )
        + "\n",
    )
    print(f"wrote {out}/summary.md ({wall:.0f} s)")
    ok = all(r.get("ok") and (r["metrics"]["passed"] or n in STRESS) for n, r in ordered.items()) and rc_sim == 0
    ok = ok and all(r.get("ok") for r in ordered.values())
    ok = ok and (calib is None or bool(calib.get("ok")))
    return 0 if ok else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
