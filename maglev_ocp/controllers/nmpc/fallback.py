"""Stages 5 and 6 of the step: checks and fallback, then the warm-start shift.

After the QP the corrections are checked for finiteness (a sum, which
propagates NaN, where ``fmax``/``fmin`` and the disk projection would swallow
it); a non-finite solution applies the LQR about the planned reference,
clipped to the disk, and restarts the warm start from the reference. Otherwise
the shooting nodes, inputs and duals are shifted by one period.
"""

from __future__ import annotations

import casadi as ca

from .design import StepDesign, scheduled_gain
from .layout import NU, NX, STATUS_FALLBACK, STATUS_INACCURATE, STATUS_OK
from .prediction import fn_pred_stage
from .qp import project_disk
from .riccati import stage_chain

#: Inputs of ``nmpc_post`` (and of the step's stages after the QP), in order.
POST_INPUTS: tuple[str, ...] = (
    "v",
    "y",
    "ubar",
    "xhat",
    "dist",
    "plan",
    "As",
    "Bs",
    "cs",
    "dx0",
    "Xbar",
    "Xref",
    "Uref",
    "w",
    "p",
    "r_prim",
    "r_dual",
    "iters_to_tol",
    "nfail",
)


def checked_input(d: StepDesign, U, X, y, xhat, Xref, Uref, r_prim, r_dual):
    """The current to apply and the step's status: the QP's, or the LQR fallback on a non-finite solution."""
    s = d.settings
    # a sum propagates NaN (fmax/fmin and the disk projection would swallow it)
    finite = ca.sum1(ca.fabs(ca.vertcat(U, X, y))) < 1e12
    u_opt = project_disk(U[:NU], s.current_limit, s.i_box)
    # Fallback: LQR about the planned reference, on the current disk; with lqr_schedule its gain is the
    # one designed at the reference gap (interpolated on the design grid), else the 20 mm design.
    K = ca.DM(d.K) if d.K_grid is None else scheduled_gain(d.K_grid, Xref[0, 0])
    u_fb = project_disk(Uref[:, 0] + ca.mtimes(K, xhat - Xref[:, 0]), s.current_limit, s.i_box)
    u = ca.if_else(finite, u_opt, u_fb)
    accurate = ca.logic_and(r_prim <= s.admm.tol_prim, r_dual <= s.admm.tol_dual)
    status = ca.if_else(finite, ca.if_else(accurate, STATUS_OK, STATUS_INACCURATE), STATUS_FALLBACK)
    return finite, u, status


def shifted(d: StepDesign, finite, U, Xm, y, Xref, Uref, p, w):
    """Warm start for the next period: nodes, inputs and duals shifted by one; on fallback the reference."""
    s = d.settings
    N, nv, ng = s.horizon, s.horizon * NU, s.n_gap
    Um = ca.reshape(U, NU, N)
    x_end = d.F(Xm[:, N], Um[:, N - 1], p, w)
    X_sh = ca.vec(ca.horzcat(Xm[:, 1:], x_end))
    U_sh = ca.vec(ca.horzcat(Um[:, 1:], Um[:, N - 1]))
    yu = y[:nv]
    y_sh = ca.vertcat(yu[NU:], yu[nv - NU :])
    if ng:
        y_sh = ca.vertcat(y_sh, y[nv:] if s.soft_gap.stride != 1 else ca.vertcat(y[nv + 1 :], y[nv + ng - 1]))
    X_fb = ca.vec(ca.horzcat(Xref[:, 1:], Xref[:, N]))
    U_fb = ca.vec(ca.horzcat(Uref[:, 1:], Uref[:, N - 1]))
    X_new = ca.if_else(finite, X_sh, X_fb)
    U_new = ca.if_else(finite, U_sh, U_fb)
    y_new = ca.if_else(finite, y_sh, ca.SX.zeros(nv + ng))
    return X_new, U_new, y_new


def fn_post_tail(d: StepDesign) -> ca.Function:
    """Checks, fallback and warm-start shift given the predicted plan ``X`` (SX)."""
    s, m = d.settings, d.model
    N, nv, ng = s.horizon, s.horizon * NU, s.n_gap
    v = ca.SX.sym("v", nv)  # projected input corrections (the z of the input rows)
    y = ca.SX.sym("y", nv + ng)
    ub = ca.SX.sym("ubar", nv)
    xhat, dist, plan = ca.SX.sym("xhat", NX), ca.SX.sym("dist", 2), ca.SX.sym("plan", 7)
    Xm = ca.SX.sym("X", NX, N + 1)
    Xref = ca.SX.sym("Xref", NX, N + 1)
    Uref = ca.SX.sym("Uref", NU, N)
    w = ca.SX.sym("w", 2)
    p = ca.SX.sym("p", m.np_)
    r_prim, r_dual, iters_to_tol = ca.SX.sym("r_prim"), ca.SX.sym("r_dual"), ca.SX.sym("iters_to_tol")
    nfail = ca.SX.sym("nfail")

    U = ub + v
    X = ca.vec(Xm)
    finite, u, status = checked_input(d, U, X, y, xhat, Xref, Uref, r_prim, r_dual)
    X_new, U_new, y_new = shifted(d, finite, U, Xm, y, Xref, Uref, p, w)
    nfail_new = ca.if_else(finite, 0, nfail + 1)
    state = ca.vertcat(xhat, dist, u, 0, plan, X_new, U_new, y_new, nfail_new)
    stats = ca.vertcat(
        status,
        1 - finite,
        s.iterations,
        iters_to_tol,
        r_prim,
        r_dual,
        plan[4],
        2 * plan[5],
        dist[0],
        dist[1],
        nfail_new,
    )
    names = ["v", "y", "ubar", "xhat", "dist", "plan", "X", "Xref", "Uref", "w", "p"]
    names += ["r_prim", "r_dual", "iters_to_tol", "nfail"]
    ins = [v, y, ub, xhat, dist, plan, Xm, Xref, Uref, w, p, r_prim, r_dual, iters_to_tol, nfail]
    return ca.Function("nmpc_post_tail", ins, [u, state, stats], names, ["u", "state", "stats"])


def build_post(d: StepDesign) -> ca.Function:
    """Prediction of the new plan, checks, fallback and warm-start shift (``nmpc_post``, inputs :data:`POST_INPUTS`).

    An MX Function: the prediction of the new plan is a
    :func:`~maglev_ocp.controllers.nmpc.riccati.stage_chain` of
    :func:`~maglev_ocp.controllers.nmpc.prediction.fn_pred_stage`, the rest one SX
    Function (:func:`fn_post_tail`).
    """
    s, m = d.settings, d.model
    N, nv, ng = s.horizon, s.horizon * NU, s.n_gap
    sym = ca.MX.sym
    v, y, ub = sym("v", nv), sym("y", nv + ng), sym("ubar", nv)
    xhat, dist, plan = sym("xhat", NX), sym("dist", 2), sym("plan", 7)
    As, Bs, cs, dx0 = sym("As", NX, NX * N), sym("Bs", NX, NU * N), sym("cs", NX, N), sym("dx0", NX)
    Xb, Xref, Uref = sym("Xbar", NX, N + 1), sym("Xref", NX, N + 1), sym("Uref", NU, N)
    w, p = sym("w", 2), sym("p", m.np_)
    r_prim, r_dual, iters_to_tol, nfail = sym("r_prim"), sym("r_dual"), sym("iters_to_tol"), sym("nfail")
    # new plan: the linear prediction of the corrections on top of the shooting nodes
    _, (Xn,) = stage_chain(fn_pred_stage(), N, [dx0], [As, Bs, ca.reshape(v, NU, N), cs, Xb[:, 1:]])
    u, state, stats = fn_post_tail(d)(
        v,
        y,
        ub,
        xhat,
        dist,
        plan,
        ca.horzcat(Xb[:, 0] + dx0, Xn),
        Xref,
        Uref,
        w,
        p,
        r_prim,
        r_dual,
        iters_to_tol,
        nfail,
    )
    ins = [v, y, ub, xhat, dist, plan, As, Bs, cs, dx0, Xb, Xref, Uref, w, p, r_prim, r_dual, iters_to_tol, nfail]
    return ca.Function("nmpc_post", ins, [u, state, stats, xhat], list(POST_INPUTS), ["u", "state", "stats", "x_hat"])


__all__ = ["POST_INPUTS", "build_post", "checked_input", "fn_post_tail", "shifted"]
