"""Test (f) of the claim guard: a lag of the phase currents acts on the thrust and the lift alike (issue 27).

The amplifier's current loops make ``i_q`` and ``i_d`` from the same phase currents, so one lag of the delivered
currents behind the commanded ones gives a force error in both channels, each ``k (i - u)`` with its own force
gain ``k``. A lag of the gap measurement gives one in the gap channel only. The truths here are written in the
test: commanded currents a band-limited random signal, a first-order lag ``tau`` applied by its exact discrete
form ``i[k+1] = a i[k] + (1 - a) u[k]``, ``a = exp(-Ts / tau)``, noise of unit floor. For signals slow beside
``tau``, ``i - u ~ -tau du/dt``, so a lag fitted at ``tau_fit`` predicts an error the data bears out by
``tau / tau_fit``.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import lfilter

from maglev_ocp.diagnosis.residuals import CHANNELS
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.stages.lag_channels import borne_everywhere, channel_figures

TS = 1e-3  # [s]
TAU = 1.5e-3  # the true lag [s]
TAU_FIT = 1.1 * TAU  # the lag as fitted (10 % long)
N = 40_000


def _lagged(u: np.ndarray, tau: float) -> np.ndarray:
    """``i[k+1] = a i[k] + (1 - a) u[k]`` from rest."""
    a = np.exp(-TS / tau)
    return lfilter([0.0, 1.0 - a], [1.0, -a], u)


def _commanded(rng: np.random.Generator) -> np.ndarray:
    """A band-limited command (white noise through a 5 ms moving average), unit rms."""
    u = np.convolve(rng.standard_normal(N + 4), np.ones(5) / 5, mode="valid")
    return u / u.std()


def _runs(per_channel: dict[str, np.ndarray]) -> list[SimpleNamespace]:
    """Two runs of residual samples, columns in the order of CHANNELS."""
    r = np.column_stack([per_channel[ch] for ch in CHANNELS])
    return [SimpleNamespace(r=r[: N // 2]), SimpleNamespace(r=r[N // 2 :])]


def _case(gains_true: dict[str, float], gains_fit: dict[str, float], seed: int) -> dict:
    """Residuals without and with the fitted lag: the true error ``k_true (i - u)`` plus unit noise, and the
    fitted lag's prediction ``k_fit (i_fit - u)`` taken from it."""
    rng = np.random.default_rng(seed)
    u = {ch: _commanded(rng) for ch in CHANNELS}
    err = {ch: gains_true[ch] * (_lagged(u[ch], TAU) - u[ch]) for ch in CHANNELS}
    pred = {ch: gains_fit[ch] * (_lagged(u[ch], TAU_FIT) - u[ch]) for ch in CHANNELS}
    no_lag = {ch: err[ch] + rng.standard_normal(N) for ch in CHANNELS}
    with_lag = {ch: no_lag[ch] - pred[ch] for ch in CHANNELS}
    return channel_figures(_runs(no_lag), _runs(with_lag), {ch: 1.0 for ch in CHANNELS})


def _gain(size_floors: float) -> float:
    """The gain whose fitted prediction ``k (i_fit - u)`` has rms ``size_floors`` (unit floor)."""
    rng = np.random.default_rng(0)
    u = _commanded(rng)
    return size_floors / float(np.std(_lagged(u, TAU_FIT) - u))


def test_a_lag_of_the_currents_is_borne_out_in_both_channels() -> None:
    """The same lag on both currents: each channel bears out tau / tau_fit = 0.909 of the prediction."""
    k = {"vertical": _gain(2.0), "horizontal": _gain(1.0)}
    per = _case(k, k, seed=11)
    st = DiagnoseSettings()
    for ch in CHANNELS:
        assert per[ch]["predicted_over_floor"] == pytest.approx(2.0 if ch == "vertical" else 1.0, rel=0.1)
        assert per[ch]["borne_out"] == pytest.approx(TAU / TAU_FIT, abs=0.08)
    assert borne_everywhere(per, st.lag_channel_min, st.lag_borne_min)


def test_a_lag_of_the_gap_reading_alone_is_not_the_amplifiers() -> None:
    """The error in the gap channel only; the fitted (current) lag predicts 1 floor along d, where the data holds
    none of it: refused at the defaults."""
    k_fit = {"vertical": _gain(2.0), "horizontal": _gain(1.0)}
    per = _case({"vertical": k_fit["vertical"], "horizontal": 0.0}, k_fit, seed=12)
    st = DiagnoseSettings()
    assert per["vertical"]["borne_out"] == pytest.approx(TAU / TAU_FIT, abs=0.08)
    assert abs(per["horizontal"]["borne_out"]) < 0.1
    assert not borne_everywhere(per, st.lag_channel_min, st.lag_borne_min)


def test_a_prediction_below_the_floor_says_nothing() -> None:
    """A small lag predicting 0.2 floors along d is not judged there, borne out or not."""
    k_fit = {"vertical": _gain(2.0), "horizontal": _gain(0.2)}
    per = _case({"vertical": k_fit["vertical"], "horizontal": 0.0}, k_fit, seed=13)
    assert per["horizontal"]["predicted_over_floor"] == pytest.approx(0.2, rel=0.1)
    assert abs(per["horizontal"]["borne_out"]) < 0.5
    assert borne_everywhere(per, DiagnoseSettings().lag_channel_min, DiagnoseSettings().lag_borne_min)
