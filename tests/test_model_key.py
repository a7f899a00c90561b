"""One way from a result to a controller: ``controller: {model: FILE}`` for every controller, paths from the
scenario file's folder, the old ``controller_params.file`` deprecated, a model file where a parameter file is
expected refused with what to write."""

from __future__ import annotations

import pytest

from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.errors import ConfigError
from maglev_ocp.params import NOMINAL, load_params, model_file_instruction, write_model_file
from maglev_ocp.scenario import load_scenario

SCENARIO = """name: t
controller: {{type: {ctype}, model: {model}}}
targets:
  - {{g: 0.020, d: 0.0, hold: 0.2}}
"""


@pytest.fixture
def layout(tmp_path, monkeypatch):
    """A scenario in sub/ naming model.yaml beside it; the working directory elsewhere (no model.yaml there)."""
    sub = tmp_path / "sub"
    sub.mkdir()
    write_model_file(sub / "model.yaml", NOMINAL.with_(C3=33.0), written_by="test")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    return sub


@pytest.mark.parametrize("ctype", ["fl", "nmpc", "pid"])
def test_every_controller_takes_the_model_key_relative_to_the_scenario(layout, ctype):
    (layout / "sc.yaml").write_text(SCENARIO.format(ctype=ctype, model="model.yaml"))
    sc = load_scenario(layout / "sc.yaml")
    path = sc.controller.settings.model
    assert load_controller_model(path).params.C3 == 33.0  # the file beside the scenario, not in the cwd


def test_the_pid_uses_the_model_files_constants(layout):
    from maglev_ocp.controllers.pid import PIDController, PIDSettings

    ctrl = PIDController(NOMINAL, PIDSettings(model=str(layout / "model.yaml")))
    assert ctrl.params.C3 == 33.0 and ctrl.params.C1 == NOMINAL.C1


def test_a_missing_model_file_names_the_scenario_and_the_rule(layout):
    (layout / "sc.yaml").write_text(SCENARIO.format(ctype="fl", model="nope.yaml"))
    with pytest.raises(ConfigError, match=r"controller\.model.*no such model file.*scenario"):
        load_scenario(layout / "sc.yaml")


def test_controller_params_file_still_works_with_a_deprecation_warning(layout):
    (layout / "sc.yaml").write_text(
        "name: t\ncontroller: {type: fl}\ncontroller_params: {file: model.yaml}\n"
        "targets:\n  - {g: 0.020, d: 0.0, hold: 0.2}\n"
    )
    with pytest.warns(FutureWarning, match=r"controller: \{model: model.yaml\}"):
        sc = load_scenario(layout / "sc.yaml")
    assert sc.controller_model_params().C3 == 33.0


def test_both_keys_at_once_are_refused(layout):
    (layout / "sc.yaml").write_text(
        "name: t\ncontroller: {type: fl, model: model.yaml}\ncontroller_params: {file: model.yaml}\n"
        "targets:\n  - {g: 0.020, d: 0.0, hold: 0.2}\n"
    )
    with pytest.raises(ConfigError, match="once"):
        load_scenario(layout / "sc.yaml")


def test_a_model_file_with_effects_as_a_parameter_file_says_what_to_write(tmp_path):
    write_model_file(
        tmp_path / "model.yaml", NOMINAL, effects={"friction": {"enabled": True, "coulomb_d": 0.5}}, written_by="t"
    )
    with pytest.raises(ConfigError, match=r"controller: \{model: model.yaml\}"):
        load_params(tmp_path / "model.yaml")
    cm = load_controller_model(tmp_path / "model.yaml")
    assert cm.effects == ("friction",)


def test_the_model_file_header_prints_the_one_instruction(tmp_path):
    write_model_file(tmp_path / "model.yaml", NOMINAL, written_by="t")
    assert model_file_instruction("model.yaml") in (tmp_path / "model.yaml").read_text()


def test_the_scenario_hands_every_consumer_the_model_files_constants(layout):
    """The compiled loops and the analysis take ``controller_model_params()``: the model file's constants too."""
    (layout / "sc.yaml").write_text(SCENARIO.format(ctype="pid", model="model.yaml"))
    assert load_scenario(layout / "sc.yaml").controller_model_params().C3 == 33.0
