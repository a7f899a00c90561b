"""The whole NMPC control step as ONE CasADi Function, assembled top-down from its stages.

``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)``:

1. observer (:mod:`.observer`): extended-state high-gain observer on the
   quantized encoders, state and a constant acceleration disturbance per axis;
2. reference (:mod:`.planner`, :mod:`maglev_ocp.controllers.nmpc.reference`): a jerk-limited bang-bang
   move planned when the target changes (``plan`` mode) or the runner's
   reference over the horizon (``preview`` mode), plus feed-forward currents
   from the inverted model;
3. RTI linearization (:mod:`.prediction`): one linearization per shooting
   interval along the shifted previous solution;
4. QP and fixed-budget ADMM (:mod:`.admm` with :mod:`.riccati` or :mod:`.qp`):
   current disk per stage, soft gap bounds;
5. checks and fallback, 6. warm-start shift (:mod:`.fallback`).

Every number comes from :class:`~maglev_ocp.controllers.nmpc.settings.NMPCSettings` through
the :class:`~maglev_ocp.controllers.nmpc.design.StepDesign`. The Function is an MX graph of
small SX Functions (observer/planner, per-node and per-stage maps, and every
recursion over the horizon as a chain of calls of one blocked stage Function,
:func:`maglev_ocp.controllers.nmpc.riccati.stage_chain`), so the generated C holds each
stage's code once, is branch-free in its loop counts and needs only fixed work
arrays. How it is evaluated (CasADi or compiled C) is up to the caller.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from maglev_ocp.params import Params

from .admm import admm_dense, admm_riccati, fn_condense, fn_kkt
from .design import StepDesign, make_design
from .fallback import build_post
from .layout import N_MEAS, NU, NX
from .observer import observe
from .osqp_solver import osqp_callback
from .planner import advance_plan, plan_duration
from .prediction import fn_stage, predict_through_delay, u_feedforward
from .qp import project_disk
from .reference import N_REF, fn_node
from .settings import NMPCSettings


def fn_head(d: StepDesign) -> ca.Function:
    """Observer update, delay predictor and planner (SX).

    ``(state, meas, target, p, moving) -> (xhat, dist, plan, w, x0, p_hat, adapt)``
    (``moving``: 1 while the previewed reference moves; ``plan`` mode reads its own planner):
    ``x0`` is the state the QP starts from: the estimate predicted through the
    commands in flight (``delay_samples > 0``), else the estimate itself; the
    planner plans from it (the plan's clock runs ``delay_samples`` periods ahead).
    ``p_hat`` is the parameter vector with the observer's online corrections of
    the adapted constants (``settings.adapt``; ``p`` without), which the
    prediction and the feed-forward use; ``adapt`` the new ``theta``, ``ups``,
    ``cov``, ``since``, ``age`` and ``noise`` state pieces (empty without ``adapt``).
    """
    lay, m = d.layout, d.model
    st, meas, tgt, p, moving = (
        ca.SX.sym("state", lay.size),
        ca.SX.sym("meas", N_MEAS),
        ca.SX.sym("target", 2),
        ca.SX.sym("p", m.np_),
        ca.SX.sym("moving"),
    )
    S = lay.split(st)
    # plan mode: the internal planner's move is under way (its clock before the move's end)
    mv = S["plan"][4] < 2 * S["plan"][5] if d.mode == "plan" else moving
    fresh, xhat, dist, w, p_hat, adapt = observe(d, S, meas[:2], p, mv)
    x0 = predict_through_delay(d, xhat, S["u_flight"], p_hat, w) if lay.n_delay else xhat
    # the planner keeps the controller's constants (its moves do not change with the online corrections)
    plan = advance_plan(d, S["plan"], fresh, x0, tgt, p, w)
    return ca.Function(
        "nmpc_head",
        [st, meas, tgt, p, moving],
        [xhat, dist, plan, w, x0, p_hat, adapt],
        ["state", "meas", "target", "p", "moving"],
        ["xhat", "dist", "plan", "w", "x0", "p_hat", "adapt"],
        {"cse": True},
    )


def build_init(d: StepDesign) -> ca.Function:
    """``nmpc_init(meas, ref, p) -> state``: at rest at the reading, plan towards ``ref``."""
    s, lay, m = d.settings, d.layout, d.model
    N = s.horizon
    ms, tg, ps = ca.SX.sym("meas", N_MEAS), ca.SX.sym("target", 2), ca.SX.sym("p", m.np_)
    xh = ca.vertcat(ms[0], 0, ms[1], 0)
    h, tj = plan_duration(d, ms[0], ms[1], tg[0], tg[1], ps, 0)
    pl = ca.vertcat(ms[0], ms[1], tg[0], tg[1], 0, h, tj)
    # hover at rest on the prediction model (the model file's effects included)
    u0 = project_disk(u_feedforward(d, xh, ca.vertcat(0, 0), ps, ca.SX.zeros(2)), s.current_limit, s.i_box)
    head = ca.Function("nmpc_init_head", [ms, tg, ps], [xh, pl, u0], {"cse": True})

    meas, ref, p = ca.MX.sym("meas", N_MEAS), ca.MX.sym("ref", N_REF, N + 1), ca.MX.sym("p", m.np_)
    xhat, plan, u_prev = head(meas, ca.vertcat(ref[0, 0], ref[3, 0]), p)
    dts = ca.DM(np.arange(N + 1) * d.Ts).T
    R, U = fn_node(d).map(N + 1, "serial")(dts, plan, ref, p, ca.MX.zeros(2))
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
        *([ca.repmat(u_prev, lay.n_delay, 1)] if lay.n_delay else []),
        *(
            [
                ca.MX.zeros(7 * lay.n_adapt),
                ca.DM(np.ravel(np.eye(lay.n_adapt) * s.adapt_prior**2)),
                1e6,
                0,
                ca.DM.ones(2) * (s.adapt_noise or s.adapt_noise_floor) ** 2,
            ]
            if lay.n_adapt
            else []
        ),
    )
    assert state.shape[0] == lay.size
    return ca.Function("nmpc_init", [meas, ref, p], [state], ["meas", "ref", "p"], ["state"])


def _front(d: StepDesign, st, meas, ref, p) -> dict:
    """Stages 1-3: observer, planner, references and RTI linearization (MX calls of the SX pieces)."""
    lay, N = d.layout, d.settings.horizon
    S = lay.split(st)
    # the previewed reference moves (rows 1 and 4: its velocities) somewhere over the horizon
    moving = ca.sum2(ca.fabs(ref[1, :]) + ca.fabs(ref[4, :])) > 0
    xhat, dist, plan, w, x0, p_hat, adapt = fn_head(d)(st, meas, ca.vertcat(ref[0, 0], ref[3, 0]), p, moving)
    dts = ca.DM(np.arange(N + 1) * d.Ts).T
    R, Uref = fn_node(d).map(N + 1, "serial")(dts, plan, ref, p_hat, w)
    Uref = Uref[:, :N]
    Xb = ca.reshape(S["X"], NX, N + 1)
    Ub = ca.reshape(S["U"], NU, N)
    As, Bs, cs = fn_stage(d).map(N, "serial")(Xb[:, :N], Ub, Xb[:, 1:], p_hat, w)
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
        "dx0": x0 - Xb[:, 0],
        "x0": x0,
        "Xbar": Xb,
        "Xref": R,
        "Uref": Uref,
        "w": w,
        "p_hat": p_hat,
        "adapt": adapt,
    }


def _front_inputs(d: StepDesign) -> tuple[tuple[ca.MX, ...], dict]:
    """The step's inputs ``(state, meas, ref, p)`` as MX symbols and stages 1-3 on them (:func:`_front`)."""
    lay, m, N = d.layout, d.model, d.settings.horizon
    ins = (
        ca.MX.sym("state", lay.size),
        ca.MX.sym("meas", N_MEAS),
        ca.MX.sym("ref", N_REF, N + 1),
        ca.MX.sym("p", m.np_),
    )
    return ins, _front(d, *ins)


def _condensed(d: StepDesign, o: dict, fault: ca.MX) -> tuple:
    """Dense condensing (:func:`~.admm.fn_condense`) of stage 3's linearization ``o``: ``(H, q, G, glb, gub)``.

    ``fault`` is the measurement's fault flag (``meas[2]``).
    """
    return fn_condense(d)(
        o["As"], o["Bs"], o["cs"], o["dx0"], o["Xbar"], o["Xref"], o["Ubar"], o["Uref"], o["u_prev"], fault
    )


def build_prep(d: StepDesign) -> ca.Function:
    """Stages 1-3 and (dense path) condensing and KKT factorization, as one MX Function ``nmpc_prep``."""
    s = d.settings
    (st, meas, ref, p), o = _front_inputs(d)
    names = ["ubar", "y0", "xhat", "dist", "plan", "As", "Bs", "cs", "dx0", "Xbar", "Xref", "Uref", "w", "x0"]
    names += ["p_hat", "adapt"]
    outs = [o[n] for n in names]
    if s.qp == "dense":
        H, q, G, glb, gub = _condensed(d, o, meas[2])
        Lc, dinv, rho = fn_kkt(d)(H, G)
        names = ["L", "dinv", "q", "G", "glb", "gub", "rho", *names]
        outs = [Lc, dinv, q, G, glb, gub, rho, *outs]
    return ca.Function("nmpc_prep", [st, meas, ref, p], outs, ["state", "meas", "ref", "p"], names)


def build_qp_export(d: StepDesign) -> ca.Function:
    """``nmpc_qp(state, meas, ref, p) -> (H, q, G, glb, gub, ubar)``: the step's QP as dense data.

    The same stages 1-3 as the step and the dense condensing of :func:`~.admm.fn_condense`
    (identical to what the Riccati x-update iterates on), for the exact reference
    solution (:mod:`maglev_ocp.controllers.nmpc.exact_qp`) and the external QP solvers.
    """
    (st, meas, ref, p), o = _front_inputs(d)
    H, q, G, glb, gub = _condensed(d, o, meas[2])
    return ca.Function(
        "nmpc_qp",
        [st, meas, ref, p],
        [ca.densify(e) for e in (H, q, G, glb, gub, o["ubar"])],
        ["state", "meas", "ref", "p"],
        ["H", "q", "G", "glb", "gub", "ubar"],
    )


def osqp_qp(d: StepDesign, o: dict, fault) -> tuple:
    """Stage 4 by OSQP (:mod:`.osqp_solver`): dense condensing, then the solver as a callback node."""
    s = d.settings
    H, q, G, glb, gub = _condensed(d, o, fault)
    z, rp, rd, iters = osqp_callback(s)(H, q, G, glb, gub, o["ubar"])
    return z, ca.MX.zeros(s.horizon * NU + s.n_gap), {"rp": rp, "rd": rd, "iters": iters}


def build_step(d: StepDesign) -> ca.Function:
    """``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)`` (MX graph of SX Functions)."""
    s, lay, m = d.settings, d.layout, d.model
    nv = s.horizon * NU
    post = build_post(d)
    st, meas, ref, p = (
        ca.MX.sym("state_in", lay.size),
        ca.MX.sym("meas", N_MEAS),
        ca.MX.sym("ref", N_REF, s.horizon + 1),
        ca.MX.sym("p", m.np_),
    )
    if s.solver == "osqp":
        o = _front(d, st, meas, ref, p)
        z, yv, tr = osqp_qp(d, o, meas[2])
    elif s.qp == "dense":
        o = build_prep(d)(state=st, meas=meas, ref=ref, p=p)
        z, yv, tr = admm_dense(d, o)
    else:
        o = _front(d, st, meas, ref, p)
        z, yv, tr = admm_riccati(d, o, meas[2])
    r = post(
        v=z[:nv],
        y=yv,
        ubar=o["ubar"],
        xhat=o["x0"],  # the fallback's LQR acts on the state the command will meet
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
        p=o["p_hat"],
        r_prim=tr["rp"],
        r_dual=tr["rd"],
        iters_to_tol=tr["iters"],
        nfail=st[lay.slices()["nfail"]],
    )
    state_out, x_hat = r["state"], r["x_hat"]
    if lay.n_delay:
        state_out, x_hat = _delay_state(d, st, r["state"], o["xhat"], r["u"]), o["xhat"]
    if lay.n_adapt:
        state_out = ca.vertcat(state_out, o["adapt"])
    return ca.Function(
        "nmpc_step",
        [st, meas, ref, p],
        [r["u"], state_out, r["stats"], x_hat],
        ["state_in", "meas", "ref", "p"],
        ["u", "state_out", "stats", "x_hat"],
    )


def _delay_state(d: StepDesign, st: ca.MX, post_state: ca.MX, xhat: ca.MX, u: ca.MX) -> ca.MX:
    """The state out with a computation delay: the estimate now, and the command queue advanced by one.

    ``post_state`` is the fallback stage's state (all pieces up to ``nfail``,
    holding the predicted ``x0`` as ``xhat`` and the new command as
    ``u_prev``); here ``xhat`` is the estimate now, ``u_prev`` the oldest
    command in flight (it is applied over the coming period) and the new
    command joins the end of ``u_flight``.
    """
    sl = d.layout.slices()
    fl = st[sl["u_flight"]]
    return ca.vertcat(
        xhat,
        post_state[sl["xhat"].stop : sl["u_prev"].start],
        fl[:NU],
        post_state[sl["u_prev"].stop : sl["u_flight"].start],
        fl[NU:],
        u,
    )


class StepBuilder:
    """The step's design and its Functions, for inspection (tests, the peer benchmark).

    Parameters
    ----------
    settings : NMPCSettings
        The controller's settings.
    mode : {"plan", "preview"}
        Reference mode.
    """

    def __init__(self, settings: NMPCSettings, mode: str = "plan", params=None):
        self.design = make_design(settings, mode, params)
        self.settings = settings
        self.layout = self.design.layout
        self.F, self.P, self.K = self.design.F, self.design.P, self.design.K

    def build_init(self) -> ca.Function:
        """``nmpc_init`` (:func:`build_init`)."""
        return build_init(self.design)

    def build_step(self) -> ca.Function:
        """``nmpc_step`` (:func:`build_step`)."""
        return build_step(self.design)

    def build_prep(self) -> ca.Function:
        """``nmpc_prep`` (:func:`build_prep`)."""
        return build_prep(self.design)

    def build_qp_export(self) -> ca.Function:
        """``nmpc_qp`` (:func:`build_qp_export`)."""
        return build_qp_export(self.design)


def step_functions(
    settings: NMPCSettings, mode: str, params: Params | None = None
) -> tuple[ca.Function, ca.Function, StepBuilder]:
    """``nmpc_init``, ``nmpc_step`` and the builder (holding the layout) of a design, built once per design.

    ``params``: the controller's model as the step receives it (the LQR pieces
    are designed on it, see :func:`~maglev_ocp.controllers.nmpc.design.make_design`).
    """
    key = None if params is None else tuple(params.vector().tolist())
    return _step_functions(settings.model_dump_json(), mode, key)


@functools.lru_cache(maxsize=32)
def _step_functions(
    settings_json: str, mode: str, pvec: tuple[float, ...] | None
) -> tuple[ca.Function, ca.Function, StepBuilder]:
    params = None if pvec is None else Params.from_vector(np.asarray(pvec))
    b = StepBuilder(NMPCSettings.model_validate_json(settings_json), mode, params)
    return b.build_init(), b.build_step(), b


__all__ = ["StepBuilder", "build_init", "build_prep", "build_qp_export", "build_step", "fn_head", "step_functions"]
