"""``maglev calibrate`` on datasets from the plant simulator with known, randomly drawn constants.

The acceptance test of issue 3 (``-m slow``) draws C1..C4, xi0 and ell at
random (±5 %, seeded), simulates the seed's full set of experiments with
process, current and encoder noise and 10 um quantization, and checks what
``calibrate`` recovers. The fast tests run the same pipeline on a smaller
design.
"""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from maglev_ocp.cli import main
from maglev_ocp.estimation.calibrate import calibrate
from maglev_ocp.estimation.procedures import COGGING_LAW_BOUNDS, _fit_cogging_law
from maglev_ocp.loop.experiments import (
    FreeDesign,
    HoverDesign,
    ParabolaDesign,
    SeedCalibrationDesign,
    generate_seed_calibration,
)
from maglev_ocp.params import NOMINAL, Params, load_params
from maglev_ocp.riglog import read_dataset, write_dataset

NAMES = ("C1", "C2", "C3", "C4", "xi0", "ell")


def draw_true(seed: int) -> Params:
    """Constants drawn uniformly within ±5 % of the nominal ones."""
    f = 1.0 + 0.05 * np.random.default_rng(seed).uniform(-1.0, 1.0, len(NAMES))
    return NOMINAL.scaled(dict(zip(NAMES, f, strict=True)))


def plant_config():
    """Default rig noise and quantization; the draws are the only parameter error; no extra effects."""
    from maglev_ocp.plant import PlantConfig

    return PlantConfig.from_profile(
        "default",
        overrides={
            "mismatch": {"relative": {n: 0.0 for n in ("C1", "C2", "C3", "C4")}},
            "effects": {"friction": {"enabled": False}, "amplifier_lag": {"enabled": False}},
        },
    )


SMALL = SeedCalibrationDesign(
    hover=HoverDesign(gaps_mm=[11.0, 14.0, 17.0, 20.0, 23.0], duration_s=1.3, quiet_s=0.3),
    parabola=ParabolaDesign(gaps_mm=[12.5, 20.0, 27.5]),
    free=FreeDesign(runs=1, duration_s=7.0),
)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small seed-calibration dataset with random constants, and its calibration."""
    true = draw_true(7)
    folder = generate_seed_calibration(
        tmp_path_factory.mktemp("ds") / "small",
        seed=11,
        plant_config=plant_config(),
        params=true,
        design=SMALL,
        progress=False,
    )
    res = calibrate(folder, progress=False)
    return true, folder, res


def test_small_dataset_runs_every_procedure_and_recovers_the_constants(small):
    true, _, res = small
    assert res.va is not None and res.vb is not None and res.vc is not None and res.vd is not None
    assert not res.skipped
    for n in ("C1", "C2", "C3"):
        assert abs(getattr(res.params, n) / getattr(true, n) - 1) < 0.01, n
        assert res.source[n] == "batch"
    for n in ("xi0", "ell"):
        assert abs(getattr(res.params, n) / getattr(true, n) - 1) < 0.15, n
    # every fitted value within 4 of its own standard errors (a small dataset: a loose but real check)
    for n in NAMES:
        se = res.stderr[n]
        assert se is not None and se > 0
        assert abs(getattr(res.params, n) - getattr(true, n)) < 4 * se + 1e-3 * getattr(true, n), n


def test_equilibrium_currents_match_eq8_with_the_V_B_estimates(small):
    _, _, res = small
    # Fig. 5: measured equilibrium i_d against eq. (8) with the eps = 0.01 estimates, within 20 mA
    diffs = [abs(q["i_d"] - q["i_d_theory"]) for q in res.vb.equilibrium]
    assert len(diffs) == 5 and max(diffs) < 0.02


def test_cogging_peak_force_falls_with_the_gap(small):
    true, _, res = small
    xi = [q["xi"] for q in res.vc.per_gap]
    assert len(xi) == 5
    assert all(a > b for a, b in itertools.pairwise(xi))  # stronger at small gaps (seed Fig. 6)
    g = np.array([q["g"] for q in res.vc.per_gap])
    truth = true.xi0 * np.exp(-(g - 0.010) / true.ell)
    np.testing.assert_allclose(xi, truth, rtol=0.25, atol=0.05)


def test_outputs_are_written_and_readable(small, tmp_path):
    _, _, res = small
    written = res.save(tmp_path / "cal")
    p = load_params(tmp_path / "cal" / "model.yaml")
    for n in NAMES:
        assert getattr(p, n) == pytest.approx(getattr(res.params, n), rel=1e-12)
    data = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert set(NAMES) <= set(data["params"]) and set(NAMES) <= set(data["stderr"])
    assert set(data["procedures"]) == {"V.A", "V.B", "V.C", "V.D"}
    assert all(data["procedures"][k]["ran"] for k in data["procedures"])
    assert data["correlation"]["names"] == list(NAMES)
    pngs = {q.name for q in written if q.suffix == ".png"}
    assert {
        "fig4_L1_fixed_gaps.png",
        "fig5_equilibrium_d0.png",
        "fig6_cogging_peak.png",
        "fig8_L1_full_span.png",
        "fig9_equilibrium_full_span.png",
    } <= pngs
    assert (tmp_path / "cal" / "tables" / "table_II.csv").read_text().count("\n") == 4
    assert "| C4 |" in res.table()


def test_only_free_runs_skip_the_locked_procedures(small, tmp_path):
    _, folder, _ = small
    ds = read_dataset(folder)
    free = [r for r in ds.runs if not r.locked]
    write_dataset(tmp_path / "free_only", free, ds.sample_time, ds.encoder_resolution)
    res = calibrate(tmp_path / "free_only", progress=False)
    assert res.va is None and res.vb is None and res.vc is None and res.vd is not None
    assert set(res.skipped) == {"V.A", "V.B", "V.C"}
    assert "C1" in res.batch.names


def test_cli_calibrate_and_its_errors(small, tmp_path, capsys):
    _, folder, _ = small
    assert (
        main(["calibrate", str(folder), "--out", str(tmp_path / "o"), "--no-figures", "--no-progress", "--eps", "0.01"])
        == 0
    )
    out = capsys.readouterr().out
    assert "| C1 |" in out and "calibration took" in out
    assert (tmp_path / "o" / "model.yaml").is_file()
    assert main(["calibrate", str(tmp_path / "nope"), "--out", str(tmp_path / "x")]) == 2
    assert "no such folder" in capsys.readouterr().err
    assert main(["calibrate", str(folder), "--out", str(tmp_path / "x"), "--eps", "0.05"]) == 2
    assert "0.01" in capsys.readouterr().err
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "dataset.yaml").write_text("format: maglev-rig-log/1\nsample_time: 0.001\n")
    assert main(["calibrate", str(tmp_path / "bad"), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "dataset.yaml" in err and len(err.strip().splitlines()) == 1


def test_clean_dataset_calibrates_without_warnings(small):
    _, _, res = small
    assert res.converged and res.warnings == []
    assert res.to_dict()["warnings"] == [] and "WARNING" not in res.table()


def test_cogging_law_recovers_the_law_and_flags_data_that_do_not_follow_it():
    """Seed V.C law fit: exact on the law; a start outside the bounds (forces that hardly decay) is clipped."""
    g = np.linspace(0.010, 0.025, 8)
    xi0, ell, warn = _fit_cogging_law(g, 4.0 * np.exp(-(g - 0.010) / 3.6e-3), np.ones_like(g))
    assert xi0 == pytest.approx(4.0, rel=1e-6) and ell == pytest.approx(3.6e-3, rel=1e-6) and warn == ""
    # forces nearly flat in the gap (e.g. guide friction in the hover runs): the log-linear start has
    # ell = 0.5 m, outside the bounds (scipy raised "Initial guess is outside of provided bounds")
    xi0, ell, warn = _fit_cogging_law(g, 2.0 * np.exp(-(g - 0.010) / 0.5), np.ones_like(g))
    lo, hi = COGGING_LAW_BOUNDS
    assert lo[1] <= ell <= hi[1] and ell == pytest.approx(hi[1], rel=1e-3)
    assert "ell" in warn and "bound" in warn
    # nothing positive to fit: NaN and the reason
    xi0, ell, warn = _fit_cogging_law(g, -np.ones_like(g), np.ones_like(g))
    assert math.isnan(xi0) and math.isnan(ell) and "do not determine" in warn


@pytest.mark.slow
def test_acceptance_full_seed_calibration_with_random_constants(tmp_path):
    """Issue 3 acceptance: C1..C3 within 1 %, xi0 and ell within 10 %, C4 within two of its standard errors."""
    true = draw_true(2024)
    folder = generate_seed_calibration(
        tmp_path / "seed_cal", seed=5, plant_config=plant_config(), params=true, progress=False
    )
    res = calibrate(folder, progress=False)
    res.save(tmp_path / "out")
    for n in ("C1", "C2", "C3"):
        assert abs(getattr(res.params, n) / getattr(true, n) - 1) < 0.01, n
    for n in ("xi0", "ell"):
        assert abs(getattr(res.params, n) / getattr(true, n) - 1) < 0.10, n
    assert abs(res.params.C4 - true.C4) < 2 * res.stderr["C4"]
    assert res.batch.rel_stderr("C4") == max(res.batch.rel_stderr(n) for n in res.batch.names)  # the weakest
    assert res.trust_problems() == []  # the seed's full design identifies every constant: nothing refused

    # NPFISI "converges" (V.B, eps = 0.01): Sigma stays positive definite, C2 and C3 move by less than
    # 0.5 % over the last 20 % of the data and end within 1 % of the truth.
    vb = res.vb.npfisi[0.01]
    assert vb.sigma_positive
    assert vb.converged(tol=0.005, names=("C2", "C3"))
    for n in ("C2", "C3"):
        assert abs(vb.final[n] / getattr(true, n) - 1) < 0.01
    # ... and worse as eps grows (seed V.A, Fig. 4): mean error of L1 over the locked gaps
    err = {
        e: np.mean([abs(r["L1_npfisi"][e] / (true.C1 * r["L1_model"] / NOMINAL.C1) - 1) for r in res.va.rows])
        for e in (0.001, 0.01, 0.05)
    }
    assert err[0.001] < err[0.01] < err[0.05]


def test_the_small_seed_design_identifies_every_constant(small):
    """The seed's procedures, even on the small design, pin every constant down: nothing to refuse."""
    _, _, res = small
    assert res.trust_problems() == []
    assert json.loads(json.dumps(res.to_dict()["trusted"])) is True


@pytest.fixture(scope="module")
def short_hover(tmp_path_factory):
    """The issue's case: one 2 s hover at 20 mm, d = 0 (no excitation: C1..C4, xi0, ell are not separable)."""
    folder = tmp_path_factory.mktemp("hover") / "hover"
    argv = ["simulate", "--experiment", "hover", "--duration", "2", "--out", str(folder), "--quiet"]
    assert main(argv) == 0
    return folder


def test_calibrate_refuses_a_short_hover_in_one_line_and_writes_nothing(short_hover, tmp_path, capsys):
    out = tmp_path / "cal"
    assert main(["calibrate", str(short_hover), "--out", str(out), "--quiet", "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "cannot identify the constants" in err and "relative standard error" in err and "--force" in err
    assert not out.exists()


def test_calibrate_force_writes_a_model_file_marked_untrusted_and_loaders_warn(short_hover, tmp_path, capsys):
    from maglev_ocp.controllers.model_file import load_controller_model
    from maglev_ocp.params import UntrustedModelWarning

    out = tmp_path / "cal"
    assert main(["calibrate", str(short_hover), "--out", str(out), "--quiet", "--no-figures", "--force"]) == 0
    stdout = capsys.readouterr().out
    assert "UNTRUSTED" in stdout and "controller: {model:" in stdout
    text = (out / "model.yaml").read_text()
    assert "trusted: false" in text and "controller: {model: model.yaml}" in text
    assert json.loads((out / "calibration.json").read_text())["trusted"] is False
    with pytest.warns(UntrustedModelWarning, match="untrusted"):
        load_controller_model(out / "model.yaml")
    with pytest.warns(UntrustedModelWarning):
        load_params(out / "model.yaml")


def test_a_run_with_an_untrusted_model_file_is_refused_unless_asked_then_flagged(short_hover, tmp_path, capsys):
    """A controller refuses an untrusted file by default (one line, exit 2, nothing written); with
    ``untrusted_model: use`` the warning on load is said once and the run's metrics.json and summary
    carry the flag themselves."""
    cal = tmp_path / "cal"
    assert main(["calibrate", str(short_hover), "--out", str(cal), "--quiet", "--no-figures", "--force"]) == 0
    scenario = tmp_path / "hold.yaml"
    text = (
        "name: hold_untrusted\nseed: 3\ncontroller: {type: fl, model: cal/model.yaml}\n"
        "plant: {profile: default}\ntargets:\n  - {g: 0.020, d: 0.0, hold: 0.2}\n"
    )
    scenario.write_text(text)
    capsys.readouterr()
    assert main(["run", str(scenario), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "marked untrusted" in err and "untrusted_model" in err and "refuse" in err
    assert not (tmp_path / "out" / "hold_untrusted" / "metrics.json").exists()
    scenario.write_text(text.replace("model: cal/model.yaml}", "model: cal/model.yaml, untrusted_model: use}"))
    main(["run", str(scenario), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"])
    captured = capsys.readouterr()
    stdout = captured.out
    assert "marked untrusted by its writer" in captured.err  # the CLI's one-line warning on load
    metrics = json.loads((tmp_path / "out" / "hold_untrusted" / "metrics.json").read_text())
    assert "relative standard error" in metrics["model_untrusted"] or "bound" in metrics["model_untrusted"]
    assert "UNTRUSTED MODEL (hold_untrusted)" in stdout
    # without the model file the same run carries no flag
    scenario.write_text(scenario.read_text().replace(", model: cal/model.yaml, untrusted_model: use", ""))
    main(["run", str(scenario), "--out", str(tmp_path / "out2"), "--quiet", "--no-figures"])
    assert json.loads((tmp_path / "out2" / "hold_untrusted" / "metrics.json").read_text())["model_untrusted"] is None
