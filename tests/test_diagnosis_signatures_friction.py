"""Test (a) of the claim guard for friction: a guide's friction is told by its dry level, not by any drag against
the velocity (:func:`maglev_ocp.diagnosis.signatures.evidence`).

The residuals are built here from laws written for the test, none the library's: a guide's Tustin friction
(Armstrong-Helouvry, Dupont & Canudas de Wit, "A survey of models, analysis tools and compensation methods for
the control of machines with friction", Automatica 30(7), 1994: Coulomb, Stribeck and viscous parts), the squeeze
film of the air under the mover (Blech, "On isothermal squeeze films", J. Lubr. Technol. 105(4), 1983: at low
squeeze numbers a damping ``c ~ mu A^2 / h^3`` of the gap's rate, no level at rest), a conductor beside the array
whose drag grows as the gap opens (a power law of the facing area), and a viscous drag along d with a flat
coefficient (a guide's viscous friction without a measurable Coulomb level, or an eddy drag at one gap: the
confusable pair an experiment separates, issue 27 item 3).
"""

from __future__ import annotations

import numpy as np
import pytest
from residual_runs import still_current_runs

from maglev_ocp.diagnosis.residuals import Residual
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import evidence

FLOOR = 0.02  # noise rms [m/s^2]
FLOORS = {"vertical": FLOOR, "horizontal": FLOOR}
ST = DiagnoseSettings()
MV, MH = 4.0, 1.7  # moving masses [kg] (the force laws below are in N)


def tustin(feat, c):
    """A guide's friction on each axis [m/s^2]: Coulomb 0.15 N, a Stribeck rise of 0.1 N below 5 mm/s, 2 N s/m."""
    v = feat["g_dot"] if c == 0 else feat["d_dot"]
    f = (0.15 + 0.1 * np.exp(-((v / 5e-3) ** 2))) * np.tanh(v / 5e-4) + 2.0 * v
    return -f / (MV if c == 0 else MH)


def squeeze_film(feat, c):
    """The air under the mover [m/s^2]: ``-c0 (15 mm / g)^3 g_dot`` on the gap, ``c0`` = 60 N s/m; nothing along d."""
    if c == 1:
        return np.zeros_like(feat["t"])
    return -60.0 * (0.015 / feat["g"]) ** 3 * feat["g_dot"] / MV


def side_rail(feat, c):
    """A conductor beside the array [m/s^2]: ``-6 N s/m (g / 12 mm)^2.5 d_dot`` along d; nothing on the gap."""
    if c == 0:
        return np.zeros_like(feat["t"])
    return -6.0 * (feat["g"] / 0.012) ** 2.5 * feat["d_dot"] / MH


def flat_drag(feat, c):
    """A viscous drag along d with a flat coefficient [m/s^2]: ``-5 N s/m d_dot``."""
    return np.zeros_like(feat["t"]) if c == 0 else -5.0 * feat["d_dot"] / MH


def _runs(force, seed: int) -> list[Residual]:
    """Held-out-like runs: sweeps along d and of the gap, residual ``force(feat) + noise``."""
    return still_current_runs(force, seed, FLOOR)


def _shows(effect: str, force, seed: int):
    return evidence(effect, _runs(force, seed), dict(FLOORS), n_null=ST.signature_null, alpha=ST.signature_alpha,
                    min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


@pytest.mark.parametrize("seed", [11, 12])
def test_a_guides_friction_shows_by_its_dry_level(seed):
    """The Tustin guide friction's signature shows in both channels."""
    ev = _shows("friction", tustin, seed)
    assert ev.shows
    assert ev.per_channel["vertical"]["shows"] and ev.per_channel["horizontal"]["shows"], ev.per_channel


@pytest.mark.parametrize("seed", [13, 14])
def test_an_air_films_damping_of_the_gap_is_not_friction(seed):
    """The squeeze film damps the gap with no level at rest: most of the vertical residual is a viscous drag
    (over 80 %), and friction's signature does not show beyond it."""
    ev = _shows("friction", squeeze_film, seed)
    assert ev.per_channel["vertical"]["beyond_share"] > 0.8, ev.per_channel
    assert not ev.shows, ev.per_channel


@pytest.mark.parametrize("seed", [15, 16])
def test_a_side_conductors_drag_is_eddy_drag_not_friction(seed):
    """The side rail's drag grows with the gap: before friction's signature is tested, a drag that follows the gap
    takes the part of the residual a flat drag does not explain (at least 90 % of that share, computed here from
    the law itself), eddy drag's signature shows, and named beside eddy drag friction's does not (what it could
    take is the drag's flat part, which a guide's viscous friction shares)."""
    runs = _runs(side_rail, seed)
    v = np.concatenate([r.run.feat["d_dot"] for r in runs])
    y = np.concatenate([side_rail(r.run.feat, 1) for r in runs])
    not_flat = 1.0 - float(y @ v) ** 2 / (float(y @ y) * float(v @ v))
    alone = _shows("friction", side_rail, seed)
    assert 0.1 < not_flat and alone.per_channel["horizontal"]["beyond_share"] > 0.9 * not_flat, (not_flat, alone)
    assert _shows("eddy_drag", side_rail, seed).shows
    beside = evidence("friction", _runs(side_rail, seed), dict(FLOORS), others=("eddy_drag",),
                      n_null=ST.signature_null, alpha=ST.signature_alpha, min_over_floor=ST.signature_min_floor,
                      seed=seed)  # fmt: skip
    assert not beside.shows, beside.per_channel


@pytest.mark.parametrize("seed", [17, 18])
def test_a_flat_viscous_drag_along_d_stays_friction_or_eddy_drag(seed):
    """A flat viscous drag along d is friction's viscous part or an eddy drag at one gap: both signatures show
    (the verdict's slot, which an experiment at two gaps resolves)."""
    assert _shows("friction", flat_drag, seed).per_channel["horizontal"]["shows"]
    assert _shows("eddy_drag", flat_drag, seed).per_channel["horizontal"]["shows"]
