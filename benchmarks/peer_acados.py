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

The loop: our compiled NMPC (C backend) drives the plant through a tour of
target steps; at every period acados solves the same OCP instance (RTI, one
QP) and both are timed, in alternating order (interleaved, so machine load
hits both alike). Reported: median, p99 and max of each, the ratios, and how
far acados's first current is from ours (same problem: they should be close).
With ``--driver acados`` acados's currents drive the plant instead (its own
closed loop, our step shadowing).

Run::

    .venv/bin/python benchmarks/peer_acados.py                  # N = 20, table
    .venv/bin/python benchmarks/peer_acados.py --json out.json  # also the numbers

acados comes from the optional extra (``pip install comma-deps-acados``); when
it is not installed this prints why and exits 0 (skipped).
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
        return "acados is not installed (pip install comma-deps-acados, the optional 'peer' extra)"
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
    """Median, p99 and max of a timing series [us]."""
    us = np.asarray(us, dtype=float)
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)), "max_us": float(us.max()),
            "n": int(us.size)}


@dataclass
class PeerResult:
    """Timings of both solvers over the same closed loop.

    Attributes
    ----------
    ours, ours_cpu : dict
        Our compiled step (observer + planner + RTI + ADMM QP + shift): wall clock and thread CPU time [us].
    acados_wall, acados_cpu, acados_internal : dict
        acados ``solve()``: wall clock and thread CPU time around the call, and its own ``time_tot`` [us].
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
        rows = [("ours: C step, wall", self.ours), ("acados: solve(), wall", self.acados_wall),
                ("acados: time_tot", self.acados_internal), ("ours: C step, CPU", self.ours_cpu),
                ("acados: solve(), CPU", self.acados_cpu)]
        s = self.settings
        lines = [f"N = {s['N']}, {s['steps']} steps after {s['warmup']} warm-up, driver: {s['driver']}, "
                 f"acados {s['qp_solver']} ({s['hpipm_mode']}), load average {s['loadavg']}",
                 f"{'':<26} {'median [us]':>12} {'p99 [us]':>10} {'max [us]':>10}"]
        for name, d in rows:
            lines.append(f"{name:<26} {d['median_us']:12.1f} {d['p99_us']:10.1f} {d['max_us']:10.1f}")
        lines.append(f"ratio ours / acados (wall): median {self.ratio_median:.2f}, p99 {self.ratio_p99:.2f}; "
                     f"(CPU): median {self.ours_cpu['median_us'] / self.acados_cpu['median_us']:.2f}, "
                     f"p99 {self.ours_cpu['p99_us'] / self.acados_cpu['p99_us']:.2f}")
        u = self.u_diff_A
        lines.append(f"|u_ours - u_acados| [A]: median {u['median']:.3g}, p99 {u['p99']:.3g}, max {u['max']:.3g}")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike) -> Path:
        """Write the result as JSON (atomically)."""
        from maglev_ocp.config import atomic_write_text

        atomic_write_text(path, json.dumps(asdict(self), indent=2) + "\n")
        return Path(path)


def build_acados(builder, p_vec: np.ndarray, build_dir: Path, qp_solver: str, hpipm_mode: str,
                 qp_iter_max: int, warm_start: int):
    """An acados SQP_RTI solver for the OCP of ``builder`` (a :class:`controllers.nmpc_step.StepBuilder`)."""
    import casadi as ca
    from acados.acados_template import AcadosModel, AcadosOcp, AcadosOcpSolver

    cfg = builder.cfg
    N, Ts, np_ = cfg.N, cfg.Ts, len(p_vec)
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
    c.lh, c.uh = np.array([0.0]), np.array([cfg.i_max**2])
    # soft gap bound (in metres: our penalties are per mm and per mm^2)
    w1, w2 = cfg.soft_w1 * 1e3, cfg.soft_w2 * 1e6
    c.idxbx, c.lbx, c.ubx, c.idxsbx = np.array([0]), np.array([cfg.gap_lo]), np.array([cfg.gap_hi]), np.array([0])
    ocp.cost.zl = ocp.cost.zu = np.array([w1]) / Ts
    ocp.cost.Zl = ocp.cost.Zu = np.array([w2]) / Ts
    c.idxbx_e, c.lbx_e, c.ubx_e, c.idxsbx_e = (np.array([0]), np.array([cfg.gap_lo]), np.array([cfg.gap_hi]),
                                                np.array([0]))
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


DEFAULT_TOUR = [(0.020, 0.000, 0.10), (0.016, 0.045, 0.25), (0.024, -0.045, 0.25), (0.015, 0.000, 0.20),
                (0.025, 0.050, 0.25), (0.020, 0.000, 0.20)]


def run(N: int = 20, driver: str = "ours", qp_solver: str = "PARTIAL_CONDENSING_HPIPM", hpipm_mode: str = "SPEED",
        qp_iter_max: int = 50, warm_start: int = 1, warmup: int = 50, build_dir: str | None = None,
        iterations: int | None = None, progress: bool = True, seed: int = 7) -> PeerResult:
    """Run the interleaved comparison (see the module docstring)."""
    from tqdm.auto import tqdm

    from controllers.nmpc import NMPCSettings, step_functions
    from maglev_ocp import constants as k
    from maglev_ocp.blocks import Reference
    from maglev_ocp.codegen.backend import build_c_controller
    from maglev_ocp.fastcall import BufferedFunction
    from maglev_ocp.params import NOMINAL
    from maglev_ocp.plant import Plant, PlantConfig

    why = setup_acados()
    if why:
        raise RuntimeError(why)
    upd = {"horizon": N, "reference": "plan"}
    if iterations is not None:
        upd["iterations"] = iterations
    settings = NMPCSettings(**upd)
    ours = build_c_controller("nmpc", settings, NOMINAL, progress=progress)
    cfg = settings.step_config("plan")
    _, _, b = step_functions(cfg)
    prep = BufferedFunction(b.build_prep())
    names = prep.f.name_out()
    io = {n: names.index(n) for n in ("xhat", "w", "Xref", "Uref")}
    p_vec = ours.p
    bdir = Path(build_dir) if build_dir else ROOT / "build" / "peer_acados" / f"N{N}_{qp_solver}_{hpipm_mode}"
    solver = build_acados(b, p_vec, bdir.resolve(), qp_solver, hpipm_mode, qp_iter_max, warm_start)

    plant = Plant(PlantConfig.from_profile("default"), params=NOMINAL, seed=seed)
    y = plant.reset()
    ours.reset(y, Reference(DEFAULT_TOUR[0][0], DEFAULT_TOUR[0][1]))
    n_total = sum(round(h / k.Ts) for _, _, h in DEFAULT_TOUR)
    t_ours, c_ours, t_ac, c_ac, t_ac_int, udiff = [], [], [], [], [], []
    perf, cpu = time.perf_counter, time.thread_time
    bar = tqdm(total=n_total, desc=f"peer N={N}", unit="step", disable=not progress, leave=False)
    i = 0
    for g_t, d_t, hold in DEFAULT_TOUR:
        ref = Reference(g_t, d_t)
        for _ in range(round(hold / k.Ts)):
            # the OCP instance of this period, as our step sees it (same state, reading and reference)
            ref_mat = ours._ref_matrix(y.t, ref)
            meas = np.array([y.y[0], y.y[1], 0.0])
            outs = prep(ours.state, meas, ref_mat, p_vec)
            xhat, w = outs[io["xhat"]], outs[io["w"]]
            Xref = outs[io["Xref"]].reshape(N + 1, 4)
            Uref = outs[io["Uref"]].reshape(N, 2)
            pw = np.concatenate([p_vec, w])
            for kk in range(N):
                solver.set(kk, "yref", np.concatenate([Xref[kk], Uref[kk]]))
                solver.set(kk, "p", pw)
            solver.set(N, "yref", Xref[N])
            solver.set(N, "p", pw)
            solver.set(0, "lbx", xhat)
            solver.set(0, "ubx", xhat)

            def run_acados():
                c0 = cpu()
                t0 = perf()
                solver.solve()
                t1 = perf()
                return (t1 - t0) * 1e6, (cpu() - c0) * 1e6

            if i % 2 == 0:  # alternate the order: both see the same machine state on average
                out = ours.step(y, ref)
                ta, ca_ = run_acados()
            else:
                ta, ca_ = run_acados()
                out = ours.step(y, ref)
            u_ac = solver.get(0, "u")
            t_ours.append(out.stats["kernel_us"])
            c_ours.append(out.stats["kernel_cpu_us"])
            t_ac.append(ta)
            c_ac.append(ca_)
            t_ac_int.append(solver.get_stats("time_tot") * 1e6)
            udiff.append(float(np.max(np.abs(u_ac - out.u))))
            # warm start: shift acados's trajectory by one period (ours shifts inside its step)
            xs = [solver.get(kk, "x") for kk in range(N + 1)]
            us = [solver.get(kk, "u") for kk in range(N)]
            for kk in range(N):
                solver.set(kk, "x", xs[kk + 1])
                solver.set(kk, "u", us[min(kk + 1, N - 1)])
            u_apply = out.u if driver == "ours" else np.clip(u_ac, -k.i_axis_max, k.i_axis_max)
            y = plant.step(u_apply)
            i += 1
            if (i & 31) == 0:
                bar.update(i - bar.n)
    bar.close()
    sl = slice(warmup, None)
    o, a, ai = summary(np.array(t_ours)[sl]), summary(np.array(t_ac)[sl]), summary(np.array(t_ac_int)[sl])
    oc, ac = summary(np.array(c_ours)[sl]), summary(np.array(c_ac)[sl])
    ud = np.array(udiff)[sl]
    err = abs(plant.x[0] - DEFAULT_TOUR[-1][0]) + abs(plant.x[2] - DEFAULT_TOUR[-1][1]) if hasattr(plant, "x") else None
    return PeerResult(
        ours=o, ours_cpu=oc, acados_wall=a, acados_cpu=ac, acados_internal=ai,
        ratio_median=o["median_us"] / a["median_us"], ratio_p99=o["p99_us"] / a["p99_us"],
        u_diff_A={"median": float(np.median(ud)), "p99": float(np.percentile(ud, 99)), "max": float(ud.max())},
        settings={"N": N, "driver": driver, "qp_solver": qp_solver, "hpipm_mode": hpipm_mode,
                  "qp_iter_max": qp_iter_max, "qp_warm_start": warm_start, "admm_iterations": settings.iterations,
                  "steps": len(t_ours) - warmup, "warmup": warmup, "cflags": ours.builds["plan"].cflags,
                  "loadavg": [round(v, 2) for v in os.getloadavg()], "tour": DEFAULT_TOUR},
        settled=None if err is None else bool(err < 2 * k.position_tolerance),
    )


def main(argv=None) -> int:
    """Command line of the peer comparison."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--horizon", "-N", type=int, default=20)
    ap.add_argument("--driver", choices=("ours", "acados"), default="ours")
    ap.add_argument("--qp-solver", default="PARTIAL_CONDENSING_HPIPM",
                    choices=("PARTIAL_CONDENSING_HPIPM", "FULL_CONDENSING_HPIPM"))
    ap.add_argument("--hpipm-mode", default="SPEED", choices=("SPEED_ABS", "SPEED", "BALANCE", "ROBUST"))
    ap.add_argument("--iterations", type=int, default=None, help="ADMM iterations of our step (default: settings)")
    ap.add_argument("--json", default=None, metavar="FILE", help="also write the result as JSON")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    why = setup_acados()
    if why:
        print(f"peer_acados: skipped: {why}")
        return 0
    if not math.isfinite(args.horizon) or not 4 <= args.horizon <= 80:
        print("peer_acados: --horizon must be in 4..80", file=sys.stderr)
        return 2
    res = run(N=args.horizon, driver=args.driver, qp_solver=args.qp_solver, hpipm_mode=args.hpipm_mode,
              iterations=args.iterations, progress=not args.no_progress)
    print(res.table())
    if args.json:
        res.save(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
