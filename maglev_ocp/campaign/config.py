"""Schema of a campaign file: a base scenario and what varies around it.

A campaign is a study of many closed-loop runs of one base scenario
(``scenarios/*.yaml``). What varies from run to run:

* ``vary.plant`` / ``vary.belief``: relative perturbations of the plant's true
  parameters and of the controller's belief about them (the model it designs
  with), each drawn from a distribution (uniform ±pct %, or normal with a
  relative standard deviation, truncated);
* ``vary.seed``: a fresh noise seed per draw (plant noise, quantization
  offsets, ...);
* ``vary.targets``: random targets drawn uniformly in the tracking envelope;
* ``vary.grid``: controller (or any scenario) settings on a grid, as dotted
  keys (``controller.horizon: [10, 20, 40]``); the grid is the cartesian
  product of the listed values;
* ``vary.controllers``: a list of controller blocks that replace the base
  scenario's ``controller`` in turn.

``n_runs`` random draws are made from the root ``seed`` and each draw is run
with every controller and every grid point (common random numbers, so that
controllers and settings are compared on the same plants), see
:mod:`maglev_ocp.campaign.expand`.

Example::

    name: robustness_fl
    base_scenario: ../scenarios/campaign_base.yaml   # relative to this file
    n_runs: 200
    seed: 20240607
    vary:
      plant:
        C1: {dist: uniform, pct: 10}
        xi0: {dist: normal, pct: 5, clip_sigma: 2}
      targets: {n: 2, hold: 0.3}
      controllers: [{type: fl}]
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, PrivateAttr, field_validator, model_validator

from .. import constants as k
from ..config import Strict, load_model, load_yaml
from ..errors import ConfigError

#: Parameters a campaign may perturb (the masses are weighed, not identified).
PERTURBABLE: tuple[str, ...] = ("C1", "C2", "C3", "C4", "xi0", "ell")
#: Most runs a campaign may expand to (draws x cases); checked before expanding.
MAX_RUNS: int = 100_000
#: Most cases (controllers x grid points x explicit runs); each is validated up front.
MAX_CASES: int = 2_000


class UniformRel(Strict):
    """Multiplicative factor uniform in ``[1 - pct/100, 1 + pct/100]``."""

    dist: Literal["uniform"]
    pct: float = Field(gt=0, lt=100, description="half-width of the interval [%]")


class NormalRel(Strict):
    """Multiplicative factor ``1 + (pct/100) z``, ``z`` standard normal truncated to ``|z| <= clip_sigma``."""

    dist: Literal["normal"]
    pct: float = Field(gt=0, lt=50, description="relative standard deviation [%]")
    clip_sigma: float = Field(3.0, gt=0, le=10, description="truncation of z (redrawn outside)")

    @model_validator(mode="after")
    def _positive(self) -> NormalRel:
        if self.pct * self.clip_sigma >= 100:
            raise ValueError("pct * clip_sigma must stay below 100 (the factor would reach 0)")
        return self


Perturbation = Annotated[UniformRel | NormalRel, Field(discriminator="dist")]


class RandomTargets(Strict):
    """Targets drawn uniformly in a box (default: the tracking envelope), replacing the base's targets."""

    n: int = Field(ge=1, le=50, description="targets per run")
    hold: float = Field(gt=0, le=60, description="hold time of each target [s]")
    g: tuple[float, float] = Field(k.g_envelope, description="gap interval [m]")
    d: tuple[float, float] = Field(k.d_envelope, description="horizontal interval [m]")
    keep_base: bool = Field(False, description="visit the base scenario's targets first")
    resolution: float = Field(1e-6, gt=0, le=1e-3, description="targets are rounded to this [m]")

    @field_validator("g", "d")
    @classmethod
    def _interval(cls, v: tuple[float, float], info) -> tuple[float, float]:
        lo, hi = v
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError("must be [low, high] with low <= high")
        stops = k.g_stop if info.field_name == "g" else k.d_stop
        if lo <= stops[0] or hi >= stops[1]:
            raise ValueError(f"must lie strictly inside the mechanical stops {list(stops)} m")
        return v


class Vary(Strict):
    """Everything that changes from run to run."""

    plant: dict[str, Perturbation] = Field(default_factory=dict, description="true-parameter perturbations")
    belief: dict[str, Perturbation] = Field(default_factory=dict, description="controller-belief perturbations")
    seed: bool = Field(True, description="a fresh noise seed per draw (else the base scenario's seed)")
    targets: RandomTargets | None = None
    grid: dict[str, list[Any]] = Field(default_factory=dict, description="dotted key -> values (cartesian)")
    controllers: list[dict[str, Any]] = Field(default_factory=list, description="controller blocks, in turn")

    @field_validator("plant", "belief")
    @classmethod
    def _names(cls, v: dict[str, Any]) -> dict[str, Any]:
        for name in v:
            if name not in PERTURBABLE:
                raise ValueError(f"unknown parameter {name!r}; one of {', '.join(PERTURBABLE)}")
        return v

    @field_validator("grid")
    @classmethod
    def _grid(cls, v: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in v.items():
            if not key or any(not part for part in key.split(".")):
                raise ValueError(f"bad dotted key {key!r}")
            if key.split(".")[0] in ("seed", "name"):
                raise ValueError(f"{key!r} cannot be on the grid (set by the campaign)")
            if not values:
                raise ValueError(f"{key}: empty list of values")
        return v

    @field_validator("controllers")
    @classmethod
    def _controllers(cls, v: list[dict[str, Any]]) -> list[dict[str, Any]]:
        for i, c in enumerate(v):
            if not isinstance(c.get("type"), str):
                raise ValueError(f"entry {i} needs a 'type' (e.g. nmpc, fl, pid)")
        return v


class SaveSettings(Strict):
    """What each run folder keeps besides ``run.json`` and ``metrics.json``."""

    log: bool = Field(True, description="keep the run's log.csv")
    figures: bool = Field(False, description="keep the run's figures (slow: matplotlib per run)")


class ExecutionSettings(Strict):
    """How each run is executed."""

    loop: Literal["auto", "compiled", "python"] = Field(
        "auto",
        description=(
            "closed loop of each run: 'compiled' (the whole run in one C call, maglev_ocp.codegen.loop_c; "
            "equal to the Python loop with the compiled controller), 'python' (maglev_ocp.loop.ClosedLoop), "
            "'auto' (compiled where the controller has a compiled step and a C compiler is found, else python)"
        ),
    )


class Campaign(Strict):
    """A campaign file (see the module docstring)."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.-]{1,64}$")
    base_scenario: str = Field(description="scenario YAML, relative to the campaign file")
    n_runs: int = Field(1, ge=1, le=1_000_000, description="random draws (each run on every case)")
    runs: list[dict[str, Any]] = Field(
        default_factory=list,
        description="explicit cases: dotted-key overrides, each combined with the grid and controllers",
    )
    seed: int = Field(ge=0, lt=2**63, description="root of the SeedSequence every draw is spawned from")
    order: Literal["draws", "cases"] = Field(
        "draws",
        description=(
            "submission order: 'draws' (every case of draw 0, then draw 1, ...: a partial campaign "
            "compares cases on the same draws) or 'cases' (all draws of case 0, then case 1, ...: "
            "a worker meets the same controller settings in a row, so per-process solver caches hit)"
        ),
    )
    vary: Vary = Field(default_factory=Vary)
    save: SaveSettings = Field(default_factory=SaveSettings)
    execution: ExecutionSettings = Field(default_factory=ExecutionSettings)
    success_tol_m: float = Field(
        k.position_tolerance, gt=0, le=1e-2, description="tolerance the runner's 'settled' refers to (reported only)"
    )

    #: Folder of the campaign file (set by :func:`load_campaign`; base_scenario is relative to it).
    _root_dir: str = PrivateAttr(".")

    def n_cases(self) -> int:
        """Number of cases (controllers x grid points x explicit runs), computed without expanding."""
        n = max(1, len(self.vary.controllers)) * max(1, len(self.runs))
        return n * math.prod(len(v) for v in self.vary.grid.values())

    def n_total(self) -> int:
        """Number of runs the campaign expands to (``n_runs`` draws on every case)."""
        return self.n_runs * self.n_cases()

    def check_size(self, source: str = "campaign") -> None:
        """Refuse a campaign larger than :data:`MAX_RUNS` runs or :data:`MAX_CASES` cases (before expanding)."""
        cases = self.n_cases()
        if cases > MAX_CASES:
            raise ConfigError(
                f"{source}: vary.grid x vary.controllers x runs: {cases} cases (the limit is {MAX_CASES}); "
                "split the campaign"
            )
        total = self.n_runs * cases
        if total > MAX_RUNS:
            raise ConfigError(
                f"{source}: n_runs x cases = {self.n_runs} x {cases} = {total} runs (the limit is {MAX_RUNS}); "
                "lower n_runs or the grid"
            )

    @property
    def root_dir(self) -> str:
        """Folder the campaign file is in."""
        return self._root_dir

    def base_scenario_path(self) -> Path:
        """Absolute path of the base scenario."""
        p = Path(self.base_scenario)
        return p if p.is_absolute() else (Path(self.root_dir) / p).resolve()

    def base_scenario_dict(self) -> dict[str, Any]:
        """The base scenario as a plain mapping (overrides are applied on it).

        Files the scenario names relative to itself (``plant.file``,
        ``controller_params.file``, ``controller.model``) are made absolute, so that a worker
        resolves them wherever it runs.
        """
        path = self.base_scenario_path()
        data = load_yaml(path)
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
        for block in ("plant", "controller_params"):
            sub = data.get(block)
            if isinstance(sub, dict) and isinstance(sub.get("file"), str) and not Path(sub["file"]).is_absolute():
                sub["file"] = str((path.parent / sub["file"]).resolve())
        ctrl = data.get("controller")
        if isinstance(ctrl, dict) and isinstance(ctrl.get("model"), str) and not Path(ctrl["model"]).is_absolute():
            ctrl["model"] = str((path.parent / ctrl["model"]).resolve())
        return data


def load_campaign(path: str | os.PathLike) -> Campaign:
    """Load and validate a campaign file; errors are one line naming the file and key."""
    path = Path(path)
    camp = load_model(Campaign, path)
    camp._root_dir = str(path.resolve().parent)
    camp.check_size(str(path))
    if not camp.base_scenario_path().is_file():
        raise ConfigError(f"{path}: base_scenario: no such file {camp.base_scenario_path()}")
    for i, case in enumerate(camp.runs):
        for key in case:
            if not isinstance(key, str) or not key or key.split(".")[0] in ("seed", "name"):
                raise ConfigError(f"{path}: runs.{i}: bad override key {key!r}")
    return camp
