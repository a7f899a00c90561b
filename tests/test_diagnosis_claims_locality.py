"""Test (d) of the claim guard: an end effect acts at the ends of the stroke (issue 27, item 2).

:func:`maglev_ocp.diagnosis.stages.claims.end_locality` measures how much of a fitted end effect's action (the
force lost as the array overhangs, or the end forces' onset) lies within the middle sixth of the stroke the runs
visit (``|d| <= stroke / 6``). The truths are computed here by hand from the geometric overhang law (MODEL.md's
end effect: a loss linear in the overhang ``|d| - d_edge`` once it starts, smoothed over ``edge_width``), not by
the code under test.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from maglev_ocp.diagnosis.library import CandidateSpec
from maglev_ocp.diagnosis.stages.claims import end_locality

STROKE = 0.045  # the runs visit +-45 mm
#: the 99th percentile of |d| of a uniform sweep over +-45 mm (the stroke the test measures against) [m]
S99 = 0.99 * STROKE


def _run() -> SimpleNamespace:
    # a uniform sweep of d over +-45 mm, in a training and a held-out run
    d = np.linspace(-STROKE, STROKE, 9001)
    runs = [SimpleNamespace(feat={"d": d}), SimpleNamespace(feat={"d": -d})]
    return SimpleNamespace(split=SimpleNamespace(train=runs[:1], test=runs[1:]))


def _att(**params: float) -> SimpleNamespace:
    spec = CandidateSpec("end_effect", ("end_effect",))
    fit = SimpleNamespace(spec=spec, params=lambda: {f"end_effect.{k}": v for k, v in params.items()})
    return SimpleNamespace(final_spec=spec, final_fit=fit)


def test_a_loss_from_the_middle_of_the_stroke_is_measured_as_such() -> None:
    """Onset at 2 mm, sharp (0.1 mm): the loss is linear in ``|d| - 2 mm``, so at the middle sixth's edge
    (44.55 mm / 6 = 7.43 mm) it is (7.43 - 2) / (44.55 - 2) = 0.128 of its largest."""
    loc = end_locality(_run(), _att(d_edge=0.002, edge_width=1e-4, edge_gain=1.0))
    assert loc is not None
    assert loc["stroke_mm"] == pytest.approx(S99 * 1e3, rel=1e-3)
    assert loc["inner_share"] == pytest.approx((S99 / 6 - 0.002) / (S99 - 0.002), abs=0.005)


def test_an_overhang_at_the_ends_leaves_the_middle_untouched_and_each_end_counts() -> None:
    """Onset at 30 mm, smoothed over 3 mm: at 7.4 mm the softplus is ``3 mm ln(1 + e^-7.5)``, nothing against
    ``~15 mm`` at the stroke's end. Moved by ``edge_skew`` = -27 mm, the end at d > 0 starts at 3 mm while the
    other stays at 57 mm (beyond the stroke): the share is (7.43 - 3) / (44.55 - 3) = 0.107 from that end alone."""
    assert end_locality(_run(), _att(d_edge=0.03, edge_width=3e-3, edge_gain=1.0))["inner_share"] < 1e-3
    loc = end_locality(_run(), _att(d_edge=0.03, edge_width=1e-4, edge_gain=1.0, edge_skew=-0.027))
    assert loc["inner_share"] == pytest.approx((S99 / 6 - 0.003) / (S99 - 0.003), abs=0.005)


def test_an_end_force_counts_where_it_acts_and_a_ripple_alone_is_not_judged() -> None:
    """An end force with its onset at 4 mm (2 mm wide) acts from there on: its logistic onset at the middle
    sixth's edge is ``1 / (1 + e^-((7.43 - 4) / 2))`` = 0.85 of its largest; a model whose end effect is only a
    thrust ripple has no overhang action to judge (``None``). Tolerance: the test's grid steps by 0.19 mm, over
    which the onset rises by 0.012 there."""
    loc = end_locality(_run(), _att(d_edge=0.004, edge_width=2e-3, edge_gain=0.0, end_force=1.0))
    assert loc is not None
    assert loc["inner_share"] == pytest.approx(1 / (1 + np.exp(-(S99 / 6 - 0.004) / 2e-3)), abs=0.015)
    assert end_locality(_run(), _att(edge_gain=0.0, ripple=0.05)) is None
