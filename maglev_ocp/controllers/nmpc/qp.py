"""Dense condensed QP of the NMPC and its fixed-budget ADMM solver, as CasADi SX.

Everything here builds CasADi expressions, so the QP solver is part of the one
step Function: evaluated by CasADi in Python, and code-generated to plain C (no
library, no malloc, no data-dependent branching) for the rig.

The QP after condensing the multiple-shooting RTI linearization is

    min_v  1/2 v' H v + q' v   s.t.  z = A v,  z in C

with ``v`` the input corrections of the horizon (``2 N`` entries), ``A = [I; G]``
(``G`` maps ``v`` to the predicted gap at the constrained stages) and ``C`` the
product of one current disk per stage (the 8 A amplitude limit, which contains
the +-8 A box) and of soft gap bounds (exact + quadratic penalty). It is solved
by OSQP's ADMM iteration with a fixed number of steps: the KKT matrix
``H + sigma I + A' R A`` is factorized once per control step (dense Cholesky,
``n^3/6`` flops), every iteration costs two triangular solves, a product with
``G`` and ``G'`` and closed-form proximal steps.
"""

from __future__ import annotations

import casadi as ca

from .settings import ADMMOptions


def chol_sx(M: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Dense Cholesky factor ``M = L L'`` of a symmetric positive definite SX matrix.

    Parameters
    ----------
    M : casadi.SX, shape (n, n)
        Symmetric positive definite matrix (only the lower triangle is read).

    Returns
    -------
    L : casadi.SX, shape (n, n)
        Lower-triangular factor (diagonal entries included).
    dinv : casadi.SX, shape (n, 1)
        ``1 / diag(L)``, so that the solves need no division.

    Notes
    -----
    A non-positive pivot gives ``sqrt`` of a negative number, i.e. NaN, which
    the step Function's finiteness check turns into a fallback.
    """
    n = M.shape[0]
    Lc = [[ca.SX(0) for _ in range(n)] for _ in range(n)]
    dinv = [ca.SX(0) for _ in range(n)]
    for j in range(n):
        s = M[j, j]
        for k_ in range(j):
            s = s - Lc[j][k_] * Lc[j][k_]
        d = ca.sqrt(s)
        Lc[j][j] = d
        dinv[j] = 1 / d
        for i in range(j + 1, n):
            s = M[i, j]
            for k_ in range(j):
                s = s - Lc[i][k_] * Lc[j][k_]
            Lc[i][j] = s * dinv[j]
    # nonzeros of Sparsity.lower(n) in column-major order
    nz = [Lc[i][j] for j in range(n) for i in range(j, n)]
    L = ca.SX(ca.Sparsity.lower(n), ca.vertcat(*nz))
    return L, ca.vertcat(*dinv)


def chol_solve_sx(L: ca.SX, dinv: ca.SX, b: ca.SX) -> ca.SX:
    """Solve ``L L' x = b`` by forward and back substitution (SX, unrolled)."""
    n = L.shape[0]
    t = [ca.SX(0)] * n
    for i in range(n):
        s = b[i]
        for j in range(i):
            s = s - L[i, j] * t[j]
        t[i] = s * dinv[i]
    x = [ca.SX(0)] * n
    for i in reversed(range(n)):
        s = t[i]
        for j in range(i + 1, n):
            s = s - L[j, i] * x[j]
        x[i] = s * dinv[i]
    return ca.vertcat(*x)


def condensed_qp(
    As: list, Bs: list, cs: list, dx0: ca.SX, E: list, Ws: list, gap_stages: tuple[int, ...], gbar: list
) -> dict[str, ca.SX]:
    """Condense the linearized shooting constraints and the tracking cost into a dense QP in ``v``.

    Dynamics ``dx_{k+1} = A_k dx_k + B_k v_k + c_k`` (``c_k`` the shooting
    gaps), ``dx_0`` fixed, ``v = (du_0, ..., du_{N-1})``; state cost
    ``sum_{k=1..N} 1/2 |dx_k + E_k|^2_{W_k}`` with ``E_k`` the node's error
    against the reference. Uses the O(N^2) recursions (Riccati-like ``S_k`` for
    the Hessian blocks, adjoints for the gradient and for the gap rows), never
    the full prediction matrix.

    Parameters
    ----------
    As, Bs, cs : list of casadi.SX
        Stage Jacobians (nx x nx, nx x nu) and gaps (nx), ``k = 0..N-1``.
    dx0 : casadi.SX
        Initial state deviation (estimate minus first shooting node).
    E : list of casadi.SX
        ``E[k]`` = node ``k`` minus reference ``k`` (``k = 0..N``; ``E[0]`` unused).
    Ws : list of casadi.DM
        State weights ``W_k`` (``k = 0..N``; ``W[0]`` unused), symmetric.
    gap_stages : tuple of int
        Stages ``k`` whose gap (state 0) is needed as a linear function of ``v``.
    gbar : list of casadi.SX
        Gap of node ``k`` (``k = 0..N``).

    Returns
    -------
    dict
        ``H`` (nu N x nu N, dense), ``q``, ``G`` (rows: gap of each stage in
        ``gap_stages`` per unit ``v``), ``gfree`` (that gap's value at ``v = 0``).
    """
    N = len(As)
    nx, nu = Bs[0].shape
    xi = [dx0]
    for k_ in range(N):
        xi.append(ca.mtimes(As[k_], xi[-1]) + cs[k_])
    # adjoint of the state cost: lam_k = W_k e_k + A_k' lam_{k+1}; q_j = B_j' lam_{j+1}
    lam = [None] * (N + 1)
    lam[N] = ca.mtimes(Ws[N], xi[N] + E[N])
    for k_ in range(N - 1, 0, -1):
        lam[k_] = ca.mtimes(Ws[k_], xi[k_] + E[k_]) + ca.mtimes(As[k_].T, lam[k_ + 1])
    q = ca.vertcat(*[ca.mtimes(Bs[j].T, lam[j + 1]) for j in range(N)])
    # S_k = W_k + A_k' S_{k+1} A_k; H_ij = B_i' S_{i+1} A_i ... A_{j+1} B_j (i >= j)
    S = [None] * (N + 1)
    S[N] = ca.SX(Ws[N])
    for k_ in range(N - 1, 0, -1):
        S[k_] = ca.SX(Ws[k_]) + ca.mtimes([As[k_].T, S[k_ + 1], As[k_]])
    blocks = [[None] * N for _ in range(N)]
    for i in range(N):
        T = ca.mtimes(Bs[i].T, S[i + 1])
        for j in range(i, -1, -1):
            blocks[i][j] = ca.mtimes(T, Bs[j])
            if j > 0:
                T = ca.mtimes(T, As[j])
    for i in range(N):
        for j in range(i + 1, N):
            blocks[i][j] = blocks[j][i].T
    H = ca.vertcat(*[ca.horzcat(*row) for row in blocks])
    # gap rows: e_1' A_{k-1} ... A_{j+1} B_j, by a backward sweep per stage
    e1 = ca.DM.zeros(1, nx)
    e1[0] = 1
    rows, gfree = [], []
    for kk in gap_stages:
        mu = ca.SX(e1)
        row = [ca.SX(1, nu) for _ in range(N)]
        for j in range(kk - 1, -1, -1):
            row[j] = ca.mtimes(mu, Bs[j])
            if j > 0:
                mu = ca.mtimes(mu, As[j])
        rows.append(ca.horzcat(*row))
        gfree.append(gbar[kk] + xi[kk][0])
    G = ca.vertcat(*rows) if rows else ca.SX(0, nu * N)
    return {"H": H, "q": q, "G": G, "gfree": ca.vertcat(*gfree) if gfree else ca.SX(0, 1), "xi": xi}


def admm_rho(H: ca.SX, lam_min: float, s: ADMMOptions) -> ca.SX:
    """ADMM penalty for the current-disk rows from the Hessian ``H`` of the condensed QP.

    ``lam_min`` is a lower bound of the smallest eigenvalue (the input weight);
    the largest is estimated from the trace, ``lambda_max <= trace(H) - (n-1)
    lambda_min``, which is tight when a few directions dominate (as in the
    condensed tracking QP, where the position error depends on the sum of all
    earlier inputs).
    """
    return rho_from_trace(ca.trace(H), H.shape[0], lam_min, s)


def rho_from_trace(trace, n: int, lam_min: float, s: ADMMOptions):
    """``rho`` of :func:`admm_rho` from ``trace(H)`` of an ``n x n`` Hessian (SX or MX)."""
    lam_max = ca.fmax(trace - (n - 1) * lam_min, lam_min)
    return ca.fmin(ca.fmax(s.rho_scale * ca.sqrt(lam_min * lam_max), 1e-3), 1e3)


def project_disk(w: ca.SX, radius: float, box: float) -> ca.SX:
    """Project a 2-vector of currents onto the disk of ``radius``, then clip to the box.

    The composition is the exact projection onto disk-and-box whenever the disk
    lies inside the box (the spec's limits: 8 A amplitude, +-8 A per axis).
    """
    n2 = w[0] ** 2 + w[1] ** 2
    scale = ca.if_else(n2 > radius**2, radius / ca.sqrt(n2 + 1e-300), 1.0)
    return ca.fmin(ca.fmax(w * scale, -box), box)


def prox_soft_bound(v: ca.SX, lb: ca.SX, ub: ca.SX, w1: float, w2: float, rho: ca.SX) -> ca.SX:
    """Proximal step of the soft bound ``w1 viol + w2/2 viol^2`` with ADMM weight ``rho``.

    ``argmin_z  w1 viol(z) + w2/2 viol(z)^2 + rho/2 (z - v)^2`` with
    ``viol(z) = max(0, z - ub, lb - z)``, in closed form (elementwise).
    """
    hi = ca.fmax(ub, (rho * v - w1 + w2 * ub) / (rho + w2))
    lo = ca.fmin(lb, (rho * v + w1 + w2 * lb) / (rho + w2))
    return ca.if_else(v > ub, hi, ca.if_else(v < lb, lo, v))


def admm_iteration(
    nv: int,
    ng: int,
    nu: int,
    radius: float,
    box: float,
    soft_w1: float,
    soft_w2: float,
    s: ADMMOptions,
    residuals: bool = True,
) -> ca.Function:
    """One ADMM iteration as an SX Function (called ``n_iter`` times in the step).

    Inputs: ``x (nv), z (nv + ng), y (nv + ng), L (nv x nv), dinv (nv), q (nv),
    G (ng x nv), ubar (nv), glb (ng), gub (ng), rho (2: penalty of the current
    rows and its inverse)``. Outputs: ``x, z, y`` after the
    iteration, and (if ``residuals``) the primal residual ``max |A x~ - z|`` and
    the dual residual ``rho max |z_new - z|`` (scaled units); without, the
    residual outputs are 0.
    ``ubar`` is the linearization point of the currents (the disk applies to
    ``ubar + v``); ``glb, gub`` are the gap bounds minus the gap's free response.
    """
    x = ca.SX.sym("x", nv)
    z = ca.SX.sym("z", nv + ng)
    y = ca.SX.sym("y", nv + ng)
    L = ca.SX.sym("L", ca.Sparsity.lower(nv))
    dinv = ca.SX.sym("dinv", nv)
    q = ca.SX.sym("q", nv)
    G = ca.SX.sym("G", ng, nv)
    ubar = ca.SX.sym("ubar", nv)
    glb = ca.SX.sym("glb", ng)
    gub = ca.SX.sym("gub", ng)
    rho = ca.SX.sym("rho", 2)
    rho_u, rho_u_inv = rho[0], rho[1]
    rho_g, rho_g_inv = s.rho_g_rel * rho_u, rho_u_inv / s.rho_g_rel
    zu, zg = z[:nv], z[nv:]
    yu, yg = y[:nv], y[nv:]
    # x~ = (P + sigma I + A' R A)^-1 (sigma x - q + A'(R z - y))
    rhs = s.sigma * x - q + (rho_u * zu - yu)
    if ng:
        rhs = rhs + ca.mtimes(G.T, rho_g * zg - yg)
    xt = chol_solve_sx(L, dinv, rhs)
    zt_u = xt
    zt_g = ca.mtimes(G, xt) if ng else ca.SX(0, 1)
    a = s.alpha
    x_new = a * xt + (1 - a) * x
    vu = a * zt_u + (1 - a) * zu
    vg = a * zt_g + (1 - a) * zg
    # proximal steps: current disk per stage (absolute currents ubar + v), soft gap bounds
    wu = vu + yu * rho_u_inv
    zu_new = []
    for k_ in range(nv // nu):
        sl = slice(k_ * nu, (k_ + 1) * nu)
        zu_new.append(project_disk(ubar[sl] + wu[sl], radius, box) - ubar[sl])
    zu_new = ca.vertcat(*zu_new)
    if ng:
        zg_new = prox_soft_bound(vg + yg * rho_g_inv, glb, gub, soft_w1, soft_w2, rho_g)
    else:
        zg_new = ca.SX(0, 1)
    yu_new = yu + rho_u * (vu - zu_new)
    yg_new = yg + rho_g * (vg - zg_new)
    z_new = ca.vertcat(zu_new, zg_new)
    y_new = ca.vertcat(yu_new, yg_new)
    if residuals:
        r_prim = ca.mmax(ca.fabs(ca.vertcat(zt_u - zu_new, zt_g - zg_new)))
        r_dual = rho_u * ca.mmax(ca.fabs(z_new - z))
    else:
        r_prim = r_dual = ca.SX(0)
    return ca.Function(
        "nmpc_admm_iter_res" if residuals else "nmpc_admm_iter",
        [x, z, y, L, dinv, q, G, ubar, glb, gub, rho],
        [x_new, z_new, y_new, r_prim, r_dual],
        ["x", "z", "y", "L", "dinv", "q", "G", "ubar", "glb", "gub", "rho"],
        ["x_out", "z_out", "y_out", "r_prim", "r_dual"],
    )
