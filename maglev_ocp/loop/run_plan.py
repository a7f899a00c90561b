"""Executable run plans: closed-loop references a rig can run with its own regulators, in physical units.

A **run plan** (``maglev-run-plan/1``, a YAML file) is a list of runs, each a
reference kind with its parameters in mm, mm/s, Hz and s, and the axis a
fixture locks. The diagnosis writes one when it cannot tell two effects apart
(:mod:`maglev_ocp.diagnosis.experiment` chooses the runs), ``maglev simulate
--experiment PLAN.yaml`` runs it on the plant simulator with the seed's PID
regulators (:func:`simulate_plan`), and :func:`write_reference_csvs` writes
each run's reference as CSV (``t, g_ref, d_ref, g_dot_ref, d_dot_ref`` in s,
m, m/s) for a rig's own loop to follow.

Reference kinds
---------------
``hold``
    Gap and position held at ``gap_mm``, ``d_mm``.
``gap_sine``
    ``g = gap_mm + amplitude_mm sin(2 pi freq_hz t)`` at ``d_mm``.
``gap_chirp``
    A linear chirp of the gap from ``freq_hz`` to ``freq_end_hz`` over the run, at ``d_mm``.
``d_traverse``
    ``d`` goes back and forth over ``d_mm +- amplitude_mm`` at the constant speed
    ``speed_mm_s`` (a triangle wave), the gap held at ``gap_mm``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from .. import constants as k
from ..blocks import Reference
from ..config import Strict, load_model
from ..output import atomic_write_text
from ..params import Params
from ..plant import Plant, PlantConfig
from ..riglog import RunLog
from .drive import run_closed_loop

#: Format tag of a run plan file.
PLAN_FORMAT = "maglev-run-plan/1"


class RunSpec(Strict):
    """One closed-loop run of a plan (all quantities in physical units).

    Attributes
    ----------
    kind : {"hold", "gap_sine", "gap_chirp", "d_traverse"}
        Reference kind (module docstring).
    gap_mm, d_mm : float
        Gap and horizontal position the reference is centred on [mm].
    amplitude_mm : float
        Gap amplitude (``gap_sine``, ``gap_chirp``) or half range of d (``d_traverse``) [mm].
    freq_hz, freq_end_hz : float
        Sine frequency, or the chirp's start and end [Hz].
    speed_mm_s : float
        Traverse speed of d [mm/s].
    duration_s : float
        Run length [s].
    lock : {"none", "g", "d"}
        Axis held by a fixture.
    """

    kind: Literal["hold", "gap_sine", "gap_chirp", "d_traverse"]
    gap_mm: float = Field(20.0, ge=10.0, le=30.0)
    d_mm: float = Field(0.0, ge=-55.0, le=55.0)
    amplitude_mm: float = Field(0.0, ge=0.0, le=55.0)
    freq_hz: float = Field(1.0, gt=0.0, le=50.0)
    freq_end_hz: float = Field(5.0, gt=0.0, le=50.0)
    speed_mm_s: float = Field(20.0, gt=0.0, le=500.0)
    duration_s: float = Field(4.0, gt=0.2, le=600.0)
    lock: Literal["none", "g", "d"] = "none"

    @model_validator(mode="after")
    def _check(self) -> RunSpec:
        if self.kind in ("gap_sine", "gap_chirp"):
            if self.lock == "g":
                raise ValueError(f"a {self.kind} run moves the gap; it cannot lock g")
            if not (10.0 <= self.gap_mm - self.amplitude_mm and self.gap_mm + self.amplitude_mm <= 30.0):
                raise ValueError(f"gap {self.gap_mm} +- {self.amplitude_mm} mm leaves 10..30 mm")
        if self.kind == "d_traverse":
            if self.lock == "d":
                raise ValueError("a d_traverse run moves d; it cannot lock d")
            if abs(self.d_mm) + self.amplitude_mm > 55.0:
                raise ValueError(f"d {self.d_mm} +- {self.amplitude_mm} mm leaves -55..55 mm")
        return self

    def label(self) -> str:
        """Short description in physical units (report text)."""
        lock = f", {self.lock} locked" if self.lock != "none" else ""
        if self.kind == "hold":
            return f"hold g = {self.gap_mm:g} mm, d = {self.d_mm:g} mm, {self.duration_s:g} s{lock}"
        if self.kind == "gap_sine":
            return (
                f"gap sine {self.gap_mm:g} +- {self.amplitude_mm:g} mm at {self.freq_hz:g} Hz, "
                f"d = {self.d_mm:g} mm, {self.duration_s:g} s{lock}"
            )
        if self.kind == "gap_chirp":
            return (
                f"gap chirp {self.gap_mm:g} +- {self.amplitude_mm:g} mm, {self.freq_hz:g}..{self.freq_end_hz:g} Hz, "
                f"d = {self.d_mm:g} mm, {self.duration_s:g} s{lock}"
            )
        return (
            f"d traverse {self.d_mm:g} +- {self.amplitude_mm:g} mm at {self.speed_mm_s:g} mm/s, "
            f"g = {self.gap_mm:g} mm, {self.duration_s:g} s{lock}"
        )

    def file_name(self, index: int) -> str:
        """Run file name in a dataset (``plan_<index>_<kind>.csv``)."""
        return f"plan_{index + 1:02d}_{self.kind}.csv"

    def reference(self) -> Callable[[float], Reference]:
        """``t -> Reference`` (positions in m, rates in m/s and m/s^2 as feedforward)."""
        g0, d0, A = self.gap_mm * 1e-3, self.d_mm * 1e-3, self.amplitude_mm * 1e-3
        if self.kind == "hold" or A == 0.0:
            ref = Reference(g=g0, d=d0)
            return lambda t: ref
        if self.kind == "gap_sine":
            w = 2 * math.pi * self.freq_hz
            return lambda t: Reference(
                g=g0 + A * math.sin(w * t), d=d0, g_dot=A * w * math.cos(w * t), g_ddot=-A * w * w * math.sin(w * t)
            )
        if self.kind == "gap_chirp":
            f0, rate = self.freq_hz, (self.freq_end_hz - self.freq_hz) / self.duration_s

            def chirp(t: float) -> Reference:
                phase = 2 * math.pi * (f0 * t + 0.5 * rate * t * t)
                w = 2 * math.pi * (f0 + rate * t)
                return Reference(g=g0 + A * math.sin(phase), d=d0, g_dot=A * w * math.cos(phase))

            return chirp
        v = self.speed_mm_s * 1e-3
        period = 4 * A / v

        def triangle(t: float) -> Reference:
            s = (t / period) % 1.0  # 0..1: centre -> +A -> centre -> -A -> centre
            if s < 0.25:
                return Reference(g=g0, d=d0 + v * s * period, d_dot=v)
            if s < 0.75:
                return Reference(g=g0, d=d0 + A - v * (s - 0.25) * period, d_dot=-v)
            return Reference(g=g0, d=d0 - A + v * (s - 0.75) * period, d_dot=v)

        return triangle

    def reference_table(self, Ts: float = k.Ts) -> np.ndarray:
        """The reference sampled each period: columns ``t, g_ref, d_ref, g_dot_ref, d_dot_ref`` [s, m, m/s]."""
        ref = self.reference()
        t = np.arange(round(self.duration_s / Ts)) * Ts
        rows = [ref(float(ti)) for ti in t]
        return np.column_stack(
            [t, [r.g for r in rows], [r.d for r in rows], [r.g_dot for r in rows], [r.d_dot for r in rows]]
        )


class RunPlan(Strict):
    """A run plan: the runs, and why the diagnosis chose them.

    Attributes
    ----------
    format : str
        ``maglev-run-plan/1``.
    excitation : str
        Name of the menu entry chosen.
    slot : list of str
        The confusable effects the plan is meant to tell apart (empty for a hand-written plan).
    predicted_snr : float
        Predicted separation of the alternatives on the plan's runs (filtered difference over the noise floor).
    why : str
        Plain-language reason.
    runs : list of RunSpec
        The runs, in order.
    """

    format: Literal["maglev-run-plan/1"] = PLAN_FORMAT
    excitation: str = Field("custom", min_length=1, max_length=80)
    slot: list[str] = Field(default_factory=list)
    predicted_snr: float | None = Field(None, ge=0.0)
    why: str = ""
    runs: list[RunSpec] = Field(min_length=1, max_length=200)

    @property
    def duration_s(self) -> float:
        """Total run time [s]."""
        return float(sum(r.duration_s for r in self.runs))


def load_plan(path: str | os.PathLike) -> RunPlan:
    """Read and validate a run plan (a :class:`~maglev_ocp.errors.ConfigError` naming file and key otherwise)."""
    return load_model(RunPlan, path)


def write_plan(plan: RunPlan, path: str | os.PathLike) -> Path:
    """Write ``plan`` as YAML (atomic)."""
    import yaml

    p = Path(path)
    head = (
        f"# {PLAN_FORMAT}: closed-loop runs that separate {' | '.join(plan.slot) or 'the alternatives'}.\n"
        "# Run with: maglev simulate --experiment THIS.yaml --out DIR   (plant simulator), or follow\n"
        "# the reference CSVs next to this file with the rig's own regulators.\n"
    )
    atomic_write_text(p, head + yaml.safe_dump(plan.model_dump(mode="json"), sort_keys=False))
    return p


def write_reference_csvs(plan: RunPlan, folder: str | os.PathLike, Ts: float = k.Ts) -> list[Path]:
    """Each run's reference as ``<folder>/<run file name>`` (``t, g_ref, d_ref, g_dot_ref, d_dot_ref``, SI)."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, r in enumerate(plan.runs):
        tab = r.reference_table(Ts)
        lines = ["t,g_ref,d_ref,g_dot_ref,d_dot_ref", *(",".join(f"{v:.9g}" for v in row) for row in tab)]
        p = out / r.file_name(i).replace(".csv", "_reference.csv")
        atomic_write_text(p, "\n".join(lines) + "\n")
        paths.append(p)
    return paths


def simulate_run(plant: Plant, params: Params, run: RunSpec, file: str, progress: bool = False) -> RunLog:
    """One plan run on ``plant`` with the seed's PID regulators tracking its reference."""
    from ..controllers.pid import PIDController, PIDSettings

    ref = run.reference()
    r0 = ref(0.0)
    ctrl = PIDController(params, PIDSettings(control_g=run.lock != "g", control_d=run.lock != "d"), plant.Ts)
    log = run_closed_loop(
        plant,
        ctrl,
        ref,
        run.duration_s,
        x0=np.array([r0.g, 0.0, r0.d, 0.0]),
        lock=run.lock,
        file=file,
        progress=progress,
    )
    log.meta.update({"experiment": f"plan:{run.kind}", "gap_mm": run.gap_mm, "d_mm": run.d_mm})
    return log


def simulate_plan(
    plan: RunPlan,
    config: PlantConfig,
    params: Params,
    seed: int | np.random.SeedSequence = 0,
    progress: bool = False,
) -> list[RunLog]:
    """Every run of ``plan`` on one plant (one set of true parameters, the run index picks the noise stream)."""
    plant = Plant(config, params, seed=seed)
    return [simulate_run(plant, params, r, r.file_name(i), progress) for i, r in enumerate(plan.runs)]


__all__ = [
    "PLAN_FORMAT",
    "RunPlan",
    "RunSpec",
    "load_plan",
    "simulate_plan",
    "simulate_run",
    "write_plan",
    "write_reference_csvs",
]
