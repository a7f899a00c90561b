"""The shared model against MODEL.md's reference table, finite differences and integrators."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from maglev_ocp.cli import main
from maglev_ocp.params import NOMINAL

# MODEL.md reference figures: g_mm -> (lam, Kc, B, i_d_eq, L1)
REFERENCE = {
    10.0: (0.8997, 1.1453, 0.2993, 5.3278, 12.109),
    15.0: (0.9189, 1.0957, 0.2066, 3.3287, 8.923),
    20.0: (0.9320, 1.0710, 0.1491, 1.4984, 6.681),
    25.0: (0.9414, 1.0563, 0.1101, -0.2195, 5.052),
}


def _sig4(a: float, b: float) -> bool:
    """True if a and b agree to 4 significant digits (half a unit in the 4th)."""
    scale = 10 ** (math.floor(math.log10(abs(b))) - 3)
    return abs(a - b) <= 0.5 * scale + 1e-12


def test_reference_table_via_cli(capsys):
    assert main(["model", "--gaps", "10", "15", "20", "25", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["g_mm"] for r in rows] == [10.0, 15.0, 20.0, 25.0]
    for r in rows:
        ref = REFERENCE[r["g_mm"]]
        got = (r["lam"], r["Kc"], r["B_T"], r["i_d_eq_A"], r["L1"])
        for name, a, b in zip(("lam", "Kc", "B", "i_d", "L1"), got, ref, strict=True):
            assert _sig4(a, b), f"{name} at {r['g_mm']} mm: {a} vs {b}"
    pole20 = rows[2]["pole_rad_s"]
    assert 38.0 < pole20 < 40.5  # MODEL.md: about +39 rad/s, unstable


@pytest.mark.parametrize("seed", range(5))
def test_jacobians_match_finite_differences(model, p_nom, seed):
    rng = np.random.default_rng(seed)
    x = np.array([rng.uniform(0.01, 0.03), rng.normal(0, 0.05), rng.uniform(-0.05, 0.05), rng.normal(0, 0.3)])
    u = rng.uniform(-6, 6, 2)
    A, B = (np.asarray(M) for M in model.linearization(x, u, p_nom))
    h = 1e-7
    f0 = np.asarray(model.f(x, u, p_nom)).ravel()
    for j in range(4):
        dx = np.zeros(4)
        dx[j] = h * max(1.0, abs(x[j])) if j % 2 else h * 1e-2
        fd = (np.asarray(model.f(x + dx, u, p_nom)).ravel() - np.asarray(model.f(x - dx, u, p_nom)).ravel()) / (
            2 * dx[j]
        )
        np.testing.assert_allclose(A[:, j], fd, rtol=1e-5, atol=1e-6 * max(1, np.abs(fd).max()))
    for j in range(2):
        du = np.zeros(2)
        du[j] = 1e-5
        fd = (np.asarray(model.f(x, u + du, p_nom)).ravel() - np.asarray(model.f(x, u - du, p_nom)).ravel()) / 2e-5
        np.testing.assert_allclose(B[:, j], fd, rtol=1e-6, atol=1e-8)
    assert np.all(np.isfinite(f0))


def test_linear_split_reconstructs_f(model, p_nom):
    names = ("C1", "C2", "C3", "C4", "xi0")
    lip = model.linear_split(names)
    rng = np.random.default_rng(1)
    for _ in range(10):
        x = np.array([rng.uniform(0.01, 0.03), rng.normal(), rng.uniform(-0.05, 0.05), rng.normal()])
        u = rng.uniform(-8, 8, 2)
        A, b = (np.asarray(M) for M in lip(x, u, p_nom))
        theta = np.array([getattr(NOMINAL, n) for n in names])
        np.testing.assert_allclose(
            A @ theta + b.ravel(), np.asarray(model.f(x, u, p_nom)).ravel(), rtol=1e-12, atol=1e-12
        )
        # b does not depend on theta
        p2 = NOMINAL.scaled({n: 1.7 for n in names}).vector()
        np.testing.assert_allclose(np.asarray(lip(x, u, p2)[1]), b, atol=1e-12)


def test_rejects_nonlinear_parameter(model):
    with pytest.raises(ValueError, match="linearly"):
        model.linear_split(("ell",))


@pytest.mark.parametrize("g", [0.012, 0.015, 0.02, 0.025])
@pytest.mark.parametrize("d", [0.0, 0.0095, 0.0286, -0.041])
def test_equilibrium_is_equilibrium(model, p_nom, g, d):
    u = np.asarray(model.u_eq(g, d, p_nom)).ravel()
    assert np.all(np.isfinite(u))
    xdot = np.asarray(model.f([g, 0, d, 0], u, p_nom)).ravel()
    np.testing.assert_allclose(xdot, 0, atol=1e-10)


def test_eq8_without_cogging_matches_u_eq(model):
    p = NOMINAL.without_cogging().vector()
    for g in np.linspace(0.01, 0.03, 9):
        assert float(model.i_d_eq(g, p)) == pytest.approx(float(model.u_eq(g, 0.0, p)[1]), rel=1e-12)


def test_discrete_step_matches_high_accuracy_integrator(model, p_nom):
    step = model.step(1e-3, 4)
    x = np.array([0.02, 0.01, 0.01, 0.2])
    u = np.array([0.5, 1.2])
    xk = x.copy()
    for _ in range(20):
        xk = np.asarray(step(xk, u, p_nom)).ravel()
    sol = solve_ivp(
        lambda t, z: np.asarray(model.f(z, u, p_nom)).ravel(), (0, 0.02), x, rtol=1e-12, atol=1e-14, method="DOP853"
    )
    np.testing.assert_allclose(xk, sol.y[:, -1], rtol=0, atol=1e-9)


def test_cogging_off_gives_eq2(model):
    p = NOMINAL.without_cogging().vector()
    x = [0.015, 0.0, 0.0286, 0.0]
    Fx, Fn = model.cogging(0.015, 0.0286, p)
    assert float(Fx) == 0 and float(Fn) == 0
    terms = [float(v) for v in model.accel_terms(x, [0.3, 2.0], p)]
    assert terms[4] == 0 and terms[6] == 0


def test_cogging_law(model, p_nom):
    t1 = 19.05e-3
    Fx, Fn = (float(v) for v in model.cogging(0.010, 1.5 * t1, p_nom))
    assert Fx == pytest.approx(-4.0, rel=1e-12)  # sin(3 pi / 2) = -1
    assert Fn == pytest.approx(4.0, rel=1e-12)
    assert float(model.cogging(0.0149, t1 / 2, p_nom)[1]) > 1.0  # above 1 N below 15 mm
    assert float(model.cogging(0.020, t1 / 2, p_nom)[1]) < 0.3  # negligible above 20 mm
