"""The NMPC with a model file (issue 12, item 1): ``controller: {type: nmpc, model: FILE}``.

The file's static effects enter the NMPC's prediction (inside the RK4), its
observer and its feed-forward; its lag's transport delay enters through the
delay augmentation. On a rig with strong friction the NMPC with the true model
file holds the targets far better than blind, the compiled C step agrees with
the Python one, and a diagnosis's ``model.yaml`` (a plant file) loads as it is.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.codegen.build import find_compiler
from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings
from maglev_ocp.effects import EFFECTS
from maglev_ocp.errors import ConfigError
from maglev_ocp.output import dump_yaml
from maglev_ocp.runner import run_scenario
from maglev_ocp.scenario import StartSpec, scenario_from_dict

#: The scenarios' default hover at the start, before the first target [s].
HOVER = StartSpec().hover

needs_cc = pytest.mark.skipif(
    find_compiler() is None or shutil.which("make") is None,
    reason="no C compiler (cc/gcc/clang, or $CC) or no make on the PATH: the generated C cannot be built here",
)
I_TOL = 1e-6  # A: C and Python currents must agree to this at every step (as tests/test_codegen.py)
TEST_CFLAGS = "-O0 -fno-math-errno"  # correctness only: fastest to compile
#: Strong guide friction (as tests/test_model_file.py: FL's d RMS 52 -> 6 um with the true model).
FRICTION = {
    "coulomb_g": 1.0,
    "coulomb_d": 2.0,
    "stribeck_g": 0.3,
    "stribeck_d": 0.8,
    "v_stribeck": 2e-3,
    "viscous_g": 3.0,
    "viscous_d": 8.0,
    "v_reg": 2e-4,
}

TARGETS = [
    {"g": 0.02, "d": 0.03, "hold": 0.25},
    {"g": 0.018, "d": -0.03, "hold": 0.25},
    {"g": 0.02, "d": 0.0, "hold": 0.25},
]


def _friction_scenario(controller: dict, name: str) -> dict:
    return {
        "name": name,
        "seed": 4,
        "controller": controller,
        "plant": {"profile": "default", "effects": {"friction": {"enabled": True, **FRICTION}}},
        "start": {"g": 0.02, "d": -0.03},
        "targets": TARGETS,
    }


def _steady_rms(res) -> float:
    """RMS of the position-error vector over the settled parts of every target [m]."""
    ms = [t.rms_error_g_m**2 + t.rms_error_d_m**2 for t in res.metrics.targets]
    return float(np.sqrt(np.mean(ms)))


@pytest.fixture(scope="module")
def friction_file(tmp_path_factory):
    f = tmp_path_factory.mktemp("model") / "friction.yaml"
    dump_yaml(f, {"effects": {"friction": {"enabled": True, **FRICTION}}})
    return f


def test_diagnosis_plant_file_loads_as_model_file(tmp_path):
    """``maglev diagnose``'s model.yaml: constants in mismatch.overrides, every effect listed, rig keys beside."""
    f = tmp_path / "model.yaml"
    effects = {n: {"enabled": False} for n in EFFECTS}
    effects["friction"] = {"enabled": True, **FRICTION}
    effects["amplifier_lag"] = {"enabled": True, "bandwidth_hz": 800.0, "delay_samples": 1}
    plant = {
        "profile": "default",
        "mismatch": {"relative": {"C1": 0.0}, "overrides": {"C1": 13.0, "xi0": 0.0}},
        "process_noise": {"g": 0.05, "d": 0.02},
        "delay_samples": 1,
        "effects": effects,
    }
    dump_yaml(f, plant)
    cm = load_controller_model(f)
    assert cm.params.C1 == 13.0 and cm.params.xi0 == 0.0 and cm.effects == ("friction",)
    assert cm.delay_samples == 2  # the lag's transport delay plus the loop's computation delay
    nmpc = NMPC(NMPCSettings(model=str(f), delay_samples=1))
    assert nmpc.settings.delay_samples == 3 and nmpc.params.C1 == 13.0
    # a key the plant file does not have is refused with the file and the key
    dump_yaml(f, {**plant, "mismatch": {"overides": {"C1": 13.0}}})
    with pytest.raises(ConfigError, match=r"model\.yaml: mismatch\.overides: unknown key"):
        load_controller_model(f)


def test_missing_or_bad_model_file_is_one_line_naming_file_and_key(tmp_path):
    sc = _friction_scenario({"type": "nmpc", "model": str(tmp_path / "nope.yaml")}, "missing")
    with pytest.raises(ConfigError) as err:
        scenario_from_dict(sc, source="sc.yaml")
    msg = str(err.value)
    assert "\n" not in msg and "controller.model" in msg and "nope.yaml" in msg
    bad = tmp_path / "bad.yaml"
    dump_yaml(bad, {"C1": 14.0, "effects": {"friction": {"enabled": True, "coulomb_q": 1.0}}})
    with pytest.raises(ConfigError, match=r"bad\.yaml: effects: .*coulomb_q"):
        NMPC(NMPCSettings(model=str(bad)))


def test_nmpc_with_the_true_friction_model_holds_better(friction_file):
    """Strong friction on the rig: steady RMS with the true model file vs blind (measured 29.0 -> 6.9 um)."""
    rms = {}
    for label, ctrl in (("blind", {"type": "nmpc"}), ("model", {"type": "nmpc", "model": str(friction_file)})):
        res = run_scenario(_friction_scenario(ctrl, f"friction_nmpc_{label}"), progress=False, figures=False)
        assert res.metrics.all_settled and res.metrics.stop_hits == 0 and res.metrics.fallbacks == 0
        rms[label] = _steady_rms(res)
    assert rms["model"] < 0.5 * rms["blind"], rms


@needs_cc
def test_nmpc_c_backend_with_a_model_file_matches_python(friction_file):
    """The effects are symbolic in the step: the compiled C step agrees with the Python one to 1e-6 A."""
    from maglev_ocp.codegen.backend import build_c_controller

    sc = scenario_from_dict(
        {**_friction_scenario({"type": "nmpc", "model": str(friction_file)}, "friction_c"), "targets": TARGETS[:1]}
    )
    py = run_scenario(sc, progress=False, figures=False)
    ctrl = build_c_controller(
        "nmpc", sc.controller.settings, sc.controller_model_params(), cflags=TEST_CFLAGS, progress=False
    )
    c = run_scenario(sc, controller=ctrl, progress=False, figures=False)
    assert ctrl.backend == "c" and ctrl.model is not None and ctrl.model.effects == ("friction",)
    assert len(c.columns["t"]) == len(py.columns["t"]) == round((HOVER + 0.25) / k.Ts)
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(py.columns[col] - c.columns[col])) <= I_TOL
    assert np.max(np.abs(py.columns["d_hat"] - c.columns["d_hat"])) <= 1e-9
    assert py.metrics.all_settled
