"""QP solvers side by side on the same OCP: ours (compiled step), acados/HPIPM, OSQP, DAQP, Clarabel.

One command rebuilds the table::

    python -m benchmarks.qp_peers                      # N = 20, SCHED_FIFO when allowed
    python -m benchmarks.qp_peers --peer-python .venv-peer/bin/python --json out.json

Procedure:

1. ``benchmarks/peer_acados.py`` runs in acados's own environment (``make peer``
   builds ``.venv-peer``): our compiled NMPC drives the plant through its tour,
   every step's inputs are recorded, and the instances are replayed with our step
   and acados (SQP_RTI + HPIPM) interleaved in blocks of 100 steps under
   SCHED_FIFO; the instances, both first controls and both timings are saved.
   Without that environment the tour is recorded here and acados is left out.
2. Here, each instance's QP (``nmpc_qp``: the QP our step solves) is solved
   exactly by Clarabel (:mod:`maglev_ocp.controllers.nmpc.exact_qp`, the disks as cones) and
   by OSQP (the ``solver: osqp`` stage, disks as tangent cuts refined once), by
   OSQP's own generated C of the same QP (``osqp: {embedded: true}``, embedded
   mode 2; timed from Python and its C calls alone) and DAQP (dual active set,
   the same polyhedral QP), each timed around the solver call under SCHED_FIFO.
3. Ours at its worst-case path (tolerances 0: all ``iterations`` and the rho
   refactorization run) is timed on the same instances, and the cost of one
   iteration is the slope between fixed budgets of 1 and ``iterations + 1``.

What is timed differs and the table says so: our step is the *whole* control
step (observer, planner, RTI linearization, QP, shift); acados's ``solve()`` is
its SQP_RTI step (linearization + QP, no observer/planner); OSQP, DAQP and
Clarabel the QP alone (from Python, on the condensed data). Accuracy is
``|u - u*|`` of the first control against Clarabel's solution of the same QP.
acados linearizes the disk (its own RTI), so its QP is not exactly ours.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from benchmarks.qp_accuracy import pct, qp_of_call  # noqa: E402
from maglev_ocp.codegen.bench import realtime_priority  # noqa: E402
from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings, step_functions  # noqa: E402
from maglev_ocp.controllers.nmpc.exact_qp import QPData, solve_exact  # noqa: E402
from maglev_ocp.controllers.nmpc.layout import NU  # noqa: E402
from maglev_ocp.controllers.nmpc.osqp_solver import EmbeddedOSQPStage, OSQPStage  # noqa: E402
from maglev_ocp.fastcall import BufferedFunction  # noqa: E402
from maglev_ocp.params import NOMINAL  # noqa: E402


def record_with_peer(peer_python: str, N: int, out: Path, realtime: bool) -> dict | None:
    """Step 1 in acados's environment; the saved arrays, or ``None`` when acados is not available."""
    if not Path(peer_python).exists():
        return None
    cmd = [peer_python, "-m", "benchmarks.peer_acados", "-N", str(N), "--block", "100", "--no-progress"]
    cmd += ["--dump", str(out / "peer.npz"), "--json", str(out / "peer.json")]
    if realtime:
        cmd.append("--realtime")
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    print(r.stdout, file=sys.stderr)
    if r.returncode != 0 or not (out / "peer.npz").exists():
        print(f"qp_peers: acados peer failed or skipped:\n{r.stderr[-2000:]}", file=sys.stderr)
        return None
    return dict(np.load(out / "peer.npz"))


def record_here(settings: NMPCSettings, seed: int = 7) -> dict:
    """Step 1 without acados: our compiled step drives the peer benchmark's tour; record the instances."""
    from benchmarks.peer_acados import DEFAULT_TOUR
    from maglev_ocp import constants as k
    from maglev_ocp.blocks import Reference
    from maglev_ocp.codegen.backend import build_c_controller
    from maglev_ocp.plant import Plant, PlantConfig

    ours = build_c_controller("nmpc", settings, NOMINAL, progress=False)
    plant = Plant(PlantConfig.from_profile("default"), params=NOMINAL, seed=seed)
    y = plant.reset()
    ours.reset(y, Reference(*DEFAULT_TOUR[0][:2]))
    rec: dict[str, list] = {"state": [], "meas": [], "ref": [], "u_ours": []}
    for g_t, d_t, hold in DEFAULT_TOUR:
        ref = Reference(g_t, d_t)
        for _ in range(round(hold / k.Ts)):
            rec["state"].append(ours.state.copy())
            rec["meas"].append(np.array([y.y[0], y.y[1], 0.0]))
            rec["ref"].append(np.ravel(ours.reference.matrix("plan", y.t, ref), order="F"))
            out = ours.step(y, ref)
            rec["u_ours"].append(out.u.copy())
            y = plant.step(out.u)
    data = {key: np.array(v) for key, v in rec.items()}
    data["p"], data["warmup"] = ours.p, np.array(50)
    return data


def qps_of(data: dict, settings: NMPCSettings) -> list[QPData]:
    """The QP of every recorded instance (``nmpc_qp``)."""
    export = BufferedFunction(step_functions(settings, "plan")[2].build_qp_export())
    return [
        qp_of_call(export, settings, (st, me, rf, data["p"]))
        for st, me, rf in zip(data["state"], data["meas"], data["ref"], strict=True)
    ]


def timed(fn, items, realtime: bool) -> tuple[np.ndarray, list]:
    """Call ``fn`` on each item (in order) under SCHED_FIFO; wall times [µs] and results."""
    t = np.zeros(len(items))
    res = []
    perf = time.perf_counter
    with realtime_priority(realtime):
        for i, it in enumerate(items):
            t0 = perf()
            r = fn(it)
            t[i] = (perf() - t0) * 1e6
            res.append(r)
    return t, res


def osqp_embedded_rows(settings: NMPCSettings, qps: list[QPData], realtime: bool, w: int, err) -> tuple:
    """OSQP's own generated C (``osqp: {embedded: true}``): the stage from Python, and its C calls alone."""
    emb = EmbeddedOSQPStage(settings.model_copy(update={"osqp": settings.osqp.model_copy(update={"embedded": True})}))
    t_c, iters = [], []

    def solve(qp: QPData) -> np.ndarray:
        c0 = emb.c_seconds
        z, _, _, it = emb.solve(qp.H, qp.q, qp.G, qp.glb, qp.gub, qp.ubar)
        t_c.append((emb.c_seconds - c0) * 1e6)
        iters.append(it)
        return z

    t, r = timed(solve, qps, realtime)
    u = [qp.ubar[:NU] + z[:NU] for qp, z in zip(qps, r, strict=True)]
    o = emb.opts
    name = f"OSQP 1.x embedded codegen (C, mode 2: P, A as parameters; no polish, eps {o.abs_tolerance:g})"
    rows = [
        row(name, "QP only (Python glue + C)", t[w:], err(u)),
        row(name.split(" (")[0] + ", its C calls alone", "updates + solves", np.asarray(t_c)[w:], None),
    ]
    it = np.asarray(iters)[w:]
    facts = {"osqp_embedded_iterations_median": float(np.median(it)), "osqp_embedded_iterations_max": float(it.max())}
    return rows, facts


def daqp_solver(settings: NMPCSettings):
    """DAQP (dual active set) on the polyhedral QP of :class:`OSQPStage` (box, tangent cuts, gap slacks)."""
    import daqp

    st = OSQPStage(settings)

    def solve(qp: QPData) -> np.ndarray:
        N = st.N
        U = qp.ubar.reshape(N, NU)
        normals = st.initial_normals(U)
        v = None
        for c in range(st.n_cuts - st.n_poly):
            P, A = st._matrices(qp.H, qp.G, normals)
            lo, hi = st._bounds(qp.ubar, qp.glb, qp.gub, normals)
            Pd = P.toarray()
            Hf = Pd + Pd.T - np.diag(Pd.diagonal())
            f = np.concatenate([qp.q, np.full(qp.ng, qp.w1)])
            x, _, flag, _ = daqp.solve(
                Hf, f, A.toarray(), np.minimum(hi, 1e30), np.maximum(lo, -1e30), np.zeros(hi.size, dtype=np.intc)
            )
            if flag < 1:
                return np.full(qp.nv, np.nan)
            v = x[: qp.nv]
            refined = st.refined_normals(U, v, normals, c)  # st.radius is qp.radius: both the current limit
            if refined is None:
                break
            normals = refined
        return v

    return solve


def ours_variants(settings: NMPCSettings, data: dict, realtime: bool) -> dict[str, np.ndarray]:
    """Our compiled step at its worst-case path and at fixed budgets (per-iteration cost), on the instances."""
    from maglev_ocp.codegen.backend import c_evaluators

    a = settings.admm
    variants = {
        "worst": settings.model_copy(update={"admm": a.model_copy(update={"tol_prim": 1e-300, "tol_dual": 1e-300})}),
        "fixed1": settings.model_copy(update={"iterations": 1, "admm": a.model_copy(update={"early_exit": False})}),
        "fixedN": settings.model_copy(
            update={"iterations": settings.iterations + 1, "admm": a.model_copy(update={"early_exit": False})}
        ),
    }
    out = {}
    for name, s in variants.items():
        ctrl = NMPC(s, NOMINAL, evaluators=c_evaluators(progress=False))
        ctrl.prepare("plan")
        f = ctrl.step_evaluator

        def call(i, f=f):
            f.args[0][:] = data["state"][i]
            f.args[1][:] = data["meas"][i]
            f.args[2][:] = data["ref"][i]
            f.args[3][:] = data["p"]
            t0 = time.perf_counter()
            f.call_raw()
            return (time.perf_counter() - t0) * 1e6

        with realtime_priority(realtime):
            out[name] = np.array([call(i) for i in range(len(data["meas"]))])
    return out


def row(name: str, what: str, t: np.ndarray | None, du: np.ndarray | None) -> dict:
    """One table row: timing percentiles [µs] and accuracy [A]."""
    r = {"solver": name, "timed": what}
    if t is not None:
        r["time_us"] = pct(t, True)
    if du is not None:
        r["u_err_A"] = pct(du, True)
    return r


def table(rows: list[dict]) -> str:
    """Markdown table of the rows."""
    lines = [
        "| solver | timed | median [µs] | p99 | p99.9 | max | \\|u-u*\\| median [A] | p99 | max |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        t, u = r.get("time_us"), r.get("u_err_A")
        ts = f"{t['median']:.1f} | {t['p99']:.1f} | {t['p99.9']:.1f} | {t['max']:.1f}" if t else "- | - | - | -"
        us = f"{u['median']:.1e} | {u['p99']:.1e} | {u['max']:.1e}" if u else "- | - | -"
        lines.append(f"| {r['solver']} | {r['timed']} | {ts} | {us} |")
    return "\n".join(lines)


def run(
    N: int = 20, peer_python: str | None = None, realtime: bool = True, work: str | None = None
) -> tuple[list[dict], dict]:
    """Steps 1-3 of the module docstring; the table rows and the facts below it.

    ``work``: keep step 1's files there, and reuse them if they exist (skips the acados run).
    """
    settings = NMPCSettings(horizon=N, reference="plan")
    with tempfile.TemporaryDirectory() as tmp:
        wd = Path(work or tmp)
        wd.mkdir(parents=True, exist_ok=True)
        if (wd / "peer.npz").exists():
            data = dict(np.load(wd / "peer.npz"))
        else:
            data = record_with_peer(peer_python or str(ROOT / ".venv-peer" / "bin" / "python"), N, wd, realtime)
        peer = json.loads((wd / "peer.json").read_text()) if data is not None else None
    if data is None:
        data = record_here(settings)
    w = int(data["warmup"])
    qps = qps_of(data, settings)
    t_ex, exact = timed(solve_exact, qps, realtime)
    u_star = np.array([qp.ubar[:NU] + ex.v[:NU] for qp, ex in zip(qps, exact, strict=True)])
    kkt_ok = all(ex.status in ("Solved", "AlmostSolved") for ex in exact)

    def err(u):
        return np.max(np.abs(np.asarray(u) - u_star), axis=1)[w:]

    t_ours = data["t_ours"][w:] if "t_ours" in data else None
    rows = [row("ours (ADMM, C), interleaved with acados", "whole NMPC step", t_ours, err(data["u_ours"]))]
    if "t_ac" in data:
        rows.append(
            row(
                "acados SQP_RTI + HPIPM, interleaved", "solve(): RTI step + QP", data["t_ac"][w:], err(data["u_acados"])
            )
        )
    osqp_stage = OSQPStage(settings)
    t_osqp, r_osqp = timed(lambda qp: osqp_stage.solve(qp.H, qp.q, qp.G, qp.glb, qp.gub, qp.ubar)[0], qps, realtime)
    u_osqp = [qp.ubar[:NU] + z[:NU] for qp, z in zip(qps, r_osqp, strict=True)]
    rows.append(row("OSQP 1.x (Python, polished, octagon + 6 cut passes)", "QP only", t_osqp[w:], err(u_osqp)))
    emb_rows, emb_facts = osqp_embedded_rows(settings, qps, realtime, w, err)
    rows += emb_rows
    t_daqp, r_daqp = timed(daqp_solver(settings), qps, realtime)
    u_daqp = [qp.ubar[:NU] + v[:NU] for qp, v in zip(qps, r_daqp, strict=True)]
    rows.append(row("DAQP (Python, same polyhedral QP)", "QP only", t_daqp[w:], err(u_daqp)))
    rows.append(row("Clarabel (exact reference, SOC, tol 1e-11)", "QP only", t_ex[w:], None))
    var = ours_variants(settings, data, realtime)
    per_iter = (np.median(var["fixedN"]) - np.median(var["fixed1"])) / settings.iterations
    rows.append(
        row(
            f"ours, worst-case path ({settings.iterations} iterations + refactorization)",
            "whole NMPC step",
            var["worst"][w:],
            None,
        )
    )
    facts = {
        "N": N,
        "instances": len(qps) - w,
        "exact_all_solved": kkt_ok,
        "ours_iterations_max": settings.iterations,
        "ours_per_iteration_us": float(per_iter),
        "ours_fixed1_median_us": float(np.median(var["fixed1"])),
        "wcet_bound_us": float(np.median(var["fixed1"]) + settings.iterations * per_iter),
        "worst_path_max_us": float(var["worst"][w:].max()),
        "peer": peer,
        "realtime": realtime,
        **emb_facts,
    }
    return rows, facts


def main(argv=None) -> int:
    """Command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--horizon", "-N", type=int, default=20)
    ap.add_argument("--peer-python", default=None, help="python of acados's environment (default .venv-peer)")
    ap.add_argument("--no-realtime", action="store_true", help="do not time under SCHED_FIFO")
    ap.add_argument("--json", default=None, metavar="FILE")
    ap.add_argument("--work", default=None, metavar="DIR", help="keep (and reuse) the acados run's files there")
    args = ap.parse_args(argv)
    rows, facts = run(args.horizon, args.peer_python, not args.no_realtime, args.work)
    print(table(rows))
    f = facts
    print(
        f"\nN = {f['N']}, {f['instances']} instances of the tour; ours: at most {f['ours_iterations_max']} ADMM "
        f"iterations, {f['ours_per_iteration_us']:.2f} us per iteration (slope of fixed budgets), step without "
        f"iterations {f['ours_fixed1_median_us']:.1f} us: worst case ~ {f['wcet_bound_us']:.0f} us + one "
        f"refactorization (measured worst-case path max {f['worst_path_max_us']:.0f} us); "
        f"{'SCHED_FIFO' if f['realtime'] else 'normal priority'}"
    )
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "facts": facts}, indent=2, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
