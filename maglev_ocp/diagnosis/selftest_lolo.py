"""Leave-one-law-out check: is a rig law still named when the library members written to match it are gone?

The library's law families grew members while the diagnosis was developed against the project's own
independent rig (:mod:`maglev_ocp.rigsim`): a cogging with a decay of its own, a Stribeck member, saturation
weighted as the rig weights its targets, end effects with two ends and a second ripple harmonic. A self-check
on that rig then measures how well generator and fitter agree, not how the diagnosis meets a law nobody wrote
down (issue 27). This check removes, for each of the rig's first law families (``new_law`` false, the families
of :mod:`maglev_ocp.rigsim.laws`), the library members that were matched to it (:data:`MATCHED`, with the
reason and the commit that added them), diagnoses datasets of that family alone and in a pair, and reports
how often the effect set is still named right (the issue's target: >= 85 % per family).

A family whose only library member is the one it was matched by cannot be left out without removing the effect
itself; it would be listed with ``members = ()`` and not run. The amplifier lag's transfer-function members
(``fractional``, ``second``: :mod:`.lagfit`) have the form of the rig's first- and second-order laws with
their fractional delays; left out, the library's first order + whole samples (its continuous effective delay)
must take the rig's law.
"""

from __future__ import annotations

import json
import math
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..markdown import md_table
from ..output import atomic_write_text
from ..parallel import map_ordered
from ..rigsim import LAWS, LIBRARY_EFFECTS
from ..rigsim.draw import DRAWS
from .selftest import Case, SelftestSettings
from .selftest_rig import run_rig_case, size_errors
from .settings import DiagnoseSettings


@dataclass(frozen=True)
class MatchedMembers:
    """The library members matched to one of the independent rig's law families.

    Attributes
    ----------
    effect : str
        The effect (the rig's and the library's name).
    family : str
        The rig's law family (:attr:`maglev_ocp.rigsim.laws.Law.families`).
    members : tuple of str
        The library's family members (:attr:`~.library.CandidateSpec.law`) matched to it; they are left out
        (``()``: nothing can be left out, the family is not run).
    reason : str
        Why these members are the ones matched (from the commit history and the library's docstrings).
    """

    effect: str
    family: str
    members: tuple[str, ...]
    reason: str


_COGGING = (
    "the rig's cogging beyond seed eq. (9) has a decay in g of its own; 'own decay' was added for it (e840ecc: "
    "seen at dBIC -8 with the default member, far below with its own) and 'free decay' (2acc506, written 20 min "
    "after the rig) nests the exponential, power-law and curved log-decays"
)
_SAT = (
    "the rig saturates the magnet field, the currents' field or both (its 'target'); 'field' and 'current terms' "
    "weight the magnetic terms as those targets do (2acc506; the current terms' reluctance loss made twice the "
    "linear terms' in 9fe7c3a, as the rig has it) and 'per term' frees each term's share"
)
_RIPPLE = (
    "every rig end-effect family has a second ripple harmonic (r2), matched by 'two ends' and 'spline profile, "
    "ripple harmonics' (9fe7c3a)"
)

#: The independent rig's first law families and the library members matched to each (left out by the check).
MATCHED: tuple[MatchedMembers, ...] = (
    *(MatchedMembers("cogging", f, ("own decay", "free decay"), _COGGING) for f in ("power", "gauss", "twoexp")),
    MatchedMembers(
        "friction",
        "coulomb_viscous",
        ("default",),
        "the library's own law (Coulomb + viscous, as the rig's); left out, the Stribeck member that nests it "
        "must take it",
    ),
    MatchedMembers(
        "friction", "stribeck", ("stribeck",), "the 'stribeck' member (2acc506) is the rig's Stribeck law per axis"
    ),
    MatchedMembers(
        "friction",
        "dahl",
        ("default",),
        "Dahl's steady state is Coulomb; below the 15 Hz cut-off its presliding acts as a smoothed Coulomb force "
        "(library.family_specs' docstring): matched by the Coulomb + viscous law",
    ),
    MatchedMembers(
        "friction",
        "lugre",
        ("stribeck",),
        "LuGre's steady state is a Stribeck curve s(v): matched by the 'stribeck' member (2acc506)",
    ),
    MatchedMembers(
        "end_effect",
        "cosine",
        ("spline profile", "spline profile, ripple harmonics", "two ends", "two ends, end force"),
        "the spline members were written for a loss that levels off, the rig's half cosine (7e043ea: it left "
        "49-66 % of the gap); " + _RIPPLE,
    ),
    MatchedMembers(
        "end_effect",
        "quadratic",
        ("free profile", "spline profile", "spline profile, ripple harmonics", "two ends", "two ends, end force"),
        "'free profile' bends the overhang loss (edge_quad, 2acc506) and the spline follows the rig's quadratic "
        "law to 3 % (7e043ea); " + _RIPPLE,
    ),
    MatchedMembers(
        "end_effect",
        "asymmetric",
        ("two ends", "two ends, end force", "spline profile, ripple harmonics"),
        "'two ends' gives each end its own onset and loss, for the rig's asymmetric ends (9fe7c3a); " + _RIPPLE,
    ),
    MatchedMembers("saturation", "exp", ("field", "current terms", "per term"), _SAT),
    MatchedMembers(
        "saturation",
        "logistic",
        ("knee", "field", "current terms", "per term"),
        "'knee' makes the loss a logistic step in g, the rig's logistic law (f1c7026, 'law families a rig "
        "shows'); " + _SAT,
    ),
    *(
        MatchedMembers(
            "amplifier_lag",
            f,
            (member,),
            f"'{member}' ({what}, issue 27 item 1, written from the current-loop literature) has the form of the "
            "rig's law; left out, the first order + whole samples (a continuous effective delay) must take it",
        )
        for f, member, what in (
            ("first", "fractional", "a first-order lag and a fractional delay"),
            ("second", "second", "a second-order response and a fractional delay"),
            ("delay", "fractional", "a fractional delay with a lag that may vanish"),
        )
    ),
    MatchedMembers(
        "commutation_offset",
        "constant",
        ("default",),
        "the library's own law (a constant dq rotation); left out, the 'drift' member that nests it must take it",
    ),
    MatchedMembers(
        "commutation_offset", "drift", ("drift",), "'drift' (f1c7026) is the rig's offset growing along the stroke"
    ),
)


def matched_table() -> dict[tuple[str, str], MatchedMembers]:
    """:data:`MATCHED` by ``(effect, family)``; checks that it covers every first family of every library effect
    of the rig and that every member it names exists (a renamed member would otherwise exclude nothing)."""
    fam = DiagnoseSettings().families()
    out = {(m.effect, m.family): m for m in MATCHED}
    for effect in LIBRARY_EFFECTS:
        for f in LAWS[effect].families:
            if (effect, f) not in out:
                raise ValueError(f"leave-one-law-out: no matched members recorded for rig law {effect}/{f}")
    for m in MATCHED:
        known = {x.law for x in fam.get(m.effect, ())}
        bad = [x for x in m.members if x not in known]
        if bad:
            raise ValueError(f"leave-one-law-out: {m.effect}/{m.family} names unknown members {bad}; known {known}")
    return out


def scenario(effect: str, family: str, kind: str, seed: int) -> dict:
    """A scenario of the rig's ``effect`` with law ``family``: alone (``single``) or with one other library
    effect of the rig (``pair``, the partner and its law drawn); parameters from the rig's own draws
    (:data:`maglev_ocp.rigsim.draw.DRAWS`, redrawn from the seed's stream until the family is the one asked)."""
    if kind not in ("single", "pair"):
        raise ValueError(f"kind must be single or pair, got {kind!r}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x1010]))
    spec = DRAWS[effect](rng)
    for _ in range(1000):
        if spec["family"] == family:
            break
        spec = DRAWS[effect](rng)
    else:  # pragma: no cover - the rig's draws choose every family with probability >= 1/4
        raise ValueError(f"{effect}: family {family!r} never drawn")
    effects = {effect: {**spec, "new_law": False}}
    if kind == "pair":
        other = str(rng.choice([e for e in LIBRARY_EFFECTS if e != effect]))
        effects[other] = {**DRAWS[other](rng), "new_law": False}
    order = list(LAWS)
    return {
        "kind": kind,
        "seed": int(seed),
        "laws": "old",
        "effects": {n: effects[n] for n in sorted(effects, key=order.index)},
    }


def _job(job: tuple) -> Case:
    """One dataset (a worker's job): the forced scenario diagnosed with the matched members left out."""
    index, effect, family, kind, seed, settings = job
    case = run_rig_case(index, kind, seed, settings, scenario=scenario(effect, family, kind, seed))
    case.truth_params["left_out"] = {"effect": effect, "family": family}
    return case


def run_leave_one_law_out(
    n: int,
    seed: int,
    families: list[str] | None = None,
    base: SelftestSettings | None = None,
    workers: int = 1,
    progress: bool = True,
    out: str | os.PathLike | None = None,
    meta: dict | None = None,
) -> dict:
    """Run the check: ``n`` datasets per rig law family (alternately single and pair), each diagnosed with the
    family's matched members excluded (:attr:`DiagnoseSettings.exclude_laws`).

    Parameters
    ----------
    n : int
        Datasets per family.
    seed : int
        Seed of every draw (the scenario of family ``i``'s dataset ``j`` is seeded by ``(seed, i, j)``).
    families : list of str, optional
        ``effect/family`` names to run (default: every one with members to leave out).
    base : SelftestSettings, optional
        Dataset size and diagnosis settings (default: the self-check's).
    workers : int
        Local worker processes.
    out : path, optional
        Writes ``<out>.json`` and ``<out>.md`` after every dataset.
    meta : dict, optional
        Command, code version and the like, stored in the json and shown in the Markdown.

    Returns
    -------
    dict
        The json document (rows per family, every case).
    """
    table = matched_table()
    keys = [k for k, m in table.items() if m.members]
    if families:
        bad = [f for f in families if tuple(f.split("/", 1)) not in table]
        if bad:
            raise ValueError(f"unknown rig law families {bad}; allowed: {', '.join('/'.join(k) for k in table)}")
        keys = [k for k in keys if "/".join(k) in families]
    base = base or SelftestSettings(seed=seed)
    jobs = []
    for i, (effect, family) in enumerate(keys):
        m = table[(effect, family)]
        dset = DiagnoseSettings(**{**base.diagnose.model_dump(), "exclude_laws": {effect: list(m.members)}})
        st = SelftestSettings(**{**base.model_dump(), "seed": seed, "diagnose": dset.model_dump()})
        for j in range(n):
            sd = int(np.random.SeedSequence([int(seed), 0x1010, i, j]).generate_state(1)[0])
            jobs.append((len(jobs), effect, family, ("single", "pair")[j % 2], sd, st))

    def doc_of(cases: list[Case]) -> dict:
        return lolo_document(cases, table, keys, n, seed, meta or {})

    def save(done: dict[int, Case]) -> None:
        if out is not None:
            write_lolo(doc_of([done[i] for i in sorted(done)]), out)

    cases = map_ordered(_job, jobs, workers, "leave one law out", progress, save)
    doc = doc_of(cases)
    if out is not None:
        write_lolo(doc, out)
    return doc


def lolo_document(cases: list[Case], table: dict, keys: list[tuple[str, str]], n: int, seed: int, meta: dict) -> dict:
    """The check's json document: one row per family (excluded members, named right, what was named instead,
    sizes) and every case."""
    rows = []
    for effect, family in keys:
        mine = [c for c in cases if c.truth_params.get("left_out") == {"effect": effect, "family": family}]
        se = np.abs([e for c in mine if c.right for e in size_errors(c).values()])
        rows.append({
            "effect": effect,
            "family": family,
            "excluded": list(table[(effect, family)].members),
            "reason": table[(effect, family)].reason,
            "datasets": len(mine),
            "right": sum(c.right for c in mine),
            "right_fraction": float(np.mean([c.right for c in mine])) if mine else None,
            "instead": dict(Counter(f"{c.truth} -> {c.verdict}" for c in mine if not c.right)),
            "sizes_compared": len(se),
            "sizes_within_20pct": float(np.mean(se <= 0.2)) if len(se) else None,
            "seconds_median": float(np.median([c.seconds for c in mine])) if mine else None,
            # an excluded member fitted anyway would void the row: the stages must read the filtered library
            "excluded_fitted": sorted({f"{e}/{law}" for c in mine for e, law in _tried(c)
                                       if e == effect and law in table[(effect, family)].members}),
        })  # fmt: skip
    not_run = [{"effect": m.effect, "family": m.family, "reason": m.reason} for m in table.values() if not m.members]
    right = [c.right for c in cases]
    return {
        "check": "leave one law out (issue 27)",
        "seed": seed,
        "datasets_per_family": n,
        **meta,
        "summary": {
            "datasets": len(cases),
            "right_fraction": float(np.mean(right)) if right else None,
            "families_at_85pct": sum(
                1 for r in rows if r["right_fraction"] is not None and r["right_fraction"] >= 0.85
            ),
            "families_run": sum(1 for r in rows if r["datasets"]),
        },
        "rows": rows,
        "not_run": not_run,
        "cases": [c.to_dict() for c in cases],
    }


def _tried(case: Case) -> list[tuple[str, str]]:
    """``(effect, member)`` of every law member a case's diagnosis fitted (``fitted.members_tried``; entries of
    a set ``a+b/x; y`` and of a member's score ``a[x]/x`` split as :func:`.selftest_rig.members_tried` does)."""
    out = []
    for m in (case.truth_params.get("fitted") or {}).get("members_tried", []):
        names, _, laws = m.partition("/")
        names_l, laws_l = names.split("[")[0].split("+"), laws.split("; ")
        if len(laws_l) != len(names_l):
            laws_l = [laws] * len(names_l)
        out += list(zip(names_l, laws_l, strict=True))
    return out


def reload_document(doc: dict) -> dict:
    """``doc`` (a saved check's json) recomputed with today's code: its rows from its cases, its command, seed
    and code version kept (``python -m benchmarks.leave_one_law_out --rewrite``)."""
    keys = [(r["effect"], r["family"]) for r in doc["rows"]]
    cases = [Case(**{k: v for k, v in c.items()}) for c in doc["cases"]]
    meta = {k: doc[k] for k in ("command", "code_version", "date") if k in doc}
    return lolo_document(cases, matched_table(), keys, doc["datasets_per_family"], doc["seed"], meta)


def _pct(x: float | None) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.0%}"


def family_table(doc: dict) -> str:
    """The per-family table of a check's document (Markdown): family, members left out, named right, what was
    named instead, sizes within 20 % on the right verdicts."""
    body = [
        [f"`{r['effect']}` {r['family']}", ", ".join(f"`{x}`" for x in r["excluded"]), r["datasets"],
         f"{r['right']} ({_pct(r['right_fraction'])})",
         "; ".join(f"{k} ({v})" for k, v in r["instead"].items()) or "-",
         f"{_pct(r['sizes_within_20pct'])} of {r['sizes_compared']}"
         + (f" (**excluded members fitted: {r['excluded_fitted']}**)" if r.get("excluded_fitted") else "")]
        for r in doc["rows"]
    ]  # fmt: skip
    cols = ["rig law", "left out of the library", "datasets", "named right", "named instead", "sizes within 20 %"]
    return md_table(cols, body)


def lolo_markdown(doc: dict) -> str:
    """The check's table in Markdown (with the command and code version of ``doc`` when it has them)."""
    s = doc["summary"]
    head = [
        "# Leave one law out (issue 27)",
        "",
        f"- command: `{doc.get('command', '?')}`",
        f"- seed: {doc['seed']}; {doc['datasets_per_family']} datasets per rig law family (single, pair, ...)",
        f"- code version: {doc.get('code_version', '?')}; run on {doc.get('date', '?')}",
        f"- named right: {_pct(s['right_fraction'])} of {s['datasets']} datasets; families at >= 85 %: "
        f"{s['families_at_85pct']} of {s['families_run']} run (target: all)",
        "",
    ]
    foot = ["", "Not run (nothing to leave out):", ""] + [
        f"- `{r['effect']}` {r['family']}: {r['reason']}" for r in doc["not_run"]
    ]
    return "\n".join([*head, family_table(doc), *foot]) + "\n"


def write_lolo(doc: dict, out: str | os.PathLike) -> None:
    """Write ``<out>.json`` and ``<out>.md``."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out.with_suffix(".json"), json.dumps(doc, indent=2, default=float))
    atomic_write_text(out.with_suffix(".md"), lolo_markdown(doc))


__all__ = [
    "MATCHED",
    "MatchedMembers",
    "family_table",
    "lolo_document",
    "lolo_markdown",
    "matched_table",
    "reload_document",
    "run_leave_one_law_out",
    "scenario",
    "write_lolo",
]
