"""Law families of the candidate library against laws a rig shows (issue 11, items 2 and 3).

The fast tests check that the library's laws nest physically different laws exactly (the independent
rig's laws of :mod:`maglev_ocp.rigsim.laws` are written apart from the library); the slow ones that a
dataset of the independent rig with such a law, or with two effects at once, gets the named set right,
with no spurious effect added for what a too-narrow law leaves.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.effects import Cogging, CommutationOffset, EndEffect, Saturation
from maglev_ocp.rigsim import laws as rig


def _num(v) -> float:
    return float(np.asarray(v).ravel()[0])


def test_cogging_harmonic_sign_is_half_a_period_and_its_normal_force_attracts():
    """A cogging harmonic of weight -h at phase phi is the harmonic h at phi + pi: the same tangential force and
    the same attractive normal force (Maxwell stress ~ B^2), never a repulsive one."""
    base = {**Cogging.defaults(), "xi0": 2.0, "kn": 0.8, "h1": 0.7}
    rng = np.random.default_rng(11)
    for _ in range(20):
        g, d = rng.uniform(9e-3, 24e-3), rng.uniform(-0.045, 0.045)
        h2, h3 = -rng.uniform(0.1, 1.0), -rng.uniform(0.1, 1.0)
        phi2, phi3 = rng.uniform(-math.pi, math.pi, 2)
        neg = {**base, "h2": h2, "h3": h3, "phi2": phi2, "phi3": phi3}
        pos = {**base, "h2": -h2, "h3": -h3, "phi2": phi2 + math.pi, "phi3": phi3 + math.pi}
        fx_n, fn_n = (_num(v) for v in Cogging().forces(g, d, neg))
        fx_p, fn_p = (_num(v) for v in Cogging().forces(g, d, pos))
        assert fx_n == pytest.approx(fx_p, rel=1e-9, abs=1e-12)
        assert fn_n == pytest.approx(fn_p, rel=1e-9, abs=1e-12)
        assert fn_n >= 0.0  # attractive (the model subtracts it from the gap's force)


def test_saturation_knee_nests_the_exponential_and_the_logistic_loss():
    """The saturation law's knee: 0 is the library's exponential loss exactly; knee = exp((g_knee - 8 mm) / w)
    with loss_8mm = loss knee / (1 + knee) is the rig's logistic loss ``loss / (1 + exp((g - g_knee) / w))``."""
    g = np.linspace(8e-3, 24e-3, 33)
    th = {**Saturation.defaults(), "loss_8mm": 0.2, "ell_sat": 3e-3, "knee": 0.0}
    k_exp = np.array([_num(Saturation.factor(x, th)) for x in g])
    np.testing.assert_allclose(k_exp, 1 - 0.2 * np.exp(-(g - k.g_stop[0]) / 3e-3), rtol=1e-12)
    law = rig.Saturation("logistic", loss=0.25, g_knee=11.5e-3, w=1.2e-3, target="both")
    b = math.exp((11.5e-3 - k.g_stop[0]) / 1.2e-3)
    th = {**th, "loss_8mm": 0.25 * b / (1 + b), "ell_sat": 1.2e-3, "knee": b}
    k_log = np.array([_num(Saturation.factor(x, th)) for x in g])
    np.testing.assert_allclose(1 - k_log, law.loss(g), rtol=1e-9, atol=1e-12)


def test_commutation_offset_drift_is_the_rigs_angle_along_the_stroke():
    """``delta + drift d`` rotates the dq currents as the rig's drifting commutation offset does."""
    law = rig.CommutationOffset("drift", delta0=-0.03, kappa=-2.5)
    th = {"delta": -0.03, "drift": -2.5}
    for d in (-0.04, 0.0, 0.035):
        x = [0.015, 0.0, d, 0.0]
        iq, i_d = 1.3, -0.4
        ours = np.asarray(CommutationOffset().currents(np.array([iq, i_d]), x, th)).ravel()
        np.testing.assert_allclose(ours, law.rotate(iq, i_d, d), rtol=1e-12)


def test_end_effect_two_ends_follow_the_rigs_asymmetric_overhang():
    """The ``two ends`` law (onset ``d_edge +- edge_skew``, loss per overhang ``edge_gain (1 +- gain_skew)``) is the
    rig's asymmetric overhang loss (each end its own onset and loss) up to the other end's softplus tail, which
    the rig keeps everywhere (below 1e-4 of the force here); the symmetric law (no skews) misses it by percent."""
    law = rig.EndEffect("asymmetric", e_p=0.039, e_n=0.030, w=5.4e-3, loss_p=0.90, loss_n=1.20)
    p = law.p
    edge, skew = 0.5 * (p["e_p"] + p["e_n"]), 0.5 * (p["e_p"] - p["e_n"])
    gain, gskew = 0.5 * (p["loss_p"] + p["loss_n"]), (p["loss_p"] - p["loss_n"]) / (p["loss_p"] + p["loss_n"])
    d = np.linspace(-0.058, 0.058, 117)
    ours = np.array([_num(EndEffect.overhang_factor(x, edge, p["w"], gain, 0.0, skew, gskew)) for x in d])
    sym = np.array([_num(EndEffect.overhang_factor(x, edge, p["w"], gain)) for x in d])
    truth = law.rho(d)
    assert np.max(np.abs(ours - truth)) < 1e-4
    assert np.max(np.abs(sym - truth)) > 0.01
    # no skew: the library's symmetric law, unchanged
    np.testing.assert_allclose(
        [_num(EndEffect.overhang_factor(x, 0.04, 4e-3, 1.0, 0.0, 0.0, 0.0)) for x in d],
        [_num(EndEffect.overhang_factor(x, 0.04, 4e-3)) for x in d],
        rtol=0,
        atol=1e-15,
    )


def test_current_terms_saturation_is_the_rigs_saturated_current_field():
    """The ``current terms`` member scales each magnetic term as the rig's saturation of the currents' field does
    to first order in the loss L: the PM-current and thrust terms (linear in that field) by 1 - L, the reluctance
    term (quadratic in it) by 1 - 2L, the magnets' attraction not at all; the difference is O(L^2)."""
    from maglev_ocp.diagnosis.candidates import family_specs

    member = next(m for m in family_specs()["saturation"] if m.law == "current terms")
    w = dict(member.fixed)
    law = rig.Saturation("exp", loss=0.05, ell=3.5e-3, target="current")
    for g in (9e-3, 11e-3, 15e-3, 22e-3):
        f = [1.0, 1.0, 1.0, 1.0]
        law.factors(g, 0.0, f)
        km, kc = f[0], f[1]
        L = float(law.loss(g))
        rig_terms = {"w_pm": km * km, "w_id": km * kc, "w_thrust": km * kc, "w_rel": kc * kc}
        for key, factor in rig_terms.items():
            ours = 1.0 - w[f"saturation.{key}"] * L
            assert abs(ours - factor) <= 1.01 * L * L, (g, key, ours, factor)


def _diagnose_rig(tmp_path, effects: dict, seed: int) -> str:
    from maglev_ocp.diagnosis.diagnose import diagnose
    from maglev_ocp.diagnosis.result import DiagnoseSettings
    from maglev_ocp.diagnosis.selftest import canonical
    from maglev_ocp.riglog import read_dataset
    from maglev_ocp.rigsim import RigSettings, generate

    folder = generate(tmp_path / "ds", effects, seed, RigSettings(n_runs=6, duration=10.0))
    diag = diagnose(read_dataset(folder), settings=DiagnoseSettings(seed=seed, consequence=False))
    return canonical(diag.verdict.verdict)


@pytest.mark.slow
def test_rig_friction_and_a_small_amplifier_lag_are_both_named(tmp_path):
    """Friction and a 0.8 ms effective amplifier delay at once on the independent rig: the lag, whose single
    fit the friction corrupts, is found by the joint refit of the forward step (the lag alone is found)."""
    effects = {
        "friction": {"family": "coulomb_viscous", "Fc_g": 0.15, "Fc_d": 0.15, "b_g": 0.5, "b_d": 1.2},
        "amplifier_lag": {"family": "first", "bandwidth_hz": 500.0, "delay_samples": 0.5},
    }
    assert set(_diagnose_rig(tmp_path, effects, 7301).split("+")) == {"friction", "amplifier_lag"}


@pytest.mark.slow
def test_rig_logistic_saturation_alone_adds_no_other_effect(tmp_path):
    """Saturation of the magnet field with a logistic knee (not the library's exponential): `saturation` alone,
    no second effect mopping up what an exponential loss would leave."""
    effects = {"saturation": {"family": "logistic", "loss": 0.2, "g_knee": 11e-3, "w": 1e-3, "target": "magnet"}}
    assert _diagnose_rig(tmp_path, effects, 7302) == "saturation"
