"""The end effect's signature (:mod:`maglev_ocp.diagnosis.signatures`): forces localized at each end of the
stroke, seen beyond their uniform counterparts over the whole stroke (a spring, a law of the gap, a constants'
error; issue 27).

Truths written here, not computed by the code under test:

* an end force from the literature, not a library law: the field of an iron edge under a magnet falls as
  Carter's conformal-map profile ``s(y) = 1/2 + arctan(y / g) / pi`` across the edge (Carter, "Note on the surface
  loss in a laminated pole-face", J. IEE 1926; the co-energy method: Furlani, *Permanent Magnet and
  Electromechanical Devices*, 2001, sec. 4.5). The co-energy of an array of length ``L`` centred at ``d`` over a
  stator ending at ``x = +-E`` is ``W(d, g) = w0(g) int_{d - L/2}^{d + L/2} s(E - x) s(E + x) dx``; the end force
  is ``F_d = dW/dd`` (in closed form) and the pull's loss ``F_g = d(W(d, g) - W(0, g))/dg`` (here by a central
  difference), ``w0(g) = w0 exp(-(g - 12 mm) / 6 mm)``. Its onset is an arctan of width ``g``, whose tail reaches
  the middle of the stroke;
* a tanh-profile overlap: each end loses the pull and the thrust over ``(1 + tanh((s d - e_s) / w_s)) / 2`` with
  its own onset, width and size;
* a spring over the whole stroke, ``-k d``, a tanh knee of the pull in the gap, a uniform error of the thrust and
  PM-current constants, and white noise: no end effect.

The residuals are the signature tests' runs (:func:`test_diagnosis_signatures._runs`: a sinusoidal stroke of
+-45 mm, the gap 12 +- 3 mm, currents), with white noise of 0.02 m/s^2, above the diagnosis's noise floors
(0.005-0.013 m/s^2 on rigsim's validation rigs).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_diagnosis_signatures import FLOOR, FLOORS, _runs

from maglev_ocp.diagnosis.signatures import END_MIDDLE, end_columns, evidence

L_ARRAY = 0.10  # array length [m]
E_STATOR = 0.08  # the stator ends at |x| = 80 mm: the array's end reaches it at |d| = 30 mm
_XG, _WG = np.polynomial.legendre.leggauss(16)


def _s(y, g):
    return 0.5 + np.arctan(y / g) / math.pi


def _coenergy(d, g, w0):
    """The overlap's co-energy ``W(d, g)`` of the Carter-edge law (module docstring), Gauss-Legendre in x."""
    half = L_ARRAY / 2
    total = sum(wi * half * _s(E_STATOR - (d + half * xi), g) * _s(E_STATOR + d + half * xi, g)
                for xi, wi in zip(_XG, _WG, strict=True))  # fmt: skip
    return w0 * np.exp(-(g - 0.012) / 6e-3) * total


def _carter(w0: float, channels=(0, 1)):
    """The Carter-edge law's ``(F_g, F_d)`` per unit mass [m/s^2] on the channels asked, as a residual law."""

    def law(feat, c):
        g, d = feat["g"], feat["d"]
        if c not in channels:
            return 0.0 * d
        if c == 1:  # F_d = dW/dd, closed form: the array's two ends over the stator's two edges
            e, h = E_STATOR, L_ARRAY / 2
            return (w0 * np.exp(-(g - 0.012) / 6e-3)
                    * (_s(e - d - h, g) * _s(e + d + h, g) - _s(e - d + h, g) * _s(e + d - h, g)))  # fmt: skip
        step = 1e-7

        def lost(gg):
            return _coenergy(d, gg, w0) - _coenergy(0.0 * d, gg, w0)

        return (lost(g + step) - lost(g - step)) / (2 * step)

    return law


def _carter_peak_fd(w0: float) -> float:
    d = np.linspace(-0.045, 0.045, 181)
    return float(np.max(np.abs(_carter(w0, (1,))({"g": np.full_like(d, 0.012), "d": d}, 1))))


def _tanh_ends(size: float):
    """Each end's overhang ``(1 + tanh((s d - e_s) / w_s)) / 2`` (28 mm / 4 mm at d > 0, 35 mm / 6 mm and 0.6 of
    the loss at d < 0) takes ``size`` [m/s^2] of the pull (current-free) and of the thrust (times ``i_q``)."""

    def law(feat, c):
        d = feat["d"]
        o = 0.5 * (1 + np.tanh((d - 0.028) / 4e-3)) + 0.6 * 0.5 * (1 + np.tanh((-d - 0.035) / 6e-3))
        return -size * o * (1.0 if c == 0 else feat["i_q"])

    return law


def _shows(law, seed: int) -> tuple[bool, dict]:
    ev = evidence("end_effect", _runs(law, seed=seed), FLOORS, seed=seed)
    return ev.shows, ev.per_channel


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_carter_edge_end_force_alone_shows_in_the_horizontal_channel(seed):
    """The Carter-edge end force along d alone, its peak 5x the noise's rms, shows the end effect's signature in
    the horizontal channel, beyond a spring (it is largely spring-like in the middle of the stroke: the spring
    takes most of its energy, what is left is at the ends)."""
    w0 = 0.1 / _carter_peak_fd(1.0)  # peak end force 0.1 m/s^2 over the stroke at g = 12 mm
    shows, pc = _shows(_carter(w0, (1,)), seed)
    assert shows and pc["horizontal"]["shows"], pc
    assert pc["horizontal"]["beyond_share"] > 0.5  # the spring takes most of it: the test is on the rest
    assert not pc["vertical"]["shows"]  # nothing on the vertical channel here


@pytest.mark.parametrize("seed", [0, 1])
def test_a_carter_edge_end_force_with_its_pull_loss_shows_in_both_channels(seed):
    """The whole Carter-edge co-energy law (the end force and the pull's loss, virtual work) shows in both."""
    w0 = 0.1 / _carter_peak_fd(1.0)
    shows, pc = _shows(_carter(w0), seed)
    assert shows and pc["horizontal"]["shows"] and pc["vertical"]["shows"], pc


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_tanh_profile_overlap_shows_at_each_end(seed):
    """Asymmetric tanh-profile ends losing the pull and the thrust (2.5x the noise) show in both channels."""
    shows, pc = _shows(_tanh_ends(2.5 * FLOOR), seed)
    assert shows and pc["horizontal"]["shows"] and pc["vertical"]["shows"], pc


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("channel", [0, 1])
def test_a_spring_over_the_whole_stroke_does_not_show(seed, channel):
    """A linear spring force over the whole stroke, 1 m/s^2 at 45 mm (10x the Carter end force above, 50x the
    noise), in either channel: no end effect (a cable's pull, a spring: it acts in the middle of the stroke too)."""
    shows, pc = _shows(lambda f, c: -1.0 * f["d"] / 0.045 * (c == channel), seed)
    assert not shows, pc
    assert pc[("vertical", "horizontal")[channel]]["beyond_share"] > 0.99


def test_white_noise_shows_no_end_effect():
    """On ten draws of white noise at the floor the end effect's signature never shows (null at alpha = 0.01)."""
    assert [s for s in range(10) if _shows(lambda f, c: 0.0 * f["t"], 100 + s)[0]] == []


def test_end_columns_are_nil_in_the_middle_and_grow_with_each_ends_overhang():
    """Every column is exactly 0 for |d| below END_MIDDLE of the farther end of the covered stroke, each end's
    only on its side, each non-decreasing with that end's overhang, and at its full value 1 at the end of the
    stroke; a side the samples do not cover beyond the middle has no end columns."""
    d = np.linspace(-0.045, 0.03, 1501)  # an asymmetric stroke: each end's range is its own
    cols = np.column_stack([c({"d": d}) for c in end_columns()])
    hi_p, hi_n = np.percentile(d, 99.5), np.percentile(-d, 99.5)
    lo = END_MIDDLE * max(hi_p, hi_n)
    assert np.all(cols[np.abs(d) < lo] == 0.0)
    n = cols.shape[1] // 2
    assert np.all(cols[d <= 0, :n] == 0.0) and np.all(cols[d >= 0, n:] == 0.0)
    assert np.all(np.diff(cols[:, :n], axis=0) >= 0.0) and np.all(np.diff(cols[:, n:], axis=0) <= 0.0)
    assert np.allclose(cols[d >= hi_p, :n], 1.0) and np.allclose(cols[-d >= hi_n, n:], 1.0)
    short = np.linspace(-0.008, 0.045, 1501)  # d < 0 is not covered beyond the middle (11 mm): no end there
    cols = np.column_stack([c({"d": short}) for c in end_columns()])
    assert np.all(cols[:, n:] == 0.0) and np.any(cols[:, :n] > 0.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_loss_over_the_whole_stroke_does_not_show(seed):
    """A loss of the pull that follows the gap everywhere (a knee ``(1 - tanh((g - 11 mm) / 2 mm)) / 2`` of the
    PM pull and the PM-current pull, 5x the noise) and a uniform error of the thrust and PM-current constants
    (``-0.1 i_q``, ``-0.1 i_d`` m/s^2 per A): no end effect (a saturation, a constant's error)."""

    def knee(feat, c):
        return -0.1 * 0.5 * (1 - np.tanh((feat["g"] - 0.011) / 2e-3)) * (1 + 0.5 * feat["i_d"]) * (c == 0)

    def constants(feat, c):
        return -0.1 * (feat["i_d"] if c == 0 else feat["i_q"])

    for law in (knee, constants):
        shows, pc = _shows(law, seed)
        assert not shows, pc
