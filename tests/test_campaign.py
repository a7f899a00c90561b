"""Campaigns: deterministic expansion, Dask execution equal to in-process, resume, failures.

The machinery tests use a cheap deterministic run function (a function of the
scenario overrides and the seed) so that they test the campaign, not the
controllers; ``test_smoke_campaign_real_runner`` runs ``campaigns/smoke.yaml``
through the real scenario runner.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.campaign import deterministic_columns, expand, load_campaign, run_campaign
from maglev_ocp.campaign.execute import chunk_sizes, execute, read_run_record, run_dir, worker_cache
from maglev_ocp.campaign.expand import apply_overrides, draw_seed_sequence, n_cases
from maglev_ocp.errors import ConfigError, UserError
from maglev_ocp.params import NOMINAL
from maglev_ocp.scenario import scenario_from_dict

REPO = Path(__file__).resolve().parents[1]

BASE = """\
name: toy
seed: 3
controller: {type: pid}
plant: {profile: default}
targets:
  - {g: 0.020, d: 0.0, hold: 0.2}
"""

CAMPAIGN = """\
name: toy
base_scenario: base.yaml
n_runs: 6
seed: 11
vary:
  plant: {C1: {dist: uniform, pct: 10}, xi0: {dist: normal, pct: 5, clip_sigma: 2}}
  belief: {C2: {dist: uniform, pct: 3}}
  targets: {n: 2, hold: 0.1}
  grid: {controller.gain: [1.0, 2.0]}
  controllers: [{type: pid}, {type: fl}]
"""


def toy_run(scenario: dict, seed: int, workdir: Path, save) -> dict:
    """Cheap deterministic stand-in for the scenario runner: metrics from the overrides and the seed."""
    c1 = scenario["plant"]["mismatch"]["overrides"]["C1"]
    gain = scenario["controller"].get("gain", 1.0)
    if seed % 7 == 0 or scenario.get("fail"):
        raise RuntimeError(f"toy failure for seed {seed}")
    rng = np.random.default_rng(seed)
    targets = []
    for t in scenario["targets"]:
        st = abs(t["d"]) * c1 / gain + 0.01 * rng.random()
        targets.append(
            {
                "settled": bool(st < 0.5),
                "settle_time_s": st if st < 0.5 else None,
                "rms_error_g_m": 1e-6 * rng.random(),
                "rms_error_d_m": 1e-6 * rng.random(),
                "max_current_A": 3.0,
            }
        )
    built = worker_cache(("toy", gain), lambda: os.getpid())  # once per process and setting
    (workdir / "log.csv").write_text("t,g\n0.0,0.02\n")
    return {
        "all_settled": all(t["settled"] for t in targets),
        "stop_hits": 0,
        "solver_failures": 0,
        "step_time_us": {"median": 5.0 + rng.random(), "p99": 20.0},
        "targets": targets,
        "built_by_pid": built,
    }


@pytest.fixture()
def camp_dir(tmp_path: Path) -> Path:
    (tmp_path / "base.yaml").write_text(BASE)
    (tmp_path / "camp.yaml").write_text(CAMPAIGN)
    return tmp_path


def _summary_det(out: Path):
    import pandas as pd

    t = pd.read_csv(out / "summary.csv")
    cols = [c for c in deterministic_columns(list(t.columns)) if c != "m.built_by_pid"]
    return t[cols]


def test_expansion_is_deterministic_and_seeded_by_spawn(camp_dir: Path) -> None:
    camp = load_campaign(camp_dir / "camp.yaml")
    a, b = expand(camp), expand(camp)
    assert [s.to_dict() for s in a] == [s.to_dict() for s in b]
    assert len(a) == camp.n_runs * n_cases(camp) == 6 * 4
    assert len({s.run_id for s in a}) == len(a)
    # A draw's streams are the root SeedSequence's spawned children.
    root = np.random.SeedSequence(camp.seed)
    child = root.spawn(camp.n_runs)[3]
    assert np.array_equal(child.spawn(4)[2].generate_state(4), draw_seed_sequence(camp.seed, 3, 2).generate_state(4))
    # Every case of a draw shares the draw (common random numbers); draws differ.
    for draw in range(camp.n_runs):
        runs = [s for s in a if s.draw == draw]
        assert len({json.dumps(s.deviations, sort_keys=True) for s in runs}) == 1
        assert len({s.seed for s in runs}) == 1
    assert len({s.seed for s in a}) == camp.n_runs
    # Perturbations within their bounds, applied to the nominal value; targets inside the envelope.
    for s in a:
        assert abs(s.deviations["plant.C1"]) <= 10.0
        assert abs(s.deviations["plant.xi0"]) <= 2 * 5.0
        assert s.overrides["plant.mismatch.overrides.C1"] == pytest.approx(
            NOMINAL.C1 * (1 + s.deviations["plant.C1"] / 100)
        )
        assert s.overrides["controller_params.C2"] == pytest.approx(NOMINAL.C2 * (1 + s.deviations["belief.C2"] / 100))
        for t in s.overrides["targets"]:
            assert k.g_envelope[0] <= t["g"] <= k.g_envelope[1]
            assert k.d_envelope[0] <= t["d"] <= k.d_envelope[1]
    devs = np.array([s.deviations["plant.C1"] for s in a if s.case == 0])
    assert devs.std() > 2.0  # really drawn, not constant
    # More draws keep the first ones; varying one more parameter keeps the others' draws.
    camp2 = camp.model_copy(update={"n_runs": 9})
    camp2._root_dir = camp.root_dir
    c = expand(camp2)
    assert [s.to_dict() for s in c[: len(a)]] == [s.to_dict() for s in a]
    camp3 = camp.model_copy(deep=True)
    camp3._root_dir = camp.root_dir
    camp3.vary.plant = {**camp3.vary.plant, "C3": camp3.vary.plant["C1"]}
    d = expand(camp3)
    assert [s.deviations["plant.C1"] for s in d] == [s.deviations["plant.C1"] for s in a]


def test_overrides_apply_to_a_copy() -> None:
    base = {"plant": {"profile": "default"}, "targets": [{"g": 0.02, "d": 0.0, "hold": 0.1}]}
    out = apply_overrides(base, {"plant.params.C1": 15.0, "targets.0.g": 0.018, "controller": {"type": "fl"}})
    assert out["plant"] == {"profile": "default", "params": {"C1": 15.0}}
    assert out["targets"][0]["g"] == 0.018 and base["targets"][0]["g"] == 0.02
    assert out["controller"] == {"type": "fl"} and "controller" not in base


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("vary: {plant: {C9: {dist: uniform, pct: 5}}}", "unknown parameter 'C9'"),
        ("vary: {plant: {C1: {dist: uniform, pct: 150}}}", "vary.plant.C1.uniform.pct"),
        ("vary: {targets: {n: 2, hold: 0.1, g: [0.001, 0.02]}}", "vary.targets.g"),
        ("vary: {grid: {seed: [1, 2]}}", "vary.grid"),
        ("bogus: 1", "bogus: unknown key"),
        ("n_runs: 0", "n_runs"),
    ],
)
def test_bad_campaign_is_one_line_error_naming_the_key(camp_dir: Path, text: str, needle: str) -> None:
    p = camp_dir / "bad.yaml"
    p.write_text(f"name: bad\nbase_scenario: base.yaml\nseed: 1\n{text}\n")
    with pytest.raises(ConfigError) as err:
        load_campaign(p)
    assert str(p) in str(err.value) and needle in str(err.value) and "\n" not in str(err.value)


def test_missing_base_scenario_is_an_error(camp_dir: Path) -> None:
    p = camp_dir / "nobase.yaml"
    p.write_text("name: x\nbase_scenario: nowhere.yaml\nseed: 1\n")
    with pytest.raises(ConfigError, match="base_scenario"):
        load_campaign(p)


def test_scheduler_address_equals_in_process_and_failures_are_recorded(camp_dir: Path) -> None:
    """A running dask.distributed cluster (scheduler + 2 worker processes on loopback), reached by its
    address as with ``--scheduler``, gives the summary of a 1-process run."""
    import cloudpickle
    from dask.distributed import LocalCluster

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/
    camp = load_campaign(camp_dir / "camp.yaml")
    r1 = run_campaign(camp, camp_dir / "one", workers=1, run_fn=toy_run, progress=False, figures=False)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0"
    ) as cluster:
        r2 = run_campaign(
            camp, camp_dir / "two", scheduler=cluster.scheduler_address, run_fn=toy_run, progress=False, figures=True
        )
    assert r1.report.workers == 1 and r2.report.workers == 2 and r2.report.scheduler.startswith("tcp://127.0.0.1")
    a, b = _summary_det(camp_dir / "one"), _summary_det(camp_dir / "two")
    assert list(a.columns) == list(b.columns)
    assert a.equals(b)
    # Runs went through worker processes, not this one; a worker built each setting at most once.
    t = r2.summary.table
    recs = [read_run_record(camp_dir / "two", rid) for rid in t["run_id"]]
    pids = {r["worker"].split(":")[1] for r in recs}
    assert str(os.getpid()) not in pids and 1 <= len(pids) <= 2
    ok = t[t["status"] == "ok"]
    for gain in (1.0, 2.0):
        builders = set(ok[ok["grid.controller.gain"] == gain]["m.built_by_pid"])
        assert len(builders) <= 2  # one build per worker process and setting
    # The toy fails for seeds divisible by 7: those runs are recorded with their error, the rest ran.
    failing = t["seed"] % 7 == 0
    assert (t.loc[failing, "status"] == "failed").all() and (t.loc[~failing, "status"] == "ok").all()
    assert t.loc[failing, "error"].str.contains("RuntimeError: toy failure").all()
    assert not t.loc[failing, "success"].any()
    assert r2.report.ran == len(t) and r2.report.remaining == 0
    for name in (
        "summary.csv",
        "summary.parquet",
        "by_case.csv",
        "success_rate.png",
        "settle_time.png",
        "vs_dev_plant_C1.png",
        "vs_grid_controller_gain.png",
        "tradeoff.png",
    ):
        assert (camp_dir / "two" / name).is_file(), name
    assert r2.summary.by_case()["runs"].sum() == len(t)
    from maglev_ocp.campaign.report import markdown_table

    md = markdown_table({"toy": r2})
    assert md.count("\n| toy | c") == n_cases(camp) and "success [%]" in md
    from maglev_ocp.campaign.report import executions_table

    ex = executions_table(camp_dir, ("one", "two"))
    assert f"| two | {len(t)} | 2 |" in ex and f"| one | {len(t)} | 1 |" in ex


def test_stop_and_resume_matches_uninterrupted(camp_dir: Path) -> None:
    camp = load_campaign(camp_dir / "camp.yaml")
    full = run_campaign(camp, camp_dir / "full", run_fn=toy_run, progress=False, figures=False)
    part = camp_dir / "part"
    rep = execute(camp, part, limit=7, run_fn=toy_run, progress=False)
    assert rep.ran == 7 and rep.remaining == len(full.summary.table) - 7
    # A crash mid-write leaves a temporary folder and maybe a folder without its 'done' marker.
    (part / "runs" / ".tmp-crashed-1234").mkdir()
    half = run_dir(part, expand(camp)[10].run_id)
    half.mkdir()
    (half / "run.json").write_text("{truncated")
    res = run_campaign(camp, part, run_fn=toy_run, progress=False, figures=False)
    assert res.report.skipped == 7 and res.report.ran == len(full.summary.table) - 7
    assert not (part / "runs" / ".tmp-crashed-1234").exists()
    assert _summary_det(part).equals(_summary_det(camp_dir / "full"))
    # Nothing left: a third invocation runs nothing.
    again = execute(camp, part, run_fn=toy_run, progress=False)
    assert again.ran == 0 and again.skipped == len(full.summary.table)


def test_failed_runs_can_be_retried_and_changed_campaign_is_refused(camp_dir: Path) -> None:
    camp = load_campaign(camp_dir / "camp.yaml")
    out = camp_dir / "o"
    rep = execute(camp, out, limit=8, run_fn=toy_run, progress=False)
    n_failed = rep.failed
    again = execute(camp, out, limit=0, retry_failed=True, run_fn=toy_run, progress=False)
    assert again.ran == 0
    again = execute(camp, out, limit=n_failed, retry_failed=True, run_fn=toy_run, progress=False)
    assert again.skipped == 8 and again.ran == n_failed and again.failed == n_failed  # deterministic failures
    changed = camp.model_copy(update={"seed": 12})
    changed._root_dir = camp.root_dir
    with pytest.raises(UserError, match="different version of the campaign"):
        execute(changed, out, run_fn=toy_run, progress=False)


@pytest.mark.parametrize(("n", "workers"), [(1, 2), (5, 2), (31, 2), (32, 2), (1000, 2), (1000, 3), (7, 1)])
def test_chunks_cover_every_run_once_and_balance(n: int, workers: int) -> None:
    sizes = chunk_sizes(n, workers)
    assert sum(sizes) == n
    assert min(sizes) >= 1
    assert sizes == sorted(sizes, reverse=True)  # shrinking: the last chunks are the small ones
    assert sizes[-1] <= 4  # the finish is balanced to a few runs
    assert sizes[0] <= max(4, -(-n // (4 * workers)))  # no worker takes more than its share at once
    assert len(sizes) <= 4 * workers * (1 + math.log(max(n, 1))) + 4  # tens of tasks, not one per run


def test_worker_cache_builds_once_per_key() -> None:
    calls = []
    a = worker_cache(("test", 1), lambda: calls.append(1) or len(calls))
    b = worker_cache(("test", 1), lambda: calls.append(1) or len(calls))
    c = worker_cache(("test", 2), lambda: calls.append(1) or len(calls))
    assert a == b == 1 and c == 2 and len(calls) == 2


def test_shipped_campaigns_validate_and_expand() -> None:
    for name, min_runs in (("robustness_nmpc", 200), ("robustness_fl", 200), ("sweep_nmpc", 2), ("smoke", 2)):
        camp = load_campaign(REPO / "campaigns" / f"{name}.yaml")
        specs = expand(camp)
        assert len(specs) >= min_runs, name
        if name.startswith("robustness"):
            for p in ("C1", "C2", "C3", "C4", "xi0", "ell"):
                devs = [s.deviations[f"plant.{p}"] for s in specs]
                assert max(map(abs, devs)) <= 10.0 + 1e-9 and max(devs) > 8 and min(devs) < -8, (name, p)
        assert all(math.isfinite(s.seed) for s in specs)
        # Every case's runs are valid scenarios (as the runner will see them).
        base = camp.base_scenario_dict()
        for s in {s.case: s for s in specs}.values():
            scenario_from_dict(apply_overrides(base, s.overrides), f"{name}/{s.run_id}")


def test_cli_plan_and_bad_values(tmp_path: Path, capsys) -> None:
    from maglev_ocp.cli import main

    assert main(["campaign", str(REPO / "campaigns" / "smoke.yaml"), "--out", str(tmp_path), "--plan"]) == 0
    assert "runs =" in capsys.readouterr().out
    assert main(["campaign", str(REPO / "campaigns" / "smoke.yaml"), "--out", str(tmp_path), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err


def test_smoke_campaign_real_runner_dask_resume_equals_in_process(tmp_path: Path) -> None:
    """campaigns/smoke.yaml through the real scenario runner: in-process, and on a 2-process LocalCluster
    stopped after 2 runs (``limit``) then resumed; the summaries are equal."""
    camp = load_campaign(REPO / "campaigns" / "smoke.yaml")
    ref = run_campaign(camp, tmp_path / "inproc", workers=1, progress=False, figures=False)
    t = ref.summary.table
    assert (t["status"] == "ok").all(), t["error"].tolist()
    assert t["m.n_steps"].gt(0).all() and t["m.max_current_A"].le(k.i_amp_max + 1e-9).all()
    part = execute(camp, tmp_path / "dask", workers=2, limit=2, progress=False)
    assert part.ran == 2 and part.remaining == len(t) - 2 and part.workers == 2
    res = run_campaign(camp, tmp_path / "dask", workers=2, progress=False, figures=False)
    assert res.report.skipped == 2 and res.report.ran == len(t) - 2
    assert _summary_det(tmp_path / "dask").equals(_summary_det(tmp_path / "inproc"))
    # The drawn true parameters reached the plant: the run's resolved scenario carries them.
    import yaml

    s0 = yaml.safe_load((run_dir(tmp_path / "dask", t["run_id"][0]) / "scenario.yaml").read_text())
    assert s0["plant"]["mismatch"]["overrides"]["C2"] == pytest.approx(t["ov.plant.mismatch.overrides.C2"][0])


def test_explicit_runs_multiply_the_cases_and_case_order(camp_dir: Path) -> None:
    p = camp_dir / "runs.yaml"
    p.write_text(
        CAMPAIGN.replace(
            "n_runs: 6",
            "n_runs: 2\norder: cases\nruns:\n  - {}\n"
            "  - {plant.process_noise.g: 0.0, controller_params.cogging: false}",
        )
    )
    camp = load_campaign(p)
    specs = expand(camp)
    assert n_cases(camp) == 2 * 2 * 2 and len(specs) == 16
    assert [s.case for s in specs[:4]] == [0, 0, 1, 1]  # case-major order
    odd = [s for s in specs if s.case % 2 == 1]
    assert all(s.overrides["controller_params.cogging"] is False for s in odd)
    assert all("controller_params.cogging" not in s.overrides for s in specs if s.case % 2 == 0)
    scn = apply_overrides(camp.base_scenario_dict(), odd[0].overrides)
    assert scn["plant"]["process_noise"] == {"g": 0.0} and scn["controller"]["type"] == "pid"


def stamped_run(scenario: dict, seed: int, workdir: Path, save) -> dict:
    """:func:`toy_run` that also records when (wall clock) and in which process it started."""
    import time

    t0 = time.time()
    time.sleep(0.01)  # long enough that a worker finishing a chunk is not overtaken within a millisecond
    try:
        m = toy_run(scenario, seed, workdir, save)
    except RuntimeError:
        m = {"all_settled": False, "stop_hits": 0, "solver_failures": 0, "targets": []}
    return {**m, "started_at": t0, "pid": os.getpid()}


def test_chunks_start_in_submission_order_on_a_local_cluster(camp_dir: Path) -> None:
    """On 2 worker processes the chunks start in the order of :func:`chunk_sizes`, largest first (guided
    self-scheduling): submitted all at once, Dask ran them last-submitted first, the largest at the end."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/
    camp = load_campaign(camp_dir / "camp.yaml").model_copy(update={"n_runs": 30})
    camp._root_dir = load_campaign(camp_dir / "camp.yaml").root_dir
    res = run_campaign(camp, camp_dir / "o", workers=2, run_fn=stamped_run, progress=False, figures=True)
    assert res.report.ran == len(res.summary.table) == 30 * n_cases(camp) and res.report.remaining == 0
    specs = expand(camp)
    sizes = chunk_sizes(len(specs), 2)
    assert len(sizes) >= 6 and sizes[0] > sizes[-1]
    starts, pids, i = [], set(), 0
    for size in sizes:  # the first run of each chunk, in submission order
        m = json.loads((run_dir(camp_dir / "o", specs[i].run_id) / "metrics.json").read_text())
        starts.append(m["started_at"])
        pids.add(m["pid"])
        i += size
    assert os.getpid() not in pids and len(pids) == 2
    # Two workers take two chunks at a time: a chunk may start just before the one submitted before it,
    # never before one submitted two or more places earlier.
    late = [(a, b) for a in range(len(starts)) for b in range(a + 2, len(starts)) if starts[b] < starts[a]]
    assert not late, (sizes, late)
    # The figures are written (drawn while the workers shut down), the same bytes as drawn again here.
    from maglev_ocp.campaign.summary import draw_figures, figure_names

    here = draw_figures(res.summary)
    assert list(here) == figure_names(res.summary) and len(here) >= 6
    for name, png in here.items():
        assert (camp_dir / "o" / name).read_bytes() == png, name
