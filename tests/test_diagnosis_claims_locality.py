"""Test (d) of the claim guard: an end effect acts at the ends of the stroke (issue 27, item 2).

:func:`maglev_ocp.diagnosis.stages.claims.end_locality` measures how much of a fitted end effect's action (the
force lost as the array overhangs, or the end forces' onset) lies within the middle third of the stroke the runs
visit. The truths are computed here by hand from the geometric overhang law (MODEL.md's end effect: a loss
linear in the overhang ``|d| - d_edge`` once it starts, smoothed over ``edge_width``), not by the code under test.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from maglev_ocp.diagnosis.library import CandidateSpec
from maglev_ocp.diagnosis.stages.claims import end_locality

STROKE = 0.045  # the runs visit +-45 mm


def _run() -> SimpleNamespace:
    # a uniform sweep of d over +-45 mm, in a training and a held-out run
    d = np.linspace(-STROKE, STROKE, 9001)
    runs = [SimpleNamespace(feat={"d": d}), SimpleNamespace(feat={"d": -d})]
    return SimpleNamespace(split=SimpleNamespace(train=runs[:1], test=runs[1:]))


def _att(**params: float) -> SimpleNamespace:
    spec = CandidateSpec("end_effect", ("end_effect",))
    fit = SimpleNamespace(params=lambda: {f"end_effect.{k}": v for k, v in params.items()})
    return SimpleNamespace(final_spec=spec, final_fit=fit)


def test_a_loss_from_the_middle_of_the_stroke_is_measured_as_such() -> None:
    """Onset at 5 mm, sharp (0.1 mm): the loss is linear in ``|d| - 5 mm``, so at the middle third's edge
    (15 mm of the 99th percentile of |d|, 44.55 mm / 3) it is (14.85 - 5) / (44.55 - 5) = 0.249 of its largest."""
    loc = end_locality(_run(), _att(d_edge=0.005, edge_width=1e-4, edge_gain=1.0))
    stroke = np.quantile(np.linspace(0, STROKE, 4501), 0.99)  # |d| of the sweep: uniform on [0, 45 mm]
    assert loc is not None
    assert loc["stroke_mm"] == pytest.approx(stroke * 1e3, rel=1e-3)
    assert loc["inner_share"] == pytest.approx((stroke / 3 - 0.005) / (stroke - 0.005), abs=0.01)


def test_an_overhang_at_the_ends_leaves_the_middle_third_untouched() -> None:
    """Onset at 30 mm, smoothed over 3 mm: at 15 mm the softplus is ``3 mm ln(1 + e^-5) = 0.02 mm`` against
    ``~15 mm`` at the stroke's end, a share of about 1e-3."""
    loc = end_locality(_run(), _att(d_edge=0.03, edge_width=3e-3, edge_gain=1.0))
    assert loc is not None
    assert loc["inner_share"] < 3e-3


def test_an_end_force_counts_where_it_acts_and_a_ripple_alone_is_not_judged() -> None:
    """An end force with its onset at 8 mm acts from there on: its logistic onset at the middle third's
    edge (14.85 mm) is ``1 / (1 + e^-((14.85 - 8) / 2))`` = 0.97 of its largest; a model whose end effect is
    only a thrust ripple has no overhang action to judge (``None``)."""
    loc = end_locality(_run(), _att(d_edge=0.008, edge_width=2e-3, edge_gain=0.0, end_force=1.0))
    assert loc is not None
    assert loc["inner_share"] == pytest.approx(1 / (1 + np.exp(-3.5)), abs=0.02)
    assert end_locality(_run(), _att(edge_gain=0.0, ripple=0.05)) is None
