"""Test (a) of the claim guard for saturation: a loss of the magnetic terms the same along the stroke, not one at the
stroke's ends (:func:`maglev_ocp.diagnosis.signatures.evidence`).

The residuals are built here from laws written for the test, none the library's: an iron whose permeability
follows Frohlich-Kennelly's law (Jiles, *Introduction to Magnetism and Magnetic Materials*, 3rd ed., 2016, ch. 3:
``mu = mu_0 / (1 + H / H_s)``), so that the magnetic terms lose ``b / (b_s + b)`` of themselves at a flux density
``b`` that grows as the gap closes (``b ~ 1 / sinh(pi (h_m + g) / tau)``, MODEL.md's field, normalized to 1 at
10 mm), uniformly along the stroke; and a double-layer winding's half-filled end slots (Pyrhonen, Jokinen &
Hrabovcova, *Design of Rotating Electrical Machines*, 2nd ed., 2014, ch. 2), where the currents' linkage drops as
the array covers the last slots of each end: the thrust and the PM-current pull lose ``0.2`` of themselves
linearly over ``|d|`` from 25 to 45 mm, whatever the gap. The currents follow the gap and the motion with a dither
of their own, as a closed loop's do. A slight Frohlich-Kennelly loss (``b_s`` 320: 0.3 % at 10 mm) is far beyond
its null though it explains less than 0.3 of the noise floor (the materiality bar,
:func:`~maglev_ocp.diagnosis.signatures.material_bar`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from residual_runs import swept_runs

from maglev_ocp.diagnosis.residuals import Residual
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import evidence

FLOOR = 0.01  # noise rms [m/s^2]
FLOORS = {"vertical": FLOOR, "horizontal": FLOOR}
ST = DiagnoseSettings()
MV, MH = 4.35, 1.59  # moving masses [kg]
TAU, HM = 0.05715, 0.006  # pole pitch, magnet height [m]
C1, C3 = 14.2, 31.0  # thrust [N/A] and PM-current pull [N/A] at 10 mm (MODEL.md's C1, C3, their gap law left out)


def _b(g: np.ndarray) -> np.ndarray:
    """The array's field at the gap ``g``, 1 at 10 mm."""
    return math.sinh(math.pi * (HM + 0.01) / TAU) / np.sinh(math.pi * (HM + g) / TAU)


def frohlich(feat, c):
    """Frohlich-Kennelly iron, ``b_s`` = 2.5: the currents' terms lose ``b / (b_s + b)`` [m/s^2]."""
    loss = _b(feat["g"]) / (2.5 + _b(feat["g"]))
    return -loss * C3 * feat["i_d"] / MV if c == 0 else -loss * C1 * feat["i_q"] / MH


def half_filled(feat, c):
    """Half-filled end slots: the currents' terms lose 0.2 of themselves from |d| = 25 mm to 45 mm [m/s^2]."""
    loss = 0.2 * np.clip((np.abs(feat["d"]) - 0.025) / 0.02, 0.0, 1.0)
    return -loss * C3 * feat["i_d"] / MV if c == 0 else -loss * C1 * feat["i_q"] / MH


def _runs(force, seed: int) -> list[Residual]:
    """Held-out-like runs (:func:`residual_runs.swept_runs`) at this test's noise floor."""
    return swept_runs(force, seed, FLOOR)


def _ev(effect: str, force, seed: int):
    return evidence(effect, _runs(force, seed), dict(FLOORS), n_null=ST.signature_null, alpha=ST.signature_alpha,
                    min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


@pytest.mark.parametrize("seed", [31, 32])
def test_an_irons_saturation_shows_as_saturation(seed):
    """The Frohlich-Kennelly iron loses its currents' terms along the whole stroke: saturation's signature shows."""
    ev = _ev("saturation", frohlich, seed)
    assert ev.shows, ev.per_channel


@pytest.mark.parametrize("seed", [33, 34])
def test_a_loss_of_the_currents_terms_at_the_ends_is_an_end_effect_not_saturation(seed):
    """The half-filled end slots lose the currents' terms only at the ends: the end effect's signature shows, and
    saturation's does not beyond the end-localized loss."""
    assert _ev("end_effect", half_filled, seed).shows
    ev = _ev("saturation", half_filled, seed)
    assert not ev.shows, ev.per_channel


def slight_frohlich(feat, c):
    """Frohlich-Kennelly iron far from saturation, ``b_s`` = 320: the currents' terms lose ``b / (b_s + b)`` (0.3 %
    at 10 mm) [m/s^2]."""
    loss = _b(feat["g"]) / (320.0 + _b(feat["g"]))
    return -loss * C3 * feat["i_d"] / MV if c == 0 else -loss * C1 * feat["i_q"] / MH


@pytest.mark.parametrize("seed", [51, 52, 53])
def test_a_slight_loss_far_beyond_its_null_is_saturation(seed):
    """A loss of a few tenths of a percent explains less than 0.3 of the noise floor in every channel (the bar of a
    barely significant share), but its share is many times its null's: it shows as saturation, its core too."""
    ev = _ev("saturation", slight_frohlich, seed)
    assert ev.shows, ev.per_channel
    for rec in ev.per_channel.values():
        assert rec["rms_explained_over_floor"] < ST.signature_min_floor
        assert rec["explained"] > 4 * rec["null_q"]
    assert any(rec["core_shows"] for rec in ev.per_channel.values())


def test_the_materiality_bar():
    """:func:`material_bar`: the full bar up to twice the null quantile (and without a finite null), lower beyond,
    never below half of it, never rising with the share."""
    from maglev_ocp.diagnosis.signatures import material_bar

    assert material_bar(0.3, 0.02, 0.01) == 0.3
    assert material_bar(0.3, 0.02, math.inf) == 0.3
    assert material_bar(0.3, 0.08, 0.01) == pytest.approx(0.3 * math.sqrt(0.25))
    assert material_bar(0.3, 0.5, 0.01) == pytest.approx(0.15)
    bars = [material_bar(0.3, s, 0.01) for s in np.linspace(0.0, 0.5, 51)]
    assert all(np.diff(bars) <= 0.0)
