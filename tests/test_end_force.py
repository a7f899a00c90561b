"""The end effect's end force: the overlap's co-energy pulls an overhanging array back (virtual work).

Truths written here, not computed by the code under test:

* the member's end force is restoring (along ``-sign(d)``), nil in the middle of the stroke, its full size
  ``end_force`` well past the onset at ``g = 10 mm``, and falls with the gap as ``exp(-(g - 10 mm) / end_ell)``;
* an end force from the literature, not the member's law: the field of an iron edge under a magnet falls as
  Carter's conformal-map profile ``s(y) = 1/2 + arctan(y / g) / pi`` across the edge (Carter, "Note on the
  surface loss in a laminated pole-face", J. IEE 1926; Furlani, *Permanent Magnet and Electromechanical Devices*,
  2001, sec. 4.5 for the co-energy method). The co-energy of an array of length ``L`` centred at ``d`` over a
  stator ending at ``x = +-E`` is ``W(d, g) = w0(g) int_{d - L/2}^{d + L/2} s(E - x) s(E + x) dx``, so
  ``F_d = dW/dd = w0 [s(E - d - L/2) s(E + d + L/2) - s(E - d + L/2) s(E + d - L/2)]`` and the loss of the pull
  is ``F_g = d(W(d, g) - W(0, g))/dg`` (the full-overlap pull is the model's own). ``w0(g) = w0 exp(-(g - g_r) /
  lam)``. Its onset is an arctan of width ``g``, not the member's logistic, and its gap law is its own.

Fitted on short PD-stabilized runs of the shared model plus that law, the member with the end force recovers
the peak end force along ``d`` at 12 and 15 mm within 20 % (fixed before the first run).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from test_effects_shapes import _fit, _member, _runs

from maglev_ocp.effects import EndEffect

TOL = 0.20
W0, G_R, LAM = 3.0, 0.012, 6e-3  # [N] the end force's size at 12 mm, its gap, its decay length [m]
E_MINUS_HALF_L = 0.030  # the array's end reaches the stator's end at |d| = 30 mm
L_ARRAY = 0.10  # array length [m]


def _s(y, g):
    return 0.5 + ca.atan(y / g) / math.pi


def _carter() -> ca.Function:
    """``(g, d) -> (F_g, F_d)`` [N] of the Carter-edge co-energy law of the module docstring."""
    g, d = ca.SX.sym("g"), ca.SX.sym("d")
    e, half = E_MINUS_HALF_L + L_ARRAY / 2, L_ARRAY / 2
    w0 = W0 * ca.exp(-(g - G_R) / LAM)
    fd = w0 * (_s(e - d - half, g) * _s(e + d + half, g) - _s(e - d + half, g) * _s(e + d - half, g))
    xg, wg = np.polynomial.legendre.leggauss(16)  # the overlap's co-energy by Gauss-Legendre quadrature

    def overlap(c):
        xs = [c + half * xi for xi in xg]
        return sum(wi * half * _s(e - x, g) * _s(e + x, g) for x, wi in zip(xs, wg, strict=True))

    lost = w0 * (overlap(d) - overlap(0.0))  # W(d, g) - W(0, g): the full-overlap pull is the model's own
    return ca.Function("carter", [g, d], [ca.jacobian(lost, g), fd])


CARTER = _carter()


def carter_end_force(g, d):
    """``(F_g, F_d)`` [N] of the Carter-edge law at ``(g, d)`` (numbers or CasADi expressions)."""
    return CARTER(g, d)


def _law(x, u):
    fg, fd = carter_end_force(x[0], x[2])
    return [fg, fd]


def _peak_fd(g: float, d: np.ndarray) -> float:
    return max(abs(float(carter_end_force(g, x)[1])) for x in d)


def test_the_member_end_force_is_restoring_nil_in_the_middle_and_decays_with_the_gap() -> None:
    th = dict(EndEffect.defaults())
    th.update(end_force=2.0, end_ell=4e-3, d_edge=0.03, edge_width=2e-3)
    assert float(EndEffect.end_force_x(0.0, 0.010, th)) == pytest.approx(0.0, abs=1e-9)
    assert abs(float(EndEffect.end_force_x(0.01, 0.010, th))) < 1e-4  # 10 mm inside the onset
    for d in (0.045, -0.045):
        f = float(EndEffect.end_force_x(d, 0.010, th))
        assert -math.copysign(1.0, d) * f == pytest.approx(2.0, rel=1e-3)  # restoring, its full size
    ratio = float(EndEffect.end_force_x(0.045, 0.014, th)) / float(EndEffect.end_force_x(0.045, 0.010, th))
    assert ratio == pytest.approx(math.exp(-4e-3 / 4e-3), rel=1e-9)


def test_the_literature_end_force_is_restoring_and_conservative() -> None:
    """The test's own law: restoring past the ends, nil in the middle (a check on the truth itself)."""
    assert abs(float(carter_end_force(0.012, 0.0)[1])) < 1e-9
    assert float(carter_end_force(0.012, 0.04)[1]) < -0.3 * W0
    assert float(carter_end_force(0.012, -0.04)[1]) > 0.3 * W0
    assert float(carter_end_force(0.012, 0.04)[0]) > 0  # the pull lost (+g: the attraction weakens)


def test_end_force_member_recovers_the_peak_end_force_of_a_carter_edge_law() -> None:
    d = np.linspace(-0.045, 0.045, 361)
    runs = []
    for g0, seeds in ((0.012, (1, 2)), (0.015, (3, 4))):
        r, filt = _runs(_law, g0=g0, n=3000, seeds=seeds)
        runs += r
    _, theta = _fit(_member("end_effect", "two ends, end force"), runs, filt)
    got = [max(abs(float(EndEffect.end_force_x(x, g, theta))) for x in d) for g in (0.012, 0.015)]
    truth = [_peak_fd(g, d) for g in (0.012, 0.015)]
    np.testing.assert_allclose(got, truth, rtol=TOL)
