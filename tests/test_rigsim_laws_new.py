"""The new law families of the independent rig (maglev_ocp.rigsim.laws_new, issue 27).

Each law is checked against a closed form or limit the law itself implies (from its source, not
from the code), every drawn law is finite and bounded over the rig's envelope, and the draw keeps
the old scenarios for ``laws="old"``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.generate import build_laws, expected_verdict
from maglev_ocp.rigsim.laws_new import NEW_LAWS, make_law

G_LO, G_HI = k.g_stop


def test_maxwell_slip_steady_sliding_is_coulomb_plus_viscous():
    # all elements broken away after a travel beyond xb: F = -(s(v) + b v), s = Fc when Fs = 0 (Dahl/Coulomb limit)
    law = make_law("friction", {"family": "maxwell_slip", "Fc_g": 0.3, "Fc_d": 0.2, "Fs_g": 0.0, "Fs_d": 0.0})
    law.reset(2)
    v = np.array([0.01, -0.02])
    for _ in range(200):  # 200 x 1e-4 s x 1 cm/s = 20 um > xb
        fg, fd = law.held(v, v, 1e-4)
    b = law.p["b_g"]
    assert fg == pytest.approx(-(0.3 * np.sign(v) + b * v), rel=1e-9)
    assert fd == pytest.approx(-(0.2 * np.sign(v) + b * v), rel=1e-9)


def test_maxwell_slip_presliding_is_a_spring_and_has_hysteresis():
    law = make_law("friction", {"family": "maxwell_slip", "b_g": 0.0, "b_d": 0.0, "Fs_g": 0.0, "Fs_d": 0.0})
    law.reset(1)
    x_small = 0.1 * law.x_break[0]  # below every break-away: all elements stick, F = -sum(k_i) x
    fg, _ = law.held(np.array([x_small / 1e-3]), np.array([0.0]), 1e-3)
    stiff = float(np.sum(law.p["Fc_g"] * law.weights / law.x_break))
    assert fg[0] == pytest.approx(-stiff * x_small, rel=1e-9)
    # go out by 3 xb and back by 3 xb: the force does not return to zero (hysteresis), it reverses to -Fc
    for v in (1e-2, -1e-2):
        for _ in range(6):
            fg, _ = law.held(np.array([v]), np.array([0.0]), law.p["xb"] / 1e-2 / 2)
        assert fg[0] == pytest.approx(-law.p["Fc_g"] * np.sign(v), rel=1e-9)


def test_karnopp_sticks_inside_the_band_and_slides_outside():
    law = make_law("friction", {"family": "karnopp", "Fc_g": 0.2, "Fs_g": 0.3, "dv": 1e-3, "b_g": 0.0})
    z = np.zeros(3)
    fg, _ = law.force(z, np.array([0.5e-3, 0.999e-3, 2e-3]), z, z)
    assert fg == pytest.approx([-0.15, -0.2997, -0.2], rel=1e-9)


def test_eddy_thin_plate_is_linear_at_low_speed_and_halves_at_v_c():
    law = make_law("eddy_drag", {"family": "thin_plate", "c0": 4.0, "v_c": 0.2})
    g = np.array([k.g_cog_ref])
    _, f_small = law.force(g, 0 * g, 0 * g, np.array([1e-5]))
    assert f_small[0] / 1e-5 == pytest.approx(-4.0, rel=1e-8)
    _, f_vc = law.force(g, 0 * g, 0 * g, np.array([0.2]))
    assert f_vc[0] == pytest.approx(-0.5 * 4.0 * 0.2, rel=1e-12)
    # pole-pitch harmonic decay with the gap: ratio exp(-2 pi dg / tau)
    _, f_far = law.force(g + 5e-3, 0 * g, 0 * g, np.array([1e-5]))
    assert f_far[0] / f_small[0] == pytest.approx(math.exp(-2 * math.pi * 5e-3 / k.tau), rel=1e-12)


def test_eddy_reitz_drag_peaks_at_w_and_lift_tends_to_f0():
    law = make_law("eddy_drag", {"family": "reitz", "F00": 1.2, "w": 0.1})
    g = np.array([k.g_cog_ref, k.g_cog_ref])
    lift, drag = law.force(g, 0 * g, 0 * g, np.array([0.1, 1e3]))
    assert -drag[0] == pytest.approx(0.6, rel=1e-12)  # F0 / 2 at v = w
    assert lift[1] == pytest.approx(1.2, rel=1e-6)  # F_L -> F0 at high speed
    v = np.linspace(0.0, 1.0, 2001)
    _, dr = law.force(np.full_like(v, k.g_cog_ref), 0 * v, 0 * v, v)
    assert v[np.argmax(-dr)] == pytest.approx(0.1, abs=1e-3)


@pytest.mark.parametrize(("family", "par"), [("frohlich", "beta"), ("langevin", "a")])
def test_saturation_laws_are_linear_at_low_field_and_lose_most_at_the_lower_stop(family, par):
    g = np.linspace(G_LO, G_HI, 50)
    weak = make_law("saturation", {"family": family, par: 1e-4})
    assert np.max(np.abs(weak.loss(g))) < 1e-4
    strong = make_law("saturation", {"family": family, par: 2.0})
    L = strong.loss(g)
    assert L[-1] == pytest.approx(0.0, abs=1e-12)  # normalized at the upper stop
    assert np.all(np.diff(L) < 0) and 0.05 < L[0] < 0.6


def test_frohlich_loss_at_the_stop_matches_the_b_h_law():
    beta = 0.5
    law = make_law("saturation", {"family": "frohlich", "beta": beta})
    x_hi = G_LO / G_HI
    assert law.loss(np.array([G_LO]))[0] == pytest.approx(1 - (1 + beta * x_hi) / (1 + beta), rel=1e-12)


def test_cascade_amplifier_step_matches_the_two_pole_closed_form():
    bw, fh = 200.0, 3200.0  # wf = 16 wc: zeta = 2, two real poles
    law = make_law("amplifier_lag", {"family": "cascade", "bandwidth_hz": bw, "filter_hz": fh})
    wc, wf = 2 * math.pi * bw, 2 * math.pi * fh
    p1, p2 = np.roots([1.0, wf, wc * wf])  # poles of wc wf / (s^2 + wf s + wc wf)
    p1, p2 = -p1.real, -p2.real
    for t in (1e-4, 5e-4, 2e-3):
        step = 1 - (p2 * math.exp(-p1 * t) - p1 * math.exp(-p2 * t)) / (p2 - p1)
        dev = law.transition(t)[0, 0] * (-1.0)  # state (i - u) starts at -1 for a unit step
        assert 1.0 + dev == pytest.approx(step, rel=1e-9, abs=1e-12)
    assert law.group_delay(1e-3) == pytest.approx(1.0 / wc, rel=1e-12)  # 2 zeta / wn = 1 / wc


def test_digital_amplifier_delay_is_computation_plus_half_a_sample():
    law = make_law("amplifier_lag", {"family": "digital", "n_comp": 2.0, "bandwidth_hz": 1000.0})
    assert law.p["delay_samples"] == 2.5
    with pytest.raises(ValueError, match="n_comp"):
        make_law("amplifier_lag", {"family": "digital", "n_comp": 1.0, "delay_samples": 2.0})
    # ZOH of a sampled sinusoid at low frequency: phase lag w Ts / 2, i.e. half a sample
    Ts, w = 1e-3, 2 * math.pi * 2.0
    t = np.linspace(0.0, 1.0, 200001)
    held = np.sin(w * np.floor(t / Ts) * Ts)
    fund = 2 * np.mean(held * np.exp(-1j * w * t))
    lag = -np.angle(fund / -1j) / w
    assert lag == pytest.approx(Ts / 2, rel=2e-2)


def test_skew_of_one_slot_pitch_removes_the_fundamental_cogging():
    law = make_law("cogging", {"family": "slot_harmonic", "c2": 0.0, "c3": 0.0, "skew": 1.0})
    d = np.linspace(-0.05, 0.05, 101)
    fn, fx = law.force(np.full_like(d, 12e-3), 0 * d, d, 0 * d)
    assert np.max(np.abs(fx)) < 1e-12 and np.max(np.abs(fn)) < 1e-12
    plain = make_law("cogging", {"family": "slot_harmonic", "c2": 0.0, "c3": 0.0, "skew": 0.0, "xi0": 2.0})
    d = np.linspace(-0.05, 0.05, 100001)
    _, fx = plain.force(np.full_like(d, k.g_cog_ref), 0 * d, d, 0 * d)
    assert np.max(np.abs(fx)) == pytest.approx(2.0, rel=1e-3)
    # period: the slot pitch (2 t1 for the pi d / t1 convention of seed eq. (9))
    _, a = plain.force(np.array([k.g_cog_ref]), 0, np.array([3e-3]), 0)
    _, b = plain.force(np.array([k.g_cog_ref]), 0, np.array([3e-3 + 2 * k.t1]), 0)
    assert a[0] == pytest.approx(b[0], rel=1e-9)


def test_end_detent_is_periodic_in_the_pole_pitch():
    law = make_law("cogging", {"family": "end_detent"})
    g = np.array([12e-3, 12e-3])
    _, fx = law.force(g, 0 * g, np.array([4e-3, 4e-3 + k.tau]), 0 * g)
    assert fx[0] == pytest.approx(fx[1], rel=1e-9)


@pytest.mark.parametrize("family", ["entry_exp", "fringe"])
def test_end_effect_laws_keep_full_force_at_the_centre_and_lose_it_at_overhang(family):
    law = make_law("end_effect", {"family": family, "loss": 0.3})
    assert law.rho(np.array([0.0]))[0] == pytest.approx(1.0, abs=1e-12)
    far = law.rho(np.array([10.0]))[0]
    assert far == pytest.approx(0.7, abs=2e-3)  # the full loss far beyond the edge
    d = np.linspace(0.0, 0.06, 61)
    assert np.all(np.diff(law.rho(d)) <= 1e-15)


def test_entry_exp_follows_the_entry_end_build_up():
    law = make_law("end_effect", {"family": "entry_exp", "d_edge": 0.02, "delta": 0.01, "loss": 0.2})
    assert law.rho(np.array([0.03]))[0] == pytest.approx(1 - 0.2 * (1 - math.exp(-1.0)), rel=1e-12)


def test_commutation_laws_rotate_without_changing_the_current_magnitude():
    for spec in ({"family": "pitch_error", "a": 0.1}, {"family": "cross_saturation", "kappa_i": 0.05}):
        law = make_law("commutation_offset", spec)
        iq, idd, d = np.array([3.0, -2.0]), np.array([1.0, 4.0]), np.array([0.01, -0.03])
        q2, d2 = law.rotate(iq, idd, d)
        assert np.hypot(q2, d2) == pytest.approx(np.hypot(iq, idd), rel=1e-12)
    law = make_law("commutation_offset", {"family": "cross_saturation", "delta0": 0.0, "kappa_i": 0.05})
    q2, d2 = law.rotate(np.array([2.0]), np.array([0.0]), np.array([0.0]))
    assert math.atan2(d2[0], q2[0]) == pytest.approx(0.1, rel=1e-12)


def test_cable_hysteresis_loop_has_width_two_f_y():
    law = make_law("cable_hysteresis", {"family": "jenkins", "F_y": 0.4, "k_h": 500.0})
    law.reset(1)
    for v in (0.05, -0.05):
        for _ in range(100):  # 5 mm of travel, far beyond F_y / k_h = 0.8 mm
            _, fd = law.held(np.zeros(1), np.array([v]), 1e-3)
        assert fd[0] == pytest.approx(-0.4 * np.sign(v), rel=1e-12)


def test_sensor_crosstalk_reads_the_other_axis():
    law = make_law("sensor_crosstalk", {"family": "linear", "c_gd": 2e-3, "c_dg": -4e-3})
    gr, dr = law.read(np.array([0.025]), np.array([0.05]))
    assert gr[0] == pytest.approx(0.025 + 1e-4, rel=1e-12) and dr[0] == pytest.approx(0.05 - 2e-5, rel=1e-9)


def test_every_drawn_new_law_is_finite_and_bounded_over_the_envelope():
    seen = set()
    for seed in range(80):
        for name, spec in draw(seed, laws="new")["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.new_law
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.3, 1.7))
    want = {(n, f) for n, c in NEW_LAWS.items() for f in c.families}
    assert seen == want  # 80 seeds draw every new family


def test_draw_old_reproduces_the_scenarios_drawn_before_the_new_laws():
    # recorded with the rig at commit 718fbd2 (before laws_new existed): draw(8)
    old = draw(8, laws="old")
    assert old["kind"] == "triple"
    assert {n: e["family"] for n, e in old["effects"].items()} == {
        "cogging": "twoexp",
        "end_effect": "asymmetric",
        "amplifier_lag": "second",
    }
    assert old["effects"]["cogging"]["xi0"] == 4.143699641892718
    assert old["effects"]["amplifier_lag"]["delay_samples"] == 1.5463381842084547
    assert old["effects"]["end_effect"]["loss_n"] == 1.3611974910161644
    assert not any(e["new_law"] for e in old["effects"].values())
    assert draw(3, laws="old")["effects"]["resonance"]["f_hz"] == 50.473329952103356


def test_draw_mix_is_seeded_and_gives_new_laws_a_fair_share():
    assert draw(21) == draw(21) and draw(21, laws="new") == draw(21, laws="new")
    flags = [e["new_law"] for s in range(200) for e in draw(s)["effects"].values()]
    assert 0.35 < np.mean(flags) < 0.75
    assert all(e["new_law"] for s in range(60) for e in draw(s, laws="new")["effects"].values())
    with pytest.raises(ValueError, match="laws must be one of"):
        draw(1, laws="some")


def test_a_new_law_dataset_is_seeded_byte_for_byte_and_marks_new_laws(tmp_path):
    import json

    effects = {"eddy_drag": {"family": "reitz"}, "friction": {"family": "maxwell_slip"}}
    s = RigSettings(n_runs=1, duration=0.5)
    a = generate(tmp_path / "a", effects, seed=4, settings=s)
    b = generate(tmp_path / "b", effects, seed=4, settings=s)
    for p in sorted(a.iterdir()):
        assert p.read_bytes() == (b / p.name).read_bytes(), p.name
    truth = json.loads((a / "truth.json").read_text())
    assert truth["effects"]["eddy_drag"]["new_law"] is True
    assert truth["effects"]["friction"]["new_law"] is True and truth["effects"]["friction"]["peak_force_n"] > 0.05
    assert truth["expected_verdict"] == expected_verdict(build_laws(effects)) == "eddy_drag+friction"


def test_every_new_family_runs_in_the_closed_loop_and_changes_the_data():
    from maglev_ocp.rigsim.excite import ExcitationSettings, references
    from maglev_ocp.rigsim.physics import NOMINAL
    from maglev_ocp.rigsim.sim import Rig, simulate

    s = RigSettings(n_runs=1, duration=0.6, excitation=ExcitationSettings(g_range=(11e-3, 16e-3)))
    ref = references(1, 600, s.Ts, s.excitation, np.random.default_rng(11))
    base = simulate(Rig(NOMINAL, [], s), ref, np.random.default_rng(12))
    for name, cls in NEW_LAWS.items():
        for fam in cls.families:
            traj = simulate(Rig(NOMINAL, build_laws({name: {"family": fam}}), s), ref, np.random.default_rng(12))
            assert np.all(np.isfinite(traj.X)), (name, fam)
            assert np.max(np.abs(traj.X[0, :, 0] - base.X[0, :, 0])) < 2e-3, (name, fam)  # still levitating
            # same noise streams: the difference is the law's, more than 2 mA RMS in the commands or
            # 20 um in the readings
            du = np.sqrt(np.mean((traj.u - base.u) ** 2))
            dy = np.max(np.abs(traj.y - base.y))
            assert du > 0.002 or dy >= 2e-5, (name, fam, du, dy)


@pytest.mark.filterwarnings("ignore:All-NaN slice")  # the fabricated cases carry no fitted constants
def test_rig_selftest_summary_splits_old_and_new_laws():
    from maglev_ocp.diagnosis.selftest import Case, SelftestSettings
    from maglev_ocp.diagnosis.selftest_rig import RigSelftestResult

    def case(i, kind, effects, truth, verdict):
        params = {"kind": kind, "effects": effects, "peak_force_n": {}, "effective_delay_s": {}}
        return Case(i, truth, params, verdict, truth == verdict, 0.0, 0.5, False, 1.0, 1.0, [])

    old, new = {"family": "dahl", "new_law": False}, {"family": "karnopp", "new_law": True}
    cases = [
        case(0, "single", {"friction": old}, "friction", "friction"),
        case(1, "single", {"friction": new}, "friction", "none"),
        case(2, "pair", {"friction": old, "eddy_drag": {"family": "reitz", "new_law": True}}, "a", "a"),
        case(3, "out_of_library", {"cable": {"family": "spring", "new_law": False}}, "unexplained", "unexplained"),
        case(4, "out_of_library", {"sensor_crosstalk": {"new_law": True}}, "unexplained", "friction"),
        case(5, "none", {}, "none", "none"),
    ]
    s = RigSelftestResult(SelftestSettings(), cases).summary()
    assert s["right_on_library_effect_sets_by_laws"] == {"old": 1.0, "new": 0.5}
    assert s["library_effect_sets_by_laws"] == {"old": 1, "new": 2}
    assert s["out_of_library_unexplained_by_laws"] == {"old": 1.0, "new": 0.0}
    text = RigSelftestResult(SelftestSettings(), cases).table()
    assert "named set right old 100% of 1, new 50% of 2" in text


def test_cli_draws_new_laws_and_refuses_an_unknown_law_set(tmp_path, capsys):
    import json

    from maglev_ocp.rigsim.__main__ import main

    out = tmp_path / "ds"
    args = ["--out", str(out), "--seed", "2", "--draw", "--laws", "new", "--runs", "1", "--duration", "0.3"]
    assert main(args) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["effects"] and all(e["new_law"] for e in truth["effects"].values())
    with pytest.raises(SystemExit) as e:
        main(["--out", str(tmp_path / "x"), "--draw", "--laws", "newest"])
    assert e.value.code == 2 and "invalid choice" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
