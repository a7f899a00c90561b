"""Eddy drag's signature on the gap axis: a conductor's damping of the gap's own motion shows as eddy drag, a flat
damping of the gap does not (:func:`maglev_ocp.diagnosis.signatures.evidence`).

The residuals are built here from laws written for the test, none the library's (whose member is an exponential in
the gap, :meth:`maglev_ocp.effects.EddyDrag.gap_coefficient`):

* a solid back iron's Lenz damping: the flux of the magnets through it changes at ``dPhi/dg g_dot`` and the eddy
  currents' loss goes with the square of that rate (Stoll, *The Analysis of Eddy Currents*, Clarendon 1974,
  ch. 1), so its coefficient follows ``(dB/dg)^2`` of MODEL.md's field ``B ~ 1 / sinh(pi (h_m + g) / tau)``;
* a thin plate's damping of a magnet approaching it, a power law of the distance (Sodano, Bae & Inman, "Improved
  concept and model of eddy current damper", J. Vib. Acoust. 128(3), 2006: the normal damping falls roughly as
  the field's square at the plate, here ``(15 mm / g)^4``);
* a flat damping of the gap (a cable's loss, the air under a cover at low frequency), and a leaky air cushion
  (a Maxwell element, ``F = -k q``, ``q' = g_dot - q / tau_l``: Harris & Piersol, *Shock and Vibration
  Handbook*, air springs): neither is a conductor's, whose coefficient follows the gap.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from residual_runs import still_current_runs

from maglev_ocp import constants as k
from maglev_ocp.diagnosis.residuals import Residual
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import evidence
from maglev_ocp.effects import EddyDrag

FLOOR = 0.02  # noise rms [m/s^2]
FLOORS = {"vertical": FLOOR, "horizontal": FLOOR}
ST = DiagnoseSettings()
MV = 4.0  # vertical moving mass [kg]


def _flux_slope(g):
    """``|dB/dg|`` of ``B = 1 / sinh(pi (h_m + g) / tau)`` (arbitrary scale)."""
    a = math.pi * (k.hm + g) / k.tau
    return np.cosh(a) / np.sinh(a) ** 2


def back_iron(feat, c):
    """A solid back iron's damping [m/s^2]: ``-12 N s/m ((dB/dg)(g) / (dB/dg)(15 mm))^2 g_dot``; nothing along d."""
    if c == 1:
        return np.zeros_like(feat["t"])
    return -12.0 * (_flux_slope(feat["g"]) / _flux_slope(0.015)) ** 2 * feat["g_dot"] / MV


def plate_power(feat, c):
    """A plate's normal damping [m/s^2]: ``-10 N s/m (15 mm / g)^4 g_dot``; nothing along d."""
    if c == 1:
        return np.zeros_like(feat["t"])
    return -10.0 * (0.015 / feat["g"]) ** 4 * feat["g_dot"] / MV


def flat_gap(feat, c):
    """A flat damping of the gap [m/s^2]: ``-12 N s/m g_dot``."""
    return np.zeros_like(feat["t"]) if c == 1 else -12.0 * feat["g_dot"] / MV


def air_cushion(feat, c):
    """A leaky air cushion on the gap [m/s^2]: ``-k_a q``, ``q' = g_dot - q / tau_l`` (2.5 kN/m, 12 ms)."""
    if c == 1:
        return np.zeros_like(feat["t"])
    t, gd = feat["t"], feat["g_dot"]
    q, a = np.zeros_like(gd), math.exp(-(t[1] - t[0]) / 0.012)
    for i in range(1, len(gd)):  # exact for g_dot held over the step
        q[i] = a * q[i - 1] + 0.012 * (1 - a) * gd[i - 1]
    return -2500.0 * q / MV


def _runs(force, seed: int) -> list[Residual]:
    """Held-out-like runs: sweeps along d and of the gap, residual ``force(feat) + noise``."""
    return still_current_runs(force, seed, FLOOR)


def _shows(effect: str, force, seed: int):
    return evidence(effect, _runs(force, seed), dict(FLOORS), n_null=ST.signature_null, alpha=ST.signature_alpha,
                    min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


@pytest.mark.parametrize(("force", "seed"), [(back_iron, 31), (back_iron, 32), (plate_power, 33)])
def test_a_conductors_damping_of_the_gap_is_eddy_drag_not_friction(force, seed):
    """A damping of the gap that falls as the gap opens shows eddy drag's signature on the gap axis, and friction's
    (a guide's dry level) does not."""
    ev = _shows("eddy_drag", force, seed)
    assert ev.shows and ev.per_channel["vertical"]["shows"], ev.per_channel
    assert not _shows("friction", force, seed).shows


@pytest.mark.parametrize(("force", "seed"), [(flat_gap, 34), (air_cushion, 35)])
def test_a_flat_damping_of_the_gap_is_not_eddy_drag(force, seed):
    """A damping of the gap whose coefficient does not follow the gap (a flat one, a leaky air cushion) is most of
    the vertical residual (over 80 % taken by a flat g_dot), and eddy drag's signature does not show beyond it."""
    ev = _shows("eddy_drag", force, seed)
    assert ev.per_channel["vertical"]["beyond_share"] > 0.8, ev.per_channel
    assert not ev.shows, ev.per_channel


def test_the_normal_damping_follows_its_own_coefficient():
    """``EddyDrag.forces``: the gap's damping is ``-c_gap exp(-kappa_gap (g - 10 mm)) g_dot`` (at 10 mm: ``-c_gap
    g_dot``; 10 mm above, ``exp(-10 mm kappa_gap)`` of it), the drag along d untouched, nothing by default."""
    th = {**EddyDrag.defaults(), "c_eddy": 0.0, "c_gap": 15.0, "kappa_gap": 80.0}
    for g, want in ((0.010, -15.0 * 0.02), (0.020, -15.0 * math.exp(-0.8) * 0.02)):
        f_g, f_d = EddyDrag.forces(g, 0.1, th, g_dot=0.02)
        assert float(f_g) == pytest.approx(want, rel=1e-12) and float(f_d) == 0.0
    f_g, _ = EddyDrag.forces(0.015, 0.1, EddyDrag.defaults(), g_dot=0.02)
    assert float(f_g) == 0.0
    lo, hi = EddyDrag.KAPPA_GAP_BOUNDS
    assert math.exp(-0.010 * lo) == pytest.approx(1 / 1.5) and hi > 2 * math.pi / k.tau  # never flat in the gap
