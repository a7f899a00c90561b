"""The independent rig generator (maglev_ocp.rigsim): physics, integrator, closed loop, datasets, effects."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from maglev_ocp.riglog import read_dataset
from maglev_ocp.rigsim import LAWS, LIBRARY_EFFECTS, OUT_OF_LIBRARY, RigSettings, draw, expected_verdict, generate
from maglev_ocp.rigsim.excite import ExcitationSettings
from maglev_ocp.rigsim.generate import build_laws
from maglev_ocp.rigsim.laws_new import ALL_LIBRARY, ALL_OUT_OF_LIBRARY
from maglev_ocp.rigsim.physics import NOMINAL, accelerations, equilibrium_current, shape, vertical_pole
from maglev_ocp.rigsim.sim import Rig, simulate

# MODEL.md "Reference figures": g [mm], lam, Kc, B [T], i_d,eq [A], L1 = C1 f1
MODEL_TABLE = [
    (10.0, 0.8997, 1.1453, 0.2993, 5.3278, 12.109),
    (15.0, 0.9189, 1.0957, 0.2066, 3.3287, 8.923),
    (20.0, 0.9320, 1.0710, 0.1491, 1.4984, 6.681),
    (25.0, 0.9414, 1.0563, 0.1101, -0.2195, 5.052),
]
SMALL = {"n_runs": 2, "duration": 1.5}


def _sig4(a: float, b: float) -> bool:
    """Do a and b agree to the 4 significant digits of b (or its last printed digit)?"""
    return abs(a - b) <= 0.5 * 10 ** (np.floor(np.log10(abs(b))) - 3) + 1e-12


@pytest.mark.parametrize("row", MODEL_TABLE)
def test_nominal_physics_matches_model_md_table(row):
    g_mm, lam, Kc, B, i_eq, L1 = row
    sh = shape(g_mm * 1e-3)
    assert _sig4(float(sh.lam), lam)
    assert _sig4(float(sh.Kc), Kc)
    assert _sig4(float(sh.B), B)
    assert abs(float(equilibrium_current(g_mm * 1e-3)) - i_eq) < 6e-5  # printed to 4 decimals
    assert abs(float(NOMINAL.C1 * sh.f1) - L1) < 6e-4
    # the current is an equilibrium of seed eq. (2)
    assert abs(float(accelerations(g_mm * 1e-3, 0.0, 0.0, i_eq, with_cogging=False)[0])) < 2e-3


def test_open_loop_pole_at_20mm():
    assert 38.5 < vertical_pole(20e-3) < 40.0  # MODEL.md: about +39 rad/s


def _hover_ref(R: int, N: int, g: float, d: float = 0.0) -> np.ndarray:
    ref = np.zeros((R, N, 6))
    ref[..., 0], ref[..., 3] = g, d
    return ref


def test_integrator_agrees_with_dop853():
    """No effects, ideal settings: the fixed-step Dormand-Prince 5 plant matches DOP853 at rtol 1e-10 to 1e-9 m."""
    s = RigSettings.ideal(n_runs=1, duration=0.4)
    c = NOMINAL
    rig = Rig(c, [], s)
    N = 400
    t = np.arange(N) * s.Ts
    ref = _hover_ref(1, N, 18e-3, 5e-3)
    ref[0, :, 0] += 2e-3 * np.sin(2 * np.pi * 3 * t)  # a moving reference: the state visits many gaps
    ref[0, :, 3] += 20e-3 * np.sin(2 * np.pi * 1.5 * t)
    traj = simulate(rig, ref, np.random.default_rng(0))
    X = traj.X[0]
    u = traj.u[0]
    x = X[0, :4].copy()
    worst = 0.0
    for n in range(N - 1):

        def f(_t, z, iq=u[n, 0], idd=u[n, 1]):
            gdd, ddd = accelerations(z[0], z[2], iq, idd, c)
            return [z[1], gdd, z[3], ddd]

        sol = solve_ivp(f, (0.0, s.Ts), x, method="DOP853", rtol=1e-10, atol=1e-13)
        x_ref = sol.y[:, -1]
        worst = max(worst, abs(X[n + 1, 0] - x_ref[0]), abs(X[n + 1, 2] - x_ref[2]))
        x = X[n + 1, :4].copy()  # local comparison per period (the loop is closed on the simulator's state)
    assert worst < 1e-9
    assert np.ptp(X[:, 2]) > 10e-3  # the comparison did cover motion


def test_closed_loop_holds_a_hover_within_0p1mm():
    s = RigSettings(n_runs=2, duration=1.5)
    N = 1500
    ref = _hover_ref(2, N, 15e-3)
    ref[1, :, 0], ref[1, :, 3] = 22e-3, 30e-3
    rig = Rig(NOMINAL.drawn(np.random.default_rng(4), 0.05), [], s)
    traj = simulate(rig, ref, np.random.default_rng(1))
    err = traj.X[:, 300:][..., [0, 2]] - ref[:, 300:][..., [0, 3]]
    assert np.max(np.abs(err)) < 1e-4


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rigsim") / "ds"
    generate(
        folder, {"cogging": {"family": "gauss"}, "friction": {"family": "dahl"}}, seed=5, settings=RigSettings(**SMALL)
    )
    return folder


def test_dataset_reads_and_passes_simulate_check(small_dataset):
    ds = read_dataset(small_dataset)
    assert len(ds.runs) == 2 and ds.sample_time == 1e-3 and ds.encoder_resolution == 1e-5
    for r in ds.runs:
        assert r.locked == ()
        q = r["g"] / 1e-5
        assert np.allclose(q, np.round(q), atol=1e-6)  # quantized encoders
        assert np.all(np.hypot(r["i_q"], r["i_d"]) <= 8.0 + 1e-9)
    assert "truth" not in json.dumps(ds.meta)  # nothing of the truth in dataset.yaml
    proc = subprocess.run(
        [sys.executable, "-m", "maglev_ocp", "simulate", "--check", str(small_dataset)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr


def test_truth_record(small_dataset):
    truth = json.loads((small_dataset / "truth.json").read_text())
    assert truth["expected_verdict"] == "cogging+friction"
    assert truth["effects"]["cogging"]["family"] == "gauss"
    assert truth["effects"]["friction"]["family"] == "dahl"
    for e in truth["effects"].values():
        assert e["peak_force_n"] > 0.05
    tc = truth["true_constants"]
    for name, v in NOMINAL.as_dict().items():
        assert abs(tc[name] / v - 1) <= 0.05
    assert any(abs(tc[name] / v - 1) > 1e-3 for name, v in NOMINAL.as_dict().items())


def test_same_seed_same_bytes(tmp_path, small_dataset):
    again = generate(
        tmp_path / "again",
        {"cogging": {"family": "gauss"}, "friction": {"family": "dahl"}},
        seed=5,
        settings=RigSettings(**SMALL),
    )
    names = sorted(p.name for p in small_dataset.iterdir())
    assert names == sorted(p.name for p in again.iterdir())
    for n in names:
        assert (small_dataset / n).read_bytes() == (again / n).read_bytes(), n
    other = generate(tmp_path / "other", None, seed=6, settings=RigSettings(n_runs=1, duration=0.5))
    assert (other / "run_00.csv").read_bytes() != (again / "run_00.csv").read_bytes()


# effect -> parameters for the "changes the data" check (defaults where None; a fast drift for temperature)
EFFECT_CASES = {n: None for n in LAWS} | {"temperature_drift": {"tau_th": 0.5, "rise": 30.0}}


@pytest.fixture(scope="module")
def baseline_trajectory():
    return _trajectory(None)


def _trajectory(effects):
    s = RigSettings(n_runs=1, duration=2.0, excitation=ExcitationSettings(g_range=(11e-3, 16e-3)))
    rng_ref = np.random.default_rng(11)
    from maglev_ocp.rigsim.excite import references

    ref = references(1, 2000, s.Ts, s.excitation, rng_ref)
    rig = Rig(NOMINAL, build_laws(effects), s)
    return simulate(rig, ref, np.random.default_rng(12))


@pytest.mark.parametrize("name", list(LAWS))
def test_each_effect_changes_the_data(name, baseline_trajectory):
    traj = _trajectory({name: EFFECT_CASES[name]})
    dy = np.max(np.abs(traj.y - baseline_trajectory.y))
    du = np.max(np.abs(traj.u - baseline_trajectory.u))
    assert dy >= 2e-5 or du >= 0.02, (name, dy, du)
    # both runs share the noise streams, so the difference is the effect's; over the run it is more than
    # a one-off: the commanded currents differ by more than 2 mA RMS
    assert np.sqrt(np.mean((traj.u - baseline_trajectory.u) ** 2)) > 0.002, name


def test_every_family_runs_and_reports_a_size():
    s = RigSettings(n_runs=1, duration=0.3)
    for name, cls in LAWS.items():
        for fam in cls.families:
            laws = build_laws({name: {"family": fam}})
            ref = _hover_ref(1, 300, 12e-3, 40e-3)
            rig = Rig(NOMINAL, laws, s)
            traj = simulate(rig, ref, np.random.default_rng(0))
            assert np.all(np.isfinite(traj.X)), (name, fam)
            assert np.max(np.abs(traj.X[0, :, 0] - 12e-3)) < 1e-3, (name, fam)


def test_draw_is_seeded_and_covers_the_kinds():
    assert draw(3) == draw(3)
    kinds = {draw(s)["kind"] for s in range(60)}
    assert kinds == {"none", "single", "pair", "triple", "out_of_library"}
    for s in range(60):
        sc = draw(s)
        laws = build_laws(sc["effects"])
        n = {"none": 0, "single": 1, "pair": 2, "triple": 3, "out_of_library": 1}[sc["kind"]]
        assert len(laws) == n
        v = expected_verdict(laws)
        if sc["kind"] == "out_of_library":
            assert v == "unexplained" and laws[0].name in ALL_OUT_OF_LIBRARY
        elif sc["kind"] == "none":
            assert v == "none"
        else:
            assert set(v.split("+")) <= set(ALL_LIBRARY)
        old = build_laws(draw(s, laws="old")["effects"])  # the first families only
        assert {law.name for law in old} <= set(LIBRARY_EFFECTS) | set(OUT_OF_LIBRARY)
        assert not any(law.new_law for law in old)


def test_bad_effect_specs_are_refused():
    with pytest.raises(ValueError, match="unknown effect"):
        build_laws(["gravity_waves"])
    with pytest.raises(ValueError, match="family"):
        build_laws({"friction": {"family": "magic"}})
    with pytest.raises(ValueError, match="unknown parameters"):
        build_laws({"friction": {"family": "dahl", "vs": 1.0}})


def test_nominal_cogging_can_be_left_out():
    N = 600
    ref = _hover_ref(1, N, 12e-3, 0.25 * 19.05e-3)  # a quarter slot pitch: eq. (9) cogging near its peak
    with_cog = simulate(Rig(NOMINAL, [], RigSettings.ideal(n_runs=1)), ref, np.random.default_rng(0))
    without = simulate(
        Rig(NOMINAL, [], RigSettings.ideal(n_runs=1, nominal_cogging=False)), ref, np.random.default_rng(0)
    )
    # the controller (no cogging in its model) needs a different thrust current to hold d against it
    assert abs(with_cog.u[0, -1, 0] - without.u[0, -1, 0]) > 0.05
