"""The amplifier as a low-order transfer function with a fractional delay: the lag members' search (issue 27, item 1).

The library's parsimonious lag member is a first-order lag plus whole samples of delay, searched over one
number, the effective delay (:func:`.fit.lag_theta`). The members here model the current the amplifier
delivers as a low-order transfer function of the command followed by a transport delay of any length
(:func:`~maglev_ocp.effects.amplifier.tf_filter_currents`: the fraction of a sample solved exactly within the
ZOH period), parameterised physically:

- ``fractional``: a first-order lag of bandwidth ``f_b`` and a transport delay ``tau_d`` (2 parameters);
- ``second``: ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` (a PI current loop on an R-L winding with the PWM's lag,
  e.g. Harnefors & Nee 1998; a drive's current loop with its filter) of natural frequency ``f_n`` and damping
  ``zeta``, and ``tau_d`` (3 parameters).

Below the residual's cut-off (15 Hz against lags of hundreds of Hz) every such response acts as its group delay
at zero frequency, ``t_eff = tau_d + 1/w`` (first order) or ``tau_d + 2 zeta / wn`` (second order,
:func:`~maglev_ocp.effects.amplifier.tf_group_delay`); the split of ``t_eff`` between lag and delay and the
damping change the response only at second order in ``w t_eff`` (the magnitude's droop or peak). So the search
runs over ``t_eff`` first, then over the lag's share ``rho`` of it (``tau_d = (1 - rho) t_eff``) and the
damping, then ``t_eff`` again, each a bounded scalar search with every other fitted parameter refitted at each
trial (the profile likelihood). The member's order is chosen like every law of a family: by the information
criterion and the held-out runs, with the first-order + delay member as the parsimonious one it must beat
(each parameter searched here counts in :attr:`.fit.FitResult.k`). The physical ranges follow the sample
rate: the delay between 0 and ``(max_delay + 1)`` periods, bandwidths within the library's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import scipy.optimize as spo

from ..effects import AmplifierLag
from ..effects.amplifier import tf_group_delay
from .fitdata import Dataset

#: Transfer-function members of the amplifier's law family: law -> (order, parameters searched).
TF_LAWS: dict[str, tuple[int, int]] = {"fractional": (1, 2), "second": (2, 3)}
#: Range of the second-order member's damping (a current loop between lightly damped and over-damped).
ZETA_RANGE: tuple[float, float] = (0.3, 1.5)
#: Start of the search's shape: the lag's share of the effective delay and the damping.
SHAPE_START: tuple[float, float] = (0.5, 0.7)
#: A fit's values that start (centre) a lag's search when given as a warm start: the effective delay, and the
#: transfer-function members' share and damping (:func:`fit_lag_tf`; :func:`.fit.fit_candidate` reads the delay).
LAG_START_KEYS: tuple[str, ...] = ("effective_delay_s", "lag_share", "zeta")


#: Grids of the shape's first pass: the lag's share of the effective delay, and the damping.
RHO_GRID: tuple[float, ...] = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
ZETA_GRID: tuple[float, ...] = (0.35, 0.5, 0.7, 1.0, 1.4)


def _refine(f: Callable[[float], float], grid: Sequence[float], at: float, xatol: float) -> float:
    """A bounded scalar search of ``f`` between the grid points next to ``at`` (the grid's best); the best seen."""
    g = np.asarray(grid, float)
    j = int(np.argmin(np.abs(g - at)))
    lo, hi = float(g[max(j - 1, 0)]), float(g[min(j + 1, len(g) - 1)])
    res = spo.minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    return float(res.x) if f(float(res.x)) <= f(at) else float(at)


def tf_theta(law: str, t_eff: float, rho: float, zeta: float, Ts: float) -> dict[str, float]:
    """The physical parameters of a transfer-function member from its search coordinates.

    Parameters
    ----------
    law : str
        A key of :data:`TF_LAWS`.
    t_eff : float
        Group delay at zero frequency [s].
    rho : float
        Share of ``t_eff`` that is the lag's (``0``: a pure delay; ``1``: no transport delay).
    zeta : float
        Damping (second order).
    Ts : float
        Sample period [s].

    Returns
    -------
    dict
        ``order``, ``tf_bandwidth_hz`` (first order: the -3 dB bandwidth; second: the natural frequency),
        ``zeta``, ``delay_s``, and the search coordinates ``effective_delay_s``, ``lag_share``; also the plant's
        equivalent first order + whole samples of delay (``bandwidth_hz``, ``delay_samples``,
        :meth:`~maglev_ocp.effects.AmplifierLag.equivalent`)
        for the model file, and ``lag_params`` (the parameters searched).
    """
    order, n_par = TF_LAWS[law]
    lo, hi = AmplifierLag.bounds()["bandwidth_hz"]
    t_eff = max(float(t_eff), 0.0)
    rho = min(max(float(rho), 0.0), 1.0)
    lag = rho * t_eff
    lag_per_w = 1.0 if order == 1 else 2.0 * zeta  # group delay of the lag times w
    bw = hi if lag <= lag_per_w / (2 * math.pi * hi) else lag_per_w / (2 * math.pi * lag)
    bw = min(max(bw, lo), hi)
    delay = max(t_eff - tf_group_delay(order, bw, zeta, 0.0), 0.0)  # the bandwidth's bounds keep t_eff
    out = {
        "order": float(order),
        "tf_bandwidth_hz": float(bw),
        "zeta": float(zeta if order == 2 else 1.0),
        "delay_s": float(delay),
        "effective_delay_s": float(tf_group_delay(order, bw, zeta, delay)),
        "lag_share": float(rho),
        "lag_params": float(n_par),
    }
    out.update(AmplifierLag.equivalent(out["effective_delay_s"], Ts))
    return out


def fit_lag_tf(
    fitter,
    finish: Callable,
    data: Dataset,
    u_runs: Sequence[np.ndarray],
    lag_Z: Callable[[Dataset, Sequence[np.ndarray], Mapping[str, float]], np.ndarray],
    max_delay: int,
    starts: Sequence[np.ndarray] | None = None,
    warm: Mapping[str, float] | None = None,
    hold: bool = False,
):
    """Fit a transfer-function member (the law of ``fitter.spec``) by the profile search of the module docstring.

    Parameters
    ----------
    fitter : CandidateFitter
        The candidate's fitter (its spec's ``law`` a key of :data:`TF_LAWS`); the search's trials are its
        :meth:`~.fit.CandidateFitter.solve_trial`.
    finish : callable
        ``finish(fitter, Z, trial, starts)``: the full solve at the chosen trial (:func:`.fit.finish_search`).
    data : Dataset
        Training data.
    u_runs : sequence of ndarray
        Commanded currents of each run.
    lag_Z : callable
        ``lag_Z(data, u_runs, theta)``: the stacked features with the currents through the amplifier model.
    max_delay : int
        Largest whole-sample delay (``t_eff <= (max_delay + 1) Ts``).
    starts : sequence of ndarray, optional
        Starts of the other parameters.
    warm : mapping, optional
        A fit's ``effective_delay_s`` (centres the search), ``lag_share`` and ``zeta`` (the shape's start).
    hold : bool
        Hold ``t_eff``, the share and the damping at ``warm``'s (the others refitted; a trial refit).

    Returns
    -------
    tuple
        The chosen trial's fit (its ``w``, ``sse``, ...) and its ``extra``: :func:`tf_theta` and
        ``effective_delay_s_stderr`` from the profile's curvature (:func:`.fit.fit_candidate` makes the result).
    """
    law = fitter.spec.law
    order = TF_LAWS[law][0]
    Ts = data.filt.Ts
    t_max = (max_delay + 1) * Ts
    w = dict(warm or {})
    t0 = w.get("effective_delay_s")
    shape = [float(w.get("lag_share", SHAPE_START[0])), float(w.get("zeta", SHAPE_START[1]))]
    if order != 2:
        shape[1] = 1.0
    shape[1] = min(max(shape[1], ZETA_RANGE[0]), ZETA_RANGE[1])
    cache: dict[tuple[float, float, float], object] = {}

    def features(key: tuple[float, float, float]) -> np.ndarray:
        return lag_Z(data, u_runs, tf_theta(law, *key, Ts))

    def sse(t_eff: float, rho: float, zeta: float) -> float:
        # a trial of the profile search: a few steps from the best trial so far (the chosen one is solved in full)
        key = (round(float(t_eff), 9), round(float(rho), 4), round(float(zeta), 4))
        if key not in cache:
            cache[key] = fitter.solve_trial(features(key), starts, list(cache.values()))
        return cache[key].sse

    def best() -> tuple[float, float, float]:
        return min(cache, key=lambda k_: cache[k_].sse)

    def result(key: tuple[float, float, float], se_t: float) -> tuple:
        return cache[key], {**tf_theta(law, *key, Ts), "effective_delay_s_stderr": se_t}

    if hold and t0 is not None:
        key = (round(float(t0), 9), round(float(shape[0]), 4), round(float(shape[1]), 4))
        cache[key] = fitter.solve_from_best(features(key), starts, [])
        return result(key, math.nan)
    # 1. the effective delay at the starting shape (around a warm t_eff, else over the whole range)
    if t0 is not None:
        grid = np.linspace(max(t0 - 0.25 * Ts, 0.0), min(t0 + 0.25 * Ts, t_max), 3)
    else:
        grid = np.linspace(0.0, t_max, 9)
    vals = [sse(t, *shape) for t in grid]
    j = int(np.argmin(vals))
    lo_, hi_ = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    spo.minimize_scalar(lambda t: sse(t, *shape), bounds=(lo_, hi_), method="bounded", options={"xatol": 4e-6})
    t_b = best()[0]
    # 2. the lag's share of it, 3. the damping (second order): a grid (the profile over the shape may have more
    # than one minimum, and its ends, a pure delay or a pure lag, are physical), then a bounded search around the
    # grid's best; 4. the effective delay again at that shape.
    for r in RHO_GRID:
        sse(t_b, r, shape[1])
    shape[0] = _refine(lambda r: sse(t_b, r, shape[1]), RHO_GRID, best()[1], 0.01)
    if order == 2:
        for z in ZETA_GRID:
            sse(t_b, shape[0], z)
        shape[1] = _refine(lambda z: sse(t_b, shape[0], z), ZETA_GRID, best()[2], 0.01)
        shape[0] = _refine(lambda r: sse(t_b, r, shape[1]), RHO_GRID, best()[1], 0.01)
    shape = [best()[1], best()[2]]
    a_, b_ = max(t_b - 0.1 * Ts, 0.0), min(t_b + 0.1 * Ts, t_max)
    spo.minimize_scalar(lambda t: sse(t, *shape), bounds=(a_, b_), method="bounded", options={"xatol": 2e-6})
    kb = best()
    fr = cache[kb] = finish(fitter, features(kb), cache[kb], starts)
    # Standard error of the effective delay from the curvature of the profile SSE at the chosen shape.
    h = 2e-5
    if kb[0] >= h:
        c2 = (sse(kb[0] + h, kb[1], kb[2]) - 2 * fr.sse + sse(kb[0] - h, kb[1], kb[2])) / h**2
    else:
        c2 = math.nan
    s2 = fr.sse / max(fr.n - fr.k - TF_LAWS[law][1], 1) * fr.inflation
    se_t = math.sqrt(2 * s2 / c2) if c2 > 0 else math.nan
    return result(kb, se_t)


__all__ = ["LAG_START_KEYS", "RHO_GRID", "SHAPE_START", "TF_LAWS", "ZETA_GRID", "ZETA_RANGE", "fit_lag_tf", "tf_theta"]
