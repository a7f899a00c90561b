"""Test (e) of the claim guard: is a ripple of cogging's period fixed to the position, or to the currents?

On this motor the slot pitch ``t1`` is ``tau / 3``: a ripple at six times the electrical angle (an inverter's dead
time, any per-phase current error) has cogging's period. :func:`angle_lock` asks whether the ripple moves along
``d`` with the currents' electrical angle; :func:`ripple_decay` how fast it falls as the gap opens, which tells a
field's ripple (the magnets' pull on the teeth, falling at least as ``exp(-2 pi g / p)`` for its period ``p``:
Laplace's equation in the gap) from a ripple of the currents (carried by the motor's force constants, which fall
by a factor e over ``tau / pi``, 18 mm). Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import constants as k
from .residuals import CHANNELS, Residual
from .signatures import (
    _V_SIGN,
    GAP_SPLINES,
    Feat,
    Signature,
    _bsplines,
    _orth,
    _other_bases,
    _shifted,
    _stack,
    gap_range,
)


def _current_angle(feat: Feat) -> np.ndarray:
    """The current vector's angle in the rotor's dq frame [rad, electrical]: ``atan2(i_q, i_d)`` (MODEL.md's dq
    convention: ``i_d`` along the magnets' field, the electrical angle ``pi d / tau``)."""
    return np.arctan2(feat["i_q"], feat["i_d"])


def angle_lock(
    sig: Signature,
    residuals: Sequence[Residual],
    floors: dict[str, float],
    others: Sequence[str] = (),
    n_null: int = 60,
    alpha: float = 0.01,
    seed: int = 0,
    step: float = 1e-5,
) -> dict[str, dict[str, float]]:
    """Does a ripple of ``sig``'s shape move along ``d`` with the currents' electrical angle?

    A force fixed to the position (cogging) is ``R(d, g)``. A ripple that the inverter or the current loop makes
    (a dead time stepping each phase current with its sign: Murai, Watanabe & Iwasaki, IEEE Trans. IA 23(5), 1987;
    a current sensor's offset or gain) is a function of the *currents'* electrical angle ``pi d / tau + phi``,
    ``phi = atan2(i_q, i_d)`` the current vector's angle in the dq frame: ``R(d + phi tau / pi, g) ~ R + beta phi
    (tau / pi) dR/dd`` with ``beta = 1``. Per channel: ``y`` is the residual beyond a constant, the other named
    effects' bases and ``sig``'s :attr:`~Signature.beyond` columns; ``R`` is its fit by ``sig``'s
    :attr:`~Signature.own` columns (least squares), ``dR/dd`` the same columns' derivative (central differences
    of ``step`` in ``d``) times the fitted coefficients; ``beta`` is the least-squares coefficient of the column
    ``phi (tau / pi) dR/dd`` beyond the own columns and beyond shifts that follow the motion, ``tanh(v / 2 mm/s)
    dR/dd`` and ``v dR/dd`` (a hysteretic or lossy tooth's pattern lags the motion by its direction or its
    speed, as the residual filter does; in closed loop the current angle follows both), tested against the
    ``1 - alpha`` quantile of ``|beta|`` on the remainder circularly shifted within its runs. Noise in ``phi``
    and in the fitted slope biases ``beta`` towards 0 (errors in variables), not beyond 1. Returns ``{channel:
    {beta, beta_null_q, lock_rms_over_floor, own_rms_over_floor, lock_share}}``, ``lock_share`` the rms the lock
    column explains over the rms of ``R``, and :func:`ripple_decay`'s ``decay_mm`` and ``period_mm`` of ``R``.
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, len(sig.effect), 2]))
    out: dict[str, dict[str, float]] = {}
    for c, ch in enumerate(CHANNELS):
        if not sig.own.get(ch):
            continue
        y, feat, ids = _stack(residuals, c)
        if len(y) < 100:
            continue
        a = np.column_stack([np.ones((len(y), 1)), *_other_bases(sig, feat, ch, others)])
        own = sig.matrix(feat, ch, "own")
        plus, minus = ({**feat, "d": feat["d"] + s_ * step} for s_ in (1.0, -1.0))
        d_own = (sig.matrix(plus, ch, "own") - sig.matrix(minus, ch, "own")) / (2 * step)
        xa = np.column_stack([a, own])
        coef, *_ = np.linalg.lstsq(xa, y, rcond=None)
        r_own = y - xa @ coef
        shape = own @ coef[a.shape[1] :]
        slope = d_own @ coef[a.shape[1] :]
        lock = _current_angle(feat) * (k.tau / math.pi) * slope
        # beyond shifts that follow the motion: a hysteretic or lossy tooth's pattern lags the motion (by its
        # direction, by its speed), as does the residual filter's; in closed loop the current angle follows both
        v = feat["d_dot"]
        moves = np.column_stack([np.tanh(v / _V_SIGN) * slope, v / 0.1 * slope])
        q = _orth(np.column_stack([xa, moves]))
        r_own = r_own - q @ (q.T @ r_own)
        lock = lock - q @ (q.T @ lock)
        ll = float(lock @ lock)
        fl = floors.get(ch, math.nan)
        if ll <= 0 or not (np.isfinite(fl) and fl > 0):
            continue
        beta = float(lock @ r_own) / ll
        null = [abs(float(lock @ _shifted(r_own, ids, rng))) / ll for _ in range(n_null)]
        lock_rms = abs(beta) * math.sqrt(ll / len(y))
        own_rms = float(np.sqrt(np.mean((shape - shape.mean()) ** 2)))
        out[ch] = {"beta": beta, "beta_null_q": float(np.quantile(null, 1 - alpha)) if null else math.inf,
                   "lock_rms_over_floor": lock_rms / fl, "own_rms_over_floor": own_rms / fl,
                   "lock_share": lock_rms / own_rms if own_rms > 0 else math.inf,
                   **ripple_decay(sig, feat["g"], coef[a.shape[1] :])}  # fmt: skip
    return out


def ripple_decay(sig: Signature, g: np.ndarray, coef: np.ndarray, lo_q: float = 5.0, hi_q: float = 75.0) -> dict:
    """How fast a ripple of ``sig``'s own shape falls as the gap opens, from its fit.

    ``coef`` are the fitted coefficients of ``sig``'s :attr:`~.signatures.Signature.own` columns (its harmonics,
    sine and cosine of each of :attr:`~.signatures.Signature.periods_m`, times :data:`~.signatures.GAP_SPLINES`
    cubic B-splines over the samples' gaps ``g``). The ripple's amplitude at a gap is the norm of its harmonics
    there; its decay length is ``(g_hi - g_lo) / ln(A(g_lo) / A(g_hi))`` between the ``lo_q`` and ``hi_q``
    percentiles of the samples' gap (infinite when it does not fall). A field's ripple of period ``p`` falls at
    least as ``exp(-2 pi g / p)`` (Laplace's equation in the gap; a force, a product of two fields, faster); a
    ripple of the currents falls with the motor's force constants, by a factor e over about ``tau / pi``.
    Returns ``{decay_mm, period_mm}``: the decay length and the period of the ripple's largest harmonic.
    """
    n_h = len(sig.periods_m)
    c = np.asarray(coef, float)
    if c.size != 2 * n_h * GAP_SPLINES or not len(g):
        return {"decay_mm": math.nan, "period_mm": math.nan}
    c = c.reshape(GAP_SPLINES, n_h, 2)
    rng = gap_range(g)  # the range of the splines the fit used
    at = np.percentile(g, [lo_q, hi_q])
    if rng is None or not at[1] > at[0]:
        return {"decay_mm": math.nan, "period_mm": math.nan}
    amp = np.linalg.norm(np.einsum("gj,jhs->ghs", _bsplines(at, *rng, GAP_SPLINES), c), axis=2)  # (gap, h)
    per_h = np.linalg.norm(np.einsum("gj,jhs->ghs", _bsplines(g, *rng, GAP_SPLINES), c), axis=2).mean(axis=0)
    a_lo, a_hi = (float(np.linalg.norm(x)) for x in amp)
    fall = math.log(a_lo / a_hi) if a_lo > 0 and a_hi > 0 else math.nan
    decay = (at[1] - at[0]) / fall if fall > 0 else math.inf
    return {"decay_mm": decay * 1e3, "period_mm": float(sig.periods_m[int(np.argmax(per_h))]) * 1e3}


__all__ = ["angle_lock", "ripple_decay"]
