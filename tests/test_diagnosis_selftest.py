"""Blind self-check of the gap diagnosis: random effects on the plant, diagnosed without being told."""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.diagnosis.generate import GeneratorSettings
from maglev_ocp.diagnosis.selftest import SelftestSettings, run_case, run_selftest


@pytest.mark.long
def test_small_blind_selfcheck_is_right(tmp_path):
    """Three seeded blind datasets (calibrated baseline; seed 5 draws a single, a two- and a three-effect set):
    the single and the pair named exactly; the three-effect set on 28 s of data may miss one effect (seen:
    cogging+saturation|end_effect for cogging+friction+end_effect), never more than that one verdict wrong."""
    st = SelftestSettings(n=3, seed=5, generator=GeneratorSettings(n_runs=4, run_duration=7.0))
    res = run_selftest(st, progress=False, out_dir=tmp_path)
    right = {c.truth: c.right for c in res.cases}
    assert all(v for t, v in right.items() if t.count("+") < 2), res.table()
    assert res.none_false_claims() == 0
    r = res.reduction_ratios()
    assert np.all(r >= 0.7), res.table()
    assert (tmp_path / "selftest.json").is_file() and (tmp_path / "selftest.md").is_file()
    assert res.confusion()[2].sum() == 3


@pytest.mark.long
def test_out_of_library_guide_ripple_is_unexplained_in_the_horizontal_channel():
    """A guide ripple with an 8.6 mm period along d (no slot or pole period): unexplained, horizontal."""
    st = SelftestSettings(n=1)
    case, diag = run_case(0, "none", np.random.SeedSequence(3), st, extra="guide_ripple")
    assert case.verdict == "unexplained", diag.table()
    regs = diag.remaining_regions or diag.regions
    assert any(r.channel == "horizontal" for r in regs)


@pytest.mark.long
def test_an_effect_that_only_takes_up_sticking_friction_is_dropped():
    """Library self-check case 14 (calibrated, seed 1): friction + end effect. Over all held-out samples an
    amplifier lag entered beside them (paired z 4.5, 0.1 % of the gap); on the samples whose velocities resolve
    the friction law it makes the residual worse, and the backward check drops it."""

    st = SelftestSettings(n=30, seed=1)
    _, s_cases = np.random.SeedSequence(st.seed).spawn(2)
    case, d = run_case(14, "friction+end_effect", s_cases.spawn(st.n)[14], st)
    assert case.right, d.table()
    assert any("amplifier_lag dropped" in r and "resolved samples" in r for r in d.verdict.reasons), d.verdict.reasons
