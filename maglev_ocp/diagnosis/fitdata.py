"""The training data of a fit (:class:`Dataset`): the stacked runs and their residual filter, applied in
polyphase form to per-period series; and the BLAS held to one thread in the fits (:func:`one_blas_thread`).

Split from :mod:`.fit` (which re-exports both): the filter product is where the fits spend most of their time
(``benchmarks/diagnosis_speed.py``).
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterator, Sequence

import numpy as np
from numpy.lib.stride_tricks import as_strided
from threadpoolctl import ThreadpoolController

from .residuals import PreparedRun, ZeroPhaseFilter

#: From this many columns on, the polyphase filter's sum over its phases is taken as shifted slice additions
#: (:func:`_shifted_sum`) instead of one strided reduction: numpy reduces a strided axis element by element in
#: the same order, so the two agree to the last bit, and the slices stream through memory where the strided
#: view jumps by a phase's stride at every term (1.6-2.5x faster at 5-30 columns, no faster below:
#: ``benchmarks/bench_filter.py``).
_SHIFTED_ADDS_MIN_COLUMNS: int = 5


def _shifted_sum(P: np.ndarray, n: int) -> np.ndarray:
    """``out[:, j] = sum_q P[q, :, j + q]`` for ``j < n`` (``P``: phases x columns x blocks), summed over ``q`` in
    increasing order, term by term: bit for bit the strided reduction it replaces."""
    out = P[0, :, :n].copy()
    for q in range(1, P.shape[0]):
        out += P[q, :, q : q + n]
    return out


@functools.lru_cache(maxsize=1)
def _blas_controller() -> ThreadpoolController:
    return ThreadpoolController()


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """The BLAS limited to one thread inside the block (restored after).

    A fit's products are small (tens of columns by a few thousand rows): OpenBLAS's threads gain nothing on
    them and, on a machine whose cores are busy (the fit workers, other processes), spin waiting for each
    other. Measured on one diagnosis's filter product (17 columns, load 5 on 2 cores): 96 ms with the default
    two threads, 29 ms with one (``results/benchmarks/diagnosis_speed.md``).
    """
    with _blas_controller().limit(limits=1, user_api="blas"):
        yield


class Dataset:
    """Training (or scoring) data of a fit: stacked runs, per-channel filter rows.

    Parameters
    ----------
    runs : sequence of PreparedRun
        Runs (each with ``Z``, ``W``, ``meas``).
    sqrt_w : ndarray, shape (2,)
        Square-root weights of the two channels (1 / noise rms).
    filt : ZeroPhaseFilter
        The filter the runs were prepared with (for the symbolic filter of the NLP).
    row_w : sequence of ndarray, optional
        Per-run weights ``(n, 2)`` of the residual samples (0 leaves a sample
        out: the baseline's calibration on the clean part of the data).
    prior_weight : float
        How many weighted residual samples one independent one is worth (the
        residual's autocorrelation inflation): the weight of a :class:`Free`
        prior against the data.
    """

    def __init__(
        self,
        runs: Sequence[PreparedRun],
        sqrt_w: np.ndarray,
        filt: ZeroPhaseFilter,
        row_w: Sequence[np.ndarray] | None = None,
        prior_weight: float = 1.0,
    ):
        keep = [i for i, r in enumerate(runs) if r.n > 0]
        self.runs = [runs[i] for i in keep]
        self.sqrt_w = np.asarray(sqrt_w, float)
        self.filt = filt
        self.prior_weight = float(prior_weight)
        rw = [np.ones((r.n, 2)) for r in self.runs] if row_w is None else [np.asarray(row_w[i], float) for i in keep]
        self.Z = np.vstack([r.Z for r in self.runs]) if self.runs else np.zeros((0, 8))
        self.offsets = np.cumsum([0] + [len(r.Z) for r in self.runs])
        meas = np.vstack([r.meas for r in self.runs]) if self.runs else np.zeros((0, 2))
        mask = np.vstack([np.tile(r.valid, (r.n, 1)) for r in self.runs]) if self.runs else np.zeros((0, 2), bool)
        self.m_c = [meas[mask[:, c], c] for c in range(2)]
        rws = np.vstack(rw) if rw else np.zeros((0, 2))
        self.row_w_c = [rws[mask[:, c], c] for c in range(2)]
        self.n_c = [int(mask[:, c].sum()) for c in range(2)]
        self.n = sum(self.n_c)
        # independent blocks of the stacked residual (channel-major, then run): one per run and channel
        sizes = [r.n for c in range(2) for r in self.runs if r.valid[c]]
        self.block_bounds = np.cumsum([0, *sizes])
        self._poly: list[tuple] | None = None

    def weighted_residual(self, a: np.ndarray) -> np.ndarray:
        """Stacked weighted residual for per-period accelerations ``a`` (N_tot, 2)."""
        return np.concatenate(
            [self.sqrt_w[c] * self.row_w_c[c] * (self.m_c[c] - self.filter(a[:, c], c)) for c in range(2)]
        )

    def filter(self, X: np.ndarray, channel: int) -> np.ndarray:
        """The runs' filter rows (``PreparedRun.W``, on the runs valid in ``channel``) applied to a per-period
        series ``X`` (N_tot,) or (N_tot, k), in polyphase form.

        With ``D`` the decimation and ``w_a`` padded to ``D Q`` taps,
        ``(W x)_j = sum_q sum_r w_a[D q + r] x[base + D (j + q) + r]``: the same products as the sparse rows
        (401 taps, every 8th sample kept) as one dense ``Q x D`` by ``D x (k n / D)`` product per run and a
        strided sum over ``q``. The fits spend most of their time here: 1.6-6 times faster than the sparse
        product on one core (k = 17 to 1 columns), without streaming 2 million stored taps per product.
        """
        X = np.asarray(X, float)
        vec = X.ndim == 1
        X2 = X[:, None] if vec else X
        k_ = X2.shape[1]
        res = np.empty((self.n_c[channel], k_))
        j0 = 0
        for (off, base, n_take, pad, nb, Q, D, wqT), run in zip(self._polyphase(), self.runs, strict=True):
            if not run.valid[channel]:
                continue
            seg = X2[off + base : off + base + n_take]
            if pad:
                seg = np.concatenate([seg, np.zeros((pad, k_))])
            # P[q, :, b] = sum_r w_a[D q + r] x[base + D b + r];  (W x)_j = sum_q P[q, :, j + q], read as a
            # strided view (element (:, j, q) at P[q, :, j + q]) summed over q
            T = seg.reshape(nb, D, k_).transpose(1, 2, 0).reshape(D, k_ * nb)
            P = (wqT @ T).reshape(Q, k_, nb)
            if k_ < _SHIFTED_ADDS_MIN_COLUMNS:
                s0, s1, s2 = P.strides
                V = as_strided(P, shape=(k_, run.n, Q), strides=(s1, s2, s0 + s2), writeable=False)
                V.sum(axis=2, out=res[j0 : j0 + run.n].T)
            else:
                res[j0 : j0 + run.n] = _shifted_sum(P, run.n).T
            j0 += run.n
        return res[:, 0] if vec else res

    def _polyphase(self) -> list[tuple]:
        # Per run: (offset, base, n_take, pad, nb, Q, D, wqT) with wqT[q, r] = w_a[D q + r].
        if self._poly is None:
            D = self.filt.decimate
            w_a = self.filt.w_a
            Q = -(-len(w_a) // D)
            wpad = np.zeros(D * Q)
            wpad[: len(w_a)] = w_a
            wqT = wpad.reshape(Q, D)
            out = []
            for i, r in enumerate(self.runs):
                base = int(r.centers[0]) - self.filt.M - 1
                nb = r.n + Q - 1
                n_seg = D * nb
                pad = max(0, n_seg - (len(r.Z) - base))
                out.append((int(self.offsets[i]), base, n_seg - pad, pad, nb, Q, D, wqT))
            self._poly = out
        return self._poly


__all__ = ["Dataset", "one_blas_thread"]
