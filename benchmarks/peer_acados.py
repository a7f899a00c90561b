"""Peer comparison: our compiled NMPC step against acados (SQP_RTI + HPIPM) on the same OCP, interleaved.

The same OCP on both sides:

* model: the NMPC's prediction model, i.e. the shared CasADi model's RK4 over
  one 1 ms period plus the observer's acceleration disturbance
  (``StepBuilder.F``, the very expression our step linearizes), given to
  acados as a ``DISCRETE`` dynamics expression (acados differentiates it
  exactly; ours uses a third-order Taylor transition matrix);
* horizon ``N`` and period 1 ms;
* cost: ``sum_k 1/2 |x_k - xref_k|_Q + 1/2 |u_k - uref_k|_R`` plus the LQR
  terminal weight ``P``, with the references our step computes (its planner
  and feed-forward currents, read from its ``nmpc_prep`` Function at every
  step). acados scales each stage cost by the time step, so its stage weights
  (and slack penalties) are ours divided by ``Ts``; the terminal cost is not scaled;
* constraints: ``|i_q|, |i_d| <= 8 A`` (box) and ``i_q^2 + i_d^2 <= 8^2``
  (nonlinear, linearized in each RTI), gap soft-bounded to [g_min, g_max] at
  every ``stride``-th stage with the same exact (L1) and quadratic penalties;
* initial state and disturbance: our observer's estimate at that step;
* warm start: both shift their previous solution by one period.

Procedure: (1) our compiled NMPC (C backend) drives the plant through a tour
of target steps and every OCP instance is recorded (our step's inputs, and the
instance as acados needs it); (2) the recorded instances are replayed, each
solved by both, alternating which goes first (interleaved, so machine load and
cache state hit both alike); acados warm-starts from its own previous solution
shifted by one period, as our step does. Only the two solver calls are timed
(wall clock and thread CPU time). Reported: median, p99 and max of each, the
ratios, and how far acados's first current is from ours (same problem: they
agree to micro-amperes once the ADMM has converged). ``--realtime`` runs the
replay under SCHED_FIFO, as a rig's control loop would (other processes on a
shared machine otherwise preempt either solver for milliseconds).

acados options: SQP_RTI, Gauss-Newton, HPIPM. Its best configuration measured here
is the default: FULL_CONDENSING_HPIPM, hpipm_mode SPEED, QP warm start (median
196 µs, p99 605 µs in blocks of 50 steps under SCHED_FIFO, against 358 / 839 for
PARTIAL_CONDENSING_HPIPM SPEED, 260 / 432 for FULL_CONDENSING SPEED_ABS without
warm start, 730 / 1164 for PARTIAL_CONDENSING BALANCE).

Run::

    make peer                                                        # N = 20, table
    make peer PEER_ARGS='--realtime --json out.json'                  # SCHED_FIFO, also the numbers

acados (``comma-deps-acados``) lives in its own environment, built and used by
``make peer`` (``.venv-peer/``): its wheel replaces CasADi's core library, which
must not happen to the project's ``.venv``. When acados is not installed this
prints why and exits 0 (skipped).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))


def setup_acados() -> str | None:
    """Make acados importable (env vars, libraries preloaded); return ``None`` or why it is not available."""
    try:
        import acados  # comma-deps-acados
    except ImportError:
        return "acados is not installed (run `make peer`: it builds .venv-peer with comma-deps-acados)"
    os.environ.setdefault("ACADOS_SOURCE_DIR", acados.DIR)
    os.environ.setdefault("ACADOS_PYTHON_INTERFACE_PATH", acados.TEMPLATE_DIR)
    os.environ.setdefault("TERA_PATH", acados.TERA_PATH)
    # libacados has no run path: load its dependencies globally first
    for lib in ("libblasfeo.so", "libhpipm.so", "libqpOASES_e.so"):
        path = os.path.join(acados.LIB_DIR, lib)
        if os.path.exists(path):
            ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
    try:
        import acados.acados_template
    except Exception as err:  # pragma: no cover - broken install
        return f"acados_template does not import: {err}"
    return None


def summary(us: np.ndarray) -> dict[str, float]:
    """Median, p99 and max of a timing series [µs]."""
    us = np.asarray(us, dtype=float)
    return {
        "median_us": float(np.median(us)),
        "p99_us": float(np.percentile(us, 99)),
        "max_us": float(us.max()),
        "n": int(us.size),
    }


@dataclass
class PeerResult:
    """Timings of both solvers over the same closed loop.

    Attributes
    ----------
    ours, ours_cpu : dict
        Our compiled step (observer + planner + RTI + ADMM QP + shift): wall clock and thread CPU time [µs].
    acados_wall, acados_cpu, acados_internal : dict
        acados ``solve()``: wall clock and thread CPU time around the call, and its own ``time_tot`` [µs].
    ratio_median, ratio_p99 : float
        Ours divided by acados (wall).
    u_diff_A : dict
        ``|u_ours - u_acados|`` (infinity norm, first control) median / p99 / max [A].
    settings : dict
        Horizon, QP solver options, driver, steps, load average.
    """

    ours: dict
    ours_cpu: dict
    acados_wall: dict
    acados_cpu: dict
    acados_internal: dict
    ratio_median: float
    ratio_p99: float
    u_diff_A: dict
    settings: dict = field(default_factory=dict)
    settled: bool | None = None

    def table(self) -> str:
        """Text table of the comparison."""
        rows = [
            ("ours: C step, wall", self.ours),
            ("acados: solve(), wall", self.acados_wall),
            ("acados: time_tot", self.acados_internal),
            ("ours: C step, CPU", self.ours_cpu),
            ("acados: solve(), CPU", self.acados_cpu),
        ]
        s = self.settings
        lines = [
            f"N = {s['N']}, {s['steps']} steps after {s['warmup']} warm-up, interleaved every "
            f"{s.get('block', 1)} step(s), "
            f"acados {s['qp_solver']} ({s['hpipm_mode']}), ours {s['admm_iterations']} ADMM iterations "
            f"({s['cflags']}), load average {s['loadavg']}, "
            f"{'SCHED_FIFO' if s.get('realtime') else 'normal priority'}",
            f"{'':<26} {'median [µs]':>12} {'p99 [µs]':>10} {'max [µs]':>10}",
        ]
        for name, d in rows:
            lines.append(f"{name:<26} {d['median_us']:12.1f} {d['p99_us']:10.1f} {d['max_us']:10.1f}")
        lines.append(
            f"ratio ours / acados (wall): median {self.ratio_median:.2f}, p99 {self.ratio_p99:.2f}; "
            f"(CPU): median {self.ours_cpu['median_us'] / self.acados_cpu['median_us']:.2f}, "
            f"p99 {self.ours_cpu['p99_us'] / self.acados_cpu['p99_us']:.2f}"
        )
        u = self.u_diff_A
        lines.append(f"|u_ours - u_acados| [A]: median {u['median']:.3g}, p99 {u['p99']:.3g}, max {u['max']:.3g}")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike) -> Path:
        """Write the result as JSON (atomically)."""
        from maglev_ocp.output import atomic_write_text

        atomic_write_text(path, json.dumps(asdict(self), indent=2) + "\n")
        return Path(path)


def build_acados(
    builder, p_vec: np.ndarray, build_dir: Path, qp_solver: str, hpipm_mode: str, qp_iter_max: int, warm_start: int
):
    """An acados SQP_RTI solver for the OCP of ``builder`` (a :class:`maglev_ocp.controllers.nmpc.StepBuilder`)."""
    import casadi as ca
    from acados.acados_template import AcadosModel, AcadosOcp, AcadosOcpSolver

    from maglev_ocp import constants as k

    cfg = builder.settings
    N, Ts, np_ = cfg.horizon, k.Ts, len(p_vec)
    model = AcadosModel()
    model.name = f"maglev_peer_N{N}"
    x, u, pp = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("pw", np_ + 2)
    model.x, model.u, model.p = x, u, pp
    model.disc_dyn_expr = builder.F(x, u, pp[:np_], pp[np_:])  # the NMPC's own prediction expression
    model.con_h_expr = u[0] ** 2 + u[1] ** 2  # current disk
    ocp = AcadosOcp()
    ocp.model = model
    ocp.dims.N = N
    ocp.solver_options.tf = N * Ts
    ocp.cost.cost_type = "LINEAR_LS"
    ocp.cost.cost_type_e = "LINEAR_LS"
    Vx = np.zeros((6, 4))
    Vx[:4, :4] = np.eye(4)
    Vu = np.zeros((6, 2))
    Vu[4:, :] = np.eye(2)
    ocp.cost.Vx, ocp.cost.Vu = Vx, Vu
    ocp.cost.W = np.diag([*cfg.Q, *cfg.R]) / Ts  # acados multiplies stage costs by the time step
    ocp.cost.yref = np.zeros(6)
    ocp.cost.Vx_e = np.eye(4)
    ocp.cost.W_e = np.asarray(builder.P)
    ocp.cost.yref_e = np.zeros(4)
    c = ocp.constraints
    c.x0 = np.array([0.02, 0.0, 0.0, 0.0])
    c.lbu, c.ubu, c.idxbu = -np.full(2, cfg.i_box), np.full(2, cfg.i_box), np.array([0, 1])
    c.lh, c.uh = np.array([0.0]), np.array([cfg.current_limit**2])
    # soft gap bound (in metres: our penalties are per mm and per mm^2)
    w1, w2 = cfg.soft_gap.w_linear * 1e3, cfg.soft_gap.w_quadratic * 1e6
    c.idxbx, c.lbx, c.ubx, c.idxsbx = (
        np.array([0]),
        np.array([cfg.soft_gap.g_min]),
        np.array([cfg.soft_gap.g_max]),
        np.array([0]),
    )
    ocp.cost.zl = ocp.cost.zu = np.array([w1]) / Ts
    ocp.cost.Zl = ocp.cost.Zu = np.array([w2]) / Ts
    c.idxbx_e, c.lbx_e, c.ubx_e, c.idxsbx_e = (
        np.array([0]),
        np.array([cfg.soft_gap.g_min]),
        np.array([cfg.soft_gap.g_max]),
        np.array([0]),
    )
    ocp.cost.zl_e = ocp.cost.zu_e = np.array([w1])
    ocp.cost.Zl_e = ocp.cost.Zu_e = np.array([w2])
    ocp.parameter_values = np.concatenate([p_vec, [0.0, 0.0]])
    o = ocp.solver_options
    o.integrator_type = "DISCRETE"
    o.nlp_solver_type = "SQP_RTI"
    o.hessian_approx = "GAUSS_NEWTON"
    o.qp_solver = qp_solver
    o.hpipm_mode = hpipm_mode
    o.qp_solver_iter_max = qp_iter_max
    o.qp_solver_warm_start = warm_start
    o.print_level = 0
    build_dir.mkdir(parents=True, exist_ok=True)
    ocp.code_export_directory = str(build_dir / "c_generated_code")
    cwd = os.getcwd()
    os.chdir(build_dir)  # acados writes its json and builds relative to the working directory
    try:
        solver = AcadosOcpSolver(ocp, json_file=str(build_dir / "acados_ocp.json"), verbose=False)
    finally:
        os.chdir(cwd)
    # stages without a gap bound: bounds far outside the stroke (inactive)
    gap = set(cfg.gap_stages)
    for kk in range(1, N):
        if kk not in gap:
            solver.constraints_set(kk, "lbx", np.array([-1.0]))
            solver.constraints_set(kk, "ubx", np.array([1.0]))
    if N not in gap:
        solver.constraints_set(N, "lbx", np.array([-1.0]))
        solver.constraints_set(N, "ubx", np.array([1.0]))
    return solver


DEFAULT_TOUR = [
    (0.020, 0.000, 0.10),
    (0.016, 0.045, 0.25),
    (0.024, -0.045, 0.25),
    (0.015, 0.000, 0.20),
    (0.025, 0.050, 0.25),
    (0.020, 0.000, 0.20),
]


def record_loop(ours, prep, io: dict, N: int, seed: int, progress: bool) -> dict[str, np.ndarray]:
    """Phase 1: our compiled NMPC drives the plant through :data:`DEFAULT_TOUR`; record every OCP instance.

    Per step: our step's inputs (``state_in, meas, ref``) and the instance as acados needs it (initial
    state and disturbance from our observer, the references from our planner, via ``nmpc_prep``).
    """
    from tqdm.auto import tqdm

    from maglev_ocp import constants as k
    from maglev_ocp.blocks import Reference
    from maglev_ocp.params import NOMINAL
    from maglev_ocp.plant import Plant, PlantConfig

    plant = Plant(PlantConfig.from_profile("default"), params=NOMINAL, seed=seed)
    y = plant.reset()
    ours.reset(y, Reference(DEFAULT_TOUR[0][0], DEFAULT_TOUR[0][1]))
    rec: dict[str, list] = {n: [] for n in ("state", "meas", "ref", "xhat", "w", "Xref", "Uref", "u")}
    n_total = sum(round(h / k.Ts) for _, _, h in DEFAULT_TOUR)
    bar = tqdm(total=n_total, desc=f"record N={N}", unit="step", disable=not progress, leave=False)
    for g_t, d_t, hold in DEFAULT_TOUR:
        ref = Reference(g_t, d_t)
        for _ in range(round(hold / k.Ts)):
            ref_mat = ours.reference.matrix("plan", y.t, ref)
            meas = np.array([y.y[0], y.y[1], 0.0])
            outs = prep(ours.state, meas, ref_mat, ours.p)
            rec["state"].append(ours.state.copy())
            rec["meas"].append(meas)
            rec["ref"].append(np.ravel(ref_mat, order="F"))
            for key in ("xhat", "w"):
                rec[key].append(outs[io[key]].copy())
            rec["Xref"].append(outs[io["Xref"]].reshape(N + 1, 4).copy())
            rec["Uref"].append(outs[io["Uref"]].reshape(N, 2).copy())
            out = ours.step(y, ref)
            rec["u"].append(out.u.copy())
            y = plant.step(out.u)
            bar.update(1)
    bar.close()
    err = abs(plant.x[0] - DEFAULT_TOUR[-1][0]) + abs(plant.x[2] - DEFAULT_TOUR[-1][1])
    data = {key: np.array(v) for key, v in rec.items()}
    data["final_error_m"] = np.array(err)
    return data


def replay_interleaved(
    fn, solver, data: dict, p_vec: np.ndarray, N: int, realtime: bool, progress: bool, block: int = 1
) -> dict[str, np.ndarray]:
    """Phase 2: every recorded instance solved by both, alternating which goes first; both timed.

    ``fn`` is our compiled ``nmpc_step`` (:class:`maglev_ocp.codegen.loader.CompiledFunction`), fed the
    recorded inputs; acados gets the same instance and warm-starts from its own previous solution,
    shifted by one period (as our step does internally). Only the two solver calls are timed.
    ``block = 1``: the two alternate every step (each runs right after the other and after the Python
    glue, i.e. with cold caches); ``block = B``: they alternate every ``B`` steps (each runs ``B`` steps
    in a row, closer to a dedicated control loop).
    """
    from tqdm.auto import tqdm

    from maglev_ocp.codegen.bench import realtime_priority

    n = len(data["meas"])
    out = {key: np.zeros(n) for key in ("t_ours", "c_ours", "t_ac", "c_ac", "t_ac_int", "udiff", "udiff_rec")}
    u_ours, u_ac = np.zeros((n, 2)), np.zeros((n, 2))
    perf, cpu = time.perf_counter, time.thread_time

    def timed(call, i: int, wall: str, cpu_key: str) -> None:
        """``call()``, its wall and thread CPU time [µs] into ``out[wall][i]``, ``out[cpu_key][i]``."""
        c0 = cpu()
        t0 = perf()
        call()
        t1 = perf()
        c1 = cpu()
        out[wall][i], out[cpu_key][i] = (t1 - t0) * 1e6, (c1 - c0) * 1e6

    def ours_step(i: int) -> None:
        fn.args[0][:] = data["state"][i]
        fn.args[1][:] = data["meas"][i]
        fn.args[2][:] = data["ref"][i]
        fn.args[3][:] = p_vec
        timed(fn.call_raw, i, "t_ours", "c_ours")
        u_ours[i] = fn.res[0]

    def acados_step(i: int) -> None:
        Xref, Uref = data["Xref"][i], data["Uref"][i]
        pw = np.concatenate([p_vec, data["w"][i]])
        for kk in range(N):
            solver.set(kk, "yref", np.concatenate([Xref[kk], Uref[kk]]))
            solver.set(kk, "p", pw)
        solver.set(N, "yref", Xref[N])
        solver.set(N, "p", pw)
        solver.set(0, "lbx", data["xhat"][i])
        solver.set(0, "ubx", data["xhat"][i])
        timed(solver.solve, i, "t_ac", "c_ac")
        out["t_ac_int"][i] = float(np.ravel(solver.get_stats("time_tot"))[0]) * 1e6
        u_ac[i] = solver.get(0, "u")
        xs = [solver.get(kk, "x") for kk in range(N + 1)]
        us = [solver.get(kk, "u") for kk in range(N)]
        for kk in range(N):  # warm start: shift by one period
            solver.set(kk, "x", xs[kk + 1])
            solver.set(kk, "u", us[min(kk + 1, N - 1)])

    bar = tqdm(total=n, desc=f"replay N={N}", unit="step", disable=not progress or realtime, leave=False)
    block = max(int(block), 1)
    with realtime_priority(realtime) as rt:
        for j, i0 in enumerate(range(0, n, block)):
            idx = range(i0, min(i0 + block, n))
            order = (ours_step, acados_step) if j % 2 == 0 else (acados_step, ours_step)  # alternate
            if block == 1:
                for f in order:
                    f(i0)
            else:
                for f in order:
                    for i in idx:
                        f(i)
            bar.update(len(idx))
    bar.close()
    out["u_ours"], out["u_acados"] = u_ours, u_ac
    out["udiff"] = np.max(np.abs(u_ac - u_ours), axis=1)
    out["udiff_rec"] = np.max(np.abs(u_ours - data["u"]), axis=1)
    out["realtime"] = np.array(bool(rt))
    return out


def run(
    N: int = 20,
    qp_solver: str = "FULL_CONDENSING_HPIPM",
    hpipm_mode: str = "SPEED",
    qp_iter_max: int = 50,
    warm_start: int = 1,
    warmup: int = 50,
    build_dir: str | None = None,
    iterations: int | None = None,
    progress: bool = True,
    seed: int = 7,
    realtime: bool = False,
    cflags: str | None = None,
    block: int = 1,
    dump: str | None = None,
) -> PeerResult:
    """Record the closed loop, then replay it interleaved (see the module docstring and
    :func:`replay_interleaved` for ``block``)."""
    from maglev_ocp.codegen.backend import build_c_controller
    from maglev_ocp.controllers.nmpc import NMPCSettings, step_functions
    from maglev_ocp.fastcall import BufferedFunction
    from maglev_ocp.params import NOMINAL

    why = setup_acados()
    if why:
        raise RuntimeError(why)
    upd = {"horizon": N, "reference": "plan"}
    if iterations is not None:
        upd["iterations"] = iterations
    settings = NMPCSettings(**upd)
    ours = build_c_controller("nmpc", settings, NOMINAL, cflags=cflags, progress=progress)
    ours.prepare("plan")  # compiles the step before anything is timed
    _, _, b = step_functions(settings, "plan")
    prep = BufferedFunction(b.build_prep())
    names = prep.f.name_out()
    io = {n: names.index(n) for n in ("xhat", "w", "Xref", "Uref")}
    p_vec = ours.p
    bdir = Path(build_dir) if build_dir else ROOT / "build" / "peer_acados" / f"N{N}_{qp_solver}_{hpipm_mode}"
    solver = build_acados(b, p_vec, bdir.resolve(), qp_solver, hpipm_mode, qp_iter_max, warm_start)

    data = record_loop(ours, prep, io, N, seed, progress)
    fn = ours.step_evaluator  # the very object the NMPC (and the runner, maglev bench) calls
    r = replay_interleaved(fn, solver, data, p_vec, N, realtime, progress, block)
    if dump:  # the instances and both solutions, for the accuracy against the exact QP (benchmarks/qp_peers.py)
        np.savez(
            dump,
            **{key: data[key] for key in ("state", "meas", "ref")},
            **{key: r[key] for key in ("u_ours", "u_acados", "t_ours", "t_ac", "c_ours", "c_ac")},
            p=p_vec,
            warmup=warmup,
        )
    sl = slice(warmup, None)
    o, a, ai = summary(r["t_ours"][sl]), summary(r["t_ac"][sl]), summary(r["t_ac_int"][sl])
    oc, ac = summary(r["c_ours"][sl]), summary(r["c_ac"][sl])
    ud = r["udiff"][sl]
    if float(np.max(r["udiff_rec"])) > 0:  # replaying our recorded inputs must give the recorded currents
        raise RuntimeError(f"replay of our step differs from the live run by {np.max(r['udiff_rec'])} A")
    from maglev_ocp import constants as k

    return PeerResult(
        ours=o,
        ours_cpu=oc,
        acados_wall=a,
        acados_cpu=ac,
        acados_internal=ai,
        ratio_median=o["median_us"] / a["median_us"],
        ratio_p99=o["p99_us"] / a["p99_us"],
        u_diff_A={"median": float(np.median(ud)), "p99": float(np.percentile(ud, 99)), "max": float(ud.max())},
        settings={
            "N": N,
            "driver": "ours (recorded), replayed interleaved",
            "block": block,
            "qp_solver": qp_solver,
            "hpipm_mode": hpipm_mode,
            "qp_iter_max": qp_iter_max,
            "qp_warm_start": warm_start,
            "admm_iterations": settings.iterations,
            "steps": len(r["t_ours"]) - warmup,
            "warmup": warmup,
            "cflags": ours.evaluators.builds["plan"].cflags,
            "loadavg": [round(v, 2) for v in os.getloadavg()],
            "tour": DEFAULT_TOUR,
            "realtime": bool(r["realtime"]),
        },
        settled=bool(float(data["final_error_m"]) < 2 * k.position_tolerance),
    )


def main(argv=None) -> int:
    """Command line of the peer comparison."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--horizon", "-N", type=int, default=20)
    ap.add_argument(
        "--qp-solver", default="FULL_CONDENSING_HPIPM", choices=("PARTIAL_CONDENSING_HPIPM", "FULL_CONDENSING_HPIPM")
    )
    ap.add_argument("--hpipm-mode", default="SPEED", choices=("SPEED_ABS", "SPEED", "BALANCE", "ROBUST"))
    ap.add_argument("--iterations", type=int, default=None, help="ADMM iterations of our step (default: settings)")
    ap.add_argument("--realtime", action="store_true", help="time the loop under SCHED_FIFO (as on a rig; root)")
    ap.add_argument(
        "--block",
        type=int,
        default=1,
        help="alternate the solvers every BLOCK steps (1: every step, caches cold for both)",
    )
    ap.add_argument("--cflags", default=None, help="compiler flags of our step (default: the C backend's)")
    ap.add_argument("--json", default=None, metavar="FILE", help="also write the result as JSON")
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument("--dump", default=None, metavar="FILE.npz", help="save the instances and both solutions")
    args = ap.parse_args(argv)
    why = setup_acados()
    if why:
        print(f"peer_acados: skipped: {why}")
        return 0
    if not math.isfinite(args.horizon) or not 4 <= args.horizon <= 80:
        print("peer_acados: --horizon must be in 4..80", file=sys.stderr)
        return 2
    res = run(
        N=args.horizon,
        qp_solver=args.qp_solver,
        hpipm_mode=args.hpipm_mode,
        iterations=args.iterations,
        progress=not args.no_progress,
        realtime=args.realtime,
        cflags=args.cflags,
        block=args.block,
        dump=args.dump,
    )
    print(res.table())
    if args.json:
        res.save(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
