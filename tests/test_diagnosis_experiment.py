"""Active diagnosis (issue 27, item 3): the excitation chosen for a confusable pair, its SNR, the run plan file."""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.diagnosis.experiment import Alternative, MenuEntry, design, effect_accelerations, score_entry
from maglev_ocp.errors import UserError
from maglev_ocp.loop.run_plan import RunPlan, RunSpec, load_plan, simulate_plan, write_plan, write_reference_csvs
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import PlantConfig

FIT_GAP_MM = 20.0
FLOORS = {"vertical": 0.05, "horizontal": 0.05}
NO_COULOMB = {"coulomb_g": 0.0, "coulomb_d": 0.0, "stribeck_g": 0.0, "stribeck_d": 0.0, "viscous_g": 0.0}


def _traverse(gap: float, speed: float) -> RunSpec:
    return RunSpec(kind="d_traverse", gap_mm=gap, amplitude_mm=20.0, speed_mm_s=speed, duration_s=1.6)


def _pair(c_eddy: float) -> tuple[Alternative, Alternative]:
    """Eddy drag and the viscous friction that a dataset at one gap (20 mm) cannot tell from it.

    The friction's coefficient is its least-squares fit to the eddy drag's horizontal acceleration on a traverse
    at the fitting gap: what a refit on data at that gap gives.
    """
    eddy = Alternative("eddy_drag", ("eddy_drag",), {"eddy_drag": {"c_eddy": c_eddy}})
    unit = Alternative("friction", ("friction",), {"friction": {**NO_COULOMB, "viscous_d": 1.0}})
    (log,) = simulate_plan(RunPlan(runs=[_traverse(FIT_GAP_MM, 100.0)]), PlantConfig.from_profile("ideal"), NOMINAL)
    a, b = effect_accelerations(eddy, log, NOMINAL)[:, 1], effect_accelerations(unit, log, NOMINAL)[:, 1]
    c = float(a @ b / (b @ b))
    return eddy, Alternative("friction", ("friction",), {"friction": {**NO_COULOMB, "viscous_d": c}})


def _menu() -> list[MenuEntry]:
    hold = RunSpec(kind="hold", gap_mm=15.0, duration_s=1.0)
    sine = RunSpec(kind="gap_sine", gap_mm=18.0, amplitude_mm=3.0, freq_hz=2.0, duration_s=1.6, lock="d")
    return [
        MenuEntry("holds", (hold,), "hold"),
        MenuEntry("gap_sine", (sine,), "gap sine, d locked"),
        MenuEntry("velocity_sweep_one_gap", (_traverse(FIT_GAP_MM, 50.0), _traverse(FIT_GAP_MM, 150.0)), "one gap"),
        MenuEntry("velocity_sweep_two_gaps", (_traverse(13.0, 50.0), _traverse(27.0, 150.0)), "two gaps"),
    ]


def test_eddy_drag_against_viscous_friction_chooses_velocity_sweeps_at_two_gaps():
    """B(g)^2 makes eddy drag depend on the gap, viscous friction does not: only other gaps separate them."""
    eddy, fric = _pair(200.0)
    d = design([eddy, fric], NOMINAL, FLOORS, menu=_menu(), target_snr=10.0)
    assert d.plan.excitation == "velocity_sweep_two_gaps"
    by = {s.name: s for s in d.scores}
    # at rest or with d locked the two predict no horizontal residual at all
    assert by["holds"].snr < 1e-6 and by["gap_sine"].snr < 1e-6
    # at the fitting gap they are (nearly) the same model: far less separation than at two other gaps
    assert by["velocity_sweep_one_gap"].snr < 0.1 * by["velocity_sweep_two_gaps"].snr
    assert d.plan.predicted_snr >= 10.0
    # neither effect acts vertically here (the friction's vertical terms refit to nothing)
    assert by["velocity_sweep_two_gaps"].per_channel["vertical"] < 1e-9
    assert d.plan.slot == ["eddy_drag", "friction"]


def test_constants_each_fit_moved_are_refitted_not_taken_for_the_effects_signatures():
    """Each alternative's fit moved C1..C4 its own way (1-10 %, within the prior): with nothing refitted those
    differences dominate every entry, holds included, where neither effect acts (d_dot = 0); the design refits
    the constants (prior PRIOR_SD) and still chooses the velocity sweeps at two gaps."""
    from dataclasses import replace

    eddy, fric = _pair(200.0)
    p = NOMINAL
    eddy = replace(eddy, constants={"C1": p.C1 * 1.02, "C2": p.C2 * 0.99, "C3": p.C3 * 1.02, "C4": p.C4 * 1.1})
    fric = replace(fric, constants={"C1": p.C1 * 0.99, "C2": p.C2 * 1.01, "C3": p.C3 * 0.99, "C4": p.C4 * 0.95})
    d = design([eddy, fric], NOMINAL, FLOORS, menu=_menu(), target_snr=10.0)
    by = {s.name: s for s in d.scores}
    assert by["holds"].snr_fixed > 10.0  # the constants' differences alone, far above the noise
    # refitted: only the prior's penalty is left, (shift / prior sd)^2 summed, about 0.1^2 + 0.2^2 + ... < 1
    assert by["holds"].snr < 1.0
    assert d.plan.excitation == "velocity_sweep_two_gaps"
    # and the effects' own separation there is what it is without constant differences (within 10 %)
    clean = score_entry(_menu()[3], _pair(200.0), NOMINAL, FLOORS).snr
    assert by["velocity_sweep_two_gaps"].snr == pytest.approx(clean, rel=0.1)


def test_snr_is_linear_in_the_effect_size():
    """Doubling the drag doubles the predicted difference (both alternatives are linear in their coefficient)."""
    entry = _menu()[3]
    s1 = score_entry(entry, _pair(100.0), NOMINAL, FLOORS).snr
    s2 = score_entry(entry, _pair(200.0), NOMINAL, FLOORS).snr
    assert s1 > 1.0
    assert s2 / s1 == pytest.approx(2.0, rel=0.02)
    # and inversely proportional to the noise floor
    s3 = score_entry(entry, _pair(100.0), NOMINAL, {c: 2 * v for c, v in FLOORS.items()}).snr
    assert s3 == pytest.approx(s1 / 2, rel=1e-6)


def test_run_plan_round_trip_and_reference_csv(tmp_path):
    plan = RunPlan(excitation="x", slot=["a", "b"], predicted_snr=3.0, why="w", runs=[_traverse(15.0, 100.0)])
    path = write_plan(plan, tmp_path / "experiment.yaml")
    assert load_plan(path) == plan
    (csv,) = write_reference_csvs(plan, tmp_path)
    tab = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert tab.shape == (1600, 5)
    # a triangle of d at 100 mm/s between -20 and +20 mm, the gap held
    assert tab[:, 2].max() == pytest.approx(0.020, abs=2e-4) and tab[:, 2].min() == pytest.approx(-0.020, abs=2e-4)
    assert np.allclose(np.abs(tab[:, 4]), 0.1) and np.allclose(tab[:, 1], 0.015)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("runs: [{kind: hold, speed: 3}]", "speed"),
        ("runs: [{kind: d_traverse, amplitude_mm: 50, d_mm: 20}]", "55"),
        ("runs: [{kind: gap_sine, lock: g}]", "lock"),
        ("runs: []", "runs"),
    ],
)
def test_bad_run_plan_is_refused_naming_the_key(tmp_path, text, needle):
    p = tmp_path / "plan.yaml"
    p.write_text(text)
    with pytest.raises(UserError) as err:
        load_plan(p)
    assert "plan.yaml" in str(err.value) and needle in str(err.value)


def test_pooled_datasets_keep_held_out_runs_of_each(tmp_path):
    """Two datasets pooled: run names tagged by dataset, and the split holds out runs of both."""
    from maglev_ocp.diagnosis.pool import dataset_tag, pool_datasets
    from maglev_ocp.diagnosis.stages.split import runs_from_dataset, split_runs
    from maglev_ocp.errors import DataError
    from maglev_ocp.riglog import Dataset

    def ds(n: int, gap: float, ts: float = 1e-3) -> Dataset:
        runs = []
        for i in range(n):
            t = np.arange(50) * ts
            cols = {
                "t": t,
                "g": np.full(50, gap + 1e-4 * i),
                "d": np.zeros(50),
                "i_q": np.zeros(50),
                "i_d": np.ones(50),
            }
            from maglev_ocp.riglog import RunLog

            runs.append(RunLog(f"r{i}.csv", cols, (), {}))
        return Dataset(sample_time=ts, encoder_resolution=1e-5, runs=runs)

    pooled = pool_datasets([ds(6, 0.02), ds(3, 0.015)])
    names = [r.file for r in pooled.runs]
    assert len(names) == 9 and len(set(names)) == 9
    train, test = split_runs(runs_from_dataset(pooled), every=3)
    assert {dataset_tag(r.name) for r in test} == {"ds1", "ds2"}
    assert {dataset_tag(r.name) for r in train} == {"ds1", "ds2"}
    assert len(train) + len(test) == 9
    with pytest.raises(DataError, match="sample times"):
        pool_datasets([ds(3, 0.02), ds(3, 0.02, ts=2e-3)])


def test_fitted_candidate_values_split_into_effect_parameters_and_model_constants():
    """A fit's free, fixed and tied values become the alternative's effect parameters and moved constants."""
    from maglev_ocp.diagnosis.active import _effect_values
    from maglev_ocp.diagnosis.fit import FitResult
    from maglev_ocp.diagnosis.library import CandidateSpec, Free

    spec = CandidateSpec(
        "friction",
        ("friction",),
        free=(Free("p.C1", 1, 30, 14, 1), Free("friction.viscous_d", 0, 100, 1, 1)),
        fixed=(("friction.coulomb_d", 0.0),),
        ties=(("friction.viscous_g", "friction.viscous_d"),),
    )
    fit = FitResult(spec, np.array([14.5, 3.25]), np.zeros(2), 1.0, 10, 1.0)
    eff, consts = _effect_values(fit)
    assert consts == {"C1": 14.5}
    assert eff == {"friction": {"viscous_d": 3.25, "coulomb_d": 0.0, "viscous_g": 3.25}}
    alt = Alternative("friction", ("friction",), eff, consts)
    (log,) = simulate_plan(RunPlan(runs=[_traverse(15.0, 100.0)]), PlantConfig.from_profile("ideal"), NOMINAL)
    moved = effect_accelerations(alt, log, NOMINAL)
    alone = effect_accelerations(Alternative("friction", ("friction",), eff), log, NOMINAL)
    # C1 (the thrust constant) scales the horizontal force, so the moved constant adds (C1'/C1 - 1) of it
    assert np.abs(moved - alone).max() > 1e-3


def test_a_confusable_verdict_writes_the_plan_the_references_and_the_report_section(tmp_path):
    """write_experiment on a verdict eddy_drag|friction: experiment.yaml, reference CSVs, report.md and .json."""
    import json
    from types import SimpleNamespace

    from maglev_ocp.diagnosis.active import write_experiment
    from maglev_ocp.diagnosis.fit import FitResult
    from maglev_ocp.diagnosis.library import CandidateSpec, Free
    from maglev_ocp.diagnosis.verdict import EffectSets, Verdict

    eddy, fric = _pair(200.0)

    def score(alt: Alternative) -> SimpleNamespace:
        ((eff, vals),) = alt.params.items()
        spec = CandidateSpec(alt.name, alt.effects, free=tuple(Free(f"{eff}.{k}", 0, 1e3, 1, 1) for k in vals))
        return SimpleNamespace(
            name=alt.name, fit=FitResult(spec, np.array(list(vals.values())), np.zeros(len(vals)), 1, 1, 1)
        )

    diag = SimpleNamespace(
        verdict=Verdict(EffectSets.parse("eddy_drag|friction"), ["eddy_drag", "friction"], True, []),
        scores=[score(eddy), score(fric)],
        final_score=None,
        floors={c: SimpleNamespace(floor=v) for c, v in FLOORS.items()},
        settings=None,
        baseline_params=NOMINAL,
    )
    (tmp_path / "report.md").write_text("# report\n")
    (tmp_path / "report.json").write_text("{}")
    plan = write_experiment(diag, tmp_path, menu=_menu())
    assert plan is not None and plan.excitation == "velocity_sweep_two_gaps"
    assert load_plan(tmp_path / "experiment.yaml") == plan
    assert len(list((tmp_path / "experiment_references").glob("*.csv"))) == len(plan.runs)
    md = (tmp_path / "report.md").read_text()
    assert "## Experiment to separate" in md and "velocity_sweep_two_gaps" in md
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["experiment"]["predicted_snr"] == plan.predicted_snr >= 10.0
    # a verdict without a confusable slot writes nothing
    diag.verdict = Verdict(EffectSets.parse("eddy_drag"), ["eddy_drag"], True, [])
    assert write_experiment(diag, tmp_path / "x", menu=_menu()) is None and not (tmp_path / "x").exists()


def test_simulate_runs_a_plan_file_and_refuses_what_the_plan_sets(tmp_path, capsys):
    """``maglev simulate --experiment PLAN.yaml``: one run per plan entry, at the plan's gap and lock."""
    from maglev_ocp.cli import main
    from maglev_ocp.riglog import read_dataset

    plan = RunPlan(
        runs=[
            _traverse(15.0, 100.0),
            RunSpec(kind="gap_sine", gap_mm=22.0, amplitude_mm=2.0, freq_hz=2.0, duration_s=1.0, lock="d"),
        ]
    )
    path = write_plan(plan, tmp_path / "plan.yaml")
    out = tmp_path / "data"
    assert main(["simulate", "--experiment", str(path), "--seed", "3", "--out", str(out), "--quiet"]) == 0
    ds = read_dataset(out)
    assert [r.file for r in ds.runs] == ["plan_01_d_traverse.csv", "plan_02_gap_sine.csv"]
    trav, sine = ds.runs
    assert np.mean(trav["g"]) == pytest.approx(0.015, abs=1e-4) and np.ptp(trav["d"]) == pytest.approx(0.04, rel=0.05)
    assert sine.locked == ("d",) and np.ptp(sine["g"]) == pytest.approx(0.004, rel=0.1)
    capsys.readouterr()
    assert main(["simulate", "--experiment", str(path), "--g", "18", "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--g" in err[0] and not (tmp_path / "o2").exists()
