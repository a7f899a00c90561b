"""Blind self-check: datasets with random effects (or none) on the plant, diagnosed without being told.

For each of ``N`` datasets a truth is drawn (``none``, the library's effects
and the two- and three-effect sets of :data:`COMBOS`, cycled through a random
permutation so that every one appears once ``N`` reaches their number), its
physical parameters are drawn at random from
:data:`DRAWS` (inside the library's bounds, in the part of the range that
moves the residual above the noise of a one-minute dataset; the ranges are in
the table below and in ``selftest.json``), the plant seed is drawn too, a
diagnosis dataset is generated (:mod:`.generate`) and diagnosed by
:func:`~.diagnose.diagnose`, which sees only the rig log.

By default (``baseline="calibrated"``) the diagnosis calibrates C1..C4 and the
cogging law's xi0, ell itself and the plant's constants carry the default
profile's random mismatch (``parameter_error``, which a calibration absorbs,
is left out). The plant always has the shared model's cogging (seed eq. (9),
MODEL.md) as a real rig does; a ``cogging`` truth is cogging beyond it (slot
harmonics, another decay). With ``baseline="given"`` the engineer's model
handed to the diagnosis is the nominal one (``--params``) and the plant's
constants equal it, so that a ``parameter_error`` dataset is a gap. Single-effect draws
include laws other than the library's default member (saturation of the
magnet field or of the current terms only, other cogging decays and normal
ratios, other overhang losses), so the law families are exercised. A verdict
is right when it names exactly the true set of effects (a confusable set
``a|b`` is not right); the confusion matrix is over effect sets. Noise, 10 um quantization, current
limits and stops are the default rig profile's.

Reported: the confusion matrix (truth x verdict), the fraction of right
verdicts, the ``none`` datasets on which an effect was claimed, the
localization accuracy, and on the right verdicts the held-out reduction
against the ideal one (the true effect with its true parameters, and the true
constants, on the same held-out samples).

Localization is right when the channel where the true effect is largest is
flagged (a reported region, or state structure beyond its floor), and, for
effects that live in the gap x position plane (whose binned map holds at
least 30 % of the effect's energy there), the box around that channel's
reported regions holds at least half of that map's energy; on ``none``
datasets it is right when nothing is flagged.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydantic import Field

from ..config import Strict
from ..effects import EFFECTS
from ..output import atomic_write_text, make_dir
from ..parallel import map_ordered
from ..params import NOMINAL, Params
from ..plant import PlantConfig
from ..rigsim.draw import LAW_SETS
from .attribution import raw_rms
from .diagnose import LIBRARY, DiagnoseSettings, Diagnosis, diagnose
from .fit import FitResult, residuals_with
from .generate import OUT_OF_LIBRARY, GeneratorSettings, generate_dataset
from .library import CandidateSpec
from .localize import bin_stats, edges_for, pool
from .report import write_report
from .residuals import CHANNELS
from .selftest_summary import target_lines, timings
from .verdict import EffectSets

Draw = Callable[[np.random.Generator], tuple[dict, dict]]


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _signed(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def _draw_cogging(rng):
    """Cogging beyond the shared model's law (seed eq. (9), which the plant always has at its own constants and
    a calibrated baseline carries): slot harmonics with their own decay, or another decay law altogether."""
    if rng.uniform() < 0.5:  # harmonics of the slot pitch on top of the seed's law
        eff = {
            "xi0": _u(rng, 2.0, 6.0),
            "ell": NOMINAL.ell * _u(rng, 0.8, 1.25),
            "power": 0.0,
            "h1": 0.0,
            "h2": _signed(rng, 0.15, 0.4),
            "h3": _u(rng, -0.3, 0.3),
            "phi2": _u(rng, -math.pi, math.pi),
            "phi3": _u(rng, -math.pi, math.pi),
            "kn": _u(rng, 0.6, 1.5),
        }
    else:  # a fundamental with a decay law other than the seed's (power law and log-curvature) and a harmonic
        eff = {
            "xi0": _u(rng, 1.5, 4.0),
            "ell": NOMINAL.ell * _u(rng, 1.2, 2.0),
            "power": _u(rng, 0.5, 2.0),
            "curv": _u(rng, -1.0, 1.0),
            "h1": 1.0,
            "h2": _u(rng, -0.3, 0.3),
            "h3": 0.0,
            "phi2": _u(rng, -math.pi, math.pi),
            "phi3": 0.0,
            "kn": _u(rng, 0.5, 2.0),
        }
    return {}, {"cogging": {"enabled": True, **eff}}


def _draw_friction(rng):
    return {}, {
        "friction": {
            "enabled": True,
            "coulomb_g": _u(rng, 0.05, 0.4),
            "coulomb_d": _u(rng, 0.05, 0.4),
            "stribeck_g": _u(rng, 0.0, 0.1),
            "stribeck_d": _u(rng, 0.0, 0.1),
            "v_stribeck": 2e-3,
            "viscous_g": _u(rng, 0.0, 2.0),
            "viscous_d": _u(rng, 0.0, 2.0),
            "v_reg": 2e-4,
        }
    }


def _draw_end_effect(rng):
    return {}, {
        "end_effect": {
            "enabled": True,
            "ripple": _u(rng, 0.03, 0.12),
            "ripple_phase": _u(rng, -math.pi, math.pi),
            "d_edge": _u(rng, 0.02, 0.04),
            "edge_width": _u(rng, 2e-3, 6e-3),
            "edge_gain": _u(rng, 0.7, 1.6),  # fringe fields: more or less loss than the geometric overhang
            "edge_quad": 0.0,
        }
    }


def _draw_lag(rng):
    return {}, {
        "amplifier_lag": {
            "enabled": True,
            "bandwidth_hz": float(math.exp(rng.uniform(math.log(100.0), math.log(1000.0)))),
            "delay_samples": int(rng.integers(0, 3)),
        }
    }


#: Saturation laws the self-check draws (the family's discrete members): term weights.
_SAT_LAWS: dict[str, dict[str, float]] = {
    "all": {"w_pm": 1.0, "w_id": 1.0, "w_rel": 1.0, "w_thrust": 1.0},
    "field": {"w_pm": 1.0, "w_id": 0.5, "w_rel": 0.0, "w_thrust": 0.5},
    "current terms": {"w_pm": 0.0, "w_id": 1.0, "w_rel": 1.0, "w_thrust": 1.0},
}


def _draw_saturation(rng):
    law = _SAT_LAWS[str(rng.choice(list(_SAT_LAWS)))]
    loss = _u(rng, 0.12, 0.3) if law["w_pm"] == 0.0 else _u(rng, 0.08, 0.3)
    return {}, {"saturation": {"enabled": True, "loss_8mm": loss, "ell_sat": _u(rng, 2e-3, 5e-3), **law}}


def _draw_commutation(rng):
    return {}, {"commutation_offset": {"enabled": True, "delta": _signed(rng, 0.02, 0.15)}}


def _draw_eddy(rng):
    return {}, {"eddy_drag": {"enabled": True, "c_eddy": _u(rng, 30.0, 200.0)}}


def _draw_param_error(rng):
    return {}, {
        "parameter_error": {
            "enabled": True,
            "k_C1": 1 + _signed(rng, 0.03, 0.1),
            "k_C2": 1 + _signed(rng, 0.02, 0.06),
            "k_C3": 1 + _signed(rng, 0.03, 0.1),
            "k_C4": 1 + _signed(rng, 0.3, 1.0),
            "k_Mh": 1 + _u(rng, -0.05, 0.05),
            "k_Mv": 1 + _u(rng, -0.05, 0.05),
        }
    }


def _draw_none(rng):
    return {}, {}


def _combo(*draws: Draw) -> Draw:
    """Several effects at once: each drawn as on its own, merged."""

    def draw(rng):
        params, effects = {}, {}
        for d in draws:
            p_, e_ = d(rng)
            params.update(p_)
            effects.update(e_)
        return params, effects

    return draw


#: Random draw of each truth: ``rng -> (param overrides, plant effect settings)``.
DRAWS: dict[str, Draw] = {
    "none": _draw_none,
    "cogging": _draw_cogging,
    "friction": _draw_friction,
    "end_effect": _draw_end_effect,
    "amplifier_lag": _draw_lag,
    "saturation": _draw_saturation,
    "commutation_offset": _draw_commutation,
    "eddy_drag": _draw_eddy,
    "parameter_error": _draw_param_error,
}
#: Two- and three-effect truths of the self-check (drawn like the singles), ``a+b`` in library order.
COMBOS: tuple[str, ...] = (
    "cogging+friction",
    "friction+end_effect",
    "cogging+saturation",
    "cogging+friction+end_effect",
)
DRAWS.update({c: _combo(*(DRAWS[n] for n in c.split("+"))) for c in COMBOS})


class SelftestSettings(Strict):
    """Settings of the blind self-check.

    Attributes
    ----------
    n : int
        Number of datasets.
    seed : int
        Seed of everything (draws, plant noise, references, diagnosis).
    truths : list of str
        What may be drawn (default: every library effect and ``none``).
    baseline : str
        ``given`` (the nominal model is the engineer's) or ``calibrated``.
    generator : GeneratorSettings
        Dataset size and excitation.
    diagnose : DiagnoseSettings
        Diagnosis settings.
    laws : str
        The independent rig's law set its effects are drawn from (:data:`maglev_ocp.rigsim.draw.LAW_SETS`):
        ``all`` (the first families and issue 27's, the default), ``old``, ``new`` or ``v3`` (the third set,
        :mod:`maglev_ocp.rigsim.laws_v3`). Only the independent generator reads it.
    """

    n: int = Field(30, ge=1, le=10000)
    seed: int = Field(0, ge=0)
    truths: list[str] | None = None
    baseline: str = Field("calibrated", pattern=r"^(given|calibrated)$")
    generator: GeneratorSettings = GeneratorSettings()
    diagnose: DiagnoseSettings = DiagnoseSettings(simulate=False)
    laws: str = Field("all", pattern="^(" + "|".join(LAW_SETS) + ")$")


@dataclass
class Case:
    """One blind dataset and its diagnosis.

    Attributes
    ----------
    index : int
        Dataset number.
    truth : str
        The effect put into the plant (``none`` or a library name, or an out-of-library name).
    truth_params : dict
        Its parameters (and the parameter overrides).
    verdict : str
        The diagnosis' verdict.
    right : bool
        ``verdict == truth``.
    reduction, ideal : float
        Held-out residual reduction of the verdict's model and of the true model.
    localized : bool
        Localization right (see the module docstring).
    seconds : float
        Diagnosis time.
    """

    index: int
    truth: str
    truth_params: dict
    verdict: str
    right: bool
    reduction: float
    ideal: float
    localized: bool
    seconds: float
    gen_seconds: float
    channels: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return {
            k: getattr(self, k)
            for k in (
                "index",
                "truth",
                "truth_params",
                "verdict",
                "right",
                "reduction",
                "ideal",
                "localized",
                "seconds",
                "gen_seconds",
                "channels",
            )
        }


@dataclass
class SelftestResult:
    """All cases of a self-check, with the summary statistics.

    Attributes
    ----------
    settings : SelftestSettings
        What was run.
    cases : list of Case
        One per dataset.
    """

    settings: SelftestSettings
    cases: list[Case]

    # --------------------------------------------------------------- statistics
    def accuracy(self) -> float:
        """Fraction of right verdicts."""
        return float(np.mean([c.right for c in self.cases])) if self.cases else math.nan

    def none_false_claims(self) -> int:
        """Number of ``none`` datasets on which an effect was claimed."""
        return sum(1 for c in self.cases if c.truth == "none" and EffectSets.parse(c.verdict).named)

    def localization_accuracy(self) -> float:
        """Fraction of datasets localized right."""
        return float(np.mean([c.localized for c in self.cases])) if self.cases else math.nan

    def reduction_ratios(self) -> np.ndarray:
        """Held-out reduction over the ideal one, on the right verdicts with an effect."""
        return np.array([c.reduction / c.ideal for c in self.cases if c.right and c.truth != "none" and c.ideal > 0])

    def confusion(self) -> tuple[list[str], list[str], np.ndarray]:
        """Confusion matrix: rows truths, columns verdicts (sets and pairs as their own columns)."""
        rows = sorted({c.truth for c in self.cases}, key=_order)
        cols = sorted({c.verdict for c in self.cases} | set(rows), key=_order)
        m = np.zeros((len(rows), len(cols)), int)
        for c in self.cases:
            m[rows.index(c.truth), cols.index(c.verdict)] += 1
        return rows, cols, m

    def summary(self) -> dict:
        """Headline numbers."""
        r = self.reduction_ratios()
        return {
            "datasets": len(self.cases),
            "right_verdicts": float(self.accuracy()),
            "none_datasets": sum(1 for c in self.cases if c.truth == "none"),
            "effects_claimed_on_none": self.none_false_claims(),
            "localization_accuracy": float(self.localization_accuracy()),
            "reduction_over_ideal_min": float(r.min()) if len(r) else None,
            "reduction_over_ideal_median": float(np.median(r)) if len(r) else None,
            "reduction_at_least_70pct_of_ideal": float(np.mean(r >= 0.7)) if len(r) else None,
            "diagnosis_seconds_median": float(np.median([c.seconds for c in self.cases])) if self.cases else None,
            "diagnosis_seconds_max": float(np.max([c.seconds for c in self.cases])) if self.cases else None,
        }

    # ------------------------------------------------------------------ views
    def table(self) -> str:
        """Text view: cases, confusion matrix, summary."""
        lines = [f"{'#':>3} {'truth':<20} {'verdict':<28} {'ok':>3} {'red.':>7} {'ideal':>7} {'loc':>4} {'t [s]':>6}"]
        for c in self.cases:
            lines.append(
                f"{c.index:>3} {c.truth:<20} {c.verdict:<28} {'y' if c.right else 'n':>3} "
                f"{c.reduction:7.1%} {c.ideal:7.1%} {'y' if c.localized else 'n':>4} {c.seconds:6.1f}"
            )
        rows, cols, m = self.confusion()
        w = max(len(x) for x in cols + rows) + 1
        lines += [
            "",
            "confusion matrix (rows: truth, columns: verdict)",
            " " * w + "".join(f"{_abbr(c):>6}" for c in cols),
        ]
        for i, r in enumerate(rows):
            lines.append(f"{r:<{w}}" + "".join(f"{v:>6}" for v in m[i]))
        lines.append("columns: " + ", ".join(f"{_abbr(c)} = {c}" for c in cols))
        lines += ["", *_summary_lines(self.summary(), markdown=False)]
        t = timings(dicts := [c.to_dict() for c in self.cases])
        if t["median"] is not None:
            lines.append(f"diagnosis time p90: {t['p90']:.1f} s")
        return "\n".join([*lines, *target_lines(dicts)])

    def markdown(self) -> str:
        """Markdown view (confusion matrix as a table)."""
        rows, cols, m = self.confusion()
        # A confusable set's "|" would end the table cell: escaped.
        md = [
            "| truth \\ verdict | " + " | ".join(c.replace("|", "\\|") for c in cols) + " |",
            "|---" * (len(cols) + 1) + "|",
        ]
        for i, r in enumerate(rows):
            md.append(f"| {r} | " + " | ".join(str(v) if v else "." for v in m[i]) + " |")
        md += ["", *_summary_lines(self.summary(), markdown=True)]
        return "\n".join(md)

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write ``selftest.json`` and ``selftest.md``."""
        out = make_dir(out_dir)
        doc = {
            "settings": self.settings.model_dump(),
            "summary": self.summary(),
            "confusion": dict(
                zip(("rows", "cols", "matrix"), (lambda r, c, m: (r, c, m.tolist()))(*self.confusion()), strict=True)
            ),
            "cases": [c.to_dict() for c in self.cases],
        }
        atomic_write_text(out / "selftest.json", json.dumps(doc, indent=2, default=float))
        atomic_write_text(
            out / "selftest.md", "# Blind self-check\n\n" + self.markdown() + "\n\n```\n" + self.table() + "\n```\n"
        )
        return out


#: The summary's sentences over the keys of :meth:`SelfTestReport.summary`: ``(key that must not be
#: None, text, Markdown)``, each a :meth:`str.format` template.
_SUMMARY_SENTENCES: tuple[tuple[str | None, str, str], ...] = (
    (
        None,
        "right verdicts: {right_verdicts:.1%} of {datasets}",
        "- right verdicts: **{right_verdicts:.1%}** of {datasets} datasets",
    ),
    (
        None,
        "effects claimed on 'none' datasets: {effects_claimed_on_none} of {none_datasets}",
        "- effects claimed on `none` datasets: **{effects_claimed_on_none}** of {none_datasets}",
    ),
    (
        None,
        "localization accuracy: {localization_accuracy:.1%}",
        "- localization accuracy: {localization_accuracy:.1%}",
    ),
    (
        "reduction_over_ideal_median",
        "held-out reduction / ideal on right verdicts: median {reduction_over_ideal_median:.2f}, "
        "min {reduction_over_ideal_min:.2f}, >= 0.7 in {reduction_at_least_70pct_of_ideal:.0%}",
        "- held-out reduction / ideal reduction on right verdicts: median {reduction_over_ideal_median:.2f}, "
        "min {reduction_over_ideal_min:.2f}, at least 0.7 in {reduction_at_least_70pct_of_ideal:.0%}",
    ),
    (
        None,
        "diagnosis time: median {diagnosis_seconds_median:.1f} s, max {diagnosis_seconds_max:.1f} s",
        "- diagnosis time per dataset: median {diagnosis_seconds_median:.1f} s, max {diagnosis_seconds_max:.1f} s",
    ),
)


def _summary_lines(s: dict, markdown: bool) -> list[str]:
    """The summary ``s``'s sentences as text lines or Markdown bullets (see :data:`_SUMMARY_SENTENCES`)."""
    return [
        (md if markdown else text).format(**s)
        for need, text, md in _SUMMARY_SENTENCES
        if need is None or s[need] is not None
    ]


_ORDER = ["none", *LIBRARY, "unexplained"]


def _order(name: str) -> tuple[int, str]:
    """Confusion-matrix order: none, the singles, sets by size, unexplained last."""
    if name == "unexplained":
        return (1000, name)
    if name in _ORDER:
        return (_ORDER.index(name), name)
    return (100 + name.count("+"), name)


def _abbr(name: str) -> str:
    short = {
        "none": "none",
        "cogging": "cog",
        "friction": "fric",
        "end_effect": "end",
        "amplifier_lag": "lag",
        "saturation": "sat",
        "commutation_offset": "comm",
        "eddy_drag": "eddy",
        "parameter_error": "par",
        "unexplained": "unex",
    }
    return "".join(short.get(p, p[:4]) + s for p, s in _split_name(name))


def _split_name(name: str) -> list[tuple[str, str]]:
    out, cur = [], ""
    for ch in name:
        if ch in "|+":
            out.append((cur, ch))
            cur = ""
        else:
            cur += ch
    out.append((cur, ""))
    return out


# ----------------------------------------------------------------------- the plant
def selftest_plant(baseline: str, effects: dict) -> PlantConfig:
    """The rig of the self-check: default profile's noise, quantization, limits, stops, and only the drawn effect."""
    off = {n: {"enabled": False} for n in EFFECTS}
    over: dict = {"effects": {**off, **effects}}
    if baseline == "given":
        over["mismatch"] = {"relative": {n: 0.0 for n in ("C1", "C2", "C3", "C4", "xi0", "ell", "Mh", "Mv")}}
    return PlantConfig.from_profile("default", over)


def truth_residuals(diag: Diagnosis, true_params: Params, effects: dict) -> list:
    """Held-out residuals of the true model (true constants and the true effect with its true parameters)."""
    names = [n for n, v in effects.items() if v]
    lag = "amplifier_lag" in names
    fixed = []
    for n in names:
        if n == "amplifier_lag":
            continue
        for q, v in effects[n].items():
            fixed.append((f"{n}.{q}", float(v)))
    spec = CandidateSpec("truth", tuple(n for n in names if n != "amplifier_lag"), (), tuple(fixed), (), lag)
    fit = None
    if lag:
        th = effects["amplifier_lag"]
        fit = FitResult(
            spec,
            np.zeros(0),
            np.zeros(0),
            0.0,
            0,
            1.0,
            {"bandwidth_hz": float(th["bandwidth_hz"]), "delay_samples": float(th["delay_samples"])},
        )
    ho = diag.heldout
    return residuals_with(spec, fit, ho.runs, true_params.vector(), ho.u)


def _localized(diag: Diagnosis, truth: str, effect_res: list, base_res: list) -> tuple[bool, list[str]]:
    """Is the true effect's contribution where the diagnosis says the gap is (see the module docstring)?"""
    if truth == "none":
        return not diag.regions and not any(f.significant for f in diag.floors.values()), []
    # The true effect's contribution on the held-out samples: baseline residual minus true-model residual.
    best_ch, best_rms = None, 0.0
    for c in range(2):
        parts = []
        for b, t in zip(base_res, effect_res, strict=True):
            if b.run.n and b.run.valid[c]:
                parts.append(b.r[:, c] - t.r[:, c])
        v = float(np.sqrt(np.mean(np.concatenate(parts) ** 2))) if parts else 0.0
        if v > best_rms:
            best_ch, best_rms = c, v
    if best_ch is None:
        return False, []
    ch = CHANNELS[best_ch]
    regs = [r for r in diag.regions if r.channel == ch]
    fl = diag.floors.get(ch)
    channel_ok = bool(regs) or (fl is not None and fl.significant)
    # Where the true contribution lives in gap x position: the bins holding most of its map energy.
    from .residuals import Residual

    diff = [Residual(b.run, b.r - t.r, b.model) for b, t in zip(base_res, effect_res, strict=True)]
    s = pool(diff, best_ch)
    eg, ed = edges_for(s.feat["g"], 10), edges_for(s.feat["d"], 10)
    bs = bin_stats(s, ("g", "d"), (eg, ed), 1.0, 1.0, min_count=10)
    m2 = np.where(np.isfinite(bs.mean), bs.mean**2 * bs.count, 0.0)
    map_share = float(m2.sum() / max(np.sum(s.r**2), 1e-300))
    if map_share < 0.3:
        # Not an effect of the gap x position plane (friction, drag, lag: velocities and current rates):
        # the channel is what can be localized.
        return channel_ok, [ch]
    if not regs:
        return False, [ch]
    gi, di = np.meshgrid(np.arange(len(eg) - 1), np.arange(len(ed) - 1), indexing="ij")
    gc, dc = (eg[gi] + eg[gi + 1]) / 2, (ed[di] + ed[di + 1]) / 2
    # The extent the report gives for the channel: the box around its regions.
    g0, g1 = min(r.g_range_m[0] for r in regs), max(r.g_range_m[1] for r in regs)
    d0, d1 = min(r.d_range_m[0] for r in regs), max(r.d_range_m[1] for r in regs)
    inside = (gc >= g0 - 1e-9) & (gc <= g1 + 1e-9) & (dc >= d0 - 1e-9) & (dc <= d1 + 1e-9)
    return bool(m2[inside].sum() >= 0.5 * m2.sum()), [ch]


def run_case(
    index: int, truth: str, seed: np.random.SeedSequence, settings: SelftestSettings, extra: str | None = None
) -> tuple[Case, Diagnosis]:
    """Generate one dataset with ``truth`` (random parameters from ``seed``) and diagnose it blind."""
    s_draw, s_gen, s_diag = seed.spawn(3)
    rng = np.random.default_rng(s_draw)
    p_over, eff = DRAWS[truth](rng) if truth in DRAWS else ({}, {})
    # The engineer's nominal model: with the shared cogging law (seed eq. (9)) when the diagnosis's baseline has it.
    base = NOMINAL if settings.diagnose.baseline_cogging else NOMINAL.without_cogging()
    true_nominal = base.with_(**p_over) if p_over else base
    cfg = selftest_plant(settings.baseline, eff)
    force, extra_info = None, None
    if extra is not None:
        factory, _ = OUT_OF_LIBRARY[extra]
        force = factory()
        extra_info = {"name": extra}
    t0 = time.perf_counter()
    gen = generate_dataset(
        cfg,
        true_nominal,
        seed=s_gen,
        settings=settings.generator,
        controller_params=base,
        extra_force=force,
        extra_info=extra_info,
    )
    t_gen = time.perf_counter() - t0
    dset = settings.diagnose.model_copy(update={"seed": int(s_diag.generate_state(1)[0] % (2**31))})
    t0 = time.perf_counter()
    diag = diagnose(gen.dataset, params=base if settings.baseline == "given" else None, settings=dset)
    secs = time.perf_counter() - t0
    true_eff = cfg.effect_values()
    t_res = truth_residuals(diag, gen.true_params, true_eff)
    before = raw_rms(diag.heldout.baseline)
    ideal = 1.0 - raw_rms(t_res) / before if before > 0 else 0.0
    head = diag.verdict.sets.head  # a confusable set is scored by its first (best) member
    sel = [diag.final_score] if diag.final_score is not None else [s for s in diag.scores if s.name == head]
    reduction = sel[0].reduction if sel else 0.0
    name = extra or truth
    right = same_set(diag.verdict.verdict, "unexplained" if extra else truth)
    if extra:
        # Out of the library: right when the channel it acts on carries the unexplained gap.
        ch = OUT_OF_LIBRARY[extra][1]
        regs = diag.remaining_regions or diag.regions
        loc, chans = any(r.channel == ch for r in regs), [ch]
    else:
        loc, chans = _localized(diag, truth, t_res, diag.heldout.baseline)
    params = {"params": p_over, "effects": {k_: v for k_, v in true_eff.items()}, "extra": extra_info}
    verdict = canonical(diag.verdict.verdict)
    return Case(
        index, name, params, verdict, right, float(reduction), float(ideal), bool(loc), secs, t_gen, chans
    ), diag


def canonical(verdict: str) -> str:
    """A verdict naming a set of effects (``b+a``) in library order (``a+b``); others as they are."""
    return EffectSets.parse(verdict).canonical(LIBRARY)


def same_set(verdict: str, truth: str) -> bool:
    """The verdict names exactly the truth's effects (in any order; a confusable set is not right).

    A partly explained verdict (``cogging+unexplained``: the effects found and a located gap they leave) is
    right for the effects it names (:meth:`~.verdict.EffectSets.matches`).
    """
    return EffectSets.parse(verdict).matches(EffectSets.parse(truth), LIBRARY)


def _library_job(job: tuple[int, str, np.random.SeedSequence, SelftestSettings, Path | None]) -> Case:
    """One library self-check case (a worker's job): run it, write its report when kept, return the case."""
    i, truth, seed, settings, keep = job
    case, diag = run_case(i, truth, seed, settings)
    if keep is not None:
        write_report(diag, keep / f"case_{i:02d}")
    return case


def run_selftest(
    settings: SelftestSettings,
    progress: bool = True,
    out_dir: str | os.PathLike | None = None,
    keep_reports: bool = False,
    workers: int = 1,
) -> SelftestResult:
    """Run the blind self-check.

    Parameters
    ----------
    settings : SelftestSettings
        Number of datasets, seed, sizes.
    progress : bool
        Progress bar over the datasets.
    out_dir : path, optional
        Where to write ``selftest.json`` / ``selftest.md`` (after every case, so a long run can be watched).
    keep_reports : bool
        Also write each dataset's diagnosis report into ``out_dir/case_NN``.
    workers : int
        Local worker processes (Dask) the datasets are spread over; every case has its own seed, so the
        result does not depend on it.
    """
    truths = list(settings.truths or ["none", *LIBRARY, *COMBOS])
    if settings.baseline == "calibrated":
        truths = [t for t in truths if t != "parameter_error"]
    bad = [t for t in truths if t not in DRAWS]
    if bad:
        raise ValueError(f"unknown truths {bad}; choose from {sorted(DRAWS)}")
    root = np.random.SeedSequence(settings.seed)
    s_order, s_cases = root.spawn(2)
    rng = np.random.default_rng(s_order)
    order: list[str] = []
    while len(order) < settings.n:
        order += list(rng.permutation(truths))
    order = order[: settings.n]
    keep = Path(out_dir) if (keep_reports and out_dir is not None) else None
    seeds = s_cases.spawn(settings.n)
    jobs = [(i, str(t), s, settings, keep) for i, (t, s) in enumerate(zip(order, seeds, strict=True))]
    save = save_partial(SelftestResult, settings, out_dir)
    return SelftestResult(settings, map_ordered(_library_job, jobs, workers, "self-check", progress, save))


def save_partial(result_cls: type, settings: SelftestSettings, out_dir: str | os.PathLike | None):
    """A :func:`maglev_ocp.parallel.map_ordered` callback saving the cases finished so far (or ``None``)."""
    if out_dir is None:
        return None

    def save(done: dict[int, Case]) -> None:
        result_cls(settings, [done[i] for i in sorted(done)]).save(out_dir)

    return save


__all__ = [
    "COMBOS",
    "DRAWS",
    "Case",
    "SelftestResult",
    "SelftestSettings",
    "canonical",
    "run_case",
    "run_selftest",
    "same_set",
    "save_partial",
    "selftest_plant",
    "truth_residuals",
]
