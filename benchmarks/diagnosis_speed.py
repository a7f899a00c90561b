"""Time of the diagnosis per dataset and per stage, on datasets of the independent rig (issue 27, item 5).

Run::

    .venv/bin/python benchmarks/diagnosis_speed.py --n 10 --seed 970221753
    .venv/bin/python benchmarks/diagnosis_speed.py --n 10 --seed 970221753 --cases 0,16 --fit-workers 1
    .venv/bin/python benchmarks/diagnosis_speed.py --cases 0,1,9 --fit-workers 1 --profile /tmp/prof
    .venv/bin/python benchmarks/diagnosis_speed.py --n 60 --seed 548879380 --laws v5 --cases 12,13,34

The datasets are the blind self-check's (``maglev diagnose selftest N --generator independent --seed SEED``:
the same kinds and case seeds, :func:`maglev_ocp.diagnosis.selftest_rig.kinds_order`, 6 runs x 10 s),
generated once into ``--data`` (default: the temporary directory) and diagnosed one after the other, each
alone in this process, as ``maglev diagnose run`` does (:func:`maglev_ocp.diagnosis.diagnose.diagnose`, no
figures). Per dataset: the wall time, the CPU time of this process and of the fit workers it forked
(``fit_workers``, reaped when the selection ends), every stage's wall time (``Diagnosis.timing``) and CPU
time (:class:`StageCPU`), the verdict and the effects found; then the median, p90 and maximum of each,
and the load average before and after (on a shared machine the wall times are not the diagnosis's alone:
CPU time is the figure other processes disturb least). Writes ``--out`` (markdown) and the same rows as JSON beside it.
"""

from __future__ import annotations

import argparse
import cProfile
import hashlib
import importlib
import json
import os
import pstats
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))


def _cpu() -> float:
    """CPU time (user + system) of this process and of its reaped children [s]."""
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def cases(n: int, seed: int) -> list[tuple[int, str, int]]:
    """The self-check's first ``n`` cases of ``seed``: ``(index, kind, case seed)`` (as ``run_rig_selftest``)."""
    from maglev_ocp.diagnosis.selftest_rig import kinds_order

    root = np.random.SeedSequence([int(seed), 0x51D])
    s_order, s_cases = root.spawn(2)
    order = kinds_order(n, np.random.default_rng(s_order))
    seeds = [int(s.generate_state(1)[0]) for s in s_cases.spawn(n)]
    return [(i, k, sd) for i, (k, sd) in enumerate(zip(order, seeds, strict=True))]


def dataset(folder: Path, kind: str, case_seed: int, runs: int, duration: float, laws: str = "all") -> Path:
    """The case's dataset in ``folder`` (generated if absent; the same bytes for the same seed), its effects
    drawn from the rig's law set ``laws`` (as ``maglev diagnose selftest --laws``)."""
    from maglev_ocp.rigsim import RigSettings, draw, generate

    if not (folder / "truth.json").exists():
        scen = draw(case_seed, kind, laws=laws)
        generate(folder, scen["effects"], case_seed, RigSettings(n_runs=runs, duration=duration))
    return folder


class StageCPU:
    """CPU time per stage: wraps the pipeline's stage clock (``diagnose._Clock.run``) while in the block.

    Per stage, the CPU time of this process and of the children reaped during it (the fit workers are
    reaped when the selection ends, so their CPU time counts in the stage that reaps them: ``candidates``
    or ``forward``). ``last`` holds the stages of the latest diagnosis (``<stage>_s``).
    """

    def __init__(self) -> None:
        self.last: dict[str, float] = {}

    def __enter__(self) -> StageCPU:
        # the module (``maglev_ocp.diagnosis.diagnose`` as an attribute is the function the package exports)
        dg = importlib.import_module("maglev_ocp.diagnosis.diagnose")
        self._mod, self._orig = dg, dg._Clock.run
        orig, last = self._orig, self.last

        def run(clock, name, fn, *args, **kwargs):
            c0 = _cpu()
            try:
                return orig(clock, name, fn, *args, **kwargs)
            finally:
                last[f"{name}_s"] = _cpu() - c0

        dg._Clock.run = run
        return self

    def __exit__(self, *exc: object) -> None:
        self._mod._Clock.run = self._orig


def report_digest(d: object, digits: int = 4) -> str:
    """SHA-256 (16 hex digits) of the diagnosis's ``report.json`` without its timings, every float rounded to
    ``digits`` significant digits: equal before and after a change that moves nothing but rounding."""
    from maglev_ocp.diagnosis.result import report_json

    def rnd(x: object) -> object:
        if isinstance(x, float):
            return float(f"{x:.{digits}g}")
        if isinstance(x, dict):
            return {k: rnd(v) for k, v in x.items()}
        if isinstance(x, list):
            return [rnd(v) for v in x]
        return x

    j = report_json(d)
    j.pop("timing_s", None)
    text = json.dumps(rnd(json.loads(json.dumps(j, default=str))), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _q(x: list[float], q: float) -> float:
    return float(np.quantile(np.asarray(x, float), q)) if x else float("nan")


def markdown(rows: list[dict], meta: dict) -> str:
    """The table of the rows and their median / p90 / max."""
    from maglev_ocp.diagnosis.diagnose import STAGES
    from maglev_ocp.markdown import md_table

    head = [
        f"# Diagnosis time per dataset ({meta['when']})",
        "",
        f"Command: `{meta['command']}` at commit {meta['commit']}; fit workers {meta['fit_workers']} "
        f"({meta['cpus']} CPUs); load average (1, 5, 15 min) before {meta['load_before']}, after "
        f"{meta['load_after']}. CPU: this process and its fit workers.",
        "",
    ]
    body = [
        [str(r["case"]), r["kind"], r["truth"], r["verdict"], f"{r['wall_s']:.1f}", f"{r['cpu_s']:.1f}",
         f"{r['timing'].get('candidates_s', 0):.1f}", f"{r['timing'].get('forward_s', 0):.1f}",
         f"`{r.get('report_digest', '')}`"]
        for r in rows
    ]  # fmt: skip
    cols = ["#", "kind", "truth", "verdict", "wall [s]", "CPU [s]", "candidates [s]", "forward [s]", "report digest"]
    table = md_table(cols, body)
    walls, cpus = [r["wall_s"] for r in rows], [r["cpu_s"] for r in rows]
    stats = [["wall per dataset", f"{_q(walls, 0.5):.1f}", f"{_q(walls, 0.9):.1f}", f"{max(walls):.1f}"],
             ["CPU per dataset", f"{_q(cpus, 0.5):.1f}", f"{_q(cpus, 0.9):.1f}", f"{max(cpus):.1f}"]]  # fmt: skip
    for st in STAGES:
        for what, key in (("wall", "timing"), ("CPU", "stage_cpu")):
            v = [r.get(key, {}).get(f"{st}_s", 0.0) for r in rows]
            stats.append([f"stage {st} ({what})", f"{_q(v, 0.5):.1f}", f"{_q(v, 0.9):.1f}", f"{max(v):.1f}"])
    return "\n".join([*head, table, "", md_table(["[s]", "median", "p90", "max"], stats), ""])


def main(argv: list[str] | None = None) -> int:
    """Generate and diagnose the cases; print and write the table."""
    from maglev_ocp.diagnosis.diagnose import diagnose
    from maglev_ocp.diagnosis.result import DiagnoseSettings
    from maglev_ocp.parallel import available_cpus
    from maglev_ocp.riglog import read_dataset

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10, help="the self-check's first N cases")
    ap.add_argument("--seed", type=int, default=970221753, help="the self-check's seed")
    ap.add_argument("--cases", default="", help="only these case indices (comma-separated)")
    ap.add_argument("--runs", type=int, default=6, help="runs per dataset")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per run")
    ap.add_argument("--laws", default="all", help="the rig's law set the effects are drawn from (selftest --laws)")
    ap.add_argument("--fit-workers", type=int, default=0, help="DiagnoseSettings.fit_workers (0: auto)")
    ap.add_argument("--data", type=Path, default=Path(tempfile.gettempdir()) / "maglev_diagnosis_speed",
                    help="where the datasets are generated (kept: a second run diagnoses the same files)")  # fmt: skip
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/diagnosis_speed.md"))
    ap.add_argument("--profile", type=Path, default=None,
                    help="also profile each diagnosis (cProfile; use --fit-workers 1 to see the fits): "
                         "DIR/case<i>.prof and the top functions by own time in DIR/case<i>.txt")  # fmt: skip
    args = ap.parse_args(argv)
    pick = {int(c) for c in args.cases.split(",") if c.strip()}
    todo = [c for c in cases(args.n, args.seed) if not pick or c[0] in pick]
    folders = {}
    for i, kind, sd in todo:  # generated first: the timed loop only diagnoses
        tag = "" if args.laws == "all" else f"_{args.laws}"
        folders[i] = dataset(args.data / f"{args.seed}{tag}_{i:02d}", kind, sd, args.runs, args.duration, args.laws)
    load0 = os.getloadavg()
    rows = []
    clock = StageCPU()
    for i, kind, sd in todo:
        ds = read_dataset(folders[i])
        truth = json.loads((folders[i] / "truth.json").read_text())
        st = DiagnoseSettings(seed=int(sd % (2**31)), fit_workers=args.fit_workers)
        prof = cProfile.Profile() if args.profile else None
        t0, c0 = time.perf_counter(), _cpu()
        with clock:
            if prof is not None:
                prof.enable()
            d = diagnose(ds, settings=st)
            if prof is not None:
                prof.disable()
        wall, cpu = time.perf_counter() - t0, _cpu() - c0
        if prof is not None:
            args.profile.mkdir(parents=True, exist_ok=True)
            prof.dump_stats(args.profile / f"case{i}.prof")
            with open(args.profile / f"case{i}.txt", "w") as fh:
                pstats.Stats(prof, stream=fh).sort_stats("tottime").print_stats(40)
        rows.append(dict(case=i, kind=kind, truth=str(truth.get("expected_verdict", kind)),
                         verdict=d.verdict.verdict, wall_s=wall, cpu_s=cpu, timing=dict(d.timing),
                         stage_cpu=dict(clock.last), load=list(os.getloadavg()),
                         effects_found=d.effects_found, report_digest=report_digest(d)))  # fmt: skip
        print(f"case {i:2d} {kind:<15} {d.verdict.verdict:<40} wall {wall:7.1f} s  CPU {cpu:7.1f} s", flush=True)
    load1 = os.getloadavg()
    commit = os.popen(f"git -C {ROOT} rev-parse --short HEAD 2>/dev/null").read().strip() or "?"
    meta = dict(when=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), commit=commit,
                command="python benchmarks/diagnosis_speed.py " + " ".join(argv if argv is not None else sys.argv[1:]),
                fit_workers=args.fit_workers or "auto", cpus=available_cpus(),
                load_before=", ".join(f"{x:.1f}" for x in load0),
                load_after=", ".join(f"{x:.1f}" for x in load1))  # fmt: skip
    md = markdown(rows, meta)
    print(md)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(md)
    args.out.with_suffix(".json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
