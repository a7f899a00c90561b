"""Noise floor from a noise model, whiteness, resonance peaks, the lag guard, effect sizes, model files.

Fast tests on synthetic residuals (a closed loop integrated under a zero-order
hold, read through 10 um encoders); the slow one diagnoses a generated dataset
with a lightly damped structural resonance end to end.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.signal as sps
import yaml

from maglev_ocp import constants as k
from maglev_ocp.diagnosis.candidates import CandidateSpec, FitResult, library_specs
from maglev_ocp.diagnosis.consequence import effect_force, effect_size, plant_effects, plant_file
from maglev_ocp.diagnosis.localize import channel_floor
from maglev_ocp.diagnosis.peaks import forced_peaks, noise_check, resonance_guard
from maglev_ocp.diagnosis.residuals import ResidualSettings, RunInput, ZeroPhaseFilter, prepare_run, residual_of
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import load_plant_config

SIG_A = 0.012  # acceleration noise per period [m/s^2] (the default rig's process force noise / Mv)


def _mode(f0: float, zeta: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """Unit-rms displacement of a second-order mode driven by white noise (bilinear discretization)."""
    w0 = 2 * math.pi * f0
    b, a = sps.bilinear([w0**2], [1, 2 * zeta * w0, w0**2], fs=1 / k.Ts)
    e = sps.lfilter(b, a, rng.standard_normal(n + 2000))[2000:]
    return e / e.std()


def synthetic_residuals(f0=None, zeta=0.02, x_rms=10e-6, n_runs=4, n=10000, seed=0, line=None, gain_error=None):
    """Residuals of a PD loop with white acceleration noise, 2 um encoder noise, 10 um quantization.

    The model knows the loop's own acceleration, so the residual is the noise (and the mode, if
    ``f0`` is given: a structural resonance of ``x_rms`` between the encoder and the stage).
    ``line = (f, amplitude_m, model_error)``: the gap reference also carries a sine of ``f`` Hz, and
    the model misses ``model_error`` of the loop's acceleration in a narrow band around it (a model
    error on a line of the excitation, as a lag or a saturation leaves).
    """
    rng = np.random.default_rng(seed)
    filt = ZeroPhaseFilter(ResidualSettings())
    out = []
    for i in range(n_runs):
        a_n = SIG_A * rng.standard_normal(n - 1)
        a_c = gain_error[0] * rng.standard_normal(n - 1) if gain_error else np.zeros(n - 1)
        t = np.arange(n) * k.Ts
        ref = np.column_stack([0.015 + 2e-3 * np.sin(2 * np.pi * 0.2 * t + i), 0.04 * np.sin(2 * np.pi * 0.15 * t)])
        if line is not None:
            ref[:, 0] += line[1] * np.sin(2 * np.pi * line[0] * t + i)
        x = np.zeros((n, 2))
        x[0] = ref[0]
        v = np.zeros(2)
        acc = np.zeros((n - 1, 2))
        for j in range(n - 1):
            acc[j] = -400.0 * (x[j] - ref[j]) - 40.0 * v
            acc[j, 0] += a_n[j] + a_c[j]
            x[j + 1] = x[j] + v * k.Ts + 0.5 * acc[j] * k.Ts**2
            v = v + acc[j] * k.Ts
        if f0:
            x[:, 0] += x_rms * _mode(f0, zeta, n, rng)
        y = np.round((x + 2e-6 * rng.standard_normal(x.shape)) / k.encoder_resolution) * k.encoder_resolution
        run = prepare_run(RunInput(f"r{i}", k.Ts, y, np.zeros((n, 2))), filt)
        model = acc.copy()
        model[:, 0] -= a_n + (gain_error[1] * a_c if gain_error else 0.0)  # the model's current force is off
        if line is not None:
            bp = sps.butter(2, [line[0] - 1.0, line[0] + 1.0], btype="bandpass", fs=1 / k.Ts, output="sos")
            model[:, 0] -= line[2] * sps.sosfiltfilt(bp, model[:, 0])
        out.append(residual_of(run, model))
    return out, filt


@pytest.fixture(scope="module")
def white():
    return synthetic_residuals()


@pytest.fixture(scope="module")
def resonant():
    return synthetic_residuals(f0=12.0, zeta=0.02, x_rms=10e-6)


def test_white_residual_passes_the_whiteness_check_and_its_model_floor_is_the_noise(white):
    """Noise alone: white, no peak, and the model floor is the filtered residual's rms (within 15 %)."""
    res, filt = white
    nc = noise_check(res, 0, filt.w_y, filt.w_a)
    assert nc.whiteness.white, nc.whiteness
    assert nc.peaks == []
    assert 0.85 < nc.rms / nc.floor < 1.15, (nc.rms, nc.floor)
    # The levels are the synthetic ones: 10 um quantization + 2 um encoder noise, SIG_A per period.
    m = nc.model.to_dict()
    assert m["position_noise_m"] == pytest.approx(math.sqrt(1e-10 / 12 + 4e-12), rel=0.1)
    assert m["accel_noise_m_s2"] == pytest.approx(SIG_A, rel=0.25)
    assert nc.quantization == pytest.approx(filt.quantization_floor(), rel=1e-12)


def test_a_broadband_misfit_raises_the_noise_model_floor_and_the_right_model_gives_the_noise(white):
    """Why the claim guard takes its floor from the verdict's model (:func:`..stages.claims._verdict_floors`): a
    model whose force on the current is off (a constant, a commutation offset) leaves a broad-band misfit where
    the current has broad-band content, above the residual filter's cut-off where the noise model is fitted, and
    its floor rises well above the noise's; the model without the misfit gives the noise's floor (truth: the
    synthetic levels, as in the white case)."""
    res, filt = white
    right = noise_check(res, 0, filt.w_y, filt.w_a)
    off_res, _ = synthetic_residuals(gain_error=(3 * SIG_A, 0.5))
    wrong = noise_check(off_res, 0, filt.w_y, filt.w_a)
    assert right.model.to_dict()["accel_noise_m_s2"] == pytest.approx(SIG_A, rel=0.25)
    # White misfit 1.5 SIG_A beside the noise SIG_A: acceleration level sqrt(1 + 1.5^2) = 1.8 times the noise's.
    assert wrong.model.to_dict()["accel_noise_m_s2"] == pytest.approx(math.sqrt(1 + 1.5**2) * SIG_A, rel=0.25)
    # The floor also carries the readings' noise and quantization through the filter, which no misfit changes:
    # it rises by less than the acceleration level, but it rises.
    assert wrong.floor > 1.15 * right.floor, (wrong.floor, right.floor)


def test_a_resonance_does_not_inflate_the_floor_and_is_found_with_its_damping(white, resonant):
    """A 12 Hz mode of 1 encoder count rms: the data floor swells, the model floor does not; peak within 5 %."""
    (rw, filt), (rr, _) = white, resonant
    clean = noise_check(rw, 0, filt.w_y, filt.w_a)
    nc = noise_check(rr, 0, filt.w_y, filt.w_a)
    data_floor = channel_floor(rr[:3], rr[3:], 0, filt.quantization_floor())
    # The data-based floor takes the resonance for noise (the failure) ...
    assert data_floor.floor > 5 * clean.floor
    # ... the noise model's floor does not move.
    assert nc.floor == pytest.approx(clean.floor, rel=0.2)
    assert nc.excess_ratio > 5
    assert not nc.whiteness.white
    pk = nc.peaks[0]
    assert pk.resolved and pk.kind == "resonance"
    assert abs(pk.freq_hz / 12.0 - 1) < 0.05
    assert 0.01 < pk.damping < 0.04, pk.damping
    assert pk.channel == "vertical"
    assert 5e-6 < pk.rms_m < 20e-6  # about one encoder count


def test_a_resonance_above_the_filter_band_is_found_too():
    """A 35 Hz mode lies above the 15 Hz residual filter: only the wide-band spectrum sees it."""
    res, filt = synthetic_residuals(f0=35.0, zeta=0.02, n_runs=3, seed=4)
    nc = noise_check(res, 0, filt.w_y, filt.w_a)
    assert nc.peaks and abs(nc.peaks[0].freq_hz / 35.0 - 1) < 0.05
    assert nc.peaks[0].damping == pytest.approx(0.02, rel=0.5)


def test_a_lag_that_only_removes_the_peak_is_flagged(resonant):
    """The guard: an 'improvement' inside the resonance band is no lag; removing broadband content is."""
    res, filt = resonant
    nc = noise_check(res, 0, filt.w_y, filt.w_a)
    sos = sps.butter(2, [10.0, 14.0], btype="bandstop", fs=1 / k.Ts, output="sos")
    lp = sps.butter(2, [1.0, 8.0], btype="bandpass", fs=1 / k.Ts, output="sos")
    rng = np.random.default_rng(3)
    notch, lagged = [], []
    for r in res:
        a = r.wide.copy()
        a[:, 0] = sps.sosfiltfilt(sos, a[:, 0])
        notch.append(type(r)(r.run, r.r, r.model, a))
        # A residual that also carries broadband content below the peak (what a real lag leaves) ...
        b = r.wide.copy()
        b[:, 0] += 0.2 * sps.sosfiltfilt(lp, rng.standard_normal(len(b)))
        lagged.append(type(r)(r.run, r.r, r.model, b))
    g = resonance_guard("amplifier_lag", res, notch, nc.peaks, filt.h)
    assert g.absorbs_resonance and g.fraction_in_peaks > 0.7 and g.peak_left < 0.2
    # ... and a candidate that removes that content, leaving the peak: not a resonance.
    g2 = resonance_guard("amplifier_lag", lagged, res, nc.peaks, filt.h)
    assert not g2.absorbs_resonance and g2.peak_left > 0.9
    assert not resonance_guard("amplifier_lag", res, notch, [], filt.h).absorbs_resonance


def test_a_lag_that_models_the_peak_and_the_broadband_residual_is_not_flagged(resonant):
    """The converse of the guard: a lag that the loop turns into a lightly damped closed-loop mode leaves a line
    in the baseline residual that the lag model removes, together with the lag's broadband residual around it;
    that candidate explains the peak and is named, while one that removes the peak only stays flagged."""
    res, filt = resonant
    nc = noise_check(res, 0, filt.w_y, filt.w_a)
    sos = sps.butter(2, [10.0, 14.0], btype="bandstop", fs=1 / k.Ts, output="sos")
    lp = sps.butter(2, [1.0, 6.0], btype="bandpass", fs=1 / k.Ts, output="sos")
    rng = np.random.default_rng(5)
    before, both, peak_only = [], [], []
    for r in res:
        b = r.wide.copy()
        b[:, 0] += 0.2 * sps.sosfiltfilt(lp, rng.standard_normal(len(b)))  # the lag's broadband part
        before.append(type(r)(r.run, r.r, r.model, b))
        a = r.wide.copy()
        a[:, 0] = sps.sosfiltfilt(sos, a[:, 0])
        both.append(type(r)(r.run, r.r, r.model, a))  # peak and broadband part removed
        c = b.copy()
        c[:, 0] = sps.sosfiltfilt(sos, c[:, 0])
        peak_only.append(type(r)(r.run, r.r, r.model, c))  # peak removed, broadband part left
    g = resonance_guard("amplifier_lag", before, both, nc.peaks, filt.h)
    # Most of the improvement is still in the peak (the old guard flagged this) ...
    assert g.fraction_in_peaks > 0.6, g
    # ... but the candidate removes the peak and most of the residual half an octave away from it.
    assert g.peak_left < 0.1 and g.outside_reduction > 0.7, g
    assert g.explains_peaks and not g.absorbs_resonance
    # Removing the peak alone (the broadband part left in place) is still absorbing a resonance.
    g2 = resonance_guard("amplifier_lag", before, peak_only, nc.peaks, filt.h)
    assert g2.outside_reduction < 0.2 and g2.absorbs_resonance and not g2.explains_peaks, g2


def test_a_line_of_the_motion_is_no_resonance_for_the_lag_guard(resonant):
    """A residual line where the excitation has one, the model missing 20 % of the response there, is the
    model's error on a forced motion (a lag may remove it); a structural mode is not in the model at all."""
    res, filt = synthetic_residuals(line=(7.0, 0.3e-3, 0.2), n_runs=3, seed=2)
    nc = noise_check(res, 0, filt.w_y, filt.w_a)
    pk = [p for p in nc.peaks if abs(p.freq_hz - 7.0) < 0.5]
    assert pk, [p.freq_hz for p in nc.peaks]
    assert forced_peaks(pk, res) == pk
    # A candidate that removes that line is not flagged as absorbing a resonance ...
    sos = sps.butter(2, [6.0, 8.0], btype="bandstop", fs=1 / k.Ts, output="sos")
    removed = []
    for r in res:
        a = r.wide.copy()
        a[:, 0] = sps.sosfiltfilt(sos, a[:, 0])
        removed.append(type(r)(r.run, r.r, r.model, a))
    g = resonance_guard("amplifier_lag", res, removed, pk, filt.h)
    assert not g.absorbs_resonance and g.forced_hz and g.peaks_hz == []
    # ... while the 12 Hz structural mode carries (almost) all the measured power in its band: not forced.
    rr, f2 = resonant
    nr = noise_check(rr, 0, f2.w_y, f2.w_a)
    assert nr.peaks and forced_peaks(nr.peaks, rr) == []


def test_the_gap_closed_is_measured_above_the_noise_models_floor():
    """A candidate that halves the residual's mean square above the floor closes half the gap; measured against a
    data-based floor that the structure has inflated (floor_ms = 1 in its units) the same fit 'closes' it all."""
    from types import SimpleNamespace

    from maglev_ocp.diagnosis.attribution import VerdictRules, score

    rng = np.random.default_rng(0)
    n = 4000
    run = SimpleNamespace(n=n, valid=np.array([True, False]))
    noise = rng.standard_normal((n, 2))
    struct = 3.0 * np.sin(np.linspace(0, 60, n))[:, None] * np.array([1.0, 0.0])
    mk = lambda r: SimpleNamespace(run=run, r=r)  # noqa: E731
    before, after = mk(noise + struct), mk(noise + struct / math.sqrt(2))
    base_fit = SimpleNamespace(success=True)
    # In units of a data-based floor of 2.5 (the structure inflated it), the noise floor is 1/2.5.
    fl = np.array([2.5, 1.0])
    kw = dict(fit=None, base_fit=base_fit, before=[before], after=[after], floors=fl, rules=VerdictRules(),
              params={}, stderr={})  # fmt: skip
    honest = score("x", floor_ms=(1 / 2.5) ** 2, **kw)
    assert honest.closes == pytest.approx(0.5, abs=0.03)
    assert score("x", floor_ms=1.0, **kw).closes > 0.95


def _cogging_fit(xi0=4.0, ell=3.6e-3):
    spec = library_specs()["cogging"]
    vals = {"p.xi0": xi0, "p.ell": ell}
    w = np.array([vals.get(f.key, 0.0) for f in spec.free])
    return spec, FitResult(spec, w, np.zeros(len(w)), 0.0, 1, 1.0)


def _sweep_run(g=0.012, n=4000):
    t = np.arange(n) * k.Ts
    d = 0.03 * np.sin(2 * np.pi * 0.25 * t)  # several slot pitches
    y = np.column_stack([np.full(n, g), d])
    u = np.column_stack([0.5 * np.sin(2 * np.pi * 3 * t), 3.0 + 0.5 * np.cos(2 * np.pi * 3 * t)])
    return prepare_run(RunInput("sweep", k.Ts, y, u), ZeroPhaseFilter(ResidualSettings())), u


def test_peak_force_of_a_known_cogging_law():
    """Seed eq. (9) at g = 12 mm: tangential peak xi0 exp(-(g - 10 mm)/ell) in N and % of the weight."""
    spec, fit = _cogging_fit()
    run, u = _sweep_run()
    p = NOMINAL.without_cogging().vector()
    F = effect_force(spec, fit, [run], [u], p)
    peak = 4.0 * math.exp(-(0.012 - 0.010) / 3.6e-3)
    assert np.max(np.abs(F[:, 1])) == pytest.approx(peak, rel=0.01)
    # Normal part xi sin^2 (attractive): the same peak, downwards.
    assert np.min(F[:, 0]) == pytest.approx(-peak, rel=0.01)
    s = effect_size("cogging", spec, fit, [run], [u], p, simulate=False)
    assert s.peak_force_n["d"] == pytest.approx(peak, rel=0.01)
    assert s.peak_force_pct_weight == pytest.approx(100 * peak / (k.Mv * k.G), rel=0.01)
    assert s.delay_us is None and s.matters is None


def test_a_small_lag_is_a_delay_in_us_and_negligible_in_closed_loop():
    """A 44 us lag on a 1 ms loop: its delay is reported in us and both controllers say negligible."""
    spec = library_specs()["amplifier_lag"]
    bw = 1.0 / (2 * math.pi * 44e-6)
    fit = FitResult(
        spec, np.zeros(0), np.zeros(0), 0.0, 1, 1.0,
        {"bandwidth_hz": bw, "delay_samples": 0, "effective_delay_s": 44e-6, "effective_delay_s_stderr": 3e-6},
    )  # fmt: skip
    run, u = _sweep_run(0.018)
    s = effect_size("amplifier_lag", spec, fit, [run], [u], NOMINAL.without_cogging().vector())
    assert s.delay_us == pytest.approx(44.0)
    # (dF/di) tau di/dt: a few mN for currents swinging 0.5 A at 3 Hz.
    assert 1e-4 < max(s.peak_force_n.values()) < 0.05
    assert set(s.closed_loop) == {"fl", "nmpc"}
    assert s.matters is False, s.summary
    assert "negligible" in s.summary


def test_model_file_loads_as_a_plant_profile(tmp_path):
    """The augmented model's plant file: constants exact, the fitted law switched on, everything else off."""
    spec = library_specs()["friction"]
    vals = {"friction.coulomb_g": 0.5, "friction.coulomb_d": 0.4, "friction.viscous_g": -1e-12}
    w = np.array([vals.get(f.key, 0.0) for f in spec.free])
    fit = FitResult(spec, w, np.zeros(len(w)), 0.0, 1, 1.0)
    p = NOMINAL.without_cogging().with_(C1=13.0).vector()
    params, effects, dropped = plant_effects(spec, fit, p)
    path = tmp_path / "model.yaml"
    path.write_text(yaml.safe_dump(plant_file(params, effects)))
    cfg = load_plant_config(path)
    assert cfg.enabled_effects() == ("friction",)
    fr = cfg.effect_values()["friction"]
    assert fr["coulomb_g"] == 0.5 and fr["coulomb_d"] == 0.4 and fr["viscous_g"] == 0.0
    assert cfg.mismatch.overrides.C1 == 13.0
    assert dropped == []
    from maglev_ocp.plant import Plant

    plant = Plant(cfg, NOMINAL, seed=0)
    assert plant.true_params.C1 == 13.0


def test_model_file_wraps_fitted_phases_into_the_plant_range():
    """A fitted phase beyond the plant's one-period range is wrapped, never clamped: the fit searches two
    periods, and cogging's 3rd harmonic fitted at 6.281 rad (= -0.002 rad) was written as pi, its sign flipped.
    The force of the written law equals the fitted one."""
    spec = library_specs()["cogging"]
    vals = {"cogging.h2": -0.996, "cogging.h3": 0.499, "cogging.phi2": 3.14, "cogging.phi3": 2 * np.pi - 0.002}
    w = np.array([vals.get(f.key, f.start) for f in spec.free])
    fit = FitResult(spec, w, np.zeros(len(w)), 0.0, 1, 1.0)
    _, effects, _ = plant_effects(spec, fit, NOMINAL.vector())
    cog = effects["cogging"]
    assert cog["phi3"] == pytest.approx(-0.002, abs=1e-12) and cog["phi2"] == pytest.approx(3.14)
    d = np.linspace(-0.05, 0.05, 41)
    fitted = np.sin(3 * np.pi * d / 0.01905 + vals["cogging.phi3"])
    written = np.sin(3 * np.pi * d / 0.01905 + cog["phi3"])
    np.testing.assert_allclose(written, fitted, atol=1e-12)


@pytest.mark.long
def test_structural_resonance_end_to_end_on_the_independent_rig(tmp_path):
    """Independent rig (rigsim), a 35 Hz frame mode of 1 encoder count and nothing else the baseline lacks.

    The diagnosis must call it ``unexplained``, with the peak's frequency within 5 %, its damping, the
    channel and the region; the model floor stays at the noise; the spectra figure is drawn; the
    report writes model files that load as plant profiles.
    """
    from maglev_ocp.diagnosis import diagnose
    from maglev_ocp.diagnosis.report import write_report
    from maglev_ocp.riglog import read_dataset
    from maglev_ocp.rigsim import RigSettings, generate

    f_true = 35.0
    folder = generate(
        tmp_path / "ds",
        {"resonance": {"family": "frame", "f_hz": f_true, "zeta": 0.02, "rms": 1e-5}},
        seed=101,
        settings=RigSettings(n_runs=4, duration=8.0, nominal_cogging=False),
    )
    d = diagnose(read_dataset(folder))
    assert d.verdict.verdict == "unexplained", d.verdict.reasons
    peaks = [p for p in d.noise.peaks if p.channel == "vertical" and p.kind == "resonance"]
    assert peaks and abs(peaks[0].freq_hz / f_true - 1) < 0.05
    assert 0.005 < peaks[0].damping < 0.08
    un = [u for u in d.noise.unexplained if u["kind"] == "resonance"]
    assert un and un[0]["channel"] == "vertical" and len(un[0]["g_range_m"]) == 2
    assert any("resonance" in r for r in d.verdict.reasons)
    # The noise model's acceleration noise is the rig's (0.05 N force noise / Mv plus current noise),
    # not the mode's 0.3 m/s^2, and its floor stays at or below the data's.
    nc = d.noise.checks["vertical"]
    assert nc.model.to_dict()["accel_noise_m_s2"] < 0.06
    assert nc.floor < 1.05 * d.floors["vertical"].floor
    out = write_report(d, tmp_path / "rep")
    doc = json.loads((out / "report.json").read_text())
    assert doc["unexplained"] and doc["noise_model"]["confirmed_peaks"]
    assert (out / "spectra.png").stat().st_size > 10_000
    assert load_plant_config(out / "model.yaml").enabled_effects() == ()
    from maglev_ocp.controllers.model_file import load_controller_model

    # the one model file a controller loads (controller: {model: model.yaml}) carries the refit constants
    assert load_controller_model(out / "model.yaml").params.C2 == pytest.approx(d.baseline_params.C2)
    # the report and the file's header give the same instruction, and no other (no model_params.yaml)
    from maglev_ocp.params import model_file_instruction

    said = model_file_instruction("model.yaml")
    assert said in (out / "model.yaml").read_text() and said in (out / "report.md").read_text()
    assert "controller_params" not in (out / "report.md").read_text()
    assert not (out / "model_params.yaml").exists()


def test_a_large_lag_matters_in_closed_loop():
    """A whole-sample delay behind a 200 Hz lag adds far more than a tenth of the goal: it matters."""
    spec = library_specs()["amplifier_lag"]
    fit = FitResult(
        spec, np.zeros(0), np.zeros(0), 0.0, 1, 1.0,
        {"bandwidth_hz": 200.0, "delay_samples": 1, "effective_delay_s": 1.8e-3},
    )  # fmt: skip
    run, u = _sweep_run(0.018)
    s = effect_size("amplifier_lag", spec, fit, [run], [u], NOMINAL.without_cogging().vector())
    assert s.delay_us == pytest.approx(1800.0)
    assert s.matters is True, s.summary
    assert max(v["added_max_m"] for v in s.closed_loop.values()) > 1e-4


def test_the_verdict_drops_a_lag_that_absorbs_a_resonance():
    """A lag verdict flagged by the guard becomes ``unexplained``; in a pair only the lag is dropped."""
    from types import SimpleNamespace

    from maglev_ocp.diagnosis.peaks import ResonanceGuard
    from maglev_ocp.diagnosis.stages.guards import apply_resonance_guard
    from maglev_ocp.diagnosis.stages.models import Attribution as _Attribution
    from maglev_ocp.diagnosis.verdict import Verdict

    lib = library_specs()
    base = SimpleNamespace(spec=CandidateSpec("baseline"), floors={"vertical": "floor"})
    flagged = {"amplifier_lag": ResonanceGuard("amplifier_lag", True, 0.95, 0.1, [35.0])}
    fits = {"amplifier_lag": "fit-lag", "cogging": "fit-cog"}
    att = _Attribution(lib, fits, [], Verdict("amplifier_lag", ["amplifier_lag"], True, []), None)
    att.final_spec, att.final_fit = lib["amplifier_lag"], "fit-lag"
    got = apply_resonance_guard(base, att, flagged)
    assert got.verdict.verdict == "unexplained" and got.final_fit is None
    assert att.verdict.verdict == "amplifier_lag" and att.final_fit == "fit-lag"  # a new record; the old one stays
    att = got
    assert any("cannot explain a narrow resonance" in r for r in att.verdict.reasons)
    att = _Attribution(lib, fits, [], Verdict("cogging+amplifier_lag", ["cogging", "amplifier_lag"], True, []), None)
    att = apply_resonance_guard(base, att, flagged)
    assert att.verdict.verdict == "cogging" and att.final_fit == "fit-cog"
    ok = {"amplifier_lag": ResonanceGuard("amplifier_lag", False, 0.1, 0.95, [35.0])}
    att = _Attribution(lib, fits, [], Verdict("amplifier_lag", ["amplifier_lag"], True, []), None)
    assert apply_resonance_guard(base, att, ok) is att and att.verdict.verdict == "amplifier_lag"


def _coverage_case(per_channel: dict[str, tuple[float, float]], verdict: str = "commutation_offset"):
    """An attribution whose final model leaves ``(before, after)`` times a unit noise floor per channel."""
    from types import SimpleNamespace

    from maglev_ocp.diagnosis.result import NoiseFindings
    from maglev_ocp.diagnosis.stages.models import Attribution as _Attribution
    from maglev_ocp.diagnosis.verdict import Verdict

    lib = library_specs()
    base = SimpleNamespace(spec=CandidateSpec("baseline"), floors={"vertical": "floor"})
    score_ = SimpleNamespace(name=verdict, per_channel={ch: list(ba) for ch, ba in per_channel.items()}, selected=True)
    att = _Attribution(lib, {verdict: "fit"}, [score_], Verdict(verdict, [verdict], True, []), score_)
    att.final_spec, att.final_fit, att.final_score = lib[verdict], "fit", score_
    noise = NoiseFindings({ch: SimpleNamespace(floor=1.0) for ch in per_channel}, [])
    return base, att, noise


def test_a_verdict_that_leaves_a_channels_gap_open_is_unexplained():
    """A commutation drift taking up the linear part of a cable's spring (independent rig, seed 47 #22: vertical
    gap 6.3x the floor closed to 2.8x, horizontal 39x left at 32x) explains part of the gap only: unexplained,
    with what it explained per channel. A steep law's misfit that closes two thirds of a 46x gap, and a channel
    left at 1.9x its floor, are no reason to doubt a verdict."""
    from maglev_ocp.diagnosis.settings import DiagnoseSettings
    from maglev_ocp.diagnosis.stages.guards import apply_coverage

    st = DiagnoseSettings()
    base, att, noise = _coverage_case({"vertical": (6.3, 2.8), "horizontal": (39.1, 31.9)})
    att, coverage, partial = apply_coverage(base, att, noise, st)
    assert att.verdict.verdict == "unexplained" and att.final_fit is None and att.final_score is None
    rows = {r["channel"]: r for r in partial["per_channel"]}
    assert partial["model"] == "commutation_offset" and coverage == partial["per_channel"]
    assert rows["horizontal"]["short"] and not rows["vertical"]["short"]
    assert rows["horizontal"]["closes"] == pytest.approx((39.1**2 - 31.9**2) / (39.1**2 - 1), rel=1e-9)
    assert any("does not account for the horizontal gap" in r for r in att.verdict.reasons)
    base, att, noise = _coverage_case({"vertical": (46.4, 27.1), "horizontal": (2.3, 1.9)}, "end_effect")
    att, coverage, partial = apply_coverage(base, att, noise, st)
    assert att.verdict.verdict == "end_effect" and att.final_fit == "fit"
    assert partial == {} and [r["short"] for r in coverage] == [False, False]
    # The threshold is a setting: at 1.5x the floor the 1.9x channel whose gap is 39 % closed is short.
    base, att, noise = _coverage_case({"vertical": (46.4, 27.1), "horizontal": (2.3, 1.9)}, "end_effect")
    att, _, _ = apply_coverage(base, att, noise, DiagnoseSettings(remainder_max=1.5))
    assert att.verdict.verdict == "unexplained"
