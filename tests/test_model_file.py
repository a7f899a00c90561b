"""Model files for controllers (issue 12, item 1): constants plus effects, loaded by ``controller: {model: FILE}``.

The loader reads the plant profiles' ``effects:`` format; FL with the true
model file of a plant with strong friction tracks far better than blind.
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings
from maglev_ocp.controllers.model_file import effect_delta_function, load_controller_model
from maglev_ocp.effects import EffectSet
from maglev_ocp.errors import ConfigError
from maglev_ocp.output import dump_yaml
from maglev_ocp.runner import run_scenario

FRICTION = {
    "coulomb_g": 1.0,
    "coulomb_d": 2.0,
    "stribeck_g": 0.3,
    "stribeck_d": 0.8,
    "v_stribeck": 2e-3,
    "viscous_g": 3.0,
    "viscous_d": 8.0,
    "v_reg": 2e-4,
}


def test_loader_reads_constants_effects_and_lag(tmp_path):
    f = tmp_path / "model.yaml"
    dump_yaml(
        f,
        {
            "C4": 0.6,
            "effects": {
                "friction": {"enabled": True, **FRICTION},
                "saturation": {"enabled": False},
                "amplifier_lag": {"enabled": True, "bandwidth_hz": 2000.0, "delay_samples": 1},
            },
        },
    )
    cm = load_controller_model(f)
    assert cm.params.C4 == 0.6 and cm.effects == ("friction",) and cm.delay_samples == 1
    np.testing.assert_allclose(cm.theta, EffectSet(["friction"]).vector({"friction": FRICTION}))
    # the delta is the effect library's force over the mass: at rest it is zero, moving it opposes the motion
    fn = effect_delta_function(cm.effects)
    x_mov = np.array([0.02, 0.0, 0.0, 0.5])
    (d,) = fn(x_mov, [0.0, 1.5], cm.params.vector(), cm.theta).full().T
    assert d[1] < 0 and abs(d[0]) < 1e-9
    # FL takes the delay of the declared lag and the model's constants
    fl = FeedbackLinearization(FLSettings(model=str(f)))
    assert fl.delay == 1 and fl.params.C4 == 0.6


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        ({"effects": {"warp": {"enabled": True}}}, "warp"),
        (
            {"effects": {"friction": {"enabled": True, "coulomb_d": -1.0}}},
            r"friction\.coulomb_d = -1 \(allowed 0\.\.10\)",
        ),
    ],
)
def test_loader_refuses_unknown_or_out_of_bounds_effects(tmp_path, bad, match):
    f = tmp_path / "bad.yaml"
    dump_yaml(f, bad)
    with pytest.raises(ConfigError, match=match):
        load_controller_model(f)


def test_fl_with_the_true_friction_model_tracks_better(tmp_path):
    """Strong friction on the plant: FL with the true model file vs blind (measured: d 52 um -> 6 um RMS)."""
    f = tmp_path / "friction.yaml"
    dump_yaml(f, {"effects": {"friction": {"enabled": True, **FRICTION}}})
    rms = {}
    for label, ctrl in (("blind", {"type": "fl"}), ("model", {"type": "fl", "model": str(f)})):
        sc = {
            "name": f"friction_{label}",
            "seed": 4,
            "controller": ctrl,
            "plant": {"profile": "default", "effects": {"friction": {"enabled": True, **FRICTION}}},
            "start": {"g": 0.02, "d": -0.03},
            "targets": [
                {"g": 0.02, "d": 0.03, "hold": 0.25},
                {"g": 0.018, "d": -0.03, "hold": 0.25},
                {"g": 0.02, "d": 0.0, "hold": 0.25},
            ],
        }
        res = run_scenario(sc, progress=False)
        assert res.metrics.all_settled and res.metrics.stop_hits == 0
        c = res.columns
        rms[label] = float(np.sqrt(np.mean((c["d_true"] - c["d_ref"]) ** 2)))
    assert rms["model"] < 0.3 * rms["blind"], rms


def test_pid_feedforward_meets_a_declared_amplifier_delay(tmp_path):
    """A plant whose amplifiers lag by two periods and 0.3 ms: the PID whose model file declares that lag takes its
    feed-forward from the plan 2.3 periods ahead and tracks the moves in d far closer than the PID without it
    (the error is the simulated mover's against the plan, which neither controller computes; measured: d RMS
    760 um -> 89 um)."""
    lag = {"enabled": True, "bandwidth_hz": 530.0, "delay_samples": 2}
    f = tmp_path / "lag.yaml"
    dump_yaml(f, {"effects": {"amplifier_lag": lag}})
    cm = load_controller_model(f)
    assert cm.delay_samples == 2 and cm.lag_time_s == pytest.approx(1 / (2 * np.pi * 530.0))
    rms = {}
    for label, ctrl in (("blind", {"type": "pid"}), ("model", {"type": "pid", "model": str(f)})):
        sc = {
            "name": f"pid_lag_{label}",
            "seed": 5,
            "controller": ctrl,
            "plant": {"profile": "default", "effects": {"amplifier_lag": lag}},
            "start": {"g": 0.02, "d": -0.03},
            "targets": [{"g": 0.02, "d": 0.03, "hold": 0.4}, {"g": 0.02, "d": -0.03, "hold": 0.4}],
        }
        res = run_scenario(sc, progress=False)
        assert res.metrics.all_settled and res.metrics.stop_hits == 0
        c = res.columns
        rms[label] = float(np.sqrt(np.mean((c["d_true"] - c["d_ref"]) ** 2)))
    assert rms["model"] < 0.3 * rms["blind"], rms


@pytest.mark.parametrize("ctype", ["fl", "pid", "nmpc"])
def test_every_controller_refuses_an_untrusted_model_file_unless_told_to_use_it(ctype, tmp_path):
    """A file marked ``trusted: false`` is refused by default (its reasons and the setting named); with
    ``untrusted_model: use`` it loads, with the loader's warning."""
    from maglev_ocp.controllers.nmpc import NMPCSettings
    from maglev_ocp.controllers.pid import PIDSettings
    from maglev_ocp.params import UntrustedModelWarning

    cls = {"fl": FLSettings, "pid": PIDSettings, "nmpc": NMPCSettings}[ctype]
    f = tmp_path / "model.yaml"
    dump_yaml(f, {"trusted": False, "untrusted_because": ["C1 -80 % from nominal"], "C1": 2.84, "effects": {}})
    with pytest.raises(ValueError, match=r"marked untrusted.*C1 -80 % from nominal.*untrusted_model"):
        cls(model=str(f))
    assert cls(model=str(f), untrusted_model="use").model == str(f)
    with pytest.raises(ValueError, match="untrusted_model"):
        cls(model=str(f), untrusted_model="maybe")
    with pytest.warns(UntrustedModelWarning, match="C1 -80 %"):
        load_controller_model(f)
    # the same file without the mark: accepted as it is
    dump_yaml(f, {"C1": 2.84, "effects": {}})
    assert cls(model=str(f)).untrusted_model == "refuse"
