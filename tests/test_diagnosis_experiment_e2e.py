"""Issue 27 item 3 end to end: a confusable verdict, the experiment it designs, the pooled diagnosis deciding.

A plant whose horizontal drag is eddy drag (``c_eddy B(g)^2 d_dot``) or viscous friction (``c d_dot``); the first
dataset is taken at one gap (20 mm: traverses of d at six speeds, gap sines with d locked, holds), where
``B(20 mm)^2`` is a constant and the two laws are the same function of the data. Expected, written before the
first run (seeds of ``tests/seeds.py``'s ``VALIDATION_SEEDS``, never looked at before):

1. ``maglev diagnose run DATA1`` (library restricted to the two effects, to keep the test's time) answers the
   confusable slot ``eddy_drag|friction`` (in either order) and nothing else, and writes ``experiment.yaml``;
2. the design chooses the velocity sweeps at two gaps (``B(g)^2`` differs by a factor 4.7 between 13 and
   25 mm, a viscous coefficient does not) with a predicted SNR of at least 10;
3. ``maglev simulate --experiment experiment.yaml`` on the same plant (its constants fixed in the plant file,
   a new noise seed) and ``maglev diagnose run DATA1 DATA2`` name the truth alone: ``eddy_drag`` for the eddy
   plant, ``friction`` for the viscous one;
4. the pooled fit's coefficient is the plant's within 20 %.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from seeds import VALIDATION_SEEDS

from maglev_ocp.cli import main
from maglev_ocp.diagnosis.verdict import EffectSets
from maglev_ocp.loop.run_plan import RunPlan, RunSpec, load_plan, write_plan
from maglev_ocp.params import NOMINAL

#: The truths: the plant's effect (plant-file ``effects:`` block) and the model-file value checked (effect, key).
TRUTHS = {
    "eddy_drag": ({"eddy_drag": {"enabled": True, "c_eddy": 180.0}}, ("eddy_drag", "c_eddy", 180.0)),
    "friction": (
        {
            "friction": {
                "enabled": True,
                **dict.fromkeys(("coulomb_g", "coulomb_d", "stribeck_g", "stribeck_d", "viscous_g"), 0.0),
                "viscous_d": 4.0,
            }
        },
        ("friction", "viscous_d", 4.0),
    ),
}
COEF_RTOL = 0.2
MIN_PREDICTED_SNR = 10.0


def _plant_file(path, truth: str, seed: int):
    """The default rig profile with only ``truth``'s drag, its constants drawn once (default profile's spread)."""
    rng = np.random.default_rng(seed)
    rel = {"C1": 0.02, "C2": 0.01, "C3": 0.02, "C4": 0.10}
    consts = {n: float(getattr(NOMINAL, n) * (1 + r * rng.uniform(-1, 1))) for n, r in rel.items()}
    effects = {"friction": {"enabled": False}, "amplifier_lag": {"enabled": False}, **TRUTHS[truth][0]}
    doc = {"profile": "default", "mismatch": {"relative": dict.fromkeys(rel, 0.0), "overrides": consts}}
    path.write_text(yaml.safe_dump({**doc, "effects": effects}))
    return path


def _one_gap_plan(path):
    """Runs at one gap (20 mm): d traverses +-30 mm at six speeds, gap sines (d locked), holds."""
    runs = [
        RunSpec(kind="d_traverse", gap_mm=20.0, amplitude_mm=30.0, speed_mm_s=v, duration_s=4.0)
        for v in (40.0, 80.0, 120.0, 160.0, 200.0, 250.0)
    ]
    runs += [
        RunSpec(kind="gap_sine", gap_mm=20.0, d_mm=d, amplitude_mm=3.0, freq_hz=f, duration_s=3.0, lock="d")
        for d, f in ((0.0, 1.0), (15.0, 3.0))
    ]
    runs += [RunSpec(kind="hold", gap_mm=20.0, d_mm=d, duration_s=2.0) for d in (-20.0, 20.0)]
    return write_plan(RunPlan(runs=runs), path)


def _verdict(rep_dir) -> EffectSets:
    return EffectSets.parse(json.loads((rep_dir / "report.json").read_text())["verdict"])


@pytest.mark.slow
@pytest.mark.timeout(1500)
# CI runs the eddy-drag truth; the friction truth (the same experiment's other branch) runs in `make check-long`
@pytest.mark.parametrize("truth", ["eddy_drag", pytest.param("friction", marks=pytest.mark.long)])
def test_confusable_drag_is_resolved_by_the_designed_experiment(tmp_path, truth):
    s = VALIDATION_SEEDS[f"experiment_{truth}"]
    plant = _plant_file(tmp_path / "plant.yaml", truth, s)
    plan1 = _one_gap_plan(tmp_path / "one_gap.yaml")
    data1, data2, rep1, rep2 = (tmp_path / n for n in ("data1", "data2", "rep1", "rep2"))
    sim = ["simulate", "--plant", str(plant), "--quiet", "--experiment"]
    assert main([*sim, str(plan1), "--seed", str(s), "--out", str(data1)]) == 0
    diag = ["diagnose", "run", "--candidates", "eddy_drag,friction", "--no-figures", "--quiet", "--seed", "0"]
    assert main([*diag, str(data1), "--out", str(rep1)]) == 0
    v1 = _verdict(rep1)
    # 1. one confusable slot holding both, nothing else
    assert [set(slot) for slot in v1.slots] == [{"eddy_drag", "friction"}] and not v1.gap, v1
    # 2. the design: velocity sweeps at two gaps, predicted SNR at least 10
    plan = load_plan(rep1 / "experiment.yaml")
    assert plan.excitation == "velocity_sweep_two_gaps", plan.why
    assert plan.predicted_snr >= MIN_PREDICTED_SNR
    assert len({r.gap_mm for r in plan.runs}) == 2
    # 3. the plan run on the same plant (new noise), both datasets diagnosed together: the truth alone
    assert main([*sim, str(rep1 / "experiment.yaml"), "--seed", str(s + 1), "--out", str(data2)]) == 0
    assert main([*diag, str(data1), str(data2), "--out", str(rep2)]) == 0
    v2 = _verdict(rep2)
    assert [set(slot) for slot in v2.slots] == [{truth}] and not v2.gap, v2
    # 4. the pooled fit's coefficient
    effect, key, value = TRUTHS[truth][1]
    model = yaml.safe_load((rep2 / "model.yaml").read_text())
    assert model["effects"][effect][key] == pytest.approx(value, rel=COEF_RTOL)
