"""Computation delay in the plant (``plant.delay_samples``) and FL's predictor (``controller.delay_samples``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings, fl_predictor_function
from maglev_ocp.errors import ConfigError
from maglev_ocp.loop import ClosedLoop
from maglev_ocp.model import get_model
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig
from maglev_ocp.reference import Target, plan_targets
from maglev_ocp.runner import run_scenario
from maglev_ocp.scenario import scenario_from_dict

P_NOM = NOMINAL.vector()
MOVE = {
    "name": "delay_move",
    "seed": 3,
    "targets": [{"g": 0.020, "d": 0.0, "hold": 0.1}, {"g": 0.016, "d": -0.03, "hold": 0.25}],
}


def _impulse_response(cfg: PlantConfig, n: int = 12, at: int = 3) -> np.ndarray:
    """Applied i_d (amplifier output) per step when the command carries a 1 A impulse at step ``at``."""
    plant = Plant(cfg, NOMINAL, seed=0)
    plant.reset()
    u0 = plant.hover_currents(plant.x)
    out = []
    for i in range(n):
        m = plant.step(u0 + (np.array([0.0, 1.0]) if i == at else 0.0))
        out.append(m.info["i_d_applied"] - u0[1])
    return np.array(out)


@pytest.mark.parametrize("n_delay", [0, 1, 3])
def test_command_reaches_the_amplifiers_exactly_n_samples_later(n_delay):
    """Ideal amplifiers: a 1 A impulse computed at step 3 is applied over period 3 + N, nowhere else."""
    r = _impulse_response(PlantConfig.from_profile("ideal", {"delay_samples": n_delay}))
    expect = np.zeros_like(r)
    expect[3 + n_delay] = 1.0
    assert np.allclose(r, expect, atol=1e-12)


def test_computation_and_amplifier_delays_add_up_in_one_buffer():
    """Computation delay 1 plus the amplifier's transport delay 2: the lagged response starts 3 samples late."""
    lag = {"amplifier_lag": {"enabled": True, "bandwidth_hz": 2000.0, "delay_samples": 2}}
    both = PlantConfig.from_profile("ideal", {"delay_samples": 1, "effects": lag})
    amp3 = PlantConfig.from_profile(
        "ideal", {"effects": {**lag, "amplifier_lag": {**lag["amplifier_lag"], "delay_samples": 3}}}
    )
    assert both.total_delay() == 3
    r, r3 = _impulse_response(both), _impulse_response(amp3)
    assert np.array_equal(r, r3)
    assert np.all(r[:6] == 0) and r[6] > 0.9  # 2 kHz lag: ~99.8 % of the step within one 1 ms period


def test_delay_zero_is_the_plant_without_the_key():
    """``delay_samples: 0`` is the plant as it was: same log bit for bit as a config without the key."""
    logs = []
    for over in (None, {"delay_samples": 0}):
        plant = Plant(PlantConfig.from_profile("default", over), NOMINAL, seed=5)
        plant.reset()
        u0 = plant.hover_currents(plant.x)
        for i in range(50):
            plant.step(u0 + 0.1 * np.sin(i))
        logs.append(plant.log)
    a, b = (np.column_stack(list(lg.columns.values())) for lg in logs)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("bad", [-1, 11, 1.5, "one"])
def test_delay_samples_validated(bad):
    with pytest.raises(ConfigError, match="delay_samples"):
        PlantConfig.from_profile("default", {"delay_samples": bad})
    with pytest.raises(ConfigError, match="delay_samples"):
        scenario_from_dict({**MOVE, "controller": {"type": "fl", "delay_samples": bad}})


def test_predictor_is_the_model_step_n_times():
    """The N-sample predictor equals N calls of the model's RK4 step plus the disturbance's drift."""
    step = get_model().step(k.Ts, 1)
    x = np.array([0.019, 0.01, 0.004, -0.2])
    dist = np.array([0.3, -0.2])
    us = [np.array([0.5, 1.2]), np.array([-0.3, 1.6]), np.array([0.0, 1.4])]
    xr = x.copy()
    for u in us:
        xr = np.asarray(step(xr, u, P_NOM)).ravel()
        xr += np.array([dist[0] * k.Ts**2 / 2, dist[0] * k.Ts, dist[1] * k.Ts**2 / 2, dist[1] * k.Ts])
    xp = np.asarray(fl_predictor_function(3)(x, dist, np.concatenate(us), P_NOM)).ravel()
    assert np.allclose(xp, xr, rtol=0, atol=1e-13)


def _move(plant_delay: int, ctrl_delay: int) -> dict:
    sc = {**MOVE, "controller": {"type": "fl", "delay_samples": ctrl_delay}}
    sc["plant"] = {"profile": "ideal", "delay_samples": plant_delay}
    return run_scenario(sc, progress=False, figures=False).columns


def test_predictor_with_plan_restores_the_delay_free_loop():
    """Exact model, no noise: FL with the predictor on a one-period-delay plant moves as FL without delay.

    Without the predictor the same move deviates from the delay-free one by more than 50 um.
    """
    ref = _move(0, 0)
    pred = _move(1, 1)
    blind = _move(1, 0)
    dev_pred = max(np.max(np.abs(pred[a] - ref[a])) for a in ("g_true", "d_true"))
    dev_blind = max(np.max(np.abs(blind[a] - ref[a])) for a in ("g_true", "d_true"))
    assert dev_pred < 1e-6
    assert dev_blind > 50e-6


def test_predictor_without_plan_gives_the_delay_free_response_n_samples_late():
    """Through the Python API (no plan): the mover follows the reference handed in, N samples late."""
    plan = plan_targets((0.020, 0.0), [Target(0.020, 0.0, 0.05), Target(0.017, 0.02, 0.2)], NOMINAL)
    n = round(plan.duration / k.Ts)
    runs = {}
    for nd in (0, 2):
        plant = Plant(PlantConfig.from_profile("ideal", {"delay_samples": nd}), NOMINAL, seed=0)
        ctrl = FeedbackLinearization(FLSettings(delay_samples=nd), NOMINAL)
        loop = ClosedLoop(plant, ctrl)
        loop.reset(np.array([0.020, 0.0, 0.0, 0.0]), plan.at(0.0))
        xs = []
        for i in range(n):
            loop.step(plan.at(i * k.Ts))
            xs.append(loop.y.x_true)
        runs[nd] = np.array(xs)
    a, b = runs[0], runs[2]
    assert np.max(np.abs(b[2:, [0, 2]] - a[:-2, [0, 2]])) < 1e-6
    assert np.max(np.abs(b[:, [0, 2]] - a[:, [0, 2]])) > 1e-4  # it is late, not on time


def test_tour_with_one_period_delay_fl_predictor():
    """Default rig profile, one-period delay: every tour target settles within 0.1 mm with steady RMS <= 6 um."""
    res = run_scenario(Path(__file__).parents[1] / "scenarios" / "tour_fl_delay1.yaml", progress=False, figures=False)
    m = res.metrics
    assert all(t.settled for t in m.targets)
    assert m.max_rms_error_g_m <= 6e-6 and m.max_rms_error_d_m <= 6e-6
