"""Stage 4 of the step: the QP in the ``2 N`` current corrections and its ADMM with a bounded budget.

Two x-updates that give the same iterates: the stage-wise Riccati recursion
(``qp = "riccati"``, default, :mod:`.riccati`) and dense condensing with a KKT
Cholesky (``qp = "dense"``, :mod:`.qp`). Both run at most ``iterations`` ADMM
steps (OSQP's iteration) on the current disks and the soft gap bounds, with the
residuals checked every ``admm.check_every`` iterations; with ``admm.early_exit``
the remaining blocks are skipped once both residuals are below tolerance
(:func:`early_exit_chain`), and the Riccati path rebalances ``rho`` once after
``admm.adapt_at`` iterations if still not converged (:func:`rho_adaptation`).
The QP itself, as data, and its exact solution: :mod:`.exact_qp`.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .design import StepDesign, fn_terminal_weight, terminal_weight
from .layout import NU, NX
from .qp import admm_iteration, admm_rho, chol_sx, condensed_qp
from .riccati import factor_function, iteration_function


def fn_condense(d: StepDesign) -> ca.Function:
    """Dense condensing (SX): ``(As, Bs, cs, dx0, Xbar, Xref, Ubar, Uref, u_prev, fault) -> (H, q, G, glb, gub)``."""
    s = d.settings
    N, nv = s.horizon, s.horizon * NU
    As, Bs, cs = ca.SX.sym("As", NX, NX * N), ca.SX.sym("Bs", NX, NU * N), ca.SX.sym("cs", NX, N)
    dx0, Xb, Xr = ca.SX.sym("dx0", NX), ca.SX.sym("Xbar", NX, N + 1), ca.SX.sym("Xref", NX, N + 1)
    Ub, Ur, u_prev, fault = (
        ca.SX.sym("Ubar", NU, N),
        ca.SX.sym("Uref", NU, N),
        ca.SX.sym("u_prev", NU),
        ca.SX.sym("fault"),
    )
    Al = [As[:, j * NX : (j + 1) * NX] for j in range(N)]
    Bl = [Bs[:, j * NU : (j + 1) * NU] for j in range(N)]
    cl = [cs[:, j] for j in range(N)]
    # Cost: sum_k |x_k - r_k|_Q (P at N, scheduled at the terminal reference gap) + |u_k - uref_k|_R.
    Ws = [ca.DM(np.diag(s.Q))] * N + [terminal_weight(d, Xr[0, N])]
    E = [Xb[:, j] - Xr[:, j] for j in range(N + 1)]
    qp = condensed_qp(Al, Bl, cl, dx0, E, Ws, s.gap_stages, [Xb[0, j] for j in range(N + 1)])
    H, q = qp["H"], qp["q"]
    Rm = np.tile(s.R, N)
    ub = ca.vec(Ub)
    H = H + ca.diag(ca.DM(Rm))
    q = q + ca.DM(Rm) * (ub - ca.vec(Ur))
    H = H + ca.if_else(fault > 0.5, math.nan, 0) * ca.DM(np.eye(nv))  # forced failure (tests)
    # Soft gap rows in millimetres.
    G = 1e3 * qp["G"]
    glb = 1e3 * (s.soft_gap.g_min - qp["gfree"])
    gub = 1e3 * (s.soft_gap.g_max - qp["gfree"])
    return ca.Function(
        "nmpc_condense",
        [As, Bs, cs, dx0, Xb, Xr, Ub, Ur, u_prev, fault],
        [ca.densify(H), q, G, glb, gub],
        ["As", "Bs", "cs", "dx0", "Xbar", "Xref", "Ubar", "Uref", "u_prev", "fault"],
        ["H", "q", "G", "glb", "gub"],
        {"cse": True},
    )


def fn_kkt(d: StepDesign) -> ca.Function:
    """ADMM penalty and Cholesky factor of the KKT matrix (SX): ``(H, G) -> (L, dinv, rho)``."""
    s = d.settings
    nv, ng = s.horizon * NU, s.n_gap
    H, G = ca.SX.sym("H", nv, nv), ca.SX.sym("G", ng, nv)
    a = s.admm
    rho = admm_rho(H, min(s.R), a)
    Mk = H + (a.sigma + rho) * ca.DM.eye(nv)
    if ng:
        Mk = Mk + a.rho_g_rel * rho * ca.mtimes(G.T, G)
    Lc, dinv = chol_sx(ca.densify(Mk))
    return ca.Function("nmpc_kkt", [H, G], [Lc, dinv, ca.vertcat(rho, 1 / rho)], ["H", "G"], ["L", "dinv", "rho"])


def checkpoints(d: StepDesign) -> list[int]:
    """Iterations after which the residuals are computed (every ``check_every``, and the last)."""
    s = d.settings
    every = s.admm.check_every
    return sorted({*range(every, s.iterations, every), s.iterations})


def _track(d: StepDesign, i, rp_i, rd_i, state) -> None:
    """Residual bookkeeping at checkpoints: iterations to reach the tolerance = first checkpoint below it
    (assuming monotone progress), else the budget."""
    a, checks = d.settings.admm, checkpoints(d)
    if i in checks:
        nxt = checks[checks.index(i) + 1] if i != checks[-1] else i
        state["rp"], state["rd"] = rp_i, rd_i
        state["iters"] = state["iters"] + (nxt - i) * ca.logic_or(rp_i > a.tol_prim, rd_i > a.tol_dual)


def _blocks(d: StepDesign) -> list[int]:
    """Iterations per block between consecutive residual checkpoints."""
    checks = checkpoints(d)
    return [b - a for a, b in zip([0, *checks[:-1]], checks, strict=True)]


def early_exit_chain(d: StepDesign, iteration: ca.Function, xzy0: list, params: list, adapt=None) -> tuple[list, dict]:
    """ADMM with early termination: blocks of iterations, each skipped once the residuals are below tolerance.

    ``iteration(x, z, y, *params) -> (x, z, y, r_prim, r_dual)``. The iterations
    between two residual checkpoints (:func:`checkpoints`) form one block
    Function; every block is a :meth:`casadi.Function.conditional` (a switch that
    evaluates only the chosen case, also in the generated C) between the block
    and the identity, chosen by the previous checkpoint's residuals. The number of
    blocks is fixed (``iterations`` at most, so the worst case is bounded:
    ``iterations`` x the cost of one iteration); once converged, the remaining
    blocks cost a branch each. ``adapt(done, rp, rd, params) -> params``, if
    given, is applied once, after the block that ends at iteration
    ``admm.adapt_at`` (a new ``rho`` and its factorization).

    Returns
    -------
    xzy : list of casadi.MX
        ``x, z, y`` after the last block that ran.
    track : dict
        ``rp``, ``rd`` (residuals of the last checkpoint that ran) and ``iters``
        (iterations run).
    """
    a = d.settings.admm
    sym = [ca.MX.sym(f"p{i}", e.sparsity()) for i, e in enumerate(params)]
    xs = [ca.MX.sym(n, e.sparsity()) for n, e in zip("xzy", xzy0, strict=True)]
    rp, rd, it = ca.MX.sym("rp"), ca.MX.sym("rd"), ca.MX.sym("it")
    ident = ca.Function("nmpc_admm_skip", [*xs, rp, rd, it, *sym], [*xs, rp, rd, it])
    switches = {}
    for n in sorted(set(_blocks(d))):
        cur = list(xs)
        r = None
        for _ in range(n):
            r = iteration(*cur, *sym)
            cur = list(r[:3])
        blk = ca.Function(f"nmpc_admm_block{n}", [*xs, rp, rd, it, *sym], [*cur, r[3], r[4], it + n])
        switches[n] = ca.Function.conditional(f"nmpc_admm_cond{n}", [blk], ident)
    cur = list(xzy0)
    r_p, r_d, n_it = ca.MX(ca.inf), ca.MX(ca.inf), ca.MX(0)
    done_at = 0
    for n in _blocks(d):
        done = ca.logic_and(r_p <= a.tol_prim, r_d <= a.tol_dual)
        out = switches[n](done, *cur, r_p, r_d, n_it, *params)
        cur, r_p, r_d, n_it = list(out[:3]), out[3], out[4], out[5]
        done_at += n
        if adapt is not None and done_at == a.adapt_at:
            params = adapt(ca.logic_and(r_p <= a.tol_prim, r_d <= a.tol_dual), r_p, r_d, params)
    return cur, {"rp": r_p, "rd": r_d, "iters": n_it}


def admm_dense(d: StepDesign, o: dict):
    """Fixed-budget ADMM on the dense condensed QP (reference implementation)."""
    s = d.settings
    nv, ng = s.horizon * NU, s.n_gap
    args = (nv, ng, NU, s.current_limit, s.i_box, s.soft_gap.w_linear, s.soft_gap.w_quadratic, s.admm)
    it_res = admm_iteration(*args, residuals=True)
    it_fast = admm_iteration(*args, residuals=False)
    checks = checkpoints(d)
    # warm start: zero correction (the linearization point is the shifted plan), shifted duals
    x, z, yv = ca.MX.zeros(nv), ca.MX.zeros(nv + ng), o["y0"]
    if s.admm.early_exit:
        params = [o["L"], o["dinv"], o["q"], o["G"], o["ubar"], o["glb"], o["gub"], o["rho"]]
        (x, z, yv), track = early_exit_chain(d, it_res, [x, z, yv], params)
        return z, yv, track
    track = {"rp": ca.MX(0), "rd": ca.MX(0), "iters": ca.MX(checks[0])}
    for i in range(1, s.iterations + 1):
        it = it_res if i in checks else it_fast
        x, z, yv, rp_i, rd_i = it(x, z, yv, o["L"], o["dinv"], o["q"], o["G"], o["ubar"], o["glb"], o["gub"], o["rho"])
        _track(d, i, rp_i, rd_i, track)
    return z, yv, track


def rho_adaptation(d: StepDesign, fac: ca.Function, fac_in: list):
    """The ``adapt`` hook of :func:`early_exit_chain` for the Riccati ADMM: one residual-balancing rho update.

    Not converged after ``admm.adapt_at`` iterations, ``rho`` is scaled by
    ``sqrt(r_prim / |z_k - z_{k-1}|)`` (= ``sqrt(rho r_prim / r_dual)``: the
    primal against the dual residual, both in amperes; Boyd et al.'s residual
    balancing, OSQP's rule without its data scaling), clipped to ``[0.1, 10]``, if
    that ratio is outside ``[1/ratio, ratio]`` (``admm.adapt_ratio``); then the
    Riccati factorization is recomputed (a :meth:`casadi.Function.conditional`:
    the refactorization runs only then). The duals ``y`` are unscaled, so the
    iterate carries over.
    """
    a = d.settings.admm
    sym_in = [ca.MX.sym(f"f{i}", e.sparsity()) for i, e in enumerate(fac_in)]
    mult, rho = ca.MX.sym("mult"), ca.MX.sym("rho", 2)
    K, Sinv, PB, Pc, rho_new = fac(*sym_in, mult)[:5]
    Ks, Ss, Ps, Cs = (
        ca.MX.sym(n, e.sparsity()) for n, e in zip(("K", "Sinv", "PB", "Pc"), (K, Sinv, PB, Pc), strict=True)
    )
    keep = ca.Function("nmpc_admm_keep", [*sym_in, mult, rho, Ks, Ss, Ps, Cs], [Ks, Ss, Ps, Cs, rho])
    refac_full = ca.Function("nmpc_admm_refactor", [*sym_in, mult, rho, Ks, Ss, Ps, Cs], [K, Sinv, PB, Pc, rho_new])
    switch = ca.Function.conditional("nmpc_admm_adapt", [keep], refac_full)

    def adapt(done, rp, rd, params):
        K0, S0, P0, C0, rho0 = params[0], params[1], params[2], params[3], params[13]
        ratio = ca.sqrt(rp * rho0[0] / ca.fmax(rd, 1e-12))
        go = ca.logic_and(ca.logic_not(done), ca.logic_or(ratio > a.adapt_ratio, ratio < 1 / a.adapt_ratio))
        mult = ca.fmin(ca.fmax(ratio, 0.1), 10.0)  # the first rho had multiplier 1 (adapted once)
        K, S, P, C, r = switch(go, *fac_in, mult, rho0, K0, S0, P0, C0)
        out = list(params)
        out[0], out[1], out[2], out[3], out[13] = K, S, P, C, r
        return out

    return adapt


def admm_riccati(d: StepDesign, o: dict, fault):
    """Fixed-budget ADMM with the Riccati x-update (:mod:`maglev_ocp.controllers.nmpc.riccati`)."""
    s = d.settings
    N, nv, sg = s.horizon, s.horizon * NU, s.soft_gap
    fac = factor_function(N, s.gap_stages, np.diag(s.Q), s.R, s.admm, sg.g_min, sg.g_max)
    it = iteration_function(N, s.gap_stages, s.current_limit, s.i_box, sg.w_linear, sg.w_quadratic, s.admm)
    P_N = fn_terminal_weight(d)(o["Xref"][0, N])
    fac_in = [o["As"], o["Bs"], o["cs"], o["dx0"], o["Xbar"], o["Xref"], o["Ubar"], o["Uref"], fault, P_N]
    K, Sinv, PB, Pc, rho, qW, rbase, glb, gub, zg0 = fac(*fac_in, 1.0)
    # warm start: zero correction (the linearization point is the shifted plan), gap rows at the free
    # response, shifted duals
    x, z, yv = ca.MX.zeros(nv), ca.vertcat(ca.MX.zeros(nv), zg0), o["y0"]
    if s.admm.early_exit:
        params = [K, Sinv, PB, Pc, o["As"], o["Bs"], o["cs"], o["dx0"], qW, rbase, o["ubar"], glb, gub, rho]
        adapt = rho_adaptation(d, fac, fac_in) if s.admm.adapt_at > 0 else None
        (x, z, yv), track = early_exit_chain(d, it, [x, z, yv], params, adapt)
        return z, yv, track
    track = {"rp": ca.MX(0), "rd": ca.MX(0), "iters": ca.MX(checkpoints(d)[0])}
    for i in range(1, s.iterations + 1):
        x, z, yv, rp_i, rd_i = it(
            x, z, yv, K, Sinv, PB, Pc, o["As"], o["Bs"], o["cs"], o["dx0"], qW, rbase, o["ubar"], glb, gub, rho
        )
        _track(d, i, rp_i, rd_i, track)
    return z, yv, track


__all__ = ["admm_dense", "admm_riccati", "checkpoints", "early_exit_chain", "fn_condense", "fn_kkt"]
