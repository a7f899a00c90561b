"""Expansion of a campaign into its list of runs, deterministically.

A campaign has *cases* (controllers x grid points x explicit ``runs``) and
*draws* (``n_runs`` random draws). Every draw is run on every case, so that
controllers and settings are compared on the same perturbed plants, noise and
targets (common random numbers).

Seeding: draw ``i`` owns the SeedSequence ``root.spawn(n_runs)[i]``, i.e.
``SeedSequence(seed, spawn_key=(i,))``, and its four children
``(i, 0)`` plant parameters, ``(i, 1)`` controller belief, ``(i, 2)`` targets,
``(i, 3)`` the run's noise seed; each perturbed parameter has its own stream
``(i, 0, j)`` / ``(i, 1, j)`` with ``j`` its index in ``PERTURBABLE``. So

* a run's draws do not depend on the number of workers, on the order in which
  runs finish, nor on how many runs there are (raising ``n_runs`` keeps the
  first draws), and
* varying one more parameter does not change the draws of the others.

The expansion never touches the filesystem beyond reading the base scenario;
:func:`expand` is a pure function of the campaign.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..errors import ConfigError, UserError
from ..params import NOMINAL
from ..scenario import scenario_from_dict
from .config import PERTURBABLE, Campaign, NormalRel, UniformRel

#: Where the plant's true parameters live in a scenario: the plant's mismatch overrides, applied after
#: the profile's random mismatch, so the drawn value is exactly the simulated rig's parameter.
PLANT_PARAMS_KEY = "plant.mismatch.overrides"
#: Where the controller's belief about the parameters lives in a scenario.
BELIEF_PARAMS_KEY = "controller_params"
#: Where a perturbation's reference value is looked up in the base scenario, in order (then NOMINAL).
_BASE_KEYS = {PLANT_PARAMS_KEY: (PLANT_PARAMS_KEY, "plant.params"), BELIEF_PARAMS_KEY: (BELIEF_PARAMS_KEY,)}

_STREAM_PLANT, _STREAM_BELIEF, _STREAM_TARGETS, _STREAM_NOISE = range(4)


@dataclass(frozen=True)
class RunSpec:
    """One run of a campaign: the base scenario with ``overrides``, run with ``seed``.

    Attributes
    ----------
    run_id : str
        Folder name of the run, unique in the campaign (``<controller>-c<case>-r<draw>``).
    index : int
        Position in the expansion (the summary's row order).
    case, draw : int
        Case index (controller x grid x explicit run) and random-draw index.
    controller : str
        Controller type of the run (the summary groups by it).
    overrides : dict
        Dotted scenario keys -> values (``plant.params.C1``, ``controller.horizon``,
        ``targets``, ...), applied in order on the base scenario.
    seed : int
        Noise seed handed to the runner.
    deviations : dict
        Relative parameter deviations drawn for this run, in percent
        (``plant.C1``, ``belief.xi0``, ...); what the figures plot against.
    grid : dict
        This case's grid point (dotted key -> value).
    """

    run_id: str
    index: int
    case: int
    draw: int
    controller: str
    overrides: dict[str, Any]
    seed: int
    deviations: dict[str, float] = field(default_factory=dict)
    grid: dict[str, Any] = field(default_factory=dict)

    def digest(self) -> str:
        """Short hash of what determines the run (overrides and seed); guards resume against a changed campaign."""
        blob = json.dumps({"overrides": self.overrides, "seed": self.seed}, sort_keys=True, default=float)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunSpec:
        """Inverse of :meth:`to_dict`."""
        return cls(**data)


def draw_seed_sequence(root_seed: int, *path: int) -> np.random.SeedSequence:
    """SeedSequence of a draw's stream: equals ``root.spawn(..)[path[0]].spawn(..)[path[1]]...``."""
    return np.random.SeedSequence(root_seed, spawn_key=tuple(path))


def _factor(spec: UniformRel | NormalRel, rng: np.random.Generator) -> float:
    """Draw a multiplicative factor from a perturbation spec."""
    if isinstance(spec, UniformRel):
        return float(1.0 + rng.uniform(-spec.pct, spec.pct) / 100.0)
    while True:  # truncated normal by rejection (P(reject) < 0.32 for clip_sigma >= 1)
        z = float(rng.standard_normal())
        if abs(z) <= spec.clip_sigma:
            return 1.0 + spec.pct / 100.0 * z


def get_dotted(data: dict[str, Any], key: str, default: Any = None) -> Any:
    """Value at dotted ``key`` in nested dicts/lists, or ``default`` if absent."""
    cur: Any = data
    for part in key.split("."):
        if isinstance(cur, dict) and part in cur:
            cur = cur[part]
        elif isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
            cur = cur[int(part)]
        else:
            return default
    return cur


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set dotted ``key`` in nested dicts (created as needed) or lists (existing index)."""
    parts = key.split(".")
    cur: Any = data
    for part in parts[:-1]:
        if isinstance(cur, list):
            cur = cur[int(part)]
            continue
        nxt = cur.get(part)
        if not isinstance(nxt, (dict, list)):
            nxt = {}
            cur[part] = nxt
        cur = nxt
    last = parts[-1]
    if isinstance(cur, list):
        cur[int(last)] = copy.deepcopy(value)
    else:
        cur[last] = copy.deepcopy(value)


def apply_overrides(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """A deep copy of ``base`` with the dotted ``overrides`` applied in order."""
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        set_dotted(out, key, value)
    return out


def _cases(camp: Campaign, base: dict[str, Any]) -> list[tuple[str, dict[str, Any], dict[str, Any]]]:
    """(controller type, overrides, grid point) of every case, in a fixed order."""
    controllers = camp.vary.controllers or [None]
    keys = list(camp.vary.grid)
    points = [dict(zip(keys, vals, strict=True)) for vals in itertools.product(*camp.vary.grid.values())]
    explicit = camp.runs or [{}]
    out = []
    for ctrl in controllers:
        for point in points:
            for extra in explicit:
                ov: dict[str, Any] = {}
                if ctrl is not None:
                    ov["controller"] = copy.deepcopy(ctrl)
                ov.update(point)
                ov.update(copy.deepcopy(extra))
                resolved = apply_overrides(base, ov)
                ctype = str(get_dotted(resolved, "controller.type", "controller"))
                out.append((ctype, ov, dict(point)))
    return out


def _random_targets(camp: Campaign, base: dict[str, Any], rng: np.random.Generator) -> list[dict[str, float]]:
    """Targets of one draw: uniform in the box, rounded to the resolution."""
    rt = camp.vary.targets
    assert rt is not None
    targets = [dict(t) for t in base.get("targets") or []] if rt.keep_base else []
    for _ in range(rt.n):
        g = rng.uniform(*rt.g)
        d = rng.uniform(*rt.d)
        # Round, then clamp back inside the box (rounding may step just outside it).
        g = min(max(round(g / rt.resolution) * rt.resolution, rt.g[0]), rt.g[1])
        d = min(max(round(d / rt.resolution) * rt.resolution, rt.d[0]), rt.d[1])
        targets.append({"g": float(g), "d": float(d), "hold": float(rt.hold)})
    return targets


def _draw(camp: Campaign, base: dict[str, Any], i: int) -> tuple[dict[str, Any], dict[str, float], int]:
    """Overrides, deviations [%] and noise seed of draw ``i``."""
    ov: dict[str, Any] = {}
    dev: dict[str, float] = {}
    for stream, key, tag, perts in (
        (_STREAM_PLANT, PLANT_PARAMS_KEY, "plant", camp.vary.plant),
        (_STREAM_BELIEF, BELIEF_PARAMS_KEY, "belief", camp.vary.belief),
    ):
        for name in PERTURBABLE:  # fixed order; each parameter its own stream
            if name not in perts:
                continue
            j = PERTURBABLE.index(name)
            rng = np.random.default_rng(draw_seed_sequence(camp.seed, i, stream, j))
            f = _factor(perts[name], rng)
            nominal = next(
                (v for v in (get_dotted(base, f"{bk}.{name}") for bk in _BASE_KEYS[key]) if v is not None),
                getattr(NOMINAL, name),
            )
            nominal = float(nominal)
            ov[f"{key}.{name}"] = nominal * f
            dev[f"{tag}.{name}"] = (f - 1.0) * 100.0
    if camp.vary.targets is not None:
        rng = np.random.default_rng(draw_seed_sequence(camp.seed, i, _STREAM_TARGETS))
        ov["targets"] = _random_targets(camp, base, rng)
    if camp.vary.seed:
        seed = int(draw_seed_sequence(camp.seed, i, _STREAM_NOISE).generate_state(1, dtype=np.uint32)[0])
    else:
        seed = int(base.get("seed", 0) or 0)
    return ov, dev, seed


def expand(camp: Campaign, base: dict[str, Any] | None = None) -> list[RunSpec]:
    """The campaign's runs, in a fixed order (``camp.order``: draw-major or case-major).

    Parameters
    ----------
    camp : Campaign
        The campaign.
    base : dict, optional
        The base scenario as a mapping (default: read ``camp.base_scenario``).

    Returns
    -------
    list of RunSpec
        Same campaign -> same list, whatever runs it later and how.
    """
    camp.check_size(f"campaign {camp.name}")
    base = camp.base_scenario_dict() if base is None else base
    cases = _cases(camp, base)
    wc = max(2, len(str(len(cases) - 1)))
    wd = max(4, len(str(camp.n_runs - 1)))
    draws = [_draw(camp, base, i) for i in range(camp.n_runs)]
    pairs = (
        itertools.product(range(camp.n_runs), range(len(cases)))
        if camp.order == "draws"
        else ((i, ci) for ci in range(len(cases)) for i in range(camp.n_runs))
    )
    specs: list[RunSpec] = []
    for i, ci in pairs:
        ov_draw, dev, seed = draws[i]
        ctype, ov_case, point = cases[ci]
        ov = {**ov_case, **ov_draw}
        rid = f"{_safe(ctype)}-c{ci:0{wc}d}-r{i:0{wd}d}"
        specs.append(RunSpec(rid, len(specs), ci, i, ctype, ov, seed, dict(dev), point))
    return specs


def _safe(s: str) -> str:
    """Folder-safe version of a label."""
    return "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in s)[:24] or "run"


def n_cases(camp: Campaign) -> int:
    """Number of cases (controllers x grid points x explicit runs)."""
    return camp.n_cases()


def validate_cases(camp: Campaign, base: dict[str, Any] | None = None, source: str | None = None) -> int:
    """Validate every case's scenario (and the first draw's) before any run: bad settings fail here, not per run.

    Each case (controller x grid point x explicit run) is the base scenario with
    its overrides, validated like a scenario file; the first random draw's
    overrides (parameters, targets) are validated on the first case.

    Returns
    -------
    int
        The number of cases checked.

    Raises
    ------
    ConfigError
        One line naming the campaign, the case's overrides and the key.
    """
    source = source or f"campaign {camp.name}"
    camp.check_size(source)
    base = camp.base_scenario_dict() if base is None else base
    cases = _cases(camp, base)
    root = str(camp.base_scenario_path().parent)
    for ci, (_ctype, ov, _point) in enumerate(cases):
        extra = _draw(camp, base, 0)[0] if ci == 0 else {}
        data = apply_overrides(base, {**ov, **extra})
        data["name"] = f"{camp.name}-case{ci}"
        what = ", ".join(f"{k}={_short(v)}" for k, v in ov.items()) or "base scenario"
        try:
            scenario_from_dict(data, f"{source}: case {ci} ({what})", root)
        except UserError as err:
            raise ConfigError(str(err)) from None
    return len(cases)


def _short(v: Any) -> str:
    """A value shortened for a one-line message."""
    text = json.dumps(v, default=str) if isinstance(v, (dict, list)) else str(v)
    return text if len(text) <= 40 else text[:37] + "..."
