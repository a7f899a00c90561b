"""The seed's calibration experiments (sections IV and V) on the plant simulator, as a rig-log dataset.

Three groups of runs, each produced with the seed's PID regulators
(:class:`maglev_ocp.controllers.pid.PIDController`) on one :class:`~maglev_ocp.plant.Plant`
(one set of true parameters, an independent noise stream per run):

* **hover** (seed V.B, V.C): d locked by the fixture at 0 and at ``3 t1 / 2``,
  u1 = i_q = 0, the gap regulated at 10..25 mm in 1 mm steps; after a quiet
  stretch the gap tracks a small sum of sines (persistent excitation);
* **parabola** (seed V.A): the gap locked at 10..27.5 mm in 2.5 mm steps; the
  horizontal regulator holds d at -50 mm, then a constant ``i_q = -0.5 A``
  accelerates the mover; the run ends when it passes +50 mm;
* **free** (seed IV, V.D): both axes free, the regulators track sums of sines
  that sweep the gap over 13..25 mm and d over ±40 mm.

``maglev simulate --experiment seed-calibration`` calls
:func:`generate_seed_calibration`.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np
from pydantic import Field
from tqdm import tqdm

from maglev_ocp.controllers.pid import PIDController, PIDSettings

from .. import constants as k
from ..blocks import ControlOutput, Measurement, Reference
from ..config import Strict
from ..estimation.batch import BATCH_PARAMS
from ..estimation.calibrate import CalibrationResult, calibrate
from ..model import get_model
from ..output import atomic_write_text
from ..params import NOMINAL, Params
from ..plant import Plant, PlantConfig
from ..plant.excitation import AxisExcitation, ExcitationSettings, SumOfSines
from ..riglog import RunLog, read_dataset, write_dataset
from .drive import run_closed_loop


class HoverDesign(Strict):
    """Hover runs with d locked (seed V.B at d = 0, V.C at d = 3 t1/2)."""

    gaps_mm: list[float] = Field(default_factory=lambda: [float(g) for g in range(10, 26)], min_length=1)
    d_positions_mm: list[float] = Field(default_factory=lambda: [0.0, 1.5 * k.t1 * 1e3], min_length=1)
    quiet_s: float = Field(0.4, ge=0, le=60)
    duration_s: float = Field(2.0, gt=0.2, le=600)
    amplitude_mm: float = Field(0.6, ge=0, le=5)
    freqs_hz: list[float] = Field(default_factory=lambda: [0.9, 2.3, 4.1, 6.7], min_length=1)


class ParabolaDesign(Strict):
    """Parabola runs with the gap locked (seed V.A, eq. (5))."""

    gaps_mm: list[float] = Field(default_factory=lambda: [10.0 + 2.5 * i for i in range(8)], min_length=1)
    i_q: float = Field(-0.5, ge=-8, le=8)
    d_start_mm: float = Field(-50.0, ge=-55, le=55)
    d_end_mm: float = Field(50.0, ge=-55, le=55)
    hold_s: float = Field(0.3, ge=0.05, le=10)


class FreeDesign(Strict):
    """Free 2-DOF runs: PID regulators tracking sums of sines (seed IV, V.D)."""

    runs: int = Field(2, ge=0, le=20)
    duration_s: float = Field(25.0, gt=1, le=3600)
    g_center_mm: float = Field(19.0, ge=10, le=30)
    g_amplitude_mm: float = Field(6.0, ge=0, le=10)
    g_freqs_hz: list[float] = Field(default_factory=lambda: [0.11, 0.29, 0.53, 0.97, 1.7], min_length=1)
    d_amplitude_mm: float = Field(40.0, ge=0, le=50)
    d_freqs_hz: list[float] = Field(default_factory=lambda: [0.07, 0.23, 0.61, 1.3], min_length=1)
    fade_in_s: float = Field(1.0, ge=0, le=60)


class SeedCalibrationDesign(Strict):
    """What :func:`generate_seed_calibration` runs (defaults: about two minutes of data)."""

    hover: HoverDesign = HoverDesign()
    parabola: ParabolaDesign = ParabolaDesign()
    free: FreeDesign = FreeDesign()


def _tag(v_mm: float) -> str:
    return f"{v_mm:g}".replace("-", "m").replace(".", "p")


class _ParabolaDriver:
    """The horizontal PID holds d at the start for ``hold_s``, then a constant i_q drives the mover (i_d = 0)."""

    name = "pid+constant"

    def __init__(self, pid, hold_s: float, i_q: float, Ts: float):
        self.pid, self.hold_s, self.i_q, self.Ts = pid, hold_s, i_q, Ts
        self._k = 0

    def reset(self, y0: Measurement, ref: Reference) -> None:
        self.pid.reset(y0, ref)
        self._k = 0

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        out = self.pid.step(y, ref)
        self._k += 1
        if self._k * self.Ts > self.hold_s:
            out = ControlOutput(u=np.array([self.i_q, 0.0]), x_hat=out.x_hat, stats=out.stats)
        else:
            out = ControlOutput(u=np.array([out.u[0], 0.0]), x_hat=out.x_hat, stats=out.stats)
        return out


def _trim(log: RunLog, n: int) -> RunLog:
    """First ``n`` rows of a run."""
    return RunLog(log.file, {c: v[:n] for c, v in log.columns.items()}, log.locked, dict(log.meta))


def _hover_run(
    plant: Plant, params: Params, des: SeedCalibrationDesign, g_mm: float, d_mm: float, rs: np.random.SeedSequence
) -> RunLog:
    """Hover run (seed V.B, V.C): d locked at ``d_mm``, i_q = 0, the gap held at ``g_mm``, then excited."""
    g, d = g_mm * 1e-3, d_mm * 1e-3
    h = des.hover
    exc = ExcitationSettings(
        g=AxisExcitation(center=g, amplitude=h.amplitude_mm * 1e-3, freqs_hz=h.freqs_hz),
        d=AxisExcitation(center=d, amplitude=0.0, freqs_hz=[1.0]),
        fade_in=min(0.5, h.duration_s / 4),
    )
    sos = SumOfSines(exc, seed=rs)
    t_q = h.quiet_s

    def ref(t: float) -> Reference:
        return Reference(g=g, d=d) if t < t_q else sos(t - t_q)

    pid = PIDController(params, PIDSettings(control_d=False, i_q_fixed=0.0), plant.Ts)
    log = run_closed_loop(
        plant,
        pid,
        ref,
        h.duration_s,
        x0=np.array([g, 0.0, d, 0.0]),
        lock="d",
        file=f"hover_d{_tag(d_mm)}_g{_tag(g_mm)}.csv",
    )
    log.meta.update({"experiment": "hover", "gap_mm": g_mm, "d_mm": d_mm})
    return log


def _parabola_run(
    plant: Plant, params: Params, des: SeedCalibrationDesign, g_mm: float, d_mm: float, rs: np.random.SeedSequence
) -> RunLog:
    """Parabola run (seed V.A, eq. (5)): gap locked at ``g_mm``, d held at ``d_mm``, then a constant i_q."""
    g, d0 = g_mm * 1e-3, d_mm * 1e-3
    pb = des.parabola
    L1 = params.C1 * float(get_model().shape(g)[3])
    travel = abs(pb.d_end_mm - pb.d_start_mm) * 1e-3
    t_move = math.sqrt(2 * travel / max(L1 * abs(pb.i_q), 1e-6))  # d = L1 |i_q| t^2 / 2 covers the travel
    pid = PIDController(params, PIDSettings(control_g=False, i_d_fixed=0.0), plant.Ts)
    drv = _ParabolaDriver(pid, pb.hold_s, pb.i_q, plant.Ts)
    ref0 = Reference(g=g, d=d0)
    log = run_closed_loop(
        plant,
        drv,
        lambda t: ref0,
        pb.hold_s + 1.25 * t_move,
        x0=np.array([g, 0.0, d0, 0.0]),
        lock="g",
        file=f"parabola_g{_tag(g_mm)}.csv",
    )
    # the run ends where the mover passes d_end (before any stop)
    sgn = 1.0 if pb.d_end_mm >= pb.d_start_mm else -1.0
    past = np.flatnonzero(sgn * (log["d"] - pb.d_end_mm * 1e-3) > 0)
    if past.size:
        log = _trim(log, int(past[0]) + 1)
    log.meta.update({"experiment": "parabola", "gap_mm": g_mm, "i_q": pb.i_q})
    return log


def _free_run(
    plant: Plant, params: Params, des: SeedCalibrationDesign, index: float, _: float, rs: np.random.SeedSequence
) -> RunLog:
    """Free 2-DOF run number ``index`` (seed IV, V.D): both regulators track sums of sines."""
    fr = des.free
    exc = ExcitationSettings(
        g=AxisExcitation(center=fr.g_center_mm * 1e-3, amplitude=fr.g_amplitude_mm * 1e-3, freqs_hz=fr.g_freqs_hz),
        d=AxisExcitation(center=0.0, amplitude=fr.d_amplitude_mm * 1e-3, freqs_hz=fr.d_freqs_hz),
        fade_in=fr.fade_in_s,
    )
    sos = SumOfSines(exc, seed=rs)
    pid = PIDController(params, PIDSettings(), plant.Ts)
    log = run_closed_loop(plant, pid, sos, fr.duration_s, lock="none", file=f"free_{int(index) + 1}.csv")
    log.meta.update({"experiment": "free"})
    return log


def generate_seed_calibration(
    out_dir: str | os.PathLike,
    *,
    seed: int = 0,
    plant_config=None,
    params: Params = NOMINAL,
    design: SeedCalibrationDesign | None = None,
    progress: bool = True,
) -> Path:
    """Run the seed's calibration experiments on the plant simulator and write a rig-log dataset.

    Parameters
    ----------
    out_dir : path
        Dataset folder to write.
    seed : int
        Seed of everything random (true-parameter mismatch, noise, excitation phases).
    plant_config : PlantConfig, optional
        The simulated rig (default: the ``default`` profile). Its ``lock`` is
        overridden run by run.
    params : Params
        Nominal parameters; the plant's mismatch perturbs them into the true ones,
        and the regulators use them.
    design : SeedCalibrationDesign, optional
        Gaps, durations and excitation (default: :class:`SeedCalibrationDesign`).
    progress : bool
        Show a progress bar over the runs.

    Returns
    -------
    Path
        The dataset folder. ``dataset.yaml``'s ``meta`` records the seed, the
        design and (simulation only) the true parameters.
    """
    cfg = plant_config if plant_config is not None else PlantConfig.from_profile("default")
    des = design or SeedCalibrationDesign()
    ss = np.random.SeedSequence(int(seed))
    ss_plant, ss_ref = ss.spawn(2)
    plant = Plant(cfg, params, seed=ss_plant)

    jobs = []
    for d_mm in des.hover.d_positions_mm:
        for g_mm in des.hover.gaps_mm:
            jobs.append(("hover", g_mm, d_mm))
    for g_mm in des.parabola.gaps_mm:
        jobs.append(("parabola", g_mm, des.parabola.d_start_mm))
    for i in range(des.free.runs):
        jobs.append(("free", float(i), 0.0))
    ref_seeds = ss_ref.spawn(len(jobs))

    run_of = {"hover": _hover_run, "parabola": _parabola_run, "free": _free_run}
    runs: list[RunLog] = []
    for (kind, a, b), rs in tqdm(
        list(zip(jobs, ref_seeds, strict=True)), desc="seed calibration runs", unit="run", disable=not progress
    ):
        log = run_of[kind](plant, params, des, a, b, rs)
        if plant.events:
            log.meta["stop_events"] = [str(e) for e in plant.events]
        runs.append(log)

    tp = plant.true_params
    meta = {
        "generator": "maglev_ocp.loop.experiments.generate_seed_calibration",
        "seed": int(seed),
        "plant_profile": cfg.profile,
        "design": des.model_dump(),
        "true_params": tp.as_dict(),
    }
    return write_dataset(
        out_dir,
        runs,
        sample_time=plant.Ts,
        encoder_resolution=k.encoder_resolution,
        meta=meta,
        description="the seed's calibration experiments (sections IV, V) on the plant simulator",
    )


def regenerate_results(
    out: str | os.PathLike = "results/calibration", *, seed: int = 2024, profile: str = "default", progress: bool = True
) -> CalibrationResult:
    """Regenerate ``results/calibration/``: the seed's experiments on a rig profile, then calibrate them.

    Writes the dataset to ``<out>/dataset`` and the calibration into ``<out>``
    (plus ``<out>/README.md`` with the tables and timings).

    Parameters
    ----------
    out : path
        Output folder.
    seed : int
        Seed of the simulated rig (true-parameter mismatch, noise, excitation).
    profile : str
        Plant profile.
    progress : bool
        Progress bars.
    """
    out = Path(out)
    t0 = time.perf_counter()
    ds_path = generate_seed_calibration(
        out / "dataset", seed=seed, plant_config=PlantConfig.from_profile(profile), progress=progress
    )
    t_gen = time.perf_counter() - t0
    res = calibrate(ds_path, progress=progress)
    res.save(out)
    true = read_dataset(ds_path).meta.get("true_params", {})
    lines = [
        f"# Calibration on a simulated '{profile}' rig (seed {seed})",
        "",
        f"Dataset generated in {t_gen:.1f} s; calibration took {res.timing['total']:.1f} s "
        f"(stages: {', '.join(f'{k} {v:.1f} s' for k, v in res.timing.items() if k != 'total')}).",
        "",
        "## Calibrated parameters",
        "",
        res.table(),
        "",
    ]
    if true:
        lines += [
            "## Against the simulator's true parameters",
            "",
            "| parameter | true | calibrated | error [%] | error / std. error |",
            "|---|---|---|---|---|",
        ]
        for n in BATCH_PARAMS:
            v, tv, se = getattr(res.params, n), true[n], res.stderr.get(n)
            z = f"{(v - tv) / se:+.2f}" if se else "-"
            lines.append(f"| {n} | {tv:.6g} | {v:.6g} | {100 * (v / tv - 1):+.3f} | {z} |")
        lines.append("")
    lines += [
        "## Table II (V.B) beside the seed",
        "",
        res.table_ii(),
        "",
        "## Table III (V.D) beside the seed",
        "",
        res.table_iii(),
        "",
    ]
    atomic_write_text(out / "README.md", "\n".join(lines))
    return res


__all__ = [
    "FreeDesign",
    "HoverDesign",
    "ParabolaDesign",
    "SeedCalibrationDesign",
    "generate_seed_calibration",
    "regenerate_results",
]
