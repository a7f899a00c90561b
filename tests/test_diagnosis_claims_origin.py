"""Test (d) of the claim guard, the end force's origin: a push at the stroke's end that does not fall with the gap
is a contact's, not an end effect's (issue 27, item 2).

An end effect's end force is the overlap's co-energy pulled along d, ``-dW/dd``, with ``W`` following the field's
energy over the iron, ``B(g)^2``: it falls as the gap opens, over ``tau / (2 pi)`` for the poles' fundamental
(MODEL.md's field ``~ 1 / sinh(pi (hm + g) / tau)``, squared). A stop's bumper pushes whatever the gap. The guard
judges only an end effect seen along d alone whose fitted loss of the magnetic terms is nil. The truths here are
written by hand: ``tau = 57.15 mm`` (Table I), so ``tau / (2 pi) = 9.096 mm`` and the bound at the default
``end_force_decay = 2`` is 18.19 mm; the loss of the geometric overhang law is ``(|d| - d_edge) / (pm tau)``
beyond a sharp onset, ``pm tau = 228.6 mm``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import SignatureEvidence
from maglev_ocp.diagnosis.stages.claims import END_LOSS_NIL, _origin_why, end_origin

STROKE = 0.045  # the runs visit +-45 mm
S99 = 0.99 * STROKE  # the 99th percentile of |d| of a uniform sweep over +-45 mm [m]
BOUND_MM = 2 * 57.15 / (2 * math.pi)  # 18.19 mm


def _run(**settings: float) -> SimpleNamespace:
    d = np.linspace(-STROKE, STROKE, 9001)
    runs = [SimpleNamespace(feat={"d": d}), SimpleNamespace(feat={"d": -d})]
    return SimpleNamespace(split=SimpleNamespace(train=runs[:1], test=runs[1:]), settings=DiagnoseSettings(**settings))


def _att(se_ell: float, **params: float) -> SimpleNamespace:
    """A verdict's model with an end effect of ``params``, the decay length's standard error ``se_ell`` [m]."""
    keys = [f"end_effect.{k}" for k in params]
    spec = SimpleNamespace(effects=("end_effect",), free=[SimpleNamespace(key=key) for key in keys], fixed=(), ties=())
    stderr = np.array([se_ell if key == "end_effect.end_ell" else 0.0 for key in keys])
    fit = SimpleNamespace(spec=spec, params=lambda: dict(zip(keys, params.values(), strict=True)), stderr=stderr)
    return SimpleNamespace(final_spec=spec, final_fit=fit)


def _ev(vertical: bool) -> SignatureEvidence:
    return SignatureEvidence("end_effect", {"vertical": {"shows": vertical}, "horizontal": {"shows": True}}, True)


#: A contact at the stroke's end as the fit renders it: a sharp end force near the stroke's end, no loss.
CONTACT = dict(d_edge=0.044, edge_width=1e-3, edge_gain=0.0, end_force=4.0)


def test_a_push_at_the_end_that_does_not_fall_with_the_gap_is_refused_as_a_contact() -> None:
    """Decay 21 +- 9 mm: 30 mm > 18.19 mm; an undetermined decay (NaN standard error) is refused too."""
    rec: dict = {}
    why = _origin_why(_run(), _att(9e-3, end_ell=0.021, **CONTACT), _ev(False), rec)
    assert "contact" in why and "not claimed" in why
    assert rec["origin"]["field_mm"] == pytest.approx(57.15 / (2 * math.pi), rel=1e-6)
    assert rec["origin"]["decay_mm"] == pytest.approx(21.0) and rec["origin"]["decay_se_mm"] == pytest.approx(9.0)
    assert rec["origin"]["loss_peak"] < END_LOSS_NIL
    why = _origin_why(_run(), _att(math.nan, end_ell=0.008, **CONTACT), _ev(False), {})
    assert "undetermined" in why


def test_a_force_falling_with_the_gap_as_the_fields_energy_is_kept() -> None:
    """Decay 8.7 +- 0.2 mm (a field's energy of the pole pitch) and 9.3 +- 7.7 mm (17.0 mm <= 18.19 mm) pass; at
    ``end_force_decay = 1`` (9.10 mm) the second no longer does, and 0 switches the test off."""
    assert _origin_why(_run(), _att(2e-4, end_ell=0.0087, **CONTACT), _ev(False), {}) == ""
    assert _origin_why(_run(), _att(7.7e-3, end_ell=0.0093, **CONTACT), _ev(False), {}) == ""
    assert _origin_why(_run(end_force_decay=1.0), _att(7.7e-3, end_ell=0.0093, **CONTACT), _ev(False), {}) != ""
    assert _origin_why(_run(end_force_decay=0.0), _att(9e-3, end_ell=0.021, **CONTACT), _ev(False), {}) == ""


def test_a_pull_change_or_a_loss_of_the_magnetic_terms_is_magnetic_by_itself() -> None:
    """Shown in the gap channel (the pull's loss, ``-dW/dg``), or with a loss of the magnetic terms: the same
    undetermined decay is not judged. The loss from a sharp onset at 30 mm reaches (44.55 - 30) / 228.6 = 0.064 at
    the stroke's 99th percentile."""
    assert _origin_why(_run(), _att(9e-3, end_ell=0.021, **CONTACT), _ev(True), {}) == ""
    lossy = dict(CONTACT, d_edge=0.03, edge_width=1e-4, edge_gain=1.0)
    org = end_origin(_run(), _att(9e-3, end_ell=0.021, **lossy))
    assert org is not None and org["loss_peak"] == pytest.approx((S99 - 0.03) / 0.2286, rel=0.02)
    assert _origin_why(_run(), _att(9e-3, end_ell=0.021, **lossy), _ev(False), {}) == ""
    assert end_origin(_run(), _att(9e-3, end_ell=0.021, **dict(CONTACT, end_force=0.0))) is None
