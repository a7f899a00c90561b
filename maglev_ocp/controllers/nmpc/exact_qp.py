"""The NMPC's QP as plain data, its exact solution (interior point, second-order cones) and a KKT check.

The QP our step solves at every RTI step (stage 4 of :mod:`maglev_ocp.controllers.nmpc.step`)
is, in the ``2 N`` input corrections ``v`` about the shifted plan ``ubar``::

    min_v  1/2 v' H v + q' v + sum_i  w1 s_i + w2/2 s_i^2,   s_i = max(0, G_i v - gub_i, glb_i - G_i v)
    s.t.   |ubar_k + v_k|_2 <= r              (current disk per stage, k = 0..N-1)

with ``H, q`` the condensed tracking cost, ``G`` the soft gap rows (millimetres,
relative to the free response) and ``w1``, ``w2`` the exact and quadratic
penalties of :class:`~maglev_ocp.controllers.nmpc.settings.SoftGap`. The per-axis box
``|i| <= i_box = min(8 A, r)`` contains the disk of radius ``r``, so it is not a
separate constraint. This is
the *reference problem* of the accuracy benchmark: exactly what the ADMM
iterates on (the disks as second-order cones, not a polygon), with the soft
bounds written with one slack per gap row::

    min  1/2 v'Hv + q'v + w1 1's + w2/2 |s|^2
    s.t. G v - s <= gub,  -G v - s <= -glb,  s >= 0,  (r, ubar_k + v_k) in SOC_3.

:func:`solve_exact` solves it with Clarabel (an interior-point conic solver) to
``1e-9`` and :func:`kkt_residuals` checks the result independently (stationarity,
primal feasibility, complementarity, dual cone membership).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .layout import NU


@dataclass(frozen=True)
class QPData:
    """One RTI QP of the NMPC (see the module docstring).

    Attributes
    ----------
    H : ndarray (nv, nv)
        Hessian of the condensed cost (inputs weight included).
    q : ndarray (nv,)
        Its gradient at ``v = 0``.
    G : ndarray (ng, nv)
        Soft gap rows [mm per A].
    glb, gub : ndarray (ng,)
        Soft gap bounds minus the free response [mm].
    ubar : ndarray (nv,)
        Linearization point of the currents (the disk applies to ``ubar + v``).
    radius : float
        Disk radius [A].
    w1, w2 : float
        Exact (per mm) and quadratic (per mm^2) penalties of the soft gap rows.
    """

    H: np.ndarray
    q: np.ndarray
    G: np.ndarray
    glb: np.ndarray
    gub: np.ndarray
    ubar: np.ndarray
    radius: float
    w1: float
    w2: float

    @property
    def nv(self) -> int:
        """Number of input corrections (``2 N``)."""
        return self.q.size

    @property
    def ng(self) -> int:
        """Number of soft gap rows."""
        return self.glb.size

    def objective(self, v: np.ndarray) -> float:
        """The QP's objective at ``v`` (soft penalties included)."""
        v = np.asarray(v, dtype=float)
        s = self.gap_violation(v)
        return float(0.5 * v @ self.H @ v + self.q @ v + self.w1 * s.sum() + 0.5 * self.w2 * s @ s)

    def gap_violation(self, v: np.ndarray) -> np.ndarray:
        """``max(0, G v - gub, glb - G v)`` per gap row [mm]."""
        gv = self.G @ v
        return np.maximum(0.0, np.maximum(gv - self.gub, self.glb - gv))

    def disk_violation(self, v: np.ndarray) -> float:
        """Largest ``|ubar_k + v_k| - r`` over the stages (<= 0 when feasible) [A]."""
        u = (self.ubar + v).reshape(-1, NU)
        return float(np.max(np.linalg.norm(u, axis=1)) - self.radius)


@dataclass(frozen=True)
class ExactSolution:
    """Solution of :func:`solve_exact`: ``v``, gap slacks ``s`` and the multipliers (Clarabel's ``z``)."""

    v: np.ndarray
    s: np.ndarray
    z: np.ndarray
    objective: float
    status: str
    iterations: int


def _conic_data(qp: QPData):
    """Clarabel's ``P, c, A, b`` and cones of the reference problem (variables ``(v, s)``)."""
    import scipy.sparse as sp

    nv, ng = qp.nv, qp.ng
    P = sp.block_diag([sp.csc_matrix(np.triu(qp.H)), qp.w2 * sp.eye(ng)], format="csc")
    c = np.concatenate([qp.q, np.full(ng, qp.w1)])
    Ig = sp.eye(ng)
    Gs = sp.csc_matrix(qp.G)
    rows = [
        sp.hstack([Gs, -Ig]),  # G v - s <= gub
        sp.hstack([-Gs, -Ig]),  # -G v - s <= -glb
        sp.hstack([sp.csc_matrix((ng, nv)), -Ig]),  # -s <= 0
    ]
    b = [qp.gub, -qp.glb, np.zeros(ng)]
    n_stages = nv // NU
    for k_ in range(n_stages):  # (r, ubar_k + v_k) in SOC: b - A x = (r, ubar_k + v_k)
        Ak = sp.lil_matrix((1 + NU, nv + ng))
        for j in range(NU):
            Ak[1 + j, k_ * NU + j] = -1.0
        rows.append(Ak.tocsc())
        b.append(np.concatenate([[qp.radius], qp.ubar[k_ * NU : (k_ + 1) * NU]]))
    A = sp.vstack(rows, format="csc")
    return P, c, A, np.concatenate(b), n_stages


def solve_exact(qp: QPData, tol: float = 1e-11, max_iter: int = 200) -> ExactSolution:
    """Solve the reference problem exactly (Clarabel, tolerances ``tol``).

    The objective is scaled by ``1 / max(1, |H|, |q|)`` (multipliers of
    saturated disks otherwise reach 1e3 while weakly active ones are 1e-2, and
    the interior point stalls on the relative gap); the multipliers returned are
    those of the unscaled problem. ``tol`` is near the limit of double
    precision: the interior point may stall (status ``AlmostSolved``, a
    reduced-accuracy iterate) or stop with KKT residuals up to 1e-7 (measured on
    recorded NMPC QPs, which tolerance does best varies from QP to QP). So while
    the largest :func:`kkt_residuals` is above ``100 tol``, the problem is solved
    again at ``10 tol`` and ``tol / 10``, and the solution with the smallest
    residual is returned.
    """
    best = _solve_clarabel(qp, tol, max_iter)
    err = max(kkt_residuals(qp, best).values())
    for t in (10 * tol, tol / 10):
        if err <= 100 * tol:
            break
        alt = _solve_clarabel(qp, t, max_iter)
        e = max(kkt_residuals(qp, alt).values())
        if e < err:
            best, err = alt, e
    return best


def _solve_clarabel(qp: QPData, tol: float, max_iter: int) -> ExactSolution:
    """One Clarabel solve of the reference problem at tolerances ``tol`` (see :func:`solve_exact`)."""
    import clarabel

    P, c, A, b, n_stages = _conic_data(qp)
    scale = 1.0 / max(1.0, float(np.abs(qp.H).max()), float(np.abs(qp.q).max()))
    P, c = P * scale, c * scale
    cones = [clarabel.NonnegativeConeT(3 * qp.ng)] + [clarabel.SecondOrderConeT(1 + NU)] * n_stages
    st = clarabel.DefaultSettings()
    st.verbose = False
    st.tol_gap_abs = st.tol_gap_rel = st.tol_feas = st.tol_ktratio = tol
    st.max_iter = max_iter
    sol = clarabel.DefaultSolver(P, c, A, b, cones, st).solve()
    x = np.asarray(sol.x)
    v = x[: qp.nv]
    return ExactSolution(
        v=v,
        s=x[qp.nv :],
        z=np.asarray(sol.z) / scale,
        objective=qp.objective(v),
        status=str(sol.status),
        iterations=int(sol.iterations),
    )


def kkt_residuals(qp: QPData, sol: ExactSolution) -> dict[str, float]:
    """Infinity norms of the KKT conditions of the reference problem at ``sol`` (independent of the solver).

    Returns ``stationarity`` (``P x + c + A' z``), ``primal`` (cone infeasibility of
    ``b - A x``), ``dual`` (cone infeasibility of ``z``) and ``complementarity``
    (``|z' (b - A x)|`` per cone relative to ``max(1, |z| |b - A x|)``: the
    cosine of the angle between slack and multiplier, which must vanish;
    multipliers of saturated disks reach 1e3), stationarity relative to the
    largest term of the gradient. Clarabel's own stopping rule measures the
    duality gap relative to the objective, which can be small against those
    terms (it then reports ``AlmostSolved`` for a solution this check accepts).
    """
    P, c, A, b, n_stages = _conic_data(qp)
    x = np.concatenate([sol.v, sol.s])
    Pf = P + P.T - np.diag(P.diagonal())
    z = sol.z
    slack = b - A @ x
    scale = max(1.0, np.abs(c).max(), np.abs(Pf @ x).max(), np.abs(A.T @ z).max())
    stat = np.abs(Pf @ x + c + A.T @ z).max() / scale
    m = 3 * qp.ng
    prim = [np.maximum(-slack[:m], 0).max(initial=0.0)]
    dual = [np.maximum(-z[:m], 0).max(initial=0.0)]
    comp = [(np.abs(slack[:m] * z[:m]) / np.maximum(1.0, np.abs(slack[:m] * z[:m]))).max(initial=0.0)]
    for k_ in range(n_stages):
        sl = slice(m + 3 * k_, m + 3 * (k_ + 1))
        sk, zk = slack[sl], z[sl]
        prim.append(max(np.linalg.norm(sk[1:]) - sk[0], 0.0))
        dual.append(max(np.linalg.norm(zk[1:]) - zk[0], 0.0))
        comp.append(abs(sk @ zk) / max(1.0, np.linalg.norm(sk) * np.linalg.norm(zk)))
    return {
        "stationarity": float(stat),
        "primal": float(max(prim)),
        "dual": float(max(dual)),
        "complementarity": float(max(comp)),
    }


__all__ = ["ExactSolution", "QPData", "kkt_residuals", "solve_exact"]
