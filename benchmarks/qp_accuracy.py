"""Accuracy of the NMPC's QP step against the exact solution of the same QP, per solver setting.

Every RTI QP of a set of closed loops (a tour, a traverse, gap steps and the two
disturbance scenarios) is recorded: the step's inputs go through
``nmpc_qp`` (:func:`maglev_ocp.controllers.nmpc.step.build_qp_export`), which gives the QP
the step solves as dense data, and the QP is solved to ``1e-9`` by Clarabel
(:func:`maglev_ocp.controllers.nmpc.exact_qp.solve_exact`, the disks as second-order cones:
the reference problem is exactly the QP our ADMM iterates on). For each solver
setting the closed loops are run with that setting (so each setting is judged
on its own trajectory) and reported:

* ``|u - u*|``: infinity norm of the first control (the one applied) against the
  exact one [A], median / p99 / max;
* the cost gap ``f(v) - f(v*)`` (absolute, and relative to ``|f(v*)|`` + 1);
* the constraint violation of the whole planned input sequence (disk) [A].

Run::

    python -m benchmarks.qp_accuracy                         # default settings + fixed 20 iterations
    python -m benchmarks.qp_accuracy --setting iterations=60 --setting admm.tol_prim=1e-3
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings, casadi_evaluators, step_functions  # noqa: E402
from maglev_ocp.controllers.nmpc.exact_qp import QPData, solve_exact  # noqa: E402
from maglev_ocp.controllers.nmpc.layout import NU  # noqa: E402
from maglev_ocp.fastcall import BufferedFunction  # noqa: E402

#: The closed loops whose QPs are recorded (shipped scenarios).
SCENARIOS: tuple[str, ...] = (
    "tour_nmpc",
    "traverse_20mm_nmpc",
    "gap_steps_nmpc",
    "push_g_nmpc",
    "push_d_nmpc",
)


class RecordingEvaluators:
    """Evaluator factory (:class:`maglev_ocp.controllers.nmpc.StepEvaluators`) that records every step call.

    Wraps ``base`` (default the Python backend); ``calls`` holds ``(state_in,
    meas, ref, p, u, state_out, stats)`` per step, ``fns`` the step's Functions.
    """

    def __init__(self, base=casadi_evaluators):
        self.base = base
        self.backend = getattr(base, "backend", "custom")
        self.calls: list[tuple[np.ndarray, ...]] = []
        self.fns = None

    def __call__(self, fns):
        init, step = self.base(fns)
        self.fns = fns

        def rec_step(*args):
            outs = step(*args)
            self.calls.append(tuple(np.array(a, dtype=float).ravel(order="F") for a in (*args, *outs[:3])))
            return outs

        return init, rec_step


def load_scenario(name: str, overrides: dict, reference: dict | None = None):
    """A shipped NMPC scenario with its controller settings updated by ``overrides`` (nested, merged), and its
    planner's settings by ``reference``."""
    from maglev_ocp.scenario import scenario_from_dict

    path = ROOT / "scenarios" / f"{name}.yaml"
    data = yaml.safe_load(path.read_text())
    _merge(data.setdefault("controller", {}), overrides)
    if reference:
        _merge(data.setdefault("reference", {}), reference)
    return scenario_from_dict(data, source=str(path), root_dir=ROOT)


def _merge(dst: dict, src: dict) -> None:
    for key, val in src.items():
        if isinstance(val, dict):
            _merge(dst.setdefault(key, {}), val)
        else:
            dst[key] = val


def record(
    name: str, overrides: dict, evaluators=None, reference: dict | None = None
) -> tuple[RecordingEvaluators, object]:
    """Run scenario ``name`` with the NMPC settings ``overrides`` (and planner settings ``reference``); the
    recorder and the run's result."""
    from maglev_ocp.runner import run_scenario

    sc = load_scenario(name, overrides, reference)
    rec = RecordingEvaluators(evaluators or casadi_evaluators)
    ctrl = NMPC(sc.controller.settings, sc.controller_model_params(), evaluators=rec)
    res = run_scenario(sc, controller=ctrl, progress=False, figures=False)
    return rec, res


def qp_of_call(export: BufferedFunction, settings: NMPCSettings, call) -> QPData:
    """The QP of one recorded step call (``nmpc_qp`` on its inputs)."""
    N, sg = settings.horizon, settings.soft_gap
    H, q, G, glb, gub, ubar = export(*call[:4])
    nv, ng = N * NU, settings.n_gap
    return QPData(
        H=H.reshape(nv, nv, order="F"),
        q=q.ravel(),
        G=G.reshape(ng, nv, order="F"),
        glb=glb.ravel(),
        gub=gub.ravel(),
        ubar=ubar.ravel(),
        radius=settings.current_limit,
        w1=sg.w_linear,
        w2=sg.w_quadratic,
    )


def ours_v(settings: NMPCSettings, layout, qp: QPData, call) -> np.ndarray:
    """Our step's full correction ``v``: the applied current and the shifted plan it stored."""
    N = settings.horizon
    u, st_out = call[4], call[5]
    U_out = st_out[layout.slices()["U"]]
    U = np.concatenate([u, U_out[: NU * (N - 1)]])
    return U - qp.ubar


def pct(values, q=None) -> dict[str, float]:
    """Median, p99, max (and optionally p99.9) of a series."""
    v = np.asarray(values, dtype=float)
    out = {"median": float(np.median(v)), "p99": float(np.percentile(v, 99)), "max": float(v.max())}
    if q:
        out["p99.9"] = float(np.percentile(v, 99.9))
    return out


@dataclass
class Accuracy:
    """Accuracy of one solver setting over the recorded QPs."""

    label: str
    settings: dict
    n_qp: int
    u_err_A: dict
    cost_gap: dict
    cost_gap_rel: dict
    disk_violation_A: float
    iterations: dict
    passed: dict = field(default_factory=dict)
    worst: dict = field(default_factory=dict)


def evaluate(
    label: str, overrides: dict, scenarios=SCENARIOS, progress: bool = True, evaluators=None
) -> tuple[Accuracy, list]:
    """Run the closed loops with ``overrides``, solve every QP exactly and compare; also the records."""
    du, gap, gap_rel, viol, iters, passed, worst, records = [], [], [], [], [], {}, {}, []
    settings = None
    for name in scenarios:
        t0 = time.perf_counter()
        rec, res = record(name, overrides, evaluators)
        fns = rec.fns
        settings = fns.settings
        export = BufferedFunction(step_functions(settings, fns.mode)[2].build_qp_export())
        passed[name] = bool(res.passed)
        for i, call in enumerate(rec.calls):
            if call[6][1] > 0.5:  # fallback (non-finite QP): not a QP solution
                continue
            qp = qp_of_call(export, settings, call)
            ex = solve_exact(qp)
            v = ours_v(settings, fns.layout, qp, call)
            e = float(np.max(np.abs(v[:NU] - ex.v[:NU])))
            du.append(e)
            f = qp.objective(v)
            gap.append(f - ex.objective)
            gap_rel.append((f - ex.objective) / (abs(ex.objective) + 1.0))
            viol.append(max(qp.disk_violation(v), 0.0))
            iters.append(call[6][3])
            if e >= worst.get("u_err_A", -1):
                worst = {"u_err_A": e, "scenario": name, "step": i}
            records.append((name, i, qp, ex, call))
        if progress:
            print(f"  {label}: {name}: {len(rec.calls)} QPs in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    acc = Accuracy(
        label=label,
        settings={
            "iterations": settings.iterations,
            "solver": settings.solver,
            **{k_: v for k_, v in settings.admm.model_dump().items()},
        },
        n_qp=len(du),
        u_err_A=pct(du, True),
        cost_gap=pct(gap),
        cost_gap_rel=pct(gap_rel),
        disk_violation_A=float(max(viol)),
        iterations=pct(iters),
        passed=passed,
        worst=worst,
    )
    return acc, records


def table(results: list[Accuracy]) -> str:
    """Markdown table of :func:`evaluate` results."""
    lines = [
        "| setting | QPs | \\|u-u*\\| median [A] | p99 | p99.9 | max | cost gap rel. p99 | max | "
        "disk viol. [A] | iterations median / max | scenarios pass |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        u, c = r.u_err_A, r.cost_gap_rel
        lines.append(
            f"| {r.label} | {r.n_qp} | {u['median']:.1e} | {u['p99']:.1e} | {u['p99.9']:.1e} | {u['max']:.1e} | "
            f"{c['p99']:.1e} | {c['max']:.1e} | {r.disk_violation_A:.0e} | "
            f"{r.iterations['median']:.0f} / {r.iterations['max']:.0f} | "
            f"{sum(r.passed.values())}/{len(r.passed)} |"
        )
    return "\n".join(lines)


def parse_setting(text: str) -> tuple[str, object]:
    """``key=value`` with a YAML value (``iterations=60``, ``admm.tol_prim=1e-3``)."""
    key, _, val = text.partition("=")
    return key.strip(), yaml.safe_load(val)


#: Settings compared by default: label -> overrides of the scenario's controller block.
DEFAULT_SETTINGS: dict[str, dict] = {
    "default (early exit, <= 40 iterations, rho rebalanced once)": {},
    "fixed 20 iterations (the default before issue 14)": {
        "iterations": 20,
        "admm": {"early_exit": False, "check_every": 5, "adapt_at": 0},
    },
    "early exit, <= 40 iterations, no rho rebalancing": {"admm": {"adapt_at": 0}},
    "solver: osqp (Python)": {"solver": "osqp"},
    "solver: osqp, embedded (OSQP's generated C)": {"solver": "osqp", "osqp": {"embedded": True}},
}


def main(argv=None) -> int:
    """Command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--setting", action="append", default=[], help="key=value override (repeatable): one setting")
    ap.add_argument("--scenario", action="append", default=None, help="scenario name (repeatable)")
    ap.add_argument("--json", default=None, metavar="FILE")
    args = ap.parse_args(argv)
    scen = tuple(args.scenario) if args.scenario else SCENARIOS
    if args.setting:
        over = dict(parse_setting(s) for s in args.setting)
        cases = {", ".join(args.setting): _nest(over)}
    else:
        cases = DEFAULT_SETTINGS
    results = [evaluate(label, over, scen)[0] for label, over in cases.items()]
    print(table(results))
    if args.json:
        Path(args.json).write_text(json.dumps([r.__dict__ for r in results], indent=2) + "\n")
    return 0


def _nest(flat: dict) -> dict:
    """``{"admm.tol_prim": x}`` -> ``{"admm": {"tol_prim": x}}``."""
    out: dict = {}
    for key, val in flat.items():
        node = out
        *parents, leaf = key.split(".")
        for p_ in parents:
            node = node.setdefault(p_, {})
        node[leaf] = val
    return out


if __name__ == "__main__":
    sys.exit(main())
