"""The whole NMPC control step as ONE CasADi Function (the Python and the C backend).

``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)``:

1. extended-state high-gain observer (the one of :mod:`maglev_ocp.observers`,
   same gains and update, but symbolic) on the quantized encoders: state and a
   constant acceleration disturbance per axis (offset-free tracking);
2. reference: a jerk-limited bang-bang move planned when the target changes
   (:mod:`controllers.nmpc_plan`, ``plan`` mode) or the runner's reference over
   the horizon (``preview`` mode), plus feed-forward currents from the inverted
   model;
3. real-time iteration (RTI) of multiple shooting on the shared model (with
   cogging unless ``p`` switches it off) plus the disturbance: one
   linearization per stage along the shifted previous solution;
4. the QP in the ``2 N`` current corrections: ADMM penalty from the trace of
   the condensed Hessian, then either the Riccati factorization of the ADMM
   x-update (``qp = "riccati"``, default, :mod:`controllers.nmpc_riccati`) or
   dense condensing and a KKT Cholesky (``qp = "dense"``, :mod:`controllers.nmpc_qp`);
   both give the same iterates;
5. a fixed number of ADMM iterations (OSQP's iteration): current disk per
   stage (contains the +-8 A box, closed-form projection), soft gap bounds
   (exact + quadratic penalty, closed-form proximal step);
6. checks and fallback (non-finite solution -> LQR about the planned
   reference, clipped to the disk), warm-start shift of states, inputs and
   duals.

The state vector layout is described by :class:`StateLayout`. The Function is
an MX graph of small SX Functions (observer/planner, per-node and per-stage
maps, and every recursion over the horizon as a chain of calls of one blocked
stage Function, :func:`controllers.nmpc_riccati.stage_chain`: factorization,
the ADMM iteration called ``n_iter`` times, the prediction of the new plan), so
the generated C holds each stage's code once (it stays in the instruction
cache), is branch-free in its loop counts, and needs only fixed work arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.linalg

from maglev_ocp import constants as k
from maglev_ocp.model import get_model
from maglev_ocp.observers import HighGainObserver, ObserverSettings, observer_update
from maglev_ocp.params import NOMINAL

from .nmpc_plan import half_duration, move_at, thrust_accel_available, u_for_accel
from .nmpc_qp import ADMMSettings, admm_iteration, admm_rho, chol_sx, condensed_qp, project_disk
from .nmpc_riccati import factor_function, iteration_function, stage_chain

NX, NU = 4, 2
N_MEAS = 3  #: meas = (g, d, fault)  [m, m, -]
REF_ROWS = ("g", "g_dot", "g_ddot", "d", "d_dot", "d_ddot")  #: rows of the ref input, one column per node
STATUS_OK, STATUS_INACCURATE, STATUS_FALLBACK = 0, 1, 2
STATS_NAMES: tuple[str, ...] = (
    "status",
    "fallback",
    "iterations",
    "iters_to_tol",
    "qp_r_prim",
    "qp_r_dual",
    "plan_t",
    "plan_T",
    "dist_g",
    "dist_d",
    "n_fail",
)


@dataclass(frozen=True)
class StepConfig:
    """Numeric design of the step Function (everything baked in as constants).

    Built from :class:`controllers.nmpc.NMPCSettings`; see there for meanings.
    """

    N: int = 20
    Ts: float = k.Ts
    n_sub: int = 1
    Q: tuple[float, float, float, float] = (4e7, 1e2, 4e7, 1e2)
    R: tuple[float, float] = (1.0, 1.0)
    terminal_scale: float = 1.0
    n_iter: int = 20
    admm: ADMMSettings = field(default_factory=ADMMSettings)
    i_max: float = k.i_amp_max
    i_box: float = k.i_axis_max
    gap_lo: float = 10e-3
    gap_hi: float = 30e-3
    gap_stride: int = 4
    soft_w1: float = 10.0
    soft_w2: float = 100.0
    obs_eps: float = 3e-3
    offset_free: bool = True
    reference: str = "plan"
    accel_margin: float = 0.9
    gap_accel: float = 20.0
    jerk_time: float = 2e-3
    min_move_time: float = 4e-3
    tol_prim: float = 1e-2
    tol_dual: float = 1e-2
    jacobian: str = "taylor"
    qp: str = "riccati"
    check_every: int = 5

    @property
    def n_gap(self) -> int:
        """Number of soft gap rows (stages ``stride, 2 stride, ..., <= N``)."""
        return len(self.gap_stages)

    @property
    def gap_stages(self) -> tuple[int, ...]:
        """Stages whose predicted gap is softly bounded."""
        if self.gap_stride <= 0:
            return ()
        return tuple(range(self.gap_stride, self.N + 1, self.gap_stride))


@dataclass(frozen=True)
class StateLayout:
    """Offsets of the pieces of the NMPC's state vector (``state_in`` / ``state_out``).

    Pieces: ``xhat`` (4) observer state, ``dist`` (2) acceleration disturbance
    [m/s^2], ``u_prev`` (2) last applied currents [A], ``fresh`` (1) 1 right
    after reset (skip the observer prediction once), ``plan`` (7) planner
    ``(g_start, d_start, g_target, d_target, t, h, tj)``, ``X`` ((N+1) x 4)
    shooting nodes, ``U`` (N x 2) currents, ``y`` ADMM duals (2N + n_gap),
    ``nfail`` (1) consecutive fallbacks.
    """

    N: int
    n_gap: int

    @property
    def pieces(self) -> tuple[tuple[str, int], ...]:
        """Names and sizes in order."""
        return (
            ("xhat", NX),
            ("dist", 2),
            ("u_prev", NU),
            ("fresh", 1),
            ("plan", 7),
            ("X", (self.N + 1) * NX),
            ("U", self.N * NU),
            ("y", self.N * NU + self.n_gap),
            ("nfail", 1),
        )

    @property
    def size(self) -> int:
        """Length of the state vector."""
        return sum(n for _, n in self.pieces)

    def slices(self) -> dict[str, slice]:
        """Slice of each piece."""
        out, i = {}, 0
        for name, n in self.pieces:
            out[name] = slice(i, i + n)
            i += n
        return out

    def split(self, v):
        """Dict of the pieces of ``v`` (numpy array or CasADi vector)."""
        return {name: v[s] for name, s in self.slices().items()}


def lqr_design(cfg: StepConfig, params=NOMINAL, g0: float = 20e-3) -> tuple[np.ndarray, np.ndarray]:
    """Discrete LQR at hover (gap ``g0``, ``d = 0``): terminal weight ``P`` and fallback gain ``K``.

    Returns
    -------
    P : ndarray, shape (4, 4)
        DARE solution for the step's ``Q`` and ``R`` (the infinite-horizon tail).
    K : ndarray, shape (2, 4)
        Gain of ``u = u_ref + K (x - x_ref)``.
    """
    m = get_model()
    p = params.vector()
    u0 = np.asarray(m.u_eq(g0, 0.0, p)).ravel()
    F = m.step(cfg.Ts, 1)
    x = ca.SX.sym("x", NX)
    u = ca.SX.sym("u", NU)
    J = ca.Function("J", [x, u], [ca.jacobian(F(x, u, p), x), ca.jacobian(F(x, u, p), u)])
    A, B = (np.asarray(M) for M in J([g0, 0, 0, 0], u0))
    Q, R = np.diag(cfg.Q), np.diag(cfg.R)
    P = scipy.linalg.solve_discrete_are(A, B, Q, R)
    K = -np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    return P, K


class StepBuilder:
    """Builds ``nmpc_step`` and ``nmpc_init`` for a :class:`StepConfig`."""

    def __init__(self, cfg: StepConfig):
        self.cfg = cfg
        self.layout = StateLayout(cfg.N, cfg.n_gap)
        self.model = get_model()
        P, K = lqr_design(cfg)
        self.P = P * cfg.terminal_scale
        self.K = K
        obs = HighGainObserver(NOMINAL, ObserverSettings(eps=cfg.obs_eps, disturbance=True), cfg.Ts)
        self.L_obs = obs.L.copy()
        if not cfg.offset_free:
            self.L_obs[2] = 0.0
        self._build_pred()

    # ------------------------------------------------------------------ pieces
    def _build_pred(self) -> None:
        """Prediction model: RK4 of ``f(x,u,p) + (0, w_g, 0, w_d)`` over one period, and its Jacobians."""
        m, cfg = self.model, self.cfg
        x, u, p, w = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("p", m.np_), ca.SX.sym("w", 2)
        E = ca.vertcat(0, w[0], 0, w[1])
        h = cfg.Ts / cfg.n_sub
        xk = x
        for _ in range(cfg.n_sub):
            k1 = m.f(xk, u, p) + E
            k2 = m.f(xk + h / 2 * k1, u, p) + E
            k3 = m.f(xk + h / 2 * k2, u, p) + E
            k4 = m.f(xk + h * k3, u, p) + E
            xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        self.F = ca.Function("nmpc_pred", [x, u, p, w], [xk])
        if cfg.jacobian == "exact":
            Ad, Bd = ca.jacobian(xk, x), ca.jacobian(xk, u)
        else:
            # Third-order Taylor series of the transition matrix at the node: |A_c Ts| ~ 0.04, so the
            # error is ~1e-7 relative; RTI converges to the same solution (the gaps use the exact RK4).
            Ac, Bc = m.linearization(x, u, p)
            T = cfg.Ts
            A2 = ca.mtimes(Ac, Ac)
            Ad = ca.DM.eye(NX) + Ac * T + A2 * (T**2 / 2) + ca.mtimes(A2, Ac) * (T**3 / 6)
            Bd = ca.mtimes(ca.DM.eye(NX) * T + Ac * (T**2 / 2) + A2 * (T**3 / 6), Bc)
        self.FJ = ca.Function("nmpc_pred_jac", [x, u, p, w], [xk, Ad, Bd])

    def _observer(self, xhat, dist, u_prev, y, p):
        """Predictor-corrector update of :class:`~maglev_ocp.observers.HighGainObserver`, symbolic.

        A non-finite reading is skipped (prediction only).
        """
        return observer_update(xhat, dist, u_prev, y, p, self.L_obs, self.cfg.Ts, disturbance=True, skip_nonfinite=True)

    def _plan(self, g_s, d_s, g_t, d_t, p, w_g):
        """Duration of a synchronized rest-to-rest move from ``(g_s, d_s)`` to ``(g_t, d_t)``."""
        cfg = self.cfg
        # Thrust acceleration left on the current disk at hover, at the weakest of start, middle, end gap.
        acc = [thrust_accel_available(g, p, cfg.i_max, w_g) for g in (g_s, g_t, (g_s + g_t) / 2)]
        a_d = cfg.accel_margin * ca.fmin(ca.fmin(acc[0], acc[1]), acc[2])
        a_d = ca.fmax(a_d, 1.0)
        h_d, _ = half_duration(d_t - d_s, a_d, cfg.jerk_time)
        h_g, _ = half_duration(g_t - g_s, cfg.gap_accel, cfg.jerk_time)
        h = ca.fmax(ca.fmax(h_d, h_g), cfg.min_move_time / 2)
        tj = ca.fmin(cfg.jerk_time, h / 2)
        return h, tj

    # ---------------------------------------------------------------- functions
    def build_init(self) -> ca.Function:
        """``nmpc_init(meas, ref, p) -> state``: at rest at the reading, plan towards ``ref``."""
        cfg, lay, m = self.cfg, self.layout, self.model
        N = cfg.N
        ms, tg, ps = ca.SX.sym("meas", N_MEAS), ca.SX.sym("target", 2), ca.SX.sym("p", m.np_)
        xh = ca.vertcat(ms[0], 0, ms[1], 0)
        h, tj = self._plan(ms[0], ms[1], tg[0], tg[1], ps, 0)
        pl = ca.vertcat(ms[0], ms[1], tg[0], tg[1], 0, h, tj)
        u0 = project_disk(u_for_accel(xh, ca.vertcat(0, 0), ps, ca.SX.zeros(2)), cfg.i_max, cfg.i_box)
        head = ca.Function("nmpc_init_head", [ms, tg, ps], [xh, pl, u0], {"cse": True})

        meas, ref, p = ca.MX.sym("meas", N_MEAS), ca.MX.sym("ref", 6, N + 1), ca.MX.sym("p", m.np_)
        xhat, plan, u_prev = head(meas, ca.vertcat(ref[0, 0], ref[3, 0]), p)
        dts = ca.DM(np.arange(N + 1) * cfg.Ts).T
        R, U = self._fn_node().map(N + 1, "serial")(dts, plan, ref, p, ca.MX.zeros(2))
        state = ca.vertcat(
            xhat,
            ca.MX.zeros(2),
            u_prev,
            1,
            plan,
            ca.vec(R),
            ca.vec(U[:, :N]),
            ca.MX.zeros(lay.N * NU + lay.n_gap),
            0,
        )
        assert state.shape[0] == lay.size
        return ca.Function("nmpc_init", [meas, ref, p], [state], ["meas", "ref", "p"], ["state"])

    def _fn_head(self) -> ca.Function:
        """Observer update and planner (SX): ``(state, meas, target, p) -> (xhat, dist, plan, w)``."""
        cfg, lay, m = self.cfg, self.layout, self.model
        st, meas, tgt, p = (
            ca.SX.sym("state", lay.size),
            ca.SX.sym("meas", N_MEAS),
            ca.SX.sym("target", 2),
            ca.SX.sym("p", m.np_),
        )
        S = lay.split(st)
        fresh = S["fresh"][0] > 0.5
        xo, do = self._observer(S["xhat"], S["dist"], S["u_prev"], meas[:2], p)
        xhat = ca.if_else(fresh, S["xhat"], xo)
        dist = ca.if_else(fresh, S["dist"], do)
        w = dist if cfg.offset_free else ca.SX.zeros(2)
        # Planner: replan from the estimate when the target changes, else advance the clock.
        pl = S["plan"]
        g_t, d_t = tgt[0], tgt[1]
        if cfg.reference == "plan":
            new = ca.fabs(g_t - pl[2]) + ca.fabs(d_t - pl[3]) > 0
            h_new, tj_new = self._plan(xhat[0], xhat[2], g_t, d_t, p, w[0])
        else:
            new, h_new, tj_new = ca.SX(0), pl[5], pl[6]
        t_adv = ca.if_else(fresh, pl[4], pl[4] + cfg.Ts)
        plan = ca.if_else(
            new,
            ca.vertcat(xhat[0], xhat[2], g_t, d_t, 0, h_new, tj_new),
            ca.vertcat(pl[0], pl[1], pl[2], pl[3], ca.fmin(t_adv, 2 * pl[5] + 1.0), pl[5], pl[6]),
        )
        return ca.Function(
            "nmpc_head",
            [st, meas, tgt, p],
            [xhat, dist, plan, w],
            ["state", "meas", "target", "p"],
            ["xhat", "dist", "plan", "w"],
            {"cse": True},
        )

    def _fn_node(self) -> ca.Function:
        """Reference node (SX, mapped over the horizon): ``(dt, plan, refcol, p, w) -> (r, uref)``."""
        cfg, m = self.cfg, self.model
        dt, plan, rc, p, w = (
            ca.SX.sym("dt"),
            ca.SX.sym("plan", 7),
            ca.SX.sym("refcol", 6),
            ca.SX.sym("p", m.np_),
            ca.SX.sym("w", 2),
        )
        g_s, d_s, g_t, d_t, t0, h, tj = (plan[i] for i in range(7))
        if cfg.reference == "plan":
            pg, vg, ag = move_at(t0 + dt, g_t - g_s, h, tj)
            pd, vd, ad = move_at(t0 + dt, d_t - d_s, h, tj)
            r, a = ca.vertcat(g_s + pg, vg, d_s + pd, vd), ca.vertcat(ag, ad)
        else:
            r, a = ca.vertcat(rc[0], rc[1], rc[3], rc[4]), ca.vertcat(rc[2], rc[5])
        uref = project_disk(u_for_accel(r, a, p, w), cfg.i_max, cfg.i_box)
        return ca.Function(
            "nmpc_node",
            [dt, plan, rc, p, w],
            [r, uref],
            ["dt", "plan", "refcol", "p", "w"],
            ["r", "uref"],
            {"cse": True},
        )

    def _fn_stage(self) -> ca.Function:
        """RTI linearization of one shooting interval (SX, mapped): ``(x, u, x_next, p, w) -> (A, B, c)``."""
        m = self.model
        x, u, xn, p, w = (
            ca.SX.sym("x", NX),
            ca.SX.sym("u", NU),
            ca.SX.sym("x_next", NX),
            ca.SX.sym("p", m.np_),
            ca.SX.sym("w", 2),
        )
        xe, A, B = self.FJ(x, u, p, w)
        # B dense (its structural zero would make every consumer re-densify the stacked Bs)
        return ca.Function(
            "nmpc_stage",
            [x, u, xn, p, w],
            [A, ca.densify(B), xe - xn],
            ["x", "u", "x_next", "p", "w"],
            ["A", "B", "c"],
            {"cse": True},
        )

    def _fn_condense(self) -> ca.Function:
        """Condensed QP (SX): ``(As, Bs, cs, dx0, Xbar, Xref, Ubar, Uref, u_prev, fault) -> (H, q, G, glb, gub)``."""
        cfg = self.cfg
        N, nv = cfg.N, cfg.N * NU
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
        # Cost: sum_k |x_k - r_k|_Q (P at N) + |u_k - uref_k|_R.
        Ws = [ca.DM(np.diag(cfg.Q))] * N + [ca.DM(self.P)]
        E = [Xb[:, j] - Xr[:, j] for j in range(N + 1)]
        qp = condensed_qp(Al, Bl, cl, dx0, E, Ws, cfg.gap_stages, [Xb[0, j] for j in range(N + 1)])
        H, q = qp["H"], qp["q"]
        Rm = np.tile(cfg.R, N)
        ub = ca.vec(Ub)
        H = H + ca.diag(ca.DM(Rm))
        q = q + ca.DM(Rm) * (ub - ca.vec(Ur))
        H = H + ca.if_else(fault > 0.5, math.nan, 0) * ca.DM(np.eye(nv))  # forced failure (tests)
        # Soft gap rows in millimetres.
        G = 1e3 * qp["G"]
        glb = 1e3 * (cfg.gap_lo - qp["gfree"])
        gub = 1e3 * (cfg.gap_hi - qp["gfree"])
        return ca.Function(
            "nmpc_condense",
            [As, Bs, cs, dx0, Xb, Xr, Ub, Ur, u_prev, fault],
            [ca.densify(H), q, G, glb, gub],
            ["As", "Bs", "cs", "dx0", "Xbar", "Xref", "Ubar", "Uref", "u_prev", "fault"],
            ["H", "q", "G", "glb", "gub"],
            {"cse": True},
        )

    def _fn_kkt(self) -> ca.Function:
        """ADMM penalty and Cholesky factor of the KKT matrix (SX): ``(H, G) -> (L, dinv, rho)``."""
        cfg = self.cfg
        nv, ng = cfg.N * NU, cfg.n_gap
        H, G = ca.SX.sym("H", nv, nv), ca.SX.sym("G", ng, nv)
        s = cfg.admm
        rho = admm_rho(H, min(cfg.R), s)
        Mk = H + (s.sigma + rho) * ca.DM.eye(nv)
        if ng:
            Mk = Mk + s.rho_g_rel * rho * ca.mtimes(G.T, G)
        Lc, dinv = chol_sx(ca.densify(Mk))
        return ca.Function("nmpc_kkt", [H, G], [Lc, dinv, ca.vertcat(rho, 1 / rho)], ["H", "G"], ["L", "dinv", "rho"])

    def _common(self, st, meas, ref, p) -> dict:
        """Observer, planner, references and RTI linearization (MX calls of the SX pieces)."""
        cfg, lay = self.cfg, self.layout
        N = cfg.N
        S = lay.split(st)
        xhat, dist, plan, w = self._fn_head()(st, meas, ca.vertcat(ref[0, 0], ref[3, 0]), p)
        dts = ca.DM(np.arange(N + 1) * cfg.Ts).T
        R, Uref = self._fn_node().map(N + 1, "serial")(dts, plan, ref, p, w)
        Uref = Uref[:, :N]
        Xb = ca.reshape(S["X"], NX, N + 1)
        Ub = ca.reshape(S["U"], NU, N)
        As, Bs, cs = self._fn_stage().map(N, "serial")(Xb[:, :N], Ub, Xb[:, 1:], p, w)
        return {
            "ubar": ca.vec(Ub),
            "Ubar": Ub,
            "y0": S["y"],
            "u_prev": S["u_prev"],
            "xhat": xhat,
            "dist": dist,
            "plan": plan,
            "As": As,
            "Bs": Bs,
            "cs": cs,
            "dx0": xhat - Xb[:, 0],
            "Xbar": Xb,
            "Xref": R,
            "Uref": Uref,
            "w": w,
        }

    def build_prep(self) -> ca.Function:
        """Observer, planner, RTI linearization and (dense path) condensing and KKT factorization.

        An MX composition of SX Functions (per-node and per-stage ones mapped
        serially: loops in the generated C), so the code stays compact.
        """
        cfg, lay, m = self.cfg, self.layout, self.model
        N = cfg.N
        st, meas, ref, p = (
            ca.MX.sym("state", lay.size),
            ca.MX.sym("meas", N_MEAS),
            ca.MX.sym("ref", 6, N + 1),
            ca.MX.sym("p", m.np_),
        )
        o = self._common(st, meas, ref, p)
        names = ["ubar", "y0", "xhat", "dist", "plan", "As", "Bs", "cs", "dx0", "Xbar", "Xref", "Uref", "w"]
        outs = [o[n] for n in names]
        if cfg.qp == "dense":
            H, q, G, glb, gub = self._fn_condense()(
                o["As"], o["Bs"], o["cs"], o["dx0"], o["Xbar"], o["Xref"], o["Ubar"], o["Uref"], o["u_prev"], meas[2]
            )
            Lc, dinv, rho = self._fn_kkt()(H, G)
            names = ["L", "dinv", "q", "G", "glb", "gub", "rho", *names]
            outs = [Lc, dinv, q, G, glb, gub, rho, *outs]
        return ca.Function("nmpc_prep", [st, meas, ref, p], outs, ["state", "meas", "ref", "p"], names)

    def build_post(self) -> ca.Function:
        """Checks, fallback and warm-start shift.

        An MX Function: the prediction of the new plan is a
        :func:`~controllers.nmpc_riccati.stage_chain` of :meth:`_fn_pred_stage`,
        the rest one SX Function (:meth:`_fn_post_tail`).
        """
        cfg, m = self.cfg, self.model
        N, nv, ng = cfg.N, cfg.N * NU, cfg.n_gap
        sym = ca.MX.sym
        v, y, ub = sym("v", nv), sym("y", nv + ng), sym("ubar", nv)
        xhat, dist, plan = sym("xhat", NX), sym("dist", 2), sym("plan", 7)
        As, Bs, cs, dx0 = sym("As", NX, NX * N), sym("Bs", NX, NU * N), sym("cs", NX, N), sym("dx0", NX)
        Xb, Xref, Uref = sym("Xbar", NX, N + 1), sym("Xref", NX, N + 1), sym("Uref", NU, N)
        w, p = sym("w", 2), sym("p", m.np_)
        r_prim, r_dual, iters_to_tol, nfail = sym("r_prim"), sym("r_dual"), sym("iters_to_tol"), sym("nfail")
        # new plan: the linear prediction of the corrections on top of the shooting nodes
        _, (Xn,) = stage_chain(self._fn_pred_stage(), N, [dx0], [As, Bs, ca.reshape(v, NU, N), cs, Xb[:, 1:]])
        u, state, stats = self._fn_post_tail()(
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
        names = [
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
        ]
        ins = [v, y, ub, xhat, dist, plan, As, Bs, cs, dx0, Xb, Xref, Uref, w, p, r_prim, r_dual, iters_to_tol, nfail]
        return ca.Function("nmpc_post", ins, [u, state, stats, xhat], names, ["u", "state", "stats", "x_hat"])

    def _fn_pred_stage(self) -> ca.Function:
        """Linear prediction of one stage (SX): ``(dx, A, B, v, c, xbar_next) -> (dx_next, x_next)``."""
        dx, A, B, v, c, xbn = (
            ca.SX.sym("dx", NX),
            ca.SX.sym("A", NX, NX),
            ca.SX.sym("B", NX, NU),
            ca.SX.sym("v", NU),
            ca.SX.sym("c", NX),
            ca.SX.sym("xbar_next", NX),
        )
        dxn = ca.mtimes(A, dx) + ca.mtimes(B, v) + c
        return ca.Function(
            "nmpc_pred_stage",
            [dx, A, B, v, c, xbn],
            [dxn, xbn + dxn],
            ["dx", "A", "B", "v", "c", "xbar_next"],
            ["dx_next", "x_next"],
        )

    def _fn_post_tail(self) -> ca.Function:
        """Checks, fallback and warm-start shift given the predicted plan ``X`` (SX)."""
        cfg, m = self.cfg, self.model
        N, nv, ng = cfg.N, cfg.N * NU, cfg.n_gap
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
        # a sum propagates NaN (fmax/fmin and the disk projection would swallow it)
        finite = ca.sum1(ca.fabs(ca.vertcat(U, X, y))) < 1e12
        u_opt = project_disk(U[:NU], cfg.i_max, cfg.i_box)
        # Fallback: LQR about the planned reference, on the current disk.
        u_fb = project_disk(Uref[:, 0] + ca.mtimes(ca.DM(self.K), xhat - Xref[:, 0]), cfg.i_max, cfg.i_box)
        u = ca.if_else(finite, u_opt, u_fb)
        accurate = ca.logic_and(r_prim <= cfg.tol_prim, r_dual <= cfg.tol_dual)
        status = ca.if_else(finite, ca.if_else(accurate, STATUS_OK, STATUS_INACCURATE), STATUS_FALLBACK)

        # Warm start: shift nodes, inputs and duals by one period; on fallback restart from the reference.
        Um = ca.reshape(U, NU, N)
        x_end = self.F(Xm[:, N], Um[:, N - 1], p, w)
        X_sh = ca.vec(ca.horzcat(Xm[:, 1:], x_end))
        U_sh = ca.vec(ca.horzcat(Um[:, 1:], Um[:, N - 1]))
        yu = y[:nv]
        y_sh = ca.vertcat(yu[NU:], yu[nv - NU :])
        if ng:
            y_sh = ca.vertcat(y_sh, y[nv:] if cfg.gap_stride != 1 else ca.vertcat(y[nv + 1 :], y[nv + ng - 1]))
        X_fb = ca.vec(ca.horzcat(Xref[:, 1:], Xref[:, N]))
        U_fb = ca.vec(ca.horzcat(Uref[:, 1:], Uref[:, N - 1]))
        X_new = ca.if_else(finite, X_sh, X_fb)
        U_new = ca.if_else(finite, U_sh, U_fb)
        y_new = ca.if_else(finite, y_sh, ca.SX.zeros(nv + ng))
        nfail_new = ca.if_else(finite, 0, nfail + 1)
        state = ca.vertcat(xhat, dist, u, 0, plan, X_new, U_new, y_new, nfail_new)
        stats = ca.vertcat(
            status,
            1 - finite,
            cfg.n_iter,
            iters_to_tol,
            r_prim,
            r_dual,
            plan[4],
            2 * plan[5],
            dist[0],
            dist[1],
            nfail_new,
        )
        names = [
            "v",
            "y",
            "ubar",
            "xhat",
            "dist",
            "plan",
            "X",
            "Xref",
            "Uref",
            "w",
            "p",
            "r_prim",
            "r_dual",
            "iters_to_tol",
            "nfail",
        ]
        ins = [v, y, ub, xhat, dist, plan, Xm, Xref, Uref, w, p, r_prim, r_dual, iters_to_tol, nfail]
        return ca.Function("nmpc_post_tail", ins, [u, state, stats], names, ["u", "state", "stats"])

    def _checkpoints(self) -> list[int]:
        cfg = self.cfg
        return sorted({*range(cfg.check_every, cfg.n_iter, cfg.check_every), cfg.n_iter})

    def _track(self, i, rp_i, rd_i, state):
        """Residual bookkeeping at checkpoints: iterations to reach the tolerance = first checkpoint below it
        (assuming monotone progress), else n_iter."""
        cfg, checks = self.cfg, self._checkpoints()
        if i in checks:
            nxt = checks[checks.index(i) + 1] if i != checks[-1] else i
            state["rp"], state["rd"] = rp_i, rd_i
            state["iters"] = state["iters"] + (nxt - i) * ca.logic_or(rp_i > cfg.tol_prim, rd_i > cfg.tol_dual)

    def _admm_dense(self, o: dict):
        """Fixed-budget ADMM on the dense condensed QP (reference implementation)."""
        cfg = self.cfg
        nv, ng = cfg.N * NU, cfg.n_gap
        args = (nv, ng, NU, cfg.i_max, cfg.i_box, cfg.soft_w1, cfg.soft_w2, cfg.admm)
        it_res = admm_iteration(*args, residuals=True)
        it_fast = admm_iteration(*args, residuals=False)
        # warm start: zero correction (the linearization point is the shifted plan), shifted duals
        x, z, yv = ca.MX.zeros(nv), ca.MX.zeros(nv + ng), o["y0"]
        track = {"rp": ca.MX(0), "rd": ca.MX(0), "iters": ca.MX(self._checkpoints()[0])}
        for i in range(1, cfg.n_iter + 1):
            it = it_res if i in self._checkpoints() else it_fast
            x, z, yv, rp_i, rd_i = it(
                x, z, yv, o["L"], o["dinv"], o["q"], o["G"], o["ubar"], o["glb"], o["gub"], o["rho"]
            )
            self._track(i, rp_i, rd_i, track)
        return z, yv, track

    def _admm_riccati(self, o: dict, fault):
        """Fixed-budget ADMM with the Riccati x-update (:mod:`controllers.nmpc_riccati`)."""
        cfg = self.cfg
        N, nv = cfg.N, cfg.N * NU
        fac = factor_function(N, cfg.gap_stages, np.diag(cfg.Q), self.P, cfg.R, cfg.admm, cfg.gap_lo, cfg.gap_hi)
        it = iteration_function(N, cfg.gap_stages, cfg.i_max, cfg.i_box, cfg.soft_w1, cfg.soft_w2, cfg.admm)
        K, Sinv, PB, Pc, rho, qW, rbase, glb, gub, zg0 = fac(
            o["As"], o["Bs"], o["cs"], o["dx0"], o["Xbar"], o["Xref"], o["Ubar"], o["Uref"], fault
        )
        # warm start: zero correction (the linearization point is the shifted plan), gap rows at the free
        # response, shifted duals
        x, z, yv = ca.MX.zeros(nv), ca.vertcat(ca.MX.zeros(nv), zg0), o["y0"]
        track = {"rp": ca.MX(0), "rd": ca.MX(0), "iters": ca.MX(self._checkpoints()[0])}
        for i in range(1, cfg.n_iter + 1):
            x, z, yv, rp_i, rd_i = it(
                x, z, yv, K, Sinv, PB, Pc, o["As"], o["Bs"], o["cs"], o["dx0"], qW, rbase, o["ubar"], glb, gub, rho
            )
            self._track(i, rp_i, rd_i, track)
        return z, yv, track

    def build_step(self) -> ca.Function:
        """``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)`` (MX graph of SX Functions)."""
        cfg, lay, m = self.cfg, self.layout, self.model
        nv = cfg.N * NU
        post = self.build_post()
        st, meas, ref, p = (
            ca.MX.sym("state_in", lay.size),
            ca.MX.sym("meas", N_MEAS),
            ca.MX.sym("ref", 6, cfg.N + 1),
            ca.MX.sym("p", m.np_),
        )
        if cfg.qp == "dense":
            o = self.build_prep()(state=st, meas=meas, ref=ref, p=p)
            z, yv, tr = self._admm_dense(o)
        else:
            o = self._common(st, meas, ref, p)
            z, yv, tr = self._admm_riccati(o, meas[2])
        nfail = st[lay.slices()["nfail"]]
        r = post(
            v=z[:nv],
            y=yv,
            ubar=o["ubar"],
            xhat=o["xhat"],
            dist=o["dist"],
            plan=o["plan"],
            As=o["As"],
            Bs=o["Bs"],
            cs=o["cs"],
            dx0=o["dx0"],
            Xbar=o["Xbar"],
            Xref=o["Xref"],
            Uref=o["Uref"],
            w=o["w"],
            p=p,
            r_prim=tr["rp"],
            r_dual=tr["rd"],
            iters_to_tol=tr["iters"],
            nfail=nfail,
        )
        return ca.Function(
            "nmpc_step",
            [st, meas, ref, p],
            [r["u"], r["state"], r["stats"], r["x_hat"]],
            ["state_in", "meas", "ref", "p"],
            ["u", "state_out", "stats", "x_hat"],
        )
