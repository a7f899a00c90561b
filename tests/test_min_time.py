"""Minimum-time OCP: the current-limited bound of the 100 mm traverse and the feasibility of its path."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.model import get_model
from maglev_ocp.ocp import MinTimeSettings, solve_min_time
from maglev_ocp.params import NOMINAL


@pytest.fixture(scope="module")
def traverse20():
    return solve_min_time((20e-3, -0.05), (20e-3, 0.05), NOMINAL, MinTimeSettings(n_intervals=120))


def test_bound_at_20mm(traverse20):
    r = traverse20
    assert r.success, r.status
    # MODEL.md / issue 4: the current-limited minimum is about 0.089 s at 20 mm
    assert 0.085 <= r.T <= 0.095, r.T
    # a double integrator with the whole 8 A as thrust at 20 mm would need 2 sqrt(D / (L1 * 8)):
    # the hover current takes part of the amplitude, so the bound must be slower than that
    L1 = get_model().operating_point(20e-3)["L1"]
    assert r.T > 2 * np.sqrt(0.05 / (L1 * 8.0))


def test_path_respects_limits_and_boundary_conditions(traverse20):
    r = traverse20
    U, X = r.U, r.X
    assert np.all(np.abs(U) <= k.i_axis_max + 1e-6)
    assert np.all(np.hypot(U[:, 0], U[:, 1]) <= k.i_amp_max + 1e-6)
    # the amplitude limit is active most of the move (bang-bang on the disk)
    assert np.mean(np.hypot(U[:, 0], U[:, 1]) > k.i_amp_max - 0.05) > 0.8
    np.testing.assert_allclose(X[0], [20e-3, 0, -0.05, 0], atol=1e-9)
    np.testing.assert_allclose(X[-1], [20e-3, 0, 0.05, 0], atol=1e-9)
    # gap held within the 0.1 mm positioning tolerance around 20 mm
    assert np.all(np.abs(X[:, 0] - 20e-3) <= k.position_tolerance + 1e-8)


def test_path_is_a_trajectory_of_the_model(traverse20):
    """Replaying the currents through a finer integrator of the shared model lands at the target."""
    r = traverse20
    n = len(r.U)
    F = get_model().step(r.T / n, 20)
    x = r.X[0].copy()
    p = NOMINAL.vector()
    err = 0.0
    for j in range(n):
        x = np.asarray(F(x, r.U[j], p)).ravel()
        err = max(err, abs(x[2] - r.X[j + 1, 2]), abs(x[0] - r.X[j + 1, 0]))
    assert err < 2e-5, err  # open-loop replay agrees with the shooting nodes to 20 um


def test_result_object(traverse20, tmp_path):
    r = traverse20
    s = r.sample(np.array([0.0, r.T / 2, r.T]))
    np.testing.assert_allclose(s["x"][0], r.X[0], atol=1e-12)
    np.testing.assert_allclose(s["x"][-1], r.X[-1], atol=1e-12)
    assert s["acc"][0, 1] > 40.0  # accelerating towards +d at the current limit (m/s^2)
    r.save(tmp_path)
    data = json.loads((tmp_path / "min_time.json").read_text())
    assert data["T_s"] == pytest.approx(r.T)
    assert (tmp_path / "min_time.png").stat().st_size > 1000
    assert "T_min" in r.table()


def test_larger_gap_is_slower():
    st = MinTimeSettings(n_intervals=60)
    t15 = solve_min_time((15e-3, -0.05), (15e-3, 0.05), NOMINAL, st)
    t25 = solve_min_time((25e-3, -0.05), (25e-3, 0.05), NOMINAL, st)
    assert t15.success and t25.success
    assert t15.T < t25.T  # less thrust per ampere at a larger gap (f1 falls with g)


def test_gap_move_keeps_d_within_the_band():
    """With i_d held below its limit, the fastest 15 -> 25 mm gap move pulls with i_q's reluctance term in
    alternating signs, which swings d; ``d_band = 0`` keeps d where it is for well under 1 % of the time."""
    st = MinTimeSettings(n_intervals=50, tol=1e-6, i_amp=0.97 * 8, i_axis=0.97 * 8, i_d_max=0.85 * 8)
    a, b = (0.015, 0.05), (0.025, 0.05)
    free = solve_min_time(a, b, NOMINAL, st)
    kept = solve_min_time(a, b, NOMINAL, replace(st, d_band=0.0))
    assert free.success and kept.success
    assert np.max(np.abs(free.X[:, 2] - 0.05)) > 1e-4  # measured: 0.25 mm
    assert np.max(np.abs(kept.X[:, 2] - 0.05)) < 1e-6
    assert free.T <= kept.T <= 1.01 * free.T  # measured: +0.7 %
