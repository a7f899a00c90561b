"""The claim guard's two-sided test for an effect no static map nests (:mod:`maglev_ocp.diagnosis.stages.claims`).

Synthetic held-out residuals with a known truth, fitted by least squares as the diagnosis fits its models: a
state ``x`` and a current rate ``r`` that the closed loop correlates with it (``r = c x + own part``), unit
noise. The *verdict's model* takes the rate (a lag-like regressor, 1 parameter) with a linear term in ``x`` (the
others' chosen member); the *flexible* explanation is a static Legendre series of degree 9 in ``x`` (the others at
full freedom). Expected paired z from ``z ~ rms(delta) sqrt(n) / (2 sigma)``
(:func:`~maglev_ocp.diagnosis.attribution.paired_z`), worked out before running:

- a real rate effect of rms 0.4 whose own part (not a function of ``x``) carries half its variance:
  ``rms(delta) ~ 0.28``, z ~ 8.9 over 4,000 samples: the verdict's model wins, the effect is kept;
- a static nonlinear misfit ``0.4 sin(2 x)`` (rms ~ 0.27, x uniform) that the rate regressor cannot take:
  z ~ -8.9: the flexible explanation wins, the effect is dropped;
- a rate effect whose every part is a function of ``x`` (``r = x``): both explain the gap alike (|z| < 4),
  and the one with fewer parameters is kept.
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.diagnosis.stages.claims import _two_sided, nested_in_static

N = 4000  # training and held-out samples each
Z_MIN = 4.0  # the default settings' z_min
DRAWS = range(5)


def _data(rng: np.random.Generator, own: float) -> tuple[np.ndarray, np.ndarray]:
    """State ``x`` (uniform, unit variance: bounded, as a gap is) and a unit-variance current rate with ``own`` of
    its variance its own."""
    x = rng.uniform(-np.sqrt(3.0), np.sqrt(3.0), N)
    r = np.sqrt(1 - own) * x + np.sqrt(own) * rng.standard_normal(N)
    return x, r


def _fit_predict(cols_train: np.ndarray, y: np.ndarray, cols_test: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(cols_train, y, rcond=None)
    return cols_test @ coef


def _compare(rng: np.random.Generator, truth, own: float) -> dict:
    """Fit both explanations on a training draw, compare them on a held-out draw."""
    out = []
    for _ in range(2):
        x, r = _data(rng, own)
        out.append((x, r, truth(x, r) + rng.standard_normal(N)))
    (xa, ra, ya), (xb, rb, yb) = out
    verdict = lambda x, r: np.column_stack([np.ones_like(x), x, r])  # noqa: E731
    flexible = lambda x, r: np.polynomial.legendre.legvander(x / np.sqrt(3.0), 9)  # noqa: E731
    e_v = yb - _fit_predict(verdict(xa, ra), ya, verdict(xb, rb))
    e_f = yb - _fit_predict(flexible(xa, ra), ya, flexible(xb, rb))
    return _two_sided(e_f, e_v, k_flexible=10, k_verdict=3, z_min=Z_MIN)


@pytest.mark.parametrize("seed", DRAWS)
def test_a_rate_effect_the_static_shape_only_imitates_is_kept(seed):
    two = _compare(np.random.default_rng(seed), lambda x, r: 0.4 * r, own=0.5)
    assert two["winner"] == "verdict" and two["keeps"], two
    assert 5.0 < two["z_region"] < 14.0, two  # expected ~8.9 (all samples ~ region: the difference is everywhere)


@pytest.mark.parametrize("seed", DRAWS)
def test_a_static_misfit_a_rate_regressor_soaked_up_is_dropped(seed):
    two = _compare(np.random.default_rng(100 + seed), lambda x, r: 0.4 * np.sin(2 * x), own=0.5)
    assert two["winner"] == "flexible" and not two["keeps"], two


@pytest.mark.parametrize("seed", DRAWS)
def test_a_tie_keeps_the_explanation_with_fewer_parameters(seed):
    two = _compare(np.random.default_rng(200 + seed), lambda x, r: 0.4 * r, own=0.0)
    assert two["winner"] == "tie", two
    assert two["keeps"]  # 3 parameters against 10
    swapped = _two_sided(np.zeros(1), np.zeros(1), 3, 10, Z_MIN)  # no samples: a tie, and now more parameters
    assert swapped["winner"] == "tie" and not swapped["keeps"]


def test_only_the_amplifier_lag_escapes_the_static_maps():
    """The lag's signature is the current rates; every other library effect's is a map of state and currents."""
    assert not nested_in_static("amplifier_lag")
    for e in ("cogging", "friction", "eddy_drag", "end_effect", "saturation", "commutation_offset"):
        assert nested_in_static(e), e
    assert nested_in_static("no such effect")  # without a signature: the cautious one-sided test
