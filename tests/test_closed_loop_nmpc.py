"""Closed-loop tolerance tests of the NMPC on the default rig profile (issue 4), marked slow.

They run the shipped scenarios (and a few written here) through the scenario
runner, :func:`maglev_ocp.runner.run_scenario`, and check its metrics: every
target settled within 0.1 mm on both axes and held (settle time from the
target switch), steady-state RMS error over the settled part on the plant's
true state, currents within the limits, no stop hit, no solver failure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.runner import run_scenario

pytestmark = pytest.mark.slow

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
T1 = k.t1  # slot pitch: cogging peaks at odd multiples of t1/2
RMS_MAX = 10e-6  # issue 4: steady-state RMS at most one encoder count
# issue 13: steps whose ADMM residuals stay above tolerance; shipped scenarios measured at most 1.04 %
# (cogging_aware_nmpc: 29 of 2800), a starved or mistuned solver leaves over 40 % (tests/test_nmpc.py)
INACCURATE_MAX = 0.02


def _check(res, rms_max=RMS_MAX):
    m = res.metrics
    assert m.error is None, m.error
    assert m.all_settled, m.table()
    for tg in m.targets:
        where = f"{res.scenario.name}: target {tg.index} (g={tg.g * 1e3:.2f} mm, d={tg.d * 1e3:.2f} mm)"
        assert tg.settled, where
        assert tg.rms_error_g_m <= rms_max and tg.rms_error_d_m <= rms_max, (where, tg)
    assert m.currents_within_limits and m.max_current_A <= k.i_amp_max + 1e-9
    assert m.stop_hits == 0 and m.solver_failures == 0 and m.fallbacks == 0
    assert m.solver_inaccurate <= INACCURATE_MAX * len(res.columns["t"]), m.solver_inaccurate


@pytest.mark.parametrize(
    "name",
    [
        "tour_nmpc",
        "random_nmpc",
        "gap_steps_nmpc",
    ],
)
def test_shipped_tours_hold_every_target(name):
    res = run_scenario(SCENARIOS / f"{name}.yaml", progress=False)
    _check(res)
    assert res.passed


def test_strong_cogging_tour_both_models():
    """Targets at 15..16 mm where cogging peaks: held to 10 um RMS with and without cogging in the model."""
    for name in ("cogging_aware_nmpc", "cogging_blind_nmpc"):
        _check(run_scenario(SCENARIOS / f"{name}.yaml", progress=False))


@pytest.mark.parametrize("gap_mm", [15, 20, 25])
def test_traverse_100mm_settles_within_120ms(gap_mm):
    res = run_scenario(SCENARIOS / f"traverse_{gap_mm}mm_nmpc.yaml", progress=False)
    _check(res)
    for tg in res.metrics.targets:
        assert tg.settle_time_s <= 0.12, tg
        # never faster than the minimum-time bound of the OCP (maglev_ocp.ocp: 80.6 / 88.7 / 99.8 ms)
        assert tg.settle_time_s > {15: 0.078, 20: 0.086, 25: 0.097}[gap_mm]


@pytest.mark.parametrize("reference", ["plan", "preview"])
def test_traverse_with_internal_planner_and_step_reference(reference):
    """With set-point steps (no planned reference) the NMPC plans the move itself and still meets 0.12 s."""
    sc = {
        "name": f"traverse_step_{reference}",
        "seed": 21,
        "controller": {"type": "nmpc", "reference": reference},
        "plant": {"profile": "default"},
        "start": {"g": 0.020, "d": -0.050},
        "reference": {"shaping": "step" if reference == "plan" else "trajectory", "current_fraction": 0.9},
        "targets": [{"g": 0.020, "d": 0.050, "hold": 0.3}],
    }
    res = run_scenario(sc, progress=False)
    _check(res)
    assert res.metrics.targets[0].settle_time_s <= 0.12


def _moving_error(res):
    c = res.columns
    t = c["t"]
    moving = np.zeros(len(t), bool)
    for tg in res.metrics.targets:
        moving |= (t >= tg.t_switch) & (t < tg.t_switch + tg.move_time_s)
    e = c["d_true"][moving] - c["d_ref"][moving]
    return float(np.sqrt(np.mean(e**2))), float(np.max(np.abs(e)))


def test_cogging_model_gain_at_15mm():
    """Moving through three half slot pitches at 15 mm, the cogging-aware model tracks far better."""
    err = {}
    for cog in (True, False):
        sc = {
            "name": f"cogging_move_{cog}",
            "seed": 3,
            "controller": {"type": "nmpc"},
            "controller_params": {"cogging": cog},
            "plant": {"profile": "default"},
            "start": {"g": 0.015, "d": -1.5 * T1},
            "reference": {"current_fraction": 0.8},
            "targets": [{"g": 0.015, "d": 1.5 * T1, "hold": 0.3}, {"g": 0.015, "d": -1.5 * T1, "hold": 0.3}],
        }
        res = run_scenario(sc, progress=False)
        _check(res)
        err[cog] = _moving_error(res)
        print(
            f"cogging in the model: {cog}: tracking error of d during the moves: RMS {err[cog][0] * 1e6:.1f} um, "
            f"max {err[cog][1] * 1e6:.1f} um"
        )
    assert err[True][1] < k.position_tolerance  # the move itself stays within 0.1 mm of the reference
    assert err[True][0] < 0.8 * err[False][0] and err[True][1] < 0.8 * err[False][1], err
