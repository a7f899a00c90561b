"""The campaign's bridge to the scenario runner (:mod:`maglev_ocp.runner`).

One run of a campaign is one scenario: the base scenario with the run's
overrides, validated like a scenario file (so a bad override is a one-line
error naming the key, recorded as the run's failure), run by
:func:`maglev_ocp.runner.run_scenario`, its files written into the work
folder the executor ships back.

Solvers and controllers are built once per worker process: the model is a
process singleton, the plant's step Function and the NMPC's step Functions
are cached per design in their modules, and the runner keeps built controllers
per :meth:`~maglev_ocp.scenario.Scenario.key`; a Dask worker is a long-lived
process, so every run after the first of a setting reuses them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .. import codegen  # noqa: F401 - registers ``backend: c`` with the runner in every worker process
from ..codegen.build import find_compiler
from ..codegen.loop_c import compiled_supported, run_scenario_compiled
from ..runner import run_scenario
from ..scenario import Scenario, scenario_from_dict
from .config import SaveSettings


def use_compiled(scn: Scenario, loop: str) -> bool:
    """Whether a run of ``scn`` goes through the compiled loop under the campaign's ``execution.loop``."""
    if loop == "python":
        return False
    if loop == "compiled":
        return True
    return compiled_supported(scn) and find_compiler() is not None


def run_scenario_dict(
    scenario: dict[str, Any], seed: int, workdir: Path, save: SaveSettings, loop: str = "python"
) -> dict[str, Any]:
    """Validate ``scenario``, run it, keep the files ``save`` asks for in ``workdir``; return its metrics.

    ``loop``: ``python`` (:func:`maglev_ocp.runner.run_scenario`), ``compiled``
    (:func:`maglev_ocp.codegen.loop_c.run_scenario_compiled`) or ``auto`` (see :func:`use_compiled`).
    """
    name = str(scenario.get("name", "run"))
    scn = scenario_from_dict(scenario, source=f"campaign run {name}")
    if use_compiled(scn, loop):
        result = run_scenario_compiled(scn, seed=seed)  # libraries loaded once per process
    else:
        result = run_scenario(scn, seed=seed, progress=False)  # controller from the process cache
    metrics = _metrics_of(result)
    workdir = Path(workdir)
    if save.log or save.figures:
        result.save(workdir, figures=bool(save.figures), log=bool(save.log))
    (workdir / "metrics.json").write_text(json.dumps(metrics, indent=1, default=_plain))
    return metrics


def _metrics_of(result: Any) -> dict[str, Any]:
    """The metrics dict of a runner result (attribute ``metrics``, a dict or an object with ``as_dict``)."""
    m = getattr(result, "metrics", None)
    if m is None:
        raise TypeError(f"runner result {type(result).__name__} has no 'metrics'")
    if hasattr(m, "as_dict"):
        m = m.as_dict()
    elif hasattr(m, "model_dump"):
        m = m.model_dump(mode="json")
    if not isinstance(m, dict):
        raise TypeError(f"runner metrics are {type(m).__name__}, not a dict")
    return json.loads(json.dumps(m, default=_plain))


def _plain(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if hasattr(o, "as_dict"):
        return o.as_dict()
    raise TypeError(f"not JSON serializable: {type(o).__name__}")
