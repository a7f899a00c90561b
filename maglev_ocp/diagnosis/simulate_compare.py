"""Simulated trajectories of the baseline and the augmented model against measured runs.

The stage is open-loop unstable (vertical pole +39..+64 rad/s), so a whole
run cannot be re-simulated from the logged currents: any model drifts off in
a fraction of a second. The comparison is therefore over short windows
(multiple shooting without the defects): from the measured state at the start
of each window (zero-phase smoothed position and velocity), the model is
integrated with the logged currents (RK4, zero-order hold) over ``horizon``
seconds and compared with the encoder readings. The rms over all windows of
the held-out runs is the trajectory error of a model; a locked axis is held.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.signal as sps

from .. import constants as k
from ..effects import AmplifierLag
from ..model import rk4
from .fit import FitResult, _accel_function
from .library import CandidateSpec
from .residuals import RunInput


@functools.lru_cache(maxsize=32)
def _window_sim(spec: CandidateSpec, n: int, n_sub: int, Ts: float) -> ca.Function:
    """``(x0[4], Z[8 x n], p, w, free[2]) -> X[4 x n]``: RK4 over ``n`` periods with the logged currents."""
    acc = _accel_function(spec)
    x = ca.SX.sym("x", 4)
    z = ca.SX.sym("z", 8)
    p = ca.SX.sym("p", acc.size1_in(1))
    w = ca.SX.sym("w", acc.size1_in(2))
    free = ca.SX.sym("free", 2)
    h = Ts / n_sub

    def f(xx):
        zz = ca.vertcat(xx, z[4:8])
        a = acc(zz, p, w)
        return ca.vertcat(xx[1] * free[0], a[0] * free[0], xx[3] * free[1], a[1] * free[1])

    xk = rk4(f, x, h, n_sub)
    step = ca.Function("sim_step", [x, z, p, w, free], [xk])
    return step.mapaccum("sim_window", n, [0], [0])


@dataclass
class TrajectoryComparison:
    """Short-window simulation errors of several models on the same windows.

    Attributes
    ----------
    horizon : float
        Window length [s].
    rms : dict
        ``{model: {"g": rms_m, "d": rms_m}}`` over all windows (locked axes omitted).
    examples : dict
        ``{model: list of (t, X_sim[4 x n])}`` for the windows of the first run where the
        baseline errs most (for overlays).
    measured : list of (t, y)
        The measured readings of those windows.
    """

    horizon: float
    rms: dict[str, dict[str, float]] = field(default_factory=dict)
    examples: dict[str, list] = field(default_factory=dict)
    measured: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {"horizon_s": self.horizon, "rms_m": self.rms}


def _smoothed_state(y: np.ndarray, Ts: float, fc: float = 20.0) -> np.ndarray:
    b, a = sps.butter(2, fc, fs=1 / Ts)
    ys = sps.filtfilt(b, a, y, axis=0)
    v = np.gradient(ys, Ts, axis=0)
    return np.column_stack([ys[:, 0], v[:, 0], ys[:, 1], v[:, 1]])


def compare_trajectories(
    runs: Sequence[RunInput],
    models: dict[str, tuple[CandidateSpec, FitResult | None]],
    p: dict[str, np.ndarray],
    horizon: float = 0.05,
    every: float = 0.25,
    n_sub: int = 2,
    n_examples: int = 4,
) -> TrajectoryComparison:
    """Simulate each model over short windows of each run and compare with the readings.

    Parameters
    ----------
    runs : sequence of RunInput
        Held-out runs.
    models : dict
        ``{label: (spec, fit)}``; ``fit`` None means the spec with no fitted values (baseline).
    p : dict
        ``{label: parameter vector}`` for each model.
    horizon : float
        Window length [s].
    every : float
        Spacing of window starts [s].
    n_sub : int
        RK4 sub-steps per period.
    n_examples : int
        Windows kept for the overlay figure.
    """
    Ts = runs[0].Ts if runs else k.Ts
    n = max(2, round(horizon / Ts))
    out = TrajectoryComparison(horizon)
    sq: dict[str, np.ndarray] = {lab: np.zeros(2) for lab in models}
    cnt = np.zeros(2)
    window_err: dict[str, list[float]] = {}
    window_sim: dict[str, list] = {}
    window_meas: list = []
    for ri, run in enumerate(runs):
        N = len(run.y)
        if N < n + 100:
            continue
        X = _smoothed_state(run.y, run.Ts)
        starts = np.arange(50, N - n - 50, max(1, round(every / Ts)))
        if len(starts) == 0:
            continue
        free = np.array([0.0 if "g" in run.locked else 1.0, 0.0 if "d" in run.locked else 1.0])
        u = run.u
        u_prev = np.vstack([u[:1], u[:-1]])
        Z_full = np.column_stack([X, u, u_prev])
        for lab, (spec, fit) in models.items():
            w = fit.w if fit is not None else np.zeros(len(spec.free))
            Zm = Z_full
            if spec.lag and fit is not None:
                # The amplifier's output currents, from the plant's own filter (see candidates.lag_features).
                ua = AmplifierLag.filter_currents(u, fit.extra, run.Ts)  # the fitted member's amplifier (any law)
                Zm = np.column_stack([X, ua, np.vstack([ua[:1], ua[:-1]])])
            sim = _window_sim(spec, n, n_sub, run.Ts)
            msim = sim.map(len(starts))
            x0 = X[starts].T
            Zw = np.hstack([Zm[s : s + n].T for s in starts])
            Xs = np.asarray(msim(x0, Zw, p[lab], w, free))  # 4 x (n * n_windows)
            for j, s in enumerate(starts):
                blk = Xs[:, j * n : (j + 1) * n]
                meas = run.y[s + 1 : s + 1 + n]
                err = np.column_stack([blk[0] - meas[:, 0], blk[2] - meas[:, 1]])
                sq[lab] += np.sum(err**2, axis=0) * free
                if ri == 0:
                    window_err.setdefault(lab, []).append(float(np.sum(err**2 * free)))
                    window_sim.setdefault(lab, []).append(((s + 1 + np.arange(n)) * run.Ts + run.t0, blk))
        if ri == 0:
            for s in starts:
                window_meas.append(((s + 1 + np.arange(n)) * run.Ts + run.t0, run.y[s + 1 : s + 1 + n]))
        cnt += len(starts) * n * free
    # Overlay examples: the windows of the first held-out run where the first model (the baseline) errs most.
    if window_meas:
        first = next(iter(models))
        pick = np.argsort(window_err[first])[::-1][:n_examples]
        pick = np.sort(pick)
        out.measured = [window_meas[i] for i in pick]
        out.examples = {lab: [window_sim[lab][i] for i in pick] for lab in models}
    for lab in models:
        out.rms[lab] = {
            ax: (float(np.sqrt(sq[lab][i] / cnt[i])) if cnt[i] else None) for i, ax in enumerate(("g", "d"))
        }
    return out


__all__ = ["TrajectoryComparison", "compare_trajectories"]
