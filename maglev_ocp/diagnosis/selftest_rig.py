"""Blind self-check on the independent rig (:mod:`maglev_ocp.rigsim`), a plant the diagnosis was not built from.

For each of ``N`` datasets a scenario is drawn by :func:`maglev_ocp.rigsim.draw`
(its own law families and parameter ranges: cogging with other decays and
harmonics, Coulomb/Stribeck/Dahl/LuGre friction, saturation of the field, the
current terms or both, other overhang profiles, second-order amplifiers and
fractional delays, drifting commutation offsets; and effects outside the
library: a structural resonance, encoder errors, magnet temperature drift, a
cable). Since issue 27 the draw also uses the new law families written from the
literature (:mod:`maglev_ocp.rigsim.laws_new`: slot-harmonic / end-detent
cogging, Maxwell-slip / Karnopp friction, entry-end / fringing end effects,
Frohlich / Langevin saturation, cascade / digital current loops, pitch-error /
cross-saturation commutation, eddy drag; a hysteretic cable slab and sensor
cross-talk outside the library), each drawn effect new with probability one
half; the summary reports the right-set rates separately for cases with a new
law and cases with the first families only. The kinds (``none``, one, two or three library effects, one effect
outside the library) are cycled through random permutations of a block of 20
that follows :data:`maglev_ocp.rigsim.draw.KINDS` (3 none, 7 singles, 4 pairs,
2 triples, 4 outside the library), so that every kind is represented once
``N`` reaches 20. The rig's constants are off nominal by up to +-5 %, it has
the shared model's cogging (seed eq. (9)) as a real rig does, its own
integrator and controller; the diagnosis sees only the rig log and calibrates
its baseline (C1..C4, xi0, ell).

A verdict is right when it names exactly the true set of library effects,
``unexplained`` for an effect outside the library and ``none`` without effects
(:func:`maglev_ocp.rigsim.expected_verdict`). Reported: the confusion matrix
over sets, the fraction right per kind, the ``none`` datasets on which an
effect was claimed, and on the right verdicts with effects the fraction of the
held-out gap above the floor that the final model closes.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from ..markdown import md_table
from ..output import atomic_write_text
from ..parallel import map_ordered
from ..riglog import read_dataset
from ..rigsim import RigSettings, draw, generate
from ..rigsim.generate import build_laws, expected_verdict
from .diagnose import diagnose
from .report import write_report
from .selftest import Case, SelftestResult, SelftestSettings, canonical, same_set, save_partial
from .selftest_summary import size_errors as truth_size_errors
from .selftest_summary import target_lines, targets, timings

#: Scenario kinds with library effects.
LIBRARY_KINDS: tuple[str, ...] = ("single", "pair", "triple")

#: One block of kinds (cycled in random order): the proportions of :data:`maglev_ocp.rigsim.draw.KINDS`.
BLOCK: dict[str, int] = {"none": 3, "single": 7, "pair": 4, "triple": 2, "out_of_library": 4}


def kinds_order(n: int, rng: np.random.Generator) -> list[str]:
    """``n`` kinds: random permutations of :data:`BLOCK` one after the other."""
    block = [k for k, m in BLOCK.items() for _ in range(m)]
    out: list[str] = []
    while len(out) < n:
        out += [str(x) for x in rng.permutation(block)]
    return out[:n]


def run_rig_case(
    index: int,
    kind: str,
    seed: int,
    settings: SelftestSettings,
    keep: Path | None = None,
    laws: str = "all",
    scenario: dict | None = None,
) -> Case:
    """Draw one scenario of ``kind`` on the independent rig, generate its dataset and diagnose it blind.

    ``laws``: the rig's law families drawn from, ``"all"`` (the self-check: old and new, issue 27), ``"old"``
    or ``"new"`` (:func:`maglev_ocp.rigsim.draw`). ``scenario``: a scenario in :func:`~maglev_ocp.rigsim.draw`'s
    form to run instead of a drawn one (the leave-one-law-out check, :mod:`.selftest_lolo`, forces a law family).
    """
    scen = scenario if scenario is not None else draw(seed, kind, laws=laws)  # new_law marked per effect
    truth = canonical(expected_verdict(build_laws(scen["effects"])))  # a set in library order, as verdicts are
    gs = settings.generator
    rs = RigSettings(n_runs=gs.n_runs, duration=gs.run_duration)
    with tempfile.TemporaryDirectory(prefix="rigsim_") as tmp:
        t0 = time.perf_counter()
        folder = generate(Path(tmp) / "ds", scen["effects"], seed, rs)
        t_gen = time.perf_counter() - t0
        ds = read_dataset(folder)
        dset = settings.diagnose.model_copy(update={"seed": int(seed % (2**31))})
        t0 = time.perf_counter()
        diag = diagnose(ds, settings=dset)
        secs = time.perf_counter() - t0
        tr = json.loads((folder / "truth.json").read_text())
    if keep is not None:
        write_report(diag, keep / f"case_{index:02d}")
    fs = diag.final_score
    closes = float(fs.closes) if fs is not None else math.nan
    reduction = float(fs.reduction) if fs is not None else 0.0
    params = {"kind": kind, "seed": seed, "effects": scen["effects"], "true_constants": tr["true_constants"],
              "peak_force_n": {n: e.get("peak_force_n") for n, e in tr["effects"].items()},
              "effective_delay_s": {n: e["effective_delay_s"] for n, e in tr["effects"].items()
                                    if "effective_delay_s" in e},
              "fitted": fitted_values(diag)}  # fmt: skip
    case = Case(index, truth, params, canonical(diag.verdict.verdict), same_set(diag.verdict.verdict, truth),
                reduction, closes, False, secs, t_gen, [])  # fmt: skip
    case.channels = sorted({r.channel for r in (diag.remaining_regions or diag.regions)})
    return case


#: Constants compared with the truth file (C4, the reluctance term, is the least determined: seed Table III).
CONSTANTS = ("C1", "C2", "C3", "C4")


def fitted_values(diag) -> dict:
    """What the diagnosis fitted, for comparison with ``truth.json``: the calibrated constants, and per effect of
    the verdict its peak force [N] (larger axis) and, for a lag, its effective delay [s]."""
    sizes = diag.consequences.sizes if diag.consequences is not None else []
    return {
        "constants": {n: float(diag.baseline_params.as_dict()[n]) for n in CONSTANTS},
        "peak_force_n": {s.name: float(max(s.peak_force_n.values())) for s in sizes if s.peak_force_n},
        "effective_delay_s": {s.name: 1e-6 * float(s.delay_us) for s in sizes if s.delay_us is not None},
        # the law-family members the final model uses and every member fitted (the leave-one-law-out check
        # reads them: an excluded member must never appear)
        "laws": {e: str(sh.get("law", "default")) for e, sh in diag.shares.items()},
        "members_tried": members_tried(diag),
    }


def members_tried(diag) -> list[str]:
    """Every law-family member the diagnosis fitted, as ``effect/member`` (scores of sets split per effect: a
    pair ``a+b`` with laws ``x; y`` gives ``a/x`` and ``b/y``; a member's score ``a[x]`` gives ``a/x``)."""
    out: set[str] = set()
    for s in (*diag.scores, *diag.law_members):
        names = s.name.split("[")[0].split("+")
        laws = s.law.split("; ")
        if len(laws) != len(names):
            laws = [s.law] * len(names)
        out |= {f"{n}/{law}" for n, law in zip(names, laws, strict=True)}
    return sorted(out)


def size_errors(case: Case) -> dict[str, float]:
    """Relative errors of the fitted sizes against the truth file, for the effects both name: the effective delay
    of a lag, the peak force of every other effect (:func:`.selftest_summary.size_errors`)."""
    return truth_size_errors(case.truth_params)


def constant_errors(case: Case) -> dict[str, float]:
    """Relative errors of the calibrated constants against the truth file."""
    true, got = (
        case.truth_params.get("true_constants") or {},
        (case.truth_params.get("fitted") or {}).get("constants") or {},
    )
    return {n: got[n] / true[n] - 1.0 for n in CONSTANTS if n in got and true.get(n)}


class RigSelftestResult(SelftestResult):
    """Cases of the independent-rig self-check; ``ideal`` holds the fraction of the gap closed."""

    def kind_of(self, c: Case) -> str:
        """The scenario kind of a case."""
        return str(c.truth_params.get("kind", ""))

    def right_fraction(self, kinds: tuple[str, ...]) -> float:
        """Fraction of right verdicts among the cases of ``kinds``."""
        sel = [c.right for c in self.cases if self.kind_of(c) in kinds]
        return float(np.mean(sel)) if sel else math.nan

    def law_set_of(self, c: Case) -> str:
        """``new`` when any drawn law of the case is one of the new families (``new_law`` in the draw,
        :mod:`maglev_ocp.rigsim.laws_new`), ``old`` when all are the first families, ``""`` without effects."""
        effects = c.truth_params.get("effects") or {}
        if not effects:
            return ""
        return "new" if any(bool(e.get("new_law")) for e in effects.values()) else "old"

    def right_fraction_laws(self, kinds: tuple[str, ...], law_set: str) -> float:
        """Fraction of right verdicts among the cases of ``kinds`` whose laws are ``law_set`` (old / new)."""
        sel = [c.right for c in self.cases if self.kind_of(c) in kinds and self.law_set_of(c) == law_set]
        return float(np.mean(sel)) if sel else math.nan

    def count_laws(self, kinds: tuple[str, ...], law_set: str) -> int:
        """Number of cases of ``kinds`` whose laws are ``law_set``."""
        return sum(1 for c in self.cases if self.kind_of(c) in kinds and self.law_set_of(c) == law_set)

    def gap_closed(self) -> np.ndarray:
        """Fraction of the held-out gap above the floor closed, on the right verdicts naming effects."""
        return np.array([c.ideal for c in self.cases if c.right and c.truth not in ("none", "unexplained")])

    def reduction_ratios(self) -> np.ndarray:  # the library's ideal model does not exist on this rig
        """Not defined on the independent rig (no true model in the library): empty."""
        return np.zeros(0)

    def size_errors(self) -> np.ndarray:
        """Relative errors of the fitted effect sizes on the right verdicts naming effects (every effect)."""
        return np.array([e for c in self.cases if c.right for e in size_errors(c).values()])

    def summary(self) -> dict:
        """Headline numbers against the issue's targets."""
        g = self.gap_closed()
        secs = [c.seconds for c in self.cases]
        se = np.abs(self.size_errors())
        ce = {n: [abs(constant_errors(c).get(n, math.nan)) for c in self.cases] for n in CONSTANTS}
        return {
            "datasets": len(self.cases),
            "right_verdicts": float(self.accuracy()),
            "right_on_library_effect_sets": self.right_fraction(("single", "pair", "triple")),
            "right_by_kind": {k: self.right_fraction((k,)) for k in BLOCK},
            "none_datasets": sum(1 for c in self.cases if c.truth == "none"),
            "effects_claimed_on_none": self.none_false_claims(),
            "out_of_library_unexplained": self.right_fraction(("out_of_library",)),
            "right_on_library_effect_sets_by_laws": {
                ls: self.right_fraction_laws(LIBRARY_KINDS, ls) for ls in ("old", "new")
            },
            "library_effect_sets_by_laws": {ls: self.count_laws(LIBRARY_KINDS, ls) for ls in ("old", "new")},
            "out_of_library_unexplained_by_laws": {
                ls: self.right_fraction_laws(("out_of_library",), ls) for ls in ("old", "new")
            },
            "out_of_library_by_laws": {ls: self.count_laws(("out_of_library",), ls) for ls in ("old", "new")},
            "gap_closed_median": float(np.median(g)) if len(g) else None,
            "gap_closed_min": float(np.min(g)) if len(g) else None,
            "sizes_compared": len(se),
            "sizes_within_20pct": float(np.mean(se <= 0.2)) if len(se) else None,
            "size_error_median": float(np.median(se)) if len(se) else None,
            "constant_error_median": {n: float(np.nanmedian(v)) if v else None for n, v in ce.items()},
            "diagnosis_seconds_median": float(np.median(secs)) if secs else None,
            "diagnosis_seconds_max": float(np.max(secs)) if secs else None,
            "diagnosis_seconds_p90": float(np.percentile(secs, 90)) if secs else None,
            "targets": [t.__dict__ for t in targets(self._case_dicts())],
        }

    def _lines(self) -> list[str]:
        s = self.summary()
        fmt = lambda x: "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.0%}"  # noqa: E731
        out = [
            f"named set right: {fmt(s['right_verdicts'])} of {s['datasets']} datasets "
            f"(library effect sets {fmt(s['right_on_library_effect_sets'])}; "
            + ", ".join(f"{k} {fmt(v)}" for k, v in s["right_by_kind"].items())
            + ")",
            f"effects claimed on 'none' datasets: {s['effects_claimed_on_none']} of {s['none_datasets']}",
            f"out-of-library effects answered 'unexplained': {fmt(s['out_of_library_unexplained'])}",
            "by law families (new: any law of rigsim.laws_new; old: the first families only): named set right "
            + ", ".join(
                f"{ls} {fmt(s['right_on_library_effect_sets_by_laws'][ls])} of {s['library_effect_sets_by_laws'][ls]}"
                for ls in ("old", "new")
            )
            + "; out-of-library 'unexplained' "
            + ", ".join(
                f"{ls} {fmt(s['out_of_library_unexplained_by_laws'][ls])} of {s['out_of_library_by_laws'][ls]}"
                for ls in ("old", "new")
            ),
        ]
        if s["gap_closed_median"] is not None:
            out.append(
                f"gap closed on the right verdicts with effects: median {s['gap_closed_median']:.0%}, "
                f"min {s['gap_closed_min']:.0%}"
            )
        if s["sizes_within_20pct"] is not None:
            out.append(
                f"fitted sizes against the truth file on the right verdicts: {s['sizes_within_20pct']:.0%} of "
                f"{s['sizes_compared']} within 20 % (median error {s['size_error_median']:.0%})"
            )
        cm = s["constant_error_median"]
        if any(v is not None and not math.isnan(v) for v in cm.values()):
            out.append("calibrated constants against the truth file, median |error|: "
                       + ", ".join(f"{n} {v:.2%}" for n, v in cm.items() if v is not None))  # fmt: skip
        t = timings(self._case_dicts())
        if t["median"] is not None:
            out.append(
                f"diagnosis time per dataset: median {t['median']:.1f} s, p90 {t['p90']:.1f} s, max {t['max']:.1f} s"
            )
        return out + target_lines(self._case_dicts())

    def _case_dicts(self) -> list[dict]:
        return [c.to_dict() for c in self.cases]

    def table(self) -> str:
        """Text view: cases, confusion matrix, summary."""
        lines = [
            f"{'#':>3} {'kind':<15} {'laws':<4} {'truth':<36} {'verdict':<36} {'ok':>3} {'closed':>7} {'t [s]':>6}"
        ]
        for c in self.cases:
            lines.append(
                f"{c.index:>3} {self.kind_of(c):<15} {self.law_set_of(c) or '-':<4} {c.truth:<36} {c.verdict:<36} "
                f"{'y' if c.right else 'n':>3} "
                f"{c.ideal:7.0%} {c.seconds:6.1f}"
            )
        rows, cols, m = self.confusion()
        lines += ["", "confusion matrix (rows: truth, columns: verdict)"]
        for i, r in enumerate(rows):
            lines.append(f"{r:<36} " + ", ".join(f"{cols[j]}: {m[i, j]}" for j in range(len(cols)) if m[i, j]))
        return "\n".join([*lines, "", *self._lines()])

    def markdown(self) -> str:
        """Markdown view: the confusion matrix over sets, one row per true set with the verdicts it got."""
        rows, cols, m = self.confusion()
        body = []
        for i, r in enumerate(rows):
            # A confusable set's "|" would end the table cell: md_table escapes it.
            got = ", ".join(f"`{cols[j]}` {m[i, j]}" for j in np.argsort(-m[i], kind="stable") if m[i, j])
            right = sum(1 for c in self.cases if c.truth == r and c.right)
            body.append([f"`{r}`", int(m[i].sum()), right, got])
        md = md_table(["truth", "datasets", "right", "verdicts (count)"], body)
        return "\n".join([md, "", *(f"- {x}" for x in self._lines())])

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write ``selftest.json`` and ``selftest.md``."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        rows, cols, m = self.confusion()
        doc = {
            "plant": "independent (maglev_ocp.rigsim)",
            "settings": self.settings.model_dump(),
            "summary": self.summary(),
            "confusion": {"rows": rows, "cols": cols, "matrix": m.tolist()},
            "cases": [c.to_dict() for c in self.cases],
        }
        atomic_write_text(out / "selftest.json", json.dumps(doc, indent=2, default=float))
        atomic_write_text(
            out / "selftest.md",
            "# Blind self-check on the independent rig\n\n" + self.markdown() + "\n\n```\n" + self.table() + "\n```\n",
        )
        return out


def _rig_job(job: tuple[int, str, int, SelftestSettings, Path | None, str]) -> Case:
    """One independent-rig case (a worker's job)."""
    return run_rig_case(*job)


def run_rig_selftest(
    settings: SelftestSettings,
    progress: bool = True,
    out_dir: str | os.PathLike | None = None,
    keep_reports: bool = False,
    workers: int = 1,
) -> RigSelftestResult:
    """Run the blind self-check on the independent rig (see the module docstring).

    Parameters
    ----------
    settings : SelftestSettings
        Number of datasets, seed, dataset size (``generator.n_runs``, ``run_duration``), diagnosis settings.
    progress : bool
        Progress bar over the datasets.
    out_dir : path, optional
        Where ``selftest.json`` / ``selftest.md`` are written after every case.
    keep_reports : bool
        Also write each dataset's diagnosis report into ``out_dir/case_NN``.
    workers : int
        Local worker processes (Dask); the result does not depend on it (every case has its own seed).
    """
    root = np.random.SeedSequence([int(settings.seed), 0x51D])
    s_order, s_cases = root.spawn(2)
    order = kinds_order(settings.n, np.random.default_rng(s_order))
    seeds = [int(s.generate_state(1)[0]) for s in s_cases.spawn(settings.n)]
    keep = Path(out_dir) if (keep_reports and out_dir is not None) else None
    jobs = [(i, kind, sd, settings, keep, settings.laws) for i, (kind, sd) in enumerate(zip(order, seeds, strict=True))]
    save = save_partial(RigSelftestResult, settings, out_dir)
    return RigSelftestResult(settings, map_ordered(_rig_job, jobs, workers, "rig self-check", progress, save))


__all__ = ["BLOCK", "RigSelftestResult", "kinds_order", "run_rig_case", "run_rig_selftest"]
