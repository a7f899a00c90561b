"""Logged runs as the estimators see them: positions, currents, velocity estimates, locked axes.

Every estimator in this package starts from a :class:`RunData`: the encoder
readings and commanded currents of one run, which axes a fixture held, and
the velocity estimates of the high-gain observer
(:mod:`maglev_ocp.observers`). The observer is run here as one CasADi
``mapaccum`` over the whole run (:func:`observe`), the same predictor-corrector
equations as stepping :class:`maglev_ocp.observers.HighGainObserver` (identical numbers,
checked in the tests) but about fifty times faster, which is what keeps a full
calibration under a minute.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .. import constants as k
from ..errors import DataError
from ..model import get_model
from ..observers import HighGainObserver, ObserverSettings, observer_update
from ..params import NOMINAL, Params

#: Index of each axis' position and velocity in the state ``x = [g, g_dot, d, d_dot]``.
AXIS_ROWS: dict[str, tuple[int, int]] = {"g": (0, 1), "d": (2, 3)}


def call_numpy(fn: ca.Function, *args: np.ndarray | float) -> list[np.ndarray]:
    """Evaluate a CasADi Function with dense inputs and outputs through its buffer API.

    Converting large DM results to numpy element by element costs far more than
    the evaluation; the buffer API lets CasADi read and write numpy memory
    directly. An input given as one column is repeated to the expected number
    of columns (as CasADi does for mapped Functions).

    Parameters
    ----------
    fn : casadi.Function
        Function with dense inputs and outputs.
    *args : array_like
        One per input, shaped like the input (or one column of it).

    Returns
    -------
    list of ndarray
        The outputs, each shaped like the Function's output.
    """
    for i in range(fn.n_out()):
        if not fn.sparsity_out(i).is_dense():
            raise ValueError(f"call_numpy: output {i} of {fn.name()} is sparse; wrap it with dense_function")
    buf, trigger = fn.buffer()
    keep = []
    for i, a in enumerate(args):
        r, c = fn.size1_in(i), fn.size2_in(i)
        arr = np.asarray(a, dtype=float).reshape(r, -1)
        arr = np.broadcast_to(arr, (r, c))
        col_major = np.ascontiguousarray(arr.T)  # CasADi stores column by column
        keep.append(col_major)
        buf.set_arg(i, memoryview(col_major))
    outs = []
    for i in range(fn.n_out()):
        o = np.empty((fn.size2_out(i), fn.size1_out(i)))
        outs.append(o)
        buf.set_res(i, memoryview(o))
    trigger()
    del keep
    return [o.T for o in outs]


_DENSE: dict[str, ca.Function] = {}
_MAPS: dict[tuple[str, int], ca.Function] = {}
#: Samples per evaluation of a mapped Function (building a map costs time growing with its size).
MAP_CHUNK = 8192
#: Samples per evaluation of the observer chain.
OBSERVER_CHUNK = 4096


def dense_function(fn: ca.Function) -> ca.Function:
    """``fn`` (an SX Function) with every output densified (structural zeros stored), cached by name."""
    key = fn.name()
    if key not in _DENSE:
        ins = fn.sx_in()
        outs = fn.call(ins)
        _DENSE[key] = ca.Function(key + "_dense", ins, [ca.densify(o) for o in outs])
    return _DENSE[key]


def eval_samples(fn: ca.Function, *args: np.ndarray) -> list[np.ndarray]:
    """Evaluate an SX Function of one sample over many samples (columns), in cached fixed-size maps.

    Parameters
    ----------
    fn : casadi.Function
        Function of one sample; its inputs are column vectors.
    *args : ndarray
        Per input either shape ``(n_in, N)`` (one column per sample) or one
        column (the same for every sample).

    Returns
    -------
    list of ndarray
        Per output, shape ``(rows, cols * N)``: the per-sample outputs side by side.
    """
    fd = dense_function(fn)
    arrs = [np.asarray(a, dtype=float).reshape(fd.size1_in(i), -1) for i, a in enumerate(args)]
    N = max(a.shape[1] for a in arrs)
    key = (fd.name(), MAP_CHUNK)
    if key not in _MAPS:
        _MAPS[key] = fd.map(MAP_CHUNK)
    fm = _MAPS[key]
    outs: list[list[np.ndarray]] = [[] for _ in range(fd.n_out())]
    for c0 in range(0, N, MAP_CHUNK):
        m = min(MAP_CHUNK, N - c0)
        chunk_args = []
        for a in arrs:
            if a.shape[1] == 1:
                chunk_args.append(a)
            else:
                blk = np.zeros((a.shape[0], MAP_CHUNK))
                blk[:, :m] = a[:, c0 : c0 + m]
                blk[:, m:] = a[:, c0 : c0 + 1]  # pad with a valid sample
                chunk_args.append(blk)
        res = call_numpy(fm, *chunk_args)
        for j, r in enumerate(res):
            w = fd.size2_out(j)
            outs[j].append(r[:, : m * w])
    return [np.hstack(o) for o in outs]


@functools.cache
def _observer_chain(Ts: float, disturbance: bool, n: int) -> ca.Function:
    """``mapaccum`` of one observer update over ``n`` samples (CasADi SX, cached)."""
    m = get_model()
    xh = ca.SX.sym("xh", 4)
    dist = ca.SX.sym("dist", 2)
    y = ca.SX.sym("y", 2)
    u = ca.SX.sym("u", 2)
    p = ca.SX.sym("p", m.np_)
    L = ca.SX.sym("L", 3)
    xn, dn = observer_update(xh, dist, u, y, p, L, Ts, disturbance)
    z = ca.vertcat(xh, dist)
    zn = ca.vertcat(xn, dn)
    one = ca.Function("observer_update", [z, y, u, p, L], [zn])
    return one.mapaccum("observer_chain", n, [0], [0])


def observe(
    y: np.ndarray,
    u: np.ndarray,
    params: Params = NOMINAL,
    settings: ObserverSettings | None = None,
    Ts: float = k.Ts,
) -> np.ndarray:
    """State estimates of a logged run by the high-gain observer, vectorized.

    Same equations and numbers as stepping :class:`~maglev_ocp.observers.HighGainObserver`
    (gain from :class:`~maglev_ocp.observers.HighGainObserver`), evaluated as
    one CasADi ``mapaccum`` instead of a Python loop.

    Parameters
    ----------
    y : ndarray, shape (N, 2)
        Encoder readings ``(g, d)`` [m].
    u : ndarray, shape (N, 2)
        Commanded currents ``(i_q, i_d)`` [A]; row k is applied after reading k.
    params : Params
        Model parameters of the observer's prediction.
    settings : ObserverSettings, optional
        Observer tuning (default: the shared default).
    Ts : float
        Sample period [s].

    Returns
    -------
    ndarray, shape (N, 4)
        ``(g, g_dot, d, d_dot)`` estimates; row k uses readings up to k.
    """
    settings = settings or ObserverSettings()
    obs = HighGainObserver(params, settings, Ts)
    y = np.asarray(y, float)
    u = np.asarray(u, float)
    n = len(y)
    out = np.empty((n, 4))
    out[0] = [y[0, 0], 0.0, y[0, 1], 0.0]
    if n == 1:
        return out
    L = np.zeros(3)
    L[: len(obs.L)] = obs.L
    z = np.concatenate([out[0], np.zeros(2)])
    chain = _observer_chain(float(Ts), bool(settings.disturbance), OBSERVER_CHUNK)
    p = params.vector()
    for c0 in range(1, n, OBSERVER_CHUNK):
        m = min(OBSERVER_CHUNK, n - c0)
        Y = np.repeat(y[c0 + m - 1 : c0 + m], OBSERVER_CHUNK, axis=0)  # padding: harmless extra steps
        U = np.repeat(u[c0 + m - 2 : c0 + m - 1], OBSERVER_CHUNK, axis=0)
        Y[:m], U[:m] = y[c0 : c0 + m], u[c0 - 1 : c0 - 1 + m]
        (Z,) = call_numpy(chain, z, Y.T, U.T, p, L)
        out[c0 : c0 + m] = Z[:4, :m].T
        z = Z[:, m - 1]
    return out


@dataclass
class RunData:
    """One logged run, ready for the estimators.

    Attributes
    ----------
    name : str
        Run name (CSV file name in the dataset).
    t : ndarray, shape (N,)
        Sample times [s] (evenly spaced by ``Ts``).
    y : ndarray, shape (N, 2)
        Encoder readings ``(g, d)`` [m].
    u : ndarray, shape (N, 2)
        Commanded currents ``(i_q, i_d)`` [A], held from sample k to k+1.
    locked : tuple of str
        Axes held by a fixture (``()``, ``("g",)`` or ``("d",)``).
    x_hat : ndarray, shape (N, 4)
        Observer state estimates; a locked axis reads its constant position and zero velocity.
    Ts : float
        Sample period [s].
    """

    name: str
    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    locked: tuple[str, ...] = ()
    x_hat: np.ndarray = field(default=None, repr=False)  # type: ignore[assignment]
    Ts: float = k.Ts

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, float)
        self.y = np.asarray(self.y, float).reshape(-1, 2)
        self.u = np.asarray(self.u, float).reshape(-1, 2)
        self.locked = tuple(self.locked)
        for ax in self.locked:
            if ax not in AXIS_ROWS:
                raise DataError(f"{self.name}: locked axis {ax!r} is not one of g, d")
        if len(self.t) != len(self.y) or len(self.t) != len(self.u):
            raise DataError(f"{self.name}: t, y and u have different lengths")

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.t)

    @property
    def state_mask(self) -> np.ndarray:
        """1 for the state rows of the free axes, 0 for the locked ones (shape (4,))."""
        m = np.ones(4)
        for ax in self.locked:
            m[list(AXIS_ROWS[ax])] = 0.0
        return m

    def with_states(self, params: Params = NOMINAL, settings: ObserverSettings | None = None) -> RunData:
        """Fill :attr:`x_hat` with the observer's estimates (locked axes: constant, zero velocity)."""
        x = observe(self.y, self.u, params, settings, self.Ts)
        for ax in self.locked:
            ip, iv = AXIS_ROWS[ax]
            x[:, ip] = self.y[:, 0 if ax == "g" else 1]
            x[:, iv] = 0.0
        self.x_hat = x
        return self

    def measured_state(self) -> np.ndarray:
        """The NPFISI measurement ``y = x + eps*nu``: encoder positions with estimated velocities."""
        if self.x_hat is None:
            self.with_states()
        x = self.x_hat.copy()
        x[:, 0] = self.y[:, 0]
        x[:, 2] = self.y[:, 1]
        return x


def runs_from_dataset(dataset, params: Params = NOMINAL, settings: ObserverSettings | None = None) -> list[RunData]:
    """The runs of a rig-log :class:`~maglev_ocp.riglog.Dataset` as :class:`RunData` with state estimates.

    Parameters
    ----------
    dataset : maglev_ocp.riglog.Dataset
        A dataset read by :func:`maglev_ocp.riglog.read_dataset`.
    params : Params
        Model parameters of the observer's prediction.
    settings : ObserverSettings, optional
        Observer tuning.
    """
    out = []
    for r in dataset.runs:
        rd = RunData(r.file, r.t, r.y, r.u, tuple(r.locked), Ts=float(dataset.sample_time))
        out.append(rd.with_states(params, settings))
    return out
