"""The scenario runner: one closed-loop run of a scenario against the plant simulator.

:func:`run_scenario` is a pure function of (scenario, seed): same inputs, the
same ``log.csv`` bit for bit, whatever process runs it (a Dask worker of a
campaign included). It builds, or reuses from a cache, the controller, plans
the reference (:mod:`maglev_ocp.reference`), and steps the loop::

    y = plant.reset(x0)
    ctrl.reset(y, ref(0))
    for k in range(n):
        out = ctrl.step(y, ref(t_k))      # timed: the controller's computation
        y = plant.step(out.u)

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
``metrics.json``, ``scenario.yaml`` (as resolved), ``dataset.yaml`` (so the
run folder is a ``maglev-rig-log/1`` dataset), ``positions.png``,
``currents.png``, ``solver_time.png``.
"""

from __future__ import annotations

import json
import math
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
from .config import atomic_write_text, dump_yaml
from .errors import UserError
from .metrics import Metrics, compute_metrics
from .reference import ReferencePlan, plan_targets
from .riglog import RunLog
from .scenario import Scenario, controller_classes, load_scenario, scenario_from_dict

#: Statistics keys holding wall-clock times: they go to ``timing.csv``, not ``log.csv``.
TIMING_SUFFIX = "_us"

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
        Controller computation time per step [us].
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


def _stat_value(v: Any) -> Any:
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    if isinstance(v, (int, float, np.integer, np.floating)):
        return float(v)
    return str(v)


def run_scenario(
    scenario: Scenario | dict | str | os.PathLike,
    out_dir: str | os.PathLike | None = None,
    seed: int | None = None,
    progress: bool = True,
    controller: Controller | None = None,
    cache: MutableMapping[str, Any] | None = None,
    figures: bool = True,
) -> RunResult:
    """Run one scenario in closed loop against the plant simulator.

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
    from tqdm.auto import tqdm

    from .plant import Plant

    t_wall = time.perf_counter()
    sc = _as_scenario(scenario).with_seed(seed)
    Ts = k.Ts
    ctrl_params = sc.controller_model_params()
    plan = plan_targets(
        (sc.start.g, sc.start.d), sc.target_list(), ctrl_params, sc.reference, source=f"{sc.source}: targets"
    )
    ctrl = controller if controller is not None else cached_controller(sc, cache)
    ss_plant, _ = sc.seed_sequences()
    plant = Plant(sc.plant_config(), params=sc.plant_params(), seed=ss_plant, Ts=Ts)

    n = round(plan.duration / Ts)
    tgrid = np.arange(n) * Ts
    refs = plan.sample(tgrid, zoh=Ts)  # accelerations: mean over each period (ZOH-consistent feedforward)
    tgt_idx = np.clip(np.searchsorted(plan.switch_times, tgrid + 1e-9, side="right") - 1, 0, len(plan.targets) - 1)
    tg_arr = np.array([[plan.targets[i].g, plan.targets[i].d] for i in tgt_idx]).reshape(n, 2)

    y = plant.reset(np.array([sc.start.g, 0.0, sc.start.d, 0.0]))
    if hasattr(ctrl, "set_reference_plan"):
        ctrl.set_reference_plan(plan)
    r0 = refs[0] if n else np.array([sc.start.g, 0, 0, sc.start.d, 0, 0])
    ctrl.reset(y, Reference(g=r0[0], d=r0[3], g_dot=r0[1], d_dot=r0[4], g_ddot=r0[2], d_ddot=r0[5]))

    Y = np.full((n, 2), np.nan)
    X = np.full((n, 4), np.nan)
    U = np.full((n, 2), np.nan)
    XH = np.full((n, 4), np.nan)
    UA = np.full((n, 2), np.nan)
    LIM = np.zeros(n)
    STT = np.full(n, np.nan)
    stats: dict[str, list[Any]] = {}
    timings: dict[str, list[float]] = {}
    error = None
    done = 0
    bar = tqdm(total=n, desc=sc.name, unit="step", disable=not progress, mininterval=0.5, leave=False)
    perf = time.perf_counter
    u_applied = (y.info.get("i_q_applied", math.nan), y.info.get("i_d_applied", math.nan))
    for i in range(n):
        r = refs[i]
        ref = Reference(g=r[0], d=r[3], g_dot=r[1], d_dot=r[4], g_ddot=r[2], d_ddot=r[5])
        try:
            t0 = perf()
            out = ctrl.step(y, ref)
            dt_us = (perf() - t0) * 1e6
            u = np.asarray(out.u, dtype=float).reshape(2)
        except Exception as err:  # a controller bug or a solver crash: end the run, keep what we have
            error = f"controller raised at t = {i * Ts:.3f} s: {type(err).__name__}: {err}"
            break
        if not np.all(np.isfinite(u)):
            error = f"controller returned non-finite currents {u.tolist()} at t = {i * Ts:.3f} s"
            break
        Y[i] = y.y
        X[i] = y.x_true if y.x_true is not None else np.nan
        U[i] = u
        UA[i] = u_applied
        if out.x_hat is not None:
            XH[i] = np.asarray(out.x_hat, dtype=float).reshape(4)
        STT[i] = dt_us
        for key, v in out.stats.items():
            if key.endswith(TIMING_SUFFIX):
                timings.setdefault(key, [math.nan] * i).append(float(v))
            else:
                stats.setdefault(key, [math.nan] * i).append(_stat_value(v))
        for lst in (*stats.values(), *timings.values()):  # keys missing this step
            if len(lst) < i + 1:
                lst.append(math.nan)
        y = plant.step(u)
        u_applied = (y.info.get("i_q_applied", math.nan), y.info.get("i_d_applied", math.nan))
        LIM[i] = float(bool(y.info.get("limited", False)))
        done = i + 1
        if progress and (i & 63) == 0:
            bar.update(i + 1 - bar.n)
    bar.update(done - bar.n)
    bar.close()

    sl = slice(0, done)
    cols: dict[str, np.ndarray] = {
        "t": tgrid[sl],
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
        "g_target": tg_arr[sl, 0],
        "d_target": tg_arr[sl, 1],
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
        "limited": LIM[sl],
    }
    stat_cols: dict[str, np.ndarray] = {}
    for key, vals in stats.items():
        vals = vals[:done]
        if any(isinstance(v, str) for v in vals):
            arr = np.array(["" if (isinstance(v, float) and math.isnan(v)) else str(v) for v in vals], dtype=object)
        else:
            arr = np.asarray(vals, dtype=float)
        name = key if key not in cols else f"stat_{key}"
        stat_cols[name] = arr
    cols.update(stat_cols)
    step_time = STT[sl]
    metrics = compute_metrics(
        scenario=sc.name,
        controller=sc.controller.type,
        seed=sc.seed,
        t=cols["t"],
        x_true=X[sl],
        y_enc=Y[sl],
        u=U[sl],
        plan=plan,
        tolerance=sc.tolerance,
        checks=sc.checks,
        stats=stat_cols,
        step_time_us=step_time,
        stop_events=list(plant.events),
        error=error,
        Ts=Ts,
    )
    if error is None and done < n:  # pragma: no cover - loop always completes without an error
        metrics.error = "run ended early"
    res = RunResult(sc, cols, step_time, plan, metrics, wall_s=time.perf_counter() - t_wall)
    if out_dir is not None:
        res.save(out_dir, figures=figures)
    return res


def summary_table(results: list[tuple[str, RunResult | None, str | None]]) -> str:
    """One row per scenario: targets settled, worst settle time and RMS errors, stops, solver health, timing.

    Parameters
    ----------
    results : list of (name, RunResult or None, error or None)
        ``None`` result with an error message: the scenario failed to run.
    """
    head = (
        f"{'scenario':<28} {'ctrl':>5} {'settled':>8} {'max t_s [s]':>11} {'rms g [um]':>10} "
        f"{'rms d [um]':>10} {'stops':>5} {'fail/fb':>7} {'max|i| [A]':>10} {'med/p99 [us]':>13} {'result':>6}"
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
            f"{'PASS' if m.passed else 'FAIL':>6}"
        )
    return "\n".join(lines)


__all__ = [
    "CONTROLLER_BACKENDS",
    "RunResult",
    "build_controller",
    "cached_controller",
    "register_backend",
    "run_scenario",
    "summary_table",
]
