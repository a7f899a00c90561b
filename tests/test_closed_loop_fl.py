"""Closed-loop tolerance tests of feedback linearization on the default rig profile.

The default profile has process and current noise, 10 um encoders, the current
limits, the stops, friction of the guides, a 2 kHz amplifier lag and a random
mismatch of C1..C4: every target must be reached and held within 0.1 mm on
both axes (true state), currents within the limits, no stop hit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.runner import run_scenario
from maglev_ocp.scenario import load_scenario

SCEN = Path(__file__).resolve().parents[1] / "scenarios"


def _assert_tolerances(res, rms_max: float | None = None):
    m = res.metrics
    assert m.error is None
    bad = [(t.index, t.final_error_g_m, t.final_error_d_m) for t in m.targets if not t.settled]
    assert m.all_settled, f"not settled within {k.position_tolerance} m: {bad}"
    assert m.stop_hits == 0, m.stop_events
    assert m.currents_within_limits, m.max_current_A
    amp = np.hypot(res.columns["i_q"], res.columns["i_d"])
    assert amp.max() <= k.i_amp_max + 1e-9
    assert np.abs(res.columns["i_q"]).max() <= k.i_axis_max + 1e-9
    assert np.abs(res.columns["i_d"]).max() <= k.i_axis_max + 1e-9
    for t in m.targets:  # settled means: within the band from the settle instant to the end of the hold
        assert t.max_abs_error_g_settled_m <= k.position_tolerance
        assert t.max_abs_error_d_settled_m <= k.position_tolerance
        if rms_max is not None:
            assert t.rms_error_g_m <= rms_max and t.rms_error_d_m <= rms_max, (
                t.index,
                t.rms_error_g_m,
                t.rms_error_d_m,
            )
    assert m.passed, m.failed_checks


def test_envelope_tour_holds_every_target_within_tolerance():
    """Corners and centre: settled, and steady-state RMS error at most one encoder count (10 um)."""
    res = run_scenario(SCEN / "tour_fl.yaml", progress=False)
    _assert_tolerances(res, rms_max=10e-6)


def test_random_targets_in_the_envelope():
    res = run_scenario(SCEN / "random_fl.yaml", progress=False)
    assert len(res.metrics.targets) == 8
    _assert_tolerances(res)


def test_traverse_100mm_at_20mm_settles_in_under_a_tenth_of_a_second():
    """100 mm at 20 mm with 95 % of the current: both axes within 0.1 mm in at most 0.1 s (measured ~0.091 s);
    the current-limited minimum is about 0.089 s."""
    res = run_scenario(SCEN / "traverse_20mm_fl.yaml", progress=False)
    _assert_tolerances(res)
    for t in res.metrics.targets:
        assert t.settle_time_s <= 0.100


def test_parameter_mismatch_leaves_no_offset():
    """True constants off by up to 30 %: the disturbance estimate makes the tracking offset-free."""
    res = run_scenario(SCEN / "mismatch_fl.yaml", progress=False)
    _assert_tolerances(res)
    for t in res.metrics.targets:  # the last 100 ms of every hold: no steady offset beyond two counts
        c = res.columns
        sel = (c["t"] >= t.t_switch + t.hold - 0.1) & (c["t"] < t.t_switch + t.hold)
        assert abs(np.mean(c["g_true"][sel]) - t.g) < 2e-5
        assert abs(np.mean(c["d_true"][sel]) - t.d) < 2e-5


@pytest.mark.slow
@pytest.mark.parametrize(
    "name", ["gap_steps_fl", "cogging_aware_fl", "cogging_blind_fl", "traverse_15mm_fl", "traverse_25mm_fl"]
)
def test_shipped_fl_scenarios(name):
    res = run_scenario(SCEN / f"{name}.yaml", progress=False)
    _assert_tolerances(res)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
def test_random_targets_more_seeds(seed):
    sc = load_scenario(SCEN / "random_fl.yaml")
    res = run_scenario(sc, progress=False, seed=seed)
    _assert_tolerances(res)
