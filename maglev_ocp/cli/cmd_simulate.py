"""``maglev simulate``: run the plant simulator and write a rig-log dataset."""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

from ..errors import DataError, UserError
from ..riglog import MAX_CELL_CHARS, MAX_COLUMNS, PHYSICAL_RANGES, is_plain_number, wide_csv_fields

EXAMPLES = """examples:
  maglev simulate --experiment hover --g 15 --duration 2 --out data/hover15
  maglev simulate --experiment excitation --duration 30 --seed 3 --out data/excite
  maglev simulate --constant -0.5 0 --lock g --g 20 --d -50 --duration 0.5 --out data/parabola
  maglev simulate --currents my_currents.csv --lock d --plant my_rig.yaml --out data/open
  maglev simulate --experiment seed-calibration --seed 1 --out data/seed_cal
  maglev simulate --experiment report/experiment.yaml --seed 2 --out data/experiment  (a run plan)
  maglev simulate --check data/excite          (validate a dataset and print its summary)"""


def register(sub) -> None:
    """Add the ``simulate`` subcommand."""
    from . import add_command, add_quiet

    p = add_command(
        sub,
        "simulate",
        help="run the plant simulator and write a rig-log dataset",
        description=(
            "Run the plant simulator (the stand-in for the rig: shared model + noise, 10 µm\n"
            "encoders, current limits, stops, fixtures and unmodelled effects, per a rig profile\n"
            "or a plant YAML) and write a maglev-rig-log/1 dataset (RIG_LOG.md).\n\n"
            "Experiments: 'hover' holds (g, d) with the seed's PID regulators; 'excitation'\n"
            "tracks a sum-of-sines reference around (g, d) as the seed did for identification;\n"
            "'seed-calibration' writes the seed's whole calibration dataset. A path to a run plan\n"
            "(maglev-run-plan/1 YAML, as 'maglev diagnose run' writes for a confusable verdict)\n"
            "runs each of its closed-loop references with the seed's PID regulators; the plan's\n"
            "reference CSVs (written next to it) are what a rig's own loop follows. With --currents or\n"
            "--constant the currents are applied open loop instead (an unlocked gap then falls\n"
            "to a stop: recorded as an event, not an error). --lock g|d holds that axis in a\n"
            "fixture at --g / --d, as in the seed's section V."
        ),
        example=EXAMPLES.split("\n", 1)[1].strip().splitlines()[0].strip(),
    )
    p.epilog = EXAMPLES
    p.add_argument(
        "--experiment",
        default=None,
        metavar="NAME|PLAN.yaml",
        help="closed-loop experiment: hover, excitation, seed-calibration, or a run plan file (.yaml) "
        "(default: hover, or open loop with --currents/--constant)",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--currents", metavar="CSV", help="open loop: CSV with columns t,i_q,i_d (ZOH between rows)")
    src.add_argument("--constant", nargs=2, type=float, metavar=("IQ", "ID"), help="open loop: constant currents [A]")
    prof = p.add_mutually_exclusive_group()
    prof.add_argument("--profile", default=None, help="rig profile: default or ideal (default: default)")
    prof.add_argument("--plant", metavar="FILE", help="plant file: a rig profile plus overrides (YAML)")
    p.add_argument(
        "--params",
        metavar="FILE",
        help="nominal constants: a parameter file (maglev-params/1; default: seed Table III)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--duration", type=float, default=None, help="run length [s] (default 2; currents CSV: its length)")
    p.add_argument("--g", type=float, default=20.0, metavar="MM", help="gap set-point / lock position [mm] (20)")
    p.add_argument("--d", type=float, default=0.0, metavar="MM", help="horizontal set-point / lock position [mm] (0)")
    p.add_argument("--lock", choices=("none", "g", "d"), default=None, help="hold an axis in a fixture")
    p.add_argument("--out", default=None, metavar="DIR", help="dataset folder (required; a new or empty folder)")
    p.add_argument(
        "--append",
        action="store_true",
        help="add the new runs to the dataset already in --out (a run of the same name is refused, never replaced)",
    )
    p.add_argument("--plot", action="store_true", help="also plot each run to DIR/<run>.png")
    add_quiet(p)
    p.add_argument(
        "--check", metavar="DATASET", help="only validate DATASET and print its summary (no other flag with it)"
    )
    p.set_defaults(handler=run)


# ---------------------------------------------------------------------- helpers
def read_current_sequence(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a current sequence CSV (``t, i_q, i_d``; one-line DataError naming file, row, column)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        raise DataError(f"{path}: cannot read: {err.__class__.__name__}") from None
    reader = csv.reader(text.splitlines())
    try:
        with wide_csv_fields():
            rows = list(reader)
    except csv.Error as err:
        raise DataError(f"{path}: line {reader.line_num}: not valid CSV: {err}") from None
    while rows and not any(c.strip() for c in rows[-1]):
        rows.pop()
    if not rows:
        raise DataError(f"{path}: empty file")
    header = [c.strip() for c in rows[0]]
    if len(header) > MAX_COLUMNS:
        raise DataError(f"{path}: header (line 1): {len(header)} columns (the limit is {MAX_COLUMNS})")
    for col in ("t", "i_q", "i_d"):
        if col not in header:
            raise DataError(f"{path}: header (line 1): missing column {col!r} (header has {', '.join(header)})")
    if len(rows) < 2:
        raise DataError(f"{path}: no data rows")
    idx = [header.index(c) for c in ("t", "i_q", "i_d")]
    out = np.empty((len(rows) - 1, 3))
    for r, row in enumerate(rows[1:], start=1):
        if len(row) != len(header):
            raise DataError(f"{path}: row {r} (line {r + 1}): {len(row)} fields, but the header has {len(header)}")
        for j, (c, name) in enumerate(zip(idx, ("t", "i_q", "i_d"), strict=True)):
            out[r - 1, j] = _cell_value(path, r, name, row[c])
    t = out[:, 0]
    if t[0] < 0:
        raise DataError(f"{path}: row 1 (line 2), column 't': time must start at >= 0, got {t[0]!r}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        r = int(bad[0]) + 2
        raise DataError(f"{path}: row {r} (line {r + 1}), column 't': time does not increase")
    return t, out[:, 1:]


def _cell_value(path: Path, r: int, name: str, cell: str) -> float:
    """A finite number from one cell of a current file (one-line DataError naming file, row and column)."""
    where = f"{path}: row {r} (line {r + 1}), column {name!r}"
    if len(cell) > MAX_CELL_CHARS:
        raise DataError(f"{where}: cell of {len(cell)} characters (the limit is {MAX_CELL_CHARS})")
    try:
        v = float(cell)
    except ValueError:
        raise DataError(f"{where}: not a number: {cell!r}") from None
    if not math.isfinite(v):
        raise DataError(f"{where}: non-finite value {cell!r}")
    if not is_plain_number(cell):
        raise DataError(f"{where}: {cell!r} is not a plain number (digits, '.', an optional exponent; no '_')")
    if name in PHYSICAL_RANGES:
        lo, hi, unit = PHYSICAL_RANGES[name]
        if not lo <= v <= hi:
            raise DataError(f"{where}: {v:g} {unit} is outside {lo:g}..{hi:g} {unit}")
    return v


def zoh_sample(t_file: np.ndarray, u_file: np.ndarray, n: int, Ts: float) -> np.ndarray:
    """Currents at ``k Ts`` for k < n: the last row at or before each sample (the first before it)."""
    tk = np.arange(n) * Ts
    idx = np.clip(np.searchsorted(t_file, tk + 1e-12, side="right") - 1, 0, len(t_file) - 1)
    return u_file[idx]


def _mm_tag(v_mm: float) -> str:
    return f"{v_mm:.1f}".replace("-", "m").replace(".", "p")


def _check_range(name: str, v: float, lo: float, hi: float, unit: str) -> None:
    from . import check_range

    check_range(name, v, lo, hi, unit)


def plot_run(run, path: Path) -> None:
    """Plot positions (with references), currents and the gap of one run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..output import atomic_write_bytes

    t = run["t"]
    fig, ax = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    ax[0].plot(t, run["g"] * 1e3, label="g (encoder)")
    if "g_ref" in run:
        ax[0].plot(t, run["g_ref"] * 1e3, "--", label="g_ref")
    ax[0].set_ylabel("g [mm]")
    ax[1].plot(t, run["d"] * 1e3, label="d (encoder)")
    if "d_ref" in run:
        ax[1].plot(t, run["d_ref"] * 1e3, "--", label="d_ref")
    ax[1].set_ylabel("d [mm]")
    ax[2].plot(t, run["i_q"], label="i_q")
    ax[2].plot(t, run["i_d"], label="i_d")
    ax[2].set_ylabel("current [A]")
    ax[2].set_xlabel("t [s]")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{run.file} (locked {list(run.locked)})")
    fig.tight_layout()
    atomic_write_bytes(path, fig)
    plt.close(fig)


# ---------------------------------------------------------------------- handler
def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev simulate``.

    Everything is checked before the simulation (values, files, the output
    folder). The dataset is written into a temporary sibling folder and swapped
    in whole. An existing dataset at ``--out`` is refused unless ``--append``;
    then its runs are kept, the new ones added (a new run with the name of an
    old one is refused: nothing is replaced silently) and the added runs named.
    """
    from ..output import check_output_dir, replace_dir
    from ..riglog import merge_datasets, read_dataset, read_header

    if args.check:
        _check_alone(args)
        ds = read_dataset(args.check)
        print(ds.table())
        return 0
    job = _prepare(args)
    if not args.out:
        raise UserError("--out DIR is required (a new or empty folder; --append adds to an existing dataset)")
    out = check_output_dir(args.out)
    previous = _existing_dataset(out, job["cfg"])
    if previous and not args.append:
        raise UserError(f"--out: {out} already holds a dataset; give a new folder, or --append to add these runs to it")
    t0 = time.perf_counter()
    with replace_dir(out) as tmp:
        if job["experiment"] == "seed-calibration":
            _seed_calibration(tmp, args, job)
            events: list = []
            sim_time = None
        elif job["experiment"] == "plan":
            sim_time, events = _plan_runs(tmp, args, job)
        else:
            sim_time, events = _simulate_runs(tmp, args, job)
        added = [e["file"] for e in read_header(tmp)["runs"]]
        if previous:
            clash = sorted(set(added) & {e["file"] for e in read_header(out)["runs"]})
            if clash:
                raise UserError(
                    f"--append: {out} already has run(s) {', '.join(clash)}; nothing written (a run is never "
                    "replaced: change --g/--d/--lock or give another folder)"
                )
            merge_datasets(tmp, out)
    wall = time.perf_counter() - t0
    ds = read_dataset(out)
    print(ds.table())
    for e in events:
        print(f"stop event: {e}")
    if previous:
        print(f"appended {len(added)} run(s) to {out}: {', '.join(added)} ({len(ds.runs)} runs now)")
    if sim_time is None:
        print(f"wrote {out} in {wall:.1f} s")
    else:
        print(f"wrote {out} ({sim_time:.3f} s simulated in {wall:.2f} s wall)")
    return 0


#: Flags that make no sense with ``--check`` (it only reads a dataset): flag -> attribute and its default.
_SIMULATION_FLAGS: tuple[tuple[str, str, object], ...] = (
    ("--out", "out", None),
    ("--append", "append", False),
    ("--experiment", "experiment", None),
    ("--currents", "currents", None),
    ("--constant", "constant", None),
    ("--profile", "profile", None),
    ("--plant", "plant", None),
    ("--params", "params", None),
    ("--duration", "duration", None),
    ("--lock", "lock", None),
    ("--plot", "plot", False),
)


def _check_alone(args: argparse.Namespace) -> None:
    """``--check`` only validates a dataset: any simulation flag with it is a conflict (one-line UserError)."""
    given = [flag for flag, attr, default in _SIMULATION_FLAGS if getattr(args, attr) != default]
    if given:
        raise UserError(f"--check only validates a dataset; leave out {', '.join(given)} (they set up a simulation)")


def _prepare(args: argparse.Namespace) -> dict:
    """Check the command-line values and load the settings files (nothing is simulated or written)."""
    from ..params import NOMINAL
    from ..plant import PlantConfig, load_plant_config
    from . import MAX_SEED, check_count, load_model_params

    check_count("--seed", args.seed, 0, MAX_SEED)
    if args.duration is not None:
        _check_range("--duration", args.duration, 0.002, 3600.0, "s")
    _check_range("--g", args.g, 5.0, 40.0, "mm")
    _check_range("--d", args.d, -100.0, 100.0, "mm")
    if args.constant:
        for name, v in zip(("IQ", "ID"), args.constant, strict=True):
            _check_range(f"--constant {name}", v, -100.0, 100.0, "A")

    params = load_model_params(args.params) if args.params else NOMINAL
    cfg = load_plant_config(args.plant) if args.plant else PlantConfig.from_profile(args.profile or "default")
    open_loop = args.currents is not None or args.constant is not None
    if open_loop and args.experiment:
        raise UserError("--experiment is a closed-loop experiment; leave it out with --currents / --constant")
    experiment = "open-loop" if open_loop else (args.experiment or "hover")
    job = {"params": params, "cfg": cfg, "experiment": experiment, "currents": None}
    if experiment.lower().endswith((".yaml", ".yml")):
        return _prepare_plan(args, job)
    if not open_loop and experiment not in EXPERIMENTS:
        raise UserError(
            f"--experiment: {experiment!r} is neither an experiment ({', '.join(EXPERIMENTS)}) nor a run plan .yaml"
        )
    if experiment == "seed-calibration":
        return job
    g, d = args.g * 1e-3, args.d * 1e-3
    if args.lock is not None:
        from ..config import parse_model

        value = None if args.lock == "none" else (g if args.lock == "g" else d)
        cfg = parse_model(PlantConfig, {**cfg.to_dict(), "lock": {"axis": args.lock, "value": value}}, "--lock")
        job["cfg"] = cfg
    if cfg.stops.enabled:
        for opt, v, (lo, hi) in (("--g", g, cfg.stops.g), ("--d", d, cfg.stops.d)):
            if not lo <= v <= hi:
                raise UserError(f"{opt}: {v * 1e3:g} mm is outside the stops {lo * 1e3:g}..{hi * 1e3:g} mm")
    if args.currents:
        job["currents"] = read_current_sequence(args.currents)
    return job


#: The named closed-loop experiments (a run plan is given by its .yaml path instead).
EXPERIMENTS: tuple[str, ...] = ("hover", "excitation", "seed-calibration")


def _prepare_plan(args: argparse.Namespace, job: dict) -> dict:
    """Load a run plan (``--experiment PLAN.yaml``); the plan sets gaps, positions, locks and durations."""
    from ..loop.run_plan import load_plan

    given = [f for f, v in (("--duration", args.duration), ("--lock", args.lock)) if v is not None]
    given += [f for f, v, dflt in (("--g", args.g, 20.0), ("--d", args.d, 0.0)) if v != dflt]
    if given:
        raise UserError(f"--experiment {args.experiment}: the run plan sets each run; leave out {', '.join(given)}")
    if not Path(args.experiment).is_file():
        raise UserError(f"--experiment: run plan {args.experiment} not found")
    plan = load_plan(args.experiment)
    cfg = job["cfg"]
    if cfg.stops.enabled:
        for i, r in enumerate(plan.runs):
            lo_g, hi_g = r.gap_mm - (r.amplitude_mm if r.kind.startswith("gap") else 0.0), r.gap_mm
            hi_g += r.amplitude_mm if r.kind.startswith("gap") else 0.0
            span_d = r.amplitude_mm if r.kind == "d_traverse" else 0.0
            if (
                lo_g * 1e-3 <= cfg.stops.g[0]
                or hi_g * 1e-3 >= cfg.stops.g[1]
                or not (cfg.stops.d[0] < (r.d_mm - span_d) * 1e-3 and (r.d_mm + span_d) * 1e-3 < cfg.stops.d[1])
            ):
                raise UserError(f"{args.experiment}: runs[{i}] ({r.label()}) reaches the plant's stops")
    job.update(experiment="plan", plan=plan)
    return job


def _plan_runs(folder: Path, args: argparse.Namespace, job: dict) -> tuple[float, list]:
    """Every run of the plan on one plant (seed ``--seed``), written as a dataset into ``folder``."""
    from ..loop.run_plan import simulate_run
    from ..plant import Plant

    plan, cfg = job["plan"], job["cfg"]
    plant = Plant(cfg, job["params"], seed=np.random.SeedSequence(args.seed))
    runs = []
    for i, r in enumerate(plan.runs):
        if not args.quiet:
            print(f"run {i + 1}/{len(plan.runs)}: {r.label()}")
        runs.append(simulate_run(plant, job["params"], r, r.file_name(i), progress=not args.quiet))
    label = f"run plan {Path(args.experiment).name} ({plan.excitation})"
    return _write_runs(folder, runs, plant, cfg, args, label, Path(args.experiment).name)


def _existing_dataset(out: Path, cfg) -> bool:
    """Whether ``out`` holds a dataset the new runs are appended to (refuses a folder that is not one)."""
    from .. import constants as k
    from ..riglog import read_header

    if not out.exists() or not any(out.iterdir()):
        return False
    if not (out / "dataset.yaml").is_file():
        raise UserError(f"--out: {out} is a folder with files but no dataset.yaml; give a new or a dataset folder")
    head = read_header(out)
    for key, want in (("sample_time", k.Ts), ("encoder_resolution", cfg.quantization.resolution)):
        if head[key] != want:
            raise UserError(
                f"--out: {out}/dataset.yaml: {key} {head[key]:g} differs from this simulation's {want:g}; "
                "give another folder"
            )
    return True


def _seed_calibration(folder: Path, args: argparse.Namespace, job: dict) -> None:
    """The seed's whole calibration dataset into ``folder``."""
    from ..loop.experiments import generate_seed_calibration

    generate_seed_calibration(
        folder, seed=args.seed, plant_config=job["cfg"], params=job["params"], progress=not args.quiet
    )


def _simulate_runs(folder: Path, args: argparse.Namespace, job: dict) -> tuple[float, list]:
    """Simulate the open-loop or closed-loop run and write it as a dataset into ``folder``.

    Returns the simulated time [s] and the plant's stop events.
    """
    from ..loop import run_open_loop
    from ..plant import Plant

    cfg, experiment = job["cfg"], job["experiment"]
    g, d = args.g * 1e-3, args.d * 1e-3
    ss = np.random.SeedSequence(args.seed)
    ss_plant, ss_ref = ss.spawn(2)
    plant = Plant(cfg, job["params"], seed=ss_plant)
    x0 = np.array([g, 0.0, d, 0.0])
    progress = not args.quiet
    if experiment == "open-loop":
        if job["currents"] is not None:
            t_file, u_file = job["currents"]
            duration = args.duration if args.duration is not None else float(t_file[-1]) + plant.Ts
            n = max(round(duration / plant.Ts), 2)
            seq = zoh_sample(t_file, u_file, n, plant.Ts)
            name = Path(args.currents).stem
        else:
            duration = args.duration if args.duration is not None else 2.0
            n = max(round(duration / plant.Ts), 2)
            seq = np.tile(np.asarray(args.constant, dtype=float), (n, 1))
            name = f"constant_iq{_mm_tag(args.constant[0])}_id{_mm_tag(args.constant[1])}"
        file = f"{name}_g{_mm_tag(args.g)}_d{_mm_tag(args.d)}.csv"
        run_log = run_open_loop(plant, seq, x0=x0, file=file, progress=progress)
    else:
        file = f"{experiment}_g{_mm_tag(args.g)}_d{_mm_tag(args.d)}.csv"
        run_log = _closed_loop(plant, job, (g, d), x0, ss_ref, args, file)
    runs = [run_log.renamed(file, experiment=experiment)]
    return _write_runs(folder, runs, plant, cfg, args, experiment, experiment)


def _write_runs(folder: Path, runs, plant, cfg, args, experiment: str, flag: str):
    """Write the simulated runs as a dataset (and their plots with ``--plot``); ``(seconds simulated, events)``.

    ``experiment``: the dataset's ``experiment`` entry; ``flag``: what ``--experiment`` named.
    """
    from ..riglog import write_dataset

    meta = {"generator": "maglev simulate", "experiment": experiment, "seed": args.seed, **plant.dataset_meta()}
    write_dataset(
        folder,
        runs,
        plant.Ts,
        cfg.quantization.resolution,
        meta=meta,
        description=f"maglev simulate --experiment {flag}",
    )
    if args.plot:
        for r in runs:
            plot_run(r, folder / (Path(r.file).stem + ".png"))
    return sum(r.duration for r in runs) + plant.Ts * len(runs), list(plant.events)


def _closed_loop(
    plant, job: dict, gd: tuple[float, float], x0: np.ndarray, ss_ref, args: argparse.Namespace, file: str
):
    """The seed's PID regulators holding (g, d) ('hover') or tracking a sum of sines ('excitation')."""
    from maglev_ocp.controllers.pid import PIDController, PIDSettings

    from ..loop import run_closed_loop
    from ..plant.excitation import AxisExcitation, ExcitationSettings, SumOfSines, constant_reference

    cfg, experiment = job["cfg"], job["experiment"]
    g, d = gd
    lock = cfg.lock.axis
    duration = args.duration if args.duration is not None else 2.0
    settings = PIDSettings(control_g=lock != "g", control_d=lock != "d")
    ctrl = PIDController(job["params"], settings, plant.Ts)
    if experiment == "hover":
        ref = constant_reference(g, d)
    else:
        base = ExcitationSettings()
        g_amp = min(base.g.amplitude, g - cfg.stops.g[0] - 1e-3, cfg.stops.g[1] - g - 1e-3)
        d_amp = min(base.d.amplitude, d - cfg.stops.d[0] - 5e-3, cfg.stops.d[1] - d - 5e-3)
        exc = ExcitationSettings(
            g=AxisExcitation(center=g, amplitude=0.0 if lock == "g" else max(g_amp, 0.0), freqs_hz=base.g.freqs_hz),
            d=AxisExcitation(center=d, amplitude=0.0 if lock == "d" else max(d_amp, 0.0), freqs_hz=base.d.freqs_hz),
            fade_in=base.fade_in,
        )
        ref = SumOfSines(exc, seed=ss_ref)
    return run_closed_loop(plant, ctrl, ref, duration, x0=x0, file=file, progress=not args.quiet)
