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
        self._A = None

    # ------------------------------------------------------------------ problem data
    def _matrices(self, H, G, normals):
        """``P`` (upper triangle) and ``A`` as CSC with a fixed sparsity (all structural entries kept)."""
        nv, ng, N = self.nv, self.ng, self.N
        # fixed sparsity: dense upper triangle of H, whatever its values
        Pd = np.zeros((nv + ng, nv + ng))
        Pd[:nv, :nv] = np.triu(H)
        Pd[nv:, nv:] = self.w2 * np.eye(ng)
        mask = np.zeros_like(Pd, dtype=bool)
        mask[:nv, :nv] = np.triu(np.ones((nv, nv), dtype=bool))
        mask[nv:, nv:] = np.eye(ng, dtype=bool)
        rows = self.nv + self.n_cuts * N + 3 * ng
        Ad = np.zeros((rows, nv + ng))
        am = np.zeros_like(Ad, dtype=bool)
        Ad[:nv, :nv] = np.eye(nv)
        am[:nv, :nv] = np.eye(nv, dtype=bool)
        r0 = nv
        for c in range(self.n_cuts):
            for k_ in range(N):
                Ad[r0 + c * N + k_, k_ * NU : (k_ + 1) * NU] = normals[c][k_]
                am[r0 + c * N + k_, k_ * NU : (k_ + 1) * NU] = True
        r0 += self.n_cuts * N
        if ng:
            for blk, sg in ((0, -1.0), (1, 1.0)):
                Ad[r0 + blk * ng : r0 + (blk + 1) * ng, :nv] = G
                am[r0 + blk * ng : r0 + (blk + 1) * ng, :nv] = True
                Ad[r0 + blk * ng : r0 + (blk + 1) * ng, nv:] = sg * np.eye(ng)
                am[r0 + blk * ng : r0 + (blk + 1) * ng, nv:] = np.eye(ng, dtype=bool)
            Ad[r0 + 2 * ng :, nv:] = np.eye(ng)
            am[r0 + 2 * ng :, nv:] = np.eye(ng, dtype=bool)
        return _csc_with_pattern(Pd, mask), _csc_with_pattern(Ad, am)

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

    def refined_normals(self, U: np.ndarray, v: np.ndarray, normals: list[np.ndarray], c: int):
        """Cut refinement after the ``c``-th solve (``v``: the input step, ``U``: ``ubar`` per stage).

        Returns the normals with the next refinement cut turned, at each stage whose input ``U + v`` lies
        outside the current disc, to that input's direction; None when no input is outside or no cut is left.
        """
        w = U + v.reshape(self.N, NU)
        out = np.linalg.norm(w, axis=1) > self.radius * (1 + 1e-9)
        j = self.n_poly + c
        if j + 1 >= self.n_cuts or not out.any():
            return None
        normals = list(normals)
        normals[j + 1] = np.where(out[:, None], self._unit(w), normals[j])
        return normals

    # ------------------------------------------------------------------ solve
    def solve(self, H, q, G, glb, gub, ubar):
        """One QP: ``(z, r_prim, r_dual, iterations)`` (NaN on non-finite data or a failed solve)."""
        import osqp

        nv, ng, N = self.nv, self.ng, self.N
        nan = (np.full(nv + ng, np.nan), np.nan, np.nan, 0.0)
        if not (np.all(np.isfinite(H)) and np.all(np.isfinite(q))):
            return nan
        U = ubar.reshape(N, NU)
        normals = self.initial_normals(U)
        qq = np.concatenate([q, np.full(ng, self.w1)])
        P, A = self._matrices(H, G, normals)
        lo, hi = self._bounds(ubar, glb, gub, normals)
        o = self.opts
        if self._solver is None:
            self._solver = osqp.OSQP()
            self._solver.setup(
                P,
                qq,
                A,
                lo,
                hi,
                verbose=False,
                eps_abs=o.eps_abs,
                eps_rel=o.eps_rel,
                max_iter=o.max_iter,
                polishing=o.polish,
                warm_starting=True,
            )
        else:
            self._solver.update(q=qq, l=lo, u=hi, Px=P.data, Ax=A.data)
        iters = 0
        res = None
        for c in range(self.n_cuts - self.n_poly):
            res = self._solver.solve()
            iters += res.info.iter
            if res.info.status_val not in (1, 2):  # solved, solved inaccurate
                return nan
            refined = self.refined_normals(U, res.x[:nv], normals, c)
            if refined is None:
                break
            normals = refined
            _, A = self._matrices(H, G, normals)
            lo, hi = self._bounds(ubar, glb, gub, normals)
            self._solver.update(l=lo, u=hi, Ax=A.data)
        v = res.x[:nv]
        z = np.concatenate([v, G @ v]) if ng else v
        return z, float(res.info.prim_res), float(res.info.dual_res), float(iters)


def _csc_with_pattern(values: np.ndarray, mask: np.ndarray):
    """CSC matrix holding every entry of ``mask`` (zeros included), so the sparsity never changes."""
    import scipy.sparse as sp

    r, c = np.nonzero(mask.T)  # column-major order
    rows, cols = c, r
    return sp.csc_matrix((values[rows, cols], (rows, cols)), shape=values.shape)


class OSQPCallback(ca.Callback):
    """:class:`OSQPStage` as a CasADi Function ``nmpc_osqp(H, q, G, glb, gub, ubar) -> (z, rp, rd, iters)``."""

    def __init__(self, settings: NMPCSettings):
        ca.Callback.__init__(self)
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
    """A new :class:`OSQPCallback` for ``settings``, kept alive for the process."""
    cb = OSQPCallback(settings)
    _ALIVE.append(cb)
    return cb


__all__ = ["OSQPCallback", "OSQPStage", "osqp_callback"]
