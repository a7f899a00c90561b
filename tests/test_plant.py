"""The plant simulator: shared model, noise and quantization, stops, fixtures, limits, effects, speed."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from maglev_ocp import constants as k
from maglev_ocp.blocks import Reference
from maglev_ocp.controllers.pid import PIDController
from maglev_ocp.effects import EFFECTS, AmplifierLag, EffectSet
from maglev_ocp.errors import ConfigError
from maglev_ocp.loop import run_closed_loop, run_open_loop
from maglev_ocp.model import get_model
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig, StopEvent, load_plant_config
from maglev_ocp.plant.excitation import ExcitationSettings, SumOfSines
from maglev_ocp.riglog import read_dataset, write_dataset

P_NOM = NOMINAL.vector()


def ideal(**over) -> PlantConfig:
    return PlantConfig.from_profile("ideal", over or None)


# ------------------------------------------------------------------ the shared model
def test_ideal_plant_is_the_shared_model_integrated_accurately(model):
    """Ideal profile, constant current: equals a tight-tolerance integration of model.f, and model.step exactly."""
    x0 = np.array([0.020, 0.0, 0.010, 0.0])
    u = np.asarray(model.u_eq(x0[0], x0[2], P_NOM)).ravel() + np.array([0.05, 0.02])
    plant = Plant(ideal(), NOMINAL, seed=0)
    plant.reset(x0, u0=u)
    n = 200
    for _ in range(n):
        plant.step(u)
    log = plant.log
    xs = np.column_stack([log["g_true"], log["g_dot_true"], log["d_true"], log["d_dot_true"]])
    xs = np.vstack([xs, plant.x])

    sol = solve_ivp(
        lambda t, x: np.asarray(model.f(x, u, P_NOM)).ravel(),
        (0, n * k.Ts),
        x0,
        t_eval=np.arange(n + 1) * k.Ts,
        method="DOP853",
        rtol=1e-12,
        atol=1e-15,
    )
    ref = sol.y.T
    assert abs(ref[-1, 0] - x0[0]) > 1e-4  # it really moved (unstable gap)
    np.testing.assert_allclose(xs[:, [0, 2]], ref[:, [0, 2]], rtol=0, atol=1e-10)  # positions to 0.1 nm
    np.testing.assert_allclose(xs[:, [1, 3]], ref[:, [1, 3]], rtol=0, atol=1e-8)
    # and it is the shared model's own RK4 with the same sub-steps (no retyped equations)
    F = model.step(k.Ts, 10)
    x = x0.copy()
    for i in range(n):
        x = np.asarray(F(x, u, P_NOM)).ravel()
        assert np.allclose(x, xs[i + 1], rtol=1e-12, atol=1e-15)


def test_plant_with_no_effects_matches_effectset_identity(model):
    """The empty effect set returns exactly the model's accelerations."""
    rng = np.random.default_rng(1)
    F = EffectSet([]).accel_function()
    for _ in range(10):
        x = np.array([rng.uniform(0.01, 0.03), rng.normal(0, 0.05), rng.uniform(-0.05, 0.05), rng.normal(0, 0.2)])
        u = rng.uniform(-5, 5, 2)
        a = np.asarray(F(x, u, P_NOM, [])).ravel()
        f = np.asarray(model.f(x, u, P_NOM)).ravel()
        assert a[0] == pytest.approx(f[1], rel=1e-14, abs=1e-14)
        assert a[1] == pytest.approx(f[3], rel=1e-14, abs=1e-14)


# ------------------------------------------------------------- noise / quantization / seeds
def test_default_profile_positions_are_exact_multiples_of_10um_after_csv(tmp_path):
    plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=5)
    log = run_closed_loop(plant, PIDController(NOMINAL), lambda t: Reference(g=0.02, d=0.0), 0.3, file="q.csv")
    write_dataset(tmp_path, [log])
    back = read_dataset(tmp_path).run("q.csv")
    for col in ("g", "d"):
        v = back[col]
        assert np.array_equal(v, log[col])  # bit for bit through the CSV
        assert np.array_equal(np.round(v / 1e-5) * 1e-5, v)
        assert len(np.unique(v)) > 1 or col == "d"  # the readings do move
    # the true positions are not quantized, the readings are within half a count plus noise
    err = back["g"] - back["g_true"]
    assert np.abs(err).max() < 0.5e-5 + 6 * 2e-6


def test_same_seed_same_data_different_seed_different(tmp_path):
    def dataset(seed: int, folder):
        plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=seed)
        log = run_closed_loop(plant, PIDController(NOMINAL), lambda t: Reference(g=0.018, d=0.001), 0.2, file="r.csv")
        write_dataset(folder, [log], meta={"true": plant.true_params.as_dict()})
        return (folder / "r.csv").read_bytes(), (folder / "dataset.yaml").read_bytes(), plant.true_params

    a = dataset(11, tmp_path / "a")
    b = dataset(11, tmp_path / "b")
    c = dataset(12, tmp_path / "c")
    assert a[0] == b[0] and a[1] == b[1] and a[2] == b[2]
    assert a[0] != c[0] and a[2] != c[2]


def test_seed_sequence_is_not_consumed_and_runs_are_independent_of_earlier_lengths():
    ss = np.random.SeedSequence(99)
    cfg = PlantConfig.from_profile("default", {"lock": {"axis": "g", "value": 0.02}})
    p1, p2 = Plant(cfg, seed=ss), Plant(cfg, seed=ss)
    assert p1.true_params == p2.true_params
    # run 2 of a plant depends on the seed and the run index only
    p1.reset()
    for _ in range(50):
        p1.step([0.0, 1.5])
    p2.reset()
    for _ in range(7):
        p2.step([0.0, 1.5])
    for p in (p1, p2):
        p.reset()
        for _ in range(20):
            p.step([0.1, 1.5])
    assert np.array_equal(p1.log["d"], p2.log["d"]) and np.array_equal(p1.log["d_true"], p2.log["d_true"])


def test_mismatch_draws_within_spread_and_overrides_win():
    cfg = PlantConfig.from_profile(
        "ideal", {"mismatch": {"relative": {"C1": 0.05, "C3": 0.05}, "overrides": {"C2": 800.0}}}
    )
    seen = set()
    for seed in range(20):
        tp = Plant(cfg, NOMINAL, seed=seed).true_params
        assert abs(tp.C1 / NOMINAL.C1 - 1) <= 0.05 and abs(tp.C3 / NOMINAL.C3 - 1) <= 0.05
        assert tp.C2 == 800.0 and tp.C4 == NOMINAL.C4 and tp.Mh == NOMINAL.Mh
        seen.add(tp.C1)
    assert len(seen) == 20


# ------------------------------------------------------------------ stops, fixtures, limits
def test_mover_driven_into_a_stop_gives_an_event_not_an_exception():
    cfg = ideal(stops={"enabled": True})
    plant = Plant(cfg, NOMINAL, seed=0)
    plant.reset()  # hovering at 20 mm
    hits = []
    for _ in range(600):  # i_d = +6 A weakens the attraction: the mover drops to the lower stop (32 mm gap)
        y = plant.step([0.0, 6.0])
        if y.info["stop"] is not None:
            hits.append(y.info["stop"])
    assert len(plant.events) == 1 and hits == plant.events
    ev = plant.events[0]
    assert isinstance(ev, StopEvent) and ev.axis == "g" and ev.side == "upper"
    assert 0.0 < ev.t < 0.6 and ev.speed > 0.05
    # the impact speed is the speed just before the hit
    log = plant.log
    i = round(ev.t / k.Ts) - 1
    assert ev.speed == pytest.approx(log["g_dot_true"][i], rel=0.2)
    assert plant.x[0] == 0.032 and plant.x[1] == 0.0  # resting on the stop, no bounce, no penetration
    assert "g hit its upper stop" in str(ev)


def test_horizontal_stop_and_locked_gap():
    cfg = ideal(stops={"enabled": True}, lock={"axis": "g", "value": 0.015})
    plant = Plant(cfg, NOMINAL, seed=0)
    y0 = plant.reset(np.array([0.025, 0.3, 0.05, 0.0]))  # lock overrides g and kills its velocity
    assert y0.y[0] == 0.015
    for _ in range(400):
        plant.step([-2.0, 0.0])  # i_q < 0 pushes +d
    log = plant.log
    assert np.all(log["g_true"] == 0.015) and np.all(log["g_dot_true"] == 0.0) and np.all(log["g"] == 0.015)
    assert [(e.axis, e.side) for e in plant.events] == [("d", "upper")]
    assert plant.x[2] == 0.060


def test_one_plant_runs_locked_and_free_with_the_same_true_parameters():
    plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=21)
    tp = plant.true_params
    plant.reset(np.array([0.02, 0.1, 0.01, 0.2]), lock="d")
    for _ in range(20):
        plant.step(plant.hover_currents(plant.x))
    assert plant.log.locked == ("d",) and np.all(plant.log["d_true"] == 0.01) and plant.log["g_dot_true"][0] == 0.1
    plant.reset(np.array([0.015, 0.0, -0.03, 0.0]), lock="g")
    for _ in range(20):
        plant.step([-0.5, 0.0])
    assert plant.log.locked == ("g",) and np.all(plant.log["g_true"] == 0.015) and plant.x[2] > -0.03
    plant.reset()
    assert plant.log.locked == () and plant.true_params == tp
    with pytest.raises(ValueError):
        plant.reset(lock="x")


def test_locked_axis_reads_a_constant_despite_noise():
    cfg = PlantConfig.from_profile("default", {"lock": {"axis": "d", "value": 3 * k.t1 / 2}})
    plant = Plant(cfg, NOMINAL, seed=3)
    log = run_closed_loop(plant, PIDController(NOMINAL), lambda t: Reference(g=0.015, d=3 * k.t1 / 2), 0.3)
    assert len(np.unique(log["d"])) == 1 and np.all(log["d_true"] == 3 * k.t1 / 2)
    assert log["d"][0] == round(3 * k.t1 / 2 / 1e-5) * 1e-5
    assert len(np.unique(log["g"])) > 1  # the free axis carries noise
    assert plant.log.locked == ("d",)


def test_current_limits_clip_each_axis_then_the_amplitude():
    plant = Plant(ideal(current_limits={"enabled": True}), NOMINAL, seed=0)
    u, lim = plant.limit([-12.0, 0.0])
    assert lim and u[0] == -8.0 and u[1] == 0.0
    u, lim = plant.limit([12.0, -3.0])  # clipped to (8, -3), then scaled to |i| = 8
    assert lim and math.hypot(*u) == pytest.approx(8.0) and u[0] / u[1] == pytest.approx(-8 / 3)
    u, lim = plant.limit([7.0, 7.0])
    assert lim and math.hypot(*u) == pytest.approx(8.0) and u[0] == pytest.approx(u[1])
    u, lim = plant.limit([1.0, -2.0])
    assert not lim and list(u) == [1.0, -2.0]
    plant.reset()
    y = plant.step([20.0, 20.0])
    assert y.info["limited"] and math.hypot(y.info["i_q_cmd"], y.info["i_d_cmd"]) == pytest.approx(8.0)
    assert plant.log["i_q"][0] == pytest.approx(8 / math.sqrt(2))


def test_noise_changes_only_what_it_should():
    base = Plant(ideal(), NOMINAL, seed=4)
    noisy = Plant(ideal(measurement_noise={"g": 5e-6, "d": 5e-6}), NOMINAL, seed=4)
    for p in (base, noisy):
        p.reset()
        for _ in range(30):
            p.step(p.hover_currents(p.x))
    assert np.array_equal(base.log["g_true"], noisy.log["g_true"])  # sensor noise does not move the mover
    assert not np.array_equal(base.log["g"], noisy.log["g"])
    forced = Plant(ideal(process_noise={"g": 0.5, "d": 0.5}), NOMINAL, seed=4)
    forced.reset()
    for _ in range(30):
        forced.step(forced.hover_currents(forced.x))
    assert not np.array_equal(base.log["g_true"], forced.log["g_true"])


def test_step_before_reset_and_nonfinite_commands_raise_programming_errors():
    plant = Plant(ideal(), NOMINAL, seed=0)
    with pytest.raises(RuntimeError):
        plant.step([0.0, 0.0])
    plant.reset()
    with pytest.raises(ValueError):
        plant.step([math.nan, 0.0])


# ------------------------------------------------------------------------------ effects
def _acc(names, values, x, u, p=P_NOM):
    es = EffectSet(names)
    return np.asarray(es.accel_function()(x, u, p, es.vector(values))).ravel()


def test_cogging_effect_reproduces_the_spec_law_as_a_special_case(model):
    rng = np.random.default_rng(0)
    spec = {"cogging": {"xi0": 4.0, "ell": 3.6e-3, "power": 0.0, "h1": 1.0, "h2": 0.0, "h3": 0.0, "kn": 1.0}}
    p0 = NOMINAL.without_cogging().vector()
    for _ in range(10):
        x = np.array([rng.uniform(0.009, 0.03), 0.0, rng.uniform(-0.05, 0.05), 0.0])
        u = rng.uniform(-3, 3, 2)
        a = _acc(["cogging"], spec, x, u, p0)
        f = np.asarray(model.f(x, u, P_NOM)).ravel()
        np.testing.assert_allclose(a, f[[1, 3]], rtol=1e-12, atol=1e-12)


def test_cogging_harmonics_are_periodic_and_stronger_at_small_gaps():
    vals = {"cogging": {"xi0": 2.0, "h1": 0.0, "h2": 1.0, "h3": 0.0, "phi2": 0.0}}
    u = np.zeros(2)
    base = lambda g, d: _acc([], {}, [g, 0, d, 0], u, NOMINAL.without_cogging().vector())  # noqa: E731
    extra = lambda g, d: _acc(["cogging"], vals, [g, 0, d, 0], u, NOMINAL.without_cogging().vector()) - base(g, d)  # noqa: E731
    d = k.t1 / 4  # 2nd harmonic sin(2 pi d / t1) peaks here
    assert extra(0.012, d)[1] > 0 and extra(0.012, d)[1] == pytest.approx(extra(0.012, d + k.t1)[1], rel=1e-9)
    assert abs(extra(0.012, 0.0)[1]) < 1e-12
    assert abs(extra(0.010, d)[1]) > 3 * abs(extra(0.015, d)[1])  # decays with the gap
    assert extra(0.012, d)[0] < 0  # the normal part attracts (reduces the gap)


def test_friction_decelerates_both_axes():
    u = np.array([0.0, 1.5])
    for v in (0.05, -0.05):
        x = np.array([0.02, v, 0.0, v])
        a0 = _acc([], {}, x, u)
        a1 = _acc(["friction"], {}, x, u)
        assert np.all(np.sign(a1 - a0) == -np.sign(v))
    # on the plant: a mover coasting horizontally (gap locked) stops sooner with friction
    out = []
    for cfg in (
        ideal(lock={"axis": "g", "value": 0.02}),
        ideal(lock={"axis": "g", "value": 0.02}, effects={"friction": {"enabled": True}}),
    ):
        plant = Plant(cfg, NOMINAL.without_cogging(), seed=0)
        plant.reset(np.array([0.02, 0, 0.0, 0.05]), u0=np.zeros(2))
        for _ in range(300):
            plant.step([0.0, 0.0])
        out.append(plant.x[3])
    assert out[0] == pytest.approx(0.05, rel=1e-9)
    # Coulomb + viscous at 50 mm/s (Stribeck negligible): v(t) = (v0 + Fc/b) exp(-b t / Mh) - Fc/b
    Fc, b = 0.1, 0.5  # the effect's defaults
    assert out[1] == pytest.approx((0.05 + Fc / b) * math.exp(-b * 0.3 / k.Mh) - Fc / b, rel=1e-3)


def test_commutation_offset_makes_a_normal_force_from_i_q():
    x = np.array([0.02, 0.0, 0.0, 0.0])
    u = np.array([2.0, 0.0])
    a0 = _acc([], {}, x, u)
    a1 = _acc(["commutation_offset"], {"commutation_offset": {"delta": 0.1}}, x, u)
    assert a1[0] > a0[0] + 0.05  # i_d' = sin(delta) i_q > 0 weakens the attraction: g_ddot grows
    assert abs(a1[1]) < abs(a0[1])  # and the thrust shrinks by cos(delta)
    a2 = _acc(["commutation_offset"], {"commutation_offset": {"delta": -0.1}}, x, u)
    assert a2[0] < a0[0] - 0.05


def test_saturation_weakens_forces_most_at_small_gaps():
    def magnetic(g, names):
        x = np.array([g, 0, 0, 0])
        return k.G - _acc(names, {}, x, np.array([0.0, 1.0]))[0]  # net upward magnetic acceleration

    r_small = magnetic(0.009, ["saturation"]) / magnetic(0.009, [])
    r_large = magnetic(0.025, ["saturation"]) / magnetic(0.025, [])
    assert r_small < 0.95 and r_small < r_large < 1.0


def test_end_effect_ripple_has_the_pole_pitch_and_overhang_loses_thrust():
    u = np.array([1.0, 0.0])
    vals = {"end_effect": {"ripple": 0.05, "d_edge": 0.045}}
    thrust = lambda d, v=vals: _acc(["end_effect"], v, [0.02, 0, d, 0], u, NOMINAL.without_cogging().vector())[1]  # noqa: E731
    nominal = _acc([], {}, [0.02, 0, 0, 0], u, NOMINAL.without_cogging().vector())[1]
    assert thrust(0.0) == pytest.approx(nominal * 1.05, rel=1e-6)
    far = {"end_effect": {"ripple": 0.05, "d_edge": 0.2}}  # no overhang anywhere in the stroke
    assert thrust(-0.02, far) == pytest.approx(thrust(-0.02 + k.tau, far), rel=1e-9)  # period tau
    assert thrust(-0.02, far) != pytest.approx(thrust(-0.02 + k.tau / 2, far), rel=1e-3)
    no_ripple = {"end_effect": {"ripple": 0.0, "d_edge": 0.045}}
    assert abs(thrust(0.058, no_ripple)) < abs(thrust(0.0, no_ripple)) * 0.97
    assert abs(thrust(-0.058, no_ripple)) < abs(thrust(0.0, no_ripple)) * 0.97


def test_amplifier_lag_and_delay_on_the_plant():
    bw, delay = 500.0, 2
    cfg = ideal(
        lock={"axis": "g", "value": 0.02},
        effects={"amplifier_lag": {"enabled": True, "bandwidth_hz": bw, "delay_samples": delay}},
    )
    plant = Plant(cfg, NOMINAL, seed=0)
    plant.reset(u0=np.zeros(2))
    applied = [plant.step([1.0, 0.0]).info["i_q_applied"] for _ in range(6)]
    a = math.exp(-2 * math.pi * bw * k.Ts)
    expected = [0.0, 0.0] + [1 - a ** (n + 1) for n in range(4)]
    np.testing.assert_allclose(applied, expected, rtol=1e-12, atol=1e-15)
    # the offline filter gives the period means of the same law
    means = AmplifierLag.filter_currents(
        np.tile([1.0, 0.0], (6, 1)), {"bandwidth_hz": bw, "delay_samples": delay}, i0=np.zeros(2)
    )
    assert means[0, 0] == 0.0 and means[1, 0] == 0.0
    assert means[2, 0] == pytest.approx(1 - (1 - a) / (2 * math.pi * bw * k.Ts), rel=1e-12)
    assert np.all(means[2:, 0] < np.array(expected[2:]))  # a mean lags the end-of-period value


def test_parameter_error_and_eddy_drag():
    x = np.array([0.02, 0.0, 0.0, 0.2])
    u = np.array([1.0, 1.0])
    p0 = NOMINAL.without_cogging().vector()
    a0 = _acc([], {}, x, u, p0)
    a1 = _acc(["parameter_error"], {"parameter_error": {"k_C1": 1.1, "k_Mv": 1.25}}, x, u, p0)
    assert a1[1] == pytest.approx(1.1 * a0[1], rel=1e-12)
    assert a1[0] - k.G == pytest.approx((a0[0] - k.G) / 1.25, rel=1e-12)  # gravity is not a force on the mass
    a2 = _acc(["eddy_drag"], {}, x, u, p0)
    assert a2[1] < a0[1] and a2[0] == a0[0]


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_every_effect_switched_on_alone_changes_the_plant(name):
    """Each effect, alone, changes the closed-loop run (and the default values are inside the bounds)."""
    es = EffectSet([name])
    lo, hi = es.bounds()
    assert np.all(lo <= es.defaults()) and np.all(es.defaults() <= hi)
    values = {"parameter_error": {"k_C2": 1.05}}.get(name, {})  # its defaults are the identity
    runs = []
    for on in (False, True):
        cfg = ideal(effects={name: {"enabled": on, **values}})
        plant = Plant(cfg, NOMINAL, seed=0)
        ref = SumOfSines(ExcitationSettings(fade_in=0.0), seed=1)
        log = run_closed_loop(plant, PIDController(NOMINAL), ref, 0.25, x0=np.array([0.02, 0, 0.0, 0]))
        runs.append(np.column_stack([log["g_true"], log["d_true"]]))
    # The smallest default effect (saturation) moves this loop by about 2 µm, the integration's own noise is
    # ~1e-12 m: 0.5 µm separates "the effect acts" from "something rounded differently".
    assert np.abs(runs[1] - runs[0]).max() > 0.5e-6


def test_effect_functions_work_on_mx_for_the_diagnosis_nlp():
    es = EffectSet(list(EFFECTS))
    x, u, p, th = ca.MX.sym("x", 4), ca.MX.sym("u", 2), ca.MX.sym("p", 8), ca.MX.sym("th", es.n_theta)
    f = ca.Function("f", [x, u, p, th], [es.accel(x, u, p, th)])
    J = ca.Function("J", [x, u, p, th], [ca.jacobian(es.accel(x, u, p, th), th)])
    xv, uv = np.array([0.015, 0.01, 0.02, -0.03]), np.array([0.4, 2.0])
    a_mx = np.asarray(f(xv, uv, P_NOM, es.defaults())).ravel()
    a_sx = np.asarray(es.accel_function()(xv, uv, P_NOM, es.defaults())).ravel()
    np.testing.assert_allclose(a_mx, a_sx, rtol=1e-12)
    assert np.all(np.isfinite(np.asarray(J(xv, uv, P_NOM, es.defaults()))))


# --------------------------------------------------------------------------- config
def test_plant_file_overlays_its_profile(tmp_path):
    f = tmp_path / "rig.yaml"
    f.write_text("profile: default\nprocess_noise: {g: 0.3}\neffects:\n  saturation: {enabled: true, loss_8mm: 0.2}\n")
    cfg = load_plant_config(f)
    assert cfg.process_noise.g == 0.3 and cfg.process_noise.d == 0.02  # the rest from the profile
    assert cfg.enabled_effects() == ("amplifier_lag", "friction", "saturation")
    assert cfg.effect_values()["saturation"]["loss_8mm"] == 0.2
    cfg.save(tmp_path / "full.yaml")
    assert load_plant_config(tmp_path / "full.yaml") == cfg
    with pytest.raises(ConfigError, match="unknown plant profile"):
        PlantConfig.from_profile("nope")


def test_too_stiff_friction_is_refused():
    with pytest.raises(ConfigError, match="v_reg"):
        PlantConfig.from_profile("ideal", {"effects": {"friction": {"enabled": True, "v_reg": 1e-6, "coulomb_d": 5.0}}})


# --------------------------------------------------------------------- closed loop, speed
@pytest.mark.parametrize("g_mm", [10.0, 17.5, 27.5])
def test_pid_stabilizes_the_gap_anywhere_in_10_to_27_5_mm(g_mm):
    plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=2)
    g = g_mm * 1e-3
    log = run_closed_loop(
        plant, PIDController(NOMINAL), lambda t: Reference(g=g, d=0.0), 1.0, x0=np.array([g + 0.5e-3, 0, 0.002, 0])
    )  # start off the set-point
    settled = slice(500, None)
    assert np.abs(log["g_true"][settled] - g).max() < 1e-4  # holds 0.1 mm
    assert np.abs(log["d_true"][settled]).max() < 2e-4
    assert not plant.events


def test_pid_tracks_a_slow_sum_of_sines_roughly():
    plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=8)
    ref = SumOfSines(ExcitationSettings(), seed=3)
    log = run_closed_loop(plant, PIDController(NOMINAL), ref, 3.0)
    eg = log["g_true"] - log["g_ref"]
    ed = log["d_true"] - log["d_ref"]
    assert np.ptp(log["g_ref"]) > 1e-3 and np.ptp(log["d_ref"]) > 3e-3  # it did excite
    assert np.sqrt(np.mean(eg**2)) < 1e-4 and np.sqrt(np.mean(ed**2)) < 5e-4
    assert not plant.events


def test_open_loop_parabola_at_a_locked_gap_matches_seed_eq_5():
    """Seed eq. (5): with g locked and constant u1, d(t) = d0 - L1 u1 t^2 / 2."""
    g = 0.0225
    p = NOMINAL.without_cogging()
    plant = Plant(ideal(lock={"axis": "g", "value": g}), p, seed=0)
    log = run_open_loop(plant, np.tile([-0.5, 0.0], (150, 1)), x0=np.array([g, 0, -0.05, 0]), u0=[-0.5, 0.0])
    t = log.t
    c = np.polyfit(t, log["d"], 2)
    L1 = p.C1 * float(get_model().shape(g)[3])
    assert 2 * c[0] / 0.5 == pytest.approx(L1, rel=1e-3)  # d_ddot = -L1 u1, quantized readings


def test_open_loop_run_is_the_plant_stepped_by_hand():
    """run_open_loop (the closed loop with a replaying controller) logs what stepping the plant by hand logs."""
    cfg = PlantConfig.from_profile("default")
    seq = np.column_stack([0.3 * np.sin(np.arange(120) / 9.0), 1.4 + 0.2 * np.cos(np.arange(120) / 7.0)])
    x0 = np.array([0.019, 0, 0.004, 0])
    log = run_open_loop(Plant(cfg, NOMINAL, seed=4), seq, x0=x0, file="o.csv")
    plant = Plant(cfg, NOMINAL, seed=4)
    plant.reset(x0)
    for u in seq:
        plant.step(u)
    for c in ("t", "g", "d", "i_q", "i_d", "g_true", "d_dot_true"):
        np.testing.assert_array_equal(log[c], plant.log[c])
    assert log.file == "o.csv" and log.meta["controller"] == "open-loop"


def test_closed_loop_run_lets_a_controller_error_through():
    """A data generator must not write half a run silently: the controller's exception propagates."""

    class Broken(PIDController):
        def step(self, y, ref):
            if y.t > 0.01:
                raise RuntimeError("broken controller")
            return super().step(y, ref)

    plant = Plant(PlantConfig.from_profile("ideal"), NOMINAL, seed=0)
    with pytest.raises(RuntimeError, match="broken controller"):
        run_closed_loop(plant, Broken(NOMINAL), lambda t: Reference(g=0.02, d=0.0), 0.1)
    with pytest.raises(ValueError, match="shorter than two periods"):
        run_closed_loop(plant, PIDController(NOMINAL), lambda t: Reference(g=0.02, d=0.0), 0.001)


# ------------------------------------------------------- impossible parameters, NaN hover currents
def test_parameter_files_refuse_impossible_constants(tmp_path):
    """C3 = C4 = 0 (no current can hold the mover), zero masses, NaN: refused on load, naming the key."""
    from maglev_ocp.params import load_params

    for text, key, what in [
        ("C3: 0\nC4: 0\n", "C3", "greater than 0"),
        ("Mv: 0\n", "Mv", "greater than 0"),
        ("ell: 0\n", "ell", "greater than 0"),
        ("xi0: -1\n", "xi0", "greater than or equal to 0"),
        ("C1: .nan\n", "C1", "NaN/inf is not allowed"),
        ("C2: .inf\n", "C2", "NaN/inf is not allowed"),
    ]:
        path = tmp_path / "p.yaml"
        path.write_text(text)
        with pytest.raises(ConfigError) as ei:
            load_params(path)
        assert f"{path}: {key}: " in str(ei.value) and what in str(ei.value), str(ei.value)


def test_hover_envelope_check_uses_the_model():
    """Real, finite hover currents (seed eq. (8)) at every gap of the envelope: nominal passes; a field too weak
    to balance the magnets (small C3, large C4) or a huge cogging force fails, naming the keys; a limit below the
    hover current at 15 mm (3.33 A, MODEL.md) fails."""
    from maglev_ocp.plant.config import hover_envelope_error

    assert hover_envelope_error(NOMINAL) is None
    assert hover_envelope_error(NOMINAL, limit=k.i_amp_max) is None
    msg = hover_envelope_error(NOMINAL.with_(C3=3.0))
    assert msg.startswith("C2, C3, C4:") and "15.0 mm" in msg
    assert "xi0, ell" in hover_envelope_error(NOMINAL.with_(xi0=900.0, ell=0.5))
    assert "3.33 A" in hover_envelope_error(NOMINAL, limit=3.0)
    assert "C3, C4" in hover_envelope_error(NOMINAL.with_(C3=0.0, C4=0.0))
    assert "NaN/inf" in hover_envelope_error(NOMINAL.with_(Mh=math.nan))


def test_plant_that_cannot_hover_says_so_instead_of_commanding_0A():
    """A rig whose true parameters have no hover current at the start: a one-line error, not a silent 0 A."""
    plant = Plant(ideal(), NOMINAL.with_(C3=3.0), seed=0)
    with pytest.raises(ConfigError, match=r"cannot hover at g = 15\.00 mm"):
        plant.reset(np.array([0.015, 0.0, 0.0, 0.0]))
    # the gap locked in its fixture needs no hover current
    y = plant.reset(np.array([0.015, 0.0, 0.0, 0.0]), lock="g")
    assert y.info["i_d_applied"] == 0.0


def test_pid_holds_the_last_hover_current_where_its_model_cannot_hover(monkeypatch):
    """A reference where the PID's model has no hover current: the last good one is held (not 0 A) and the
    step is flagged; a start where it has none is a clear error."""
    from maglev_ocp.blocks import Measurement

    ctrl = PIDController(NOMINAL)
    y0 = Measurement(0.0, np.array([0.020, 0.0]), None)
    ref = Reference(g=0.020, d=0.0)
    ctrl.reset(y0, ref)
    good = ctrl.step(y0, ref)
    assert "fallback" not in good.stats
    u_eq = good.stats["i_d_eq"]
    real = ctrl.schedule
    monkeypatch.setattr(ctrl, "schedule", lambda g, d: (np.full(2, np.nan), *real(g, d)[1:]))
    out = ctrl.step(y0, ref)
    assert out.stats["fallback"] == 1
    assert out.stats["i_d_eq"] == u_eq
    assert abs(out.u[1] - good.u[1]) < 0.1  # the hover current, not a 1.5 A drop to 0 A
    with pytest.raises(ConfigError, match="no hover current"):
        ctrl.reset(y0, ref)
