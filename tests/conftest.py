"""Shared pytest fixtures, the hypothesis profiles and the CI rule that no test is skipped quietly.

Tiers (see the README and ``make help``):

* default set (``pytest``): every capability, each test a few seconds;
* ``slow``: closed loops and statistical checks that still fit CI's budget (``make test`` runs them);
* ``long``: many-dataset self-checks and recovery tables (``make check-long``, never in CI), each writing its
  table under ``results/``.

Under ``CI=true`` a skipped test fails the run unless it is marked ``optional`` (a truly optional extra):
CI installs the compiler and every package the suite needs, so a skip there would hide a missing install step.
"""

from __future__ import annotations

import os

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

# Hypothesis: the same examples on every run (derandomized, a failure is replayed by re-running), no deadline
# (the machine is shared; speed belongs to benchmarks/). Each test's own ``max_examples`` is its fixed budget.
# ``HYPOTHESIS_PROFILE=explore`` draws new examples for a local hunt.
settings.register_profile(
    "ci", derandomize=True, deadline=None, print_blob=True, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("explore", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def _in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def _skip_fails(rep, what: str) -> None:
    """Turn the skipped report ``rep`` into a failure that keeps the skip's reason."""
    reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
    rep.outcome = "failed"
    rep.longrepr = f"{what} under CI=true, where nothing may be skipped: {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under ``CI=true`` turn a skip into a failure (unless the test is marked ``optional``)."""
    outcome = yield
    rep = outcome.get_result()
    if rep.skipped and _in_ci() and item.get_closest_marker("optional") is None and not hasattr(rep, "wasxfail"):
        _skip_fails(rep, "skipped")


@pytest.fixture(scope="session")
def model():
    """The shared symbolic model (built once per test session)."""
    from maglev_ocp.model import get_model

    return get_model()


@pytest.fixture(scope="session")
def p_nom():
    """Nominal parameter vector (seed Table III, spec cogging law)."""
    from maglev_ocp.params import NOMINAL

    return NOMINAL.vector()


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    """Under ``CI=true`` a whole module skipped at collection (``importorskip`` at the top) fails too."""
    outcome = yield
    rep = outcome.get_result()
    if rep.skipped and _in_ci():
        _skip_fails(rep, "module skipped")


#: Per-test time limits by tier [s] (pytest-timeout; the ini's ``timeout`` is the default set's). A hung test
#: fails with its stack instead of eating CI's budget; a test that needs more says so with its own marker.
TIER_TIMEOUT = {"slow": 900, "long": 6 * 3600}


def pytest_collection_modifyitems(config, items):
    """Give ``slow`` and ``long`` tests their tier's time limit unless they carry their own."""
    for item in items:
        if item.get_closest_marker("timeout") is not None:
            continue
        for tier, seconds in TIER_TIMEOUT.items():
            if item.get_closest_marker(tier) is not None:
                item.add_marker(pytest.mark.timeout(seconds))
                break
