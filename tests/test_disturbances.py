"""Scheduled plant disturbances: force pulses and steps, payload, cable; their validation and metrics."""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.errors import ConfigError
from maglev_ocp.metrics import disturbance_metrics, disturbance_table
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig
from maglev_ocp.plant.disturbances import with_payload
from maglev_ocp.scenario import scenario_from_dict

X0 = np.array([0.020, 0.0, 0.0, 0.0])


def _velocities(dist: list, n: int = 6, x0: np.ndarray = X0, u: np.ndarray | None = None) -> np.ndarray:
    """True state after each period, ideal plant held at the nominal hover current at ``x0``."""
    plant = Plant(PlantConfig.from_profile("ideal", {"disturbances": dist}), NOMINAL, seed=0)
    plant.reset(x0)
    u = plant.hover_currents(x0) if u is None else u
    return np.array([plant.step(u).x_true for _ in range(n)])


@pytest.mark.parametrize(("axis", "col", "mass"), [("g", 1, NOMINAL.Mv), ("d", 3, NOMINAL.Mh)])
@pytest.mark.parametrize("amp", [7.0, -3.0])
def test_force_step_accelerates_by_f_over_m(axis, col, mass, amp):
    """A force step F on an axis adds F / M to its acceleration, with the model's sign (+g opens the gap)."""
    base = _velocities([])
    pushed = _velocities([{"type": "force_step", "axis": axis, "amplitude": amp, "start": 0.002}])
    dv = pushed[:, col] - base[:, col]
    assert np.allclose(dv[:2], 0.0, atol=1e-15)  # before its start (periods 0 and 1)
    # its first period (2): F / M * Ts more velocity (the hover is an equilibrium; later periods add the
    # open-loop instability's response to the displacement, seed eq. (2))
    assert dv[2] == pytest.approx(amp / mass * k.Ts, rel=1e-3)


def test_force_pulse_acts_only_for_its_duration():
    res = _velocities([{"type": "force_pulse", "axis": "d", "amplitude": 10.0, "start": 0.001, "duration": 0.003}], 8)
    dv = np.diff(np.concatenate([[0.0], res[:, 3]]))
    per = 10.0 / NOMINAL.Mh * k.Ts
    assert np.allclose(dv, [0, per, per, per, 0, 0, 0, 0], atol=1e-3 * per)  # cogging: d moves a little


def test_force_step_shifts_the_hover_current_as_the_model_predicts():
    """A constant force F on g is held by the hover current of a mover F / G kg heavier (seed eq. (8))."""
    F = 4.0
    u_heavy = Plant(PlantConfig.from_profile("ideal"), with_payload(NOMINAL, F / k.G)).hover_currents(X0)
    res = _velocities([{"type": "force_step", "axis": "g", "amplitude": F, "start": 0.0}], u=u_heavy)
    assert np.max(np.abs(res[:, 1])) < 1e-9
    u_nom = Plant(PlantConfig.from_profile("ideal"), NOMINAL).hover_currents(X0)
    assert u_heavy[1] < u_nom[1] - 0.1  # more attraction needed: i_d lower (seed eq. (2): +C3 f3 i_d opens)


def test_payload_changes_the_dynamics_at_its_time():
    """A payload m at t: from then the nominal hover current leaves G m / (Mv + m) of net downward acceleration."""
    m, t_on = 1.5, 0.003
    res = _velocities([{"type": "payload", "mass": m, "time": t_on}], 8)
    acc = np.diff(np.concatenate([[0.0], res[:, 1]])) / k.Ts
    assert np.allclose(acc[:3], 0.0, atol=1e-9)
    assert acc[3] == pytest.approx(k.G * m / (NOMINAL.Mv + m), rel=1e-3)  # its first period (then unstable)
    plant = Plant(PlantConfig.from_profile("ideal", {"disturbances": [{"type": "payload", "mass": m, "time": 0}]}))
    plant.reset(X0)
    assert plant.payload_mass == m and plant.params_now.Mv == pytest.approx(NOMINAL.Mv + m)
    # the heavier mover hovers on its own hover current; the thrust per ampere per kg stays C1 f1 Mh
    assert plant.params_now.C1 * plant.params_now.Mh == pytest.approx(NOMINAL.C1 * NOMINAL.Mh)


def test_payload_is_reset_between_runs():
    plant = Plant(
        PlantConfig.from_profile("ideal", {"disturbances": [{"type": "payload", "mass": 1.0, "time": 0.002}]})
    )
    for _ in range(2):
        plant.reset(X0)
        assert plant.payload_mass == 0.0
        for _ in range(4):
            plant.step(plant.hover_currents(X0))
        assert plant.payload_mass == 1.0


def test_cable_spring_and_drag_pull_back():
    """Cable at d = 10 mm moving at 0.1 m/s: F_d = -k (d - rest) - c d_dot, and its weight on g."""
    kd, c, w = 200.0, 3.0, 2.0
    x0 = np.array([0.020, 0.0, 0.010, 0.1])
    cab = [{"type": "cable", "stiffness_d": kd, "damping_d": c, "rest_d": 0.0, "weight_g": w}]
    base, pulled = _velocities([], 1, x0), _velocities(cab, 1, x0)
    f_d = -kd * 0.010 - c * 0.1
    assert (pulled[0, 3] - base[0, 3]) == pytest.approx(f_d / NOMINAL.Mh * k.Ts, rel=1e-3)
    assert (pulled[0, 1] - base[0, 1]) == pytest.approx(w / NOMINAL.Mv * k.Ts, rel=1e-3)


@pytest.mark.parametrize(
    ("item", "match"),
    [
        ({"type": "force_pulse", "axis": "g", "amplitude": 1.0, "start": 0.1}, "duration"),
        ({"type": "force_step", "axis": "x", "amplitude": 1.0, "start": 0.1}, "axis"),
        ({"type": "payload", "mass": -1.0, "time": 0.1}, "mass"),
        ({"type": "magnet", "mass": 1.0}, "type|magnet"),
        ({"type": "force_step", "axis": "g", "amplitude": float("nan"), "start": 0.1}, "amplitude"),
    ],
)
def test_disturbance_settings_validated(item, match):
    with pytest.raises(ConfigError, match=match):
        PlantConfig.from_profile("default", {"disturbances": [item]})


def test_one_cable_only():
    with pytest.raises(ConfigError, match="one cable"):
        PlantConfig.from_profile("default", {"disturbances": [{"type": "cable"}, {"type": "cable"}]})


SC = {
    "name": "pay",
    "seed": 1,
    "controller": {"type": "fl"},
    "targets": [{"g": 0.025, "d": 0.0, "hold": 0.3}],
}


def test_payload_that_cannot_hover_is_rejected_naming_the_key():
    ok = {**SC, "plant": {"disturbances": [{"type": "payload", "mass": 1.0, "time": 0.1}]}}
    scenario_from_dict(ok)
    bad = {
        **SC,
        "plant": {
            "disturbances": [
                {"type": "force_pulse", "axis": "d", "amplitude": 1, "start": 0, "duration": 0.1},
                {"type": "payload", "mass": 18.0, "time": 0.1},
            ]
        },
    }
    with pytest.raises(ConfigError, match=r"plant\.disturbances\[1\]\.mass: .*current_limits"):
        scenario_from_dict(bad)
    pull = {**SC, "plant": {"disturbances": [{"type": "force_step", "axis": "g", "amplitude": 150.0, "start": 0.1}]}}
    with pytest.raises(ConfigError, match=r"plant\.disturbances\[0\]\.amplitude"):
        scenario_from_dict(pull)


def _cols(err_g: np.ndarray, n: int) -> dict[str, np.ndarray]:
    t = np.arange(n) * k.Ts
    z = np.zeros(n)
    return {
        "t": t, "g_true": 0.02 + err_g, "g_ref": z + 0.02, "d_true": z, "d_ref": z,
        "g_target": z + 0.02, "d_target": z, "i_q": z, "i_d": np.where(err_g > 400e-6, 8.0, 1.0),
    }  # fmt: skip


def test_disturbance_metrics_recovery_peak_and_limit_time():
    n = 400
    err = np.zeros(n)
    err[100:150] = np.linspace(0.0, 500e-6, 50)  # out of 0.1 mm from step 110 to 179
    err[150:180] = 300e-6
    err[180:] = 20e-6
    items = PlantConfig.from_profile(
        "ideal",
        {"disturbances": [{"type": "force_pulse", "axis": "g", "amplitude": 50, "start": 0.1, "duration": 0.01}]},
    ).disturbances
    (dm,) = disturbance_metrics(_cols(err, n), list(items), [0.16])
    assert dm.peak_error_g_m == pytest.approx(500e-6)
    assert dm.recovery_time_s == pytest.approx(0.08)
    assert dm.stop_hits == 1
    assert dm.time_at_limit_s == pytest.approx(0.010)  # i_d at 8 A while err > 0.4 mm (steps 140..149)
    assert dm.rms_error_after_m == pytest.approx(20e-6)
    row = {"scenario": "x", "controller": "fl", "settled": "1/1", **dm.to_dict()}
    assert "force_pulse" in disturbance_table([row]) and "| x |" in disturbance_table([row], markdown=True)
