"""The eddy drag's profile along the stroke (:meth:`maglev_ocp.effects.EddyDrag.profile`).

Truths that do not come from the effect's code: a uniform cubic B-spline is 2/3 at its centre and 1/6 one knot
away, and the basis sums to one inside the knot grid (partition of unity), so a profile with every coefficient
``a`` scales the drag by ``1 + a`` over the stroke; with its coefficients at their lower bound (-1) the drag
vanishes but never changes sign.
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.effects import EddyDrag, EffectSet
from maglev_ocp.params import Params

BASE = {**EddyDrag.defaults(), "c_eddy": 300.0}


def _fd(d: float, theta: dict, g: float = 0.015, v: float = 0.1) -> float:
    return float(EddyDrag.forces(g, v, theta, 0.0, d)[1])


def test_defaults_leave_the_drag_as_it_was():
    assert _fd(0.033, BASE) == pytest.approx(float(EddyDrag.forces(0.015, 0.1, BASE)[1]), rel=1e-14)


@pytest.mark.parametrize("a", [-0.5, 0.3, 2.0])
@pytest.mark.parametrize("d", [-0.04, -0.013, 0.0, 0.027, 0.04])
def test_a_uniform_profile_scales_the_drag(a, d):
    th = {**BASE, **dict.fromkeys(EddyDrag.profile_names(), a)}
    assert _fd(d, th) == pytest.approx((1 + a) * _fd(d, BASE), rel=1e-12)


def test_one_knot_is_a_local_bump():
    th = {**BASE, "dprof_20": 1.5}
    ref = _fd(0.02, BASE)
    assert _fd(0.02, th) / ref == pytest.approx(1 + 1.5 * 2 / 3, rel=1e-12)
    assert _fd(0.04, th) / _fd(0.04, BASE) == pytest.approx(1 + 1.5 / 6, rel=1e-12)
    assert _fd(-0.02, th) / _fd(-0.02, BASE) == pytest.approx(1.0, abs=1e-14)  # two knots away and beyond: nil


def test_the_drag_never_changes_sign():
    lo = {**BASE, **dict.fromkeys(EddyDrag.profile_names(), -1.0)}
    for d in np.linspace(-0.05, 0.05, 41):
        assert _fd(float(d), lo) <= 1e-12  # opposes v > 0 or vanishes
    assert abs(_fd(0.0, lo)) < 1e-9


def test_the_model_sees_the_profile_through_d():
    es = EffectSet(["eddy_drag"])
    fn, p = es.accel_function(), Params().vector()
    th = {"c_eddy": 300.0, "dprof_m20": 1.0}
    x_a, x_b = [0.015, 0.0, -0.02, 0.1], [0.015, 0.0, 0.02, 0.1]
    a_a = float(np.asarray(fn(x_a, [0.0, 0.0], p, es.vector({"eddy_drag": th}))).ravel()[1])
    a_b = float(np.asarray(fn(x_b, [0.0, 0.0], p, es.vector({"eddy_drag": th}))).ravel()[1])
    a_0 = float(np.asarray(fn(x_b, [0.0, 0.0], p, es.vector({"eddy_drag": {"c_eddy": 300.0}}))).ravel()[1])
    # the thrust and cogging terms are the same at both positions only up to cogging: compare the eddy parts
    drag_b = _fd(0.02, {**BASE, **th}) / Params().Mh
    drag_a = _fd(-0.02, {**BASE, **th}) / Params().Mh
    assert drag_a == pytest.approx((1 + 2 / 3) * drag_b, rel=1e-12)
    assert a_b - a_0 == pytest.approx(0.0, abs=1e-12)  # dprof_m20 does not reach d = +20 mm
    assert a_a != pytest.approx(a_b, rel=1e-3)
