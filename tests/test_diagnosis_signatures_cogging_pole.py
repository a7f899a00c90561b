"""Cogging at the array's period: a stator that is not uniform pulls on each pole of the array in turn, and its
detent shows as cogging; a spring, a cable's pull or a tilt does not (:func:`maglev_ocp.diagnosis.signatures.evidence`).

The residuals are built here from laws written for the test, not the library's (whose pole-pair member is a
co-energy of two free harmonics of ``2 tau``, :meth:`maglev_ocp.effects.Cogging.energy_forces`):

* a tooth magnetized by an earlier overload (a remanent dipole ``m`` at ``x_r``) in the field of an array of
  rectangular magnets: the array's field is a square wave along ``d``, its odd harmonics ``n`` of ``2 tau`` weighted
  ``sin(n pi w_m / (2 tau)) / n`` (the magnet's width ``w_m``) and decaying as ``exp(-n pi g / tau)`` (Furlani,
  *Permanent Magnet and Electromechanical Devices*, Academic Press 2001, ch. 4: the field of a periodic array);
  the dipole's energy is ``-m B(x_r - d, g)`` (Gasparin et al., IEEE Trans. Magn. 45(3), 2009: a stator
  imperfection adds cogging at multiples of the pole number);
* a tooth narrower than the others: the slots' permeance loses a pulse of width ``w_t`` there, whose energy in the
  array's field is ``-(1/2) P_t B^2`` (Zhu & Howe, 1992: the co-energy of the permeance): with ``B^2`` the square
  wave's even harmonics, the narrow tooth's detent has the pole pitch's period ``tau``.

Not cogging: a cable's pull (a constant plus a spring along d, nothing on the gap), and a tilted base with a spring
on the gap (a constant along d and a force linear in the gap).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from residual_runs import still_current_runs

from maglev_ocp import constants as k
from maglev_ocp.diagnosis.library import family_specs
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import evidence
from maglev_ocp.effects import Cogging
from maglev_ocp.effects.cogging import POLE_PERIOD

FLOOR = 0.02  # noise rms [m/s^2]
FLOORS = {"vertical": FLOOR, "horizontal": FLOOR}
ST = DiagnoseSettings()
MV, MH = 4.0, 4.0  # moving masses [kg]


def _array_field(x, g, harmonics=(1, 3, 5)):
    """The rectangular magnets' field (arbitrary scale) and its derivatives ``(B, dB/dx, dB/dg)`` at ``x`` along the
    array, gap ``g``: odd harmonics of ``2 tau``, weighted ``sin(n pi w_m / (2 tau)) / n``, decaying ``exp(-n pi g
    / tau)``."""
    b, bx, bg = 0.0, 0.0, 0.0
    for n in harmonics:
        q = n * math.pi / k.tau
        a = math.sin(n * math.pi * k.taup / (2 * k.tau)) / n * np.exp(-q * g)
        b = b + a * np.cos(q * x)
        bx = bx - a * q * np.sin(q * x)
        bg = bg - q * a * np.cos(q * x)
    return b, bx, bg


def remanent_tooth(feat, c, x_r=0.012, size=0.5):
    """A remanent tooth's detent [m/s^2]: ``W = -m B(x_r - d, g)``, ``F_d = -dW/dd``, ``F_g = -dW/dg`` (the normal
    force on the mover, closing the gap where it is negative); ``size`` [N] the force along d's peak at 15 mm."""
    _, bx0, _ = _array_field(np.linspace(-k.tau, k.tau, 2001), 0.015)
    m = size / float(np.max(np.abs(bx0)))
    _, bx, bg = _array_field(x_r - feat["d"], feat["g"])
    f_d = -m * bx  # -dW/dd = m dB/dd = -m dB/dx
    f_g = m * bg
    return f_g / MV if c == 0 else f_d / MH


def narrow_tooth(feat, c, x_t=-0.02, size=0.4):
    """A narrow tooth's detent [m/s^2]: ``W = -(1/2) P_t B(x_t - d, g)^2`` with the array's square-wave field."""
    xs = np.linspace(-k.tau, k.tau, 2001)
    b0, bx0, _ = _array_field(xs, 0.015)
    p_t = size / float(np.max(np.abs(b0 * bx0)))
    b, bx, bg = _array_field(x_t - feat["d"], feat["g"])
    f_d = -p_t * b * bx  # -dW/dd = (1/2) P_t d(B^2)/dd = -P_t B dB/dx
    f_g = p_t * b * bg
    return f_g / MV if c == 0 else f_d / MH


def cable(feat, c):
    """A cable's pull [m/s^2]: 0.3 N plus 12 N/m along d, nothing on the gap."""
    return np.zeros_like(feat["t"]) if c == 0 else (0.3 + 12.0 * feat["d"]) / MH


def tilt_and_spring(feat, c):
    """A tilted base and a spring on the gap [m/s^2]: 0.4 N along d, 150 N/m times (g - 18 mm) on the gap."""
    if c == 1:
        return np.full_like(feat["t"], 0.4 / MH)
    return -150.0 * (feat["g"] - 0.018) / MV


def _shows(effect: str, force, seed: int):
    runs = still_current_runs(force, seed, FLOOR)
    return evidence(effect, runs, dict(FLOORS), n_null=ST.signature_null, alpha=ST.signature_alpha,
                    min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


@pytest.mark.parametrize(("force", "seed"), [(remanent_tooth, 41), (remanent_tooth, 42), (narrow_tooth, 43)])
def test_a_stators_detent_at_the_arrays_period_is_cogging(force, seed):
    """A detent of the array's period (a remanent tooth: ``2 tau``; a narrow tooth: ``tau``) shows cogging's
    signature in both channels, and friction's (odd in the velocities) does not."""
    ev = _shows("cogging", force, seed)
    assert ev.shows, ev.per_channel
    assert ev.per_channel["horizontal"]["shows"], ev.per_channel
    assert not _shows("friction", force, seed).shows


@pytest.mark.parametrize(("force", "seed"), [(cable, 44), (tilt_and_spring, 45)])
def test_a_spring_a_cable_or_a_tilt_is_not_cogging(force, seed):
    """A force linear in d or in the gap (a cable, a spring, a tilt) is most of the residual (over 90 % taken by a
    spring and a linear function of the gap), and cogging's signature does not show beyond it."""
    ev = _shows("cogging", force, seed)
    shown = [ch for ch, rec in ev.per_channel.items() if rec.get("beyond_share", 0.0) > 0.9]
    assert shown, ev.per_channel
    assert not ev.shows, ev.per_channel


def test_the_pole_pair_co_energy():
    """``Cogging.energy_forces`` with the pole-pair harmonics: period ``2 tau`` in d, the tangential force
    ``-dW/dd`` of ``W = (A(g) / q) (c cos(q d) + s sin(q d))``, and the member frees them (no velocity, no current)."""
    th = {**Cogging.defaults(), "e_pc1": 0.3, "e_ps1": -0.2, "e_pr1": 1.2, "e_pc2": 0.1, "e_pr2": 0.8}
    d = np.linspace(-0.05, 0.05, 11)
    fx, fn = Cogging.energy_forces(0.017, d, th)
    fx2, fn2 = Cogging.energy_forces(0.017, d + POLE_PERIOD, th)
    assert np.allclose(np.asarray(fx, float).ravel(), np.asarray(fx2, float).ravel(), atol=1e-12)
    assert np.allclose(np.asarray(fn, float).ravel(), np.asarray(fn2, float).ravel(), atol=1e-12)
    # harmonic 1 alone against its closed form
    one = {**Cogging.defaults(), "e_pc1": 0.3, "e_ps1": -0.2, "e_pr1": 1.2}
    q = 2 * math.pi / POLE_PERIOD
    a = math.exp(-1.2 * q * (0.017 - 0.02))
    want = a * (0.3 * np.sin(q * d) + 0.2 * np.cos(q * d))
    fx1, _ = Cogging.energy_forces(0.017, d, one)
    assert np.allclose(np.asarray(fx1, float).ravel(), want, rtol=1e-12, atol=1e-15)
    pole = [m for m in family_specs()["cogging"] if m.law == "pole pair"]
    assert len(pole) == 1 and pole[0].flexible
    keys = {f.key for f in pole[0].free}
    assert {f"cogging.{n}" for n in Cogging.pole_names()} <= keys
