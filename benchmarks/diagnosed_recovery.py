"""How much of the true model's closed-loop gain a diagnosed model recovers (issue 12, "What it must show").

For each library effect (:data:`maglev_ocp.effects.EFFECTS`) set strong (:data:`STRONG`):

1. a diagnosis dataset of that plant is generated (``maglev diagnose generate DIR --effect NAME
   --effect-param ...``: the PID excitation, 6 runs of 10 s, plant without random mismatch);
2. ``maglev diagnose run DIR --out REPORT`` diagnoses it with default settings (calibrated baseline,
   not told the effect) and writes ``REPORT/model.yaml``;
3. a tour of the envelope (:data:`TOUR`) is run on the same plant with FL and NMPC using
   (a) the blind nominal model (the nominal constants without cogging, no effects: what the
   diagnosis starts from), (b) the diagnosed ``model.yaml`` (``controller: {model: FILE}``) and
   (c) the true model (the plant's constants and effect as a model file);
4. steady and tracking RMS of each, and the recovered fraction ``(a - b) / (a - c)`` of the
   blind-to-true improvement; ``n/a`` where that improvement is below :data:`MIN_GAIN_M` (1 µm).

Beside them, an ablation (:data:`ABLATION`): the diagnosed effects on the nominal constants, which
separates what the fitted law recovers from what the diagnosis's calibrated constants cost or add.

Run::

    python -m benchmarks.diagnosed_recovery --out results/recovery            # all effects (~40 min, 87 % diagnosing)
    python -m benchmarks.diagnosed_recovery --out results/recovery --effects friction cogging
    python -m benchmarks.diagnosed_recovery --out results/recovery --reuse    # keep existing diagnoses

The tours run on the compiled closed loop (``--loop auto``, :func:`run_tour`: the controllers'
generated steps carry the model files' constants, delay and effects, the same trajectories as the
Python loop to 1e-9); ``--loop python`` steps the blocks in Python instead. The wall-clock time of the
diagnoses and of the tours is written with the table.

Writes ``OUT/recovery.md`` and ``OUT/recovery.json``; the datasets, reports and model files go to
``--work`` (default ``OUT/work``, ignored by git apart from the model files).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from maglev_ocp.cli import main as maglev  # noqa: E402
from maglev_ocp.config import load_yaml  # noqa: E402
from maglev_ocp.output import atomic_write_text, dump_yaml  # noqa: E402
from maglev_ocp.params import NOMINAL  # noqa: E402

#: Strong settings of each library effect (top of the self-check's draw ranges,
#: :mod:`maglev_ocp.diagnosis.selftest`); cogging is the spec's law at twice its nominal amplitude.
STRONG: dict[str, dict[str, float]] = {
    "cogging": {"xi0": 8.0, "ell": 3.6e-3},
    "friction": {
        "coulomb_g": 0.4,
        "coulomb_d": 0.4,
        "stribeck_g": 0.1,
        "stribeck_d": 0.1,
        "viscous_g": 2.0,
        "viscous_d": 2.0,
    },
    "end_effect": {"ripple": 0.12, "ripple_phase": 0.5, "d_edge": 0.03, "edge_width": 4e-3, "edge_gain": 1.5},
    "amplifier_lag": {"bandwidth_hz": 300.0, "delay_samples": 1},
    "saturation": {"loss_8mm": 0.3, "ell_sat": 5e-3},
    "commutation_offset": {"delta": 0.15},
    "eddy_drag": {"c_eddy": 200.0},
    "parameter_error": {"k_C1": 1.1, "k_C2": 1.05, "k_C3": 1.1, "k_C4": 2.0, "k_Mh": 1.05, "k_Mv": 1.05},
}
#: Improvements below this are not scored (the table says n/a) [m].
MIN_GAIN_M: float = 1e-6
#: The recovered fraction the issue asks for.
TARGET_FRACTION: float = 0.7
#: Tour of the envelope (g, d, hold): the shipped tour's corners and centre.
TOUR: tuple[tuple[float, float, float], ...] = (
    (0.020, 0.000, 0.3),
    (0.015, -0.050, 0.4),
    (0.015, 0.050, 0.4),
    (0.025, 0.050, 0.4),
    (0.025, -0.050, 0.4),
    (0.020, 0.000, 0.4),
)
MODELS: tuple[str, ...] = ("blind", "diagnosed", "true")
#: Ablation run beside them: the diagnosed effects (and cogging law) on the nominal C1..C4, Mh, Mv
#: (separates what the fitted law recovers from what the calibrated constants cost or add).
ABLATION: str = "diagnosed_law"
#: Constants the ablation takes from the nominal set.
NOMINAL_KEYS: tuple[str, ...] = ("C1", "C2", "C3", "C4", "Mh", "Mv")
CONTROLLERS: tuple[str, ...] = ("fl", "nmpc")


# ------------------------------------------------------------------ plant and model files
def rig_of_dataset(data: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """The rig a generated dataset ran on: its ``plant:`` block and its true model file.

    Read from the dataset's own metadata (``meta.plant``, the plant file the
    generator simulated, and ``meta.diagnosis_truth.true_params``), so the tours
    run on exactly the plant the diagnosis saw, whatever the generator puts in
    it (e.g. the spec's eq. (9) cogging at nominal plus the effect).
    """
    meta = load_yaml(data / "dataset.yaml")["meta"]
    plant = meta["plant"]
    truth = meta["diagnosis_truth"]["true_params"]
    on = {n: v for n, v in (plant.get("effects") or {}).items() if v.get("enabled")}
    return plant, {**{n: float(v) for n, v in truth.items()}, "effects": on}


def law_only(model_file: dict[str, Any]) -> dict[str, Any]:
    """A diagnosed plant file with :data:`NOMINAL_KEYS` set back to nominal (:data:`ABLATION`).

    Its effects and its cogging law (``xi0``, ``ell``) are kept.
    """
    out = json.loads(json.dumps(model_file))
    over = out.setdefault("mismatch", {}).setdefault("overrides", {})
    over.update({n: float(getattr(NOMINAL, n)) for n in NOMINAL_KEYS})
    return out


def blind_model() -> dict[str, Any]:
    """The blind model: the nominal constants without cogging, no effects (where a diagnosis starts)."""
    consts = {n: float(getattr(NOMINAL, n)) for n in ("C1", "C2", "C3", "C4", "Mh", "Mv", "ell")}
    return {**consts, "xi0": 0.0, "effects": {}}


# ------------------------------------------------------------------ diagnosis
def generate_and_diagnose(effect: str, work: Path, seed: int, reuse: bool) -> tuple[Path, Path, dict[str, Any]]:
    """Steps 1-2: ``maglev diagnose generate``, then ``maglev diagnose run`` with default settings.

    Returns the dataset folder, the diagnosed ``model.yaml`` and ``{"verdict", "commands"}``.
    """
    data, rep = work / effect / "dataset", work / effect / "diagnosis"
    gen = generate_command(effect, data, seed)
    diag = ["diagnose", "run", str(data), "--out", str(rep), "--no-figures"]
    if not (reuse and (rep / "model.yaml").is_file()):
        for args in (gen, diag):
            if maglev(args) != 0:
                raise RuntimeError(f"maglev {' '.join(args)} failed")
    report = json.loads((rep / "report.json").read_text())
    return (
        data,
        rep / "model.yaml",
        {"verdict": verdict_text(report), "commands": [f"maglev {' '.join(a)}" for a in (gen, diag)]},
    )


def generate_command(effect: str, data: Path, seed: int) -> list[str]:
    """``maglev`` arguments that generate the strong-``effect`` dataset into ``data``."""
    gen = ["diagnose", "generate", str(data), "--effect", effect, "--seed", str(seed), "--effect-param"]
    return gen + [f"{kk}={v!r}" for kk, v in STRONG[effect].items()]


def verdict_text(report: dict[str, Any]) -> str:
    """The verdict of a diagnosis report (``report.json``) as one short string."""
    v = report.get("verdict")
    if isinstance(v, dict):
        for key in ("label", "text", "summary", "kind"):
            if isinstance(v.get(key), str):
                return v[key]
    return str(v)


# ------------------------------------------------------------------ closed loop
def tour_scenario(
    effect: str, ctype: str, model_file: Path, plant: dict[str, Any], seed: int = 7, backend: str = "python"
) -> dict[str, Any]:
    """The tour on the rig ``plant`` (:func:`rig_of_dataset`) with controller ``ctype`` on ``model_file``."""
    return {
        "name": f"recovery_{effect}_{ctype}_{model_file.stem}",
        "seed": seed,
        "controller": {"type": ctype, "backend": backend, "model": str(model_file)},
        "plant": plant,
        "targets": [{"g": g, "d": d, "hold": h} for g, d, h in TOUR],
    }


def tour_rms(metrics) -> dict[str, float]:
    """Steady and tracking RMS [m] of a run: per target the RMS of the position-error vector
    (``sqrt(rms_g^2 + rms_d^2)``, settled part / whole hold), then the RMS over the targets.

    An unsettled target makes the steady RMS NaN (reported, never scored).
    """
    st, tr = [], []
    for t in metrics.targets:
        if t.rms_error_g_m is None or t.rms_error_d_m is None or not t.settled:
            st.append(math.nan)
        else:
            st.append(t.rms_error_g_m**2 + t.rms_error_d_m**2)
        tr.append((t.rms_tracking_error_g_m or 0.0) ** 2 + (t.rms_tracking_error_d_m or 0.0) ** 2)
    return {"steady_m": float(np.sqrt(np.mean(st))), "tracking_m": float(np.sqrt(np.mean(tr)))}


def recovered(blind: float, diagnosed: float, true: float, min_gain: float = MIN_GAIN_M) -> float | None:
    """Recovered fraction ``(blind - diagnosed) / (blind - true)``; None where the improvement is below ``min_gain``.

    Non-finite inputs (an unsettled run) give None as well.
    """
    gain = blind - true
    if not all(math.isfinite(v) for v in (blind, diagnosed, true)) or gain < min_gain:
        return None
    return (blind - diagnosed) / gain


def run_tour(scenario: dict[str, Any], loop: str = "auto"):
    """One tour on the closed loop ``loop`` chooses (:func:`maglev_ocp.codegen.loop_c.run_scenario_on`).

    ``auto``: the compiled loop (one C call per tour, the controller's generated step with the model
    file's constants, delay and effects; equal to the Python loop to 1e-9, ``tests/test_compiled_loop.py``)
    wherever it can run the scenario, else the Python loop (the reason is logged); ``python``: the blocks'
    ``reset``/``step`` in Python (the reference the timing is compared against).
    """
    from maglev_ocp.codegen.loop_c import run_scenario_on

    return run_scenario_on(scenario, loop=loop, progress=False, figures=False)


def run_effect(
    effect: str, work: Path, seed: int, reuse: bool, backend: str, bar: tqdm, loop: str = "auto"
) -> dict[str, Any]:
    """Steps 1-4 for one effect: the diagnosis and the six tours, with the RMS and recovered fractions.

    ``row["seconds"]`` holds the wall-clock time of the diagnosis (0 when reused) and of the tours.
    """
    t0 = time.perf_counter()
    data, diagnosed, info = generate_and_diagnose(effect, work, seed, reuse)
    t_diag = time.perf_counter() - t0
    plant, true = rig_of_dataset(data)
    mdir = work / effect / "models"
    mdir.mkdir(parents=True, exist_ok=True)
    files = {m: mdir / f"{m}.yaml" for m in (*MODELS, ABLATION)}
    dump_yaml(files["blind"], blind_model())
    dump_yaml(files["true"], true)
    shutil.copyfile(diagnosed, files["diagnosed"])
    dump_yaml(files[ABLATION], law_only(load_yaml(diagnosed)))
    row: dict[str, Any] = {"effect": effect, "strong": STRONG[effect], **info, "controllers": {}}
    t0 = time.perf_counter()
    for ctype in CONTROLLERS:
        res: dict[str, Any] = {}
        for model in (*MODELS, ABLATION):
            r = run_tour(tour_scenario(effect, ctype, files[model], plant, backend=backend), loop)
            m = r.metrics
            res[model] = {
                **tour_rms(m),
                "all_settled": bool(m.all_settled),
                "stop_hits": int(m.stop_hits),
                "fallbacks": int(m.fallbacks),
                "solver_failures": int(m.solver_failures),
            }
            bar.update()
        for metric in ("steady_m", "tracking_m"):
            b, d, t = (res[x][metric] for x in MODELS)
            res[f"recovered_{metric[:-2]}"] = recovered(b, d, t)
            res[f"recovered_{metric[:-2]}_{ABLATION}"] = recovered(b, res[ABLATION][metric], t)
        row["controllers"][ctype] = res
    row["seconds"] = {"diagnosis": round(t_diag, 1), "tours": round(time.perf_counter() - t0, 1)}
    return row


def _um(v: float) -> str:
    return "unsettled" if not math.isfinite(v) else f"{v * 1e6:.2f}"


def _frac(f: float | None) -> str:
    if f is None:
        return "n/a"
    return f"**{f * 100:.0f} %**" if f < TARGET_FRACTION else f"{f * 100:.0f} %"


def markdown(
    rows: list[dict[str, Any]], command: str, loop: str = "auto", seconds: dict[str, float] | None = None
) -> str:
    """The recovery table (one line per effect and controller) with the commands and how long it took."""
    lines = [
        "# Closed-loop recovery of diagnosed models (issue 12)",
        "",
        f"`{command}`",
        "",
    ]
    if seconds is not None:
        lines += [
            f"Wall-clock time: {seconds['total']:.0f} s in all, {seconds['diagnosis']:.0f} s generating and "
            f"diagnosing the datasets (0 where reused), {seconds['tours']:.0f} s for the tours on the "
            f"`{loop}` closed loop.",
            "",
        ]
    lines += [
        "Per effect (set strong, the other effects off, no random mismatch): a diagnosis dataset "
        "(`maglev diagnose generate`), a diagnosis with default settings (calibrated baseline, not told the "
        "effect), then the envelope tour (6 targets, g 15-25 mm, d +-50 mm, seed 7) on that rig with each "
        "controller on the blind nominal model, the diagnosed `model.yaml` and the true model "
        "(`controller: {model: FILE}`). RMS in µm of the position-error vector: *steady* over the settled "
        "part of each target, *tracking* against the planned reference over each whole hold, then RMS over "
        f"the targets. *Recovered* = (blind - diagnosed) / (blind - true); n/a where blind - true < "
        f"{MIN_GAIN_M * 1e6:g} µm; **bold** below the {TARGET_FRACTION * 100:.0f} % asked for.",
        "",
        "| effect | verdict | ctrl | steady blind | steady diag. | steady true | recovered | "
        "tracking blind | tracking diag. | tracking true | recovered |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        for ctype, res in r["controllers"].items():
            st = [_um(res[m]["steady_m"]) for m in MODELS]
            tr = [_um(res[m]["tracking_m"]) for m in MODELS]
            lines.append(
                f"| {r['effect']} | {r['verdict']} | {ctype} | {' | '.join(st)} | {_frac(res['recovered_steady'])} "
                f"| {' | '.join(tr)} | {_frac(res['recovered_tracking'])} |"
            )
    scored = [
        (r["effect"], c, kind, res[f"recovered_{kind}"])
        for r in rows
        for c, res in r["controllers"].items()
        for kind in ("steady", "tracking")
        if res[f"recovered_{kind}"] is not None
    ]
    short = [f"{e} {c} {kind} ({f * 100:.0f} %)" for e, c, kind, f in scored if f < TARGET_FRACTION]
    lines += [
        "",
        f"Scored cells (improvement > {MIN_GAIN_M * 1e6:g} µm): {len(scored)}; at or above "
        f"{TARGET_FRACTION * 100:.0f} %: {len(scored) - len(short)}; below: {', '.join(short) or 'none'}.",
        "",
        "Ablation: the diagnosed effects (and cogging law) on the nominal constants "
        f"({', '.join(NOMINAL_KEYS)}), i.e. what the fitted law alone recovers:",
        "",
        "| effect | ctrl | steady | recovered | tracking | recovered |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        for ctype, res in r["controllers"].items():
            ab = res[ABLATION]
            lines.append(
                f"| {r['effect']} | {ctype} | {_um(ab['steady_m'])} | {_frac(res[f'recovered_steady_{ABLATION}'])} "
                f"| {_um(ab['tracking_m'])} | {_frac(res[f'recovered_tracking_{ABLATION}'])} |"
            )
    lines += ["", "Commands of each row (datasets and reports under the work folder):", ""]
    for r in rows:
        lines.append(f"- {r['effect']}: `{r['commands'][0]}`; `{r['commands'][1]}`")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--out", default="results/recovery", help="recovery.md and recovery.json go here")
    ap.add_argument("--work", default=None, help="datasets and diagnoses (default OUT/work)")
    ap.add_argument("--effects", nargs="+", default=list(STRONG), choices=list(STRONG))
    ap.add_argument("--seed", type=int, default=3, help="seed of the datasets (the tours use the scenario seed 7)")
    ap.add_argument("--reuse", action="store_true", help="keep existing diagnoses in WORK")
    ap.add_argument("--backend", default="python", choices=("python",), help="controller backend of the tours")
    ap.add_argument(
        "--loop",
        default="auto",
        choices=("auto", "compiled", "python"),
        help="closed loop of the tours (auto: compiled wherever it can run them; python: the blocks stepped in "
        "Python, the same trajectories to 1e-9, tens of times slower)",
    )
    a = ap.parse_args(argv)
    out = Path(a.out)
    work = Path(a.work) if a.work else out / "work"
    rows = []
    t_start = time.perf_counter()
    with tqdm(total=len(a.effects) * len(CONTROLLERS) * (len(MODELS) + 1), desc="tours", unit="run") as bar:
        for eff in a.effects:
            rows.append(run_effect(eff, work, a.seed, a.reuse, a.backend, bar, a.loop))
    command = "python -m benchmarks.diagnosed_recovery " + " ".join(argv if argv is not None else sys.argv[1:])
    out.mkdir(parents=True, exist_ok=True)
    seconds = {
        "total": round(time.perf_counter() - t_start, 1),
        "diagnosis": round(sum(r["seconds"]["diagnosis"] for r in rows), 1),
        "tours": round(sum(r["seconds"]["tours"] for r in rows), 1),
    }
    doc = {
        "command": command.strip(),
        "loop": a.loop,
        "seconds": seconds,
        "min_gain_m": MIN_GAIN_M,
        "target_fraction": TARGET_FRACTION,
        "tour": TOUR,
        "rows": rows,
    }
    (out / "models").mkdir(exist_ok=True)
    for eff in a.effects:  # the diagnosed model files, kept with the table (the datasets stay in WORK)
        shutil.copyfile(work / eff / "models" / "diagnosed.yaml", out / "models" / f"{eff}.yaml")
    atomic_write_text(out / "recovery.json", json.dumps(doc, indent=2) + "\n")
    md = markdown(rows, command.strip(), a.loop, seconds)
    atomic_write_text(out / "recovery.md", md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
