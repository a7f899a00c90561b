"""Filtered equation-error residuals between the model and a logged run.

The residual of a channel (vertical: the gap ``g``; horizontal: the position
``d``) is the measured acceleration minus the model's, both passed through the
**same** zero-phase FIR low-pass ``h``:

``r_c = h * D2(y_c) - h * K * a_c(y, u; p)``

- ``D2`` is the second difference ``(y[k+1] - 2 y[k] + y[k-1]) / Ts^2`` of the
  quantized encoder reading. Under a zero-order hold it equals exactly
  ``(a[k-1] + a[k]) / 2``, the mean of the accelerations of the two periods
  around sample ``k``; ``K = [1/2, 1/2]`` applies that same average to the
  model side, so no half-sample delay is introduced (a delay would look like an
  amplifier lag).
- ``a[k]`` is the model acceleration over period ``k`` (current ``u[k]`` held
  from ``t[k]`` to ``t[k+1]``), evaluated at the mid-period position
  ``(y[k] + y[k+1]) / 2``.
- Because the identical linear filter acts on the measured accelerations and
  on the model acceleration (hence on every current-carrying regressor, since
  filtering is linear), the closed loop's correlation between current and
  measurement noise produces no phase bias, and the 10 um quantization (white,
  variance q^2/12, amplified as f^4 by ``D2``) is removed above the cut-off.
- The filtered series is decimated (the filter is band-limited), which also
  makes the residual samples less correlated.

The filter, the autocorrelation factor and the standard errors are those of
the identification toolkit shared with the calibration
(:mod:`maglev_ocp.estimation.ident`). The filter gives the analytic
quantization part of the noise floor, ``q / sqrt(12) * ||w||`` with ``w`` the
filter applied to the encoder reading; :mod:`.noise` propagates a whole noise
model through it. Each residual also keeps its unfiltered, full-rate version
(``Residual.wide``) for the spectra: a structural resonance of tens of Hz lies
above the filter's cut-off.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.signal as sps
import scipy.sparse as spa

from .. import constants as k
from ..errors import DataError
from ..estimation import ident

#: Channel names, in the order of the residual's columns.
CHANNELS: tuple[str, str] = ("vertical", "horizontal")
#: Axis measured by each channel.
CHANNEL_AXIS: dict[str, str] = {"vertical": "g", "horizontal": "d"}
#: Columns of the per-period feature matrix ``Z`` fed to the model acceleration.
Z_NAMES: tuple[str, ...] = ("g", "g_dot", "d", "d_dot", "i_q", "i_d", "i_q_prev", "i_d_prev")


@dataclass(frozen=True)
class ResidualSettings:
    """How residuals are filtered.

    Attributes
    ----------
    fc_hz : float
        Cut-off of the zero-phase FIR low-pass [Hz]. Gap effects of a stage
        sweeping at < 0.3 m/s stay below it; quantization noise above it.
    numtaps : int
        FIR length (odd). Kaiser window, ~80 dB stop band.
    decimate : int
        Keep every ``decimate``-th filtered sample.
    vel_fc_hz : float
        Cut-off of the zero-phase smoother that gives velocities (for
        velocity-dependent effects such as friction) [Hz].
    """

    fc_hz: float = 15.0
    numtaps: int = 401
    decimate: int = 8
    vel_fc_hz: float = 25.0


@dataclass
class RunInput:
    """One logged run as the diagnosis needs it (independent of the file format).

    Attributes
    ----------
    name : str
        Run name (file name).
    Ts : float
        Sample period [s].
    y : ndarray, shape (N, 2)
        Encoder readings ``(g, d)`` [m].
    u : ndarray, shape (N, 2)
        Commanded currents ``(i_q, i_d)`` [A]; row k is held from ``t[k]`` to ``t[k+1]``.
    locked : tuple of str
        Axes held by a fixture (``"g"``, ``"d"``).
    t0 : float
        Time of the first row [s].
    """

    name: str
    Ts: float
    y: np.ndarray
    u: np.ndarray
    locked: tuple[str, ...] = ()
    t0: float = 0.0


@dataclass
class PreparedRun:
    """A run turned into filtered residual data.

    Attributes
    ----------
    name : str
        Run name.
    locked : tuple of str
        Locked axes.
    valid : ndarray of bool, shape (2,)
        Which channels carry information (a locked axis has none).
    Z : ndarray, shape (N-1, 8)
        Per-period inputs of the model acceleration (columns :data:`Z_NAMES`).
    W : scipy.sparse.csr_matrix, shape (n_c, N-1)
        The filter ``h * K`` applied to a per-period acceleration series, at the
        decimated centre samples.
    meas : ndarray, shape (n_c, 2)
        Filtered measured accelerations ``h * D2(y)`` [m/s^2].
    centers : ndarray of int, shape (n_c,)
        Sample indices of the residual samples.
    feat : dict of ndarray
        Smoothed signals at the centres: ``t, g, d, g_dot, d_dot, i_q, i_d, di_q, di_d``.
    d2 : ndarray, shape (N-2, 2)
        Unfiltered second difference ``D2(y)`` at samples ``1 .. N-2`` [m/s^2]: the
        wide-band measured acceleration, for the spectra of :mod:`.noise` (a structural
        resonance of tens of Hz lies above the residual filter's cut-off).
    """

    name: str
    locked: tuple[str, ...]
    valid: np.ndarray
    Z: np.ndarray
    W: spa.csr_matrix
    meas: np.ndarray
    centers: np.ndarray
    feat: dict[str, np.ndarray] = field(default_factory=dict)
    d2: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def n(self) -> int:
        """Number of residual samples."""
        return len(self.centers)


class ZeroPhaseFilter(ident.ZeroPhaseFilter):
    """The diagnosis's zero-phase filter: the toolkit's Kaiser kernel, plus the velocity smoother.

    Parameters
    ----------
    settings : ResidualSettings
        Cut-off, length, decimation.
    Ts : float
        Sample period [s].
    """

    def __init__(self, settings: ResidualSettings, Ts: float = k.Ts) -> None:
        if settings.numtaps % 2 == 0:
            raise ValueError("numtaps must be odd (zero phase)")
        super().__init__(ident.kaiser_kernel(settings.fc_hz, settings.numtaps, Ts), Ts, settings.decimate)
        self.settings = settings
        b, a = sps.butter(2, settings.vel_fc_hz, fs=1.0 / Ts)
        self._vel_ba = (b, a)

    def velocity(self, y: np.ndarray) -> np.ndarray:
        """Zero-phase smoothed velocity per period (at the mid-period instants), shape (N-1,)."""
        b, a = self._vel_ba
        ys = sps.filtfilt(b, a, np.asarray(y, float), padlen=min(3 * max(len(a), len(b)), len(y) - 1))
        return np.diff(ys) / self.Ts


def prepare_run(run: RunInput, filt: ZeroPhaseFilter) -> PreparedRun:
    """Turn one logged run into filtered residual data.

    Parameters
    ----------
    run : RunInput
        The run.
    filt : ZeroPhaseFilter
        The filter (shared by all runs of a diagnosis).

    Returns
    -------
    PreparedRun
        With no residual samples if the run is shorter than the filter.
    """
    y = np.asarray(run.y, float)
    u = np.asarray(run.u, float)
    N = len(y)
    if y.shape != (N, 2) or u.shape != (N, 2):
        raise DataError(f"run {run.name}: expected (N, 2) positions and currents")
    if abs(run.Ts - filt.Ts) > 1e-9:
        raise DataError(f"run {run.name}: sample time {run.Ts} differs from the filter's {filt.Ts}")
    centers = filt.centers(N)
    valid = np.array(["g" not in run.locked, "d" not in run.locked])
    if len(centers) == 0:
        return PreparedRun(
            run.name, tuple(run.locked), valid, np.zeros((0, 8)), spa.csr_matrix((0, 0)), np.zeros((0, 2)), centers, {}
        )
    y_mid = 0.5 * (y[:-1] + y[1:])
    v = np.column_stack([filt.velocity(y[:, 0]), filt.velocity(y[:, 1])])
    for j, ax in enumerate(("g", "d")):
        if ax in run.locked:
            v[:, j] = 0.0
    u_prev = np.vstack([u[:1], u[:-2]])
    Z = np.column_stack([y_mid[:, 0], v[:, 0], y_mid[:, 1], v[:, 1], u[:-1, 0], u[:-1, 1], u_prev])
    meas = filt.encoder_accel(y, centers)
    W = filt.period_matrix(N, centers)
    t = run.t0 + centers * run.Ts
    du = np.vstack([np.zeros((1, 2)), np.diff(u, axis=0) / run.Ts])
    feat = {
        "t": t,
        "g": filt.smooth(y[:, 0], centers),
        "d": filt.smooth(y[:, 1], centers),
        "g_dot": filt.smooth(np.append(v[:, 0], v[-1, 0]), centers),
        "d_dot": filt.smooth(np.append(v[:, 1], v[-1, 1]), centers),
        "i_q": filt.smooth(u[:, 0], centers),
        "i_d": filt.smooth(u[:, 1], centers),
        "di_q": filt.smooth(du[:, 0], centers),
        "di_d": filt.smooth(du[:, 1], centers),
    }
    d2 = (y[2:] - 2.0 * y[1:-1] + y[:-2]) / run.Ts**2
    return PreparedRun(run.name, tuple(run.locked), valid, Z, W, meas, centers, feat, d2)


@dataclass
class Residual:
    """Filtered residual of one run under one model.

    Attributes
    ----------
    run : PreparedRun
        The run's data.
    r : ndarray, shape (n_c, 2)
        Residual ``measured - model`` per channel [m/s^2]; NaN in invalid channels.
    model : ndarray, shape (n_c, 2)
        Filtered model acceleration [m/s^2].
    wide : ndarray, shape (N-2, 2) or None
        Unfiltered residual ``D2(y) - K a`` at the full sample rate (samples
        ``1 .. N-2``), NaN in invalid channels: what the spectra and the whiteness
        check of :mod:`.noise` read.
    """

    run: PreparedRun
    r: np.ndarray
    model: np.ndarray
    wide: np.ndarray | None = None


def residual_of(run: PreparedRun, accel: np.ndarray) -> Residual:
    """Residual of ``run`` given the per-period model accelerations ``accel`` (shape (N-1, 2))."""
    model = np.asarray(run.W @ accel)
    r = run.meas - model
    r[:, ~run.valid] = np.nan
    wide = None
    a = np.asarray(accel, float)
    if len(run.d2) and len(a) == len(run.d2) + 1:
        # D2 at sample k equals (a[k-1] + a[k]) / 2 under the zero-order hold (module docstring).
        wide = run.d2 - 0.5 * (a[:-1] + a[1:])
        wide[:, ~run.valid] = np.nan
    return Residual(run, r, model, wide)


__all__ = [
    "CHANNELS",
    "CHANNEL_AXIS",
    "Z_NAMES",
    "PreparedRun",
    "Residual",
    "ResidualSettings",
    "RunInput",
    "ZeroPhaseFilter",
    "prepare_run",
    "residual_of",
]
