"""A model file the diagnosis cannot vouch for says so in the file (brief: a result that cannot be trusted is
flagged in the file itself), and every loader of it warns."""

from __future__ import annotations

import warnings

import pytest

from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.diagnosis.stages.quantify import TRUST_PRIOR_SDS, model_trust, trust_marked
from maglev_ocp.diagnosis.verdict import EffectSets
from maglev_ocp.output import dump_yaml
from maglev_ocp.params import NOMINAL, UntrustedModelWarning
from maglev_ocp.plant import load_plant_config

SD = {"C1": 0.1, "C2": 0.1, "C3": 0.1, "C4": 0.5}


def test_a_constant_far_outside_the_prior_is_named():
    c1 = NOMINAL.C1 * 0.2  # -80 %: 8 prior sd at 10 %
    why = model_trust(EffectSets.of([["friction"]]), {**NOMINAL.as_dict(), "C1": c1}, NOMINAL, SD)
    assert len(why) == 1 and why[0].startswith("C1 = ") and "-80 %" in why[0], why
    # within the trusted band (3 sd at 10 %: -30 %): nothing against it
    ok = {**NOMINAL.as_dict(), "C1": NOMINAL.C1 * (1 - 0.1 * (TRUST_PRIOR_SDS - 1))}
    assert model_trust(EffectSets.of([["friction"]]), ok, NOMINAL, SD) == []


@pytest.mark.parametrize("text", ["unexplained", "cogging+unexplained"])
def test_a_gap_the_library_does_not_account_for_is_named(text):
    why = model_trust(EffectSets.parse(text), NOMINAL.as_dict(), NOMINAL, SD)
    assert len(why) == 1 and why[0].startswith(f"verdict {text}"), why


def test_an_untrusted_model_file_warns_as_model_and_as_plant(tmp_path):
    f = tmp_path / "model.yaml"
    data = trust_marked({"mismatch": {"overrides": {"C1": 3.0}}, "effects": {}}, ["C1 far off"])
    dump_yaml(f, data)
    for load in (load_controller_model, load_plant_config):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            load(f)
        assert any(issubclass(x.category, UntrustedModelWarning) and "C1 far off" in str(x.message) for x in w), load
