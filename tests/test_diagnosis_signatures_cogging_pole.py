"""Cogging at the array's period: a stator that is not uniform pulls on each pole of the array in turn, and its
detent shows as cogging where the data span two of its periods; a spring, a cable's pull or a tilt does not, nor,
over the rig's stroke (shorter than 2 tau), a smooth pull towards the stator's ends
(:func:`maglev_ocp.diagnosis.signatures.evidence`, :func:`maglev_ocp.diagnosis.library.offered`).

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

Not cogging: a cable's pull (a constant plus a spring along d, nothing on the gap), a tilted base with a spring
on the gap (a constant along d and a force linear in the gap), and iron end plates beyond the stroke pulling the
array's end poles (each the image pole of a pole near a permeable plane, ``F = m^2 / (4 pi mu0 (2 s)^2)``: Furlani
2001, ch. 3): a bend over the stroke that a cosine of ``2 tau`` takes as well as an end force, so the array's
period is not tested on a stroke shorter than two of it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from residual_runs import still_current_runs

from maglev_ocp import constants as k
from maglev_ocp.diagnosis.library import MIN_PERIODS, family_specs, offered
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


def end_plates(feat, c, x_e=0.075, size=0.5):
    """Iron plates ``x_e`` beyond the stroke's middle at both ends pull the array's end poles [m/s^2]: the image
    force ``A / (2 s)^2`` at a pole's distance ``s = x_e -+ d`` from each plate, ``size`` [N] the net pull along d
    at 45 mm; on the gap the pull's normal part, ``0.4`` of it, falling with the gap over 10 mm."""
    a = size / (1 / (2 * (x_e - 0.045)) ** 2 - 1 / (2 * (x_e + 0.045)) ** 2)
    near, far = a / (2 * (x_e - feat["d"])) ** 2, a / (2 * (x_e + feat["d"])) ** 2
    if c == 1:
        return (near - far) / MH
    return -0.4 * (near + far) * np.exp(-(feat["g"] - 0.015) / 0.01) / MV


def _shows(effect: str, force, seed: int, d_amp: float = 0.045):
    runs = still_current_runs(force, seed, FLOOR, d_amp=d_amp)
    return evidence(effect, runs, dict(FLOORS), n_null=ST.signature_null, alpha=ST.signature_alpha,
                    min_over_floor=ST.signature_min_floor, seed=seed)  # fmt: skip


#: Sweeps of +-120 mm along d: the data span two of the array's periods (2 x 2 tau = 228.6 mm, Table I).
LONG_STROKE = 0.12


@pytest.mark.parametrize(("force", "seed"), [(remanent_tooth, 41), (remanent_tooth, 42), (narrow_tooth, 43)])
def test_a_stators_detent_at_the_arrays_period_is_cogging(force, seed):
    """A detent of the array's period (a remanent tooth: ``2 tau``; a narrow tooth: ``tau``) over a stroke that
    spans two of ``2 tau`` shows cogging's signature in both channels, and friction's (odd in the velocities) does
    not."""
    ev = _shows("cogging", force, seed, LONG_STROKE)
    assert ev.shows, ev.per_channel
    assert ev.per_channel["horizontal"]["shows"], ev.per_channel
    assert not _shows("friction", force, seed, LONG_STROKE).shows


@pytest.mark.parametrize("seed", [46, 47])
def test_end_plates_pull_over_the_rigs_stroke_is_not_cogging(seed):
    """Iron end plates' pull on the array's end poles, a smooth bend over the rig's +-45 mm (its rms several
    times the noise floor), does not show cogging's signature: the array's period is not tested there."""
    runs = still_current_runs(end_plates, seed, FLOOR)
    assert math.sqrt(np.mean(np.concatenate([r.r[:, 1] for r in runs]) ** 2)) > 3 * FLOOR
    ev = _shows("cogging", end_plates, seed)
    assert not ev.shows, ev.per_channel


def test_a_periodic_shape_is_offered_where_the_data_span_two_periods():
    """The learned periodic members are offered only where the data span two of their longest period: the pole
    pair (2 tau = 114.3 mm) from 228.6 mm, the slot co-energy (2 t1 = 38.1 mm) from 76.2 mm (Table I)."""
    assert MIN_PERIODS == 2
    laws = {span: {m.law for m in offered(family_specs(), span)["cogging"]} for span in (0.07, 0.1, 0.23)}
    assert "pole pair" in laws[0.23] and "co-energy 3" in laws[0.23]
    assert "pole pair" not in laws[0.1] and {"co-energy 3", "co-energy 6"} <= laws[0.1]
    assert not laws[0.07] & {"pole pair", "co-energy 3", "co-energy 6"}
    assert {"default", "free decay", "own decay"} <= laws[0.07]  # closed-form laws: no period claimed


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
