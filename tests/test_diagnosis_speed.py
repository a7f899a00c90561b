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
