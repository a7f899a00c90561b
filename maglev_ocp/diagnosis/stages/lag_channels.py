"""Test (f) of the claim guard: a lag of the currents acts on both axes alike (issue 27, item 2).

The amplifier's phase current loops make ``i_q`` and ``i_d`` together (the dq currents are one rotation of the
same three phase currents), so a lag of the delivered currents behind the commanded ones is one transfer
function for both: the thrust lags as the lift does. Its force error, ``dF/di (i - u)``, is then predicted in
*each* channel by the one fitted lag (the verdict's model with and without the lag's filter on the currents). A
lag of something else, the gap sensor's reading (a demodulator's low-pass filter) or the vertical channel's
own measurement chain, leaves the horizontal channel without its share: fitted as an amplifier lag, the lag
that closes the gap channel predicts a thrust error the data along ``d`` does not hold (rigsim's thirteenth
set, training material since its check: a gap probe's filter was taken for an amplifier lag on six of six
datasets; along d, where the fitted lag predicted 0.8-2.0 noise floors, the residual bore out 0.03-0.09 of it,
against 0.96-1.09 for eight true amplifier lags wherever they predicted half a floor or more).

In every channel where the fitted lag's predicted error is at least ``lag_channel_min`` times the noise floor,
the held-out residual of the verdict's model *without* the lag's filter, regressed on that predicted error,
must give a coefficient of at least ``lag_borne_min`` (1: the prediction is borne out in full; 0: the channel
holds none of it). A channel where the lag predicts less than that says nothing (a small lag, or a stroke
without thrust moves): the test is passed, not failed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..fit import residuals_with
from ..residuals import CHANNELS
from .joint import joint_model
from .models import Attribution, Run


def lag_channels(run: Run, att: Attribution, names: Sequence[str], floors: Mapping[str, float]) -> dict:
    """The amplifier lag's prediction in each channel, and how much of it the held-out runs bear out.

    Parameters
    ----------
    run, att : Run, Attribution
        The diagnosis's inputs and the guard's copy of the selection's record.
    names : sequence of str
        The verdict's effects (``amplifier_lag`` among them): their joint model is the one judged.
    floors : mapping
        ``{channel: noise floor}`` [m/s^2] (test (a)'s).

    Returns
    -------
    dict
        ``{per_channel: {channel: {predicted_over_floor, borne_out}}, passes}``; ``passes`` is True when the
        joint model has no lag or did not converge (nothing to judge), and when every channel where the lag
        predicts at least ``lag_channel_min`` floors bears out at least ``lag_borne_min`` of it.
    """
    st, split, base = run.settings, run.split, run.base
    spec, fit, _ = joint_model(run, att, list(names))
    if not (spec.lag and fit.success):
        return {"per_channel": {}, "passes": True}
    with_lag = residuals_with(spec, fit, split.test, base.p, split.u_test)
    # The same model and parameters with the currents unfiltered: the commanded currents, as if no lag.
    no_lag = residuals_with(spec, fit, split.test, base.p, None)
    per = channel_figures(no_lag, with_lag, floors)
    return {"per_channel": per, "passes": borne_everywhere(per, st.lag_channel_min, st.lag_borne_min)}


def channel_figures(no_lag: Sequence, with_lag: Sequence, floors: Mapping[str, float]) -> dict[str, dict[str, float]]:
    """Per channel, the lag's predicted error (``no_lag - with_lag``, the residuals of one model without and with
    the lag's filter on the currents, runs alike) and how much of it the ``no_lag`` residual holds.

    Returns ``{channel: {predicted_over_floor, borne_out}}``: the prediction's rms over the channel's noise floor
    and the least-squares coefficient of the residual on it (channels without samples or floor left out).
    """
    per: dict[str, dict[str, float]] = {}
    for c, ch in enumerate(CHANNELS):
        y = np.concatenate([r.r[:, c] for r in no_lag if r.r.shape[0]] or [np.zeros(0)])
        pred = y - np.concatenate([r.r[:, c] for r in with_lag if r.r.shape[0]] or [np.zeros(0)])
        ok = np.isfinite(y) & np.isfinite(pred)
        y, pred = y[ok], pred[ok]
        fl = floors.get(ch, float("nan"))
        pp = float(pred @ pred)
        if len(y) < 20 or pp <= 0 or not (np.isfinite(fl) and fl > 0):
            continue
        per[ch] = {"predicted_over_floor": float(np.sqrt(pp / len(pred))) / fl, "borne_out": float(pred @ y) / pp}
    return per


def borne_everywhere(per: Mapping[str, Mapping[str, float]], channel_min: float, borne_min: float) -> bool:
    """True unless some channel where the lag predicts at least ``channel_min`` floors bears out less than
    ``borne_min`` of it."""
    return not any(r["predicted_over_floor"] >= channel_min and r["borne_out"] < borne_min for r in per.values())


def lag_channels_why(run: Run, att: Attribution, names: Sequence[str], floors: Mapping[str, float],
                     rec: dict) -> str:  # fmt: skip
    """Test (f) for the amplifier lag: the record goes to ``rec["lag_channels"]``; the reason it is not claimed
    (empty: it stays, or the test is off)."""
    st = run.settings
    if st.lag_channel_min <= 0 or "amplifier_lag" not in names:
        return ""
    out = lag_channels(run, att, names, floors)
    rec["lag_channels"] = out
    if out["passes"]:
        return ""
    txt = ", ".join(
        f"{ch}: predicted {r['predicted_over_floor']:.2g} floors, borne out {r['borne_out']:.2f}"
        for ch, r in out["per_channel"].items()
    )
    return (
        f"amplifier_lag: one lag of the phase currents acts on the thrust and the lift alike, but the fitted lag's "
        f"predicted force error is not in the data where it predicts one ({txt}; at least {st.lag_borne_min:.2g} "
        "needed): a lag of one channel's measurement (the gap sensor's filter), not of the currents: not claimed"
    )


__all__ = ["borne_everywhere", "channel_figures", "lag_channels", "lag_channels_why"]
