"""Closed-loop tolerance tests of the NMPC on the default rig profile (issue 4), marked slow.

Metrics as the issue defines them, on the plant's true state: a target is
settled when both axes stay within 0.1 mm of it from some time to the end of
its hold; the settle time runs from the target switch; the RMS error is taken
over the settled part. The loop is the one of :mod:`maglev_ocp.blocks`
(``plant.reset`` -> ``ctrl.reset`` -> ``ctrl.step`` / ``plant.step``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from controllers.nmpc import NMPC, NMPCSettings
from maglev_ocp import constants as k
from maglev_ocp.blocks import Reference
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig

pytestmark = pytest.mark.slow

TOL = k.position_tolerance
T1 = k.t1  # slot pitch: cogging peaks at odd multiples of t1/2

TOUR = [  # corners and centre of the envelope, incl. the 15 mm gap where cogging is strongest
    (0.020, 0.000, 0.3), (0.015, 0.050, 0.3), (0.025, 0.050, 0.3), (0.025, -0.050, 0.3),
    (0.015, -0.050, 0.3), (0.020, 0.000, 0.3), (0.015, T1 / 2, 0.3), (0.015, -1.5 * T1, 0.3),
]


@dataclass
class TargetMetrics:
    """Per-target metrics of a closed-loop run."""

    g: float
    d: float
    settled: bool
    settle_time_s: float
    rms_error_g_m: float
    rms_error_d_m: float
    max_current_A: float


def run_targets(settings: NMPCSettings, targets, seed=7, profile="default", plan=None, x0=None):
    """Closed loop through ``targets`` [(g, d, hold)]; returns per-target metrics, the log and the plant."""
    plant = Plant(PlantConfig.from_profile(profile), params=NOMINAL, seed=seed)
    ctrl = NMPC(settings, NOMINAL)
    if plan is not None:
        ctrl.set_reference_plan(plan)
    y = plant.reset(x0)
    ctrl.reset(y, Reference(targets[0][0], targets[0][1]))
    log, stats = [], []
    for g, d, hold in targets:
        for _ in range(round(hold / k.Ts)):
            ref = plan.at(y.t) if plan is not None else Reference(g, d)
            out = ctrl.step(y, ref)
            log.append((y.t, *y.x_true, *out.u))
            stats.append(out.stats)
            y = plant.step(out.u)
    log = np.array(log)
    metrics, i0 = [], 0
    for g, d, hold in targets:
        n = round(hold / k.Ts)
        seg = log[i0:i0 + n]
        inside = (np.abs(seg[:, 1] - g) < TOL) & (np.abs(seg[:, 3] - d) < TOL)
        out_idx = np.flatnonzero(~inside)
        first = 0 if out_idx.size == 0 else out_idx[-1] + 1
        settled = first < n
        s = seg[first:] if settled else seg[-1:]
        metrics.append(TargetMetrics(
            g, d, bool(settled), first * k.Ts, float(np.sqrt(np.mean((s[:, 1] - g) ** 2))),
            float(np.sqrt(np.mean((s[:, 3] - d) ** 2))), float(np.max(np.hypot(seg[:, 5], seg[:, 6]))),
        ))
        i0 += n
    return metrics, log, stats, plant


def _check_tour(metrics, log, stats, plant, rms_max=10e-6):
    for m in metrics:
        where = f"target g={m.g * 1e3:.2f} mm, d={m.d * 1e3:.2f} mm"
        assert m.settled, where
        assert m.rms_error_g_m <= rms_max and m.rms_error_d_m <= rms_max, (where, m)
    assert np.all(np.hypot(log[:, 5], log[:, 6]) <= k.i_amp_max + 1e-9)
    assert np.all(np.abs(log[:, 5:7]) <= k.i_axis_max + 1e-9)
    assert not plant.events, plant.events
    assert not any(s["fallback"] for s in stats)


def test_tour_targets_held_within_tolerance():
    metrics, log, stats, plant = run_targets(NMPCSettings(), TOUR, x0=[0.02, 0, 0, 0])
    _check_tour(metrics, log, stats, plant)


def test_random_targets_in_the_envelope():
    rng = np.random.default_rng(np.random.SeedSequence(2024))
    targets = [(0.020, 0.0, 0.1)] + [
        (rng.uniform(*k.g_envelope), rng.uniform(*k.d_envelope), 0.3) for _ in range(6)
    ]
    metrics, log, stats, plant = run_targets(NMPCSettings(), targets, seed=11, x0=[0.02, 0, 0, 0])
    _check_tour(metrics, log, stats, plant)


@pytest.mark.parametrize("mode", ["plan", "preview"])
def test_traverse_100mm_at_20mm_settles_within_120ms(mode):
    targets = [(0.020, -0.050, 0.1), (0.020, 0.050, 0.3)]
    plan = None
    if mode == "preview":  # the runner's current-feasible reference (maglev_ocp.reference)
        from maglev_ocp.reference import ReferenceSettings, Target, plan_targets

        plan = plan_targets((0.020, -0.050), [Target(*t) for t in targets], NOMINAL,
                            ReferenceSettings(current_fraction=0.9))
    metrics, log, stats, plant = run_targets(NMPCSettings(reference=mode), targets, plan=plan,
                                             x0=[0.02, 0, -0.05, 0])
    m = metrics[1]
    assert m.settled and m.settle_time_s <= 0.12, m
    # and not faster than the current-limited minimum-time bound (about 0.089 s, maglev_ocp.ocp)
    assert m.settle_time_s > 0.085
    _check_tour(metrics, log, stats, plant)


def test_cogging_model_gain_at_15mm():
    """Through the strong-cogging region the cogging-aware model tracks a move far better than the blind one."""
    from maglev_ocp.reference import ReferenceSettings, Target, plan_targets

    targets = [(0.015, -1.5 * T1, 0.1), (0.015, 1.5 * T1, 0.3)]
    plan = plan_targets((0.015, -1.5 * T1), [Target(*t) for t in targets], NOMINAL,
                        ReferenceSettings(current_fraction=0.8))
    err = {}
    for cog in (True, False):
        _, log, _, _ = run_targets(NMPCSettings(use_cogging=cog), targets, plan=plan, x0=[0.015, 0, -1.5 * T1, 0])
        t = log[:, 0]
        moving = (t >= 0.1) & (t < 0.1 + plan.moves[1].T)
        e_d = log[moving, 3] - plan.sample(t[moving])[:, 3]
        err[cog] = (np.sqrt(np.mean(e_d**2)), np.max(np.abs(e_d)))
    assert err[True][1] < TOL  # the aware model keeps the move itself within 0.1 mm of the reference
    assert err[True][0] < 0.8 * err[False][0] and err[True][1] < 0.7 * err[False][1], err
