"""Structure-exploiting ADMM for the NMPC's QP: the x-update by a Riccati recursion, O(N) per iteration.

The same QP and the same ADMM iteration as :mod:`controllers.nmpc_qp` (OSQP's
iteration with the current disks and the soft gap bounds as the ``z`` block,
the same penalty ``rho`` from the trace of the condensed Hessian), but the
equality-constrained x-update

    min  sum_k 1/2 |dx_k + E_k|^2_{W_k} + 1/2 |du_k + e_k|^2_R + sigma/2 |du - x|^2
         + rho/2 |du - z_u + y_u/rho|^2 + rho_g/2 |1e3 dx_gap - z_g + y_g/rho_g|^2
    s.t. dx_{k+1} = A_k dx_k + B_k du_k + c_k

is solved stage-wise instead of through the dense condensed matrix: the
Riccati factorization (``P_k``, feedback ``K_k``) depends only on the
linearization and ``rho``, so it is computed once per control step
(``O(N nx^3)``), and every ADMM iteration is one backward sweep of the linear
terms and one forward rollout (``O(N nx^2)``). In exact arithmetic the iterates
equal the dense ones (tested). Two SX Functions with the stages unrolled (the
factorization, and one iteration called ``n_iter`` times): straight-line code
without copies, about a fifth of the dense version's size.

The gap rows use ``z_g = 1e3 dx_k[0]`` (millimetres relative to the shooting
node) instead of the dense form's ``G v`` (relative to the free response), a
constant shift: the warm start ``z_g = 1e3 xi_k[0]`` (free response) makes the
two sequences identical.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

NX, NU = 4, 2


def _sx(n, m=1, name="a"):
    return ca.SX.sym(name, n, m)


def open_loop_stage() -> ca.Function:
    """``(S_next, A, B, W) -> (S, tr)``: ``S = W + A' S_next A``, ``tr = trace(B' S_next B)`` (for rho)."""
    Sn, A, B, W = _sx(NX, NX, "S_next"), _sx(NX, NX, "A"), _sx(NX, NU, "B"), _sx(NX, NX, "W")
    S = W + ca.mtimes([A.T, Sn, A])
    tr = ca.trace(ca.mtimes([B.T, Sn, B]))
    return ca.Function("nmpc_ol_stage", [Sn, A, B, W], [S, tr], ["S_next", "A", "B", "W"], ["S", "tr"],
                       {"cse": True})


def riccati_stage() -> ca.Function:
    """One backward step of the Riccati factorization of the ADMM x-update.

    ``(P_next, A, B, c, Wq, Rt) -> (P, K, Sinv, PB, Pc)`` with ``S = diag(Rt) +
    B' P_next B``, ``K = -S^-1 B' P_next A``, ``P = Wq + A' P_next (A + B K)``;
    ``Wq`` is the state weight of this node including the gap-row penalty.
    """
    Pn, A, B, c, Wq, Rt = (_sx(NX, NX, "P_next"), _sx(NX, NX, "A"), _sx(NX, NU, "B"), _sx(NX, 1, "c"),
                           _sx(NX, NX, "Wq"), _sx(NU, 1, "Rt"))
    PB = ca.mtimes(Pn, B)
    PA = ca.mtimes(Pn, A)
    S = ca.diag(Rt) + ca.mtimes(B.T, PB)
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    Sinv = ca.vertcat(ca.horzcat(S[1, 1], -S[0, 1]), ca.horzcat(-S[1, 0], S[0, 0])) / det
    K = -ca.mtimes(Sinv, ca.mtimes(B.T, PA))
    P = Wq + ca.mtimes(A.T, PA) + ca.mtimes(ca.mtimes(A.T, PB), K)
    P = (P + P.T) / 2
    return ca.Function("nmpc_ric_stage", [Pn, A, B, c, Wq, Rt], [P, K, Sinv, PB, ca.mtimes(Pn, c)],
                       ["P_next", "A", "B", "c", "Wq", "Rt"], ["P", "K", "Sinv", "PB", "Pc"], {"cse": True})


def backward_stage() -> ca.Function:
    """Linear terms, backward: ``(p_next, Sinv, PB, Pc, A, B, r, q) -> (p, kff)``.

    ``s = p_next + P_next c``, ``kff = -S^-1 (r + B' s)``, ``p = q + A' (s + P_next B kff)``.
    """
    pn, Sinv, PB, Pc, A, B, r, q = (_sx(NX, 1, "p_next"), _sx(NU, NU, "Sinv"), _sx(NX, NU, "PB"), _sx(NX, 1, "Pc"),
                                    _sx(NX, NX, "A"), _sx(NX, NU, "B"), _sx(NU, 1, "r"), _sx(NX, 1, "q"))
    s = pn + Pc
    kff = -ca.mtimes(Sinv, r + ca.mtimes(B.T, s))
    p = q + ca.mtimes(A.T, s + ca.mtimes(PB, kff))
    return ca.Function("nmpc_bwd_stage", [pn, Sinv, PB, Pc, A, B, r, q], [p, kff],
                       ["p_next", "Sinv", "PB", "Pc", "A", "B", "r", "q"], ["p", "kff"])


def forward_stage() -> ca.Function:
    """Rollout: ``(dx, K, kff, A, B, c) -> (dx_next, du)`` with ``du = K dx + kff``."""
    dx, K, kff, A, B, c = (_sx(NX, 1, "dx"), _sx(NU, NX, "K"), _sx(NU, 1, "kff"), _sx(NX, NX, "A"),
                           _sx(NX, NU, "B"), _sx(NX, 1, "c"))
    du = ca.mtimes(K, dx) + kff
    return ca.Function("nmpc_fwd_stage", [dx, K, kff, A, B, c], [ca.mtimes(A, dx) + ca.mtimes(B, du) + c, du],
                       ["dx", "K", "kff", "A", "B", "c"], ["dx_next", "du"])


def factor_function(N: int, gap_stages: tuple[int, ...], Q: np.ndarray, P: np.ndarray, R: tuple[float, float],
                    admm, gap_lo: float, gap_hi: float) -> ca.Function:
    """Per-step preparation of the Riccati ADMM (one SX Function, stages unrolled).

    ``(As, Bs, cs, dx0, Xbar, Xref, Ubar, Uref, fault) -> (K, Sinv, PB, Pc, rho, qW, rbase, glb, gub, zg0)``:
    penalty ``rho`` from the trace of the condensed Hessian (open-loop cost-to-go
    recursion, the rule of :func:`controllers.nmpc_qp.admm_rho`), the Riccati
    factorization for ``R + sigma + rho``, the constant linear terms, the soft gap
    bounds and the free response of the gap rows (warm start of ``z_g``).
    """
    from .nmpc_qp import rho_from_trace

    ng = len(gap_stages)
    nv = NU * N
    As, Bs, cs = _sx(NX, NX * N, "As"), _sx(NX, NU * N, "Bs"), _sx(NX, N, "cs")
    dx0, Xb, Xr = _sx(NX, 1, "dx0"), _sx(NX, N + 1, "Xbar"), _sx(NX, N + 1, "Xref")
    Ub, Ur, fault = _sx(NU, N, "Ubar"), _sx(NU, N, "Uref"), _sx(1, 1, "fault")
    A = [As[:, j * NX:(j + 1) * NX] for j in range(N)]
    B = [Bs[:, j * NU:(j + 1) * NU] for j in range(N)]
    c = [cs[:, j] for j in range(N)]
    W = [ca.DM(Q)] * N + [ca.DM(P)]
    # trace of the condensed Hessian: N tr(R) + sum_j tr(B_j' S_{j+1} B_j), S_k = W_k + A_k' S_{k+1} A_k
    ol = open_loop_stage()
    Sk = ca.SX(W[N])
    tr = N * float(sum(R))
    for j in range(N - 1, -1, -1):
        Sk, t = ol(Sk, A[j], B[j], W[j])
        tr = tr + t
    rho = rho_from_trace(tr, nv, min(R), admm)
    Rt = ca.DM(R) + admm.sigma + rho + ca.if_else(fault > 0.5, np.nan, 0)  # forced failure (tests)
    gam = admm.rho_g_rel * rho * 1e6  # gap rows are 1e3 dx[0]: weight rho_g (1e3)^2 on dx[0]^2
    e11 = ca.DM.zeros(NX, NX)
    e11[0, 0] = 1
    gset = set(gap_stages)
    Wq = [W[j] + gam * e11 if j in gset else ca.SX(W[j]) for j in range(N + 1)]
    ric = riccati_stage()
    Pk = Wq[N]
    K, Sinv, PB, Pc = [None] * N, [None] * N, [None] * N, [None] * N
    for j in range(N - 1, -1, -1):
        Pk, K[j], Sinv[j], PB[j], Pc[j] = ric(Pk, A[j], B[j], c[j], Wq[j], Rt)
    qW = ca.horzcat(*[ca.mtimes(W[j], Xb[:, j] - Xr[:, j]) for j in range(N + 1)])
    rbase = ca.DM(R) * (Ub - Ur)
    xi, zg0 = dx0, []
    for j in range(N):
        xi = ca.mtimes(A[j], xi) + c[j]
        if j + 1 in gset:
            zg0.append(1e3 * xi[0])
    glb = ca.vertcat(*[1e3 * (gap_lo - Xb[0, j]) for j in gap_stages]) if ng else ca.SX(0, 1)
    gub = ca.vertcat(*[1e3 * (gap_hi - Xb[0, j]) for j in gap_stages]) if ng else ca.SX(0, 1)
    outs = [ca.horzcat(*K), ca.horzcat(*Sinv), ca.horzcat(*PB), ca.horzcat(*Pc), ca.vertcat(rho, 1 / rho), qW,
            rbase, glb, gub, ca.vertcat(*zg0) if ng else ca.SX(0, 1)]
    return ca.Function("nmpc_ric_factor", [As, Bs, cs, dx0, Xb, Xr, Ub, Ur, fault], outs,
                       ["As", "Bs", "cs", "dx0", "Xbar", "Xref", "Ubar", "Uref", "fault"],
                       ["K", "Sinv", "PB", "Pc", "rho", "qW", "rbase", "glb", "gub", "zg0"], {"cse": True})


def iteration_function(N: int, gap_stages: tuple[int, ...], radius: float, box: float, soft_w1: float,
                       soft_w2: float, admm) -> ca.Function:
    """One ADMM iteration with the Riccati x-update (one SX Function, stages unrolled).

    ``(x, z, y, K, Sinv, PB, Pc, As, Bs, cs, dx0, qW, rbase, ubar, glb, gub, rho) -> (x, z, y, r_prim, r_dual)``.
    """
    ng = len(gap_stages)
    nv = NU * N
    x, z, y = _sx(nv, 1, "x"), _sx(nv + ng, 1, "z"), _sx(nv + ng, 1, "y")
    K, Sinv, PB, Pc = _sx(NU, NX * N, "K"), _sx(NU, NU * N, "Sinv"), _sx(NX, NU * N, "PB"), _sx(NX, N, "Pc")
    As, Bs, cs, dx0 = _sx(NX, NX * N, "As"), _sx(NX, NU * N, "Bs"), _sx(NX, N, "cs"), _sx(NX, 1, "dx0")
    qW, rbase, ubar = _sx(NX, N + 1, "qW"), _sx(NU, N, "rbase"), _sx(nv, 1, "ubar")
    glb, gub, rho = _sx(ng, 1, "glb"), _sx(ng, 1, "gub"), _sx(2, 1, "rho")
    terms = admm_terms(N, gap_stages, admm.sigma, admm.rho_g_rel)
    r_rev, q_rev, q_last = terms(x, z, y, rbase, qW, rho)
    bwd, fwd = backward_stage(), forward_stage()
    sl = lambda M, j, w: M[:, j * w:(j + 1) * w]  # noqa: E731
    p = q_last
    kff = [None] * N
    for i in range(N):  # stage j = N-1 .. 0
        j = N - 1 - i
        p, kff[j] = bwd(p, sl(Sinv, j, NU), sl(PB, j, NU), Pc[:, j], sl(As, j, NX), sl(Bs, j, NU), r_rev[:, i],
                        q_rev[:, i])
    dxk, dxs, dus = dx0, [], []
    for j in range(N):
        dxk, du = fwd(dxk, sl(K, j, NX), kff[j], sl(As, j, NX), sl(Bs, j, NU), cs[:, j])
        dxs.append(dxk)
        dus.append(du)
    upd = admm_update(N, gap_stages, radius, box, soft_w1, soft_w2, admm.alpha, admm.rho_g_rel)
    outs = upd(ca.vertcat(*dus), ca.horzcat(*dxs), x, z, y, ubar, glb, gub, rho)
    return ca.Function("nmpc_ric_iter", [x, z, y, K, Sinv, PB, Pc, As, Bs, cs, dx0, qW, rbase, ubar, glb, gub, rho],
                       list(outs), ["x", "z", "y", "K", "Sinv", "PB", "Pc", "As", "Bs", "cs", "dx0", "qW", "rbase",
                                    "ubar", "glb", "gub", "rho"], ["x_out", "z_out", "y_out", "r_prim", "r_dual"])


def admm_terms(N: int, gap_stages: tuple[int, ...], sigma: float, rho_g_rel: float) -> ca.Function:
    """Linear terms of the x-update from the ADMM state (SX).

    ``(x, z, y, rbase, qW, rho) -> (r_rev, q_rev, q_last)``: input terms
    ``r_k = rbase_k - sigma x_k + y_u,k - rho z_u,k`` and node terms
    ``q_k = qW_k + 1e3 (y_g - rho_g z_g) e_1`` at gap nodes, in the orders
    :meth:`RiccatiADMM.backward` takes them.
    """
    ng = len(gap_stages)
    nv = NU * N
    x, z, y = _sx(nv, 1, "x"), _sx(nv + ng, 1, "z"), _sx(nv + ng, 1, "y")
    rbase, qW, rho = _sx(NU, N, "rbase"), _sx(NX, N + 1, "qW"), _sx(2, 1, "rho")
    rho_u, rho_g = rho[0], rho_g_rel * rho[0]
    r = ca.reshape(ca.vec(rbase) - sigma * x + y[:nv] - rho_u * z[:nv], NU, N)
    qcols = [qW[:, j] for j in range(N + 1)]
    for i, j in enumerate(gap_stages):
        qcols[j] = qcols[j] + ca.vertcat(1e3 * (y[nv + i] - rho_g * z[nv + i]), 0, 0, 0)
    r_rev = ca.horzcat(*[r[:, N - 1 - j] for j in range(N)])
    q_rev = ca.horzcat(*[qcols[N - 1 - j] for j in range(N)])
    return ca.Function("nmpc_admm_terms", [x, z, y, rbase, qW, rho], [r_rev, q_rev, qcols[N]],
                       ["x", "z", "y", "rbase", "qW", "rho"], ["r_rev", "q_rev", "q_last"])


def admm_update(N: int, gap_stages: tuple[int, ...], radius: float, box: float, soft_w1: float, soft_w2: float,
                alpha: float, rho_g_rel: float) -> ca.Function:
    """Relaxation, proximal steps and dual update of one ADMM iteration (SX).

    ``(xt, dx, x, z, y, ubar, glb, gub, rho) -> (x, z, y, r_prim, r_dual)`` where
    ``xt`` are the input corrections of the x-update and ``dx`` (NX x N) its
    states ``dx_1 .. dx_N``; ``z_g = 1e3 dx_k[0]`` at the gap stages.
    ``r_dual`` is ``rho max |z_new - z|`` (scaled units).
    """
    from .nmpc_qp import project_disk, prox_soft_bound

    ng = len(gap_stages)
    nv = NU * N
    xt, dx, x, z, y = (_sx(nv, 1, "xt"), _sx(NX, N, "dx"), _sx(nv, 1, "x"), _sx(nv + ng, 1, "z"),
                       _sx(nv + ng, 1, "y"))
    ubar, glb, gub, rho = _sx(nv, 1, "ubar"), _sx(ng, 1, "glb"), _sx(ng, 1, "gub"), _sx(2, 1, "rho")
    rho_u, rho_u_inv = rho[0], rho[1]
    rho_g, rho_g_inv = rho_g_rel * rho_u, rho_u_inv / rho_g_rel
    zt_g = ca.vertcat(*[1e3 * dx[0, j - 1] for j in gap_stages]) if ng else ca.SX(0, 1)
    zu, zg, yu, yg = z[:nv], z[nv:], y[:nv], y[nv:]
    a = alpha
    x_new = a * xt + (1 - a) * x
    vu = a * xt + (1 - a) * zu
    vg = a * zt_g + (1 - a) * zg
    wu = vu + yu * rho_u_inv
    zu_new = ca.vertcat(*[project_disk(ubar[k * NU:(k + 1) * NU] + wu[k * NU:(k + 1) * NU], radius, box)
                          - ubar[k * NU:(k + 1) * NU] for k in range(N)])
    zg_new = prox_soft_bound(vg + yg * rho_g_inv, glb, gub, soft_w1, soft_w2, rho_g) if ng else ca.SX(0, 1)
    y_new = ca.vertcat(yu + rho_u * (vu - zu_new), yg + rho_g * (vg - zg_new))
    z_new = ca.vertcat(zu_new, zg_new)
    r_prim = ca.mmax(ca.fabs(ca.vertcat(xt - zu_new, zt_g - zg_new)))
    r_dual = rho_u * ca.mmax(ca.fabs(z_new - z))
    return ca.Function("nmpc_admm_update", [xt, dx, x, z, y, ubar, glb, gub, rho],
                       [x_new, z_new, y_new, r_prim, r_dual],
                       ["xt", "dx", "x", "z", "y", "ubar", "glb", "gub", "rho"],
                       ["x_out", "z_out", "y_out", "r_prim", "r_dual"])


