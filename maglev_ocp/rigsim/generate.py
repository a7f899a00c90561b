"""Diagnosis datasets from the independent rig, with a truth record.

:func:`generate` draws the rig's true constants (off nominal), simulates the
closed loop on the excitation of :mod:`.excite` with the requested effects,
writes a ``maglev-rig-log/1`` dataset (:mod:`maglev_ocp.riglog`) and a
``truth.json`` beside ``dataset.yaml`` in the same folder: the effects with
their law family and parameters, the true constants and each effect's peak
force [N] along the simulated trajectory (for scoring a diagnosis later).
Nothing of the truth goes into ``dataset.yaml``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from .. import constants as k
from ..output import atomic_write_text
from ..riglog import RunLog, write_dataset
from .excite import references
from .laws import Law
from .laws_new import AmplifierNew
from .laws_v18 import EFFECTS_V18, make_law
from .physics import NOMINAL, Constants
from .sim import Rig, RigSettings, Trajectory, simulate

TRUTH_FORMAT = "rigsim-truth/1"
EffectsArg = Mapping[str, Mapping[str, Any] | None] | Iterable[str | Law] | None


def build_laws(effects: EffectsArg) -> list[Law]:
    """Effects from ``{name: {"family": ..., param: value}}``, a list of names / Law objects, or None."""
    if effects is None:
        return []
    if isinstance(effects, Mapping):
        laws = [make_law(n, spec) for n, spec in effects.items()]
    else:
        laws = [e if isinstance(e, Law) else make_law(e) for e in effects]
    names = [law.name for law in laws]
    if len(set(names)) != len(names):
        raise ValueError(f"each effect at most once, got {names}")
    order = list(EFFECTS_V18)
    return sorted(laws, key=lambda law: order.index(law.name))


def expected_verdict(laws: Iterable[Law]) -> str:
    """What a diagnosis should answer: the library effects joined by ``+``, ``unexplained`` or ``none``."""
    laws = list(laws)
    lib = sorted(law.name for law in laws if law.library)
    if lib:
        return "+".join(lib)
    return "unexplained" if laws else "none"


def generate(
    out_dir: str | os.PathLike,
    effects: EffectsArg = None,
    seed: int = 0,
    settings: RigSettings | None = None,
    constants: Constants | None = None,
) -> Path:
    """Simulate the rig with ``effects`` and write a dataset with its ``truth.json``.

    Parameters
    ----------
    out_dir : path
        Dataset folder (created).
    effects : dict, list or None
        ``{name: {"family": ..., param: value, ...}}`` (unspecified parameters take the family's
        defaults), a list of effect names / :class:`~.laws.Law` objects, or None for none.
    seed : int
        Seeds the true constants, the excitation and the noise (``numpy.random.SeedSequence``).
    settings : RigSettings, optional
        Noise, limits, runs and excitation (default: the diagnosis-sized rig).
    constants : Constants, optional
        True constants (default: nominal, drawn off by ``settings.mismatch``).

    Returns
    -------
    Path
        The dataset folder.
    """
    settings = settings or RigSettings()
    laws = build_laws(effects)
    s_const, s_ref, s_noise = np.random.SeedSequence(int(seed)).spawn(3)
    true = constants or NOMINAL.drawn(np.random.default_rng(s_const), settings.mismatch)
    n_steps = round(settings.duration / settings.Ts)
    ref = references(settings.n_runs, n_steps, settings.Ts, settings.excitation, np.random.default_rng(s_ref))
    rig = Rig(true, laws, settings)
    traj = simulate(rig, ref, np.random.default_rng(s_noise))
    folder = Path(out_dir)
    write_dataset(
        folder,
        _runs(traj, settings),
        settings.Ts,
        settings.resolution or k.encoder_resolution,
        meta={"generator": "maglev_ocp.rigsim", "seed": int(seed)},
        description="closed-loop excitation (min-jerk moves + dither) on the independent rig simulator",
    )
    truth = truth_record(rig, traj, laws, true, settings, seed)
    atomic_write_text(folder / "truth.json", json.dumps(truth, indent=2, sort_keys=True) + "\n")
    return folder


def _runs(traj: Trajectory, s: RigSettings) -> list[RunLog]:
    R = traj.X.shape[0]
    locks = (s.locked + [""] * R)[:R]
    runs = []
    for r in range(R):
        cols = {
            "t": traj.t,
            "g": traj.y[r, :, 0],
            "d": traj.y[r, :, 1],
            "i_q": traj.u[r, :, 0],
            "i_d": traj.u[r, :, 1],
            "g_ref": traj.ref[r, :, 0],
            "d_ref": traj.ref[r, :, 3],
        }
        runs.append(RunLog(f"run_{r:02d}.csv", cols, (locks[r],) if locks[r] else (), {"controller": "rigsim-fl-pid"}))
    return runs


# ----------------------------------------------------------------------------- truth
def _forces(rig: Rig, X: np.ndarray, I: np.ndarray, km, t=None) -> tuple[np.ndarray, np.ndarray]:
    """Total vertical and horizontal force on the mover [N] (without the frame's motion) at states ``X``
    (``t``: the dataset time of each state, for laws that read it)."""
    g, gd, d, dd = X[..., 0], X[..., 1], X[..., 2], X[..., 3]
    iq, idd = I[..., 0], I[..., 1]
    for law in rig.rotate_laws:
        iq, idd = law.rotate(iq, idd, d)
    for law in rig.rotate_at_laws:
        iq, idd = law.rotate_at(iq, idd, X, t)
    a_up, a_x = rig.magnetic(g, d, iq, idd, km)
    Fg, Fd = rig.c.Mv * (k.G - a_up), -rig.c.Mh * a_x
    for law in rig.force_laws:
        fg, fd = law.force(g, gd, d, dd)
        Fg, Fd = Fg + fg, Fd + fd
    for law in rig.force_i_laws:
        fg, fd = law.force_i(g, gd, d, dd, iq, idd)
        Fg, Fd = Fg + fg, Fd + fd
    return Fg, Fd


def effective_delay(family: str, p: dict[str, float], Ts: float) -> float:
    """Low-frequency group delay of an amplifier law [s]: its transport delay plus the lag's own, ``1 / omega_b``
    for a first-order lag and ``2 zeta / omega_n`` for a second-order one (the phase slope at zero frequency)."""
    delay = p.get("delay_samples", 0.0) * Ts
    if family == "first":
        delay += 1.0 / (2 * math.pi * p["bandwidth_hz"])
    elif family == "second":
        delay += 2 * p["zeta"] / (2 * math.pi * p["fn_hz"])
    return float(delay)


def effect_size(law: Law, rig: Rig, traj: Trajectory) -> dict[str, Any]:
    """Peak force of one effect along the trajectory [N] (per axis), and other sizes where forces do not apply.

    The force of an effect is the difference between the rig with only this effect and without
    effects, at the recorded true states and currents (the commanded ones; the delivered ones for the
    amplifier); hysteretic friction uses the recorded held force.
    """
    X, u = traj.X, traj.u
    base = Rig(rig.c, [], rig.s)
    one = Rig(rig.c, [law], rig.s)
    F0 = _forces(base, X, u, 1.0)
    out: dict[str, Any] = {}
    recorded: dict[str, Any] = {}
    if hasattr(law, "recorded"):  # a state the trajectory does not hold (laws_v4 ... v16): the law's own record
        recorded = law.recorded()
        out.update(recorded)
        F1 = F0
    elif law.name == "amplifier_lag":
        F1 = _forces(base, X, traj.i_amp, 1.0)
        if isinstance(law, AmplifierNew) or getattr(law, "lti", False):
            out["effective_delay_s"] = law.group_delay(rig.s.Ts)
        else:
            out["effective_delay_s"] = effective_delay(law.family, law.p, rig.s.Ts)
    elif law.name == "temperature_drift":
        F1 = _forces(base, X, u, traj.km)
        out["peak_field_change"] = float(np.max(np.abs(traj.km - 1.0)))
    elif law.name == "resonance":
        sdd = np.gradient(X[..., 5], traj.t, axis=1)
        F1 = (F0[0] + rig.c.Mv * sdd, F0[1])
        out["rms_m"] = float(np.sqrt(np.mean(X[..., 4] ** 2)))
    elif getattr(law, "has_read_at", False):
        t = np.arange(X.shape[0])[:, None] * rig.s.duration + traj.t[None, :]
        gr, dr = law.read_at(X[..., 0], X[..., 2], t)
        out["peak_error_g_m"] = float(np.max(np.abs(gr - X[..., 0])))
        out["peak_error_d_m"] = float(np.max(np.abs(dr - X[..., 2])))
        F1 = F0
    elif law.has_read:
        gr, dr = law.read(X[..., 0], X[..., 2])
        out["peak_error_g_m"] = float(np.max(np.abs(gr - X[..., 0])))
        out["peak_error_d_m"] = float(np.max(np.abs(dr - X[..., 2])))
        F1 = F0
    elif law.has_held:
        F1 = (F0[0] + traj.F_held[..., 0], F0[1] + traj.F_held[..., 1])
        if law.has_force:  # a smooth part beside the hysteretic one (the cable slab's spring)
            Fs = _forces(one, X, u, 1.0)
            F1 = (F1[0] + Fs[0] - F0[0], F1[1] + Fs[1] - F0[1])
    else:
        F1 = _forces(one, X, u, 1.0)
    pg = float(np.max(np.abs(F1[0] - F0[0])))
    pd = float(np.max(np.abs(F1[1] - F0[1])))
    out.update({"peak_force_n": max(pg, pd), "peak_force_g_n": pg, "peak_force_d_n": pd})
    out.update({a: b for a, b in recorded.items() if a.startswith("peak_force")})  # a force the law recorded
    return out


def truth_record(
    rig: Rig, traj: Trajectory, laws: list[Law], true: Constants, s: RigSettings, seed: int
) -> dict[str, Any]:
    """The truth of a generated dataset (what ``truth.json`` holds)."""
    effects = {}
    for law in laws:
        effects[law.name] = {**law.describe(), **effect_size(law, rig, traj)}
    settings = asdict(s)
    return {
        "format": TRUTH_FORMAT,
        "generator": "maglev_ocp.rigsim",
        "seed": int(seed),
        "expected_verdict": expected_verdict(laws),
        "effects": effects,
        "true_constants": true.as_dict(),
        "nominal_constants": NOMINAL.as_dict(),
        "weight_n": true.Mv * k.G,
        "settings": settings,
        "hover_error_rms_m": _tracking(traj),
    }


def _tracking(traj: Trajectory) -> dict[str, float]:
    """RMS of the reading minus the reference per axis (after the first second)."""
    n0 = min(1000, traj.y.shape[1] // 2)
    e = traj.y[:, n0:] - traj.ref[:, n0:][..., [0, 3]]
    return {"g": float(np.sqrt(np.mean(e[..., 0] ** 2))), "d": float(np.sqrt(np.mean(e[..., 1] ** 2)))}


__all__ = ["TRUTH_FORMAT", "build_laws", "effect_size", "expected_verdict", "generate", "truth_record"]
