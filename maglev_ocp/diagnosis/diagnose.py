"""The diagnosis pipeline: baseline, residuals, localization, attribution, quantification.

:func:`diagnose` takes any ``maglev-rig-log/1`` dataset (closed- or open-loop,
any controller, locked axes allowed) and returns a :class:`Diagnosis`, whose
:meth:`~Diagnosis.save` writes ``report.json``, ``report.md`` and the figures
(:mod:`.report`).

1. **Split**: whole runs are held out for scoring (sorted by fixture and mean
   gap, every ``holdout_every``-th from the second). A dataset with fewer than
   three runs is cut into three pieces per run first.
2. **Baseline**: the nominal model *without* cogging, its C1..C4 calibrated
   by the filtered-equation-error NLP on the training runs (or ``params`` as
   given).
3. **Residuals** (:mod:`.residuals`), **floor and structure test**,
   **localization** (:mod:`.localize`).
4. **Attribution** (:mod:`.candidates`, :mod:`.attribution`): every library
   effect fitted on the training runs on top of the baseline (jointly with
   C1..C4 when the baseline was calibrated, since the calibration absorbed
   part of the effect), scored on the held-out runs; verdict; a second effect
   if a significant gap remains.
5. **Quantification**: held-out residual rms before/after, short-window
   simulated trajectories of the baseline and the augmented model against the
   held-out runs (:mod:`.simulate_compare`), fitted parameters with standard
   errors.

Stages on the noise model (:mod:`.noise`) and the consequences
(:mod:`.consequence`), each a function a verdict stage may call:

- :func:`noise_stage` (after the localization): the floor a structured residual
  cannot inflate, whiteness, spectral peaks with frequency and damping; peaks
  both halves of the data show count as evidence of a gap;
- :func:`lag_guards` and :func:`apply_resonance_guard` (after the verdict): a lag
  whose improvement lies in a narrow resonance is not counted;
- :func:`unexplained_stage` (after the quantification): what the final model
  leaves beyond the noise model, with channel, band, peak and region; a ``none``
  with a remaining resonance becomes ``unexplained``;
- :func:`consequence_stage`: force in N and % of the weight, delay in µs,
  closed-loop error of the shipped controllers with and without each effect
  (negligible or not for the 0.1 mm goal), and the model files.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ..constants import encoder_resolution
from ..errors import DataError
from ..params import NOMINAL, Params
from ..riglog import Dataset as RigDataset
from ..signals import PARAM_NAMES
from .attribution import EffectScore, Verdict, VerdictRules, decide, paired_z, rank, score
from .candidates import (
    CandidateSpec,
    Dataset,
    FitResult,
    calibration_free,
    fit_candidate,
    library_specs,
    residuals_with,
)
from .consequence import EffectSize, effect_size, plant_effects, plant_file
from .localize import (
    ChannelFloor,
    Region,
    bin_stats,
    channel_floor,
    dominant_band,
    edges_for,
    period_scan,
    pool,
    regions_from_map,
    spectrum,
)
from .noise import (
    GUARD_FLAG,
    NoiseCheck,
    ResonanceGuard,
    SpectralPeak,
    confirm_peaks,
    noise_check,
    resonance_guard,
    wide_spectrum,
)
from .residuals import CHANNELS, PreparedRun, Residual, ResidualSettings, RunInput, ZeroPhaseFilter, prepare_run
from .result import ChannelView, Consequences, DiagnoseSettings, Diagnosis, HeldOut, NoiseFindings
from .simulate_compare import TrajectoryComparison, compare_trajectories

#: The candidate library, in report order.
LIBRARY: tuple[str, ...] = tuple(library_specs())


# ------------------------------------------------------------------------ helpers
def runs_from_dataset(ds: RigDataset) -> list[RunInput]:
    """The dataset's runs as :class:`RunInput` (commanded currents, encoder readings, fixtures)."""
    out = []
    for r in ds.runs:
        t = r.t
        if len(t) > 2:
            dt = np.diff(t)
            if np.max(np.abs(dt - ds.sample_time)) > 0.05 * ds.sample_time:
                raise DataError(f"{r.file}: rows are not evenly spaced by sample_time {ds.sample_time:g} s")
        out.append(RunInput(r.file, float(ds.sample_time), r.y, r.u, tuple(r.locked), float(t[0]) if len(t) else 0.0))
    return out


def split_runs(runs: Sequence[RunInput], every: int = 3) -> tuple[list[RunInput], list[RunInput]]:
    """Hold out whole runs: sorted by fixture and mean gap, every ``every``-th from the second.

    With fewer than three runs, each run is first cut into three contiguous
    pieces (named ``<file>#1/3`` ...), so that scoring still uses data the fit
    has not seen.
    """
    runs = list(runs)
    if len(runs) < 3:
        pieces = []
        for r in runs:
            n = len(r.y)
            cuts = np.linspace(0, n, 4).astype(int)
            for j in range(3):
                a, b = cuts[j], cuts[j + 1]
                pieces.append(RunInput(f"{r.name}#{j + 1}/3", r.Ts, r.y[a:b], r.u[a:b], r.locked, r.t0 + a * r.Ts))
        runs = pieces
    order = sorted(range(len(runs)), key=lambda i: (runs[i].locked, float(np.mean(runs[i].y[:, 0]))))
    test_idx = set(order[1::every]) if len(order) > 1 else set()
    train = [runs[i] for i in range(len(runs)) if i not in test_idx]
    test = [runs[i] for i in range(len(runs)) if i in test_idx]
    return train, test


def _params_with(p: np.ndarray, fit: FitResult) -> np.ndarray:
    out = np.array(p, float)
    for key, v in zip(fit.spec.keys, fit.w, strict=True):
        if key.startswith("p."):
            out[PARAM_NAMES.index(key[2:])] = v
    return out


def _readable(fit: FitResult, pair: bool) -> tuple[dict[str, float], dict[str, float]]:
    vals, errs = {}, {}
    for key, v in fit.params().items():
        if key.endswith("_stderr"):
            continue
        name = key if pair else key.split(".", 1)[-1]
        if "phi" in key or key.endswith("_phase"):
            v = float((v + math.pi) % (2 * math.pi) - math.pi)
        vals[name] = float(v)
    se = dict(zip(fit.spec.keys, fit.stderr, strict=True))
    if "effective_delay_s_stderr" in fit.extra:
        se["effective_delay_s"] = fit.extra["effective_delay_s_stderr"]
    for key, s in se.items():
        name = key if pair else key.split(".", 1)[-1]
        errs[name] = float(s) if np.isfinite(s) else None
    return vals, errs


def combine(a: CandidateSpec, b: CandidateSpec) -> CandidateSpec:
    """Two candidates composed on the model at once (shared model parameters appear once)."""
    keys = set()
    free = []
    for f in (*a.free, *b.free):
        if f.key not in keys:
            keys.add(f.key)
            free.append(f)
    return CandidateSpec(
        f"{a.name}+{b.name}",
        tuple(dict.fromkeys((*a.effects, *b.effects))),
        tuple(free),
        a.fixed + b.fixed,
        a.ties + b.ties,
        a.lag or b.lag,
        f"{a.note}; {b.note}",
    )


def _views(
    res: Sequence[Residual],
    floors: np.ndarray,
    infl: np.ndarray,
    fs: float,
    fmax: float,
    rng: np.random.Generator,
    n_null: int = 12,
) -> dict[str, ChannelView]:
    out = {}
    for c, ch in enumerate(CHANNELS):
        s = pool(res, c)
        if s.n < 50:
            continue
        eg, ed = edges_for(s.feat["g"], 10), edges_for(s.feat["d"], 10)
        mp = bin_stats(s, ("g", "d"), (eg, ed), floors[c], infl[c])
        bins = {
            n: bin_stats(s, (n,), (edges_for(s.feat[n], 16),), floors[c], infl[c])
            for n in ("g", "d", "g_dot", "d_dot", "i_q", "i_d", "di_q", "di_d")
        }
        sp = spectrum(res, c, fs, fmax)
        ps = period_scan(s, rng, n_null=n_null)
        out[ch] = ChannelView(mp, bins, sp, ps, dominant_band(sp) if sp is not None else None)
    return out


def _regions(views: dict[str, ChannelView], floors: dict[str, ChannelFloor]) -> list[Region]:
    """Regions per channel: significant gap x position bins; else, for a gap the bins cannot show (a
    spectral line, a period finer than the bins, a dependence on velocity or current rate), the visited
    range with the band, the period and the excess."""
    out: list[Region] = []
    for ch, v in views.items():
        band = v.spectrum.peaks[0]["band_hz"] if v.spectrum is not None and v.spectrum.peaks else v.band
        fl = floors.get(ch)
        sigma = fl.floor if fl is not None and fl.floor > 0 else 1.0
        period = v.period.best_period if v.period is not None and v.period.significant else None
        regs = regions_from_map(v.map_gd, ch, band, sigma)
        for r in regs:
            r.period_m = period
        eg, ed = v.map_gd.edges
        whole = ([float(eg[0]), float(eg[-1])], [float(ed[0]), float(ed[-1])])
        if not regs and v.spectrum is not None and v.spectrum.peaks:
            pk = v.spectrum.peaks[0]
            amp = math.sqrt(max(pk["power_m2_s4"], 0.0))
            regs = [Region(ch, *whole, pk["band_hz"], float(amp / sigma), amp, 0, float(pk["ratio"]), period)]
        if not regs and ((fl is not None and fl.significant) or period is not None):
            exc = fl.excess if fl is not None else 0.0
            regs = [Region(ch, *whole, v.band, float(exc / sigma), exc, 0, float(fl.z) if fl else math.nan, period)]
        out += regs
    return out


# ------------------------------------------------------------------------ pipeline
@dataclass
class _Split:
    """Stage 1: the runs split and filtered (training and held-out)."""

    filt: ZeroPhaseFilter
    train_in: list[RunInput]
    test_in: list[RunInput]
    train: list[PreparedRun]
    test: list[PreparedRun]
    has: tuple[bool, bool]  # the training runs carry a vertical / horizontal channel

    @property
    def u_train(self) -> list[np.ndarray]:
        """Commanded currents of the training runs."""
        return [r.u for r in self.train_in]

    @property
    def u_test(self) -> list[np.ndarray]:
        """Commanded currents of the held-out runs."""
        return [r.u for r in self.test_in]


@dataclass
class _Baseline:
    """Stage 2: the baseline model, its residuals and the noise floors."""

    spec: CandidateSpec
    given: bool
    p: np.ndarray
    params: Params
    stderr: dict[str, float]
    cal_free: tuple
    fit: FitResult
    b_train: list[Residual]
    b_test: list[Residual]
    floors: dict[str, ChannelFloor]
    fvec: np.ndarray
    data_train: Dataset
    q_floor: float
    noise_lag: int

    def floors_of(self, spec: CandidateSpec, fit: FitResult | None, split: _Split) -> dict[str, ChannelFloor]:
        """Channel floors of the residuals of a fitted candidate (training and held-out runs)."""
        a_train = residuals_with(spec, fit, split.train, self.p, split.u_train)
        a_test = residuals_with(spec, fit, split.test, self.p, split.u_test)
        return {
            CHANNELS[c]: fl
            for c in range(2)
            if (fl := channel_floor(a_train, a_test, c, self.q_floor, max_lag=self.noise_lag)) is not None
        }


@dataclass
class _Localization:
    """Stage 3: where the baseline misses, and whether there is a gap at all."""

    views: dict[str, ChannelView]
    evidence: list[str]
    infl: np.ndarray
    fs: float

    @property
    def gap_detected(self) -> bool:
        """Any evidence of a gap beyond the floor."""
        return bool(self.evidence)


@dataclass
class _Attribution:
    """Stages 4 and 5: candidates, verdict, the final model and what it leaves."""

    specs: dict[str, CandidateSpec]
    fits: dict[str, FitResult]
    scores: list[EffectScore]
    verdict: Verdict
    best: EffectScore | None
    final_spec: CandidateSpec | None = None
    final_fit: FitResult | None = None
    remaining: dict[str, ChannelFloor] = field(default_factory=dict)


def _split(dataset: RigDataset, st: DiagnoseSettings) -> _Split:
    """Stage 1: hold out whole runs, filter every run; refuse runs too short for the filter."""
    runs = runs_from_dataset(dataset)
    Ts = float(dataset.sample_time)
    filt = ZeroPhaseFilter(ResidualSettings(st.fc_hz, st.numtaps | 1, st.decimate), Ts)
    train_in, test_in = split_runs(runs, st.holdout_every)
    train = [(ri, pr) for ri in train_in if (pr := prepare_run(ri, filt)).n > 0]
    test = [(ri, pr) for ri in test_in if (pr := prepare_run(ri, filt)).n > 0]
    if not train or not test:
        raise DataError(
            f"{dataset.folder or 'dataset'}: runs are too short for the residual filter "
            f"({st.numtaps} taps at {Ts:g} s); need at least {3 * st.numtaps} samples per run"
        )
    tr = [b for _, b in train]
    has = (any(r.valid[0] for r in tr), any(r.valid[1] for r in tr))
    return _Split(filt, [a for a, _ in train], [a for a, _ in test], tr, [b for _, b in test], has)


def _baseline(split: _Split, params: Params | None, st: DiagnoseSettings, warnings: list[str]) -> _Baseline:
    """Stage 2: the baseline (C1..C4 calibrated on the training runs unless ``params`` is given), noise floors."""
    filt, train, test = split.filt, split.train, split.test
    given = params is not None
    base = params if given else NOMINAL.without_cogging()
    p0 = base.vector()
    base_spec = CandidateSpec("baseline")
    cal_free = calibration_free(base, *split.has) if not given else ()
    if cal_free:
        r0 = residuals_with(base_spec, None, train, p0)
        w0 = np.array([1.0 / max(_rms_channel(r0, c), 1e-6) for c in range(2)])
        cal_spec = CandidateSpec("baseline", free=cal_free, note="C1..C4 calibrated on the training runs")
        fit0 = fit_candidate(cal_spec, Dataset(train, w0, filt), p0)
        _check_fit(fit0, "baseline calibration (first pass)", warnings)
        p_base = _params_with(p0, fit0)
    else:
        p_base = p0
    base_params = Params.from_vector(p_base)
    b_train = residuals_with(base_spec, None, train, p_base)
    b_test = residuals_with(base_spec, None, test, p_base)
    q_floor = filt.quantization_floor()
    # The residual's noise is correlated over the filter's main lobe: 2 fs / fc decimated samples.
    noise_lag = max(4, math.ceil(2.0 / (st.fc_hz * filt.Ts * st.decimate)))
    floors: dict[str, ChannelFloor] = {}
    for c in range(2):
        fl = channel_floor(b_train, b_test, c, q_floor, max_lag=noise_lag)
        if fl is not None:
            floors[CHANNELS[c]] = fl
    fvec = np.array([floors[ch].floor if ch in floors else 1.0 for ch in CHANNELS])
    fvec = np.maximum(fvec, 1e-9)
    data_train = Dataset(train, 1.0 / fvec, filt)
    base_stderr: dict[str, float] = {}
    if cal_free:
        cal_free2 = calibration_free(base_params, *split.has)
        base_fit = fit_candidate(CandidateSpec("baseline", free=cal_free2), data_train, p_base)
        _check_fit(base_fit, "baseline calibration", warnings)
        base_stderr = {k_.split(".", 1)[1]: float(s) for k_, s in zip(base_fit.spec.keys, base_fit.stderr, strict=True)}
    else:
        cal_free2 = ()
        base_fit = fit_candidate(base_spec, data_train, p_base)
    return _Baseline(
        base_spec, given, p_base, base_params, base_stderr, cal_free2, base_fit, b_train, b_test, floors, fvec,
        data_train, q_floor, noise_lag,
    )  # fmt: skip


def _localize(split: _Split, base: _Baseline, st: DiagnoseSettings, rng: np.random.Generator) -> _Localization:
    """Stage 3: the baseline residual over the state, its spectrum and period scan; the evidence of a gap."""
    fs = 1.0 / (split.filt.Ts * st.decimate)
    infl = np.array([base.floors[ch].inflation if ch in base.floors else 1.0 for ch in CHANNELS])
    views = _views(base.b_train + base.b_test, base.fvec, infl, fs, st.fc_hz, rng, st.n_null)
    evidence = []
    for ch, fl in base.floors.items():
        if fl.significant:
            evidence.append(
                f"{ch}: the residual has state structure beyond the floor (held-out map gain "
                f"{fl.gain:.1%}, z = {fl.z:.1f})"
            )
    for c, ch in enumerate(CHANNELS):
        # A spectral line counts as a gap only if the training and the held-out runs both show it.
        lines = _consistent_lines(base.b_train, base.b_test, c, fs, st.fc_hz)
        if lines:
            pk = lines[0]
            evidence.append(
                f"{ch}: spectral line at {pk['peak_hz']:.2f} Hz ({pk['ratio']:.0f}x the PSD around it, "
                "in training and held-out runs)"
            )
    for ch, v in views.items():
        if v.period is not None and v.period.significant:
            evidence.append(
                f"{ch}: periodic in d with period {v.period.best_period * 1e3:.2f} mm"
                + (f" (= {v.period.match})" if v.period.match else "")
            )
    return _Localization(views, evidence, infl, fs)


def _fit_and_score(
    name: str, spec: CandidateSpec, split: _Split, base: _Baseline, rules: VerdictRules, note: str, pair: bool
) -> tuple[FitResult, EffectScore]:
    """Fit one candidate (or pair) on the training runs and score it on the held-out runs."""
    fit = fit_candidate(spec, base.data_train, base.p, u_runs=split.u_train)
    after = residuals_with(spec, fit, split.test, base.p, split.u_test)
    vals, errs = _readable(fit, pair=pair)
    return fit, score(name, fit, base.fit, base.b_test, after, base.fvec, rules, vals, errs, note)


def _attribute(
    split: _Split, base: _Baseline, loc: _Localization, st: DiagnoseSettings, progress: bool, warnings: list[str]
) -> _Attribution:
    """Stage 4: every library effect fitted on top of the baseline, scored on the held-out runs; verdict."""
    rules = st.rules()
    lib = library_specs()
    names = [n for n in (st.candidates or LIBRARY) if n in lib]
    if not base.given:
        names = [n for n in names if n != "parameter_error"]
    specs: dict[str, CandidateSpec] = {}
    fits: dict[str, FitResult] = {}
    scores: list[EffectScore] = []
    for name in tqdm(names, desc="candidates", disable=not progress, leave=False):
        spec = lib[name].with_free(base.cal_free) if base.cal_free else lib[name]
        fit, sc = _fit_and_score(name, spec, split, base, rules, lib[name].note, pair=False)
        _check_fit(fit, f"candidate {name}", warnings)
        specs[name], fits[name] = spec, fit
        scores.append(sc)
    verdict, best = decide(scores, loc.gap_detected, rules, loc.evidence)
    return _Attribution(specs, fits, scores, verdict, best)


def _second_effect(
    split: _Split, base: _Baseline, att: _Attribution, st: DiagnoseSettings, warnings: list[str]
) -> None:
    """Stage 4b: if a significant gap remains after the best effect, try it with each other significant one."""
    rules = st.rules()
    best = att.best
    att.final_spec, att.final_fit = base.spec, None
    if best is None:
        return
    att.final_spec, att.final_fit = att.specs[best.name], att.fits[best.name]
    att.remaining = base.floors_of(att.final_spec, att.final_fit, split)
    still = any(f.significant for f in att.remaining.values())
    if still and best.closes < 0.9:
        others = [
            s for s in rank(att.scores) if s.significant and s.name != best.name and s.name not in best.confusable_with
        ][:3]
        pair_scores = []
        for o in others:
            spec = combine(att.specs[best.name], att.specs[o.name])
            fit, ps = _fit_and_score(spec.name, spec, split, base, rules, spec.note, pair=True)
            _check_fit(fit, f"candidate pair {spec.name}", warnings)
            Ra_best2, Ra_pair2 = best.r2_after, ps.r2_after
            extra = (Ra_best2 - Ra_pair2) / max(Ra_best2 - 1.0, Ra_best2 - Ra_pair2, 1e-12)
            zp = paired_z(best.e_after, ps.e_after)
            pair_scores.append((extra, zp, ps, spec, fit))
            att.scores.append(ps)
        good = [t for t in pair_scores if t[1] >= rules.z_min and t[0] >= rules.second_min and t[2].fit.success]
        if good:
            extra, zp, ps, spec, fit = max(good, key=lambda t: t[0])
            if att.verdict.verdict != "unexplained" or ps.closes >= rules.closes_min:
                att.verdict = Verdict(
                    ps.name,
                    ps.name.split("+"),
                    True,
                    [
                        *att.verdict.reasons,
                        f"a significant gap remained; adding {ps.name.split('+')[1]} closes {extra:.0%} of it "
                        f"(paired z = {zp:.1f}): {ps.name}",
                    ],
                )
                ps.selected = True
                att.final_spec, att.final_fit = spec, fit
                att.remaining = base.floors_of(spec, fit, split)
    if att.verdict.verdict == "unexplained":
        att.verdict.reasons.append(
            f"no candidate, alone or with a second one, closes {rules.closes_min:.0%} of the gap: unexplained"
        )


def _settle_verdict(base: _Baseline, att: _Attribution) -> None:
    """No effect claimed: the final model is the baseline and its gap remains; mark the selected scores."""
    verdict = att.verdict
    if verdict.verdict in ("none", "unexplained"):
        att.final_spec, att.final_fit = base.spec, None
        att.remaining = base.floors
    in_verdict = set(verdict.verdict.replace("|", "+").split("+"))
    for s in att.scores:
        s.selected = verdict.verdict not in ("none", "unexplained") and (
            s.name in in_verdict or s.name == verdict.verdict
        )


@dataclass
class _Quantification:
    """Stage 5: the final model's residuals and views, regions, simulated trajectories."""

    residuals_after: list[Residual]
    views_after: dict[str, ChannelView]
    regions: list[Region]
    remaining_regions: list[Region]
    trajectories: TrajectoryComparison | None


def _quantify(
    split: _Split,
    base: _Baseline,
    loc: _Localization,
    att: _Attribution,
    st: DiagnoseSettings,
    rng: np.random.Generator,
) -> _Quantification:
    """Stage 5: residuals of the final model, remaining regions, short-window simulations on held-out runs."""
    spec, fit = att.final_spec, att.final_fit
    all_after = residuals_with(spec, fit, split.train, base.p, split.u_train) + residuals_with(
        spec, fit, split.test, base.p, split.u_test
    )
    views_after = _views(all_after, base.fvec, loc.infl, loc.fs, st.fc_hz, rng, st.n_null)
    regions = _regions(loc.views, base.floors) if loc.gap_detected else []
    rem = att.remaining
    remaining_regions = _regions(views_after, rem) if any(f.significant for f in rem.values()) else []
    if att.verdict.verdict == "unexplained":
        # Where the unexplained gap is (the baseline's: no candidate closes it).
        regions_unexpl = remaining_regions or regions
        if regions_unexpl:
            att.verdict.reasons.append(
                "unexplained gap: "
                + "; ".join(
                    f"{r.channel} g {r.g_range_m[0] * 1e3:.1f}..{r.g_range_m[1] * 1e3:.1f} mm, d "
                    f"{r.d_range_m[0] * 1e3:.0f}..{r.d_range_m[1] * 1e3:.0f} mm"
                    + (f", {r.freq_band_hz[0]:.2f}..{r.freq_band_hz[1]:.2f} Hz" if r.freq_band_hz else "")
                    for r in regions_unexpl[:3]
                )
            )
    traj = None
    if st.simulate:
        models = {"baseline": (base.spec, None)}
        pvecs = {"baseline": base.p}
        if fit is not None:
            models["augmented"] = (spec, fit)
            pvecs["augmented"] = base.p
        traj = compare_trajectories(split.test_in, models, pvecs, horizon=st.horizon_s)
    return _Quantification(all_after, views_after, regions, remaining_regions, traj)


# ------------------------------------------------------------ noise-model stages
def noise_stage(
    split: _Split, base: _Baseline, loc: _Localization, q: float, seed: int = 0, excess_min: float = 1.5
) -> NoiseFindings:
    """Stage 3b: noise-model floors, whiteness and spectral peaks of the baseline residual (:mod:`.noise`).

    Adds to the localization's evidence of a gap what the data-based floor
    hides: peaks (resonances, lines) beyond the noise model that the training
    and the held-out runs both show, and a filtered residual above
    ``excess_min`` times the noise-model floor that is not white.
    """
    allr = base.b_train + base.b_test
    checks: dict[str, NoiseCheck] = {}
    peaks: list[SpectralPeak] = []
    for c, ch in enumerate(CHANNELS):
        nc = noise_check(allr, c, split.filt.w_y, split.filt.w_a, q, split.filt.Ts, seed)
        if nc is None:
            continue
        checks[ch] = nc
        conf = confirm_peaks(nc.peaks, [base.b_train, base.b_test], nc.model, c)
        peaks += conf
        for pk in conf:
            loc.evidence.append(f"{ch}: spectral {pk.describe()}; beyond the noise model in training and held-out runs")
        if nc.excess_ratio > excess_min and not nc.whiteness.white:
            loc.evidence.append(
                f"{ch}: filtered residual rms {nc.rms:.3g} m/s^2 is {nc.excess_ratio:.1f}x the noise-model floor "
                f"{nc.floor:.3g} m/s^2 and not white (flatness {nc.whiteness.flatness:.2f} < "
                f"{nc.whiteness.flatness_null:.2f})"
            )
    return NoiseFindings(checks, peaks)


def lag_guards(split: _Split, base: _Baseline, att: _Attribution, noise: NoiseFindings) -> dict[str, ResonanceGuard]:
    """Resonance guard of every lag-type candidate on the held-out runs (see :func:`.noise.resonance_guard`)."""
    out = {}
    for name, spec in att.specs.items():
        if not spec.lag or name not in att.fits:
            continue
        after = residuals_with(spec, att.fits[name], split.test, base.p, split.u_test)
        out[name] = resonance_guard(name, base.b_test, after, noise.peaks, split.filt.h, split.filt.Ts)
    return out


def apply_resonance_guard(base: _Baseline, att: _Attribution, guards: dict[str, ResonanceGuard]) -> None:
    """A lag never absorbs a resonance: drop a flagged lag from the verdict (alone, the verdict is ``unexplained``).

    The verdict stage may call :func:`lag_guards` itself and read each guard's
    :data:`~.noise.GUARD_FLAG`; this stage enforces it on whatever verdict it gets.
    """
    v = att.verdict
    if v.verdict in ("none", "unexplained"):
        return
    sep = "|" if "|" in v.verdict else "+"
    names = v.verdict.split(sep)
    bad = [n for n in names if n in guards and getattr(guards[n], GUARD_FLAG)]
    if not bad:
        return
    for n in bad:
        g = guards[n]
        v.reasons.append(
            f"{n}: {g.fraction_in_peaks:.0%} of its improvement lies in the residual's peak(s) at "
            + ", ".join(f"{f:.2f}" for f in g.peaks_hz)
            + " Hz; a lag scales the residual smoothly over frequency and cannot explain a narrow resonance: "
            "not counted"
        )
    keep = [n for n in names if n not in bad]
    for s_ in att.scores:
        if s_.name in bad or s_.name == v.verdict:
            s_.selected = False
    if not keep:
        v.verdict, v.selected = "unexplained", []
        att.final_spec, att.final_fit = base.spec, None
        att.remaining = base.floors
        return
    v.verdict, v.selected = sep.join(keep), keep
    if len(keep) == 1 and keep[0] in att.fits:
        att.final_spec, att.final_fit = att.specs[keep[0]], att.fits[keep[0]]


def unexplained_stage(
    split: _Split, base: _Baseline, att: _Attribution, q: _Quantification, noise: NoiseFindings, st: DiagnoseSettings
) -> None:
    """Stage 6: what the final model leaves beyond the noise model, with where; ``none`` becomes ``unexplained``.

    A confirmed peak whose band keeps at least half its power under the final
    model, or a filtered residual still above 1.5x the model floor and not
    white, is listed in ``noise.unexplained`` with channel, band / peak /
    damping and region. A ``none`` verdict with such a remainder becomes
    ``unexplained``; an effect verdict keeps its effects and says what stays
    unexplained.
    """
    after = q.residuals_after
    q_res = noise.checks[next(iter(noise.checks))].model.q if noise.checks else encoder_resolution
    for c, ch in enumerate(CHANNELS):
        nc = noise_check(after, c, split.filt.w_y, split.filt.w_a, q_res, split.filt.Ts, st.seed)
        if nc is not None:
            noise.checks_after[ch] = nc
    for pk in noise.peaks:
        c = CHANNELS.index(pk.channel)
        sb, sa = wide_spectrum(base.b_train + base.b_test, c, split.filt.Ts), wide_spectrum(after, c, split.filt.Ts)
        if sb is None or sa is None:
            continue
        w = max(pk.damping * pk.freq_hz, sb.df)
        sel = (sb.f >= pk.freq_hz - w) & (sb.f <= pk.freq_hz + w)
        left = float(np.sum(sa.psd[sel]) / max(np.sum(sb.psd[sel]), 1e-300))
        if left >= 0.5:
            noise.remaining_peaks.append(pk)
            noise.unexplained.append(
                {
                    "channel": pk.channel,
                    "kind": pk.kind,
                    "freq_hz": pk.freq_hz,
                    "damping": pk.damping,
                    "band_hz": pk.band_hz,
                    "rms_m_s2": pk.rms_m_s2,
                    "rms_m": pk.rms_m,
                    "g_range_m": pk.g_range_m,
                    "d_range_m": pk.d_range_m,
                    "power_left": left,
                    "what": pk.describe(),
                }
            )
    for ch, nc in noise.checks_after.items():
        if nc.excess_ratio > 1.5 and not nc.whiteness.white and not any(u["channel"] == ch for u in noise.unexplained):
            regs = [r for r in (q.remaining_regions or q.regions) if r.channel == ch]
            g_r = regs[0].g_range_m if regs else []
            d_r = regs[0].d_range_m if regs else []
            band = regs[0].freq_band_hz if regs else None
            noise.unexplained.append(
                {
                    "channel": ch,
                    "kind": "excess",
                    "rms_over_model_floor": nc.excess_ratio,
                    "band_hz": band,
                    "g_range_m": g_r,
                    "d_range_m": d_r,
                    "what": f"{ch} residual {nc.excess_ratio:.1f}x the noise-model floor, not white"
                    + (f", g {g_r[0] * 1e3:.1f}..{g_r[1] * 1e3:.1f} mm" if g_r else "")
                    + (f", d {d_r[0] * 1e3:.0f}..{d_r[1] * 1e3:.0f} mm" if d_r else "")
                    + (f", band {band[0]:.2f}..{band[1]:.2f} Hz" if band else ""),
                }
            )
    peaks_left = [u for u in noise.unexplained if u["kind"] in ("resonance", "line")]
    v = att.verdict
    if v.verdict == "none" and peaks_left:
        v.verdict, v.selected, v.gap_detected = "unexplained", [], True
        v.reasons.append("the noise model leaves spectral peaks the data-based floor had absorbed: unexplained")
    if peaks_left:
        v.reasons.append("unexplained: " + "; ".join(u["what"] for u in peaks_left))


def consequence_stage(split: _Split, base: _Baseline, att: _Attribution, st: DiagnoseSettings) -> Consequences:
    """Stage 7: force, delay and closed-loop consequence of every effect of the verdict; the model files."""
    v = att.verdict
    names = [] if v.verdict in ("none", "unexplained") else v.verdict.replace("|", "+").split("+")
    runs = split.train + split.test
    u_runs = split.u_train + split.u_test
    sizes: list[EffectSize] = []
    for n in names:
        if n not in att.fits:
            continue
        sizes.append(
            effect_size(n, att.specs[n], att.fits[n], runs, u_runs, base.p, simulate=st.simulate and st.consequence)
        )
    matters = [s.name for s in sizes if s.matters]
    negligible = [s.name for s in sizes if s.matters is False]
    if sizes and v.verdict not in ("none", "unexplained"):
        if matters:
            v.reasons.append(f"matters for the 0.1 mm goal: {', '.join(matters)}")
        if negligible:
            v.reasons.append(f"detectable but negligible for the 0.1 mm goal: {', '.join(negligible)}")
    p_b, e_b, _ = plant_effects(base.spec, None, base.p)
    spec = att.final_spec or base.spec
    p_m, e_m, dropped = plant_effects(spec, att.final_fit, base.p)
    label = spec.name if att.final_fit is not None else "baseline"
    return Consequences(
        sizes,
        matters,
        negligible,
        plant_file(p_m, e_m),
        plant_file(p_b, e_b),
        dropped,
        label,
    )


def _check_fit(fit: FitResult, what: str, warnings: list[str]) -> None:
    """Record a fit whose solver did not converge (never silently marked ok)."""
    if not fit.success:
        warnings.append(f"{what}: the fit's solver did not converge ({fit.status}); not counted as evidence")


def diagnose(
    dataset: RigDataset,
    params: Params | None = None,
    settings: DiagnoseSettings | None = None,
    progress: bool = False,
) -> Diagnosis:
    """Diagnose the gap between the model and a dataset (the stages of the module docstring).

    Parameters
    ----------
    dataset : riglog.Dataset
        Any rig-log dataset.
    params : Params, optional
        The model to test as given; default: the nominal model without
        cogging, calibrated (C1..C4) on the training runs.
    settings : DiagnoseSettings
        Filter, split, thresholds.
    progress : bool
        Progress bar over the candidates.

    Returns
    -------
    Diagnosis
        With ``warnings`` naming every fit whose solver did not converge.
    """
    st = settings or DiagnoseSettings()
    rng = np.random.default_rng(np.random.SeedSequence(st.seed))
    timing: dict[str, float] = {}
    warnings: list[str] = []
    t_all = time.perf_counter()
    cpu_all = time.process_time()

    def lap(name: str, t0: float) -> float:
        now = time.perf_counter()
        timing[name] = now - t0
        return now

    split = _split(dataset, st)
    t0 = lap("prepare_s", t_all)
    base = _baseline(split, params, st, warnings)
    t0 = lap("baseline_s", t0)
    loc = _localize(split, base, st, rng)
    q_enc = float(dataset.encoder_resolution or 0.0) or encoder_resolution
    noise = noise_stage(split, base, loc, q_enc, st.seed)
    t0 = lap("localize_s", t0)
    att = _attribute(split, base, loc, st, progress, warnings)
    t0 = lap("candidates_s", t0)
    _second_effect(split, base, att, st, warnings)
    _settle_verdict(base, att)
    noise.guards = lag_guards(split, base, att, noise)
    apply_resonance_guard(base, att, noise.guards)
    t0 = lap("pairs_s", t0)
    q = _quantify(split, base, loc, att, st, rng)
    unexplained_stage(split, base, att, q, noise, st)
    t0 = lap("quantify_s", t0)
    cons = consequence_stage(split, base, att, st)
    lap("consequence_s", t0)
    timing["total_s"] = time.perf_counter() - t_all
    timing["cpu_s"] = time.process_time() - cpu_all
    return Diagnosis(
        verdict=att.verdict,
        scores=rank(att.scores),
        floors=base.floors,
        remaining=att.remaining,
        baseline_params=base.params,
        baseline_mode="given" if base.given else "calibrated",
        baseline_stderr=base.stderr,
        views_before=loc.views,
        views_after=q.views_after,
        regions=q.regions,
        remaining_regions=q.remaining_regions,
        trajectories=q.trajectories,
        train=[r.name for r in split.train_in],
        test=[r.name for r in split.test_in],
        timing=timing,
        residuals_before=base.b_train + base.b_test,
        residuals_after=q.residuals_after,
        final_model=att.final_spec.name if att.final_fit is not None else "baseline",
        settings=st,
        quantization_floor=base.q_floor,
        heldout=HeldOut(split.test, split.u_test, base.fvec, base.b_test),
        warnings=warnings,
        noise=noise,
        consequences=cons,
    )


def _consistent_lines(
    train: Sequence[Residual], test: Sequence[Residual], c: int, fs: float, fmax: float
) -> list[dict]:
    """Spectral lines found in both the training and the held-out residuals (each at 1 % false alarm)."""
    a = spectrum(train, c, fs, fmax, false_alarm=1e-2)
    b = spectrum(test, c, fs, fmax, false_alarm=1e-2)
    if a is None or b is None:
        return []
    out = []
    for pa in a.peaks:
        for pb in b.peaks:
            if (
                pa["band_hz"][0] <= pb["peak_hz"] <= pa["band_hz"][1]
                or pb["band_hz"][0] <= pa["peak_hz"] <= pb["band_hz"][1]
            ):
                out.append(pa)
                break
    return out


def _rms_channel(res: Sequence[Residual], c: int) -> float:
    x = [r.r[:, c] for r in res if r.run.n and r.run.valid[c]]
    if not x:
        return 1.0
    v = np.concatenate(x)
    return float(np.sqrt(np.mean(v**2)))


__all__ = [
    "LIBRARY",
    "ChannelView",
    "DiagnoseSettings",
    "Diagnosis",
    "HeldOut",
    "apply_resonance_guard",
    "combine",
    "consequence_stage",
    "diagnose",
    "lag_guards",
    "noise_stage",
    "runs_from_dataset",
    "split_runs",
    "unexplained_stage",
]
