"""The scenario runner: one closed-loop run of a scenario against the plant simulator.

:func:`run_scenario` is a pure function of (scenario, seed): same inputs, the
same ``log.csv`` bit for bit, whatever process runs it (a Dask worker of a
campaign included). It goes through five stages:

1. **plan** (:func:`plan_run`): the reference (:mod:`maglev_ocp.reference`)
   planned on the controller's model and sampled on the control grid, and
   the active target of each step (a scenario whose targets cannot be
   planned fails here, before anything is built);
2. **build** (:func:`build_run`): the controller (built, or reused from a
   cache) and the plant simulator;
3. **loop** (:func:`loop_run`): the one closed loop
   (:class:`maglev_ocp.loop.ClosedLoop`) with a
   :class:`~maglev_ocp.loop.TraceRecorder`::

       y = plant.reset(x0)
       ctrl.reset(y, ref(0))
       for k in range(n):
           out = ctrl.step(y, ref(t_k))      # timed: the controller's computation
           y = plant.step(out.u)

4. **metrics** (:func:`run_columns`, :func:`run_metrics`): the log's columns,
   metrics and tolerance checks;
5. **save** (:meth:`RunResult.save`).

A controller that raises, or returns non-finite currents, ends the run early
with ``error`` set in the metrics (the run is then failed, never lost).

Files written by :meth:`RunResult.save` into ``DIR``:

``log.csv``
    Rig-log columns ``t, g, d, i_q, i_d`` first (readings and commanded
    currents, RIG_LOG.md), then references, targets, the true state, the
    controller's estimates, the applied currents and the controller's
    statistics. Deterministic: no wall-clock column.
``timing.csv``
    ``t, step_time_us``: the controller's computation time per step (wall
    clock, so it differs from run to run; kept out of ``log.csv`` for that).
``metrics.json``, ``scenario.yaml``, ``dataset.yaml``, figures
    The metrics, the scenario as resolved, ``dataset.yaml`` (so the run folder
    is a ``maglev-rig-log/1`` dataset), ``positions.png``, ``currents.png``,
    ``solver_time.png``.
"""

from __future__ import annotations

import json
import os
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping, MutableMapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import constants as k
from .blocks import Controller, Reference
from .errors import UserError
from .loop import TIMING_SUFFIX, ClosedLoop, TraceRecorder
from .metrics import Metrics, compute_metrics
from .output import atomic_write_text, dump_yaml
from .plant import Plant
from .reference import ReferencePlan, plan_targets
from .riglog import RunLog
from .scenario import Scenario, controller_classes, load_scenario, scenario_from_dict

#: Controllers built in this process, reused by later runs of the same setting (a campaign worker's cache).
_PROCESS_CACHE: OrderedDict[str, Any] = OrderedDict()
_PROCESS_CACHE_SIZE = 16


#: Builds a controller on a non-Python backend: ``builder(type, settings, params) -> Controller``.
ControllerBuilder = Callable[[str, Any, Any], Controller]

#: Controller builders per backend other than ``python``. The runner sits below code generation and
#: never imports it: :mod:`maglev_ocp.codegen` registers ``c`` here when it is imported (the ``maglev``
#: CLI imports it with its commands; a script running ``backend: c`` imports ``maglev_ocp.codegen``).
CONTROLLER_BACKENDS: dict[str, ControllerBuilder] = {}


def register_backend(name: str, builder: ControllerBuilder) -> None:
    """Make ``controller.backend: <name>`` buildable by :func:`build_controller` (called by upper layers)."""
    CONTROLLER_BACKENDS[name] = builder


def build_controller(scenario: Scenario, backends: Mapping[str, ControllerBuilder] | None = None) -> Controller:
    """Build the scenario's controller on what its model believes (``controller_params``).

    ``backend: python`` is the controller class itself; any other backend is
    built by the builder registered for it (``backends``, default
    :data:`CONTROLLER_BACKENDS`; ``c`` comes from :mod:`maglev_ocp.codegen`);
    an unregistered backend is a clear :class:`UserError`.
    """
    spec = scenario.controller
    _, cls = controller_classes(spec.type)
    params = scenario.controller_model_params()
    if spec.backend == "python":
        return cls(settings=spec.settings, params=params)
    builder = (CONTROLLER_BACKENDS if backends is None else backends).get(spec.backend)
    if builder is None:
        raise UserError(
            f"{scenario.source}: controller.backend: {spec.backend!r} is not available yet for {spec.type} "
            "(needs the generated code of maglev codegen: import maglev_ocp.codegen, as the maglev CLI does); "
            "use backend: python"
        )
    return builder(spec.type, spec.settings, params)


def cached_controller(scenario: Scenario, cache: MutableMapping[str, Any] | None = None) -> Controller:
    """The scenario's controller, reused if one was built for the same :meth:`Scenario.key`.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    cache : mutable mapping, optional
        Where built controllers are kept; default: this process's cache (the
        last 16 settings), so a campaign worker builds each setting once.
    """
    key = scenario.key()
    if cache is None:
        if key in _PROCESS_CACHE:
            _PROCESS_CACHE.move_to_end(key)
            return _PROCESS_CACHE[key]
        ctrl = build_controller(scenario)
        _PROCESS_CACHE[key] = ctrl
        while len(_PROCESS_CACHE) > _PROCESS_CACHE_SIZE:
            _PROCESS_CACHE.popitem(last=False)
        return ctrl
    if key not in cache:
        cache[key] = build_controller(scenario)
    return cache[key]


def _as_scenario(scenario: Scenario | dict | str | os.PathLike) -> Scenario:
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, dict):
        return scenario_from_dict(scenario)
    return load_scenario(scenario)


@dataclass
class RunResult:
    """Outcome of one closed-loop run.

    Attributes
    ----------
    scenario : Scenario
        The scenario as run (its ``seed`` is the one used).
    columns : dict of str to ndarray
        The log, column by column (see the module docstring).
    step_time_us : ndarray
        Controller computation time per step [µs].
    plan : ReferencePlan
        The reference plan of the run.
    metrics : Metrics
        Metrics and tolerance checks.
    wall_s : float
        Wall time of the run [s].
    """

    scenario: Scenario
    columns: dict[str, np.ndarray]
    step_time_us: np.ndarray
    plan: ReferencePlan
    metrics: Metrics
    wall_s: float = 0.0
    files: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """All tolerance checks hold."""
        return self.metrics.passed

    @property
    def log(self) -> RunLog:
        """The log as a :class:`~maglev_ocp.riglog.RunLog` (``log.csv``)."""
        return RunLog("log.csv", self.columns, (), {"scenario": self.scenario.name, "seed": self.scenario.seed})

    def table(self) -> str:
        """Text view of the metrics (one row per target, then the overall figures)."""
        return self.metrics.table()

    def save(self, out_dir: str | os.PathLike, figures: bool = True, log: bool = True) -> Path:
        """Write the run's files into ``out_dir`` (each atomically; see the module docstring)."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        files = []
        if log:
            files.append(self.log.save(out / "log.csv"))
            dump_yaml(
                out / "dataset.yaml",
                {
                    "format": "maglev-rig-log/1",
                    "sample_time": k.Ts,
                    "encoder_resolution": k.encoder_resolution,
                    "description": f"closed-loop run of scenario {self.scenario.name} (maglev run)",
                    "runs": [{"file": "log.csv", "locked": []}],
                },
            )
            files.append(out / "dataset.yaml")
            lines = ["t,step_time_us"] + [
                f"{t!r},{s!r}" for t, s in zip(self.columns["t"].tolist(), self.step_time_us.tolist(), strict=True)
            ]
            atomic_write_text(out / "timing.csv", "\n".join(lines) + "\n")
            files.append(out / "timing.csv")
        atomic_write_text(out / "metrics.json", json.dumps(self.metrics.to_dict(), indent=2) + "\n")
        dump_yaml(out / "scenario.yaml", self.scenario.resolved())
        files += [out / "metrics.json", out / "scenario.yaml"]
        if figures and len(self.columns["t"]):
            from .plots import plot_run

            files += plot_run(
                out, self.columns, self.step_time_us, self.plan, self.scenario.tolerance, self.scenario.name
            )
        self.files = files
        return out


@dataclass
class RunPlan:
    """The plan stage of a run: the reference on the control grid and the active target of each step.

    Attributes
    ----------
    plan : ReferencePlan
        The reference plan.
    t : ndarray (n,)
        Control grid ``t_k = k Ts`` [s].
    refs : ndarray (n, 6)
        Reference rows (:data:`maglev_ocp.signals.REF_FIELDS` order), accelerations averaged over each period.
    targets : ndarray (n, 2)
        Active target ``(g, d)`` at each step [m].
    """

    plan: ReferencePlan
    t: np.ndarray
    refs: np.ndarray
    targets: np.ndarray

    @property
    def n(self) -> int:
        """Number of steps."""
        return len(self.t)

    def reference(self, i: int) -> Reference:
        """The controller's reference at step ``i``."""
        r = self.refs[i]
        return Reference(g=r[0], d=r[3], g_dot=r[1], d_dot=r[4], g_ddot=r[2], d_ddot=r[5])


def build_run(
    sc: Scenario, controller: Controller | None = None, cache: MutableMapping[str, Any] | None = None
) -> tuple[Controller, Plant]:
    """Build stage: the controller (``controller`` if given, else from the cache) and the plant of ``sc``."""
    ctrl = controller if controller is not None else cached_controller(sc, cache)
    ss_plant, _ = sc.seed_sequences()
    plant = Plant(sc.plant_config(), params=sc.plant_params(), seed=ss_plant, Ts=k.Ts)
    return ctrl, plant


def plan_run(sc: Scenario) -> RunPlan:
    """Plan stage: plan the scenario's targets on the controller's model (its model file's constants and
    effects, :meth:`~maglev_ocp.scenario.Scenario.planning_model`) and sample the reference per step."""
    Ts = k.Ts
    params, effects = sc.planning_model()
    plan = plan_targets(
        (sc.start.g, sc.start.d),
        sc.target_list(),
        params,
        sc.reference,
        t_start=sc.start.hover,
        source=f"{sc.source}: targets",
        effects=effects,
    )
    n = round(plan.duration / Ts)
    tgrid = np.arange(n) * Ts
    refs = plan.sample(tgrid, zoh=Ts)  # accelerations: mean over each period (ZOH-consistent feedforward)
    tgt_idx = np.clip(np.searchsorted(plan.switch_times, tgrid + 1e-9, side="right") - 1, 0, len(plan.targets) - 1)
    targets = np.array([[plan.targets[i].g, plan.targets[i].d] for i in tgt_idx]).reshape(n, 2)
    return RunPlan(plan, tgrid, refs, targets)


def loop_run(
    sc: Scenario, ctrl: Controller, plant: Plant, rp: RunPlan, progress: bool = False
) -> tuple[TraceRecorder, int, str | None]:
    """Loop stage: the closed loop from the scenario's start; ``(trace, steps done, error or None)``."""
    if hasattr(ctrl, "set_reference_plan"):
        ctrl.set_reference_plan(rp.plan)
    r0 = rp.reference(0) if rp.n else Reference(g=sc.start.g, d=sc.start.d)
    trace = TraceRecorder(rp.n)
    loop = ClosedLoop(plant, ctrl, [trace], on_error="stop")
    loop.reset(np.array([sc.start.g, 0.0, sc.start.d, 0.0]), r0)
    done = loop.run(rp.reference, rp.n, progress=progress, desc=sc.name)
    return trace, done, loop.error


def run_columns(rp: RunPlan, trace: TraceRecorder, done: int) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The log's columns of the first ``done`` steps (see the module docstring), and the statistics among them."""
    sl = slice(0, done)
    Y, X, U, XH, UA, refs, tg = trace.Y, trace.X, trace.U, trace.XH, trace.UA, rp.refs, rp.targets
    cols: dict[str, np.ndarray] = {
        "t": rp.t[sl],
        "g": Y[sl, 0],
        "d": Y[sl, 1],
        "i_q": U[sl, 0],
        "i_d": U[sl, 1],
        "g_ref": refs[sl, 0],
        "d_ref": refs[sl, 3],
        "g_dot_ref": refs[sl, 1],
        "d_dot_ref": refs[sl, 4],
        "g_ddot_ref": refs[sl, 2],
        "d_ddot_ref": refs[sl, 5],
        "g_target": tg[sl, 0],
        "d_target": tg[sl, 1],
        "g_true": X[sl, 0],
        "g_dot_true": X[sl, 1],
        "d_true": X[sl, 2],
        "d_dot_true": X[sl, 3],
        "g_hat": XH[sl, 0],
        "g_dot_hat": XH[sl, 1],
        "d_hat": XH[sl, 2],
        "d_dot_hat": XH[sl, 3],
        "i_q_applied": UA[sl, 0],
        "i_d_applied": UA[sl, 1],
        "limited": trace.limited[sl],
    }
    stat_cols = trace.stat_columns(done, taken=set(cols))
    cols.update(stat_cols)
    return cols, stat_cols


def run_metrics(
    sc: Scenario,
    rp: RunPlan,
    trace: TraceRecorder,
    done: int,
    stat_cols: dict[str, np.ndarray],
    plant: Plant,
    error: str | None,
) -> Metrics:
    """Metrics stage: settling, errors, limits, solver health and timing of the first ``done`` steps."""
    sl = slice(0, done)
    metrics = compute_metrics(
        scenario=sc.name,
        controller=sc.controller.type,
        seed=sc.seed,
        t=rp.t[sl],
        x_true=trace.X[sl],
        y_enc=trace.Y[sl],
        u=trace.U[sl],
        plan=rp.plan,
        tolerance=sc.tolerance,
        checks=sc.checks,
        stats=stat_cols,
        step_time_us=trace.step_time_us[sl],
        stop_events=list(plant.events),
        error=error,
        Ts=k.Ts,
    )
    if error is None and done < rp.n:  # pragma: no cover - loop always completes without an error
        metrics.error = "run ended early"
    return metrics


def finish_run(
    sc: Scenario,
    rp: RunPlan,
    trace: TraceRecorder,
    done: int,
    plant: Plant,
    error: str | None,
    t_wall: float,
    out_dir: str | os.PathLike | None = None,
    figures: bool = True,
) -> RunResult:
    """Result stage: the log's columns and the metrics as a :class:`RunResult`, saved to ``out_dir`` if given.

    ``t_wall`` is the :func:`time.perf_counter` reading when the run started (the result's ``wall_s``).
    """
    cols, stat_cols = run_columns(rp, trace, done)
    metrics = run_metrics(sc, rp, trace, done, stat_cols, plant, error)
    metrics.model_untrusted = sc.model_untrusted()  # flagged in the result's own files, not only warned once
    res = RunResult(sc, cols, trace.step_time_us[:done], rp.plan, metrics, wall_s=time.perf_counter() - t_wall)
    if out_dir is not None:
        res.save(out_dir, figures=figures)
    return res


def run_scenario(
    scenario: Scenario | dict | str | os.PathLike,
    out_dir: str | os.PathLike | None = None,
    seed: int | None = None,
    progress: bool = True,
    controller: Controller | None = None,
    cache: MutableMapping[str, Any] | None = None,
    figures: bool = True,
) -> RunResult:
    """Run one scenario in closed loop against the plant simulator (plan, build, loop, metrics, save).

    Parameters
    ----------
    scenario : Scenario, dict or path
        The scenario (a mapping or a YAML path is validated first).
    out_dir : path, optional
        Write the run's files there (:meth:`RunResult.save`).
    seed : int, optional
        Replace the scenario's seed.
    progress : bool
        Show a progress bar.
    controller : Controller, optional
        Use this controller (reset before the run) instead of building one.
    cache : mutable mapping, optional
        Reuse controllers across runs: keyed by :meth:`Scenario.key` (controller
        type, backend, settings, believed parameters). Default: this process's
        cache (a campaign worker builds each setting once). Every controller is
        reset before a run, so reuse never changes the result.
    figures : bool
        Also write the figures when saving.

    Returns
    -------
    RunResult
    """
    t_wall = time.perf_counter()
    sc = _as_scenario(scenario).with_seed(seed)
    rp = plan_run(sc)
    ctrl, plant = build_run(sc, controller, cache)
    trace, done, error = loop_run(sc, ctrl, plant, rp, progress)
    return finish_run(sc, rp, trace, done, plant, error, t_wall, out_dir, figures)


def summary_table(results: list[tuple[str, RunResult | None, str | None]]) -> str:
    """One row per scenario: targets settled, worst settle time and RMS errors, stops, solver health, timing.

    Parameters
    ----------
    results : list of (name, RunResult or None, error or None)
        ``None`` result with an error message: the scenario failed to run.
    """
    head = (
        f"{'scenario':<28} {'ctrl':>5} {'settled':>8} {'max t_s [s]':>11} {'rms g [µm]':>10} "
        f"{'rms d [µm]':>10} {'stops':>5} {'fail/fb':>7} {'max|i| [A]':>10} {'med/p99 [µs]':>13} {'result':>6}"
    )
    lines = [head, "-" * len(head)]
    for name, res, err in results:
        if res is None:
            lines.append(
                f"{name:<28} {'':>5} {'':>8} {'':>11} {'':>10} {'':>10} {'':>5} {'':>7} {'':>10} "
                f"{'':>13} {'ERROR':>6}  {err}"
            )
            continue
        m = res.metrics
        n_ok = sum(t.settled for t in m.targets)
        ts = "-" if m.max_settle_time_s is None else f"{m.max_settle_time_s:.3f}"
        rg = "-" if m.max_rms_error_g_m is None else f"{m.max_rms_error_g_m * 1e6:.2f}"
        rd = "-" if m.max_rms_error_d_m is None else f"{m.max_rms_error_d_m * 1e6:.2f}"
        st = m.step_time_us
        tm = "-" if st["median"] is None else f"{st['median']:.0f}/{st['p99']:.0f}"
        lines.append(
            f"{name:<28} {m.controller:>5} {f'{n_ok}/{len(m.targets)}':>8} {ts:>11} {rg:>10} {rd:>10} "
            f"{m.stop_hits:>5} {f'{m.solver_failures}/{m.fallbacks}':>7} {m.max_current_A:10.2f} {tm:>13} "
            f"{'PASS' if m.passed else 'FAIL':>6}{'  UNTRUSTED MODEL' if m.model_untrusted else ''}"
        )
    untrusted = [(name, res.metrics.model_untrusted) for name, res, _ in results if res and res.metrics.model_untrusted]
    lines += [f"UNTRUSTED MODEL ({name}): {why}" for name, why in untrusted]
    return "\n".join(lines)


__all__ = [
    "CONTROLLER_BACKENDS",
    "TIMING_SUFFIX",
    "RunPlan",
    "RunResult",
    "build_controller",
    "build_run",
    "cached_controller",
    "finish_run",
    "loop_run",
    "plan_run",
    "register_backend",
    "run_columns",
    "run_metrics",
    "run_scenario",
    "summary_table",
]
