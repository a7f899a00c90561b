"""The local Dask map the campaigns and the diagnosis self-checks scale out with."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

from maglev_ocp.parallel import map_ordered


def _noisy_square(seed: int) -> float:
    """A seeded job: the result depends on its own seed only."""
    return float(np.random.default_rng(np.random.SeedSequence(seed)).normal()) ** 2


def test_map_ordered_keeps_the_order_and_reports_progress():
    seen: list[int] = []
    one = map_ordered(_noisy_square, list(range(6)), workers=1, progress=False, on_result=lambda d: seen.append(len(d)))
    two = map_ordered(_noisy_square, list(range(6)), workers=2, progress=False)
    assert one == two == [_noisy_square(s) for s in range(6)]
    assert seen == [1, 2, 3, 4, 5, 6]
    with pytest.raises(ValueError, match="workers"):
        map_ordered(_noisy_square, [1], workers=0)


@pytest.mark.long
def test_rig_selfcheck_gives_the_same_cases_on_one_or_two_workers(tmp_path):
    """Two independent-rig datasets diagnosed in-process and on two Dask workers: the same verdicts and scores."""
    from maglev_ocp.diagnosis.selftest import GeneratorSettings, SelftestSettings
    from maglev_ocp.diagnosis.selftest_rig import run_rig_selftest

    st = SelftestSettings(n=2, seed=4, generator=GeneratorSettings(n_runs=2, run_duration=5.0))
    a = run_rig_selftest(st, progress=False, out_dir=tmp_path / "a", workers=1)
    b = run_rig_selftest(st, progress=False, out_dir=tmp_path / "b", workers=2)
    for ca, cb in zip(a.cases, b.cases, strict=True):
        assert (ca.index, ca.truth, ca.verdict, ca.right) == (cb.index, cb.truth, cb.verdict, cb.right)
        assert ca.reduction == cb.reduction and (
            ca.ideal == cb.ideal or (math.isnan(ca.ideal) and math.isnan(cb.ideal))
        )
    ja = json.loads((tmp_path / "a" / "selftest.json").read_text())
    assert [c["verdict"] for c in ja["cases"]] == [c.verdict for c in b.cases]


def _worker_env(_: int) -> dict:
    return {k: os.environ.get(k) for k in ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}


def test_workers_keep_glibcs_dynamic_mmap_threshold(monkeypatch):
    """Dask's default MALLOC_TRIM_THRESHOLD_ in the workers made every large array a fresh mapping (the gap
    diagnosis ran 4 times slower in a worker than alone): unset there, with one BLAS thread per worker."""
    # also where an earlier nanny of this process left it in the environment (Dask sets it there)
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    env = map_ordered(_worker_env, [0, 1], workers=2, progress=False)
    assert os.environ["MALLOC_TRIM_THRESHOLD_"] == "65536"  # the process's own environment is left as it was
    for e in env:
        assert e["MALLOC_TRIM_THRESHOLD_"] is None, e
        assert e["OMP_NUM_THREADS"] == "1" and e["OPENBLAS_NUM_THREADS"] == "1", e
    # the speed this buys (worker vs in-process allocation time) is measured in benchmarks/bench_workers.py


def _failing_plugin():
    raise RuntimeError("plugin factory failed")


def test_background_cluster_hands_its_start_error_to_the_caller_and_restores_sigint():
    """A LocalCluster started in the background: its start's error is raised by ``client()`` in the caller's
    thread, ``close()`` still shuts down what had started, and SIGINT is the caller's own again."""
    import signal

    from maglev_ocp.parallel import BackgroundCluster

    before = signal.getsignal(signal.SIGINT)
    cluster = BackgroundCluster(2, _failing_plugin)
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # while the workers start (they inherit it)
    with pytest.raises(RuntimeError, match="plugin factory failed"):
        cluster.client()
    assert signal.getsignal(signal.SIGINT) is before
    closing = cluster.close(background=True)  # the client and the cluster that did start are shut down
    assert closing is not None
    closing.join(timeout=120)
    assert not closing.is_alive()
    assert cluster.close(background=True) is None  # once only
