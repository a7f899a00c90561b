"""Test (a) of the claim guard for a commutation offset: at a fixed position its error follows the currents
(:func:`maglev_ocp.diagnosis.signatures.evidence`, the signature's core).

The residuals are built here from laws written for the test, none the library's. A commutation offset ``delta``
rotates the currents the drive applies (the dq transformation, Krishnan, *Permanent Magnet Synchronous and
Brushless DC Motor Drives*, 2010, ch. 3): the thrust gains ``C1 sin(delta) i_d`` and the PM-current pull loses
``C3 sin(delta) i_q``; the levitation current follows the gap, so at a fixed position the thrust error changes
with the gap. Gravity on a base tilted by ``theta0 + kappa d`` (compliant feet giving under the mover) pulls along
the stroke with ``-g0 sin(theta0 + kappa d)`` per unit mass (Newton), and a cable's spring with ``-k d / Mh``:
forces of the position alone, which a flexible function of ``d`` takes in full.
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
C1, C3 = 14.2, 31.0  # thrust and PM-current pull [N/A] (MODEL.md's C1, C3 at 10 mm; their gap law left out)
G0 = 9.81  # [m/s^2]


def commutation(feat, c):
    """A 0.03 rad offset: ``C1 sin(delta) i_d`` into the thrust, ``-C3 sin(delta) i_q`` off the pull [m/s^2]."""
    s = math.sin(0.03)
    return -C3 * s * feat["i_q"] / MV if c == 0 else C1 * s * feat["i_d"] / MH


def tilt(feat, c):
    """A base off level by 5 mrad, 0.1 rad/m more along the stroke: gravity along d [m/s^2]."""
    return np.zeros_like(feat["d"]) if c == 0 else -G0 * np.sin(0.005 + 0.1 * feat["d"])


def cable(feat, c):
    """A cable's spring of 20 N/m along d, centred 10 mm off the middle [m/s^2]."""
    return np.zeros_like(feat["d"]) if c == 0 else -20.0 * (feat["d"] - 0.01) / MH


def _runs(force, seed: int) -> list[Residual]:
    """Held-out-like runs (:func:`residual_runs.swept_runs`) at this test's noise floor."""
    return swept_runs(force, seed, FLOOR)


def _ev(force, seed: int):
    return evidence("commutation_offset", _runs(force, seed), dict(FLOORS), n_null=ST.signature_null,
                    alpha=ST.signature_alpha, min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


@pytest.mark.parametrize("seed", [41, 42])
def test_a_rotation_of_the_currents_shows_at_a_fixed_position(seed):
    """The offset's thrust error follows i_d, which changes with the gap at a fixed position: its core shows."""
    ev = _ev(commutation, seed)
    assert ev.shows, ev.per_channel
    assert ev.per_channel["horizontal"]["core_shows"], ev.per_channel


@pytest.mark.parametrize(("force", "seed"), [(tilt, 45), (cable, 47)])
def test_a_force_of_the_position_alone_is_not_a_commutation_offset(force, seed):
    """Gravity on a tilted base and a cable's spring are functions of d: nothing of them is left at a fixed
    position, so the offset's signature does not show, whatever its basis takes of them beyond a constant."""
    ev = _ev(force, seed)
    assert not ev.shows, ev.per_channel
    assert not any(r.get("core_shows") for r in ev.per_channel.values()), ev.per_channel


def shielded_heads(feat, c):
    """Heads that read the array through a conducting plate: the field reaches them delayed by the sheet's time
    constant (3 ms), so the angle lags by the phase of a thin sheet's transmission ``1 / (1 + j w tau_s)`` at the
    electrical frequency ``w = pi v / tau`` (Stoll, *The Analysis of Eddy Currents*, 1974, ch. 3): ``delta =
    -atan(pi v tau_s / tau)``, odd in the speed and saturating; its rotation of the currents [m/s^2]."""
    s = np.sin(-np.arctan(math.pi * feat["d_dot"] * 3e-3 / 0.05715))
    return -C3 * s * feat["i_q"] / MV if c == 0 else C1 * s * feat["i_d"] / MH


@pytest.mark.parametrize("seed", [48, 49])
def test_an_angle_lagging_with_the_speed_is_a_commutation_offset(seed):
    """A rotation that follows the speed (a shield's or a sensor's delay) shows as the commutation offset's, at a
    fixed position too (its thrust error follows i_d times the speed)."""
    ev = _ev(shielded_heads, seed)
    assert ev.shows and ev.per_channel["horizontal"]["core_shows"], ev.per_channel


def test_the_latency_turns_the_angle_by_the_electrical_angle_travelled():
    """``CommutationOffset.angle``: a latency ``t`` lags the angle by ``(pi / tau) t v`` (seed section III's
    electrical angle ``pi d / tau``); without a speed, or with the default latency, nothing changes."""
    from maglev_ocp import constants as k
    from maglev_ocp.effects import CommutationOffset

    th = {**CommutationOffset.defaults(), "delta": 0.02, "latency": 2e-3}
    got = float(CommutationOffset.angle(0.0, th, 0.02, 0.15))
    assert got == pytest.approx(0.02 - math.pi / k.tau * 2e-3 * 0.15, rel=1e-12)
    assert float(CommutationOffset.angle(0.0, th, 0.02)) == pytest.approx(0.02, rel=1e-12)
    base = CommutationOffset.defaults()
    assert float(CommutationOffset.angle(0.01, base, 0.02, 0.3)) == float(CommutationOffset.angle(0.01, base, 0.02))
