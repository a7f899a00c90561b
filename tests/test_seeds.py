"""The seed registry keeps validation honest: held-out seeds stay out of the development set."""

from __future__ import annotations

import re
from pathlib import Path

from seeds import DEVELOPMENT_SEEDS, FRESH_FLOOR, VALIDATION_SEEDS, fresh_seed, is_held_out

TESTS = Path(__file__).resolve().parent


def test_validation_seeds_are_held_out_and_distinct():
    assert len(set(VALIDATION_SEEDS.values())) == len(VALIDATION_SEEDS)
    for label, seed in VALIDATION_SEEDS.items():
        assert is_held_out(seed), label


def test_fresh_seeds_are_outside_the_registry_and_follow_the_code_version():
    a, b = fresh_seed("rig_selfcheck", "abc"), fresh_seed("rig_selfcheck", "abd")
    assert a == fresh_seed("rig_selfcheck", "abc")  # a run can be repeated
    assert a != b and a != fresh_seed("library_selfcheck", "abc")
    for s in (a, b):
        assert s >= FRESH_FLOOR and s < 2**31 and is_held_out(s) and s not in VALIDATION_SEEDS.values()


def test_no_test_draws_from_a_validation_seed_by_its_number():
    """Validation seeds are used through the registry only, so a spent one cannot linger under another name."""
    numbers = {str(s) for s in VALIDATION_SEEDS.values()}
    for path in TESTS.glob("test_*.py"):
        found = set(re.findall(r"\b\d{5,}\b", path.read_text())) & numbers
        assert not found, (path.name, found)


def test_the_tests_literal_seeds_are_registered():
    """Every seed a test passes by number (``seed=N``, ``"seed": N``, ``SeedSequence(N)``) is in the development
    registry: a new test draw from an unregistered seed would make that seed look held out when it is not."""
    pat = re.compile(r"(?:\bseed\s*=\s*|[\"']seed[\"']\s*:\s*|SeedSequence\()(\d+)\b")
    for path in TESTS.glob("test_*.py"):
        for m in pat.finditer(path.read_text()):
            assert int(m.group(1)) in DEVELOPMENT_SEEDS, (path.name, m.group(0))
