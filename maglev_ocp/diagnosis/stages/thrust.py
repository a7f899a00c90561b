"""Stage 2, part: the thrust constant C1 calibrated beyond every force that does not scale with the thrust current.

In closed loop the controller balances whatever force acts on the stage: along ``d`` the position loop holds
the mover with a thrust current ``i_q`` that cancels an unmodelled force (an end force pulling an overhanging
array back, a cogging of another shape, a presliding friction, an ``i_d`` rotated into the thrust by a
commutation offset), so ``i_q`` follows that force, and the measured acceleration does not. A filtered
equation-error fit of ``d_ddot = -C1 f1(g) i_q + ...`` (MODEL.md; seed eq. (2)) then takes ``C1`` towards zero:
the classic bias of identification in closed loop, where the input is correlated with the equation error. On
rigsim's fourth law set (data seen since its blind check) the calibrated ``C1`` went to 20-40 % of its true value
on 7 of 30 datasets, and every candidate started from there.

Here ``C1`` is estimated as in a partially linear model (Robinson, "Root-N-consistent semiparametric
regression", Econometrica 56(4), 1988): the horizontal residual ``r(C1)`` is linear in ``C1`` (the thrust is the
only term of that channel that scales with it), and the regressor ``dr/dC1`` and the residual are both
partialled out of a flexible nuisance of everything a force that does not scale with ``i_q`` can depend on
(:func:`nuisance_basis`): a static map of the gap and position, the cogging's harmonics in ``d``, odd shapes of
the velocity, and the levitation current's ``i_d`` alone, along ``d`` and with the direction of motion. What is
left of ``dr/dC1`` is the thrust current's part that no such force explains, the moves' accelerations; ``C1`` is
fitted on it. The vertical constants are not treated so: the magnets' pull ``C2 f2(g)`` is itself a function of
the gap, which the nuisance would take.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ... import constants as k
from ...signals import PARAM_NAMES
from ..fit import residuals_with
from ..library import CandidateSpec
from ..residuals import PreparedRun
from ..signatures import _V_SIGN, STATIC_V_SCALES, Feat, _bsplines, state_map_basis

_C1 = PARAM_NAMES.index("C1")
_H = 1  # the horizontal channel

#: Harmonics of ``2 t1`` in the nuisance (to ``t1 / 6``: a slot opening's sharp force profile).
COGGING_HARMONICS: int = 12
#: Cubic B-splines in ``g`` each harmonic is multiplied by (its amplitude a smooth function of the gap). With a
#: fixed amplitude per harmonic, a cogging that decays with the gap (the sixth law set's finite-array law,
#: 6-10 N at the lower gaps) stayed in the thrust current's part: C1 partialled 3.6-4.5 against 13.7-14.0.
COGGING_GAP_SPLINES: int = 5


def nuisance_basis(feat: Feat) -> np.ndarray:
    """Columns of every horizontal force that does not scale with the thrust current ``i_q``, shape ``(n, p)``.

    A constant; a flexible function of ``(g, d)`` (:func:`..signatures.state_map_basis`: an end force, a spring,
    a cable, the gap-dependent part of any of them); harmonics 1..:data:`COGGING_HARMONICS` of seed eq. (9)'s
    period ``2 t1`` in ``d``, each times cubic B-splines in ``g`` (a cogging of any shape, its harmonics decaying
    with the gap each at its own rate); odd shapes of ``d_dot`` at the velocity scales of a Stribeck dip to a
    viscous slope (:data:`..signatures.STATIC_V_SCALES`); ``i_d``, ``i_d d`` and ``i_d tanh(d_dot / v)`` (a
    commutation offset rotating the levitation current into the thrust, constant, drifting along ``d``, or
    switching with the direction of motion as a Hall sensor's hysteresis does).
    """
    d, g = feat["d"], feat["g"]
    cols: list[np.ndarray] = [np.ones_like(d)[:, None], state_map_basis(feat, ("g", "d"))]
    lo, hi = (float(x) for x in np.percentile(g, [0.5, 99.5]))
    # A cogging's harmonics decay with the gap, each at a rate of its own (the slot openings' field, seed eq. (9)
    # and MODEL.md's field): each harmonic times smooth functions of g, not a fixed amplitude.
    amp = _bsplines(g, lo, hi, COGGING_GAP_SPLINES) if hi > lo else np.ones((len(g), 1))
    for h in range(1, COGGING_HARMONICS + 1):
        w = 2 * math.pi * h / (2 * k.t1)
        for wave in (np.sin(w * d), np.cos(w * d)):
            cols.append(amp * wave[:, None])
    v = feat["d_dot"]
    cols.append(np.column_stack([np.tanh(v / s) for s in STATIC_V_SCALES] + [v]))
    i_d = feat["i_d"]
    cols.append(np.column_stack([i_d, i_d * d / 0.05, i_d * np.tanh(v / _V_SIGN)]))
    return np.column_stack(cols)


@dataclass(frozen=True)
class ThrustConstant:
    """The thrust constant partialled out of the forces that do not scale with ``i_q``.

    Attributes
    ----------
    c1_plain : float
        ``C1`` of the plain calibration (the first pass, every constant free) [m/s^2/A].
    c1 : float
        ``C1`` partialled out of :func:`nuisance_basis` [m/s^2/A].
    stderr : float
        Its standard error (the residual's autocorrelation over the filter's main lobe counted) [m/s^2/A].
    used : bool
        The baseline holds ``c1`` (its standard error is within the prior's sd); else the plain calibration's.
    reason : str
        Why, in words.
    n : int
        Residual samples used.
    determined : bool
        ``c1`` is positive and its standard error within the prior's sd (held or not): the candidates' joint
        refits start from it.
    """

    c1_plain: float
    c1: float
    stderr: float
    used: bool
    reason: str
    n: int = 0
    determined: bool = False

    def to_dict(self) -> dict:
        """JSON form."""
        return {"C1_plain": self.c1_plain, "C1_partialled": self.c1, "stderr": self.stderr, "used": self.used,
                "determined": self.determined, "reason": self.reason, "samples": self.n}  # fmt: skip


def _stack(runs: Sequence, res_a: Sequence, res_b: Sequence) -> tuple[np.ndarray, np.ndarray, Feat]:
    """Horizontal residual samples at ``C1`` and at ``C1 + 1``, and their features, over the training runs."""
    ya, yb, fs = [], [], []
    for run, a, b in zip(runs, res_a, res_b, strict=True):
        if not (run.n and run.valid[_H] and run.feat):
            continue
        ok = np.isfinite(a.r[:, _H]) & np.isfinite(b.r[:, _H])
        ya.append(a.r[ok, _H])
        yb.append(b.r[ok, _H])
        fs.append({key: v[ok] for key, v in run.feat.items()})
    if not ya:
        return np.zeros(0), np.zeros(0), {}
    feat = {key: np.concatenate([f[key] for f in fs]) for key in fs[0]}
    return np.concatenate(ya), np.concatenate(yb), feat


def partialled_thrust(
    train: Sequence[PreparedRun], p: np.ndarray, noise_lag: int, prior_sd_c1: float, hold: bool = True
) -> ThrustConstant | None:
    """``C1`` by the partially linear model of the module docstring, on the training runs at constants ``p``.

    Parameters
    ----------
    train : sequence of PreparedRun
        The training runs.
    p : ndarray
        The plain calibration's constants (the other constants do not enter the horizontal channel but through
        the cogging law, which the nuisance spans).
    noise_lag : int
        Residual samples per independent one (the filter's main lobe).
    prior_sd_c1 : float
        The calibration prior's sd of ``C1`` [m/s^2/A] (``inf``: none): a partialled estimate less precise than
        that is not used.
    hold : bool
        Whether the baseline is to hold a determined estimate (``used``); False: computed and reported only.

    Returns
    -------
    ThrustConstant or None
        None without horizontal training data.
    """
    spec = CandidateSpec("baseline")
    p1 = np.array(p, float)
    p1[_C1] += 1.0
    y, y1, feat = _stack(train, residuals_with(spec, None, train, p), residuals_with(spec, None, train, p1))
    c1_plain = float(p[_C1])
    if len(y) == 0:
        return None
    x = y1 - y  # d r / d C1: the horizontal residual is linear in C1
    q, _ = np.linalg.qr(nuisance_basis(feat))
    xp = x - q @ (q.T @ x)
    yp = y - q @ (q.T @ y)
    sxx = float(xp @ xp)
    n, dof = len(y), len(y) - q.shape[1] - 1
    if sxx <= 0 or dof <= 0:
        return ThrustConstant(c1_plain, math.nan, math.inf, False, "the thrust current has no part beyond the "
                              "nuisance forces: plain calibration kept", n)  # fmt: skip
    beta = -float(xp @ yp) / sxx
    e = yp + beta * xp
    se = math.sqrt(float(e @ e) / dof * max(noise_lag, 1) / sxx)
    c1 = c1_plain + beta
    if not (np.isfinite(c1) and c1 > 0 and se <= prior_sd_c1):
        return ThrustConstant(c1_plain, c1, se, False, f"partialled C1 = {c1:.3g} +- {se:.2g} is not determined "
                              f"within the prior's sd {prior_sd_c1:.2g}: plain calibration kept", n)  # fmt: skip
    what = ("held in the baseline" if hold else "reported; the baseline keeps the plain calibration's, and the "
            "candidates' joint refits start from it")  # fmt: skip
    why = (f"C1 partialled out of the forces that do not scale with i_q: {c1:.4g} +- {se:.2g} (plain calibration "
           f"{c1_plain:.4g}); {what}")  # fmt: skip
    return ThrustConstant(c1_plain, c1, se, hold, why, n, determined=True)


__all__ = ["ThrustConstant", "nuisance_basis", "partialled_thrust"]
