"""The verdict as a type: its one text form, the sets it names, what a guard's drop leaves."""

from __future__ import annotations

import pytest

from maglev_ocp.diagnosis.selftest import canonical, same_set
from maglev_ocp.diagnosis.verdict import EffectSets, Verdict


@pytest.mark.parametrize(
    ("text", "slots", "named", "unexplained"),
    [
        ("none", (), False, False),
        ("unexplained", (), False, True),
        ("cogging", (("cogging",),), True, False),
        ("friction|eddy_drag", (("friction", "eddy_drag"),), True, False),
        ("cogging+friction", (("cogging",), ("friction",)), True, False),
        ("end_effect|saturation+friction", (("end_effect", "saturation"), ("friction",)), True, False),
    ],
)
def test_the_text_form_parses_to_slots_and_back(text, slots, named, unexplained):
    """Each report form parses to the slots written out by hand and prints back to the same text."""
    v = EffectSets.parse(text)
    assert v.slots == slots and v.named is named and v.unexplained is unexplained
    assert str(v) == text
    assert EffectSets.parse(str(v)) == v


def test_effects_names_and_head():
    """The chosen effects are the slots' first members; the names include the alternatives; a single slot is
    scored by its first member."""
    v = EffectSets.parse("end_effect|saturation+friction")
    assert v.effects == ("end_effect", "friction")
    assert v.names == ("end_effect", "saturation", "friction")
    assert EffectSets.parse("friction|eddy_drag").head == "friction"
    assert EffectSets.parse("cogging+friction").head == "cogging+friction"
    assert EffectSets.parse("none").head == "none"


def test_dropping_effects():
    """A guard's drop: a member of a single slot leaves the others; an effect of a set leaves the rest; nothing
    left is unexplained."""
    assert str(EffectSets.parse("amplifier_lag|friction").without(["amplifier_lag"])) == "friction"
    assert str(EffectSets.parse("cogging+amplifier_lag").without(["amplifier_lag"])) == "cogging"
    assert str(EffectSets.parse("amplifier_lag").without(["amplifier_lag"])) == "unexplained"
    assert EffectSets.parse("none").without(["cogging"]) == EffectSets.none()


def test_canonical_order_and_same_set():
    """A set of plain effects is compared in library order; a confusable slot is never the same as a set."""
    assert canonical("friction+cogging") == canonical("cogging+friction")
    assert same_set("friction+cogging", "cogging+friction")
    assert not same_set("cogging|friction", "cogging+friction")
    assert canonical("cogging|friction") == "cogging|friction"


def test_malformed_slots_are_refused():
    """An empty slot, a name with a separator in it, or an unexplained verdict with effects is not a verdict."""
    for bad in ((), ("a+b",)), ((("a|b",),)):
        with pytest.raises(ValueError):
            EffectSets(bad)
    with pytest.raises(ValueError):
        EffectSets((("cogging",),), unexplained=True)
    with pytest.raises(ValueError):
        EffectSets.parse("cogging++friction")


def test_a_verdict_built_from_text_reads_as_that_text():
    """``Verdict("a|b", ...)`` holds the parsed sets; ``verdict`` is the report's text."""
    v = Verdict("friction|eddy_drag", ["friction", "eddy_drag"], True, [])
    assert v.sets == EffectSets.of([["friction", "eddy_drag"]]) and v.verdict == "friction|eddy_drag" and v.named


@pytest.mark.parametrize(
    ("text", "slots"),
    [
        ("cogging+unexplained", (("cogging",),)),
        ("cogging+friction+unexplained", (("cogging",), ("friction",))),
        ("friction|eddy_drag+unexplained", (("friction", "eddy_drag"),)),
    ],
)
def test_a_partly_explained_verdict_round_trips(text, slots):
    """``a+unexplained``: the effects found and a located gap they leave; it names its effects only."""
    v = EffectSets.parse(text)
    assert v.slots == slots and v.gap and v.named and not v.unexplained
    assert str(v) == text and EffectSets.parse(str(v)) == v
    assert "unexplained" not in v.names
    assert v.partly(False) == EffectSets(slots)


def test_partly_explained_is_refused_where_it_means_nothing():
    """A gap flag needs effects; ``unexplained`` is the last part only; ``none`` with a gap is unexplained."""
    with pytest.raises(ValueError):
        EffectSets((), gap=True)
    with pytest.raises(ValueError):
        EffectSets.parse("unexplained+cogging")
    assert EffectSets.none().partly() == EffectSets.gap_unexplained()
    assert str(EffectSets.parse("cogging+friction+unexplained").without(["friction"])) == "cogging+unexplained"


def test_partly_explained_scores_right_for_the_named_effects_only():
    """The self-checks: a right set plus a located gap is right; a partly explained verdict never matches
    ``unexplained`` or ``none``, and a wrong set with a gap stays wrong."""
    assert same_set("cogging+unexplained", "cogging")
    assert same_set("friction+cogging+unexplained", "cogging+friction")
    assert not same_set("cogging+unexplained", "unexplained")
    assert not same_set("cogging+unexplained", "none")
    assert not same_set("saturation+unexplained", "cogging")
    assert not same_set("cogging", "cogging+unexplained")
    assert canonical("friction+cogging+unexplained") == "cogging+friction+unexplained"
