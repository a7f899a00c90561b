"""Diagnosis datasets on the plant simulator: closed-loop excitation sweeping gap and position.

A diagnosis needs data that visits the gaps and positions where effects live
(cogging below 15 mm, the ends of the stroke, both directions of motion,
current changes). The seed's PID regulators (:mod:`maglev_ocp.controllers.pid`) track a
sum of slow, large sines (the sweep) plus small, faster sines (dither that
excites velocities and current rates), as the seed did for its
identification. Each run covers a different band of gaps, so a dataset of
``n_runs`` runs spans ``g_range`` and holding out whole runs still leaves the
training runs covering the whole range (the runs' bands overlap).

Effects outside the library (for the blind self-check's ``unexplained``
case) are injected as an extra force through :class:`ForcedPlant`, which
adds it to the plant's process-force input (held over each period).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from maglev_ocp.controllers.pid import PIDController

from .. import constants as k
from ..blocks import Reference
from ..config import Strict
from ..params import NOMINAL, Params
from ..plant import Plant, PlantConfig
from ..plant.excitation import AxisExcitation, ExcitationSettings, SumOfSines
from ..riglog import Dataset, RunLog

ForceLaw = Callable[[float, np.ndarray], np.ndarray]


class GeneratorSettings(Strict):
    """How a diagnosis dataset is excited.

    Attributes
    ----------
    n_runs : int
        Number of runs.
    run_duration : float
        Length of each run [s].
    g_range : list of float
        Gap band swept by the dataset [m].
    d_amplitude : float
        Peak horizontal excursion [m].
    dither_g, dither_d : float
        Peak amplitude of the fast dither on each axis [m].
    loop : {"auto", "compiled", "python"}
        Closed loop of the runs: ``compiled`` (each run in one C call,
        :func:`maglev_ocp.codegen.loop_c.run_closed_loop_compiled`; equal to the
        Python loop), ``python`` (:func:`maglev_ocp.loop.run_closed_loop`),
        ``auto`` (compiled where possible, else Python with a logged note). Not
        part of the dataset's truth: both loops give the same data.
    """

    n_runs: int = Field(6, ge=2, le=100)
    run_duration: float = Field(10.0, ge=2.0, le=600.0)
    g_range: list[float] = Field(default_factory=lambda: [11e-3, 24e-3], min_length=2, max_length=2)
    d_amplitude: float = Field(45e-3, ge=0.0, le=55e-3)
    dither_g: float = Field(0.4e-3, ge=0.0, le=3e-3)
    dither_d: float = Field(2e-3, ge=0.0, le=10e-3)
    loop: Literal["auto", "compiled", "python"] = "auto"


class _Composite:
    """Sum of two sum-of-sines references (sweep + dither)."""

    def __init__(self, a: SumOfSines, b: SumOfSines):
        self.a, self.b = a, b

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Rows ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` at the times ``t``, equal to the calls (for the C loop)."""
        return self.a.sample(t) + self.b.sample(t)

    def __call__(self, t: float) -> Reference:
        ra, rb = self.a(t), self.b(t)
        return Reference(
            ra.g + rb.g,
            ra.d + rb.d,
            ra.g_dot + rb.g_dot,
            ra.d_dot + rb.d_dot,
            ra.g_ddot + rb.g_ddot,
            ra.d_ddot + rb.d_ddot,
        )


def run_reference(i: int, settings: GeneratorSettings, seed: np.random.SeedSequence) -> _Composite:
    """Reference of run ``i``: its gap band, the horizontal sweep, and the dither."""
    lo, hi = settings.g_range
    n = settings.n_runs
    # Overlapping bands: each run sweeps c +- half, the centres spread over the range (the sum of sines
    # rarely reaches its peak, so the bands reach to within ~0.2 half of the range's ends).
    half = max(0.3 * (hi - lo), 2.5e-3)
    centers = np.linspace(lo + 0.8 * half, hi - 0.8 * half, n)
    order = [j for pair in zip(range(0, n, 2), range(1, n, 2), strict=False) for j in pair] + ([n - 1] if n % 2 else [])
    c = float(centers[order[i % n]])
    amp = half
    rng = np.random.default_rng(seed)
    fg = sorted(rng.uniform(0.05, 0.6, 3).tolist())
    fd = sorted(rng.uniform(0.04, 0.35, 3).tolist())
    sweep = ExcitationSettings(
        g=AxisExcitation(center=c, amplitude=amp, freqs_hz=fg),
        d=AxisExcitation(center=0.0, amplitude=settings.d_amplitude, freqs_hz=fd),
        fade_in=1.0,
    )
    dither = ExcitationSettings(
        g=AxisExcitation(center=0.0, amplitude=settings.dither_g, freqs_hz=sorted(rng.uniform(1.0, 6.0, 3).tolist())),
        d=AxisExcitation(center=0.0, amplitude=settings.dither_d, freqs_hz=sorted(rng.uniform(0.8, 4.0, 3).tolist())),
        fade_in=1.0,
    )
    s1, s2 = seed.spawn(2)
    return _Composite(SumOfSines(sweep, s1), SumOfSines(dither, s2))


class _ForcedNoise:
    """Process-noise stream with an extra deterministic force added (see :class:`ForcedPlant`)."""

    def __init__(self, inner, std: np.ndarray, scale: np.ndarray, plant: ForcedPlant):
        self.inner, self.std, self.scale, self.plant = inner, std, scale, plant

    def next(self) -> np.ndarray:
        F = np.asarray(self.plant.force(self.plant.t, self.plant.x), float)
        return (self.std * self.inner.next() + F) / self.scale


class ForcedPlant(Plant):
    """The plant with an extra force law ``F(t, x) -> (F_g, F_d)`` [N] added to its process force.

    The force is evaluated at the start of each period and held over it, like
    the plant's process noise (through which it enters). Used to put effects
    that are *not* in the library into a dataset.

    Parameters
    ----------
    force : callable
        ``(t, x) -> (F_g, F_d)`` [N]; ``F_g > 0`` opens the gap.
    *args, **kwargs
        As for :class:`~maglev_ocp.plant.Plant`.

    Notes
    -----
    This reaches into the plant's process-noise stream (``_n_proc``,
    ``_proc_std``, ``_proc_on``), the only per-period force input the plant
    has; a public extra-force hook in the plant would be cleaner.
    """

    def __init__(self, force: ForceLaw, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.force = force

    def reset(self, *args, **kwargs):
        """As :meth:`Plant.reset`, then route the extra force through the process-force input."""
        y = super().reset(*args, **kwargs)
        std = np.asarray(self._proc_std, float).copy()
        scale = np.where(std > 0, std, 1.0)
        self._n_proc = _ForcedNoise(self._n_proc, std, scale, self)
        self._proc_std = scale
        self._proc_on = True
        return y


def vibration_force(amplitude_n: float = 0.4, freq_hz: float = 7.3, axis: str = "g") -> ForceLaw:
    """A structural vibration (a fan, a pump): ``A sin(2 pi f t)`` on one axis, independent of the state."""
    j = 0 if axis == "g" else 1

    def F(t: float, x: np.ndarray) -> np.ndarray:
        out = np.zeros(2)
        out[j] = amplitude_n * math.sin(2 * math.pi * freq_hz * t)
        return out

    return F


def guide_ripple_force(amplitude_n: float = 0.15, period_m: float = 8.6e-3) -> ForceLaw:
    """Ball-recirculation ripple of a linear guide: ``A sin(2 pi d / P)`` along d (no slot or pole period)."""

    def F(t: float, x: np.ndarray) -> np.ndarray:
        return np.array([0.0, amplitude_n * math.sin(2 * math.pi * x[2] / period_m)])

    return F


#: Out-of-library effects the self-check can inject: name -> (force law factory, channel, what to expect).
OUT_OF_LIBRARY: dict[str, tuple[Callable[..., ForceLaw], str]] = {
    "vibration": (vibration_force, "vertical"),
    "guide_ripple": (guide_ripple_force, "horizontal"),
}


@dataclass
class GeneratedDataset:
    """A generated dataset and the truth behind it.

    Attributes
    ----------
    dataset : riglog.Dataset
        The runs (rig-log format).
    true_params : Params
        The plant's true parameters.
    effects : dict
        Switched-on library effects and their parameters.
    extra : dict or None
        The out-of-library force, if any (``{"name", "params"}``).
    """

    dataset: Dataset
    true_params: Params
    effects: dict
    extra: dict | None = None

    def save(self, folder: str | os.PathLike) -> None:
        """Write the dataset (the truth goes into ``dataset.yaml``'s ``meta``)."""
        self.dataset.save(folder)


def generate_dataset(
    config: PlantConfig,
    params: Params = NOMINAL,
    seed: int | np.random.SeedSequence = 0,
    settings: GeneratorSettings | None = None,
    controller_params: Params | None = None,
    extra_force: ForceLaw | None = None,
    extra_info: dict | None = None,
    progress: bool = False,
) -> GeneratedDataset:
    """Run the diagnosis excitation on the plant and return the dataset.

    Parameters
    ----------
    config : PlantConfig
        The simulated rig.
    params : Params
        Nominal parameters handed to the plant (its mismatch perturbs them).
    seed : int or SeedSequence
        Seeds the plant (noise, mismatch) and the references' phases and frequencies.
    settings : GeneratorSettings
        Excitation.
    controller_params : Params, optional
        Model of the PID regulators (default: ``params`` without cogging, the
        nominal model an engineer starts from).
    extra_force : callable, optional
        Out-of-library force law (see :class:`ForcedPlant`).
    extra_info : dict, optional
        Description of ``extra_force`` stored with the truth.
    progress : bool
        Progress bar per run.

    Returns
    -------
    GeneratedDataset
    """
    settings = settings or GeneratorSettings()
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
    s_plant, s_ref = ss.spawn(2)
    plant = (
        ForcedPlant(extra_force, config, params, seed=s_plant) if extra_force else Plant(config, params, seed=s_plant)
    )
    cparams = controller_params or params.without_cogging()
    from ..codegen.loop_c import rig_loop  # the loop choice (codegen is heavy to import)

    run = rig_loop(settings.loop, plant, PIDController(cparams))
    runs: list[RunLog] = []
    for i, s_run in enumerate(s_ref.spawn(settings.n_runs)):
        ref = run_reference(i, settings, s_run)
        ctrl = PIDController(cparams)
        log = run(
            plant,
            ctrl,
            ref,
            settings.run_duration,
            file=f"excite_{i:02d}.csv",
            progress=progress,
            desc=f"run {i + 1}/{settings.n_runs}",
        )
        runs.append(log)
    truth = {
        "true_params": plant.true_params.as_dict(),
        "effects": config.effect_values(),
        "extra_force": extra_info,
        "generator": settings.model_dump(exclude={"loop"}),
    }
    ds = Dataset(
        k.Ts,
        config.quantization.resolution if config.quantization.enabled else k.encoder_resolution,
        runs,
        meta={"diagnosis_truth": truth, "plant": config.to_dict()},
    )
    return GeneratedDataset(ds, plant.true_params, config.effect_values(), extra_info)


__all__ = [
    "OUT_OF_LIBRARY",
    "ForcedPlant",
    "GeneratedDataset",
    "GeneratorSettings",
    "generate_dataset",
    "guide_ripple_force",
    "run_reference",
    "vibration_force",
]
