"""The end effect's winding force (:meth:`maglev_ocp.effects.EndEffect.winding_force_x`) against the co-energy it
comes from.

The armature's inductance over a stator end ``L(d) = L0 - dL w softplus((|d| - d_edge) / w)`` (it falls as the
back iron leaves the winding, with the overhang's smooth onset) stores the co-energy ``W = (3/4) |i|^2 L(d)``
(three phases, amplitude-invariant dq currents); the force along d is ``dW/dd`` at constant currents (virtual
work, Fitzgerald, Kingsley & Umans, *Electric Machinery*, ch. 3). Its derivative is taken here by central
differences of ``W``, not from the effect's formula; ``end_i2 = (3/4) dL``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp.effects import EndEffect

THETA = {**EndEffect.defaults(), "d_edge": 0.03, "edge_width": 6e-3, "end_i2": 0.04}


def _coenergy(d: float, i_q: float, i_d: float, dL: float, d_edge: float, w: float) -> float:
    z = (abs(d) - d_edge) / w
    L = -dL * w * math.log1p(math.exp(z))  # L0 drops out of the force
    return 0.75 * (i_q**2 + i_d**2) * L


@pytest.mark.parametrize("d", [-0.045, -0.035, -0.031, 0.029, 0.034, 0.04, 0.048])
@pytest.mark.parametrize("i", [(2.0, 0.0), (-3.0, 1.5), (0.5, -4.0)])
def test_force_is_the_coenergy_gradient(d, i):
    dL = THETA["end_i2"] / 0.75
    h = 1e-7
    want = (_coenergy(d + h, *i, dL, 0.03, 6e-3) - _coenergy(d - h, *i, dL, 0.03, 6e-3)) / (2 * h)
    got = float(EndEffect.winding_force_x(d, i[0], i[1], THETA))
    assert got == pytest.approx(want, rel=1e-5, abs=1e-9)


def test_nil_in_the_middle_quadratic_in_current_and_restoring():
    mid = float(EndEffect.winding_force_x(0.0, 5.0, 0.0, THETA))
    assert abs(mid) < 0.2 * 0.04 * 25 * 1e-2  # under 1 % of its size at the end
    f1 = float(EndEffect.winding_force_x(0.045, 2.0, 0.0, THETA))
    f2 = float(EndEffect.winding_force_x(0.045, 4.0, 0.0, THETA))
    assert f2 == pytest.approx(4 * f1, rel=1e-12)
    # a falling inductance pulls the array back over the winding, at either end
    assert f1 < 0 and float(EndEffect.winding_force_x(-0.045, 2.0, 0.0, THETA)) > 0
    assert float(EndEffect.winding_force_x(0.045, 2.0, 0.0, {**THETA, "end_i2": 0.0})) == 0.0


def test_in_the_model_it_moves_only_the_horizontal_acceleration():
    from maglev_ocp.effects import EffectSet
    from maglev_ocp.params import Params

    es = EffectSet(["end_effect"])
    x, u, p = [0.015, 0.0, 0.045, 0.0], [3.0, 0.5], Params().vector()
    fn = es.accel_function()
    a0 = np.asarray(fn(x, u, p, es.vector({"end_effect": {**THETA, "end_i2": 0.0}}))).ravel()
    a1 = np.asarray(fn(x, u, p, es.vector({"end_effect": THETA}))).ravel()
    f = float(EndEffect.winding_force_x(0.045, 3.0, 0.5, THETA))
    assert f < -0.01  # 0.04 * 9.25 A^2 * ~0.9 of its onset
    assert a1[0] == pytest.approx(a0[0], abs=1e-12)
    assert a1[1] - a0[1] == pytest.approx(f / Params().Mh, rel=1e-9)
