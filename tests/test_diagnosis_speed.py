"""The selection's fits spread over worker processes: the same record as in one process (issue 27, item 5)."""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.diagnosis import DiagnoseSettings
from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
from maglev_ocp.diagnosis.selftest import selftest_plant
from maglev_ocp.diagnosis.stages.baseline import calibrate_baseline
from maglev_ocp.diagnosis.stages.localization import localize_gap
from maglev_ocp.diagnosis.stages.models import FitJob, Run, fit_and_score, prefetch
from maglev_ocp.diagnosis.stages.selection import attribute
from maglev_ocp.diagnosis.stages.split import split_dataset
from maglev_ocp.params import NOMINAL


def _record(att) -> list[tuple]:
    """What the selection keeps of every candidate fit: name, law, values, objective, scores, residual."""
    return [
        (s.name, s.law, tuple(s.fit.w), s.fit.sse, s.fit.status, s.z, s.delta_bic, s.r2_after, tuple(s.e_after))
        for s in [*att.scores, *att.members]
    ]


@pytest.mark.slow  # a dataset, its baseline and the candidates fitted twice: 10 min under load 25 on 2 cores
def test_fits_on_workers_give_the_record_of_one_process():
    """Candidates and their law families fitted on two forked workers give bit for bit the scores, fitted
    values and single-effect verdict of the same fits made one after the other (each fit is the same
    computation wherever it runs, and the results are used in the sequential order); a fit made ahead
    (:func:`prefetch`) is the one the sequential call then gets."""
    cfg = selftest_plant("given", {})
    gen = generate_dataset(
        cfg, NOMINAL.with_(xi0=3.0, ell=4.2e-3), seed=12, settings=GeneratorSettings(n_runs=3, run_duration=5.0)
    )
    st1 = DiagnoseSettings(candidates=["eddy_drag", "commutation_offset"], fit_workers=1)
    st2 = st1.model_copy(update={"fit_workers": 2})
    split = split_dataset(gen.dataset, st1)
    base = calibrate_baseline(split, None, st1)
    loc = localize_gap(split, base, st1, np.random.default_rng(0))
    one = Run(split, base, st1)
    att1 = attribute(one, loc)
    two = Run(split, base, st2)
    try:
        att2 = attribute(two, loc)
        assert two.pool() is not None  # the fits did run on workers
        spec = att1.specs["eddy_drag"]
        half = {k: 0.5 * v for k, v in att1.fits["eddy_drag"].params().items()}
        jobs = [FitJob("eddy_drag", spec, spec.note, False, half), FitJob("eddy_drag", spec, spec.note, False)]
        prefetch(two, jobs)
        assert len(two.workers.ready) == 2
        ahead = fit_and_score(two, *jobs[0])
        assert len(two.workers.ready) == 1  # taken, once
    finally:
        two.close()
    assert _record(att1) == _record(att2)
    assert att1.verdict.verdict == att2.verdict.verdict
    here = fit_and_score(one, *jobs[0])
    assert tuple(here[0].w) == tuple(ahead[0].w) and here[1].z == ahead[1].z


# ----------------------------------------------------------------- the fits' cheap filter and HAC products
def _runs(n_runs: int = 2, n: int = 2500):
    """Runs with smooth positions (a sweep in d, a wobble in g) and currents (the products only need inputs)."""
    from maglev_ocp import constants as k
    from maglev_ocp.diagnosis.residuals import ResidualSettings, RunInput, ZeroPhaseFilter, prepare_run

    filt = ZeroPhaseFilter(ResidualSettings())
    t = np.arange(n) * k.Ts
    runs = []
    for i in range(n_runs):
        y = np.column_stack([0.018 + 0.002 * np.sin(2 * np.pi * (0.7 + 0.1 * i) * t), 0.03 * np.sin(0.8 * t + i)])
        u = np.column_stack([0.5 * np.sin(3.1 * t + i), 1.2 + 0.3 * np.cos(1.7 * t)])
        runs.append(prepare_run(RunInput(f"r{i}", k.Ts, y, u), filt))
    return runs, filt


def test_the_fitters_jacobian_is_the_filtered_derivative_of_its_residual():
    """The fitter's residual Jacobian, whose zero columns it skips and whose linear columns it filters once,
    is the filter rows (the sparse ``PreparedRun.W``) applied to CasADi's own Jacobian of every library
    candidate, and the derivative of its residual (central differences); a second call (the linear columns
    from the cache) gives the same array."""
    from maglev_ocp.diagnosis.fit import CandidateFitter, Dataset, _accel_jac_function
    from maglev_ocp.diagnosis.library import library_specs

    runs, filt = _runs()
    data = Dataset(runs, np.array([3.0, 0.5]), filt)
    p0 = NOMINAL.vector()
    Zt = np.ascontiguousarray(data.Z.T)
    rng = np.random.default_rng(3)
    for name, spec in library_specs().items():
        if not spec.free or spec.lag:
            continue
        fi = CandidateFitter(spec, data, p0)
        lo, hi = np.array([f.lo for f in spec.free]), np.array([f.hi for f in spec.free])
        w = np.clip(
            np.array([f.start for f in spec.free]) + 0.2 * rng.random(len(lo)) * np.minimum(hi - lo, 1.0), lo, hi
        )
        s = w / fi.scale
        r, J = fi.residual_jacobian(s, Zt)
        _, J2 = fi.residual_jacobian(s, Zt)
        assert np.array_equal(J, J2), name
        a, da = _accel_jac_function(spec).map(Zt.shape[1])(Zt, p0, w)
        a, da = np.asarray(a), np.asarray(da).reshape(2, Zt.shape[1], len(w))  # (2, N, n_w)
        ref = []
        for c in range(2):
            cols = [run.W @ da[c, o : o + len(run.Z)] for run, o in zip(data.runs, data.offsets[:-1], strict=True)]
            ref.append(-(fi._sw[c][:, None] * np.vstack(cols)) * fi.scale[None, :])
        ref = np.vstack(ref)
        assert np.abs(J - ref).max() <= 1e-9 * np.abs(ref).max(), name
        for i in rng.choice(len(s), size=min(3, len(s)), replace=False):
            h = 1e-6 * max(abs(s[i]), 1.0)
            sp, sm = s.copy(), s.copy()
            sp[i] += h
            sm[i] -= h
            fd = (fi.residual_jacobian(sp, Zt, jac=False)[0] - fi.residual_jacobian(sm, Zt, jac=False)[0]) / (2 * h)
            scale = max(np.abs(J[:, i]).max(), 1e-12 * np.abs(r).max())
            assert np.abs(fd - J[:, i]).max() <= 1e-4 * scale + 1e-9 * np.abs(r).max(), (name, i)


def test_newey_west_is_the_bartlett_weighted_sum_over_lags():
    """The HAC meat computed by one convolution equals its definition, the Bartlett-weighted sum of the
    lagged cross-products ``sum_k g_k g_(k+l)^T`` written out pair by pair, for short and long lags."""
    from maglev_ocp.estimation.ident import newey_west

    rng = np.random.default_rng(7)
    for n, lags in ((1, 3), (6, 10), (40, 5), (300, 120)):
        J = rng.standard_normal((n, 3))
        r = np.convolve(rng.standard_normal(n + 9), np.ones(10) / 10, "valid")
        g = J * r[:, None]
        ref = np.zeros((3, 3))
        for t in range(n):
            for u in range(n):
                lag = abs(t - u)
                if lag <= lags:
                    ref += (1.0 - lag / (lags + 1.0)) * np.outer(g[t], g[u])
        S = newey_west(J, r, lags)
        assert np.allclose(S, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
        assert np.allclose(S, S.T, rtol=0, atol=0)
