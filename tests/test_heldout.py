"""Held-out validation: the diagnosis's fitted values against the independent rig's ``truth.json``.

The datasets come from :mod:`maglev_ocp.rigsim` (which shares no model, effect or controller code with the
suite: an import-linter contract) with seeds from :data:`seeds.VALIDATION_SEEDS`, never used while developing.
The effect's parameters are drawn by rigsim's own drawers from that seed, so nobody chose them. The truth the
fitted values are compared with is what the generator wrote (its constants, its effect's peak force along the
trajectory), and the lag's effective delay is computed here from the generator's law parameters (the low-frequency
group delay of a first- or second-order lag plus its transport delay), not by the fitter.

Tolerances were set before these checks first ran and follow the issue's targets: constants C1..C3 within 1 %
and C4 within 10 % (the generator draws them up to 5 % off nominal, so a calibration that learned nothing fails),
effect sizes within 20 % of the truth.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from seeds import DEVELOPMENT_SEEDS, VALIDATION_SEEDS

from maglev_ocp import constants as k
from maglev_ocp.diagnosis import DiagnoseSettings, diagnose
from maglev_ocp.riglog import read_dataset
from maglev_ocp.rigsim import RigSettings, generate
from maglev_ocp.rigsim.draw import DRAWS

pytestmark = pytest.mark.slow

#: Relative tolerances of the constants (C4, the reluctance term, is the least determined: seed Table III).
CONSTANT_TOL = {"C1": 0.01, "C2": 0.01, "C3": 0.01, "C4": 0.10}
#: Relative tolerance of a fitted effect size against the truth.
SIZE_TOL = 0.20


def _dataset(tmp_path, label: str, effect: str | dict | None):
    seed = VALIDATION_SEEDS[label]
    assert seed not in DEVELOPMENT_SEEDS
    if isinstance(effect, dict):
        effects = effect
    else:
        effects = {} if effect is None else {effect: DRAWS[effect](np.random.default_rng(seed))}
    folder = generate(tmp_path / label, effects, seed, RigSettings(n_runs=4, duration=8.0))
    truth = json.loads((folder / "truth.json").read_text())
    d = diagnose(read_dataset(folder), settings=DiagnoseSettings(seed=seed % 2**31, simulate=False))
    return truth, d


def _check_constants(truth: dict, d) -> None:
    got = d.baseline_params.as_dict()
    for name, tol in CONSTANT_TOL.items():
        true = truth["true_constants"][name]
        assert abs(got[name] / true - 1) <= tol, (name, got[name], true, d.table())


def _size(d, name: str):
    sizes = {s.name: s for s in (d.consequences.sizes if d.consequences is not None else [])}
    assert name in sizes, (sorted(sizes), d.table())
    return sizes[name]


def true_effective_delay(family: str, p: dict) -> float:
    """Low-frequency group delay of rigsim's amplifier law [s]: transport delay plus the lag's own (the phase
    slope at zero frequency: ``1 / omega_b`` of a first-order lag, ``2 zeta / omega_n`` of a second-order one)."""
    delay = p.get("delay_samples", 0.0) * k.Ts
    if family == "first":
        delay += 1.0 / (2 * math.pi * p["bandwidth_hz"])
    elif family == "second":
        delay += 2 * p["zeta"] / (2 * math.pi * p["fn_hz"])
    return delay


@pytest.mark.long  # CI: `none` on a clean dataset (test_diagnosis.py) and the calibration acceptance
def test_a_rig_without_effects_gives_its_constants(tmp_path):
    """No effect: the verdict is `none`, and the calibrated constants are the generator's true ones."""
    truth, d = _dataset(tmp_path, "rig_truth_none", None)
    assert d.verdict.verdict == "none", d.table()
    _check_constants(truth, d)


def test_an_amplifier_lag_is_fitted_with_its_delay(tmp_path):
    """A drawn amplifier law (first order, second order or pure delay): named, its effective delay within 20 %
    of the generator's, the constants still the true ones."""
    truth, d = _dataset(tmp_path, "rig_truth_lag", "amplifier_lag")
    assert "amplifier_lag" in d.verdict.verdict.split("+"), d.table()
    size = _size(d, "amplifier_lag")
    law = truth["effects"]["amplifier_lag"]
    want = true_effective_delay(law["family"], law["params"])
    assert law["effective_delay_s"] == pytest.approx(want, rel=1e-12)  # the generator's own record agrees
    assert size.delay_us is not None
    assert abs(size.delay_us * 1e-6 / want - 1) <= SIZE_TOL, (size.delay_us, want * 1e6, truth["effects"])
    _check_constants(truth, d)


def test_friction_is_fitted_with_its_force(tmp_path):
    """A drawn friction law: named, its peak force on the larger axis within 20 % of the generator's."""
    truth, d = _dataset(tmp_path, "rig_truth_friction", "friction")
    assert "friction" in d.verdict.verdict.split("+"), d.table()
    size = _size(d, "friction")
    t = truth["effects"]["friction"]
    axis = "g" if t["peak_force_g_n"] >= t["peak_force_d_n"] else "d"
    want = t[f"peak_force_{axis}_n"]
    assert abs(size.peak_force_n[axis] / want - 1) <= SIZE_TOL, (axis, size.peak_force_n, want, t)


@pytest.mark.long  # issue 29: a lag beside another effect, named and sized from the joint model
def test_a_one_period_delay_and_second_order_lag_beside_friction_is_named(tmp_path):
    """Issue 29: an amplifier of second order (natural frequency drawn in 400-800 Hz from the seed, zeta 0.6)
    behind a one-period delay, next to Stribeck friction: the lag is named and its effective delay is within
    20 % of the generator's (the single-effect check above does not meet another effect's misfit)."""
    fn = float(np.random.default_rng(VALIDATION_SEEDS["rig_truth_lag_friction"]).uniform(400.0, 800.0))
    lag = {"family": "second", "fn_hz": fn, "zeta": 0.6, "delay_samples": 1.0}
    truth, d = _dataset(tmp_path, "rig_truth_lag_friction", {"amplifier_lag": lag, "friction": {"family": "stribeck"}})
    assert "amplifier_lag" in d.verdict.verdict.split("+"), (d.verdict.reasons, d.table())
    size = _size(d, "amplifier_lag")
    want = true_effective_delay("second", lag)
    assert truth["effects"]["amplifier_lag"]["effective_delay_s"] == pytest.approx(want, rel=1e-12)
    assert size.delay_us is not None
    assert abs(size.delay_us * 1e-6 / want - 1) <= SIZE_TOL, (size.delay_us, want * 1e6, truth["effects"])
