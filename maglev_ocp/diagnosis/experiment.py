"""Active diagnosis: the excitation that tells a confusable slot's alternatives apart.

When the held-out runs cannot separate two (or more) effects, each alternative
was fitted on the *same* data and predicts it equally well; what separates them
is what they predict *differently* on a run that has not been made yet. This is
auxiliary signal design for failure detection (R. Nikoukhah and S. L. Campbell,
*Auxiliary Signal Design for Failure Detection*, Princeton University Press,
2006): among a menu of excitations the rig can execute, choose the one whose
predicted outputs under the competing models differ most, measured against the
noise the diagnosis has measured.

How an excitation is scored (:func:`design`):

1. every menu entry (:func:`default_menu`: holds, gap sines and chirps at
   several d, traverses of d at constant speed at two gaps, velocity sweeps,
   traverses to the ends of the travel at two gaps, slow traverses, locked-gap
   runs) is a list of closed-loop runs (:class:`~maglev_ocp.loop.run_plan.RunSpec`,
   physical units) simulated *once* on the baseline model (the plant simulator,
   noise-free, the baseline's constants, the seed's PID regulators, as ``maglev
   simulate`` runs them);
2. along that trajectory each alternative's effect acceleration is evaluated
   with the effect library's symbolic functions
   (:func:`maglev_ocp.effects.effect_delta_function`, the same terms the fitter
   adds to the shared model), with the shared model's change for the constants
   its fit moved;
3. what separates two alternatives is what is left of their difference once
   the *rival* refits what a diagnosis on the pooled data refits: its own
   effect parameters and the calibrated constants (C1..C4, xi0, ell, Mv). For
   alternative ``a`` taken as the truth and ``b`` as the rival,

   ``T_ab = min_delta |W (y_a - y_b - J_b delta)|^2 + |delta_c / s_c|^2``

   with ``J_b`` the Jacobian of ``b``'s filtered prediction with respect to its
   refitted parameters (central differences along the trajectory; exact for the
   parameters the accelerations are linear in), ``W`` the noise weighting below
   and ``s_c`` the prior sd of each calibrated constant
   (:data:`~maglev_ocp.diagnosis.library.PRIOR_SD`, relative to its value; the
   rival's effect parameters have a flat prior). This is the linearised
   T-optimality criterion for discriminating rival models (A. C. Atkinson and
   V. V. Fedorov, "The design of experiments for discriminating between two
   rival models", *Biometrika* 62(1):57-70, 1975): the lack of fit the rival
   keeps after its best fit to the true model's prediction. The prior term
   makes it the Bayesian one: for a linear model with a Gaussian prior on the
   constants, ``d' (Sigma_noise + J P J')^-1 d`` (the mean shift between the
   alternatives' marginal predictive densities: twice their Kullback-Leibler
   divergence with the covariances taken equal, the expected log Bayes
   factor) equals this ridge residual by the Woodbury identity: the constants
   are marginalised with their prior, as in Bayesian active diagnosis (Kong
   et al. 2025). Held at their fitted values instead, two
   alternatives' *constant* differences (each fit moved C1..C4 its own way)
   can swamp the effects' own signatures and favour runs that separate the
   constants, not the effects;
4. the noise weighting: the difference is passed through the diagnosis's
   residual low-pass (:class:`~maglev_ocp.diagnosis.residuals.ZeroPhaseFilter`)
   and compared with the channel's noise floor ``sigma_c`` (the held-out floor
   of the diagnosis), ``W^2 = 2 f_c T_s / sigma_c^2`` per filtered sample, so that
   with nothing refitted ``SNR^2 = sum_c (rms_c / sigma_c)^2 * 2 f_c T`` (``2 f_c
   T`` the independent samples the filter leaves in a run of length ``T``; a
   channel a fixture locks has no residual). The pair's SNR is
   ``sqrt(min(T_ab, T_ba))`` (either may be the truth); a slot with more than
   two alternatives is scored by its least separated pair.

Entries are compared at equal running time (the SNR per minute), and the
chosen plan repeats its runs until the predicted SNR reaches the target (or
the time cap). The refit is over the new runs alone (the existing data, which
constrains the constants further, is left out): the predicted SNR is a
conservative one, and an entry wins only if it separates the alternatives on
its own. The diagnosis on both datasets (``maglev diagnose run DATA1 DATA2``)
decides.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import casadi as ca
import numpy as np
import scipy.signal as sps

from ..effects import EffectSet, effect_delta_function
from ..loop.run_plan import RunPlan, RunSpec, simulate_plan
from ..model import get_model
from ..params import Params
from ..plant import PlantConfig
from ..riglog import RunLog
from ..signals import PARAM_NAMES
from .library import PRIOR_SD
from .residuals import ResidualSettings, ZeroPhaseFilter

#: Channels of the residual, in the order of the effect accelerations (vertical g, horizontal d).
CHANNELS: tuple[str, str] = ("vertical", "horizontal")


@dataclass(frozen=True)
class Refit:
    """A parameter a refit on the new runs may move (an entry of an alternative's fit).

    Attributes
    ----------
    key : str
        ``"p.<name>"`` for a model constant, ``"<effect>.<param>"`` for an effect parameter.
    scale : float
        Typical magnitude (sets the finite-difference step).
    prior_sd : float or None
        Gaussian prior sd in physical units (None: flat).
    """

    key: str
    scale: float = 1.0
    prior_sd: float | None = None


@dataclass(frozen=True)
class Alternative:
    """One fitted alternative of a confusable slot: an effect set and its fitted parameters.

    Attributes
    ----------
    name : str
        Label (the slot member, e.g. ``eddy_drag``).
    effects : tuple of str
        The effect set of the alternative's model (the slot member and any effects common to all alternatives).
    params : dict
        ``{effect: {param: value}}`` fitted on the existing data; missing ones take their defaults.
    constants : dict
        The model constants the alternative's fit moved (``{"C1": ...}``); the others are the baseline's.
    refit : tuple of Refit or None
        What a refit may move (its fit's free parameters). None: every effect parameter in ``params`` (flat
        prior) and every constant in ``constants`` (prior :data:`~maglev_ocp.diagnosis.library.PRIOR_SD`).
    ties : tuple of (str, str)
        ``(key, source)``: ``key`` takes the value of ``source`` (e.g. ``cogging.xi0`` follows ``p.xi0``).
    """

    name: str
    effects: tuple[str, ...]
    params: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    constants: Mapping[str, float] = field(default_factory=dict)
    refit: tuple[Refit, ...] | None = None
    ties: tuple[tuple[str, str], ...] = ()

    def theta(self) -> np.ndarray:
        """The parameter vector in the effect library's order."""
        return EffectSet(self.effects).vector(self.params)

    def refits(self, params: Params) -> tuple[Refit, ...]:
        """What a refit may move (``refit``, or the default of the class docstring at the baseline ``params``)."""
        if self.refit is not None:
            return self.refit
        eff = tuple(Refit(f"{e}.{k}", max(abs(v), 1.0)) for e, vals in self.params.items() for k, v in vals.items())
        return eff + tuple(constant_refit(c, params) for c in self.constants)


def constant_refit(name: str, params: Params, prior_sd: Mapping[str, float] | None = None) -> Refit:
    """A calibrated constant as a refit entry, its prior sd relative to the baseline's value (``PRIOR_SD``)."""
    v = abs(float(getattr(params, name)))
    rel = (prior_sd if prior_sd is not None else PRIOR_SD).get(name)
    return Refit(f"p.{name}", max(v, 1e-6), None if rel is None else rel * max(v, 1e-12))


@dataclass(frozen=True)
class MenuEntry:
    """An executable excitation: a name, its runs and what it is for."""

    name: str
    runs: tuple[RunSpec, ...]
    purpose: str

    @property
    def duration_s(self) -> float:
        """Total run time [s]."""
        return float(sum(r.duration_s for r in self.runs))


@dataclass(frozen=True)
class EntryScore:
    """Predicted separation of the alternatives on one menu entry.

    Attributes
    ----------
    name : str
        Menu entry.
    snr : float
        Predicted SNR of the least separated pair on the entry as it is, after the rival's refit.
    snr_per_minute : float
        ``snr`` scaled to one minute of running (``snr sqrt(60 / T)``): the design criterion.
    per_channel : dict
        ``{channel: SNR}`` of the least separated pair (what the refit leaves on each channel).
    pair : tuple of str
        The least separated pair.
    snr_fixed : float
        The pair's SNR with both alternatives held at their fitted values (nothing refitted), for comparison.
    """

    name: str
    snr: float
    snr_per_minute: float
    per_channel: dict[str, float]
    pair: tuple[str, str]
    snr_fixed: float = float("nan")


@dataclass(frozen=True)
class Design:
    """The chosen excitation and every entry's score."""

    plan: RunPlan
    chosen: EntryScore
    scores: tuple[EntryScore, ...]
    repeats: int


def _traverse(gap: float, half: float, speed: float, *, cycles: float = 1.0, lock: str = "none") -> RunSpec:
    """A d traverse of ``cycles`` full back-and-forth periods (at least 2 s, at most 30 s)."""
    duration = min(30.0, max(2.0, cycles * 4 * half / speed))
    return RunSpec(kind="d_traverse", gap_mm=gap, amplitude_mm=half, speed_mm_s=speed, duration_s=duration, lock=lock)


def default_menu(
    gaps_mm: Sequence[float] = (13.0, 25.0),
    speeds_mm_s: Sequence[float] = (30.0, 100.0, 250.0),
    d_reach_mm: float = 50.0,
) -> list[MenuEntry]:
    """The excitations the design chooses from, each a list of closed-loop runs (physical units).

    Parameters
    ----------
    gaps_mm : sequence of float
        Two (or more) gaps the gap-dependent entries are run at [mm]; the first is also the single-gap one.
    speeds_mm_s : sequence of float
        Speeds of the velocity sweeps [mm/s].
    d_reach_mm : float
        How far the end-of-travel traverses go [mm].
    """
    g_lo, g_hi = min(gaps_mm), max(gaps_mm)
    g_mid = 0.5 * (g_lo + g_hi)
    menu = [
        MenuEntry(
            "holds",
            tuple(
                RunSpec(kind="hold", gap_mm=g, d_mm=d, duration_s=1.5) for g in (g_lo, g_hi) for d in (-30.0, 0.0, 30.0)
            ),
            "holds at two gaps and three positions (static forces)",
        ),
        MenuEntry(
            "gap_sines",
            tuple(
                RunSpec(kind="gap_sine", gap_mm=g_mid, d_mm=d, amplitude_mm=4.0, freq_hz=2.0, duration_s=4.0, lock="d")
                for d in (0.0, 20.0)
            ),
            "gap sines (4 mm, 2 Hz) at two fixed d, d locked (vertical velocity and gap)",
        ),
        MenuEntry(
            "gap_chirps",
            tuple(
                RunSpec(
                    kind="gap_chirp", gap_mm=g, amplitude_mm=2.0, freq_hz=0.5, freq_end_hz=8.0, duration_s=6.0, lock="d"
                )
                for g in (g_lo + 2.0, g_hi - 2.0)
            ),
            "gap chirps 0.5..8 Hz at two gaps, d locked (vertical dynamics)",
        ),
        MenuEntry(
            "velocity_sweep_one_gap",
            tuple(_traverse(g_mid, 30.0, v, cycles=2) for v in speeds_mm_s),
            f"d traverses +-30 mm at {', '.join(f'{v:g}' for v in speeds_mm_s)} mm/s at one gap",
        ),
        MenuEntry(
            "velocity_sweep_two_gaps",
            tuple(_traverse(g, 30.0, v, cycles=2) for g in (g_lo, g_hi) for v in speeds_mm_s),
            f"d traverses +-30 mm at {', '.join(f'{v:g}' for v in speeds_mm_s)} mm/s at gaps {g_lo:g} and {g_hi:g} mm "
            "(velocity- against gap-dependence of a drag)",
        ),
        MenuEntry(
            "ends_two_gaps",
            tuple(_traverse(g, d_reach_mm, 25.0) for g in (g_lo, g_hi)),
            f"slow d traverses to +-{d_reach_mm:g} mm at gaps {g_lo:g} and {g_hi:g} mm "
            "(overhang at the ends, large currents at the large gap)",
        ),
        MenuEntry(
            "slow_traverse",
            (_traverse(g_lo, 25.0, 5.0),),
            f"slow d traverse +-25 mm at 5 mm/s at {g_lo:g} mm (force periodic in d resolved: slot against pole pitch)",
        ),
        MenuEntry(
            "locked_gap_traverse",
            tuple(_traverse(g, 40.0, 60.0, cycles=2, lock="g") for g in (g_lo, g_hi)),
            f"d traverses +-40 mm at 60 mm/s, gap locked at {g_lo:g} and {g_hi:g} mm (horizontal force alone)",
        ),
    ]
    return menu


def _state_inputs(log: RunLog) -> tuple[np.ndarray, np.ndarray]:
    """States ``(g, g_dot, d, d_dot)`` and currents ``(i_q, i_d)`` along a simulated run, each (N, .)."""
    g, d = log["g_true"] if "g_true" in log else log["g"], log["d_true"] if "d_true" in log else log["d"]
    gd = log["g_dot_true"] if "g_dot_true" in log else np.gradient(g, log.t)
    dd = log["d_dot_true"] if "d_dot_true" in log else np.gradient(d, log.t)
    return np.column_stack([g, gd, d, dd]), np.column_stack([log["i_q"], log["i_d"]])


@lru_cache(maxsize=64)
def _sensitivity(names: tuple[str, ...], n: int) -> ca.Function:
    """``(x, u, p, p0, theta) -> (acc, d acc / d theta, d acc / d p)`` mapped over ``n`` samples.

    ``acc`` is what the effects ``names`` with the constants ``p`` add to the shared model with the baseline's
    ``p0`` (:func:`~maglev_ocp.effects.effect_delta_function` plus MODEL.md's accelerations at ``p`` minus at
    ``p0``), shape (2,); the Jacobians are exact (CasADi's algorithmic differentiation of the same expressions).
    """
    m = get_model()
    es = EffectSet(names)
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 2)
    p, p0, th = ca.SX.sym("p", m.np_), ca.SX.sym("p0", m.np_), ca.SX.sym("theta", es.n_theta)
    f, f0 = m.f(x, u, p), m.f(x, u, p0)
    acc = ca.vertcat(f[1] - f0[1], f[3] - f0[3])
    if names:
        acc += effect_delta_function(names)(x, u, p, th)
    fn = ca.Function("alt_sensitivity", [x, u, p, p0, th], [acc, ca.jacobian(acc, th), ca.jacobian(acc, p)])
    return fn.map(n)


def _evaluate(alt: Alternative, log: RunLog, params: Params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``alt``'s acceleration along ``log`` (N, 2) and its Jacobians w.r.t. theta (N, 2, n_theta) and p (N, 2, np)."""
    x, u = _state_inputs(log)
    n = len(x)
    p_alt = params.with_(**alt.constants) if alt.constants else params
    args = [
        x.T,
        u.T,
        np.tile(np.asarray(p_alt.vector(), float)[:, None], (1, n)),
        np.tile(np.asarray(params.vector(), float)[:, None], (1, n)),
        np.tile(alt.theta()[:, None], (1, n)),
    ]
    acc, j_th, j_p = (np.asarray(v, float) for v in _sensitivity(tuple(alt.effects), n)(*args))
    return acc.T, j_th.reshape(2, n, -1).transpose(1, 0, 2), j_p.reshape(2, n, -1).transpose(1, 0, 2)


def effect_accelerations(alt: Alternative, log: RunLog, params: Params) -> np.ndarray:
    """What ``alt`` adds to the baseline model's accelerations along ``log``, shape (N, 2) [m/s^2].

    Its effects' accelerations (:func:`~maglev_ocp.effects.effect_delta_function`) plus, when its fit moved
    model constants, the shared model's change with them (MODEL.md's equations with the alternative's constants).
    """
    return _evaluate(alt, log, params)[0]


def sensitivities(alt: Alternative, keys: Sequence[str], log: RunLog, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """``alt``'s acceleration (N, 2) along ``log`` and its derivative w.r.t. each of ``keys`` (N, 2, len(keys)).

    ``keys`` are ``"p.<constant>"`` or ``"<effect>.<param>"`` (zero for a parameter of an effect ``alt`` does
    not have); an effect parameter tied to a key (``alt.ties``) moves with it (chain rule).
    """
    acc, j_th, j_p = _evaluate(alt, log, params)
    th_names = EffectSet(alt.effects).param_names
    keys = list(keys)

    def column(key: str) -> np.ndarray:
        head, _, name = key.partition(".")
        if head == "p":
            return j_p[:, :, PARAM_NAMES.index(name)]
        if key in th_names:
            return j_th[:, :, th_names.index(key)]
        return np.zeros(j_p.shape[:2])

    cols = [column(k) for k in keys]
    for key, src in alt.ties:
        if src in keys and key not in keys and key in th_names:
            cols[keys.index(src)] = cols[keys.index(src)] + column(key)
    return acc, (np.stack(cols, axis=-1) if cols else np.zeros((*j_p.shape[:2], 0)))


def _filtered(sig: np.ndarray, filt: ZeroPhaseFilter) -> np.ndarray:
    """The residual low-pass applied to per-period signals along axis 0 (valid part only)."""
    if len(sig) <= len(filt.h):
        return np.zeros((0, *sig.shape[1:]))
    return sps.oaconvolve(sig, filt.h.reshape(-1, *([1] * (sig.ndim - 1))), mode="valid", axes=0)


def _weights(lock: str, floors: Mapping[str, float], fc_hz: float, Ts: float) -> np.ndarray:
    """Per-channel weight ``W = sqrt(2 f_c T_s) / sigma_c`` of a filtered sample (0 on a locked channel)."""
    return np.array(
        [
            0.0 if lock == axis else math.sqrt(2.0 * fc_hz * Ts) / max(floors[ch], 1e-12)
            for ch, axis in zip(CHANNELS, ("g", "d"), strict=True)
        ]
    )


def pair_snr(
    a: np.ndarray,
    b: np.ndarray,
    lock: str,
    floors: Mapping[str, float],
    filt: ZeroPhaseFilter,
    fc_hz: float,
    Ts: float,
) -> dict[str, float]:
    """Per-channel SNR of the filtered difference of two effect accelerations on one run (nothing refitted)."""
    w = _weights(lock, floors, fc_hz, Ts)
    diff = _filtered(a - b, filt)
    return {ch: float(w[c] * np.sqrt(np.sum(diff[:, c] ** 2))) for c, ch in enumerate(CHANNELS)}


@dataclass(frozen=True)
class _Prediction:
    """An alternative's weighted, filtered prediction on an entry's runs and its Jacobian w.r.t. ``keys``.

    ``y`` is (M, 2) (rows: the runs' filtered samples stacked; columns: channels, noise-weighted), ``jac``
    (M, 2, K); ``prior`` the prior sd of each key (``inf``: flat).
    """

    y: np.ndarray
    jac: np.ndarray
    keys: tuple[str, ...]
    prior: np.ndarray


def _predict(
    alt: Alternative,
    refits: Sequence[Refit],
    logs: Sequence[RunLog],
    runs: Sequence[RunSpec],
    params: Params,
    floors: Mapping[str, float],
    filt: ZeroPhaseFilter,
    fc_hz: float,
) -> _Prediction:
    """``alt``'s weighted, filtered prediction along ``logs`` and its sensitivity to ``refits``."""
    keys = [r.key for r in refits]
    ys, jacs = [], []
    for log, run in zip(logs, runs, strict=True):
        w = _weights(run.lock, floors, fc_hz, filt.Ts)
        acc, jac = sensitivities(alt, keys, log, params)
        cols = np.concatenate([acc[:, :, None], jac], axis=-1)
        f = _filtered(cols, filt) * w[None, :, None]
        ys.append(f[:, :, 0])
        jacs.append(f[:, :, 1:])
    prior = np.array([r.prior_sd if r.prior_sd else np.inf for r in refits])
    return _Prediction(np.concatenate(ys), np.concatenate(jacs), tuple(keys), prior)


def refit_lack_of_fit(truth: np.ndarray, rival: _Prediction) -> tuple[np.ndarray, float]:
    """The rival's refit to ``truth``: its data residual (M, 2) and the prior's penalty ``|delta / s|^2``."""
    d = truth - rival.y
    k = rival.jac.shape[-1]
    if k == 0:
        return d, 0.0
    a = rival.jac.reshape(-1, k)
    norm = np.linalg.norm(a, axis=0)
    keep = norm > 1e-12 * max(float(norm.max(initial=0.0)), 1e-300)
    if not keep.any():
        return d, 0.0
    a, norm, prior = a[:, keep] / norm[keep], norm[keep], rival.prior[keep]
    ridge = np.where(np.isfinite(prior), 1.0 / (norm * np.where(np.isfinite(prior), prior, 1.0)), 0.0)
    lhs = np.vstack([a, np.diag(ridge)])
    rhs = np.concatenate([d.reshape(-1), np.zeros(len(ridge))])
    z, *_ = np.linalg.lstsq(lhs, rhs, rcond=1e-10)
    res = d - (a @ z).reshape(d.shape)
    return res, float(np.sum((ridge * z) ** 2))


def score_entry(
    entry: MenuEntry,
    alternatives: Sequence[Alternative],
    params: Params,
    floors: Mapping[str, float],
    residual: ResidualSettings | None = None,
    logs: Sequence[RunLog] | None = None,
) -> EntryScore:
    """The predicted separation of ``alternatives`` on ``entry`` (simulated on the baseline unless ``logs``).

    The SNR after the rival's refit (module docstring, step 3), the least separated pair; ``snr_fixed`` with
    every alternative held at its fitted values.
    """
    rs = residual or ResidualSettings()
    if logs is None:
        logs = simulate_plan(RunPlan(runs=list(entry.runs)), PlantConfig.from_profile("ideal"), params, seed=0)
    filt = ZeroPhaseFilter(rs, float(np.median(np.diff(logs[0].t))))
    consts = {r.key: r for alt in alternatives for r in alt.refits(params) if r.key.startswith("p.")}
    preds = {}
    for alt in alternatives:
        own = [r for r in alt.refits(params) if not r.key.startswith("p.")]
        preds[alt.name] = _predict(alt, [*own, *consts.values()], logs, entry.runs, params, floors, filt, rs.fc_hz)
    worst: tuple[float, dict[str, float], tuple[str, str], float] | None = None
    for i, a in enumerate(alternatives):
        for b in alternatives[i + 1 :]:
            pa, pb = preds[a.name], preds[b.name]
            fixed = float(np.sqrt(np.sum((pa.y - pb.y) ** 2)))
            # either may be the truth: the direction the rival absorbs best counts (maximin)
            fits = [refit_lack_of_fit(truth.y, rival) for truth, rival in ((pa, pb), (pb, pa))]
            t, res = min(((float(np.sum(r**2)) + pen, r) for r, pen in fits), key=lambda x: x[0])
            total = math.sqrt(t)
            per = {ch: float(np.sqrt(np.sum(res[:, c] ** 2))) for c, ch in enumerate(CHANNELS)}
            if worst is None or total < worst[0]:
                worst = (total, per, (a.name, b.name), fixed)
    if worst is None:
        raise ValueError("a design needs at least two alternatives")
    snr, per, pair, fixed = worst
    scale = math.sqrt(60.0 / entry.duration_s)
    return EntryScore(entry.name, snr, snr * scale, per, pair, fixed)


def design(
    alternatives: Sequence[Alternative],
    params: Params,
    floors: Mapping[str, float],
    *,
    menu: Iterable[MenuEntry] | None = None,
    residual: ResidualSettings | None = None,
    target_snr: float = 10.0,
    max_duration_s: float = 300.0,
    progress: bool = False,
) -> Design:
    """Choose the menu entry that best separates ``alternatives`` and write it as a run plan.

    Parameters
    ----------
    alternatives : sequence of Alternative
        The fitted alternatives of a confusable slot (two or more).
    params : Params
        The baseline model's constants (the trajectory is simulated with them).
    floors : mapping
        ``{"vertical": sigma, "horizontal": sigma}``: the diagnosis's held-out noise floors [m/s^2].
    menu : iterable of MenuEntry, optional
        Excitations to choose from (default :func:`default_menu`).
    residual : ResidualSettings, optional
        The diagnosis's residual filter.
    target_snr : float
        Predicted SNR the plan's runs are repeated to reach.
    max_duration_s : float
        Most running time the plan may take [s].
    progress : bool
        A tqdm bar over the menu.

    Returns
    -------
    Design
        The plan (runs, predicted SNR, why) and every entry's score.
    """
    if len(alternatives) < 2:
        raise ValueError("a design needs at least two alternatives")
    entries = list(menu if menu is not None else default_menu())
    it: Iterable[MenuEntry] = entries
    if progress:
        from tqdm import tqdm

        it = tqdm(entries, desc="experiment design", unit="excitation", leave=False)
    scores = tuple(score_entry(e, alternatives, params, floors, residual) for e in it)
    best_i = int(np.argmax([s.snr_per_minute for s in scores]))
    best, entry = scores[best_i], entries[best_i]
    repeats = 1
    if best.snr > 0:
        want = math.ceil((target_snr / best.snr) ** 2)
        repeats = int(max(1, min(want, max_duration_s // max(entry.duration_s, 1e-9))))
    snr = best.snr * math.sqrt(repeats)
    ranked = sorted(scores, key=lambda s: -s.snr_per_minute)
    runner_up = ranked[1] if len(ranked) > 1 else None
    why = (
        f"{entry.purpose}: the alternatives {' and '.join(best.pair)} predict residuals that differ by SNR "
        f"{best.snr_per_minute:.1f} per minute of running after either refits its effect parameters and the "
        f"calibrated constants to the other (vertical {best.per_channel['vertical']:.1f}, "
        f"horizontal {best.per_channel['horizontal']:.1f} on one pass; {best.snr_fixed:.1f} with nothing refitted)"
        + (f"; next best {runner_up.name} at {runner_up.snr_per_minute:.1f} per minute" if runner_up else "")
        + ("; below the target even at the time cap" if snr < target_snr else "")
    )
    plan = RunPlan(
        excitation=entry.name,
        slot=[a.name for a in alternatives],
        predicted_snr=round(snr, 3),
        why=why,
        runs=list(entry.runs) * repeats,
    )
    return Design(plan, best, scores, repeats)


__all__ = [
    "CHANNELS",
    "Alternative",
    "Design",
    "EntryScore",
    "MenuEntry",
    "Refit",
    "constant_refit",
    "default_menu",
    "design",
    "effect_accelerations",
    "pair_snr",
    "refit_lack_of_fit",
    "score_entry",
    "sensitivities",
]
