"""Bases of the learned shapes: a uniform cubic B-spline and a Fourier series, as CasADi expressions.

Every flexible effect member (:mod:`maglev_ocp.effects`) builds its shape from
these two functions, so the basis math exists once. Both work on numbers and
on CasADi ``SX``/``MX`` expressions alike.

The B-spline coefficients are usually written as cumulative steps
(:func:`cumulative_bspline`): ``c_j = sum_{i <= j} s_i`` so that non-negative
steps give a monotone shape (a B-spline with monotone coefficients is monotone,
de Boor, *A Practical Guide to Splines*, ch. IX) and a bound ``s_i >= 0`` is a
sign constraint the NLP handles as a simple bound; a step the data do not
determine stays at its start (0) and the shape keeps its level there (P-spline
practice: a penalty on coefficient differences, Eilers and Marx 1996).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca

Expr = Any  # casadi SX or MX expression, or a float


def cubic_bspline(t: Expr) -> Expr:
    """The uniform cubic B-spline ``B(t)`` (support ``|t| < 2``, ``B(0) = 2/3``, twice continuously differentiable).

    Written with truncated powers of the clamped argument,
    ``B(t) = sum_k (-1)^k C(4, k) (t + 2 - k)_+^3 / 6``, so that it is exactly 0
    outside its support and cheap in CasADi.
    """
    t = ca.fmin(ca.fmax(t, -2.0), 2.0)
    tp = [ca.fmax(t - s, 0.0) ** 3 for s in (-2.0, -1.0, 0.0, 1.0, 2.0)]
    return (tp[0] - 4 * tp[1] + 6 * tp[2] - 4 * tp[3] + tp[4]) / 6.0


def bspline(x: Expr, centres: Sequence[float], step: float, coefs: Sequence[Expr]) -> Expr:
    """``sum_j coefs[j] B((x - centres[j]) / step)``: a cubic spline on a uniform knot grid.

    Parameters
    ----------
    x : float or SX/MX
        Where to evaluate (same unit as ``centres``).
    centres : sequence of float
        Centres of the basis functions, ``step`` apart.
    step : float
        Knot spacing (a basis function spans four of them).
    coefs : sequence
        One coefficient per centre.
    """
    if len(coefs) != len(centres):
        raise ValueError(f"{len(coefs)} coefficients for {len(centres)} knots")
    out: Expr = 0.0
    for c, a in zip(centres, coefs, strict=True):
        out = out + a * cubic_bspline((x - c) / step)
    return out


def cumulative(steps: Sequence[Expr], reverse: bool = False) -> list[Expr]:
    """Cumulative sums of ``steps`` (from the last one backwards if ``reverse``), the monotone coefficients."""
    order = list(reversed(steps)) if reverse else list(steps)
    out, acc = [], 0.0
    for s in order:
        acc = acc + s
        out.append(acc)
    return list(reversed(out)) if reverse else out


def cumulative_bspline(
    x: Expr, centres: Sequence[float], step: float, steps: Sequence[Expr], reverse: bool = False
) -> Expr:
    """A spline whose coefficients are cumulative ``steps`` (:func:`cumulative`): non-negative steps give a
    function non-decreasing in ``x`` (``reverse``: non-increasing in ``x``) wherever the spline is supported."""
    return bspline(x, centres, step, cumulative(steps, reverse))


def fourier(phase: Expr, cos_coefs: Sequence[Expr], sin_coefs: Sequence[Expr]) -> Expr:
    """``sum_k a_k cos(k phase) + b_k sin(k phase)``, ``k = 1..K`` (no constant term).

    Parameters
    ----------
    phase : float or SX/MX
        Angle [rad] of the fundamental (e.g. ``2 pi d / slot pitch``).
    cos_coefs, sin_coefs : sequence
        ``a_1..a_K`` and ``b_1..b_K``.
    """
    if len(cos_coefs) != len(sin_coefs):
        raise ValueError("as many cosine as sine coefficients are needed")
    out: Expr = 0.0
    for k, (a, b) in enumerate(zip(cos_coefs, sin_coefs, strict=True), start=1):
        out = out + a * ca.cos(k * phase) + b * ca.sin(k * phase)
    return out


__all__ = ["bspline", "cubic_bspline", "cumulative", "cumulative_bspline", "fourier"]
