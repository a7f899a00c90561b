"""A gap the library cannot have caused: the baseline residual's dependence on time (issue 27, item 2).

Every library effect is a function of the state (gap, position, velocities), of the currents and of their
rates (:data:`.signatures.SIGNATURES`, the variables of each signature): cogging and the end effect of the
position, friction and eddy drag of the velocities, saturation of the gap and the currents, the amplifier lag
of the current rates. None of them changes with *when* a sample was taken: the same state and currents give
the same force in the first run of a session and in the last. A gap that does change with time at a fixed
state is outside the library by the physics of each member, and a drift is how such gaps usually show on a
rig: a gap sensor's offset warming up with its electronics (an inductive probe drifts by about 1 um/K), the
magnets' remanence falling as they warm (Nd-Fe-B: about -0.12 %/K, so the force constants fall with it), a
coil's resistance rising. This module tests for that dependence and says where it is.

**The test** (:func:`time_drift`). The time of a sample is the session time
``tau = (run's place in the recording order) * (run length) + (time within the run)``, the runs taken in the
order of their file names (a rig log's runs are named in the order they are recorded, ``run_00``,
``run_01``, ...). Two models of the residual are fitted on the *training* runs: the additive binned map of the
state and the currents that the data-based floor uses (:class:`.localize.AdditiveMap`: gap x position,
velocities, currents, current rates; it takes up every library effect's static shape, whatever its law), and
the same map with a smooth function of the session time added (Legendre polynomials of ``tau`` to degree
:data:`TIME_ORDER`, backfitted jointly with the map, so that runs recorded at different gaps cannot lend the
time term the map's shape). Both predict the *held-out* runs, which the split interleaves in time with the
training runs. Without a time dependence the time term is fitted noise, independent of the held-out
residual, and cannot predict it; the paired z of the two held-out errors (:func:`.attribution.paired_z`, its
long-run variance from the residual's autocorrelation, the Newey-West principle) is then below ``z_crit``
with the floor test's false-alarm rate. A drift is reported when that z exceeds ``z_crit``, the time term
predicts at least ``min_gain`` of what the state map leaves of the held-out residual, and its rms on the
held-out runs is at least ``min_over_floor`` times the noise model's floor (a drift smaller than the noise is
no gap worth naming).

**Where.** The fitted time term's swing over the session in m/s^2 and as a force in N (the axis' moving mass),
and, for the reading of that axis, the offset that would cause it: a sensor whose reading drifts by ``delta``
makes the model act at the wrong state, ``r = -da/dy * delta`` with ``da/dy`` the baseline model's stiffness
on the held-out runs (:func:`model_stiffness`). Both are said, since the data cannot tell a drifting reading
from a drifting force; either way the library has no member for it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .attribution import paired_z
from .fit import accel_series
from .library import CandidateSpec
from .localize import AdditiveMap, Samples, pool
from .residuals import CHANNEL_AXIS, CHANNELS, PreparedRun, Residual

#: Degree of the session-time polynomial (a warm-up ``1 - exp(-t / tau)`` over a session of one to a few time
#: constants is within 2 % of its span at degree 3).
TIME_ORDER: int = 3
#: Backfitting sweeps between the state map and the time term.
SWEEPS: int = 3


def _run_order(residuals: Sequence[Residual]) -> dict[str, int]:
    """Place of each recorded run in the recording order: file names (the part before a piece's ``@``/``#``
    suffix, :func:`.stages.split.off_stops`) sorted as the rig log names them."""
    files = sorted({_file_of(r.run.name) for r in residuals})
    return {f: i for i, f in enumerate(files)}


def _file_of(name: str) -> str:
    return name.split("@")[0].split("#")[0]


def session_time(residuals: Sequence[Residual], run_length: float | None = None) -> list[np.ndarray]:
    """Session time ``tau`` [s] of each residual sample (module docstring), one array per residual.

    ``run_length``: the time a run occupies in the session [s]; default the longest run's span of ``t``.
    """
    order = _run_order(residuals)
    if run_length is None:
        spans = [float(r.run.feat["t"][-1]) for r in residuals if r.run.n and "t" in r.run.feat]
        run_length = max(spans, default=1.0)
    return [order[_file_of(r.run.name)] * run_length + (r.run.feat["t"] if r.run.n else np.zeros(0)) for r in residuals]


def _legendre(tau: np.ndarray, lo: float, hi: float, order: int) -> np.ndarray:
    """Legendre polynomials 1..``order`` of ``tau`` mapped onto [-1, 1] (the constant is the map's)."""
    x = 2.0 * (tau - lo) / max(hi - lo, 1e-12) - 1.0
    return np.column_stack([np.polynomial.legendre.Legendre.basis(n)(x) for n in range(1, order + 1)])


@dataclass(frozen=True)
class TimeDrift:
    """A channel's dependence on session time at a fixed state (:func:`time_drift`).

    Attributes
    ----------
    channel : str
        ``vertical`` or ``horizontal``.
    z : float
        Held-out paired z of the state map with the time term over the map alone.
    gain : float
        Share of what the state map leaves of the held-out residual that the time term predicts.
    rms_over_floor : float
        Rms of the time term on the held-out runs over the channel's noise floor.
    swing_m_s2 : float
        Largest minus smallest value of the fitted time term over the session [m/s^2].
    span_s : float
        Session time spanned [s].
    significant : bool
        All three tests of the module docstring passed.
    mass : float
        The axis' moving mass [kg] (nan: not given).
    stiffness : float
        The baseline model's ``da/dy`` along the axis [1/s^2] (:func:`model_stiffness`; nan: not given).
    """

    channel: str
    z: float
    gain: float
    rms_over_floor: float
    swing_m_s2: float
    span_s: float
    significant: bool = False
    mass: float = math.nan
    stiffness: float = math.nan

    @property
    def force_n(self) -> float:
        """``swing_m_s2`` as a force on the axis' moving mass [N] (nan without the mass)."""
        return self.swing_m_s2 * self.mass

    @property
    def reading_um(self) -> float:
        """The drift of the axis' reading that would leave the same residual, ``swing / |da/dy|`` [um]."""
        return self.swing_m_s2 / abs(self.stiffness) * 1e6 if abs(self.stiffness) > 0 else math.nan

    def describe(self) -> str:
        """Where, in words."""
        axis = CHANNEL_AXIS[self.channel]
        txt = (
            f"{self.channel}: a drift in session time at a fixed state that no library effect has: the residual "
            f"moves by {self.swing_m_s2:.3g} m/s^2"
        )
        if np.isfinite(self.force_n):
            txt += f" ({self.force_n:.2g} N)"
        txt += f" over the {self.span_s:.0f} s of the runs"
        if np.isfinite(self.reading_um):
            txt += f", as a reading of {axis} drifting by {self.reading_um:.1f} um"
        return txt + f" (held-out z = {self.z:.1f}, {self.rms_over_floor:.1f}x the noise floor)"

    def to_dict(self) -> dict:
        """JSON form."""
        out = dict(self.__dict__)
        out.update(force_n=self.force_n, reading_um=self.reading_um, what=self.describe())
        return out


def _backfit(s: Samples, T: np.ndarray) -> tuple[AdditiveMap, np.ndarray]:
    """The state map and the time term's coefficients fitted jointly on ``s`` (backfitting)."""
    beta = np.zeros(T.shape[1])
    m = AdditiveMap.fit(s)
    for _ in range(SWEEPS):
        rt = s.r - m.predict(s)
        beta = np.linalg.lstsq(T, rt - rt.mean(), rcond=None)[0]
        m = AdditiveMap.fit(Samples(s.r - T @ beta, s.feat, s.run))
    return m, beta


def _pooled_time(res: Sequence[Residual], taus: Sequence[np.ndarray], c: int) -> np.ndarray:
    """Session time of the samples :func:`.localize.pool` pools for channel ``c`` (same order)."""
    parts = [t for r, t in zip(res, taus, strict=True) if r.run.n and r.run.valid[c]]
    return np.concatenate(parts) if parts else np.zeros(0)


def time_drift(
    train: Sequence[Residual],
    test: Sequence[Residual],
    channel: int,
    floor: float,
    z_crit: float = 4.0,
    min_gain: float = 0.01,
    min_over_floor: float = 0.5,
    mass: float = math.nan,
    stiffness: float = math.nan,
) -> TimeDrift | None:
    """Does the residual of ``channel`` depend on session time at a fixed state (module docstring)?

    Parameters
    ----------
    train, test : sequences of Residual
        The baseline's training and held-out residuals.
    channel : int
        0 vertical, 1 horizontal.
    floor : float
        The channel's noise floor [m/s^2] (the noise model's).
    z_crit, min_gain, min_over_floor : float
        The three tests (module docstring).
    mass : float
        The axis' moving mass [kg], to give the drift as a force.
    stiffness : float
        The baseline model's ``da/dy`` on the held-out runs [1/s^2], to give it as a reading drift.

    Returns
    -------
    TimeDrift or None
        None when the channel has too few samples.
    """
    taus = session_time([*train, *test])
    tau_tr, tau_te = _pooled_time(train, taus[: len(train)], channel), _pooled_time(test, taus[len(train) :], channel)
    tr, te = pool(train, channel), pool(test, channel)
    if tr.n < 100 or te.n < 50 or len(tau_tr) != tr.n or len(tau_te) != te.n:
        return None
    lo, hi = float(min(tau_tr.min(), tau_te.min())), float(max(tau_tr.max(), tau_te.max()))
    T_tr, T_te = _legendre(tau_tr, lo, hi, TIME_ORDER), _legendre(tau_te, lo, hi, TIME_ORDER)
    m0 = AdditiveMap.fit(tr)
    m1, beta = _backfit(tr, T_tr)
    e0 = te.r - m0.predict(te)
    drift_te = T_te @ beta
    e1 = te.r - m1.predict(te) - drift_te
    z = paired_z(e0, e1)
    sse0 = float(e0 @ e0)
    gain = (sse0 - float(e1 @ e1)) / sse0 if sse0 > 0 else 0.0
    grid = np.linspace(lo, hi, 200)
    curve = _legendre(grid, lo, hi, TIME_ORDER) @ beta
    swing = float(np.ptp(curve))
    rms = float(np.sqrt(np.mean((drift_te - drift_te.mean()) ** 2)))
    over = rms / floor if floor > 0 and np.isfinite(floor) else math.nan
    ok = bool(z > z_crit and gain > min_gain and np.isfinite(over) and over >= min_over_floor)
    return TimeDrift(CHANNELS[channel], float(z), float(gain), float(over), swing, hi - lo, ok, mass, stiffness)


def model_stiffness(spec: CandidateSpec, p: np.ndarray, runs: Sequence[PreparedRun], step: float = 1e-6) -> np.ndarray:
    """The model's mean stiffness of each channel along its own axis, ``da_g/dg`` and ``da_d/dd`` [1/s^2].

    A reading of axis ``y`` that is off by ``delta`` makes the model act at ``y + delta``; the residual
    (measured minus model acceleration) then moves by ``-da/dy * delta`` (a central difference of ``step`` on
    the model's acceleration at the runs' samples, averaged over them). Nan for a channel without samples.
    """
    num, cnt = np.zeros(2), np.zeros(2)
    w = np.zeros(len(spec.free))
    for run in runs:
        if run.n == 0:
            continue
        for c, col in ((0, 0), (1, 2)):  # the columns of g and d in Z (:data:`.residuals.Z_NAMES`)
            if not run.valid[c]:
                continue
            zp, zm = run.Z.copy(), run.Z.copy()
            zp[:, col] += step
            zm[:, col] -= step
            da = (accel_series(spec, zp, p, w)[:, c] - accel_series(spec, zm, p, w)[:, c]) / (2 * step)
            num[c] += float(np.sum(da))
            cnt[c] += len(da)
    return np.where(cnt > 0, num / np.maximum(cnt, 1), np.nan)


__all__ = ["SWEEPS", "TIME_ORDER", "TimeDrift", "model_stiffness", "session_time", "time_drift"]
