"""The claim guard's test (c): an effect named beside others must explain more than the verdict leaves
(:func:`~maglev_ocp.diagnosis.stages.claims.leftover_test`, :func:`~.leftover_excess`).

Synthetic held-out residuals with a known composition, fitted by least squares as the diagnosis fits a flexible
member: unit noise (the floor), a misfit of the other effects that no basis here takes (a random smooth signal of
time, as a friction's memory is to a static map of the state) and, when the effect is there, a force of its own
on a static basis of a state ``x`` (a cubic B-spline-like set of columns: Legendre polynomials of degree 6). The
misfit also correlates with ``x`` (a share ``rho`` of its variance), as a leftover does with the state it was
made on. What each case should give, worked out before running:

- no effect of its own, a misfit of rms 1.5 floors with 20 % of its variance on the basis: the basis explains
  about ``sqrt(0.2) 1.5 = 0.67`` floors, the verdict (the basis fitted) leaves about ``sqrt(0.8) 1.5 = 1.34``
  above the floor: test (c) fails, the effect is not claimed;
- the effect there at rms 2 floors beside the same misfit: it explains about 2.1, the leftover is 1.34: it passes;
- a small effect (0.5 floors) beside others that leave nothing but the noise (leftover ~0): it passes: (c) does
  not ask a size of its own, only that it is not smaller than the misfit it may have been carved from.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from maglev_ocp.diagnosis.signatures import SignatureEvidence
from maglev_ocp.diagnosis.stages.claims import leftover_excess, leftover_test

N = 6000
FLOOR = 1.0


def _smooth(rng: np.random.Generator, n: int, width: int = 200) -> np.ndarray:
    """A unit-rms smooth random signal (white noise through a moving average)."""
    w = np.convolve(rng.standard_normal(n + width), np.ones(width) / width, mode="valid")[:n]
    w -= w.mean()
    return w / np.sqrt(np.mean(w**2))


def _case(seed: int, own: float, misfit: float, rho: float = 0.2) -> tuple[dict, dict]:
    """The test's record and the measured explained / leftover rms, for a residual ``own f(x) + misfit m +
    noise``: ``m`` holds ``rho`` of its variance on the basis."""
    rng = np.random.default_rng(seed)
    x = np.sin(np.linspace(0.0, 40.0 * np.pi, N))  # a state swept back and forth, as the excitation does
    basis = np.polynomial.legendre.legvander(x, 6)[:, 1:]
    f = basis[:, 1] - basis[:, 3]
    f /= np.sqrt(np.mean(f**2))
    on = basis[:, 0] / np.sqrt(np.mean(basis[:, 0] ** 2))
    m = np.sqrt(rho) * on + np.sqrt(1 - rho) * _smooth(rng, N)
    m /= np.sqrt(np.mean(m**2))
    y = own * f + misfit * m + FLOOR * rng.standard_normal(N)
    cols = np.column_stack([np.ones(N), basis])
    coef, *_ = np.linalg.lstsq(cols, y, rcond=None)
    fit = cols @ coef - y.mean()
    left = y - cols @ coef
    # the explained rms over the floor, as :func:`..signatures.evidence` records it
    ev = SignatureEvidence(
        "saturation", {"vertical": {"rms_explained_over_floor": float(np.sqrt(np.mean(fit**2))) / FLOOR,
                                    "shows": True}}, True)  # fmt: skip
    r = np.column_stack([left, np.full(N, np.nan)])
    excess = leftover_excess([SimpleNamespace(r=r)], {"vertical": FLOOR, "horizontal": FLOOR})
    return leftover_test(ev, excess, {"vertical": FLOOR}, 1.0), excess


def test_leftover_excess_is_the_rms_above_the_floor():
    """A residual of noise (rms 1) and an offset of 2 holds sqrt(5 - 1) = 2 above a floor of 1; a channel of
    NaN has no figure."""
    rng = np.random.default_rng(7)
    r = np.column_stack([2.0 + rng.standard_normal(200_000), np.full(200_000, np.nan)])
    ex = leftover_excess([SimpleNamespace(r=r)], {"vertical": 1.0, "horizontal": 1.0})
    assert ex["vertical"] == pytest.approx(2.0, rel=0.01)
    assert "horizontal" not in ex
    below = leftover_excess([SimpleNamespace(r=0.5 * r)], {"vertical": 2.0})
    assert below["vertical"] == 0.0


@pytest.mark.parametrize("seed", range(4))
def test_a_share_carved_from_the_others_misfit_is_not_claimed(seed):
    rec, excess = _case(seed, own=0.0, misfit=1.5)
    ch = rec["per_channel"]["vertical"]
    assert ch["explained_m_s2"] == pytest.approx(0.67, abs=0.25)
    assert excess["vertical"] == pytest.approx(1.34, abs=0.25)
    assert not rec["passes"]


@pytest.mark.parametrize("seed", range(4))
def test_an_effect_of_its_own_beside_the_misfit_is_kept(seed):
    rec, _ = _case(seed, own=2.0, misfit=1.5)
    ch = rec["per_channel"]["vertical"]
    assert ch["explained_m_s2"] == pytest.approx(2.1, abs=0.35)
    assert rec["passes"]


@pytest.mark.parametrize("seed", range(4))
def test_a_small_effect_beside_a_complete_model_is_kept(seed):
    rec, excess = _case(seed, own=0.5, misfit=0.0)
    assert excess["vertical"] < 0.2
    assert rec["passes"]


def test_a_channel_where_the_signature_does_not_show_is_not_counted():
    per = {
        "vertical": {"rms_explained_over_floor": 5.0, "shows": False},
        "horizontal": {"rms_explained_over_floor": 0.5, "shows": True},
    }
    ev = SignatureEvidence("saturation", per, True)
    rec = leftover_test(ev, {"vertical": 0.1, "horizontal": 1.0}, {"vertical": 1.0, "horizontal": 1.0}, 1.0)
    assert list(rec["per_channel"]) == ["horizontal"] and not rec["passes"]
