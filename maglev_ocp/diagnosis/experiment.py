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
   adds to the shared model);
3. the difference of two alternatives is passed through the diagnosis's
   residual low-pass (:class:`~maglev_ocp.diagnosis.residuals.ZeroPhaseFilter`)
   and compared with the channel's noise floor ``sigma_c`` (the held-out floor of
   the diagnosis): ``SNR^2 = sum_c (rms_c / sigma_c)^2 * 2 f_c T``, with
   ``2 f_c T`` the independent samples the filter leaves in a run of length
   ``T`` (a channel a fixture locks has no residual). A slot with more than two
   alternatives is scored by its least separated pair.

Entries are compared at equal running time (the SNR per minute), and the
chosen plan repeats its runs until the predicted SNR reaches the target (or
the time cap). The alternatives are held at their fitted parameters; what a
refit on the pooled data can still absorb is decided by the diagnosis on both
datasets (``maglev diagnose run DATA1 DATA2``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..effects import EffectSet, effect_delta_function
from ..loop.run_plan import RunPlan, RunSpec, simulate_plan
from ..model import get_model
from ..params import Params
from ..plant import PlantConfig
from ..riglog import RunLog
from .residuals import ResidualSettings, ZeroPhaseFilter

#: Channels of the residual, in the order of the effect accelerations (vertical g, horizontal d).
CHANNELS: tuple[str, str] = ("vertical", "horizontal")


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
    """

    name: str
    effects: tuple[str, ...]
    params: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    constants: Mapping[str, float] = field(default_factory=dict)

    def theta(self) -> np.ndarray:
        """The parameter vector in the effect library's order."""
        return EffectSet(self.effects).vector(self.params)


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
        Predicted SNR of the least separated pair on the entry as it is.
    snr_per_minute : float
        ``snr`` scaled to one minute of running (``snr sqrt(60 / T)``): the design criterion.
    per_channel : dict
        ``{channel: SNR}`` of the least separated pair.
    pair : tuple of str
        The least separated pair.
    """

    name: str
    snr: float
    snr_per_minute: float
    per_channel: dict[str, float]
    pair: tuple[str, str]


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


def effect_accelerations(alt: Alternative, log: RunLog, params: Params) -> np.ndarray:
    """What ``alt`` adds to the baseline model's accelerations along ``log``, shape (N, 2) [m/s^2].

    Its effects' accelerations (:func:`~maglev_ocp.effects.effect_delta_function`) plus, when its fit moved
    model constants, the shared model's change with them (MODEL.md's equations with the alternative's constants).
    """
    x, u = _state_inputs(log)
    n = len(x)
    out = np.zeros((n, 2))
    p_alt = params.with_(**alt.constants) if alt.constants else params
    p = np.tile(np.asarray(p_alt.vector(), float)[:, None], (1, n))
    if alt.effects:
        f = effect_delta_function(tuple(alt.effects)).map(n)
        th = np.tile(alt.theta()[:, None], (1, n))
        out += np.asarray(f(x.T, u.T, p, th), float).T
    if alt.constants:
        fm = get_model().f.map(n)
        p0 = np.tile(np.asarray(params.vector(), float)[:, None], (1, n))
        fa, f0 = np.asarray(fm(x.T, u.T, p), float), np.asarray(fm(x.T, u.T, p0), float)
        out += (fa - f0)[[1, 3], :].T
    return out


def _filtered(sig: np.ndarray, filt: ZeroPhaseFilter) -> np.ndarray:
    """The residual low-pass applied to a per-period signal (valid part only)."""
    if len(sig) <= len(filt.h):
        return np.zeros(0)
    return np.convolve(sig, filt.h, mode="valid")


def pair_snr(
    a: np.ndarray,
    b: np.ndarray,
    lock: str,
    floors: Mapping[str, float],
    filt: ZeroPhaseFilter,
    fc_hz: float,
    Ts: float,
) -> dict[str, float]:
    """Per-channel SNR of the filtered difference of two effect accelerations on one run."""
    out = {}
    for c, (ch, axis) in enumerate(zip(CHANNELS, ("g", "d"), strict=True)):
        if lock == axis:
            out[ch] = 0.0  # the fixture takes the force: no residual on this channel
            continue
        diff = _filtered(a[:, c] - b[:, c], filt)
        if diff.size == 0:
            out[ch] = 0.0
            continue
        n_eff = 2.0 * fc_hz * diff.size * Ts
        out[ch] = float(np.sqrt(np.mean(diff**2) * n_eff) / max(floors[ch], 1e-12))
    return out


def score_entry(
    entry: MenuEntry,
    alternatives: Sequence[Alternative],
    params: Params,
    floors: Mapping[str, float],
    residual: ResidualSettings | None = None,
    logs: Sequence[RunLog] | None = None,
) -> EntryScore:
    """The predicted separation of ``alternatives`` on ``entry`` (simulated on the baseline unless ``logs``)."""
    rs = residual or ResidualSettings()
    if logs is None:
        logs = simulate_plan(RunPlan(runs=list(entry.runs)), PlantConfig.from_profile("ideal"), params, seed=0)
    filt = ZeroPhaseFilter(rs, float(np.median(np.diff(logs[0].t))))
    accel = {alt.name: [effect_accelerations(alt, lg, params) for lg in logs] for alt in alternatives}
    worst: tuple[float, dict[str, float], tuple[str, str]] | None = None
    for i, a in enumerate(alternatives):
        for b in alternatives[i + 1 :]:
            ch2 = dict.fromkeys(CHANNELS, 0.0)
            for run, ea, eb in zip(entry.runs, accel[a.name], accel[b.name], strict=True):
                for ch, v in pair_snr(ea, eb, run.lock, floors, filt, rs.fc_hz, filt.Ts).items():
                    ch2[ch] += v * v
            total = math.sqrt(sum(ch2.values()))
            if worst is None or total < worst[0]:
                worst = (total, {c: math.sqrt(v) for c, v in ch2.items()}, (a.name, b.name))
    if worst is None:
        raise ValueError("a design needs at least two alternatives")
    snr, per, pair = worst
    return EntryScore(entry.name, snr, snr * math.sqrt(60.0 / entry.duration_s), per, pair)


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
        f"{best.snr_per_minute:.1f} per minute of running (vertical {best.per_channel['vertical']:.1f}, "
        f"horizontal {best.per_channel['horizontal']:.1f} on one pass)"
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
    "default_menu",
    "design",
    "effect_accelerations",
    "pair_snr",
    "score_entry",
]
