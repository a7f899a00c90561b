"""The gap diagnosis on the independent rig (maglev_ocp.rigsim), and the machinery that makes it fast."""

from __future__ import annotations

import json

import numpy as np
import pytest

from maglev_ocp.diagnosis.candidates import _accel_function, _accel_jac_function, family_specs
from maglev_ocp.diagnosis.generate import GeneratorSettings
from maglev_ocp.diagnosis.selftest import SelftestSettings
from maglev_ocp.diagnosis.selftest_rig import BLOCK, kinds_order, run_rig_case, run_rig_selftest
from maglev_ocp.diagnosis.sxnumpy import vectorized
from maglev_ocp.params import NOMINAL


def test_vectorized_candidate_functions_match_casadi_map():
    """Every law-family member's model acceleration and Jacobian, evaluated with numpy over 500 random states,
    equals CasADi's mapped evaluation to 1e-12 relative."""
    rng = np.random.default_rng(4)
    N = 500
    Z = np.vstack(
        [
            rng.uniform(0.009, 0.025, N), rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N),
            rng.uniform(-0.3, 0.3, N), rng.uniform(-3, 3, N), rng.uniform(-1, 4, N), rng.uniform(-3, 3, N),
            rng.uniform(-1, 4, N),
        ]
    )  # fmt: skip
    p = NOMINAL.vector()
    n_checked = 0
    for members in family_specs().values():
        for spec in members:
            w = np.array([f.start for f in spec.free]) * (1 + 0.2 * rng.standard_normal(len(spec.free)))
            for f in (_accel_function(spec), _accel_jac_function(spec)):
                ev = vectorized(f)
                assert ev is not None, f.name()
                got = ev(Z, p, w)
                ref = f.map(N)(Z, p, w)
                ref = ref if isinstance(ref, (list, tuple)) else [ref]
                for g, r in zip(got, ref, strict=True):
                    r = np.asarray(r).reshape(g.shape[0], N, g.shape[1]).transpose(0, 2, 1)
                    assert np.all(np.isfinite(g))
                    if g.size == 0:  # a candidate without fitted values (the lag): an empty Jacobian
                        continue
                    assert np.max(np.abs(g - r)) <= 1e-12 * max(np.max(np.abs(r)), 1.0), f.name()
                n_checked += 1
    assert n_checked >= 20


def test_generate_independent_cli_validates_effects_and_writes_the_truth(tmp_path, capsys):
    """``--generate --plant independent``: effects, families and parameters from rigsim's catalogue (one-line
    errors, exit 2); a valid call writes a rig-log dataset with its truth.json (two effects, a Dahl law)."""
    from maglev_ocp.cli import main
    from maglev_ocp.riglog import read_dataset

    out = tmp_path / "g"
    base = ["diagnose", "--generate", str(out), "--plant", "independent", "--runs", "2", "--duration", "2"]
    for bad, word in (
        (["--effect", "cogging,gremlin"], "gremlin"),
        (["--effect", "friction", "--effect-param", "family=viscoelastic"], "coulomb_viscous"),
        (["--effect", "friction", "--effect-param", "family=dahl", "Fs_g=0.1"], "Fc_g"),
        (["--effect", "friction,cogging", "--effect-param", "xi0=3"], "EFFECT.xi0"),
        (["--effect", "friction", "--extra", "vibration"], "resonance"),
    ):
        assert main(base + bad) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0], err
    args = ["--effect", "friction,resonance", "--effect-param", "friction.family=dahl", "resonance.f_hz=40"]
    assert main(base + args) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["expected_verdict"] == "friction"
    assert truth["effects"]["friction"]["family"] == "dahl"
    assert truth["effects"]["resonance"]["params"]["f_hz"] == pytest.approx(40.0)
    ds = read_dataset(out)
    assert len(ds.runs) == 2 and abs(len(ds.runs[0].t) - 2000) <= 1


def test_kinds_cycle_through_blocks_of_twenty():
    """The independent self-check's kinds: every block of 20 holds 3 none, 7 singles, 4 pairs, 2 triples and
    4 effects outside the library, in a seeded random order."""
    a = kinds_order(40, np.random.default_rng(1))
    assert a == kinds_order(40, np.random.default_rng(1))
    for blk in (a[:20], a[20:]):
        assert {k: blk.count(k) for k in BLOCK} == BLOCK


def test_small_independent_rig_check():
    """Three seeded datasets of the independent rig (3 runs of 6 s; laws other than the library's, constants
    off nominal, the rig's own integrator and controller): `none` without effects, an effect outside the library
    is `unexplained`, a single library effect is named."""
    st = SelftestSettings(n=3, seed=0, generator=GeneratorSettings(n_runs=3, run_duration=6.0))
    cases = {k: run_rig_case(i, k, 31 + i, st) for i, k in enumerate(("none", "out_of_library", "single"))}
    assert cases["none"].verdict == "none", cases["none"]
    assert cases["out_of_library"].verdict == "unexplained", cases["out_of_library"]
    assert cases["single"].right, cases["single"]


def test_structure_test_is_on_the_residual_of_the_final_calibration(tmp_path):
    """A rig dataset without effects (constants off nominal by up to 5 %, the rig's own integrator and
    controller): the floors and their structure test are those of the residual of the calibration the diagnosis
    goes on with (formerly those of the first, rms-weighted pass, whose prior held Mv near nominal and left a
    state-dependent vertical residual: held-out map gain 20-30 %, z 4-8, on 3 of 9 such datasets), and that
    residual has no structure."""
    import importlib

    from maglev_ocp.diagnosis import DiagnoseSettings
    from maglev_ocp.diagnosis.localize import channel_floor
    from maglev_ocp.diagnosis.residuals import CHANNELS
    from maglev_ocp.riglog import read_dataset
    from maglev_ocp.rigsim import RigSettings, draw, generate

    dg = importlib.import_module("maglev_ocp.diagnosis.diagnose")
    seed = 77
    folder = generate(tmp_path / "ds", draw(seed, "none")["effects"], seed, RigSettings(n_runs=3, duration=8.0))
    st = DiagnoseSettings(seed=seed)
    split = dg._split(read_dataset(folder), st)
    base = dg._baseline(split, None, st, [])
    for c, ch in enumerate(CHANNELS):
        fl = channel_floor(base.b_train, base.b_test, c, base.q_floor, max_lag=base.noise_lag)
        assert base.floors[ch].gain == pytest.approx(fl.gain, rel=1e-9, abs=1e-12), ch
        assert base.floors[ch].floor == pytest.approx(fl.floor, rel=1e-9), ch
        assert not base.floors[ch].significant, (ch, base.floors[ch].to_dict())
        # The weights the calibration used are the floors within the reweighting tolerance.
        assert base.fvec[c] == pytest.approx(fl.floor, rel=dg.FLOOR_RTOL + 1e-9), ch


@pytest.mark.slow
def test_independent_rig_selfcheck_20_datasets(tmp_path):
    """20 blind datasets of the independent rig (seed 3; one block of kinds): the named set right on >= 90 %, no
    effect claimed on a `none` dataset, out-of-library effects `unexplained` on >= 90 %, the gap closed by at
    least 70 % (median) on the right verdicts, the median diagnosis time at most 60 s. Two local workers;
    about 6 min on 2 cores (18/20 right, median 20.6 s per dataset, max 78 s; CI measured a 60 s median
    before the workers kept glibc's dynamic mmap threshold, see :func:`maglev_ocp.parallel.local_client`)."""
    res = run_rig_selftest(SelftestSettings(n=20, seed=3), progress=False, out_dir=tmp_path, workers=2)
    s = res.summary()
    assert s["datasets"] == 20
    assert s["right_verdicts"] >= 0.9, res.table()
    assert s["effects_claimed_on_none"] == 0, res.table()
    assert s["out_of_library_unexplained"] >= 0.9, res.table()
    assert s["gap_closed_median"] is not None and s["gap_closed_median"] >= 0.7, res.table()
    assert np.median([c.seconds for c in res.cases]) <= 60.0, res.table()
    assert (tmp_path / "selftest.md").is_file()


def test_end_effect_spline_profile_nests_the_geometric_law_and_follows_other_profiles():
    """The end effect's free profile (a cubic B-spline in |d|): 0 with its default coefficients, and with any
    0 at d = 0 (a uniform loss is the calibrated constants) and the same at both ends; projected by
    least squares on it, the independent rig's overhang laws that level off (half cosine) or grow quadratically
    are followed to 3 % of their peak loss over the stroke the targets visit (1 % rms)."""
    import casadi as ca

    from maglev_ocp.effects import EndEffect
    from maglev_ocp.rigsim.laws import EndEffect as RigEndEffect

    names = [n for n in EndEffect.param_names() if n.startswith("dloss_")]
    d = ca.SX.sym("d")
    c = ca.SX.sym("c", len(names))
    f = ca.Function("loss", [d, c], [EndEffect.profile_loss(d, dict(zip(names, ca.vertsplit(c), strict=True)))])
    xs = np.linspace(-0.05, 0.05, 201)
    basis = np.array([[float(f(x, e)) for e in np.eye(len(names))] for x in xs])
    rng = np.random.default_rng(2)
    for _ in range(3):
        w = rng.uniform(-0.5, 0.5, len(names))
        prof = basis @ w
        assert prof[100] == 0.0 and xs[100] == 0.0
        assert prof == pytest.approx(prof[::-1], abs=1e-12)
    assert not np.any(basis @ np.zeros(len(names)))
    for family, params in (
        ("cosine", {"d_edge": 0.03, "w": 0.012, "loss": 0.25}),
        ("quadratic", {"d_edge": 0.025, "c2": 400.0}),
    ):
        law = RigEndEffect(family, **params)
        loss = 1.0 - law.rho(xs)
        coef, *_ = np.linalg.lstsq(basis, loss, rcond=None)
        err = basis @ coef - loss
        assert np.max(np.abs(err)) < 0.03 * np.max(loss), family
        assert np.sqrt(np.mean(err**2)) < 0.01 * np.max(loss), family
