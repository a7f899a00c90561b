"""Physical size and closed-loop consequence of a fitted effect; the augmented model as a plant file.

For every effect a diagnosis finds:

- **force**: the effect's force over the states the data visited,
  ``F = M (a_aug - a_base)`` per axis (``M = Mv`` vertical, ``Mh`` horizontal),
  with ``a_base`` the same fitted constants without the effect; peak and rms in
  N, and the peak in % of the stage's weight ``Mv G``;
- **delay** of a lag in µs (the fitted effective delay of the amplifier);
- **closed-loop consequence**: a short scenario (three targets across the
  envelope) run with the shipped controllers (feedback linearization and NMPC)
  on the shared model — the ``ideal`` plant profile with the diagnosis's
  constants — once without and once with the fitted effect in the plant,
  controllers unaware of it. The added tracking error in µm is the effect's
  consequence; if it adds less than :data:`NEGLIGIBLE_M` (a tenth of the
  0.1 mm goal) to either controller's largest tracking error, the effect is
  *detectable but negligible*.

The fitted model is also written as a plant file (:func:`plant_file`):
``mismatch.overrides`` hold the constants, ``effects`` every library effect
(switched on with its fitted law, or off). :func:`maglev_ocp.plant.load_plant_config`
loads it, so a plant (and a scenario's ``plant: {file: model.yaml}``) runs the
augmented model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .. import constants as k
from ..effects import EFFECTS, EffectSet
from ..errors import ConfigError
from ..signals import PARAM_NAMES
from .fit import FitResult, accel_series, lag_features
from .library import CandidateSpec
from .residuals import PreparedRun

#: The positioning goal [m] (0.1 mm).
GOAL_M: float = 1e-4
#: An effect that adds less than this to the closed-loop error is negligible for the goal [m].
NEGLIGIBLE_M: float = 0.1 * GOAL_M
#: Constants a plant file can hold (``mismatch.overrides``).
PLANT_PARAMS: tuple[str, ...] = ("C1", "C2", "C3", "C4", "xi0", "ell", "Mh", "Mv")
#: Targets of the consequence scenario (gap, position, hold): across the tracking envelope.
CONSEQUENCE_TARGETS: tuple[tuple[float, float, float], ...] = (
    (0.015, 0.0, 0.15),
    (0.016, 0.02, 0.15),
    (0.024, -0.02, 0.15),
)


# ---------------------------------------------------------------- plant-file view
def plant_effects(spec: CandidateSpec, fit: FitResult | None, p: np.ndarray) -> tuple[dict, dict, list[str]]:
    """The fitted model as plant-file blocks.

    Parameters
    ----------
    spec : CandidateSpec
        The fitted candidate (or the baseline).
    fit : FitResult or None
        Its fit (None: the baseline).
    p : ndarray
        The baseline parameter vector (fitted ``p.*`` entries replace its values).

    Returns
    -------
    params : dict
        ``{name: value}`` of the constants (for ``mismatch.overrides``).
    effects : dict
        ``{effect: {"enabled": bool, param: value}}`` for every library effect.
    dropped : list of str
        Fitted keys a plant file cannot hold (laws outside the plant's effects).
    """
    w = fit.w if fit is not None else np.zeros(len(spec.free))
    values = {f.key: float(v) for f, v in zip(spec.free, w, strict=True)}
    pv = np.array(p, float)
    for key, v in values.items():
        if key.startswith("p."):
            pv[PARAM_NAMES.index(key[2:])] = v
    params = {n: float(pv[PARAM_NAMES.index(n)]) for n in PLANT_PARAMS if n in PARAM_NAMES}
    effects: dict[str, dict] = {n: {"enabled": False} for n in EFFECTS}
    ties, fixed = dict(spec.ties), dict(spec.fixed)
    used: set[str] = set()
    for name in spec.effects:
        es = EffectSet((name,))
        dflt = dict(zip(es.param_names, es.defaults(), strict=True))
        block: dict = {"enabled": True}
        for key in es.param_names:
            if key in values:
                v = values[key]
            elif key in ties:
                v = values.get(ties[key], fixed.get(ties[key], dflt[key]))
                used.add(ties[key])
            elif key in fixed:
                v = fixed[key]
            else:
                v = dflt[key]
            used.add(key)
            q = next(x for x in EFFECTS[name].params if f"{name}.{x.name}" == key)
            if q.hi - q.lo == 2 * math.pi:
                # A phase whose plant range is one period: the fit searches a wider range (two periods, so a
                # start near the bound is not stuck there), and 6.281 rad is -0.002 rad, never the bound pi
                # (clamped, a harmonic of cogging came out with its sign flipped in the model file).
                v = float((float(v) - q.lo) % (2 * math.pi) + q.lo)
            # Solver round-off may step a hair outside the plant's range (e.g. -1e-12 for a bound at 0).
            v = min(max(float(v), q.lo), q.hi)
            block[key.split(".", 1)[1]] = round(v) if q.integer else v
        effects[name] = block
    if spec.lag and fit is not None:
        effects["amplifier_lag"] = {
            "enabled": True,
            "bandwidth_hz": float(fit.extra.get("bandwidth_hz", 2000.0)),
            "delay_samples": int(fit.extra.get("delay_samples", 0)),
        }
    dropped = sorted(kk for kk in values if not kk.startswith("p.") and kk not in used)
    return params, effects, dropped


def plant_file(params: dict, effects: dict, profile: str = "default") -> dict:
    """A complete plant-file mapping (loadable by :func:`maglev_ocp.plant.load_plant_config`).

    The constants go to ``mismatch.overrides`` with no random spread; the
    profile supplies noise, quantization, limits and stops.
    """
    return {
        "profile": profile,
        "mismatch": {
            "relative": {n: 0.0 for n in PLANT_PARAMS},
            "overrides": {n: v for n, v in params.items() if not (n == "ell" and v <= 0)},
        },
        "effects": effects,
    }


# ------------------------------------------------------------------------ force
def effect_force(
    spec: CandidateSpec,
    fit: FitResult,
    runs: Sequence[PreparedRun],
    u_runs: Sequence[np.ndarray],
    p: np.ndarray,
) -> np.ndarray:
    """The effect's force ``(n, 2)`` [N] over the visited periods: ``M (a_aug - a_same_constants_without)``."""
    pv = np.array(p, float)
    for f, v in zip(spec.free, fit.w, strict=True):
        if f.key.startswith("p."):
            pv[PARAM_NAMES.index(f.key[2:])] = v
    # Constants the candidate moves belong to the model, not to the effect: keep them on both sides,
    # except the cogging law's (xi0, ell) against a cogging-blind baseline (xi0 = 0), where it *is* the effect.
    p_off = pv.copy()
    if p[PARAM_NAMES.index("xi0")] == 0.0 and any(f.key in ("p.xi0",) for f in spec.free):
        p_off[PARAM_NAMES.index("xi0")] = 0.0
    base = CandidateSpec("baseline")
    out = []
    for i, run in enumerate(runs):
        if len(run.Z) == 0:
            continue
        Z = run.Z
        if spec.lag and i < len(u_runs):
            Z = lag_features(run.Z, u_runs[i], fit.extra)  # the fitted member's amplifier (any law)
        a_aug = accel_series(spec, Z, pv, fit.w)
        a_off = accel_series(base, run.Z, p_off, np.zeros(0))
        da = a_aug - a_off
        da[:, ~run.valid] = np.nan
        out.append(da)
    if not out:
        return np.zeros((0, 2))
    da = np.vstack(out)
    return da * np.array([pv[PARAM_NAMES.index("Mv")], pv[PARAM_NAMES.index("Mh")]])


# ------------------------------------------------------------- closed loop
def _overrides(params: dict) -> dict:
    return {n: float(v) for n, v in params.items() if n in PLANT_PARAMS and not (n == "ell" and v <= 0)}


def consequence_scenario(
    controller: str, params: dict, effects: dict, seed: int = 1, controller_params: dict | None = None
) -> dict:
    """The consequence scenario for ``controller`` on the ``ideal`` plant with ``params`` and ``effects``.

    The controller believes ``controller_params`` (default ``params``).
    """
    return {
        "name": f"consequence_{controller}",
        "description": "effect consequence: three targets across the envelope on the shared model",
        "seed": seed,
        "controller": {"type": controller},
        "controller_params": _overrides(controller_params if controller_params is not None else params),
        "plant": {
            "profile": "ideal",
            "mismatch": {"overrides": _overrides(params)},
            "effects": effects,
        },
        "targets": [{"g": g, "d": d, "hold": h} for g, d, h in CONSEQUENCE_TARGETS],
    }


def _errors(res) -> dict[str, float]:
    """Tracking error of a run: max |e| and rms over the holds' second halves (settled) [m]."""
    c = res.columns
    eg, ed = c["g_true"] - c["g_ref"], c["d_true"] - c["d_ref"]
    e = np.hypot(eg, ed)
    return {"max_m": float(np.max(np.abs(e))), "rms_m": float(np.sqrt(np.mean(e**2)))}


def closed_loop_consequence(
    params: dict,
    effects: dict,
    params_without: dict | None = None,
    controllers: Sequence[str] = ("fl", "nmpc"),
    seed: int = 1,
) -> dict[str, dict]:
    """Tracking error of each controller without and with ``effects`` in the plant (see the module docstring).

    Parameters
    ----------
    params, effects : dict
        Constants and effects of the plant with the effect (plant-file blocks).
    params_without : dict, optional
        Constants without the effect (default ``params``; differs for cogging,
        whose law lives in ``xi0``). The controllers believe these in both runs.
    controllers : sequence of str
        Shipped controllers to run.
    seed : int
        Scenario seed.

    Returns
    -------
    dict
        ``{controller: {"without_max_m", "with_max_m", "without_rms_m", "with_rms_m", "added_max_m",
        "added_rms_m", "diff_max_m"}}``; ``diff_max_m`` is the largest distance between the two
        trajectories (same seed, same references), the effect's own footprint.
    """
    from ..codegen.loop_c import run_scenario_on  # the loop choice (codegen is heavy to import)

    off = {n: {"enabled": False} for n in EFFECTS}
    p0 = params_without if params_without is not None else params
    out = {}
    for ctrl in controllers:
        a = run_scenario_on(consequence_scenario(ctrl, p0, off, seed))  # the compiled loop where it can run
        b = run_scenario_on(consequence_scenario(ctrl, params, effects, seed, p0))
        ea, eb = _errors(a), _errors(b)
        n = min(len(a.columns["t"]), len(b.columns["t"]))
        dg = a.columns["g_true"][:n] - b.columns["g_true"][:n]
        dd = a.columns["d_true"][:n] - b.columns["d_true"][:n]
        out[ctrl] = {
            "without_max_m": ea["max_m"],
            "with_max_m": eb["max_m"],
            "without_rms_m": ea["rms_m"],
            "with_rms_m": eb["rms_m"],
            "added_max_m": eb["max_m"] - ea["max_m"],
            "added_rms_m": eb["rms_m"] - ea["rms_m"],
            "diff_max_m": float(np.max(np.hypot(dg, dd))) if n else math.nan,
        }
    return out


# ------------------------------------------------------------------------ sizes
@dataclass
class EffectSize:
    """Physical size and consequence of one fitted effect.

    Attributes
    ----------
    name : str
        Effect (or model) name.
    peak_force_n, rms_force_n : dict
        ``{"g": ..., "d": ...}`` over the visited states [N].
    peak_force_pct_weight : float
        Largest peak force in % of the weight ``Mv G``.
    delay_us, delay_stderr_us : float or None
        Effective delay of a lag [µs].
    closed_loop : dict
        :func:`closed_loop_consequence` (empty if not simulated).
    matters : bool or None
        The effect adds at least :data:`NEGLIGIBLE_M` to either controller's largest
        tracking error (None: not simulated).
    summary : str
        One line: size, consequence and whether it matters for the goal.
    dropped : list of str
        Fitted keys the plant could not carry into the simulation.
    """

    name: str
    peak_force_n: dict[str, float]
    rms_force_n: dict[str, float]
    peak_force_pct_weight: float
    delay_us: float | None = None
    delay_stderr_us: float | None = None
    closed_loop: dict[str, dict] = field(default_factory=dict)
    matters: bool | None = None
    summary: str = ""
    dropped: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready view."""
        return dict(self.__dict__)


def effect_in_model(
    single: CandidateSpec, model: FitResult, p: np.ndarray
) -> tuple[CandidateSpec, FitResult, np.ndarray] | None:
    """One effect as it was fitted inside a joint model: its own parameters, the model's constants.

    An effect's size must be the one of the model the user loads (the joint model of
    every effect found, whose values go to the model file), not of its single-effect
    fit: alone, an effect also absorbs the misfit of the others (a lag beside friction
    alone fitted an effective delay of 1 µs; in the joint model, 1.35 ms against the
    rig's 1.28 ms).

    Parameters
    ----------
    single : CandidateSpec
        The effect's own candidate (which effects and keys are its).
    model : FitResult
        The joint model's fit (its ``spec`` holds every effect found).
    p : ndarray
        The baseline parameter vector.

    Returns
    -------
    (spec, fit, p) or None
        The effect's candidate with the joint model's values of its own keys (the
        constants the joint model fitted, other than the effect's own, folded into
        ``p``), or None when the model does not hold the effect's keys.
    """
    mine = tuple(f"{e}." for e in single.effects)
    tied = {b for _, b in single.ties}
    own = {f.key for f in single.free if f.key.startswith(mine) or f.key in tied}
    keys = [f.key for f in model.spec.free]
    if not own <= set(keys) or (single.lag and not model.spec.lag):
        return None
    pv = np.array(p, float)
    for key, v in zip(keys, model.w, strict=True):
        if key.startswith("p.") and key not in own:
            pv[PARAM_NAMES.index(key[2:])] = float(v)
    idx = [i for i, key in enumerate(keys) if key in own]
    spec = replace(
        single,
        free=tuple(model.spec.free[i] for i in idx),
        fixed=tuple(x for x in model.spec.fixed if x[0].startswith(mine)),
        ties=tuple(x for x in model.spec.ties if x[0].startswith(mine)),
    )
    extra = dict(model.extra) if single.lag else {}
    fit = FitResult(spec, model.w[idx], model.stderr[idx], model.sse, model.n, model.inflation, extra,
                    model.success, model.status)  # fmt: skip
    return spec, fit, pv


def effect_size(
    name: str,
    spec: CandidateSpec,
    fit: FitResult,
    runs: Sequence[PreparedRun],
    u_runs: Sequence[np.ndarray],
    p: np.ndarray,
    simulate: bool = True,
    Ts: float = k.Ts,
) -> EffectSize:
    """Force, delay and closed-loop consequence of a fitted effect (see the module docstring)."""
    F = effect_force(spec, fit, runs, u_runs, p)
    peak, rms = {}, {}
    for j, ax in enumerate(("g", "d")):
        col = F[:, j] if len(F) else np.zeros(0)
        col = col[np.isfinite(col)]
        peak[ax] = float(np.max(np.abs(col))) if len(col) else 0.0
        rms[ax] = float(np.sqrt(np.mean(col**2))) if len(col) else 0.0
    pv = np.array(p, float)
    weight = pv[PARAM_NAMES.index("Mv")] * k.G
    size = EffectSize(name, peak, rms, 100.0 * max(peak.values()) / weight)
    if spec.lag and "effective_delay_s" in fit.extra:
        size.delay_us = 1e6 * float(fit.extra["effective_delay_s"])
        se = fit.extra.get("effective_delay_s_stderr")
        size.delay_stderr_us = 1e6 * float(se) if se is not None and np.isfinite(se) else None
    params, effects, dropped = plant_effects(spec, fit, p)
    size.dropped = dropped
    note = ""
    if simulate:
        # Without the effect: the same fitted constants; against a cogging-blind baseline, no cogging law.
        xi_base = float(pv[PARAM_NAMES.index("xi0")])
        p0 = dict(params, xi0=xi_base) if xi_base == 0.0 else params
        try:
            size.closed_loop = closed_loop_consequence(params, effects, p0)
        except ConfigError as exc:  # fitted constants no shipped controller accepts: said, not simulated
            note = f"; closed loop not simulated ({exc})"
        if size.closed_loop:
            # What the goal bounds is the tracking error: the effect matters if it adds a tenth of the goal to it.
            added = max(v["added_max_m"] for v in size.closed_loop.values())
            size.matters = bool(added >= NEGLIGIBLE_M)
    size.summary = _summary(size, Ts) + note
    return size


def _summary(s: EffectSize, Ts: float) -> str:
    parts = [
        f"peak force {s.peak_force_n['g']:.3g} N (g) / {s.peak_force_n['d']:.3g} N (d), "
        f"{s.peak_force_pct_weight:.2g} % of the weight"
    ]
    if s.delay_us is not None:
        parts.append(f"delay {s.delay_us:.0f} µs ({s.delay_us * 1e-6 / Ts:.2f} of the {Ts * 1e3:g} ms period)")
    if s.closed_loop:
        parts.append(
            "closed loop: "
            + ", ".join(
                f"{c.upper()} max error {v['without_max_m'] * 1e6:.1f} -> {v['with_max_m'] * 1e6:.1f} µm "
                f"(trajectories differ by up to {v['diff_max_m'] * 1e6:.1f} µm)"
                for c, v in s.closed_loop.items()
            )
        )
        parts.append(
            "matters for the 0.1 mm goal"
            if s.matters
            else f"detectable but negligible for the 0.1 mm goal (< {NEGLIGIBLE_M * 1e6:.0f} µm)"
        )
    return f"{s.name}: " + "; ".join(parts)


__all__ = [
    "CONSEQUENCE_TARGETS",
    "GOAL_M",
    "NEGLIGIBLE_M",
    "EffectSize",
    "closed_loop_consequence",
    "consequence_scenario",
    "effect_force",
    "effect_in_model",
    "effect_size",
    "plant_effects",
    "plant_file",
]
