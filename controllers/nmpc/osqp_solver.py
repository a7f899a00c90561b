"""OSQP as the NMPC's QP solver (``solver: osqp``): the same condensed QP, solved by the osqp package.

OSQP takes linear constraints only, so the current disks of the QP
(:mod:`controllers.nmpc.exact_qp`) become, per stage, the per-axis box and
tangent cuts ``n' (ubar_k + v_k) <= r``: a fixed circumscribed polygon of
``osqp.polygon`` sides, one cut at the direction of the linearization point
``ubar_k`` (the cut acados's RTI linearization of ``|u|^2 <= r^2`` also gives,
but tangent to the disk), and after every refinement pass (``osqp.passes > 1``)
one more at the direction of the last pass's solution where it left the disk:
a cutting-plane outer approximation that converges to the disk. The soft gap rows use one slack each (as in the
reference problem). Variables ``(v, s)``; rows ``[box (2N) | cuts ((polygon + passes) N) | G v -
s <= gub | G v + s >= glb | s >= 0]``.

The solver is a :class:`casadi.Callback` inside the step Function, so the
NMPC's Python backend evaluates it like any other step; it cannot be
code-generated (the C backend refuses it). The OSQP workspace persists between
calls (its own warm start: the previous solution), and is set up once per
design.
"""

from __future__ import annotations

import ctypes
import time

import casadi as ca
import numpy as np

from .layout import NU
from .settings import NMPCSettings


class OSQPStage:
    """The QP stage solved by OSQP: ``(H, q, G, glb, gub, ubar) -> (z, r_prim, r_dual, iters)``.

    ``z`` is ``(v, G v)`` (the ADMM's ``z`` layout: corrections, then the gap rows).
    """

    def __init__(self, settings: NMPCSettings):
        s = settings
        self.N, self.nv, self.ng = s.horizon, s.horizon * NU, s.n_gap
        self.radius, self.box = s.current_limit, s.i_box
        self.w1, self.w2 = s.soft_gap.w_linear, s.soft_gap.w_quadratic
        self.opts = s.osqp
        self.n_poly = s.osqp.polygon
        self.n_cuts = self.n_poly + max(s.osqp.passes, 1)
        self._solver = None
        self._structure()

    # ------------------------------------------------------------------ problem data
    def _structure(self) -> None:
        """The fixed CSC sparsity of ``P`` (upper triangle) and ``A``, and where each stored entry comes from.

        Every structural entry is kept (zeros included), so the sparsity never changes and the values of a
        new QP are one gather: ``P.data = [H.ravel(), w2][p_src]``, ``A.data = [1, -1, normals.ravel(),
        G.ravel()][a_src]`` (see :meth:`_values`).
        """
        nv, ng, N, nc = self.nv, self.ng, self.N, self.n_cuts
        rows, cols, src = [], [], []  # P: dense upper triangle of H, then w2 on the slacks' diagonal
        for j in range(nv):
            for i in range(j + 1):
                rows.append(i), cols.append(j), src.append(i * nv + j)
        for i in range(ng):
            rows.append(nv + i), cols.append(nv + i), src.append(nv * nv)
        self._P_struct = _csc_structure(rows, cols, src, nv + ng)
        one, neg, o_nrm = 0, 1, 2
        o_g = o_nrm + nc * N * NU
        rows, cols, src = [], [], []
        for i in range(nv):  # box rows
            rows.append(i), cols.append(i), src.append(one)
        r0 = nv
        for c in range(nc):  # cut rows: n' v_k
            for k_ in range(N):
                for j in range(NU):
                    rows.append(r0 + c * N + k_), cols.append(k_ * NU + j), src.append(o_nrm + (c * N + k_) * NU + j)
        r0 += nc * N
        for blk, sg in ((0, neg), (1, one)):  # G v - s <= gub, G v + s >= glb
            for i in range(ng):
                for j in range(nv):
                    rows.append(r0 + blk * ng + i), cols.append(j), src.append(o_g + i * nv + j)
                rows.append(r0 + blk * ng + i), cols.append(nv + i), src.append(sg)
        for i in range(ng):  # s >= 0
            rows.append(r0 + 2 * ng + i), cols.append(nv + i), src.append(one)
        self.n_rows = nv + nc * N + 3 * ng
        self._A_struct = _csc_structure(rows, cols, src, nv + ng)

    def _values(self, H, G, normals) -> tuple[np.ndarray, np.ndarray]:
        """``(P.data, A.data)`` of the QP in the fixed sparsity of :meth:`_structure`."""
        px = np.concatenate([np.ravel(H), [self.w2]])[self._P_struct[2]]
        ax = np.concatenate([[1.0, -1.0], np.ravel(normals), np.ravel(G)])[self._A_struct[2]]
        return px, ax

    def _bounds(self, ubar, glb, gub, normals):
        ng, N = self.ng, self.N
        lo = [-self.box - ubar]
        hi = [self.box - ubar]
        for c in range(self.n_cuts):
            nb = np.einsum("ij,ij->i", normals[c], ubar.reshape(N, NU))
            lo.append(np.full(N, -np.inf))
            hi.append(self.radius - nb)
        if ng:
            lo += [np.full(ng, -np.inf), glb, np.zeros(ng)]
            hi += [gub, np.full(ng, np.inf), np.full(ng, np.inf)]
        return np.concatenate(lo), np.concatenate(hi)

    @staticmethod
    def _unit(w: np.ndarray) -> np.ndarray:
        n = np.linalg.norm(w, axis=1, keepdims=True)
        return np.where(n > 1e-9, w / np.maximum(n, 1e-12), np.array([1.0, 0.0]))

    def initial_normals(self, U: np.ndarray) -> list[np.ndarray]:
        """Cut normals per stage: the fixed polygon's, then the refinement cuts (all at ``ubar``'s direction)."""
        ang = 2 * np.pi * np.arange(self.n_poly) / max(self.n_poly, 1)
        poly = [np.tile([np.cos(a), np.sin(a)], (self.N, 1)) for a in ang]
        return poly + [self._unit(U)] * (self.n_cuts - self.n_poly)

    # ------------------------------------------------------------------ solve
    def solve(self, H, q, G, glb, gub, ubar):
        """One QP: ``(z, r_prim, r_dual, iterations)`` (NaN on non-finite data or a failed solve)."""
        nv, ng, N = self.nv, self.ng, self.N
        nan = (np.full(nv + ng, np.nan), np.nan, np.nan, 0.0)
        if not (np.all(np.isfinite(H)) and np.all(np.isfinite(q))):
            return nan
        U = ubar.reshape(N, NU)
        normals = self.initial_normals(U)
        qq = np.concatenate([q, np.full(ng, self.w1)])
        px, ax = self._values(H, G, normals)
        lo, hi = self._bounds(ubar, glb, gub, normals)
        self._load(qq, lo, hi, px, ax)
        iters = 0
        x = info = None
        for c in range(self.n_cuts - self.n_poly):
            x, info = self._run()
            iters += info[1]
            if info[0] not in (1, 2):  # solved, solved inaccurate
                return nan
            v = x[:nv]
            w = U + v.reshape(N, NU)
            out = np.linalg.norm(w, axis=1) > self.radius * (1 + 1e-9)
            j = self.n_poly + c
            if j + 1 >= self.n_cuts or not out.any():
                break
            normals = list(normals)
            normals[j + 1] = np.where(out[:, None], self._unit(w), normals[j])
            _, ax = self._values(H, G, normals)
            lo, hi = self._bounds(ubar, glb, gub, normals)
            self._recut(lo, hi, ax)
        v = x[:nv]
        z = np.concatenate([v, G @ v]) if ng else v
        return z, float(info[2]), float(info[3]), float(iters)

    # ------------------------------------------------------------------ the solver (osqp package)
    def _load(self, q, lo, hi, px, ax) -> None:
        """A new QP: set up the solver on the first, else update all its data (warm start: the last solution)."""
        import osqp

        if self._solver is None:
            o = self.opts
            P, A = self._matrices_of(px, ax)
            self._solver = osqp.OSQP()
            self._solver.setup(
                P,
                q,
                A,
                lo,
                hi,
                verbose=False,
                eps_abs=o.abs_tolerance,
                eps_rel=o.rel_tolerance,
                max_iter=o.max_iter,
                polishing=o.polishing,
                warm_starting=True,
            )
        else:
            self._solver.update(q=q, l=lo, u=hi, Px=px, Ax=ax)

    def _recut(self, lo, hi, ax) -> None:
        """The next cutting-plane pass: new cut rows (``A`` and the bounds)."""
        self._solver.update(l=lo, u=hi, Ax=ax)

    def _run(self) -> tuple[np.ndarray, tuple[int, int, float, float]]:
        """Solve: ``x`` and ``(status, iterations, primal residual, dual residual)``."""
        res = self._solver.solve()
        i = res.info
        return res.x, (int(i.status_val), int(i.iter), float(i.prim_res), float(i.dual_res))

    def _matrices(self, H, G, normals):
        """``P`` (upper triangle) and ``A`` of the QP as scipy CSC, in the fixed sparsity."""
        return self._matrices_of(*self._values(H, G, normals))

    def _matrices_of(self, px, ax):
        """``P`` and ``A`` as scipy CSC from their values in the fixed sparsity."""
        import scipy.sparse as sp

        n = self.nv + self.ng
        (pi, pp, _), (ai, ap, _) = self._P_struct, self._A_struct
        return sp.csc_matrix((px, pi, pp), shape=(n, n)), sp.csc_matrix((ax, ai, ap), shape=(self.n_rows, n))


def _csc_structure(rows: list[int], cols: list[int], src: list[int], n_cols: int):
    """``(indices, indptr, src)`` of a CSC matrix with the given entries, in column-major order."""
    rows_a, cols_a, src_a = (np.asarray(a, dtype=np.int64) for a in (rows, cols, src))
    order = np.lexsort((rows_a, cols_a))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(cols_a, minlength=n_cols))])
    return rows_a[order], indptr, src_a[order]


#: OSQP's infinity (``OSQP_INFTY``): bounds beyond it are absent.
_OSQP_INFTY = 1e30


class EmbeddedOSQPStage(OSQPStage):
    """:class:`OSQPStage` on OSQP's generated C (embedded mode 2) instead of the osqp package.

    Attributes
    ----------
    library : pathlib.Path
        The cached shared library this stage loaded a private copy of
        (:func:`controllers.nmpc.osqp_embedded.load`).
    c_seconds : float
        Time spent in the generated code's calls (updates and solves) since the stage was made [s].
    """

    def __init__(self, settings: NMPCSettings, progress: bool = False):
        from .osqp_embedded import load

        super().__init__(settings)
        self.library, self._lib = load(self, progress)  # a private copy: its own workspace and warm start
        n = int(self._lib.nmpc_osqp_n())
        if n != self.nv + self.ng:
            raise RuntimeError(f"OSQP's embedded code has {n} variables, the QP {self.nv + self.ng}")
        self._x, self._info = np.zeros(n), np.zeros(4)
        self.c_seconds = 0.0

    @staticmethod
    def _ptr(a: np.ndarray | None):
        return None if a is None else a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def _update(self, q, lo, hi, px, ax) -> None:
        # OSQP's C API takes +-OSQP_INFTY (1e30) for a missing bound, not inf (the package clips it for us)
        lo, hi = np.maximum(lo, -_OSQP_INFTY), np.minimum(hi, _OSQP_INFTY)
        arrs = [None if a is None else np.ascontiguousarray(a, dtype=float) for a in (q, lo, hi, px, ax)]
        t0 = time.perf_counter()
        err = self._lib.nmpc_osqp_update(*(self._ptr(a) for a in arrs))
        self.c_seconds += time.perf_counter() - t0
        if err:
            raise RuntimeError(f"OSQP's embedded update failed (error {err})")

    def _load(self, q, lo, hi, px, ax) -> None:
        self._update(q, lo, hi, px, ax)

    def _recut(self, lo, hi, ax) -> None:
        self._update(None, lo, hi, None, ax)

    def _run(self) -> tuple[np.ndarray, tuple[int, int, float, float]]:
        t0 = time.perf_counter()
        self._lib.nmpc_osqp_solve(self._ptr(self._x), self._ptr(self._info))
        self.c_seconds += time.perf_counter() - t0
        i = self._info
        return self._x.copy(), (int(i[0]), int(i[1]), float(i[2]), float(i[3]))


class OSQPCallback(ca.Callback):
    """:class:`OSQPStage` as a CasADi Function ``nmpc_osqp(H, q, G, glb, gub, ubar) -> (z, rp, rd, iters)``."""

    def __init__(self, settings: NMPCSettings):
        ca.Callback.__init__(self)
        if settings.osqp.embedded:
            self.stage: OSQPStage = EmbeddedOSQPStage(settings)
        else:
            self.stage = OSQPStage(settings)
        self.construct("nmpc_osqp", {})

    def get_n_in(self) -> int:
        return 6

    def get_n_out(self) -> int:
        return 4

    def get_name_in(self, i: int) -> str:
        return ("H", "q", "G", "glb", "gub", "ubar")[i]

    def get_name_out(self, i: int) -> str:
        return ("z", "r_prim", "r_dual", "iters")[i]

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        st = self.stage
        shapes = ((st.nv, st.nv), (st.nv, 1), (st.ng, st.nv), (st.ng, 1), (st.ng, 1), (st.nv, 1))
        return ca.Sparsity.dense(*shapes[i])

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.stage.nv + self.stage.ng, 1) if i == 0 else ca.Sparsity.dense(1, 1)

    def eval(self, arg):
        H, q, G, glb, gub, ubar = (np.array(a, dtype=float) for a in arg)
        st = self.stage
        z, rp, rd, it = st.solve(
            H.reshape(st.nv, st.nv), q.ravel(), G.reshape(st.ng, st.nv), glb.ravel(), gub.ravel(), ubar.ravel()
        )
        return [ca.DM(z), ca.DM(rp), ca.DM(rd), ca.DM(it)]


#: Callbacks must outlive the Functions that call them (CasADi holds a raw pointer).
_ALIVE: list[OSQPCallback] = []


def osqp_callback(settings: NMPCSettings) -> OSQPCallback:
    """A new :class:`OSQPCallback` for ``settings`` (package or embedded, ``osqp.embedded``), kept alive."""
    cb = OSQPCallback(settings)
    _ALIVE.append(cb)
    return cb


__all__ = ["EmbeddedOSQPStage", "OSQPCallback", "OSQPStage", "osqp_callback"]
