"""Execution of a campaign's runs on Dask (or in-process), with resume.

Layout of a campaign folder ``OUT``::

    OUT/campaign.yaml          the campaign as resolved (base scenario embedded)
    OUT/plan.csv               every run of the expansion (id, case, draw, seed, digest)
    OUT/runs/<run_id>/         one folder per finished run, renamed into place when complete:
        run.json               spec, status (ok | failed), error, wall time, worker
        metrics.json           the runner's metrics (ok runs)
        log.csv, *.png         the runner's files, if the campaign keeps them
        done                   marker, written last
    OUT/summary.csv, OUT/summary.parquet, OUT/*.png    see :mod:`.summary`

Execution model
---------------
* The client expands the campaign, skips every run whose folder is finished
  (resume), and submits the rest. With ``workers=1`` and no scheduler, runs
  execute in this process; otherwise on a ``dask.distributed`` cluster: a
  ``LocalCluster`` of ``workers`` single-threaded processes, or the remote
  scheduler at ``scheduler`` (its workers need ``maglev_ocp`` installed).
* A worker runs one scenario in a private temporary folder and sends the
  files back as bytes; the client alone writes ``OUT`` (temporary folder, then
  rename), so workers need no shared filesystem and a stop at any instant
  leaves only finished run folders.
* Each worker process builds the shared model and imports the runner once (a
  worker plugin warms it up, while the client still expands the campaign:
  :func:`start_cluster`) and keeps what the runner builds per controller
  setting in a per-process cache (:func:`worker_cache`), reused by every run
  it executes.
* Runs go out in chunks that shrink (:func:`chunk_sizes`), one chunk per
  worker at a time, the next handed out, in order, as one finishes.
* A run that raises (or whose worker dies) is recorded as ``failed`` with its
  error, and the campaign goes on; ``retry_failed`` re-runs those on resume.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import json
import os
import shutil
import socket
import tempfile
import threading
import time
import traceback
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..config import load_yaml
from ..errors import UserError
from ..output import atomic_write_text
from ..parallel import BackgroundCluster
from .config import Campaign, SaveSettings
from .expand import RunSpec, apply_overrides, expand

#: A run function: ``(scenario mapping, seed, work folder, save settings) -> metrics``.
#: It may write files into the work folder; they end up in the run's folder.
RunFn = Callable[[dict[str, Any], int, Path, SaveSettings], dict[str, Any]]

RUNS_DIR = "runs"
DONE = "done"

_CACHE: dict[Any, Any] = {}


def worker_cache(key: Any, factory: Callable[[], Any]) -> Any:
    """Per-process cache: build ``factory()`` once per ``key`` in this process, then reuse it.

    On a Dask worker this keeps solvers and controllers across the runs the
    worker executes; ``key`` must capture everything the built object depends
    on (e.g. the controller settings as a JSON string).
    """
    if key not in _CACHE:
        _CACHE[key] = factory()
    return _CACHE[key]


def run_real(
    scenario: dict[str, Any], seed: int, workdir: Path, save: SaveSettings, loop: str = "python"
) -> dict[str, Any]:
    """The shipped run function: validate the scenario and run it with the scenario runner.

    Parameters
    ----------
    scenario : dict
        Base scenario with the run's overrides applied.
    seed : int
        Noise seed of the run.
    workdir : Path
        Folder the runner's files go to.
    save : SaveSettings
        Which of the runner's files to keep.
    loop : {"python", "compiled", "auto"}
        Closed loop of the run (:class:`~maglev_ocp.campaign.config.ExecutionSettings`).

    Returns
    -------
    dict
        The runner's metrics (``metrics.json``).
    """
    from .runner_adapter import run_scenario_dict

    return run_scenario_dict(scenario, seed, workdir, save, loop=loop)


@dataclass
class RunOutcome:
    """What a worker sends back for one run."""

    run_id: str
    status: str
    metrics: dict[str, Any] | None = None
    error: str | None = None
    traceback: str | None = None
    wall_s: float = 0.0
    cpu_s: float = 0.0
    worker: str = ""
    files: dict[str, bytes] = field(default_factory=dict)


def execute_one(
    spec_d: dict[str, Any],
    base: dict[str, Any],
    campaign_name: str,
    save_d: dict[str, Any],
    run_fn: RunFn | None = None,
) -> RunOutcome:
    """Execute one run (on a worker or in-process); never raises for a failing run.

    Parameters
    ----------
    spec_d : dict
        :meth:`RunSpec.to_dict` of the run.
    base : dict
        Base scenario mapping.
    campaign_name : str
        Campaign name (the scenario is renamed ``<campaign>-<run_id>``).
    save_d : dict
        :class:`SaveSettings` as a dict.
    run_fn : callable, optional
        Run function (default :func:`run_real`, the scenario runner).
    """
    spec = RunSpec.from_dict(spec_d)
    save = SaveSettings(**save_d)
    fn = run_fn or run_real
    who = f"{socket.gethostname()}:{os.getpid()}"
    t0, c0 = time.perf_counter(), time.process_time()
    tmp = Path(tempfile.mkdtemp(prefix=f"maglev-run-{spec.run_id}-"))
    try:
        scenario = apply_overrides(base, spec.overrides)
        scenario["name"] = f"{campaign_name}-{spec.run_id}"
        scenario["seed"] = spec.seed
        metrics = fn(scenario, spec.seed, tmp, save)
        if not isinstance(metrics, dict):
            raise TypeError(f"run function returned {type(metrics).__name__}, not a metrics dict")
        files = {}
        for p in sorted(tmp.rglob("*")):
            if p.is_file():
                files[str(p.relative_to(tmp))] = p.read_bytes()
        # The runner ends a run early when the controller raises or returns non-finite currents, and says so.
        err = metrics.get("error") or ("diverged" if metrics.get("diverged") else None)
        status = "failed" if err else "ok"
        return RunOutcome(
            spec.run_id,
            status,
            metrics=metrics,
            error=err,
            wall_s=time.perf_counter() - t0,
            cpu_s=time.process_time() - c0,
            worker=who,
            files=files,
        )
    except Exception as exc:
        return RunOutcome(
            spec.run_id,
            "failed",
            error=_one_line(exc),
            traceback=traceback.format_exc(limit=8),
            wall_s=time.perf_counter() - t0,
            cpu_s=time.process_time() - c0,
            worker=who,
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def execute_chunk(
    spec_ds: list[dict[str, Any]],
    base: dict[str, Any],
    campaign_name: str,
    save_d: dict[str, Any],
    run_fn: RunFn | None = None,
) -> list[RunOutcome]:
    """Execute several runs in order on one worker: :func:`execute_one` for each.

    A campaign's runs take tens of milliseconds on the compiled loop, about as
    long as the scheduler needs to hand out a task and collect its result, so
    the parallel path submits runs in chunks (:func:`chunk_sizes`).
    """
    return [execute_one(d, base, campaign_name, save_d, run_fn) for d in spec_ds]


def chunk_sizes(n_runs: int, workers: int, share: int = 4, smallest: int = 4) -> list[int]:
    """Split ``n_runs`` into shrinking chunks (guided self-scheduling): each ``1/(share * workers)`` of what is left.

    Large chunks first keep the scheduler's per-task cost to a few dozen tasks
    (a run on the compiled loop takes tens of milliseconds, about as long as
    handing out a task and collecting its result); chunks that shrink to
    ``smallest`` runs at the end keep the load balanced where it matters, at
    the finish: no worker idles while another still has a long chunk to go
    (equal chunks of 31 runs left one of two workers idle for half a chunk,
    about 0.8 s of the 1,000 NMPC runs, on average). A worker slowed by other
    jobs simply takes fewer chunks.
    """
    if n_runs <= 0:
        return []
    out, left = [], n_runs
    while left:
        size = min(left, max(smallest, -(-left // (share * max(workers, 1)))))
        out.append(size)
        left -= size
    return out


def _load() -> float:
    """1-minute load average of this machine (NaN where unknown): how busy the cores were."""
    try:
        return float(os.getloadavg()[0])
    except (OSError, AttributeError):
        return float("nan")


def _one_line(exc: BaseException) -> str:
    msg = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {msg}"[:500]


def run_dir(out_dir: Path, run_id: str) -> Path:
    """Folder of run ``run_id`` in campaign folder ``out_dir``."""
    return Path(out_dir) / RUNS_DIR / run_id


def read_run_record(out_dir: Path, run_id: str) -> dict[str, Any] | None:
    """``run.json`` of a finished run (``None`` while not finished)."""
    d = run_dir(out_dir, run_id)
    if not (d / DONE).is_file():
        return None
    try:
        return json.loads((d / "run.json").read_text())
    except (OSError, ValueError) as exc:
        raise UserError(f"{d / 'run.json'}: unreadable run record ({exc}); delete the folder to re-run it") from None


def store_outcome(out_dir: Path, spec: RunSpec, outcome: RunOutcome) -> None:
    """Write a run's folder atomically: temporary folder, files, ``run.json``, ``done``, rename."""
    runs = Path(out_dir) / RUNS_DIR
    runs.mkdir(parents=True, exist_ok=True)
    tmp = runs / f".tmp-{spec.run_id}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        for rel, data in outcome.files.items():
            p = tmp / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
        if outcome.metrics is not None and "metrics.json" not in outcome.files:
            (tmp / "metrics.json").write_text(json.dumps(outcome.metrics, indent=1, default=_json_default))
        record = {
            "run_id": spec.run_id,
            "digest": spec.digest(),
            "status": outcome.status,
            "error": outcome.error,
            "traceback": outcome.traceback,
            "wall_s": outcome.wall_s,
            "cpu_s": outcome.cpu_s,
            "worker": outcome.worker,
            "spec": spec.to_dict(),
        }
        (tmp / "run.json").write_text(json.dumps(record, indent=1, default=_json_default))
        (tmp / DONE).write_text("")
        final = run_dir(out_dir, spec.run_id)
        if final.exists():  # a failed run being retried: move the old one aside first
            old = runs / f".old-{spec.run_id}-{uuid.uuid4().hex[:8]}"
            os.replace(final, old)
            shutil.rmtree(old, ignore_errors=True)
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _json_default(o: Any) -> Any:
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


@dataclass
class ExecutionReport:
    """What one invocation of :func:`execute` did.

    Attributes
    ----------
    out_dir : Path
        Campaign folder.
    total : int
        Runs in the campaign.
    skipped : int
        Runs already finished before this invocation (resume).
    ran, failed : int
        Runs executed now, and how many of them failed.
    remaining : int
        Runs still without a finished folder (``--limit`` or an interruption).
    wall_s : float
        Wall time of the execution, from the start of :func:`execute` (the cluster's start-up included; of a
        cluster the caller started in the background, the part not done by then).
    workers : int
        Worker processes used (1 = in-process).
    scheduler : str or None
        Address of the remote scheduler, if any.
    """

    out_dir: Path
    total: int
    skipped: int
    ran: int
    failed: int
    remaining: int
    wall_s: float
    workers: int
    scheduler: str | None = None
    interrupted: bool = False
    cpu_s: float = 0.0
    load_avg_1m: float = float("nan")

    @property
    def efficiency(self) -> float:
        """CPU time of the runs / (wall time x workers): near 1 when every worker had a free core."""
        return self.cpu_s / (self.wall_s * self.workers) if self.wall_s > 0 else float("nan")

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (JSON)."""
        d = dict(self.__dict__)
        d["out_dir"] = str(self.out_dir)
        d["efficiency"] = self.efficiency
        return d

    def save(self, path: str | os.PathLike | None = None) -> None:
        """Append this invocation to ``OUT/executions.jsonl`` (or write ``path``)."""
        line = json.dumps(self.as_dict())
        if path is not None:
            atomic_write_text(path, line + "\n")
            return
        p = Path(self.out_dir) / "executions.jsonl"
        prev = p.read_text() if p.exists() else ""
        atomic_write_text(p, prev + line + "\n")

    def __str__(self) -> str:
        where = self.scheduler or (f"LocalCluster x{self.workers}" if self.workers > 1 else "in-process")
        return (
            f"{self.total} runs: {self.skipped} already done, {self.ran} ran now ({self.failed} failed), "
            f"{self.remaining} remaining; {self.wall_s:.1f} s on {where} "
            f"(runs' CPU {self.cpu_s:.1f} s, efficiency {self.efficiency:.2f}, "
            f"load average {self.load_avg_1m:.1f} on {os.cpu_count()} CPUs)"
        )


def _write_plan(out_dir: Path, camp: Campaign, base: dict[str, Any], specs: list[RunSpec]) -> None:
    """Write ``campaign.yaml`` and ``plan.csv`` (refuse an OUT made by a different campaign)."""
    resolved = camp.model_dump(mode="json")
    resolved["base_scenario_resolved"] = base
    text = yaml.safe_dump(resolved, sort_keys=False)
    _check_plan(out_dir, camp)
    atomic_write_text(out_dir / "campaign.yaml", text)
    lines = ["index,run_id,controller,case,draw,seed,digest"]
    lines += [f"{s.index},{s.run_id},{s.controller},{s.case},{s.draw},{s.seed},{s.digest()}" for s in specs]
    atomic_write_text(out_dir / "plan.csv", "\n".join(lines) + "\n")


def _check_plan(out_dir: Path, camp: Campaign) -> None:
    """Refuse an OUT made by a different campaign (before anything is written)."""
    p = out_dir / "campaign.yaml"
    if p.exists():
        old = load_yaml(p) or {}
        if not isinstance(old, dict):
            raise UserError(f"{p}: not a campaign record; use another --out")
        if old.get("name") not in (None, camp.name):
            raise UserError(f"{out_dir}: holds campaign {old.get('name')!r}, not {camp.name!r}; use another --out")


def pending_runs(out_dir: Path, specs: list[RunSpec], retry_failed: bool = False) -> tuple[list[RunSpec], int, int]:
    """Runs still to execute, and the counts of finished ok / failed runs (resume).

    A finished folder whose digest differs from the spec (the campaign file was
    changed under the same ``--out``) is an error, not silently mixed in.
    """
    todo: list[RunSpec] = []
    n_ok = n_failed = 0
    for s in specs:
        rec = read_run_record(out_dir, s.run_id)
        if rec is None:
            todo.append(s)
            continue
        if rec.get("digest") != s.digest():
            raise UserError(
                f"{run_dir(out_dir, s.run_id)}: made by a different version of the campaign "
                "(overrides or seed differ); use another --out"
            )
        if rec.get("status") == "failed":
            if retry_failed:
                todo.append(s)
            else:
                n_failed += 1
        else:
            n_ok += 1
    return todo, n_ok, n_failed


def _clean_tmp(out_dir: Path) -> None:
    """Remove temporary folders left by an interrupted invocation."""
    runs = out_dir / RUNS_DIR
    if runs.is_dir():
        for p in runs.iterdir():
            if p.name.startswith((".tmp-", ".old-")):
                shutil.rmtree(p, ignore_errors=True)


class _WarmUp:
    """Dask worker plugin: what every run needs, built once when a worker starts (before the first run).

    Parameters
    ----------
    runner : bool
        Also import the scenario runner's modules (the compiled loop, the controllers, SciPy: about half a
        second per process) and hash the code that names the compiled libraries; only for the shipped run
        function (a campaign's own ``run_fn`` may need none of it).
    """

    name = "maglev-warmup"

    def __init__(self, runner: bool = True) -> None:
        self.runner = runner

    def setup(self, worker: Any) -> None:
        """Build the model's Functions in the worker process (and load the runner, see ``runner``)."""
        from ..model import get_model

        get_model()
        if self.runner:
            from ..codegen.loop_c import code_version
            from . import runner_adapter  # noqa: F401

            code_version()

    def teardown(self, worker: Any) -> None:
        """Nothing to release."""


def _warmup_plugin(runner: bool) -> Any:
    """A :class:`_WarmUp` that is a Dask ``WorkerPlugin`` (dask imported only here)."""
    from dask.distributed import WorkerPlugin

    return type("MaglevWarmUp", (_WarmUp, WorkerPlugin), {})(runner)


def start_cluster(workers: int, scheduler: str | None = None, runner: bool = True) -> BackgroundCluster | None:
    """Start the campaign's LocalCluster in the background (``None`` for in-process runs or a remote scheduler).

    The worker processes start and warm up (:class:`_WarmUp`) while the caller expands the campaign and
    checks its folder; pass the result to :func:`execute` as ``cluster`` and close it when done.
    ``runner``: the runs go through the shipped run function (:func:`run_real`).
    """
    if scheduler or workers <= 1:
        return None
    return BackgroundCluster(workers, functools.partial(_warmup_plugin, runner))


def _preload_summary() -> None:
    """Import the summary's plotting and table libraries (Agg backend); a missing optional one is skipped."""
    import importlib

    with contextlib.suppress(ImportError):
        import matplotlib

        matplotlib.use("Agg")
        for name in ("matplotlib.pyplot", "pandas", "pyarrow"):
            with contextlib.suppress(ImportError):
                importlib.import_module(name)


@contextlib.contextmanager
def _client(workers: int, scheduler: str | None, cluster: BackgroundCluster | None, runner: bool) -> Iterator[Any]:
    """A ``dask.distributed`` client: on ``cluster`` (left open), a remote scheduler, or a new LocalCluster."""
    if cluster is not None:
        yield cluster.client()
        return
    if scheduler:
        try:
            from dask.distributed import Client
        except ImportError:
            raise UserError("dask.distributed is not installed: pip install 'maglev-ocp[campaign]'") from None
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise UserError(f"--scheduler {scheduler}: cannot connect ({_one_line(exc)})") from None
        try:
            client.register_plugin(_warmup_plugin(runner))
            yield client
        finally:
            client.close()
        return
    started = start_cluster(workers, runner=runner)
    assert started is not None
    try:
        yield started.client()
    finally:
        started.close()


def _run_on_dask(
    todo: list[RunSpec],
    base: dict[str, Any],
    campaign_name: str,
    save_d: dict[str, Any],
    run_fn: RunFn,
    workers: int,
    scheduler: str | None,
    record: Callable[[RunSpec, RunOutcome], None],
    cluster: BackgroundCluster | None = None,
    runner: bool = True,
) -> int:
    """Run ``todo`` in chunks on a Dask cluster; ``record`` each outcome as its chunk completes.

    Returns the number of workers the runs had (the remote scheduler's count where one is given).
    """
    from dask.distributed import as_completed

    with _client(workers, scheduler, cluster, runner) as client:
        if scheduler:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
        base_f = client.scatter(base, broadcast=True)
        by_key: dict[str, list[RunSpec]] = {}
        futures: list[Any] = []
        sizes = chunk_sizes(len(todo), workers)
        bounds = [sum(sizes[:i]) for i in range(len(sizes) + 1)]
        chunks = iter([todo[a:b] for a, b in itertools.pairwise(bounds)])
        running = as_completed()

        def submit_next() -> None:
            """Hand out the next chunk (largest first), if any is left."""
            chunk = next(chunks, None)
            if chunk is None:
                return
            fut = client.submit(
                execute_chunk,
                [s.to_dict() for s in chunk],
                base_f,
                campaign_name,
                save_d,
                run_fn,
                key=f"maglev-runs-{campaign_name}-{chunk[0].run_id}-{chunk[-1].run_id}-{chunk[0].digest()}",
                pure=False,
            )
            by_key[fut.key] = chunk
            futures.append(fut)
            running.add(fut)

        # One chunk per worker at a time, the next handed out as one finishes (guided self-scheduling in the
        # order of chunk_sizes). Submitted all at once, Dask's scheduler gave the chunks submitted within its
        # 100 ms FIFO window one priority, assigned the first few to workers before it started queuing, and
        # ran the rest last-submitted first: the smallest chunks first and the largest at the end.
        for _ in range(workers):
            submit_next()
        # the client waits on the workers from here on: it loads what the summary needs meanwhile (the
        # figures' matplotlib and the parquet writer, ~0.5-1 s that would otherwise follow the runs)
        threading.Thread(target=_preload_summary, name="maglev-preload-summary", daemon=True).start()
        try:
            for fut in running:
                submit_next()  # before writing this chunk's folders: the worker does not wait on the client
                chunk = by_key[fut.key]
                try:
                    outcomes = fut.result()
                except Exception as exc:  # worker lost, unpicklable result, ...
                    err, tb = f"worker: {_one_line(exc)}", traceback.format_exc(limit=4)
                    outcomes = [RunOutcome(s.run_id, "failed", error=err, traceback=tb) for s in chunk]
                for s, outcome in zip(chunk, outcomes, strict=True):
                    record(s, outcome)
        finally:
            client.cancel(futures)
    return workers


def execute(
    camp: Campaign,
    out_dir: str | os.PathLike,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    limit: int | None = None,
    retry_failed: bool = False,
    run_fn: RunFn | None = None,
    progress: bool = True,
    base: dict[str, Any] | None = None,
    specs: list[RunSpec] | None = None,
    cluster: BackgroundCluster | None = None,
) -> ExecutionReport:
    """Run every unfinished run of the campaign; finished ones are skipped.

    Parameters
    ----------
    camp : Campaign
        The campaign.
    out_dir : path
        Campaign folder (created; reused to resume).
    workers : int
        Worker processes of the local cluster; 1 runs in this process.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); overrides ``workers``.
    limit : int, optional
        Execute at most this many runs now (the rest stay for a later resume).
    retry_failed : bool
        Re-run runs recorded as failed.
    run_fn : callable, optional
        Run function (default: the scenario runner); must be picklable for Dask.
    progress : bool
        Show a tqdm bar with done / failed / remaining counts.
    base : dict, optional
        Base scenario mapping (default: read the campaign's ``base_scenario``).
    specs : list of RunSpec, optional
        The campaign's expansion with ``base`` (default: expanded here), for a caller that needs it
        too (:func:`maglev_ocp.campaign.run_campaign` summarizes on it: one expansion, not two).
    cluster : BackgroundCluster, optional
        A LocalCluster already starting (:func:`start_cluster`), used instead of starting one here (and left
        open: the caller closes it); ignored for in-process runs and with ``scheduler``.

    Returns
    -------
    ExecutionReport
        Counts and wall time of this invocation (also appended to ``OUT/executions.jsonl``).
    """
    from tqdm.auto import tqdm

    if workers < 1:
        raise UserError(f"--workers: must be >= 1, got {workers}")
    if limit is not None and limit < 0:
        raise UserError(f"--limit: must be >= 0, got {limit}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    base = camp.base_scenario_dict() if base is None else base
    specs = expand(camp, base) if specs is None else specs
    _check_plan(out, camp)
    _clean_tmp(out)
    todo, n_ok, n_failed = pending_runs(out, specs, retry_failed)  # refuses a changed campaign: nothing written yet
    _write_plan(out, camp, base, specs)
    skipped = n_ok + n_failed
    if limit is not None:
        todo = todo[:limit]
    save_d = camp.save.model_dump()
    runner = run_fn is None
    if run_fn is None:  # the scenario runner, on the campaign's closed loop (a module-level partial: picklable)
        run_fn = functools.partial(run_real, loop=camp.execution.loop)
    counts = {"ok": n_ok, "failed": n_failed, "ran": 0, "failed_now": 0, "cpu_s": 0.0}
    t0 = time.perf_counter()
    bar = tqdm(
        total=len(specs),
        initial=skipped,
        desc=f"campaign {camp.name}",
        unit="run",
        disable=not progress,
        dynamic_ncols=True,
    )

    def _record(spec: RunSpec, outcome: RunOutcome) -> None:
        store_outcome(out, spec, outcome)
        counts["ran"] += 1
        counts["cpu_s"] += outcome.cpu_s
        key = "failed" if outcome.status == "failed" else "ok"
        counts[key] += 1
        counts["failed_now"] += key == "failed"
        finished = counts["ok"] + counts["failed"]
        bar.set_postfix(done=finished, failed=counts["failed"], remaining=len(specs) - finished, refresh=False)
        bar.update(1)

    bar.set_postfix(done=skipped, failed=n_failed, remaining=len(specs) - skipped)
    interrupted = False
    use_dask = bool(scheduler) or workers > 1
    try:
        if not todo:
            pass
        elif not use_dask:
            for s in todo:
                _record(s, execute_one(s.to_dict(), base, camp.name, save_d, run_fn))
        else:
            on = None if scheduler else cluster
            workers = _run_on_dask(todo, base, camp.name, save_d, run_fn, workers, scheduler, _record, on, runner)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    remaining = len(specs) - counts["ok"] - counts["failed"]
    report = ExecutionReport(
        out,
        len(specs),
        skipped,
        counts["ran"],
        counts["failed_now"],
        remaining,
        time.perf_counter() - t0,
        1 if not use_dask else workers,
        scheduler,
        interrupted,
        counts["cpu_s"],
        _load(),
    )
    report.save()
    if interrupted:
        raise KeyboardInterrupt
    return report
