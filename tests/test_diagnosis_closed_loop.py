"""``maglev diagnose closed-loop SCENARIO --from report.json``: the report's own models against a rig log."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from maglev_ocp.diagnosis.candidates import CandidateSpec, FitResult, library_specs
from maglev_ocp.diagnosis.closed_loop import closed_loop_from_report
from maglev_ocp.diagnosis.consequence import plant_effects, plant_file
from maglev_ocp.errors import UserError
from maglev_ocp.params import NOMINAL

FRICTION = {"friction.coulomb_g": 0.5, "friction.coulomb_d": 0.4}


def _report(folder, with_models=True):
    """A small report: verdict friction, its fitted law in model.yaml, the baseline in baseline.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    spec = library_specs()["friction"]
    w = np.array([FRICTION.get(f.key, 0.0) for f in spec.free])
    fit = FitResult(spec, w, np.zeros(len(w)), 0.0, 1, 1.0)
    p = NOMINAL.without_cogging().vector()
    pm, em, _ = plant_effects(spec, fit, p)
    pb, eb, _ = plant_effects(CandidateSpec("baseline"), None, p)
    (folder / "report.json").write_text(
        json.dumps({"verdict": "friction", "final_model": "friction", "consequences": {"model": "friction"}})
    )
    if with_models:
        (folder / "model.yaml").write_text(yaml.safe_dump(plant_file(pm, em)))
        (folder / "baseline.yaml").write_text(yaml.safe_dump(plant_file(pb, eb)))
    return folder / "report.json", pm, em


def _rig_scenario(path, params, effects):
    """The rig: the default profile with the very law and constants the report fitted (so the model is exact)."""
    sc = {
        "name": "rig_friction",
        "seed": 3,
        "controller": {"type": "fl"},
        "plant": {
            "profile": "default",
            "mismatch": {"relative": {n: 0.0 for n in params}, "overrides": params},
            "effects": effects,
        },
        "targets": [{"g": 0.016, "d": 0.0, "hold": 0.15}, {"g": 0.02, "d": 0.03, "hold": 0.15}],
    }
    path.write_text(yaml.safe_dump(sc))
    return path


def test_closed_loop_from_report_cli(tmp_path):
    """The CLI runs the scenario on its plant and on the report's two models and writes the comparison."""
    report, pm, em = _report(tmp_path / "rep")
    scen = _rig_scenario(tmp_path / "rig.yaml", pm, em)
    out = tmp_path / "cl"
    cmd = [sys.executable, "-m", "maglev_ocp", "diagnose", "closed-loop", str(scen), "--from", str(report)]
    proc = subprocess.run(
        [*cmd, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    doc = json.loads((out / "closed_loop.json").read_text())
    assert doc["verdict"] == "friction" and doc["model"] == "friction"
    assert (out / "closed_loop.md").is_file() and (out / "closed_loop.png").is_file()
    # The augmented model is the rig here: same plant, same seed, same controller, same log.
    assert doc["rms_vs_rig"]["augmented"]["d"] < 1e-9
    assert doc["rms_vs_rig"]["baseline"]["d"] > 1e-6
    assert doc["shrink"]["d"] > 0.99 and doc["shrink"]["i_q"] > 0.99
    assert set(doc["metrics"]) == {"rig", "baseline", "augmented"}


def test_closed_loop_from_report_needs_the_model_files(tmp_path):
    """A report without its model files is a one-line user error naming the missing file."""
    report, pm, em = _report(tmp_path / "rep", with_models=False)
    scen = _rig_scenario(tmp_path / "rig.yaml", pm, em)
    with pytest.raises(UserError, match=r"baseline\.yaml"):
        closed_loop_from_report(scen, report)
    proc = subprocess.run(
        [sys.executable, "-m", "maglev_ocp", "diagnose", "closed-loop", str(scen)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "--from" in proc.stderr
