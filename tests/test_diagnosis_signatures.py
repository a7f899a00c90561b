"""Effect signatures in a residual (:mod:`maglev_ocp.diagnosis.signatures`): each shows where its physics is,
not where another's is; pure noise shows none; a period in d that is no library period is located.

The residuals are built here from closed forms written for the test (a slot-periodic force, a Coulomb force,
white noise), not from the library's laws.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from residual_runs import feature_residual

from maglev_ocp import constants as k
from maglev_ocp.diagnosis.residuals import Residual
from maglev_ocp.diagnosis.signatures import SIGNATURES, evidence, locate_gap

FLOOR = 0.02  # noise rms [m/s^2]
FLOORS = {"vertical": FLOOR, "horizontal": FLOOR}


def _runs(force, seed: int = 0, n_runs: int = 3, n: int = 1500) -> list[Residual]:
    """Held-out-like runs: smooth random motion in g and d, currents, and the residual ``force(feat) + noise``."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n_runs):
        t = np.arange(n) * 8e-3
        f1, f2, f3 = rng.uniform(0.15, 0.5, 3)
        ph = rng.uniform(0, 2 * math.pi, 4)
        d = 0.045 * np.sin(2 * math.pi * f1 * t + ph[0])
        g = 0.012 + 0.003 * np.sin(2 * math.pi * f2 * t + ph[1])
        feat = {
            "t": t,
            "g": g,
            "d": d,
            "g_dot": np.gradient(g, t),
            "d_dot": np.gradient(d, t),
            "i_q": 0.8 * np.sin(2 * math.pi * f3 * t + ph[2]),
            "i_d": 1.5 + 0.4 * np.sin(2 * math.pi * 0.37 * t + ph[3]),
        }
        out.append(feature_residual(f"run{i}", feat, force, FLOOR, rng))
    return out


def _cogging(feat, c):
    """A slot-periodic force with its own decay in g (not eq. (9)'s): 0.15 m/s^2 at 10 mm."""
    amp = 0.15 * (0.6 * np.exp(-(feat["g"] - 0.01) / 2e-3) + 0.4 * np.exp(-(feat["g"] - 0.01) / 8e-3))
    return amp * np.sin(2 * math.pi * feat["d"] / k.t1 + 0.4 + c)


def _coulomb(feat, c):
    """A Coulomb force of each guide, 0.1 m/s^2, against the velocity of the channel's axis."""
    v = feat["g_dot"] if c == 0 else feat["d_dot"]
    return -0.1 * np.sign(v)


def test_each_signature_shows_where_its_physics_is():
    """Cogging shows in a slot-periodic residual and friction does not; friction shows in a Coulomb residual
    and cogging does not (explained share above the circular-shift null and above 0.3x the floor)."""
    cog = _runs(_cogging)
    fric = _runs(_coulomb, seed=1)
    assert evidence("cogging", cog, FLOORS).shows
    assert not evidence("friction", cog, FLOORS).shows
    assert evidence("friction", fric, FLOORS).shows
    assert not evidence("cogging", fric, FLOORS).shows
    ev = evidence("cogging", cog, FLOORS)
    # Most of the slot-periodic force is in the signature's span (its amplitude is smooth in g).
    assert ev.per_channel["horizontal"]["explained"] > 0.8


@pytest.mark.parametrize("seed", [3, 4])
def test_white_noise_shows_no_signature(seed):
    """No effect's signature shows in a residual of white noise at the floor."""
    res = _runs(lambda f, c: 0.0 * f["t"], seed=seed)
    assert [e for e in SIGNATURES if evidence(e, res, FLOORS, seed=seed).shows] == []


def test_another_effects_basis_is_fitted_first():
    """A saturation-like basis does not count where the friction basis, fitted first, explains the residual."""
    fric = _runs(_coulomb, seed=5)
    ev = evidence("eddy_drag", fric, FLOORS, others=["friction"])
    assert not ev.shows


def test_a_period_that_is_no_library_period_is_located():
    """A force periodic in d with 33 mm (no slot or pole pitch) is located at that period; a slot-periodic
    force is not reported as a gap."""
    odd = _runs(lambda f, c: 0.1 * np.sin(2 * math.pi * f["d"] / 0.033) * (c == 1), seed=6)
    found = locate_gap(odd, FLOORS)
    per = [g for g in found if g["kind"] == "period"]
    assert len(per) == 1 and per[0]["channel"] == "horizontal"
    assert per[0]["period_m"] == pytest.approx(0.033, rel=0.03)
    assert [g for g in locate_gap(_runs(_cogging, seed=7), FLOORS) if g["kind"] == "period"] == []


def test_same_seed_same_evidence():
    """The null draws come from the seed: the same seed gives the same numbers."""
    res = _runs(_cogging, seed=8)
    a = evidence("friction", res, FLOORS, seed=11).to_dict()
    b = evidence("friction", res, FLOORS, seed=11).to_dict()
    assert a == b


def test_an_eddy_lift_shows_eddy_drag_and_not_friction():
    """Reitz's lift of a magnet over a conducting sheet (Reitz 1970, even in the velocity, written here:
    ``F0 v^2 / (v^2 + w^2)``, w = 30 mm/s, F0 falling with the gap) on the vertical channel alone shows eddy
    drag's signature and not friction's (odd in each velocity). (Cogging's does show a little here: on a
    sinusoidal stroke ``v^2`` is a function of d, which its slot harmonics partly span.)"""

    def lift(feat, c):
        v = feat["d_dot"]
        return (c == 0) * 0.2 * np.exp(-(feat["g"] - 0.012) / 5e-3) * v**2 / (v**2 + 0.03**2)

    res = _runs(lift, seed=8)
    ev = evidence("eddy_drag", res, FLOORS)
    assert ev.shows and ev.per_channel["vertical"]["shows"], ev.to_dict()
    assert not evidence("friction", res, FLOORS).shows
