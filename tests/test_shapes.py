"""The learned-shape bases (:mod:`maglev_ocp.shapes`) and the saturation's learned loss.

Truths come from outside the code under test: the cubic B-spline's textbook
values, a tanh-shaped saturation loss and a slot-periodic signal written here.
Tolerances were fixed before the first run.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import nnls

from maglev_ocp import constants as k
from maglev_ocp.effects import EndEffect, Saturation
from maglev_ocp.shapes import bspline, cubic_bspline, cumulative, cumulative_bspline, fourier


def test_cubic_bspline_textbook_values() -> None:
    """B(0) = 2/3, B(+-1) = 1/6, B(+-2) = 0, B(+-1/2) = 23/48 (de Boor), and the partition of unity."""
    for t, want in ((0.0, 2 / 3), (1.0, 1 / 6), (-1.0, 1 / 6), (2.0, 0.0), (-3.0, 0.0), (0.5, 23 / 48)):
        assert float(cubic_bspline(t)) == pytest.approx(want)
    xs = np.linspace(-3.0, 3.0, 61)
    total = sum(np.array([float(cubic_bspline(x - c)) for x in xs]) for c in range(-6, 7))
    assert np.max(np.abs(total - 1.0)) < 1e-12


def test_monotone_bspline_fits_tanh_saturation() -> None:
    """A tanh-shaped loss (an iron's B-H knee, not the library's exponential/logistic) is fitted by the
    saturation's knots with non-negative steps to within 0.01 (5 % of its 0.2 peak) over the gap range."""
    g = np.linspace(k.g_stop[0], k.g_stop[1], 200)
    truth = 0.1 * (1.0 - np.tanh((g - 0.012) / 0.004))
    knots, h = Saturation.KNOTS, Saturation.KNOT_STEP
    cols = []
    for j in range(len(knots)):
        unit = [0.0] * len(knots)
        unit[j] = 1.0
        cols.append([float(cumulative_bspline(x, knots, h, unit, reverse=True)) for x in g])
    steps, _ = nnls(np.array(cols).T, truth)
    fit = np.array([float(cumulative_bspline(x, knots, h, list(steps), reverse=True)) for x in g])
    assert np.max(np.abs(fit - truth)) < 0.01
    assert np.all(np.diff(fit) <= 1e-12)  # non-increasing in g


def test_fourier_reproduces_slot_periodic_signal() -> None:
    """A cogging-like signal with a 4th harmonic is reproduced exactly by K = 4 harmonics of the slot pitch."""
    pitch = k.tau / 2
    d = np.linspace(-0.06, 0.06, 301)
    phase = 2 * math.pi * d / pitch
    truth = 0.7 * np.cos(phase) - 0.3 * np.sin(2 * phase + 0.4) + 0.1 * np.cos(4 * phase)
    basis = []
    for j in range(8):
        a = [1.0 if i == j else 0.0 for i in range(4)]
        b = [1.0 if i + 4 == j else 0.0 for i in range(4)]
        basis.append([float(fourier(p, a, b)) for p in phase])
    coef, *_ = np.linalg.lstsq(np.array(basis).T, truth, rcond=None)
    fit = np.array([float(fourier(p, list(coef[:4]), list(coef[4:]))) for p in phase])
    assert np.max(np.abs(fit - truth)) < 1e-9
    assert abs(coef[3] - 0.1) < 1e-9 and abs(coef[1] + 0.3 * math.sin(0.4)) < 1e-9


def test_saturation_shape_monotone_and_nil_by_default() -> None:
    """Random non-negative steps give a factor non-decreasing in g (a loss that grows as the gap closes);
    the default steps change nothing; the loss vanishes above the last knot's support."""
    rng = np.random.default_rng(7)
    gs = ca.SX.sym("g")
    names = Saturation.shape_names()
    c = ca.SX.sym("c", len(names))
    theta = {**Saturation.defaults(), "loss_8mm": 0.0, **dict(zip(names, ca.vertsplit(c), strict=True))}
    f = ca.Function("k", [gs, c], [Saturation.factor(gs, theta)])
    g = np.linspace(k.g_stop[0], k.g_stop[1], 400)
    assert np.allclose(np.array(f(g[None, :], np.zeros(len(names)))).ravel(), 1.0, atol=0.0)
    for _ in range(5):
        steps = rng.uniform(0.0, 0.1, len(names))
        kk = np.array([float(f(x, steps)) for x in g])
        assert np.all(np.diff(kk) >= -1e-12)
        assert abs(kk[-1] - 1.0) < 1e-12  # g = 32 mm: beyond 23 mm + two knot steps


def test_end_effect_profile_uses_the_shared_basis() -> None:
    """A single step at the first end knot sets the level of every cumulative coefficient: at both ends."""
    names = EndEffect.profile_names()
    theta = {n: 0.0 for n in names}
    theta[names[0]] = 0.3
    c0 = EndEffect.KNOTS[0]
    for d in (c0, -c0):
        # the first knot has no left neighbour: B(0) + B(1) of the level 0.3
        assert abs(float(EndEffect.profile_loss(d, theta)) - 0.3 * (2 / 3 + 1 / 6)) < 1e-12
    far = EndEffect.KNOTS[-1] + 3 * EndEffect.KNOT_STEP
    assert abs(float(EndEffect.profile_loss(far, theta))) < 1e-12  # no basis function reaches there
    mid = EndEffect.KNOTS[4]
    assert abs(float(EndEffect.profile_loss(mid, theta)) - 0.3) < 1e-12  # level 0.3 inside the grid
    assert cumulative([1.0, 2.0, 3.0]) == [1.0, 3.0, 6.0]
    assert cumulative([1.0, 2.0, 3.0], reverse=True) == [6.0, 5.0, 3.0]
    assert float(bspline(0.0, [0.0], 1.0, [2.0])) == pytest.approx(4 / 3)


def test_shape_report_curves_follow_the_effect_definitions() -> None:
    """The report's curves meet each effect's documented meaning: ``loss_8mm`` is the loss at g = 8 mm, no
    overhang loss mid-stroke, ``delta`` in degrees; a learned saturation loss is stated at the lower stop."""
    from maglev_ocp.diagnosis.shape_report import SHAPES

    sat = {**Saturation.defaults(), "loss_8mm": 0.12}
    assert SHAPES["saturation"].curve(sat, np.array([8.0]))[0] == pytest.approx(12.0, abs=1e-9)
    assert "12.00 %" in SHAPES["saturation"].size(sat)
    learned = {**Saturation.defaults(), "loss_8mm": 0.0, Saturation.shape_names()[0]: 0.2}
    loss = SHAPES["saturation"].curve(learned, np.array([8.0, 32.0]))
    assert 0.0 < loss[0] <= 20.0 and loss[1] == pytest.approx(0.0, abs=1e-12)
    end = EndEffect.defaults()
    assert abs(SHAPES["end_effect"].curve(end, np.array([0.0]))[0]) < 0.1
    off = {"delta": math.radians(5.0), "drift": 0.0}
    assert SHAPES["commutation_offset"].curve(off, np.array([-30.0, 30.0])) == pytest.approx([5.0, 5.0])
