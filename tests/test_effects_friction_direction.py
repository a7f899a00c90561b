"""The friction's directional level (:meth:`maglev_ocp.effects.Friction.axis_force`, ``dir_<axis>``).

A seal lip that rubs harder one way: well above the regularization velocity the guide's friction is
``-(Fc + dir)`` moving forward and ``+(Fc - dir)`` moving backward (plus the viscous part ``-b v``), and nothing at
rest. These levels are the definition of the law (Armstrong-Helouvry et al. 1994's direction-dependent friction),
checked here at speeds where ``tanh(v / v_reg)`` is 1 to double precision.
"""

from __future__ import annotations

import pytest

from maglev_ocp.effects import Friction

TH = {**Friction.defaults(), "coulomb_d": 0.3, "stribeck_d": 0.0, "viscous_d": 2.0, "dir_d": 0.12, "v_reg": 1e-3}


@pytest.mark.parametrize("v", [0.05, 0.2])
def test_levels_per_direction(v):
    fwd = float(Friction.axis_force(v, TH, "d"))
    back = float(Friction.axis_force(-v, TH, "d"))
    assert fwd == pytest.approx(-(0.3 + 0.12) - 2.0 * v, rel=1e-12)
    assert back == pytest.approx(+(0.3 - 0.12) + 2.0 * v, rel=1e-12)
    # the asymmetry is twice the directional level, whatever the speed
    assert -(fwd + back) == pytest.approx(2 * 0.12, rel=1e-12)


def test_nil_at_rest_and_nested_at_zero():
    assert float(Friction.axis_force(0.0, TH, "d")) == 0.0
    plain = {**TH, "dir_d": 0.0}
    for v in (-0.1, -1e-3, 2e-4, 0.07):
        odd = float(Friction.axis_force(v, plain, "d")) + float(Friction.axis_force(-v, plain, "d"))
        assert odd == pytest.approx(0.0, abs=1e-15)


def test_the_other_axis_is_untouched():
    assert float(Friction.axis_force(0.1, TH, "g")) == float(Friction.axis_force(0.1, {**TH, "dir_d": 0.0}, "g"))
