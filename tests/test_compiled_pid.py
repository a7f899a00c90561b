"""The PID regulators compiled (``pid_step``) and the diagnosis generator's runs on the compiled loop.

Reference: the Python loop (:func:`maglev_ocp.loop.run_closed_loop`) with the Python
:class:`maglev_ocp.controllers.pid.PIDController`, on the same plant seeds and so the same noise draws. The
compiled side is the PID's CasADi step (built from the controller's own law,
:func:`maglev_ocp.controllers.pid.pid_law`) code-generated, and the plant's step code-generated, in one C call.
The default rig profile (noise, quantization, limits, stops, amplifier lag, friction) is on; the logs
must agree to 1e-9, and the quantized readings must be identical (no encoder count flipped).
"""

from __future__ import annotations

import numpy as np
import pytest

from maglev_ocp.codegen.backend import CompiledPID
from maglev_ocp.codegen.build import find_compiler
from maglev_ocp.codegen.loop_c import rig_loop, run_closed_loop_compiled
from maglev_ocp.controllers.pid import PIDController, PIDSettings
from maglev_ocp.diagnosis.generate import ForcedPlant, GeneratorSettings, generate_dataset, run_reference
from maglev_ocp.errors import UserError
from maglev_ocp.loop import run_closed_loop
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig
from maglev_ocp.plant.excitation import AxisExcitation, ExcitationSettings, SumOfSines

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler: the compiled loop cannot be built here")
TOL = 1e-9


def _config(**overrides) -> PlantConfig:
    return PlantConfig.from_profile("default", overrides)


def _assert_same_log(py, cc) -> float:
    """Column by column within TOL (same names, same lengths), readings bit-identical; the worst difference."""
    assert list(py.columns) == list(cc.columns)
    assert py.locked == cc.locked and py.meta == cc.meta
    worst = 0.0
    for key, a in py.columns.items():
        a, b = np.asarray(a, dtype=float), np.asarray(cc.columns[key], dtype=float)
        assert a.shape == b.shape, key
        assert np.array_equal(np.isnan(a), np.isnan(b)), key
        diff = np.abs(a - b)[~np.isnan(a)]
        worst = max(worst, float(diff.max()) if diff.size else 0.0)
        assert worst <= TOL, (key, worst)
    for key in ("g", "d"):  # the readings bit for bit (no encoder count flipped; a zero reading is +0.0 in both)
        a, b = np.asarray(py.columns[key]), np.asarray(cc.columns[key])
        assert np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b)), key
    return worst


def _both(cfg: PlantConfig, seed: int, ref, duration: float, settings: PIDSettings | None = None, **kw):
    """The same run on the Python loop and on the compiled loop (two plants with the same seed)."""
    cparams = NOMINAL.without_cogging()
    logs = []
    for run in (run_closed_loop, run_closed_loop_compiled):
        plant = Plant(cfg, NOMINAL, seed=np.random.SeedSequence(seed))
        logs.append(run(plant, PIDController(cparams, settings), ref, duration, **kw))
    return logs


def test_excitation_sample_equals_its_calls():
    """The vectorized reference the C loop reads is the one the Python loop asks for, bit for bit."""
    ref = run_reference(1, GeneratorSettings(), np.random.SeedSequence(5))
    t = np.arange(3000) * 1e-3  # through the fade-in and beyond
    rows = np.array([[r.g, r.g_dot, r.g_ddot, r.d, r.d_dot, r.d_ddot] for r in map(ref, t)])
    assert np.array_equal(ref.sample(t), rows)
    assert np.ptp(rows[:, 0]) > 1e-4 and np.ptp(rows[:, 3]) > 1e-3  # it does move


@needs_cc
def test_compiled_pid_backend_equals_python_pid():
    """backend: c of the PID (CompiledPID, one pid_step call) gives the Python PID's currents and estimates."""
    ref = run_reference(0, GeneratorSettings(), np.random.SeedSequence(2))
    cparams = NOMINAL.without_cogging()
    out = []
    for ctrl in (PIDController(cparams), CompiledPID(cparams, progress=False)):
        plant = Plant(_config(), NOMINAL, seed=np.random.SeedSequence(4))
        log = run_closed_loop(plant, ctrl, ref, 2.0)
        out.append(log)
    assert out[1].meta["controller"] == "pid"
    _assert_same_log(*out)


@needs_cc
@pytest.mark.parametrize("run", [0, 3])
def test_generator_run_on_the_compiled_loop_equals_the_python_loop(run):
    """A diagnosis run (its excitation reference, the default rig) is the same on both loops."""
    ref = run_reference(run, GeneratorSettings(), np.random.SeedSequence(run + 7))
    py, cc = _both(_config(), 31 + run, ref, 4.0, file=f"excite_{run:02d}.csv")
    assert len(py.columns["t"]) == 4000
    assert np.std(py.columns["g"]) > 5e-4  # the run sweeps the gap (not a trivially quiet hover)
    _assert_same_log(py, cc)


@needs_cc
def test_compiled_loop_equals_python_with_lock_and_stop_hits():
    """A locked horizontal axis (the seed's fixture, i_q fixed) and a gap swept into its lower stop."""
    exc = ExcitationSettings(
        g=AxisExcitation(center=17e-3, amplitude=5e-3, freqs_hz=[0.4, 0.9, 1.7]),
        d=AxisExcitation(center=0.0, amplitude=0.0, freqs_hz=[0.2]),
        fade_in=0.2,
    )
    ref = SumOfSines(exc, 3)
    cfg = _config(stops={"enabled": True, "g": [0.0155, 0.032], "d": [-0.06, 0.06]})
    py, cc = _both(cfg, 5, ref, 3.0, settings=PIDSettings(control_d=False), lock="d", x0=np.array([17e-3, 0, 0, 0]))
    assert py.locked == ("d",)
    assert len(py.meta["stop_events"]) > 0  # the stop is hit: the events must match too
    assert py.meta["stop_events"] == cc.meta["stop_events"]
    _assert_same_log(py, cc)


@needs_cc
def test_compiled_loop_equals_python_where_the_plant_limiter_acts():
    """The rig's amplitude limit below the PID's own: the logged commands are the limiter's on both loops."""
    ref = run_reference(0, GeneratorSettings(), np.random.SeedSequence(8))
    cfg = _config(current_limits={"enabled": True, "axis": 8.0, "amplitude": 3.9})
    py, cc = _both(cfg, 12, ref, 3.0)
    amp = np.hypot(py.columns["i_q"], py.columns["i_d"])
    assert np.sum(np.isclose(amp, 3.9, rtol=0, atol=1e-12)) > 10  # the limiter acted on many steps
    _assert_same_log(py, cc)


@needs_cc
def test_generate_dataset_compiled_equals_python(tmp_path):
    """``maglev diagnose generate``'s generator: the dataset is the same with loop: compiled and python
    (to 1e-9 column by column, and the saved files byte for byte)."""
    cfg = _config(effects={"cogging": {"enabled": True}})
    small = {"n_runs": 3, "run_duration": 2.5}
    gp = generate_dataset(cfg, NOMINAL, seed=9, settings=GeneratorSettings(loop="python", **small))
    gc = generate_dataset(cfg, NOMINAL, seed=9, settings=GeneratorSettings(loop="compiled", **small))
    assert gp.dataset.meta == gc.dataset.meta and "loop" not in gp.dataset.meta["diagnosis_truth"]["generator"]
    assert len(gp.dataset.runs) == len(gc.dataset.runs) == 3
    for a, b in zip(gp.dataset.runs, gc.dataset.runs, strict=True):
        assert a.file == b.file
        _assert_same_log(a, b)
    gp.save(tmp_path / "python")
    gc.save(tmp_path / "compiled")
    files = sorted(p.name for p in (tmp_path / "python").iterdir())
    assert len(files) == 4 and files == sorted(p.name for p in (tmp_path / "compiled").iterdir())
    for name in files:
        assert (tmp_path / "python" / name).read_bytes() == (tmp_path / "compiled" / name).read_bytes(), name


def test_rig_loop_choice():
    """python is the Python loop; a plant with its own Python step (ForcedPlant) cannot be compiled."""
    cfg = _config()
    plant = Plant(cfg, NOMINAL, seed=1)
    assert rig_loop("python", plant) is run_closed_loop
    forced = ForcedPlant(lambda t, x: np.zeros(2), cfg, NOMINAL, seed=1)
    assert rig_loop("auto", forced) is run_closed_loop
    with pytest.raises(UserError, match="ForcedPlant"):
        rig_loop("compiled", forced)
    with pytest.raises(UserError, match="not one of"):
        rig_loop("fast", plant)
    if find_compiler() is not None:
        assert rig_loop("auto", plant) is run_closed_loop_compiled


def test_rig_loop_without_a_compiler_falls_back_with_a_warning(monkeypatch, caplog):
    """No C compiler: auto runs the Python loop and says so in the log; compiled is a clear error."""
    import maglev_ocp.codegen.loop_c as loop_c

    monkeypatch.setattr(loop_c, "find_compiler", lambda: None)
    plant = Plant(_config(), NOMINAL, seed=1)
    with caplog.at_level("WARNING", logger="maglev_ocp.codegen.loop_c"):
        assert rig_loop("auto", plant) is run_closed_loop
    assert any("no C compiler" in r.getMessage() for r in caplog.records)
    with pytest.raises(UserError, match="no C compiler"):
        rig_loop("compiled", plant)
