"""Law families of the candidate library against physics written in the tests (issue 11, items 2 and 3).

The fast tests check the library's laws against closed forms stated here from the physics (the Park rotation
of the dq currents, the first-order loss of a saturated field, an exponential saturation, the symmetry of the
overhang loss). They do not compare the library with :mod:`maglev_ocp.rigsim`'s laws: the independent rig must
stay free to draw laws the library does not nest, or the rig check measures how well two generators agree. The
slow ones check that a dataset of the independent rig with a law the library does not hold exactly, or with two
effects at once, gets the named set right, with no spurious effect added for what a too-narrow law leaves.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.effects import Cogging, CommutationOffset, EndEffect, Saturation


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


def test_saturation_without_knee_is_the_exponential_loss_and_a_knee_holds_it_longer():
    """The saturation law's knee: 0 is the exponential loss ``1 - L8 exp(-(g - 8 mm) / ell)`` exactly; a positive
    knee gives the same loss at the stop and a plateau before it fades (a logistic shape: the loss above the
    exponential one at every larger gap); the loss falls as the gap opens and the factor never exceeds 1
    (saturation only loses force)."""
    g = np.linspace(8e-3, 24e-3, 33)
    th = {**Saturation.defaults(), "loss_8mm": 0.2, "ell_sat": 3e-3, "knee": 0.0}
    k_exp = np.array([_num(Saturation.factor(x, th)) for x in g])
    np.testing.assert_allclose(k_exp, 1 - 0.2 * np.exp(-(g - k.g_stop[0]) / 3e-3), rtol=1e-12)
    k_knee = np.array([_num(Saturation.factor(x, {**th, "knee": 5.0})) for x in g])
    assert np.all(k_knee <= 1.0 + 1e-15) and np.all(1 - k_knee[1:] > 1 - k_exp[1:])
    assert k_knee[0] == pytest.approx(k_exp[0], rel=1e-12) and np.all(np.diff(k_knee) > 0)


def test_commutation_offset_drift_is_a_park_rotation_along_the_stroke():
    """``delta + drift d`` rotates the dq currents by that electrical angle (Park transform): the q current the
    motor carries is ``iq cos(a) - id sin(a)`` and the d current ``iq sin(a) + id cos(a)``; the amplitude is kept."""
    th = {"delta": -0.03, "drift": -2.5}
    for d in (-0.04, 0.0, 0.035):
        x = [0.015, 0.0, d, 0.0]
        iq, i_d = 1.3, -0.4
        a = th["delta"] + th["drift"] * d
        ours = np.asarray(CommutationOffset().currents(np.array([iq, i_d]), x, th)).ravel()
        want = [iq * math.cos(a) - i_d * math.sin(a), iq * math.sin(a) + i_d * math.cos(a)]
        if not np.allclose(ours, want, rtol=1e-12):  # the opposite sense of rotation is the same law, -a
            want = [iq * math.cos(a) + i_d * math.sin(a), -iq * math.sin(a) + i_d * math.cos(a)]
        np.testing.assert_allclose(ours, want, rtol=1e-12, atol=1e-15)
        assert math.hypot(*ours) == pytest.approx(math.hypot(iq, i_d), rel=1e-12)


def test_end_effect_two_ends_are_mirror_images_without_skew_and_differ_with_it():
    """The overhang loss: with no skew a mirror image about d = 0 (the mover overhangs either end alike) and the
    library's symmetric law exactly; an onset skew moves the two ends' onsets apart by twice the skew, a gain
    skew makes one end lose more; the loss grows with the overhang and never turns into a gain."""
    d = np.linspace(-0.058, 0.058, 117)
    sym = np.array([_num(EndEffect.overhang_factor(x, 0.035, 5e-3, 1.0)) for x in d])
    np.testing.assert_allclose(sym, sym[::-1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        [_num(EndEffect.overhang_factor(x, 0.04, 4e-3, 1.0, 0.0, 0.0, 0.0)) for x in d],
        [_num(EndEffect.overhang_factor(x, 0.04, 4e-3)) for x in d],
        rtol=0,
        atol=1e-15,
    )
    skewed = np.array([_num(EndEffect.overhang_factor(x, 0.035, 5e-3, 1.0, 0.0, 0.004, 0.0)) for x in d])
    gain = np.array([_num(EndEffect.overhang_factor(x, 0.035, 5e-3, 1.0, 0.0, 0.0, 0.3)) for x in d])
    assert np.max(np.abs(skewed - skewed[::-1])) > 1e-3 and np.max(np.abs(gain - gain[::-1])) > 1e-3
    for prof in (sym, skewed, gain):
        assert np.all(prof <= 1.0 + 1e-12)
        # beyond 10 mm from the centre the loss only grows with the overhang (near d = 0 a skewed law has its
        # least loss off centre)
        assert np.all(np.diff(prof[68:]) <= 1e-12) and np.all(np.diff(prof[:49]) >= -1e-12)


def test_current_terms_saturation_is_first_order_in_the_currents_field():
    """The ``current terms`` member: a loss L of the currents' field (the magnets' field untouched) scales the
    terms linear in that field (PM-current, thrust) by 1 - L and the reluctance term, quadratic in it, by
    (1 - L)^2 = 1 - 2L + O(L^2); the magnets' attraction does not change."""
    from maglev_ocp.diagnosis.candidates import family_specs

    member = next(m for m in family_specs()["saturation"] if m.law == "current terms")
    w = dict(member.fixed)
    for L in (0.01, 0.05, 0.1):
        kc = 1.0 - L  # the currents' field; the magnets' field km = 1
        exact = {"w_pm": 1.0, "w_id": kc, "w_thrust": kc, "w_rel": kc * kc}
        for key, factor in exact.items():
            ours = 1.0 - w[f"saturation.{key}"] * L
            assert abs(ours - factor) <= 1.01 * L * L, (L, key, ours, factor)


def _diagnose_rig(tmp_path, effects: dict, seed: int) -> str:
    from maglev_ocp.diagnosis.diagnose import diagnose
    from maglev_ocp.diagnosis.result import DiagnoseSettings
    from maglev_ocp.diagnosis.selftest import canonical
    from maglev_ocp.riglog import read_dataset
    from maglev_ocp.rigsim import RigSettings, generate

    folder = generate(tmp_path / "ds", effects, seed, RigSettings(n_runs=6, duration=10.0))
    diag = diagnose(read_dataset(folder), settings=DiagnoseSettings(seed=seed, consequence=False))
    return canonical(diag.verdict.verdict)


@pytest.mark.long
def test_rig_friction_and_a_small_amplifier_lag_are_both_named(tmp_path):
    """Friction and a 0.8 ms effective amplifier delay at once on the independent rig: the lag, whose single
    fit the friction corrupts, is found by the joint refit of the forward step (the lag alone is found)."""
    effects = {
        "friction": {"family": "coulomb_viscous", "Fc_g": 0.15, "Fc_d": 0.15, "b_g": 0.5, "b_d": 1.2},
        "amplifier_lag": {"family": "first", "bandwidth_hz": 500.0, "delay_samples": 0.5},
    }
    assert set(_diagnose_rig(tmp_path, effects, 7301).split("+")) == {"friction", "amplifier_lag"}


@pytest.mark.long
def test_rig_logistic_saturation_alone_adds_no_other_effect(tmp_path):
    """Saturation of the magnet field with a logistic knee (not the library's exponential): `saturation` alone,
    no second effect mopping up what an exponential loss would leave."""
    effects = {"saturation": {"family": "logistic", "loss": 0.2, "g_knee": 11e-3, "w": 1e-3, "target": "magnet"}}
    assert _diagnose_rig(tmp_path, effects, 7302) == "saturation"
