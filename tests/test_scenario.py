"""Scenario files: validation with one-line errors naming file and key, resolution, random targets."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from maglev_ocp import constants as k
from maglev_ocp.errors import ConfigError, UserError
from maglev_ocp.scenario import CONTROLLERS, load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml"))

GOOD = {
    "name": "t",
    "seed": 3,
    "controller": {"type": "fl", "omega_g": 90},
    "plant": {"profile": "default"},
    "targets": [{"g": 0.020, "d": 0.0, "hold": 0.3}, {"g": 0.016, "d": 0.045, "hold": 0.3}],
}


def _write(tmp_path: Path, data, name: str = "s.yaml") -> Path:
    p = tmp_path / name
    p.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return p


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_scenarios_validate(path):
    sc = load_scenario(path)
    assert sc.name == path.stem
    for t in sc.target_list():
        assert k.g_envelope[0] <= t.g <= k.g_envelope[1] and k.d_envelope[0] <= t.d <= k.d_envelope[1]


def test_shipped_scenarios_cover_the_issue():
    names = {p.stem for p in SHIPPED}
    for c in ("fl", "nmpc", "pid"):
        assert f"tour_{c}" in names
    for c in ("fl", "nmpc"):
        for g in (15, 20, 25):
            assert f"traverse_{g}mm_{c}" in names
        for n in ("gap_steps", "cogging_aware", "cogging_blind", "mismatch", "random"):
            assert f"{n}_{c}" in names


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"bogus": 1}, "bogus: unknown key"),
        ({"controller": {"type": "fl", "omega_g": "fast"}}, "controller.omega_g"),
        ({"controller": {"type": "fl", "horizon": 20}}, "controller.horizon: unknown key"),
        ({"controller": {"type": "nmpc", "horizon": 2}}, "controller.horizon"),
        ({"controller": {"type": "lqr"}}, "controller.type"),
        ({"controller": {"type": "fl", "backend": "fortran"}}, "controller.backend"),
        ({"targets": [{"g": 0.030, "d": 0.0, "hold": 0.3}]}, "targets.0.g"),
        ({"targets": [{"g": 0.020, "d": -0.07, "hold": 0.3}]}, "targets.0.d"),
        ({"targets": [{"g": 0.020, "d": 0.0, "hold": -1}]}, "targets.0.hold"),
        ({"targets": [{"g": 0.020, "d": 0.0}]}, "targets.0.hold: required key missing"),
        ({"targets": []}, "needs 'targets' or 'random_targets'"),
        ({"plant": {"profile": "nope"}}, "plant.profile"),
        ({"plant": {"process_noise": {"x": 1}}}, "plant.process_noise.x: unknown key"),
        ({"plant": {"quantization": {"resolution": -1}}}, "plant.quantization.resolution"),
        ({"plant": {"params": {"C1": -1.0}}}, "plant.params.C1"),
        ({"controller_params": {"C2": "x"}}, "controller_params.C2"),
        ({"controller_params": {"file": "missing.yaml"}}, "controller_params.file"),
        ({"random_targets": {"n": 0}}, "random_targets.n"),
        ({"random_targets": {"n": 2, "g": [0.010, 0.02]}}, "random_targets.g"),
        ({"seed": -1}, "seed"),
        ({"tolerance": 0}, "tolerance"),
        ({"start": {"g": 0.005}}, "start.g"),
        ({"reference": {"current_fraction": 1.5}}, "reference.current_fraction"),
    ],
)
def test_bad_scenarios_name_file_and_key(tmp_path, change, key):
    data = {**GOOD, **change}
    path = _write(tmp_path, data)
    with pytest.raises(ConfigError) as ei:
        load_scenario(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(str(path)), msg
    assert key in msg, msg


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"targets": [{"g": 0.020, "d": 0.0, "hold": NAN}]}, "targets.0.hold"),
        ({"controller": {"type": "fl", "omega_g": INF}}, "controller.omega_g"),
        ({"controller": {"type": "nmpc", "soft_gap": {"g_min": NAN}}}, "controller.soft_gap.g_min"),
        ({"plant": {"process_noise": {"g": NAN}}}, "plant.process_noise.g"),
        ({"plant": {"params": {"C2": -INF}}}, "plant.params.C2"),
        ({"controller_params": {"C1": NAN}}, "controller_params.C1"),
        ({"reference": {"ramp_fraction": NAN}}, "reference.ramp_fraction"),
        ({"start": {"g": INF}}, "start.g"),
        ({"checks": {"max_settle_time_s": INF}}, "checks.max_settle_time_s"),
    ],
)
def test_nan_and_inf_are_refused_as_such(tmp_path, change, key):
    """NaN/inf anywhere: the key and "NaN/inf is not allowed", not a misleading range message."""
    with pytest.raises(ConfigError) as ei:
        load_scenario(_write(tmp_path, {**GOOD, **change}))
    msg = str(ei.value)
    assert f"{key}: NaN/inf is not allowed" in msg, msg
    assert "should be" not in msg, msg


@pytest.mark.parametrize(
    ("change", "key", "what"),
    [
        # physically impossible parameters (C3 = C4 = 0 gave i_d,eq = inf and NaN currents)
        ({"controller_params": {"C3": 0, "C4": 0}}, "controller_params.C3", "greater than 0"),
        ({"plant": {"params": {"C4": 0.0}}}, "plant.params.C4", "greater than 0"),
        ({"plant": {"params": {"Mv": 0.0}}}, "plant.params.Mv", "greater than 0"),
        ({"plant": {"params": {"ell": -1e-3}}}, "plant.params.ell", "greater than 0"),
        ({"plant": {"params": {"xi0": -1.0}}}, "plant.params.xi0", "greater than or equal to 0"),
        ({"plant": {"mismatch": {"overrides": {"C3": 0.0}}}}, "plant.mismatch.overrides.C3", "greater than 0"),
        # positive, but no real hover current somewhere in the envelope (seed eq. (8))
        ({"controller_params": {"C3": 1e-3, "C4": 900.0}}, "controller_params: C2, C3, C4", "no current holds"),
        ({"plant": {"params": {"C3": 3.0}}}, "plant.params: C2, C3, C4", "g = 15.0 mm"),
        ({"plant": {"params": {"xi0": 900.0, "ell": 0.5}}}, "plant.params: C2, C3, C4, xi0, ell", "no real root"),
        # settings that cannot work together
        (
            {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.026, "g_max": 0.014}}},
            "controller.soft_gap",
            "must be below g_max",
        ),
        (
            {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.018, "g_max": 0.029}}},
            "targets[1].g",
            "outside controller.soft_gap",
        ),
        ({"controller": {"type": "fl", "i_amp_max": 1.0}}, "controller.i_amp_max", "needs to hover at start"),
        ({"controller": {"type": "pid", "i_axis_max": 2.0}}, "controller.i_axis_max", "per axis"),
        ({"controller": {"type": "nmpc", "current_limit": 2.5}}, "controller.current_limit", "targets[1]"),
        (
            {"plant": {"current_limits": {"enabled": True, "amplitude": 2.0}}},
            "plant.current_limits.amplitude",
            "the rig needs",
        ),
        ({"plant": {"stops": {"enabled": True, "g": [0.017, 0.030]}}}, "targets[1].g", "plant.stops.g"),
        ({"plant": {"stops": {"enabled": True, "d": [-0.01, 0.01]}}}, "targets[1].d", "plant.stops.d"),
        (
            {
                "random_targets": {"n": 3, "g": [0.015, 0.025]},
                "plant": {"stops": {"enabled": True, "g": [0.0155, 0.03]}},
            },
            "random_targets.g",
            "plant.stops.g",
        ),
        ({"targets": [{"g": 0.020, "d": 0.0, "hold": 0.04}]}, "targets[0].hold", "checks.min_settled_s"),
    ],
)
def test_settings_that_cannot_work_are_refused(tmp_path, change, key, what):
    """Impossible parameters and settings that cannot work together: one line naming the key and what is wrong."""
    path = _write(tmp_path, {**GOOD, **change})
    with pytest.raises(ConfigError) as ei:
        load_scenario(path)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(str(path)), msg
    assert key in msg and what in msg, msg


def _assert_kept(asked: dict, loaded: dict, where: str = "") -> None:
    """Every value asked for is the loaded one (nested mappings compared key by key)."""
    for key, v in asked.items():
        got = loaded[key]
        if isinstance(v, dict):
            _assert_kept(v, got if isinstance(got, dict) else got.model_dump(), f"{where}{key}.")
        else:
            assert (list(got) if isinstance(got, tuple) else got) == v, (f"{where}{key}", got, v)


#: Settings just inside what can work, each with its twin just across the edge (the checks must refuse the twin).
EDGES = [
    # hover at the 16 mm, d = 45 mm target needs 2.977 A (nominal constants)
    ({"controller": {"type": "fl", "i_amp_max": 3.0}}, {"controller": {"type": "fl", "i_amp_max": 2.95}}),
    # a soft-gap band holding both target gaps (16 and 20 mm), and one that leaves the 20 mm target out
    (
        {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.0155, "g_max": 0.0205}}},
        {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.0155, "g_max": 0.0195}}},
    ),
    # a band that misses the targets is fine while it is switched off (stride 0), refused when it is on
    (
        {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.018, "g_max": 0.029, "stride": 0}}},
        {"controller": {"type": "nmpc", "soft_gap": {"g_min": 0.018, "g_max": 0.029}}},
    ),
    # stops just outside the targets, and one that cuts the d = 0 target off
    (
        {"plant": {"stops": {"enabled": True, "g": [0.0155, 0.0205], "d": [-0.001, 0.046]}}},
        {"plant": {"stops": {"enabled": True, "g": [0.0155, 0.0205], "d": [0.001, 0.046]}}},
    ),
    # a tiny positive C4 is a constant; a negative one is not
    ({"plant": {"params": {"C4": 1e-6}}}, {"plant": {"params": {"C4": -1e-6}}}),
]


@pytest.mark.parametrize(("ok", "over"), EDGES, ids=["i_amp_max", "soft_gap", "soft_gap_off", "stops", "C4"])
def test_settings_at_the_edge_still_work(tmp_path, ok, over):
    """The checks refuse only what cannot work: each setting just inside the edge loads with its value kept,
    and its twin just across the edge is refused with one line naming the file."""
    sc = load_scenario(_write(tmp_path, {**GOOD, **ok}))
    section, values = next(iter(ok.items()))
    obj = getattr(sc, section)
    _assert_kept(values, obj.to_dict() if hasattr(obj, "to_dict") else obj.model_dump())
    path = _write(tmp_path, {**GOOD, **over}, "over.yaml")
    with pytest.raises(ConfigError) as ei:
        load_scenario(path)
    assert "\n" not in str(ei.value) and str(path) in str(ei.value), str(ei.value)


def test_yaml_that_does_not_parse(tmp_path):
    path = _write(tmp_path, "name: [unclosed\n")
    with pytest.raises(ConfigError, match="does not parse"):
        load_scenario(path)
    path = _write(tmp_path, "- just a list\n", "l.yaml")
    with pytest.raises(ConfigError, match="mapping"):
        load_scenario(path)


def test_controller_settings_are_validated_by_the_controllers_model():
    sc = scenario_from_dict({**GOOD, "controller": {"type": "nmpc", "horizon": 25}})
    assert sc.controller.settings.horizon == 25
    sc = scenario_from_dict(GOOD)
    assert sc.controller.settings.omega_g == 90
    assert sc.controller.to_dict()["type"] == "fl"


def test_missing_controller_module_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(CONTROLLERS, "pid", ("controllers.not_there", "X", "Y"))
    with pytest.raises(UserError, match="not available"):
        scenario_from_dict({**GOOD, "controller": {"type": "pid"}}, "s.yaml")


def test_controller_params_belief(tmp_path):
    from maglev_ocp.params import NOMINAL

    sc = scenario_from_dict({**GOOD, "controller_params": {"cogging": False, "C1": 15.0}})
    p = sc.controller_model_params()
    assert p.xi0 == 0.0 and p.C1 == 15.0 and p.C2 == NOMINAL.C2
    NOMINAL.with_(C3=30.0).save(tmp_path / "p.yaml")
    path = _write(tmp_path, {**GOOD, "controller_params": {"file": "p.yaml"}})  # relative to the scenario
    assert load_scenario(path).controller_model_params().C3 == 30.0


def test_plant_block_reaches_the_plant_config():
    sc = scenario_from_dict(
        {**GOOD, "plant": {"profile": "ideal", "params": {"C2": 800.0}, "process_noise": {"g": 0.1}}}
    )
    cfg = sc.plant_config()
    assert cfg.profile == "ideal" and cfg.process_noise.g == 0.1 and not cfg.quantization.enabled
    assert sc.plant_params().C2 == 800.0


def test_random_targets_are_seeded_and_inside_the_envelope():
    data = {**GOOD, "random_targets": {"n": 20, "hold": 0.3}}
    a = scenario_from_dict(data).target_list()
    b = scenario_from_dict(data).target_list()
    c = scenario_from_dict({**data, "seed": 4}).target_list()
    assert a == b and a != c
    assert len(a) == 22 and a[:2] == scenario_from_dict(GOOD).target_list()
    for t in a[2:]:
        assert k.g_envelope[0] <= t.g <= k.g_envelope[1] and k.d_envelope[0] <= t.d <= k.d_envelope[1]
        assert abs(t.g / 1e-5 - round(t.g / 1e-5)) < 1e-6  # rounded to the resolution
    own = {**data, "random_targets": {"n": 5, "seed": 99}}
    assert scenario_from_dict(own).target_list() == scenario_from_dict({**own, "seed": 5}).target_list()


def test_resolved_is_complete_and_loads_back(tmp_path):
    sc = scenario_from_dict({**GOOD, "random_targets": {"n": 3}, "controller_params": {"cogging": False}})
    res = sc.resolved()
    assert len(res["targets"]) == 5 and "random_targets" not in res
    assert res["controller_params"]["xi0"] == 0.0
    assert res["controller"]["omega_d"] == sc.controller.settings.omega_d
    path = _write(tmp_path, res)
    again = load_scenario(path)
    assert again.resolved() == res
    assert again.key() == sc.key()


def test_with_seed_keeps_everything_else():
    sc = scenario_from_dict(GOOD, "x.yaml", "/tmp")
    s2 = sc.with_seed(11)
    assert s2.seed == 11 and sc.seed == 3 and s2.source == "x.yaml" and s2.root_dir == "/tmp"
    assert s2.controller.settings == sc.controller.settings


def test_cli_bad_scenario_exits_2_with_one_line(tmp_path):
    bad = _write(tmp_path, {**GOOD, "targets": [{"g": 0.040, "d": 0.0, "hold": 0.3}]})
    good = _write(tmp_path, GOOD, "good.yaml")
    out = tmp_path / "out"
    r = subprocess.run(
        [sys.executable, "-m", "maglev_ocp", "run", str(good), str(bad), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "targets.0.g" in lines[0] and str(bad) in lines[0]
    assert "Traceback" not in r.stderr
    assert not out.exists()  # validated before anything runs


def test_the_controller_key_follows_the_model_files_content_not_its_path(tmp_path):
    """A model file rewritten between two runs (same path, same constants, other effects) must not reuse the
    controller built from its old content (the runner's controller cache is keyed by :meth:`Scenario.key`)."""
    from maglev_ocp.params import NOMINAL, model_file_text

    model = tmp_path / "model.yaml"
    model.write_text(model_file_text(NOMINAL, written_by="test"))
    data = {**GOOD, "controller": {"type": "fl", "model": str(model)}}
    before = scenario_from_dict(data).key()
    params_before = scenario_from_dict(data).controller_model_params()
    assert scenario_from_dict(data).key() == before  # same content, same key
    fr = {"friction": {"enabled": True, "coulomb_g": 0.3, "coulomb_d": 0.2}}
    model.write_text(model_file_text(NOMINAL, fr, written_by="test"))
    after = scenario_from_dict(data).key()
    assert after != before
    assert scenario_from_dict(data).controller_model_params() == params_before  # only the effects changed
