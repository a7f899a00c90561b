"""The diagnosed-model recovery benchmark (issue 12, "What it must show"): arithmetic, rigs and model files.

``python -m benchmarks.diagnosed_recovery`` diagnoses a dataset of each strong
effect and runs the tour on the blind, diagnosed and true model files. The fast
tests check what the table is computed from (the recovered fraction, the
per-tour RMS, and that the "true" model file is exactly the rig the tours and
the dataset run on, and that the tours' compiled loop gives the Python loop's figures); the slow one runs
the whole chain for one effect.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.diagnosed_recovery import (
    MIN_GAIN_M,
    STRONG,
    blind_model,
    generate_command,
    main,
    recovered,
    rig_of_dataset,
    tour_rms,
    tour_scenario,
)
from maglev_ocp.cli import main as cli_main
from maglev_ocp.codegen.build import find_compiler
from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.effects import EffectSet
from maglev_ocp.output import dump_yaml
from maglev_ocp.plant import Plant
from maglev_ocp.scenario import scenario_from_dict


def test_recovered_fraction_and_its_threshold():
    assert recovered(10e-6, 4e-6, 2e-6) == pytest.approx(0.75)
    assert recovered(10e-6, 12e-6, 2e-6) == pytest.approx(-0.25)  # a diagnosed model can make it worse
    assert recovered(5e-6, 5e-6, 5e-6 - 0.5 * MIN_GAIN_M) is None  # improvement below 1 um: not scored
    assert recovered(5e-6, 4e-6, 6e-6) is None  # the true model no better than blind
    assert recovered(math.nan, 4e-6, 2e-6) is None  # an unsettled run is reported, never scored


def test_tour_rms_combines_axes_and_targets():
    t = [
        SimpleNamespace(settled=True, rms_error_g_m=3e-6, rms_error_d_m=4e-6, rms_tracking_error_g_m=6e-6,
                        rms_tracking_error_d_m=8e-6),
        SimpleNamespace(settled=True, rms_error_g_m=0.0, rms_error_d_m=5e-6, rms_tracking_error_g_m=0.0,
                        rms_tracking_error_d_m=10e-6),
    ]  # fmt: skip
    r = tour_rms(SimpleNamespace(targets=t))
    assert r["steady_m"] == pytest.approx(5e-6) and r["tracking_m"] == pytest.approx(10e-6)
    t[1].settled = False
    assert math.isnan(tour_rms(SimpleNamespace(targets=t))["steady_m"])


@pytest.mark.parametrize("effect", list(STRONG))
def test_true_model_file_is_the_rig_of_the_tours(effect, tmp_path):
    """The tours run on the very rig the dataset came from; the true model file holds its constants and effect law."""
    data = tmp_path / "data"
    assert cli_main(generate_command(effect, data, seed=3)) == 0
    plant, true = rig_of_dataset(data)
    f, fb = tmp_path / "true.yaml", tmp_path / "blind.yaml"
    dump_yaml(f, true)
    dump_yaml(fb, blind_model())
    sc = scenario_from_dict(tour_scenario(effect, "fl", f, plant))
    cfg = sc.plant_config()
    rig = Plant(cfg, sc.plant_params(), seed=np.random.SeedSequence(0)).true_params
    cm, blind = load_controller_model(f), load_controller_model(fb)
    np.testing.assert_allclose(cm.params.vector(), rig.vector(), rtol=1e-12)
    assert blind.params.xi0 == 0.0 and blind.effects == () and blind.delay_samples == 0
    on = cfg.effect_values()
    assert set(on) == {effect}  # the strong effect, and only it, is on in the tours' rig
    if effect == "amplifier_lag":  # dynamic: its transport delay is what a controller takes
        assert cm.effects == () and cm.delay_samples == STRONG[effect]["delay_samples"]
    else:
        assert cm.effects == (effect,)
        np.testing.assert_allclose(cm.theta, EffectSet([effect]).vector(on))


@pytest.mark.long
def test_diagnosed_commutation_offset_recovers_the_true_models_gain(tmp_path):
    """Whole chain for one effect (dataset, diagnosis, six tours; about 2 min): >= 70 % wherever scored."""
    assert main(["--out", str(tmp_path), "--effects", "commutation_offset"]) == 0
    doc = json.loads((tmp_path / "recovery.json").read_text())
    (row,) = doc["rows"]
    assert row["verdict"] == "commutation_offset"
    scored = [c[f"recovered_{kind}"] for c in row["controllers"].values() for kind in ("steady", "tracking")]
    scored = [v for v in scored if v is not None]
    assert scored and min(scored) >= 0.7, row
    md = (tmp_path / "recovery.md").read_text()
    assert md.count("| commutation_offset | commutation_offset |") == 2  # FL and NMPC rows of the main table


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler: the compiled loop cannot be built here")
def test_tours_run_on_the_compiled_loop_with_the_python_loops_figures(tmp_path, monkeypatch):
    """The recovery tours go through the compiled loop (``--loop auto``) and give the Python loop's RMS figures:
    FL on a model file with a fitted effect, on a rig with that effect."""
    import maglev_ocp.codegen.loop_c as loop_c
    from benchmarks.diagnosed_recovery import run_tour

    f = tmp_path / "model.yaml"
    law = {"enabled": True, **STRONG["commutation_offset"]}
    dump_yaml(f, {**blind_model(), "effects": {"commutation_offset": law}})
    plant = {"profile": "default", "effects": {"commutation_offset": law}}
    sc = tour_scenario("commutation_offset", "fl", f, plant)
    calls = []
    real = loop_c.run_scenario_compiled
    monkeypatch.setattr(loop_c, "run_scenario_compiled", lambda *a, **kw: calls.append(1) or real(*a, **kw))
    auto, py = tour_rms(run_tour(sc, "auto").metrics), tour_rms(run_tour(sc, "python").metrics)
    assert calls == [1]
    assert math.isfinite(py["steady_m"]) and py["tracking_m"] > 1e-6  # a settled tour that tracked a plan
    for key in ("steady_m", "tracking_m"):
        assert auto[key] == pytest.approx(py[key], rel=0, abs=1e-9), key
