"""The backward check's test on the resolved samples (:func:`maglev_ocp.diagnosis.attribution.resolved_paired_z`).

Synthetic floor-normalized held-out residuals with a known truth: an effect whose difference and gain are spread
over all samples (a real amplifier lag: it acts wherever the currents move) must be kept with half the samples
unresolved; an effect that only takes up a sticking guide's structured misfit on the unresolved samples (and adds
a little error on the resolved ones) must be dropped although its all-sample z passes ``z_min``. The premise holds
both ways: an effect that gains on the resolved samples and loses on the unresolved ones (where the friction
law's structured misfit trades against it) must be kept although its all-sample z fails. The numbers are
chosen from ``z ~ rms(delta) sqrt(n) / (2 sigma)`` (:func:`~maglev_ocp.diagnosis.attribution.paired_z`) before
running: 12 draws, counts with the binomial margins stated at each assertion.
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.diagnosis.attribution import paired_z, resolved_delta_bic, resolved_paired_z

N = 4800  # held-out samples, as on the foreign rig
Z_MIN, Z_TIE = 4.0, 2.0  # the default settings' z_min and confusable_z
DRAWS = range(12)  # the tests' registered small seeds


def _resolved_half(rng: np.random.Generator) -> np.ndarray:
    """Unresolved samples in stretches (a guide sticks near velocity reversals), about half of them."""
    blocks = rng.random(N // 50) < 0.5
    return ~np.repeat(blocks, 50)


def test_an_effect_spread_over_all_samples_is_kept_with_half_of_them_unresolved():
    """rms(delta) = 0.2 sigma: expected z 6.9 over 4,800 samples, 4.9 over the resolved half (below z_min)."""
    kept, ratio = 0, []
    for k in DRAWS:
        rng = np.random.default_rng(k)
        e_b = rng.standard_normal(N)  # the full model leaves noise
        delta = 0.2 * rng.standard_normal(N)  # the effect's prediction, everywhere
        e_a = e_b + delta  # without the effect its prediction is left in the residual
        res = _resolved_half(rng)
        z, z_all, z_res = resolved_paired_z(e_a, e_b, e_a[res], e_b[res], Z_TIE)
        kept += z >= Z_MIN
        ratio.append(z_res * np.sqrt(N / res.sum()) / z_all)
    # per draw P(drop) ~ P(z_all < 4) + P(scaled z_res < 4) ~ 0.002 + 0.02: P(more than 1 of 12 dropped) ~ 2 %
    assert kept >= 11, kept
    # the resolved samples carry the same evidence per sample (the scaled z's sd is ~0.2 of its mean)
    assert abs(np.median(ratio) - 1.0) <= 0.25, ratio


def test_an_effect_that_only_takes_up_a_sticking_misfit_is_dropped():
    """On the unresolved samples a structured misfit (+-0.3 sigma in 4-sample stretches), 30 % of which the
    effect takes up; on the resolved ones the effect adds a 0.05 sigma error. All-sample z ~7.5 (above the
    library self-check's false lag, 4.5-5.3, so that the all-sample test alone keeps it on nearly every draw; at
    +-0.2 sigma it came out 5.1 +- 1.6 over the 12 draws), resolved z ~ -1.2."""
    passes_all, kept = 0, 0
    for k in DRAWS:
        rng = np.random.default_rng(k)
        res = _resolved_half(rng)
        noise = rng.standard_normal(N)
        misfit = 0.3 * np.repeat(rng.choice([-1.0, 1.0], N // 4), 4)
        spurious = 0.05 * rng.standard_normal(N)
        e_a = noise + np.where(res, 0.0, misfit)  # without the effect: the misfit stays where the guide sticks
        e_b = np.where(res, noise - spurious, noise + 0.7 * misfit)  # with it: 30 % taken up, an error elsewhere
        z, z_all, z_res = resolved_paired_z(e_a, e_b, e_a[res], e_b[res], Z_TIE)
        passes_all += z_all >= Z_MIN
        kept += z >= Z_MIN
        assert z_res < Z_TIE, (k, z_all, z_res)  # P(z_res >= 2) ~ 1e-3 per draw
    assert passes_all >= 10, passes_all  # the premise: over all samples it looks needed (z_all's sd ~2)
    assert kept == 0, kept


def test_a_gain_only_where_friction_is_unresolved_is_no_evidence():
    """The effect changes nothing on the resolved samples (zero difference there): not evidenced, whatever its
    all-sample z."""
    rng = np.random.default_rng(3)
    res = _resolved_half(rng)
    e_b = rng.standard_normal(N)
    e_a = e_b + np.where(res, 0.0, 0.3 * rng.standard_normal(N))
    z, z_all, z_res = resolved_paired_z(e_a, e_b, e_a[res], e_b[res], Z_TIE)
    assert z_all > Z_MIN  # expected ~7.3 (rms 0.3 on half the samples)
    assert z_res == 0.0
    assert z == 0.0


def test_with_every_sample_resolved_the_rule_is_the_plain_paired_z():
    """No sample left out: the same test as without the restriction."""
    rng = np.random.default_rng(5)
    e_b = rng.standard_normal(N)
    e_a = e_b + 0.1 * rng.standard_normal(N)
    z, z_all, _ = resolved_paired_z(e_a, e_b, e_a, e_b, Z_TIE)
    assert z == pytest.approx(paired_z(e_a, e_b, inflation="null"), rel=1e-12)
    assert z == z_all


def test_an_effect_that_loses_only_where_friction_is_unresolved_is_kept():
    """The other way round: the effect (rms(delta) = 0.2 sigma everywhere, as a real lag) gains on the resolved
    samples, and on the unresolved ones the friction law's structured misfit (+-0.3 sigma in 4-sample
    stretches) is 30 % larger with it than without (the other terms traded against it). Expected: resolved z ~4.9
    over the 2,400 resolved samples, ~6.9 at the all-sample count; all-sample z ~ -0.3 (gain 0.04 sigma^2 on one
    half, loss 0.046 on the other). The unresolved samples do not veto it."""
    kept, vetoed_all = 0, 0
    for k in DRAWS:
        rng = np.random.default_rng(50 + k)
        res = _resolved_half(rng)
        noise = rng.standard_normal(N)
        misfit = 0.3 * np.repeat(rng.choice([-1.0, 1.0], N // 4), 4)
        delta = 0.2 * rng.standard_normal(N)
        e_b = np.where(res, noise, noise + misfit)  # with the effect
        e_a = np.where(res, noise + delta, noise + 0.7 * misfit)  # without it
        z, z_all, _ = resolved_paired_z(e_a, e_b, e_a[res], e_b[res], Z_TIE)
        kept += z >= Z_MIN
        vetoed_all += z_all < Z_MIN
    # per draw P(scaled z_res < 4) ~ P(z_res < 2.8) ~ 0.02: P(more than 1 of 12 dropped) ~ 2 %
    assert kept >= 11, kept
    assert vetoed_all >= 11, vetoed_all  # the premise: the all-sample test alone would drop it


def test_the_criterion_on_the_resolved_samples_rewards_a_gain_and_charges_a_parameter():
    """``resolved_delta_bic``: n ln(SSE ratio) + dk ln(n) on the samples given (white noise, inflation 1)."""
    rng = np.random.default_rng(7)
    noise = rng.standard_normal(N)
    gain = resolved_delta_bic(noise, noise + 0.2 * rng.standard_normal(N), 1, 0, 1.0)
    assert gain == pytest.approx(N * np.log(1 / 1.04) + np.log(N), abs=40.0)  # ~ -180 +- sampling (sd ~ 25)
    assert resolved_delta_bic(noise, noise, 1, 0, 1.0) == pytest.approx(np.log(N), rel=1e-12)
    assert resolved_delta_bic(noise, noise, 1, 0, 4.0) == pytest.approx(np.log(N / 4), rel=1e-12)


def test_a_real_gain_with_heavy_tailed_products_keeps_its_evidence():
    """The backward check's ``null`` variance against the products' own mean square, where the better model's
    law is only nearly right where it acts: white unit noise, an effect of +-5 sigma on 1 % of the samples
    (isolated, random sign; a lag's spikes at the moves' current steps), and a model that takes up half of it
    (``e_b = noise + s/2``, ``delta = s/2``). Expected before running: gain ``0.75 * 25 * 0.01 = 0.1875``;
    ``null``: ``z = gain / (2 sqrt(mean(e_b^2) mean(delta^2) / n)) ~ 0.1875 / (2 sqrt(1.06 * 0.0625 / 4800))
    ~ 25.2``; the products' mean square is ``0.01 (0.25 * 25 + 0.0625 * 625) = 0.453``, about 6.8 times the null
    variance, so ``product`` gives ``z ~ 9.6``: the heavy tail hides 60 % of the evidence. The ratio is asserted,
    within 20 %, as the null z's level."""
    for k in DRAWS[:4]:
        rng = np.random.default_rng(k)
        noise = rng.standard_normal(N)
        s = np.zeros(N)
        at = rng.choice(N, size=N // 100, replace=False)
        s[at] = 5.0 * rng.choice([-1.0, 1.0], size=len(at))
        e_a, e_b = noise + s, noise + 0.5 * s
        z_null, z_prod = paired_z(e_a, e_b, inflation="null"), paired_z(e_a, e_b, inflation="product")
        assert z_null == pytest.approx(25.2, rel=0.2), (k, z_null)
        assert z_prod / z_null == pytest.approx(9.6 / 25.2, rel=0.2), (k, z_prod, z_null)


def test_the_null_variance_does_not_pass_fitted_noise():
    """Under the null (the better-looking model's extra structure is fitted noise: on the held-out runs its
    difference ``delta`` is independent of the residual, ``e_b = e_a - delta``) the gain has mean
    ``-mean(delta^2)``: with ``delta`` of rms 0.2 sigma, heavy-tailed (Student t, 3 degrees of freedom), z is
    negative on average and below ``z_min`` on every draw (P(z >= 4) ~ 3e-5 per draw)."""
    zs = []
    for k in DRAWS:
        rng = np.random.default_rng(k)
        e_a = rng.standard_normal(N)
        delta = 0.2 * rng.standard_t(3, size=N) / np.sqrt(3.0)
        zs.append(paired_z(e_a, e_a - delta, inflation="null"))
    assert max(zs) < Z_MIN, zs
    assert np.mean(zs) < 0, zs
