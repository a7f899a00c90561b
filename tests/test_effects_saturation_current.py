"""The saturation's current loss (:meth:`maglev_ocp.effects.Saturation.current_loss`): a loss of the current terms
that grows with the current magnitude, whatever the gap.

Truths not taken from the effect's code: with every step ``s`` the cumulative spline rises by ``s`` per knot
(2 A) once the partition of unity holds, i.e. linearly at ``s / 2`` per ampere between the first knots' support
and the last one's; it is 0 at no current and never falls; in the model the thrust of a current ``i_q`` at
``|i|`` loses that share (current-terms shares: thrust 1), so ``a_d`` scales by ``1 - L_i``.
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.effects import EffectSet, Saturation
from maglev_ocp.params import Params

UNIFORM = {**Saturation.defaults(), "loss_8mm": 0.0, **dict.fromkeys(Saturation.current_names(), 0.01)}


def test_zero_at_no_current_and_never_falling():
    rng = np.random.default_rng(3)
    for _ in range(20):
        th = {**Saturation.defaults(), **{n: float(rng.uniform(0, 0.1)) for n in Saturation.current_names()}}
        a = np.linspace(0.0, 12.0, 121)
        L = np.array([float(Saturation.current_loss(x, th)) for x in a])
        assert L[0] == 0.0
        assert np.all(np.diff(L) >= -1e-15)


@pytest.mark.parametrize("a", [3.0, 4.5, 6.0, 7.7])
def test_uniform_steps_give_a_linear_loss(a):
    # 0.01 per 2 A: between 2 A and 10 A the loss is 0.005 A^-1 (a - a0) with the same a0 at every current
    slope = (float(Saturation.current_loss(a, UNIFORM)) - float(Saturation.current_loss(2.5, UNIFORM))) / (a - 2.5)
    assert slope == pytest.approx(0.005, rel=1e-9)


def test_the_thrust_loses_its_share_at_any_gap():
    es = EffectSet(["saturation"])
    fn, p = es.accel_function(), Params().vector()
    shares = {"w_pm": 0.0, "w_id": 1.0, "w_thrust": 1.0, "w_rel": 2.0}
    th_on = es.vector({"saturation": {**UNIFORM, **shares}})
    th_off = es.vector({"saturation": {"loss_8mm": 0.0, **shares}})
    none = EffectSet([])
    for g in (0.012, 0.02, 0.03):
        x, u = [g, 0.0, 0.0, 0.0], [5.0, 0.0]  # i_d = 0: the horizontal channel is the thrust (and cogging)
        a_on = float(np.asarray(fn(x, u, p, th_on)).ravel()[1])
        a_off = float(np.asarray(fn(x, u, p, th_off)).ravel()[1])
        # the cogging term is not a current term (w_pm = 0): take it out with the thrust-free model
        a_cog = float(np.asarray(none.accel_function()(x, [0.0, 0.0], p, none.defaults())).ravel()[1])
        loss = float(Saturation.current_loss(float(np.sqrt(25.0 + 1e-6)), UNIFORM))
        assert (a_on - a_cog) == pytest.approx((1 - loss) * (a_off - a_cog), rel=1e-9)
        assert loss == pytest.approx(0.0225, abs=0.002)
