"""What a self-check's result says against issue 27's targets: per-effect confusion, timings, targets met.

Everything here reads the cases of a self-check's json (``selftest.json`` of the library or the independent rig,
``results/prereg/issue27_result.json``, the leave-one-law-out json): each case a dict with ``truth``,
``verdict``, ``right``, ``seconds`` and ``truth_params``. So the figures of the validation page are computed
from the results' files by one function (:func:`validation_markdown`), never copied by hand.

- :func:`per_effect`: for every library effect, the datasets where it was named and is there (named right), named
  and not there (false claim: also when it is offered as a confusable alternative) and there but not named
  (missed);
- :func:`timings`: diagnosis time per dataset, median, p90 and max;
- :func:`targets`: issue 27's targets (named set right on new laws >= 85 % and old laws >= 90 %, an effect
  claimed that is not there on <= 5 % of the datasets, out-of-library ``unexplained`` >= 90 %, no effect on
  ``none``, fitted sizes within 20 % on every right verdict), each met or not.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..markdown import md_table
from .library import family_specs
from .verdict import NONE, UNEXPLAINED, EffectSets

#: The library's effects (the verdict's vocabulary), in report order.
LIBRARY: tuple[str, ...] = tuple(family_specs())

#: Kinds of dataset with library effects.
LIBRARY_KINDS: tuple[str, ...] = ("single", "pair", "triple")


def truth_effects(case: Mapping) -> tuple[str, ...]:
    """The library effects a case's plant has (``()`` for ``none`` and for an effect outside the library)."""
    t = str(case["truth"])
    if t in (NONE, UNEXPLAINED):
        return ()
    names = EffectSets.parse(t).names
    return names if all(n in LIBRARY for n in names) else ()


def named_effects(case: Mapping) -> tuple[str, ...]:
    """Every library effect a case's verdict names, confusable alternatives included."""
    return EffectSets.parse(str(case["verdict"])).names


def kind_of(case: Mapping) -> str:
    """``none``, ``single``, ``pair``, ``triple`` or ``out_of_library`` (the rig's record, else from the truth)."""
    k = (case.get("truth_params") or {}).get("kind")
    if k:
        return str(k)
    t = str(case["truth"])
    if t == NONE:
        return "none"
    eff = truth_effects(case)
    return {1: "single", 2: "pair", 3: "triple"}.get(len(eff), "out_of_library") if eff else "out_of_library"


def law_set(case: Mapping) -> str:
    """``new`` when any of the case's rig laws is one of issue 27's new families, ``old`` when all are the first
    families, ``""`` without that record (the library generator) or without effects."""
    effects = (case.get("truth_params") or {}).get("effects") or {}
    flags = [e.get("new_law") for e in effects.values() if isinstance(e, Mapping)]
    if not flags or any(f is None for f in flags):
        return ""
    return "new" if any(flags) else "old"


def false_claim(case: Mapping) -> bool:
    """The verdict names an effect (or offers an alternative) that the plant does not have."""
    return bool(set(named_effects(case)) - set(truth_effects(case)))


def size_errors(truth_params: Mapping) -> dict[str, float]:
    """Relative errors of the fitted sizes against the truth file, for the effects both name: the effective delay
    of a lag, the peak force [N] of every other effect (``truth_params["fitted"]`` against the truth's)."""
    tp, fit = truth_params, truth_params.get("fitted") or {}
    out: dict[str, float] = {}
    for name, true in (tp.get("effective_delay_s") or {}).items():
        got = (fit.get("effective_delay_s") or {}).get(name)
        if got is not None and true:
            out[name] = got / true - 1.0
    for name, true in (tp.get("peak_force_n") or {}).items():
        got = (fit.get("peak_force_n") or {}).get(name)
        if name not in out and got is not None and true:
            out[name] = got / true - 1.0
    return out


def per_effect(cases: Sequence[Mapping]) -> dict[str, dict[str, int]]:
    """Per library effect (those that occur): datasets with it named right, claimed falsely, missed."""
    out: dict[str, dict[str, int]] = {}
    for c in cases:
        truth, named = set(truth_effects(c)), set(named_effects(c))
        for e in truth | named:
            row = out.setdefault(e, {"present": 0, "named_right": 0, "false_claims": 0, "missed": 0})
            row["present"] += e in truth
            row["named_right"] += e in truth and e in named
            row["false_claims"] += e in named and e not in truth
            row["missed"] += e in truth and e not in named
    return {e: out[e] for e in sorted(out, key=lambda n: LIBRARY.index(n) if n in LIBRARY else len(LIBRARY))}


def timings(cases: Sequence[Mapping]) -> dict[str, float | None]:
    """Diagnosis time per dataset [s]: median, p90 and max (``None`` without cases)."""
    s = np.array([float(c["seconds"]) for c in cases if c.get("seconds") is not None], float)
    s = s[np.isfinite(s)]
    if not len(s):
        return {"n": 0, "median": None, "p90": None, "max": None}
    return {"n": len(s), "median": float(np.median(s)), "p90": float(np.percentile(s, 90)), "max": float(s.max())}


@dataclass(frozen=True)
class Target:
    """One of issue 27's targets, evaluated on a self-check's cases.

    Attributes
    ----------
    name : str
        What is measured.
    value : float or None
        The measured figure (``None``: no case it applies to).
    count : str
        The figure as a count (``"12 of 14"``).
    goal : str
        The target (``">= 85 %"``).
    met : bool or None
        Whether it is met (``None`` when it does not apply).
    """

    name: str
    value: float | None
    count: str
    goal: str
    met: bool | None


def _fraction(name: str, hits: Sequence[bool], goal: float, at_least: bool = True) -> Target:
    n, k = len(hits), int(sum(hits))
    text = "all" if at_least and goal >= 1.0 else f"{'>=' if at_least else '<='} {goal:.0%}"
    if not n:
        return Target(name, None, "0 of 0", text, None)
    v = k / n
    return Target(name, v, f"{k} of {n}", text, bool(v >= goal - 1e-12 if at_least else v <= goal + 1e-12))


def targets(cases: Sequence[Mapping]) -> list[Target]:
    """Issue 27's targets on ``cases`` (see the module docstring); a target no case applies to is ``met=None``."""
    lib = [c for c in cases if kind_of(c) in LIBRARY_KINDS]
    ool = [c for c in cases if kind_of(c) == "out_of_library"]
    none = [c for c in cases if kind_of(c) == "none"]
    sizes = [abs(e) for c in cases if c["right"] for e in size_errors(c.get("truth_params") or {}).values()]
    out = [
        _fraction("named set right, new laws", [bool(c["right"]) for c in lib if law_set(c) == "new"], 0.85),
        _fraction("named set right, old laws", [bool(c["right"]) for c in lib if law_set(c) == "old"], 0.90),
        _fraction("an effect claimed that is not there", [false_claim(c) for c in cases], 0.05, at_least=False),
        _fraction("out-of-library answered unexplained", [str(c["verdict"]) == UNEXPLAINED for c in ool], 0.90),
    ]
    claims = sum(bool(named_effects(c)) for c in none)
    out.append(Target("effects claimed on none", float(claims) if none else None, f"{claims} of {len(none)}",
                      "0", (claims == 0) if none else None))  # fmt: skip
    out.append(_fraction("fitted sizes within 20 % (right verdicts)", [e <= 0.2 for e in sizes], 1.0))
    return out


def _pct(x: float | None) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.0%}"


def target_lines(cases: Sequence[Mapping]) -> list[str]:
    """The targets as text lines (the self-check prints them)."""
    out = []
    for t in targets(cases):
        met = {True: "met", False: "NOT MET", None: "n/a"}[t.met]
        val = t.count if t.name == "effects claimed on none" else f"{_pct(t.value)} ({t.count})"
        out.append(f"target {t.name}: {val}, target {t.goal}: {met}")
    return out


def targets_markdown(cases: Sequence[Mapping]) -> str:
    """The targets as a Markdown table."""
    rows = [
        [t.name, t.count if t.name == "effects claimed on none" else f"{_pct(t.value)} ({t.count})", t.goal,
         {True: "met", False: "**not met**", None: "n/a"}[t.met]]
        for t in targets(cases)
    ]  # fmt: skip
    return md_table(["target", "measured", "goal", ""], rows)


def section_markdown(title: str, doc: Mapping, note: str = "") -> str:
    """One result's section: targets, per-effect rows, timings and the confusion of sets (truth vs named)."""
    cases = list(doc.get("cases") or [])
    rows = [[f"`{e}`", r["present"], r["named_right"], r["false_claims"], r["missed"]]
            for e, r in per_effect(cases).items()]  # fmt: skip
    t = timings(cases)
    sec = lambda x: "n/a" if x is None else f"{x:.1f} s"  # noqa: E731
    conf = Counter((str(c["truth"]), str(c["verdict"])) for c in cases)
    truths = sorted({k[0] for k in conf}, key=lambda s: (s == UNEXPLAINED, s.count("+"), s))
    crow = []
    for tr in truths:
        got = sorted(((v, n) for (t_, v), n in conf.items() if t_ == tr), key=lambda x: -x[1])
        right = sum(1 for c in cases if c["truth"] == tr and c["right"])
        crow.append([f"`{tr}`", sum(n for _, n in got), right, ", ".join(f"`{v}` {n}" for v, n in got)])
    cmd = doc.get("command") or (doc.get("meta") or {}).get("command")
    head = [f"### {title}", ""]
    if note:
        head += [note, ""]
    if cmd:
        head += [f"Command: `{cmd}`" + (f" (code {doc['code_version']})" if doc.get("code_version") else ""), ""]
    return "\n".join([
        *head,
        f"{len(cases)} datasets; named set right on {sum(bool(c['right']) for c in cases)}. Targets (issue 27):",
        "",
        targets_markdown(cases),
        "",
        "Per effect (datasets): *present* in the plant, *named right* (present and named), *false claims* (named,"
        " or offered as a confusable alternative, and not present), *missed* (present, not named):",
        "",
        md_table(["effect", "present", "named right", "false claims", "missed"], rows),
        "",
        f"Diagnosis time per dataset: median {sec(t['median'])}, p90 {sec(t['p90'])}, max {sec(t['max'])} "
        f"({t['n']} datasets).",
        "",
        "Truth set against named set:",
        "",
        md_table(["truth", "datasets", "right", "named (count)"], crow),
    ])  # fmt: skip


def validation_markdown(results: Mapping[str, tuple[Mapping | None, str]]) -> str:
    """The validation page's generated part: one :func:`section_markdown` per result (``title -> (json document
    or None when the file is missing, note)``)."""
    parts = []
    for title, (doc, note) in results.items():
        if doc is None:
            parts.append(f"### {title}\n\n{note}\n\nNo result file yet.")
        else:
            parts.append(section_markdown(title, doc, note))
    return "\n\n".join(parts) + "\n"


__all__ = [
    "LIBRARY",
    "Target",
    "false_claim",
    "kind_of",
    "law_set",
    "named_effects",
    "per_effect",
    "section_markdown",
    "size_errors",
    "target_lines",
    "targets",
    "targets_markdown",
    "timings",
    "truth_effects",
    "validation_markdown",
]
