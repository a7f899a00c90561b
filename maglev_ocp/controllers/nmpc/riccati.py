"""Structure-exploiting ADMM for the NMPC's QP: the x-update by a Riccati recursion, O(N) per iteration.

The same QP and the same ADMM iteration as :mod:`maglev_ocp.controllers.nmpc.qp` (OSQP's
iteration with the current disks and the soft gap bounds as the ``z`` block,
the same penalty ``rho`` from the trace of the condensed Hessian), but the
equality-constrained x-update::

    min  sum_k 1/2 |dx_k + E_k|^2_{W_k} + 1/2 |du_k + e_k|^2_R + sigma/2 |du - x|^2
         + rho/2 |du - z_u + y_u/rho|^2 + rho_g/2 |1e3 dx_gap - z_g + y_g/rho_g|^2
    s.t. dx_{k+1} = A_k dx_k + B_k du_k + c_k

is solved stage-wise instead of through the dense condensed matrix: the
Riccati factorization (``P_k``, feedback ``K_k``) depends only on the
linearization and ``rho``, so it is computed once per control step
(``O(N nx^3)``), and every ADMM iteration is one backward sweep of the linear
terms and one forward rollout (``O(N nx^2)``). In exact arithmetic the iterates
equal the dense ones (tested). The factorization and the iteration (called
``n_iter`` times) are MX chains that call one small SX Function per stage
(open-loop and Riccati steps, backward sweep, rollout), so the generated C
holds each stage's code once (a few kB that stay in the instruction cache)
instead of ``N`` unrolled copies.

The gap rows use ``z_g = 1e3 dx_k[0]`` (millimetres relative to the shooting
node) instead of the dense form's ``G v`` (relative to the free response), a
constant shift: the warm start ``z_g = 1e3 xi_k[0]`` (free response) makes the
two sequences identical.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from .layout import NU, NX
from .qp import project_disk, prox_soft_bound, rho_from_trace


def _sx(n, m=1, name="a"):
    return ca.SX.sym(name, n, m)


def _mx(n, m=1, name="a"):
    return ca.MX.sym(name, n, m)


def open_loop_stage() -> ca.Function:
    """``(S_next, tr_next, A, B, W) -> (S, tr)``: ``S = W + A' S_next A``, ``tr = tr_next + trace(B' S_next B)``.

    The accumulated ``tr`` gives the trace of the condensed Hessian (for ``rho``).
    """
    Sn, trn, A, B, W = _sx(NX, NX, "S_next"), _sx(1, 1, "tr_next"), _sx(NX, NX, "A"), _sx(NX, NU, "B"), _sx(NX, NX, "W")
    S = W + ca.mtimes([A.T, Sn, A])
    tr = trn + ca.trace(ca.mtimes([B.T, Sn, B]))
    return ca.Function(
        "nmpc_ol_stage", [Sn, trn, A, B, W], [S, tr], ["S_next", "tr_next", "A", "B", "W"], ["S", "tr"], {"cse": True}
    )


def riccati_stage() -> ca.Function:
    """One backward step of the Riccati factorization of the ADMM x-update.

    ``(P_next, A, B, c, Wq, Rt) -> (P, K, Sinv, PB, Pc)`` with ``S = diag(Rt) +
    B' P_next B``, ``K = -S^-1 B' P_next A``, ``P = Wq + A' P_next (A + B K)``;
    ``Wq`` is the state weight of this node including the gap-row penalty.
    """
    Pn, A, B, c, Wq, Rt = (
        _sx(NX, NX, "P_next"),
        _sx(NX, NX, "A"),
        _sx(NX, NU, "B"),
        _sx(NX, 1, "c"),
        _sx(NX, NX, "Wq"),
        _sx(NU, 1, "Rt"),
    )
    PB = ca.mtimes(Pn, B)
    PA = ca.mtimes(Pn, A)
    S = ca.diag(Rt) + ca.mtimes(B.T, PB)
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    Sinv = ca.vertcat(ca.horzcat(S[1, 1], -S[0, 1]), ca.horzcat(-S[1, 0], S[0, 0])) / det
    K = -ca.mtimes(Sinv, ca.mtimes(B.T, PA))
    P = Wq + ca.mtimes(A.T, PA) + ca.mtimes(ca.mtimes(A.T, PB), K)
    P = (P + P.T) / 2
    return ca.Function(
        "nmpc_ric_stage",
        [Pn, A, B, c, Wq, Rt],
        [P, K, Sinv, PB, ca.mtimes(Pn, c)],
        ["P_next", "A", "B", "c", "Wq", "Rt"],
        ["P", "K", "Sinv", "PB", "Pc"],
        {"cse": True},
    )


def backward_stage() -> ca.Function:
    """Linear terms, backward: ``(p_next, Sinv, PB, Pc, A, B, r, q) -> (p, kff)``.

    ``s = p_next + P_next c``, ``kff = -S^-1 (r + B' s)``, ``p = q + A' (s + P_next B kff)``.
    """
    pn, Sinv, PB, Pc, A, B, r, q = (
        _sx(NX, 1, "p_next"),
        _sx(NU, NU, "Sinv"),
        _sx(NX, NU, "PB"),
        _sx(NX, 1, "Pc"),
        _sx(NX, NX, "A"),
        _sx(NX, NU, "B"),
        _sx(NU, 1, "r"),
        _sx(NX, 1, "q"),
    )
    s = pn + Pc
    kff = -ca.mtimes(Sinv, r + ca.mtimes(B.T, s))
    p = q + ca.mtimes(A.T, s + ca.mtimes(PB, kff))
    return ca.Function(
        "nmpc_bwd_stage",
        [pn, Sinv, PB, Pc, A, B, r, q],
        [p, kff],
        ["p_next", "Sinv", "PB", "Pc", "A", "B", "r", "q"],
        ["p", "kff"],
    )


def forward_stage() -> ca.Function:
    """Rollout: ``(dx, K, kff, A, B, c) -> (dx_next, dx_next, du)`` with ``du = K dx + kff``.

    ``dx_next`` twice: as the carried state and as the stage's output of a :func:`stage_chain`.
    """
    dx, K, kff, A, B, c = (
        _sx(NX, 1, "dx"),
        _sx(NU, NX, "K"),
        _sx(NU, 1, "kff"),
        _sx(NX, NX, "A"),
        _sx(NX, NU, "B"),
        _sx(NX, 1, "c"),
    )
    du = ca.mtimes(K, dx) + kff
    dxn = ca.mtimes(A, dx) + ca.mtimes(B, du) + c
    return ca.Function(
        "nmpc_fwd_stage",
        [dx, K, kff, A, B, c],
        [dxn, dxn, du],
        ["dx", "K", "kff", "A", "B", "c"],
        ["dx_next", "dx_out", "du"],
    )


STAGES_PER_CALL = 4  #: stages unrolled in one call of a blocked stage Function (code size vs call count)


def _blocked(stage: ca.Function, n_stages: int, n_carry: int, n_shared: int, reverse: bool) -> ca.Function:
    """``stage`` applied ``n_stages`` times in one SX Function (stages inlined).

    ``stage`` takes ``(carry..., per-stage inputs..., shared inputs...)`` and
    returns ``(carry..., per-stage outputs...)``; the blocked Function takes the
    per-stage inputs and returns the per-stage outputs horizontally stacked in
    stage order, and runs the stages backwards if ``reverse``.
    """
    n_in, n_out = stage.n_in(), stage.n_out()
    n_ps = n_in - n_carry - n_shared
    carry = [ca.SX.sym(stage.name_in(i), stage.sparsity_in(i)) for i in range(n_carry)]
    ps = [
        ca.SX.sym(stage.name_in(i), stage.size1_in(i), stage.size2_in(i) * n_stages)
        for i in range(n_carry, n_carry + n_ps)
    ]
    widths = [stage.size2_in(i) for i in range(n_carry, n_carry + n_ps)]
    sh = [ca.SX.sym(stage.name_in(i), stage.sparsity_in(i)) for i in range(n_carry + n_ps, n_in)]
    outs = [[None] * n_stages for _ in range(n_out - n_carry)]
    cur = carry
    for k in range(n_stages - 1, -1, -1) if reverse else range(n_stages):
        res = stage.call([*cur, *[M[:, k * w : (k + 1) * w] for M, w in zip(ps, widths, strict=True)], *sh])
        cur = res[:n_carry]
        for i, o in enumerate(res[n_carry:]):
            outs[i][k] = o
    return ca.Function(
        f"{stage.name()}_x{n_stages}",
        carry + ps + sh,
        cur + [ca.horzcat(*o) for o in outs],
        [stage.name_in(i) for i in range(n_in)],
        [stage.name_out(i) for i in range(n_out)],
    )


def stage_chain(
    stage: ca.Function,
    N: int,
    carry: list,
    per_stage: list,
    shared: list = (),
    reverse: bool = False,
    block: int | None = None,
) -> tuple[list, list]:
    """A recursion over the ``N`` stages of the horizon as a chain of calls (MX).

    ``stage`` as in :func:`_blocked`; ``per_stage`` are MX matrices with the
    stages' inputs side by side (stage ``j`` in columns ``j w .. (j+1) w``).
    Calls a Function of ``block`` (default :data:`STAGES_PER_CALL`) inlined stages ``N / block`` times (plus one
    for the remainder): the generated C holds the stage code once or twice
    instead of ``N`` times, and the CasADi evaluation makes few calls.

    Returns
    -------
    carry : list of casadi.MX
        The carried values after the last stage (stage 0 if ``reverse``).
    outputs : list of casadi.MX
        The per-stage outputs side by side, in stage order.
    """
    block = block or STAGES_PER_CALL
    n_carry = len(carry)
    widths = [stage.size2_in(n_carry + i) for i in range(len(per_stage))]
    starts = list(range(0, N, block))
    got, fns = {}, {}
    for st in reversed(starts) if reverse else starts:
        n = min(block, N - st)
        if n not in fns:
            fns[n] = _blocked(stage, n, n_carry, len(shared), reverse)
        f = fns[n]
        res = f.call([*carry, *[M[:, st * w : (st + n) * w] for M, w in zip(per_stage, widths, strict=True)], *shared])
        carry, got[st] = res[:n_carry], res[n_carry:]
    outs = [ca.horzcat(*[got[st][i] for st in starts]) for i in range(stage.n_out() - n_carry)]
    return list(carry), outs


def factor_function(
    N: int,
    gap_stages: tuple[int, ...],
    Q: np.ndarray,
    R: tuple[float, float],
    admm,
    gap_lo: float,
    gap_hi: float,
) -> ca.Function:
    """Per-step preparation of the Riccati ADMM (MX of stage chains and SX Functions).

    ``(As, Bs, cs, dx0, Xbar, Xref, Ubar, Uref, fault, P, rho_mult) -> (K, Sinv, PB, Pc, rho, qW,
    rbase, glb, gub, zg0)``, ``P`` the terminal weight (an input: scheduled with the
    operating point, :func:`maglev_ocp.controllers.nmpc.design.terminal_weight`): penalty ``rho``
    from the trace of the condensed Hessian (open-loop cost-to-go recursion, the rule of
    :func:`maglev_ocp.controllers.nmpc.qp.admm_rho`) times ``rho_mult`` (the adaptation of
    :func:`maglev_ocp.controllers.nmpc.admm.admm_riccati`, 1 at first), the Riccati factorization
    for ``R + sigma + rho``, the constant linear terms, the soft gap bounds and the free
    response of the gap rows (warm start of ``z_g``).

    The recursions over the horizon are :func:`stage_chain` s of
    :func:`open_loop_stage`, :func:`riccati_stage` and :func:`free_stage`, so the
    generated C holds each stage's code once instead of ``N`` unrolled copies
    (instruction cache); the constant weights are passed as dense constants.
    ``Bs`` must be dense.
    """
    As, Bs, cs = ca.MX.sym("As", NX, NX * N), ca.MX.sym("Bs", NX, NU * N), ca.MX.sym("cs", NX, N)
    dx0, Xb, Xr = ca.MX.sym("dx0", NX), ca.MX.sym("Xbar", NX, N + 1), ca.MX.sym("Xref", NX, N + 1)
    Ub, Ur, fault = ca.MX.sym("Ubar", NU, N), ca.MX.sym("Uref", NU, N), ca.MX.sym("fault")
    Pt, mult = ca.MX.sym("P", NX, NX), ca.MX.sym("rho_mult")
    Wc = ca.DM(Q)
    # trace of the condensed Hessian: N tr(R) + sum_j tr(B_j' S_{j+1} B_j), S_k = W_k + A_k' S_{k+1} A_k
    (_, tr), _ = stage_chain(open_loop_stage(), N, [Pt, ca.MX(N * float(sum(R)))], [As, Bs], [ca.MX(Wc)], reverse=True)
    # penalty, input weight of the x-update (NaN on a forced failure, for tests), gap-row weight
    trs, fs, ms = _sx(1, 1, "trace"), _sx(1, 1, "fault"), _sx(1, 1, "rho_mult")
    rho = ca.fmin(ca.fmax(rho_from_trace(trs, NU * N, min(R), admm) * ms, 1e-3), 1e3)
    Rt = ca.DM(R) + admm.sigma + rho + ca.if_else(fs > 0.5, np.nan, 0)
    gam = admm.rho_g_rel * rho * 1e6  # gap rows are 1e3 dx[0]: weight rho_g (1e3)^2 on dx[0]^2
    pen = ca.Function(
        "nmpc_ric_penalty",
        [trs, fs, ms],
        [Rt, gam, ca.vertcat(rho, 1 / rho)],
        ["trace", "fault", "rho_mult"],
        ["Rt", "gam", "rho"],
    )
    Rt, gam, rho2 = pen(tr, fault, mult)
    e11 = ca.DM.zeros(NX, NX)
    e11[0, 0] = 1
    gset = set(gap_stages)
    Wq = ca.horzcat(*[Wc + gam * e11 if j in gset else ca.MX(Wc) for j in range(N)])
    PN = Pt + gam * e11 if N in gset else Pt
    _, (K, Sinv, PB, Pc) = stage_chain(riccati_stage(), N, [PN], [As, Bs, cs, Wq], [Rt], reverse=True)
    # free response xi_{j+1} = A_j xi_j + c_j (its gap: warm start of z_g)
    _, (g_free,) = stage_chain(free_stage(), N, [dx0], [As, cs])
    qW, rbase, glb, gub, zg0 = linear_terms_function(N, gap_stages, Q, R, gap_lo, gap_hi)(Xb, Xr, Ub, Ur, g_free, Pt)
    outs = [K, Sinv, PB, Pc, rho2, qW, rbase, glb, gub, zg0]
    return ca.Function(
        "nmpc_ric_factor",
        [As, Bs, cs, dx0, Xb, Xr, Ub, Ur, fault, Pt, mult],
        outs,
        ["As", "Bs", "cs", "dx0", "Xbar", "Xref", "Ubar", "Uref", "fault", "P", "rho_mult"],
        ["K", "Sinv", "PB", "Pc", "rho", "qW", "rbase", "glb", "gub", "zg0"],
    )


def free_stage() -> ca.Function:
    """Free response of one stage (SX): ``(xi, A, c) -> (xi_next, g)``, ``xi_next = A xi + c``, ``g = xi_next[0]``."""
    xi, A, c = _sx(NX, 1, "xi"), _sx(NX, NX, "A"), _sx(NX, 1, "c")
    xn = ca.mtimes(A, xi) + c
    return ca.Function("nmpc_free_stage", [xi, A, c], [xn, xn[0]], ["xi", "A", "c"], ["xi_next", "g"])


def linear_terms_function(
    N: int,
    gap_stages: tuple[int, ...],
    Q: np.ndarray,
    R: tuple[float, float],
    gap_lo: float,
    gap_hi: float,
) -> ca.Function:
    """Constant linear terms of the x-update, soft gap bounds and free gap rows (SX).

    ``(Xbar, Xref, Ubar, Uref, g_free, P) -> (qW, rbase, glb, gub, zg0)``; ``g_free``
    (1 x N) is the free response's gap deviation at nodes ``1..N``, ``P`` the terminal weight.
    """
    ng = len(gap_stages)
    Xb, Xr = _sx(NX, N + 1, "Xbar"), _sx(NX, N + 1, "Xref")
    Ub, Ur, gf, P = _sx(NU, N, "Ubar"), _sx(NU, N, "Uref"), _sx(1, N, "g_free"), _sx(NX, NX, "P")
    W = [ca.DM(Q)] * N + [P]
    qW = ca.horzcat(*[ca.mtimes(W[j], Xb[:, j] - Xr[:, j]) for j in range(N + 1)])
    rbase = ca.DM(R) * (Ub - Ur)
    glb = ca.vertcat(*[1e3 * (gap_lo - Xb[0, j]) for j in gap_stages]) if ng else ca.SX(0, 1)
    gub = ca.vertcat(*[1e3 * (gap_hi - Xb[0, j]) for j in gap_stages]) if ng else ca.SX(0, 1)
    zg0 = ca.vertcat(*[1e3 * gf[j - 1] for j in gap_stages]) if ng else ca.SX(0, 1)
    return ca.Function(
        "nmpc_ric_linear",
        [Xb, Xr, Ub, Ur, gf, P],
        [qW, rbase, glb, gub, zg0],
        ["Xbar", "Xref", "Ubar", "Uref", "g_free", "P"],
        ["qW", "rbase", "glb", "gub", "zg0"],
        {"cse": True},
    )


def iteration_function(
    N: int, gap_stages: tuple[int, ...], radius: float, box: float, soft_w1: float, soft_w2: float, admm
) -> ca.Function:
    """One ADMM iteration with the Riccati x-update (MX of stage chains and SX Functions).

    ``(x, z, y, K, Sinv, PB, Pc, As, Bs, cs, dx0, qW, rbase, ubar, glb, gub, rho) -> (x, z, y, r_prim, r_dual)``.
    The backward sweep and the rollout are :func:`stage_chain` s of
    :func:`backward_stage` and :func:`forward_stage`, so the generated C holds
    each stage's code once. ``Bs`` must be dense.
    """
    ng = len(gap_stages)
    nv = NU * N
    x, z, y = _mx(nv, 1, "x"), _mx(nv + ng, 1, "z"), _mx(nv + ng, 1, "y")
    K, Sinv, PB, Pc = _mx(NU, NX * N, "K"), _mx(NU, NU * N, "Sinv"), _mx(NX, NU * N, "PB"), _mx(NX, N, "Pc")
    As, Bs, cs, dx0 = _mx(NX, NX * N, "As"), _mx(NX, NU * N, "Bs"), _mx(NX, N, "cs"), _mx(NX, 1, "dx0")
    qW, rbase, ubar = _mx(NX, N + 1, "qW"), _mx(NU, N, "rbase"), _mx(nv, 1, "ubar")
    glb, gub, rho = _mx(ng, 1, "glb"), _mx(ng, 1, "gub"), _mx(2, 1, "rho")
    r, q, q_last = admm_terms(N, gap_stages, admm.sigma, admm.rho_g_rel)(x, z, y, rbase, qW, rho)
    _, (kff,) = stage_chain(backward_stage(), N, [q_last], [Sinv, PB, Pc, As, Bs, r, q], reverse=True)
    _, (dxs, dus) = stage_chain(forward_stage(), N, [dx0], [K, kff, As, Bs, cs])
    upd = admm_update(N, gap_stages, radius, box, soft_w1, soft_w2, admm.alpha, admm.rho_g_rel)
    outs = upd(ca.vec(dus), dxs, x, z, y, ubar, glb, gub, rho)
    return ca.Function(
        "nmpc_ric_iter",
        [x, z, y, K, Sinv, PB, Pc, As, Bs, cs, dx0, qW, rbase, ubar, glb, gub, rho],
        list(outs),
        ["x", "z", "y", "K", "Sinv", "PB", "Pc", "As", "Bs", "cs", "dx0", "qW", "rbase", "ubar", "glb", "gub", "rho"],
        ["x_out", "z_out", "y_out", "r_prim", "r_dual"],
    )


def admm_terms(N: int, gap_stages: tuple[int, ...], sigma: float, rho_g_rel: float) -> ca.Function:
    """Linear terms of the x-update from the ADMM state (SX).

    ``(x, z, y, rbase, qW, rho) -> (r, q, q_last)``: input terms
    ``r_k = rbase_k - sigma x_k + y_u,k - rho z_u,k`` and node terms
    ``q_k = qW_k + 1e3 (y_g - rho_g z_g) e_1`` at gap nodes, stages side by side
    (``q`` for nodes ``0..N-1``, ``q_last`` for node ``N``).
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
    return ca.Function(
        "nmpc_admm_terms",
        [x, z, y, rbase, qW, rho],
        [r, ca.horzcat(*qcols[:N]), qcols[N]],
        ["x", "z", "y", "rbase", "qW", "rho"],
        ["r", "q", "q_last"],
    )


def admm_update(
    N: int,
    gap_stages: tuple[int, ...],
    radius: float,
    box: float,
    soft_w1: float,
    soft_w2: float,
    alpha: float,
    rho_g_rel: float,
) -> ca.Function:
    """Relaxation, proximal steps and dual update of one ADMM iteration (MX of two SX Functions).

    ``(xt, dx, x, z, y, ubar, glb, gub, rho) -> (x, z, y, r_prim, r_dual)`` where
    ``xt`` are the input corrections of the x-update and ``dx`` (NX x N) its
    states ``dx_1 .. dx_N``; ``z_g = 1e3 dx_k[0]`` at the gap stages.
    ``r_dual`` is ``rho max |z_new - z|`` (scaled units). The current rows are
    a :func:`stage_chain` of :func:`disk_update_stage`, the gap rows and the
    residuals one more SX Function.
    """
    ng = len(gap_stages)
    nv = NU * N
    xt, dx, x, z, y = _mx(nv, 1, "xt"), _mx(NX, N, "dx"), _mx(nv, 1, "x"), _mx(nv + ng, 1, "z"), _mx(nv + ng, 1, "y")
    ubar, glb, gub, rho = _mx(nv, 1, "ubar"), _mx(ng, 1, "glb"), _mx(ng, 1, "gub"), _mx(2, 1, "rho")
    rs = lambda v: ca.reshape(v, NU, N)  # noqa: E731
    _, (x_new, zu_new, yu_new, rp, rd) = stage_chain(
        disk_update_stage(radius, box, alpha), N, [], [rs(xt), rs(x), rs(z[:nv]), rs(y[:nv]), rs(ubar)], [rho]
    )
    zg_new, yg_new, r_prim, r_dual = gap_update(N, gap_stages, soft_w1, soft_w2, alpha, rho_g_rel)(
        dx, z[nv:], y[nv:], glb, gub, rho, rp, rd
    )
    return ca.Function(
        "nmpc_admm_update",
        [xt, dx, x, z, y, ubar, glb, gub, rho],
        [ca.vec(x_new), ca.vertcat(ca.vec(zu_new), zg_new), ca.vertcat(ca.vec(yu_new), yg_new), r_prim, r_dual],
        ["xt", "dx", "x", "z", "y", "ubar", "glb", "gub", "rho"],
        ["x_out", "z_out", "y_out", "r_prim", "r_dual"],
    )


def disk_update_stage(radius: float, box: float, alpha: float) -> ca.Function:
    """ADMM update of one stage's current rows (SX): relaxation, projection on the disk, dual step.

    ``(xt, x, zu, yu, ubar, rho) -> (x, zu, yu, rp, rd)`` with the stage's
    contributions ``rp = max |xt - zu_new|`` and ``rd = max |zu_new - zu|`` to the residuals.
    """
    xt, x, zu, yu, ubar, rho = (
        _sx(NU, 1, "xt"),
        _sx(NU, 1, "x"),
        _sx(NU, 1, "zu"),
        _sx(NU, 1, "yu"),
        _sx(NU, 1, "ubar"),
        _sx(2, 1, "rho"),
    )
    rho_u, rho_u_inv = rho[0], rho[1]
    a = alpha
    x_new = a * xt + (1 - a) * x
    vu = a * xt + (1 - a) * zu
    zu_new = project_disk(ubar + (vu + yu * rho_u_inv), radius, box) - ubar
    yu_new = yu + rho_u * (vu - zu_new)
    return ca.Function(
        "nmpc_disk_update",
        [xt, x, zu, yu, ubar, rho],
        [x_new, zu_new, yu_new, ca.mmax(ca.fabs(xt - zu_new)), ca.mmax(ca.fabs(zu_new - zu))],
        ["xt", "x", "zu", "yu", "ubar", "rho"],
        ["x_out", "zu_out", "yu_out", "rp", "rd"],
    )


def gap_update(
    N: int, gap_stages: tuple[int, ...], soft_w1: float, soft_w2: float, alpha: float, rho_g_rel: float
) -> ca.Function:
    """ADMM update of the soft gap rows and the residuals (SX).

    ``(dx, zg, yg, glb, gub, rho, rp, rd) -> (zg, yg, r_prim, r_dual)``; ``rp``, ``rd``
    (1 x N) are the current rows' per-stage residual contributions.
    """
    ng = len(gap_stages)
    dx, zg, yg, glb, gub, rho = (
        _sx(NX, N, "dx"),
        _sx(ng, 1, "zg"),
        _sx(ng, 1, "yg"),
        _sx(ng, 1, "glb"),
        _sx(ng, 1, "gub"),
        _sx(2, 1, "rho"),
    )
    rp, rd = _sx(1, N, "rp"), _sx(1, N, "rd")
    rho_u, rho_u_inv = rho[0], rho[1]
    rho_g, rho_g_inv = rho_g_rel * rho_u, rho_u_inv / rho_g_rel
    a = alpha
    if ng:
        zt_g = ca.vertcat(*[1e3 * dx[0, j - 1] for j in gap_stages])
        vg = a * zt_g + (1 - a) * zg
        zg_new = prox_soft_bound(vg + yg * rho_g_inv, glb, gub, soft_w1, soft_w2, rho_g)
        yg_new = yg + rho_g * (vg - zg_new)
        r_prim = ca.mmax(ca.vertcat(rp.T, ca.fabs(zt_g - zg_new)))
        r_dual = rho_u * ca.mmax(ca.vertcat(rd.T, ca.fabs(zg_new - zg)))
    else:
        zg_new, yg_new = ca.SX(0, 1), ca.SX(0, 1)
        r_prim, r_dual = ca.mmax(rp), rho_u * ca.mmax(rd)
    return ca.Function(
        "nmpc_gap_update",
        [dx, zg, yg, glb, gub, rho, rp, rd],
        [zg_new, yg_new, r_prim, r_dual],
        ["dx", "zg", "yg", "glb", "gub", "rho", "rp", "rd"],
        ["zg_out", "yg_out", "r_prim", "r_dual"],
    )
