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
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydantic import Field
from tqdm import tqdm

from ..config import Strict
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
from .localize import (
    BinStats,
    ChannelFloor,
    PeriodScan,
    Region,
    Spectrum,
    bin_stats,
    channel_floor,
    dominant_band,
    edges_for,
    period_scan,
    pool,
    regions_from_map,
    spectrum,
)
from .residuals import CHANNELS, Residual, ResidualSettings, RunInput, ZeroPhaseFilter, prepare_run
from .simulate_compare import TrajectoryComparison, compare_trajectories

#: The candidate library, in report order.
LIBRARY: tuple[str, ...] = tuple(library_specs())


class DiagnoseSettings(Strict):
    """Settings of :func:`diagnose` (all have defaults that suit 1 kHz rig logs).

    Attributes
    ----------
    fc_hz, numtaps, decimate : float, int, int
        Residual filter (see :class:`~.residuals.ResidualSettings`).
    holdout_every : int
        Hold out every n-th run (at least one).
    candidates : list of str or None
        Restrict the candidate library (default: all; ``parameter_error`` is
        dropped against a calibrated baseline, which absorbs it).
    z_min, bic_margin, closes_min, confusable_z, second_min : float
        Verdict thresholds (see :class:`~.attribution.VerdictRules`).
    n_null : int
        Null draws (circular shifts) of the period scan's threshold.
    seed : int
        Seed of the null draws and subsampling (same seed, same report).
    horizon_s : float
        Window of the simulated-trajectory comparison [s].
    simulate : bool
        Run the trajectory comparison.
    """

    fc_hz: float = Field(15.0, gt=0.5, le=200.0)
    numtaps: int = Field(401, ge=31, le=4001)
    decimate: int = Field(8, ge=1, le=100)
    holdout_every: int = Field(3, ge=2, le=20)
    candidates: list[str] | None = None
    z_min: float = Field(4.0, gt=0)
    bic_margin: float = Field(10.0, ge=0)
    closes_min: float = Field(0.5, gt=0, le=1)
    confusable_z: float = Field(2.0, ge=0)
    second_min: float = Field(0.5, gt=0, le=1)
    n_null: int = Field(8, ge=3, le=200)
    seed: int = Field(0, ge=0)
    horizon_s: float = Field(0.05, gt=0.002, le=1.0)
    simulate: bool = True

    def rules(self) -> VerdictRules:
        """Verdict thresholds."""
        return VerdictRules(self.z_min, self.bic_margin, self.closes_min, self.confusable_z, self.second_min)


@dataclass
class ChannelView:
    """Localization of one channel for one model (baseline or augmented).

    Attributes
    ----------
    map_gd : BinStats
        Residual over gap x position, with per-bin floors.
    bins : dict of BinStats
        1-D views over each feature.
    spectrum : Spectrum or None
        Welch PSD and peak bands.
    period : PeriodScan or None
        Least-squares period scan in d.
    band : list of float or None
        Band holding most of the residual's excess power.
    """

    map_gd: BinStats
    bins: dict[str, BinStats]
    spectrum: Spectrum | None
    period: PeriodScan | None
    band: list[float] | None


@dataclass
class HeldOut:
    """The held-out data of a diagnosis, for scoring other models on the same samples (self-check).

    Attributes
    ----------
    runs : list of PreparedRun
        Held-out runs.
    u : list of ndarray
        Their commanded currents.
    floors : ndarray
        Channel floors used for normalization [m/s^2].
    baseline : list of Residual
        Baseline residuals of the held-out runs.
    """

    runs: list
    u: list
    floors: np.ndarray
    baseline: list


@dataclass
class Diagnosis:
    """Everything a diagnosis found (see :mod:`.report` for the files it writes).

    Attributes
    ----------
    verdict : Verdict
        The verdict and the reasons.
    scores : list of EffectScore
        Candidates (and any pair tried), ranked best first.
    floors : dict
        ``{channel: ChannelFloor}`` of the baseline.
    remaining : dict
        ``{channel: ChannelFloor}`` after the selected effect(s) (or the best candidate).
    baseline_params : Params
        The baseline model.
    baseline_mode : str
        ``calibrated`` or ``given``.
    baseline_stderr : dict
        Standard errors of the calibrated constants.
    views_before, views_after : dict
        ``{channel: ChannelView}`` of the baseline and of the final model (all runs).
    regions : list of Region
        Where the baseline residual exceeds the floor.
    remaining_regions : list of Region
        Where the final model's residual still does.
    trajectories : TrajectoryComparison or None
        Short-window simulation errors on the held-out runs.
    train, test : list of str
        Run names used for fitting and for scoring.
    timing : dict
        Seconds per stage.
    residuals_before, residuals_after : list of Residual
        Baseline and final residuals of every run (for figures).
    final_model : str
        Label of the final model (``baseline`` or the selected effects).
    """

    verdict: Verdict
    scores: list[EffectScore]
    floors: dict[str, ChannelFloor]
    remaining: dict[str, ChannelFloor]
    baseline_params: Params
    baseline_mode: str
    baseline_stderr: dict[str, float]
    views_before: dict[str, ChannelView]
    views_after: dict[str, ChannelView]
    regions: list[Region]
    remaining_regions: list[Region]
    trajectories: TrajectoryComparison | None
    train: list[str]
    test: list[str]
    timing: dict[str, float] = field(default_factory=dict)
    residuals_before: list[Residual] = field(default_factory=list)
    residuals_after: list[Residual] = field(default_factory=list)
    final_model: str = "baseline"
    settings: DiagnoseSettings | None = None
    quantization_floor: float = math.nan
    heldout: HeldOut | None = None

    def to_json(self) -> dict:
        """The ``report.json`` content."""
        from .report import report_json

        return report_json(self)

    def table(self) -> str:
        """Text summary (printed by ``maglev diagnose``)."""
        from .report import summary_table

        return summary_table(self)

    def save(self, out_dir) -> None:
        """Write ``report.json``, ``report.md`` and the figures into ``out_dir``."""
        from .report import write_report

        write_report(self, out_dir)


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
def diagnose(
    dataset: RigDataset,
    params: Params | None = None,
    settings: DiagnoseSettings | None = None,
    progress: bool = False,
) -> Diagnosis:
    """Diagnose the gap between the model and a dataset.

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
    """
    st = settings or DiagnoseSettings()
    rules = st.rules()
    rng = np.random.default_rng(np.random.SeedSequence(st.seed))
    timing: dict[str, float] = {}
    t_all = time.perf_counter()
    cpu_all = time.process_time()

    runs = runs_from_dataset(dataset)
    Ts = float(dataset.sample_time)
    filt = ZeroPhaseFilter(ResidualSettings(st.fc_hz, st.numtaps | 1, st.decimate), Ts)
    train_in, test_in = split_runs(runs, st.holdout_every)
    train = [prepare_run(r, filt) for r in train_in]
    test = [prepare_run(r, filt) for r in test_in]
    keep = [(ri, pr) for ri, pr in zip(train_in, train, strict=True) if pr.n > 0]
    train_in, train = [a for a, _ in keep], [b for _, b in keep]
    keep = [(ri, pr) for ri, pr in zip(test_in, test, strict=True) if pr.n > 0]
    test_in, test = [a for a, _ in keep], [b for _, b in keep]
    if not train or not test:
        raise DataError(
            f"{dataset.folder or 'dataset'}: runs are too short for the residual filter "
            f"({st.numtaps} taps at {Ts:g} s); need at least {3 * st.numtaps} samples per run"
        )
    u_train = [r.u for r in train_in]
    u_test = [r.u for r in test_in]
    has = (any(r.valid[0] for r in train), any(r.valid[1] for r in train))
    timing["prepare_s"] = time.perf_counter() - t_all

    # ---------------------------------------------------------------- baseline
    t0 = time.perf_counter()
    given = params is not None
    base = params if given else NOMINAL.without_cogging()
    p0 = base.vector()
    base_spec = CandidateSpec("baseline")
    r0 = residuals_with(base_spec, None, train, p0)
    w0 = np.array([1.0 / max(_rms_channel(r0, c), 1e-6) for c in range(2)])
    cal_free = calibration_free(base, *has) if not given else ()
    base_stderr: dict[str, float] = {}
    if cal_free:
        cal_spec = CandidateSpec("baseline", free=cal_free, note="C1..C4 calibrated on the training runs")
        fit0 = fit_candidate(cal_spec, Dataset(train, w0, filt), p0)
        p_base = _params_with(p0, fit0)
    else:
        p_base = p0
    base_params = Params.from_vector(p_base)
    b_train = residuals_with(base_spec, None, train, p_base)
    b_test = residuals_with(base_spec, None, test, p_base)
    q_floor = filt.quantization_floor()
    # The residual's noise is correlated over the filter's main lobe: 2 fs / fc decimated samples.
    noise_lag = max(4, math.ceil(2.0 / (st.fc_hz * Ts * st.decimate)))
    floors: dict[str, ChannelFloor] = {}
    for c in range(2):
        fl = channel_floor(b_train, b_test, c, q_floor, max_lag=noise_lag)
        if fl is not None:
            floors[CHANNELS[c]] = fl
    fvec = np.array([floors[ch].floor if ch in floors else 1.0 for ch in CHANNELS])
    fvec = np.maximum(fvec, 1e-9)
    data_train = Dataset(train, 1.0 / fvec, filt)
    if cal_free:
        cal_free2 = calibration_free(base_params, *has)
        base_fit = fit_candidate(CandidateSpec("baseline", free=cal_free2), data_train, p_base)
        base_stderr = {k_.split(".", 1)[1]: float(s) for k_, s in zip(base_fit.spec.keys, base_fit.stderr, strict=True)}
    else:
        cal_free2 = ()
        base_fit = fit_candidate(base_spec, data_train, p_base)
    timing["baseline_s"] = time.perf_counter() - t0

    # ------------------------------------------------------------ localization
    t0 = time.perf_counter()
    fs = 1.0 / (Ts * st.decimate)
    infl = np.array([floors[ch].inflation if ch in floors else 1.0 for ch in CHANNELS])
    all_before = b_train + b_test
    views_before = _views(all_before, fvec, infl, fs, st.fc_hz, rng, st.n_null)
    evidence = []
    for ch, fl in floors.items():
        if fl.significant:
            evidence.append(
                f"{ch}: the residual has state structure beyond the floor (held-out map gain "
                f"{fl.gain:.1%}, z = {fl.z:.1f})"
            )
    for c, ch in enumerate(CHANNELS):
        # A spectral line counts as a gap only if the training and the held-out runs both show it.
        lines = _consistent_lines(b_train, b_test, c, fs, st.fc_hz)
        if lines:
            pk = lines[0]
            evidence.append(
                f"{ch}: spectral line at {pk['peak_hz']:.2f} Hz ({pk['ratio']:.0f}x the PSD around it, "
                "in training and held-out runs)"
            )
    for ch, v in views_before.items():
        if v.period is not None and v.period.significant:
            evidence.append(
                f"{ch}: periodic in d with period {v.period.best_period * 1e3:.2f} mm"
                + (f" (= {v.period.match})" if v.period.match else "")
            )
    gap_detected = bool(evidence)
    timing["localize_s"] = time.perf_counter() - t0

    # -------------------------------------------------------------- candidates
    t0 = time.perf_counter()
    lib = library_specs()
    names = [n for n in (st.candidates or LIBRARY) if n in lib]
    if not given:
        names = [n for n in names if n != "parameter_error"]
    specs: dict[str, CandidateSpec] = {}
    fits: dict[str, FitResult] = {}
    scores: list[EffectScore] = []
    for name in tqdm(names, desc="candidates", disable=not progress, leave=False):
        spec = lib[name].with_free(cal_free2) if cal_free2 else lib[name]
        fit = fit_candidate(spec, data_train, p_base, u_runs=u_train)
        after = residuals_with(spec, fit, test, p_base, u_test)
        vals, errs = _readable(fit, pair=False)
        specs[name], fits[name] = spec, fit
        scores.append(score(name, fit, base_fit, b_test, after, fvec, rules, vals, errs, lib[name].note))
    verdict, best = decide(scores, gap_detected, rules, evidence)
    timing["candidates_s"] = time.perf_counter() - t0

    # ------------------------------------------------- second effect / pairs
    t0 = time.perf_counter()
    final_spec, final_fit = base_spec, None
    list(verdict.selected)
    if best is not None:
        final_spec, final_fit = specs[best.name], fits[best.name]
        a_train = residuals_with(final_spec, final_fit, train, p_base, u_train)
        a_test = residuals_with(final_spec, final_fit, test, p_base, u_test)
        rem = {
            CHANNELS[c]: fl
            for c in range(2)
            if (fl := channel_floor(a_train, a_test, c, q_floor, max_lag=noise_lag)) is not None
        }
        still = any(f.significant for f in rem.values())
        if still and best.closes < 0.9:
            others = [
                s for s in rank(scores) if s.significant and s.name != best.name and s.name not in best.confusable_with
            ][:3]
            pair_scores = []
            for o in others:
                spec = combine(specs[best.name], specs[o.name])
                fit = fit_candidate(spec, data_train, p_base, u_runs=u_train)
                after = residuals_with(spec, fit, test, p_base, u_test)
                vals, errs = _readable(fit, pair=True)
                ps = score(spec.name, fit, base_fit, b_test, after, fvec, rules, vals, errs, spec.note)
                Ra_best2, Ra_pair2 = best.r2_after, ps.r2_after
                extra = (Ra_best2 - Ra_pair2) / max(Ra_best2 - 1.0, Ra_best2 - Ra_pair2, 1e-12)
                zp = paired_z(best.e_after, ps.e_after)
                pair_scores.append((extra, zp, ps, spec, fit))
                scores.append(ps)
            good = [t for t in pair_scores if t[1] >= rules.z_min and t[0] >= rules.second_min]
            if good:
                extra, zp, ps, spec, fit = max(good, key=lambda t: t[0])
                if verdict.verdict != "unexplained" or ps.closes >= rules.closes_min:
                    verdict = Verdict(
                        ps.name,
                        ps.name.split("+"),
                        True,
                        [
                            *verdict.reasons,
                            f"a significant gap remained; adding {ps.name.split('+')[1]} closes {extra:.0%} of it "
                            f"(paired z = {zp:.1f}): {ps.name}",
                        ],
                    )
                    ps.name.split("+")
                    ps.selected = True
                    final_spec, final_fit = spec, fit
                    a_train = residuals_with(final_spec, final_fit, train, p_base, u_train)
                    a_test = residuals_with(final_spec, final_fit, test, p_base, u_test)
                    rem = {
                        CHANNELS[c]: fl
                        for c in range(2)
                        if (fl := channel_floor(a_train, a_test, c, q_floor, max_lag=noise_lag)) is not None
                    }
        if verdict.verdict == "unexplained":
            verdict.reasons.append(
                f"no candidate, alone or with a second one, closes {rules.closes_min:.0%} of the gap: unexplained"
            )
    if verdict.verdict in ("none", "unexplained"):
        # No effect is claimed: the final model is the baseline, and the gap that remains is its gap.
        final_spec, final_fit = base_spec, None
        rem = floors
    in_verdict = set(verdict.verdict.replace("|", "+").split("+"))
    for s in scores:
        s.selected = verdict.verdict not in ("none", "unexplained") and (
            s.name in in_verdict or s.name == verdict.verdict
        )
    timing["pairs_s"] = time.perf_counter() - t0

    # ---------------------------------------------------------- quantification
    t0 = time.perf_counter()
    show_spec, show_fit = (final_spec, final_fit)
    all_after = residuals_with(show_spec, show_fit, train, p_base, u_train) + residuals_with(
        show_spec, show_fit, test, p_base, u_test
    )
    views_after = _views(all_after, fvec, infl, fs, st.fc_hz, rng, st.n_null)
    regions = _regions(views_before, floors) if gap_detected else []
    remaining_regions = _regions(views_after, rem) if any(f.significant for f in rem.values()) else []
    if verdict.verdict == "unexplained":
        # Where the unexplained gap is (the baseline's: no candidate closes it).
        regions_unexpl = remaining_regions or regions
        if regions_unexpl:
            verdict.reasons.append(
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
        models = {"baseline": (base_spec, None)}
        pvecs = {"baseline": p_base}
        if final_fit is not None:
            models["augmented"] = (show_spec, show_fit)
            pvecs["augmented"] = p_base
        traj = compare_trajectories(test_in, models, pvecs, horizon=st.horizon_s)
    timing["quantify_s"] = time.perf_counter() - t0
    timing["total_s"] = time.perf_counter() - t_all
    timing["cpu_s"] = time.process_time() - cpu_all
    return Diagnosis(
        verdict=verdict,
        scores=rank(scores),
        floors=floors,
        remaining=rem,
        baseline_params=base_params,
        baseline_mode="given" if given else "calibrated",
        baseline_stderr=base_stderr,
        views_before=views_before,
        views_after=views_after,
        regions=regions,
        remaining_regions=remaining_regions,
        trajectories=traj,
        train=[r.name for r in train_in],
        test=[r.name for r in test_in],
        timing=timing,
        residuals_before=all_before,
        residuals_after=all_after,
        final_model=show_spec.name if show_fit is not None else "baseline",
        settings=st,
        quantization_floor=q_floor,
        heldout=HeldOut(test, u_test, fvec, b_test),
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
    "combine",
    "diagnose",
    "runs_from_dataset",
    "split_runs",
]
