"""Leave-one-law-out and the self-checks' summaries (issue 27): the exclusion setting, the matched-members
table, the targets / per-effect / timing figures computed from a hand-made result with known counts, and the
validation page's generated part."""

from __future__ import annotations

import json
import math

import pytest
from pydantic import ValidationError

from maglev_ocp.diagnosis.library import family_specs
from maglev_ocp.diagnosis.selftest import Case
from maglev_ocp.diagnosis.selftest_lolo import (
    MATCHED,
    lolo_document,
    lolo_markdown,
    matched_table,
    reload_document,
    scenario,
)
from maglev_ocp.diagnosis.selftest_summary import (
    false_claim,
    per_effect,
    section_markdown,
    target_lines,
    targets,
    timings,
)
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.stages.claims import most_flexible
from maglev_ocp.rigsim import LAWS, LIBRARY_EFFECTS


# ------------------------------------------------------------------------------------------ exclusion setting
def test_exclude_laws_rejects_an_unknown_effect_with_the_allowed_ones():
    with pytest.raises(ValidationError) as e:
        DiagnoseSettings(exclude_laws={"end_efect": ["two ends"]})
    msg = str(e.value)
    assert "exclude_laws" in msg and "unknown effect 'end_efect'" in msg
    assert "end_effect" in msg and "saturation" in msg  # the allowed effects are named


def test_exclude_laws_rejects_an_unknown_member_with_the_allowed_ones():
    with pytest.raises(ValidationError) as e:
        DiagnoseSettings(exclude_laws={"end_effect": ["two ends", "one end"]})
    msg = str(e.value)
    assert "'one end'" in msg and "'two ends'" not in msg.split("allowed")[0]
    assert "spline profile, ripple harmonics" in msg  # the allowed members are named


def test_excluded_members_are_absent_from_the_candidate_library():
    full = family_specs()
    assert {e: [m.law for m in ms] for e, ms in DiagnoseSettings().families().items()} == {
        e: [m.law for m in ms] for e, ms in full.items()
    }
    every_lag = ["default", "fractional", "second"]
    st = DiagnoseSettings(exclude_laws={"end_effect": ["default", "two ends"], "amplifier_lag": every_lag})
    fam = st.families()
    laws = [m.law for m in fam["end_effect"]]
    assert "two ends" not in laws and "default" not in laws
    assert laws == [m.law for m in full["end_effect"] if m.law not in ("default", "two ends")]
    assert "amplifier_lag" not in fam  # every member left out: no candidate
    assert [m.law for m in fam["saturation"]] == [m.law for m in full["saturation"]]  # others untouched
    # the claim guard's "full freedom" member comes from the filtered library, not the whole one
    assert "end_effect" in {m.name for m in fam["end_effect"]}
    flex = most_flexible("end_effect", fam["end_effect"][0], fam)
    assert flex.law in laws
    wide = most_flexible("end_effect", full["end_effect"][0])
    assert wide.law not in ("default",)


# -------------------------------------------------------------------------------------- matched-members table
def test_matched_table_covers_every_first_rig_law_and_names_real_members():
    table = matched_table()
    rig = {(e, f) for e in LIBRARY_EFFECTS for f in LAWS[e].families}
    assert rig <= set(table)
    known = {e: {m.law for m in ms} for e, ms in family_specs().items()}
    for m in MATCHED:
        assert set(m.members) <= known[m.effect], m
        assert m.reason
    # the amplifier's transfer-function members have the rig's forms: they are left out, the library's first
    # order + whole samples stays
    assert all(table[("amplifier_lag", f)].members for f in LAWS["amplifier_lag"].families)
    assert all("default" not in table[("amplifier_lag", f)].members for f in LAWS["amplifier_lag"].families)
    assert "two ends" in table[("end_effect", "asymmetric")].members


def test_scenario_forces_the_family_and_pairs_it_with_another_effect():
    a = scenario("end_effect", "asymmetric", "single", 17)
    assert list(a["effects"]) == ["end_effect"] and a["effects"]["end_effect"]["family"] == "asymmetric"
    assert a["effects"]["end_effect"]["new_law"] is False
    b = scenario("saturation", "logistic", "pair", 17)
    assert len(b["effects"]) == 2 and b["effects"]["saturation"]["family"] == "logistic"
    assert all(n in LIBRARY_EFFECTS for n in b["effects"])
    assert scenario("saturation", "logistic", "pair", 17) == b  # seeded
    with pytest.raises(ValueError, match="single or pair"):
        scenario("saturation", "logistic", "triple", 1)


# ------------------------------------------------------------------------------- summaries of a known result
def _case(truth, verdict, right, seconds, kind=None, new=None, sizes=None):
    effects = {}
    if new is not None:
        effects = {e: {"family": "x", "new_law": new} for e in truth.split("+") if e not in ("none", "unexplained")}
        if truth == "unexplained":
            effects = {"cable": {"family": "spring", "new_law": new}}
    tp = {"kind": kind, "effects": effects} if kind else {"params": {}, "effects": {}, "extra": None}
    if sizes:
        tp["peak_force_n"] = {e: t for e, (t, _) in sizes.items()}
        tp["fitted"] = {"peak_force_n": {e: g for e, (_, g) in sizes.items()}}
    return {"truth": truth, "verdict": verdict, "right": right, "seconds": seconds, "truth_params": tp}


#: 10 rig datasets with known counts: new laws 3 of 4 right, old laws 2 of 2, out-of-library 1 of 2
#: unexplained, none 1 claim of 2; false claims on #4 (friction beside a right effect... named instead),
#: #6 (saturation on an out-of-library dataset) and #8 (a claim on none); sizes 2 of 3 within 20 %.
KNOWN = [
    _case("cogging", "cogging", True, 10.0, "single", True, {"cogging": (2.0, 2.2)}),
    _case("end_effect", "end_effect", True, 20.0, "single", True, {"end_effect": (1.0, 0.5)}),
    _case("friction+saturation", "friction+saturation", True, 30.0, "pair", True),
    _case("end_effect", "end_effect|saturation", False, 40.0, "single", True),
    _case("amplifier_lag", "amplifier_lag", True, 50.0, "single", False, {"amplifier_lag": (3.0, 3.1)}),
    _case("cogging+friction", "cogging+friction", True, 60.0, "pair", False),
    _case("unexplained", "saturation", False, 70.0, "out_of_library", False),
    _case("unexplained", "unexplained", True, 80.0, "out_of_library", True),
    _case("none", "friction", False, 90.0, "none"),
    _case("none", "none", True, 100.0, "none"),
]


def test_targets_on_a_hand_made_result_with_known_counts():
    t = {x.name: x for x in targets(KNOWN)}
    assert t["named set right, new laws"].count == "3 of 4" and t["named set right, new laws"].met is False
    assert t["named set right, old laws"].count == "2 of 2" and t["named set right, old laws"].met is True
    fc = t["an effect claimed that is not there"]
    assert fc.count == "3 of 10" and fc.value == pytest.approx(0.3) and fc.met is False
    assert t["out-of-library answered unexplained"].count == "1 of 2"
    assert t["out-of-library answered unexplained"].met is False
    assert t["effects claimed on none"].count == "1 of 2" and t["effects claimed on none"].met is False
    sz = t["fitted sizes within 20 % (right verdicts)"]
    assert sz.count == "2 of 3" and sz.met is False and sz.goal == "all"
    lines = target_lines(KNOWN)
    assert len(lines) == 6 and sum("NOT MET" in x for x in lines) == 5


def test_a_target_no_dataset_applies_to_is_not_counted_as_met():
    lib_only = [_case("cogging", "cogging", True, 1.0), _case("none", "none", True, 2.0)]
    t = {x.name: x for x in targets(lib_only)}
    assert t["named set right, new laws"].met is None and t["named set right, old laws"].met is None
    assert t["effects claimed on none"].met is True
    assert t["an effect claimed that is not there"].met is True


def test_per_effect_rows_and_false_claims_count_confusable_alternatives():
    rows = per_effect(KNOWN)
    assert rows["saturation"] == {"present": 1, "named_right": 1, "false_claims": 2, "missed": 0}
    assert rows["end_effect"] == {"present": 2, "named_right": 2, "false_claims": 0, "missed": 0}
    assert rows["friction"] == {"present": 2, "named_right": 2, "false_claims": 1, "missed": 0}
    assert rows["cogging"]["missed"] == 0 and rows["amplifier_lag"]["present"] == 1
    assert next(iter(rows)) == "cogging"  # library order
    assert false_claim(KNOWN[3]) and not false_claim(KNOWN[2]) and not false_claim(KNOWN[7])
    missed = per_effect([_case("cogging+friction", "cogging", False, 1.0, "pair", False)])
    assert missed["friction"] == {"present": 1, "named_right": 0, "false_claims": 0, "missed": 1}


def test_timings_median_p90_max():
    t = timings(KNOWN)
    assert t["n"] == 10 and t["median"] == pytest.approx(55.0) and t["max"] == pytest.approx(100.0)
    assert t["p90"] == pytest.approx(91.0)  # linear interpolation between 90 and 100
    assert timings([])["median"] is None


def test_section_markdown_shows_targets_rows_timings_and_sets():
    md = section_markdown("Known", {"cases": KNOWN, "command": "maglev diagnose selftest 10"})
    assert "### Known" in md and "`maglev diagnose selftest 10`" in md
    assert "| `saturation` | 1 | 1 | 2 | 0 |" in md
    assert "median 55.0 s, p90 91.0 s, max 100.0 s" in md
    assert "| `end_effect` | 2 | 1 | `end_effect` 1, `end_effect\\|saturation` 1 |" in md


# --------------------------------------------------------------------------------------------- lolo document
def _lolo_case(i, effect, family, verdict, right, tried=()):
    tp = {
        "left_out": {"effect": effect, "family": family},
        "kind": "single",
        "effects": {effect: {"family": family, "new_law": False}},
        "fitted": {"members_tried": list(tried)},
    }
    return Case(i, effect, tp, verdict, right, 0.5, 0.9, False, 12.0 + i, 1.0)


def test_lolo_document_counts_per_family_and_flags_an_excluded_member_fitted():
    table = matched_table()
    keys = [("end_effect", "asymmetric"), ("saturation", "exp")]
    cases = [
        _lolo_case(
            0, "end_effect", "asymmetric", "end_effect", True, ["end_effect/default", "end_effect/free profile"]
        ),
        _lolo_case(1, "end_effect", "asymmetric", "unexplained", False, ["end_effect/two ends"]),
        _lolo_case(2, "saturation", "exp", "saturation", True, ["amplifier_lag+saturation/default; knee"]),
        _lolo_case(3, "saturation", "exp", "saturation", True, ["amplifier_lag+saturation/default; field"]),
    ]
    doc = lolo_document(cases, table, keys, 2, 99, {"command": "python -m benchmarks.leave_one_law_out --n 2"})
    ee, sat = doc["rows"]
    assert ee["datasets"] == 2 and ee["right"] == 1 and ee["right_fraction"] == pytest.approx(0.5)
    assert ee["instead"] == {"end_effect -> unexplained": 1}
    assert ee["excluded_fitted"] == ["end_effect/two ends"]
    assert sat["right_fraction"] == 1.0 and sat["excluded_fitted"] == ["saturation/field"]  # a pair's law, split
    assert doc["summary"]["families_at_85pct"] == 1 and doc["summary"]["families_run"] == 2
    saved = json.loads(json.dumps(doc, default=float))
    assert reload_document(saved)["rows"] == saved["rows"]  # the table is recomputed from the cases alone
    assert doc["not_run"] == []  # every rig law has members to leave out (the amplifier's since issue 27 item 1)
    md = lolo_markdown(doc)
    assert "python -m benchmarks.leave_one_law_out --n 2" in md and "excluded members fitted" in md
    assert json.loads(json.dumps(doc, default=float))["seed"] == 99


def test_the_validation_page_is_regenerated_between_its_markers(tmp_path):
    from benchmarks.diagnosis_page import BEGIN, END, generated, rewrite

    (tmp_path / "results" / "prereg").mkdir(parents=True)
    (tmp_path / "results" / "prereg" / "issue27_result.json").write_text(json.dumps({"cases": KNOWN}))
    body = generated(tmp_path)
    assert "3 of 10" in body and "No result file yet." in body  # the other results are absent here
    page = f"# Page\n\nbefore\n\n{BEGIN}\n\nold figures\n{END}\n\nafter\n"
    new = rewrite(page, body)
    assert "old figures" not in new and "before" in new and "after" in new and new.count(BEGIN) == 1
    assert rewrite(new, body) == new  # idempotent
    assert not math.isnan(timings(KNOWN)["p90"])


@pytest.mark.parametrize(
    ("flag", "says"),
    [
        ("end_effect:one end", "unknown law member(s) ['one end']; allowed: ['default'"),
        ("end_efect:two ends", "unknown effect 'end_efect'; allowed: cogging"),
        ("end_effect", "expected EFFECT:MEMBER"),
    ],
)
def test_exclude_law_flag_refuses_bad_names_in_one_line(tmp_path, capsys, flag, says):
    from maglev_ocp.cli import main

    code = main(["diagnose", "selftest", "1", "--out", str(tmp_path / "o"), "--exclude-law", flag])
    err = capsys.readouterr().err.strip()
    assert code == 2 and says in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()  # refused before any work


@pytest.mark.slow
def test_an_excluded_member_is_never_fitted_in_a_diagnosis():
    """End to end on the independent rig (an asymmetric end effect, the members matched to it left out): the
    diagnosis fits the end effect's other members and never an excluded one."""
    from maglev_ocp.diagnosis.generate import GeneratorSettings
    from maglev_ocp.diagnosis.selftest import SelftestSettings
    from maglev_ocp.diagnosis.selftest_rig import run_rig_case

    left_out = list(matched_table()[("end_effect", "asymmetric")].members)
    st = SelftestSettings(
        n=1,
        seed=23,
        generator=GeneratorSettings(n_runs=3, run_duration=6.0),
        diagnose=DiagnoseSettings(simulate=False, exclude_laws={"end_effect": left_out}),
    )
    case = run_rig_case(0, "single", 23, st, scenario=scenario("end_effect", "asymmetric", "single", 23))
    tried = case.truth_params["fitted"]["members_tried"]
    assert "end_effect/default" in tried
    assert not [m for m in tried if m.split("/", 1)[1] in left_out and m.startswith("end_effect/")], tried
    assert all(law not in left_out for e, law in case.truth_params["fitted"]["laws"].items() if e == "end_effect")
