"""Metrics of a closed-loop run: settling, steady-state accuracy, currents, stops, solver health, timing.

Per target (the target is active from its switch time for its ``hold``):

``settled``
    Both axes of the TRUE state stay within ``tolerance`` of the target from
    some instant to the end of the hold, for at least ``min_settled_s``.
``settle_time_s``
    From the target switch to that instant (``null`` if not settled).
``rms_error_g_m``, ``rms_error_d_m``
    Steady RMS error of the true state: over the settled part once the planned
    reference has arrived (from the later of the settle instant and the end of
    the planned move; the whole settled part if the plan has not arrived
    within the hold). A minimum-time move enters the 0.1 mm band 1-3 ms before
    its plan ends, and the plan's own approach inside the band (about 3.5 µm
    RMS over a 0.3 s hold after a 50 m/s^2 braking, with a perfect tracker) is
    tracking, not steady-state error. ``*_enc_m`` the same on the encoder
    readings (what the rig would report).
``max_abs_error_g_settled_m``, ``max_abs_error_d_settled_m``
    Largest error of the true state over the same steady part.
``rms_tracking_error_g_m``, ``rms_tracking_error_d_m``
    RMS error of the true state against the planned reference over the whole
    hold, the move included (where model errors such as cogging show before
    the disturbance observer has absorbed them).
``max_current_A``
    Largest commanded current amplitude ``sqrt(i_q^2 + i_d^2)`` during the hold.

Overall: ``all_settled``, ``stop_hits``, ``solver_failures``, ``fallbacks``,
``step_time_us`` (median, p99, max of the controller's computation), the
largest currents, and ``passed`` with the list of ``failed_checks``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import constants as k

#: Status texts that count as a solver failure.
FAILURE_STATUSES = frozenset({"failed", "error", "infeasible", "fallback", "nan", "max_iter"})

_LIMIT_SLACK = 1e-9  # currents are compared with the limits up to rounding [A]


def _none_if_nan(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def _truthy(col: np.ndarray) -> np.ndarray:
    """0/1 view of a logged stats column (numbers, booleans, or text)."""
    if col.dtype.kind in "fiub":
        c = col.astype(float)
        return np.where(np.isfinite(c), c != 0, False)
    return np.array([str(v).strip().lower() in ("1", "true", "yes") for v in col])


@dataclass
class TargetMetrics:
    """Metrics of one target (see the module docstring)."""

    index: int
    g: float
    d: float
    hold: float
    t_switch: float
    move_time_s: float
    settled: bool
    settle_time_s: float | None
    rms_error_g_m: float | None
    rms_error_d_m: float | None
    rms_error_g_enc_m: float | None
    rms_error_d_enc_m: float | None
    max_abs_error_g_settled_m: float | None
    max_abs_error_d_settled_m: float | None
    final_error_g_m: float
    final_error_d_m: float
    max_current_A: float
    max_abs_i_q_A: float
    max_abs_i_d_A: float
    rms_tracking_error_g_m: float | None = None
    rms_tracking_error_d_m: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for ``metrics.json``."""
        return dict(self.__dict__)

    as_dict = to_dict


@dataclass
class Metrics:
    """All metrics of a run; :meth:`to_dict` is ``metrics.json``."""

    scenario: str
    controller: str
    seed: int
    tolerance_m: float
    duration_s: float
    n_steps: int
    targets: list[TargetMetrics]
    all_settled: bool
    stop_hits: int
    stop_events: list[str]
    solver_failures: int
    solver_inaccurate: int
    fallbacks: int
    unreachable_steps: int
    step_time_us: dict[str, float | None]
    max_current_A: float
    max_abs_i_q_A: float
    max_abs_i_d_A: float
    currents_within_limits: bool
    max_settle_time_s: float | None
    max_rms_error_g_m: float | None
    max_rms_error_d_m: float | None
    error: str | None = None
    failed_checks: list[str] = field(default_factory=list)
    #: Why the controller's model file is not to be relied on (its writer marked it ``trusted: false``, e.g.
    #: ``maglev calibrate --force``); ``None`` for a trusted or no model file. Flags the result, does not fail it.
    model_untrusted: str | None = None

    @property
    def passed(self) -> bool:
        """All tolerance checks hold and the run finished."""
        return not self.failed_checks and self.error is None

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for ``metrics.json`` (targets as a list)."""
        d = {k_: v for k_, v in self.__dict__.items() if k_ != "targets"}
        d["targets"] = [t.to_dict() for t in self.targets]
        d["passed"] = self.passed
        return d

    as_dict = to_dict

    def table(self) -> str:
        """Text view: one row per target, then the overall figures."""
        head = (
            f"{'#':>3} {'g [mm]':>7} {'d [mm]':>8} {'settled':>7} {'t_s [s]':>8} {'rms g [µm]':>10} "
            f"{'rms d [µm]':>10} {'enc g [µm]':>10} {'enc d [µm]':>10} {'max |i| [A]':>11}"
        )
        lines = [f"scenario {self.scenario} (controller {self.controller}, seed {self.seed})", head, "-" * len(head)]

        def um(v: float | None) -> str:
            return "-" if v is None else f"{v * 1e6:.2f}"

        for t in self.targets:
            lines.append(
                f"{t.index:3d} {t.g * 1e3:7.2f} {t.d * 1e3:8.2f} {'yes' if t.settled else 'NO':>7} "
                f"{'-' if t.settle_time_s is None else f'{t.settle_time_s:.3f}':>8} {um(t.rms_error_g_m):>10} "
                f"{um(t.rms_error_d_m):>10} {um(t.rms_error_g_enc_m):>10} {um(t.rms_error_d_enc_m):>10} "
                f"{t.max_current_A:11.2f}"
            )
        st = self.step_time_us
        med = "-" if st.get("median") is None else f"{st['median']:.0f}"
        p99 = "-" if st.get("p99") is None else f"{st['p99']:.0f}"
        lines.append(
            f"all settled: {'yes' if self.all_settled else 'NO'}; stop hits: {self.stop_hits}; "
            f"solver failures: {self.solver_failures}; fallbacks: {self.fallbacks}; "
            f"max |i| {self.max_current_A:.2f} A; step time median {med} us, p99 {p99} us"
        )
        if self.error:
            lines.append(f"ERROR: {self.error}")
        if self.model_untrusted:
            lines.append(f"UNTRUSTED MODEL: {self.model_untrusted}")
        lines.append("PASS" if self.passed else "FAIL: " + "; ".join(self.failed_checks or ["run did not finish"]))
        return "\n".join(lines)


def target_metrics(
    index: int,
    t: np.ndarray,
    x_true: np.ndarray,
    y_enc: np.ndarray,
    u: np.ndarray,
    target: Any,
    t_switch: float,
    move_time: float,
    tolerance: float,
    min_settled_s: float,
    Ts: float = k.Ts,
    ref: np.ndarray | None = None,
) -> TargetMetrics:
    """Metrics of one target from the samples of its hold (see the module docstring).

    Parameters
    ----------
    index : int
        Target number.
    t, x_true, y_enc, u : ndarray
        Time, true state (N, 4), encoder readings (N, 2) and commanded currents
        (N, 2) of the samples inside the hold.
    target : Target
        The target (``g``, ``d``, ``hold``).
    t_switch, move_time : float
        Switch time and planned move duration [s].
    tolerance, min_settled_s : float
        Positioning tolerance [m] and the shortest settled part that counts [s].
    Ts : float
        Sample period [s].
    ref : ndarray, optional
        Planned reference positions ``(g, d)`` at ``t`` (N, 2), for the tracking error.
    """
    n = len(t)
    nan = math.nan
    if n == 0:
        return TargetMetrics(
            index,
            target.g,
            target.d,
            target.hold,
            t_switch,
            move_time,
            False,
            None,
            None,
            None,
            None,
            None,
            None,
            None,
            nan,
            nan,
            nan,
            nan,
            nan,
        )
    eg, ed = x_true[:, 0] - target.g, x_true[:, 2] - target.d
    inside = (np.abs(eg) <= tolerance) & (np.abs(ed) <= tolerance)
    bad = np.flatnonzero(~inside)
    i0 = 0 if bad.size == 0 else int(bad[-1]) + 1  # first sample of the final in-tolerance stretch
    settled_len = (n - i0) * Ts
    settled = i0 < n and settled_len >= min_settled_s - 1e-12
    amp = np.hypot(u[:, 0], u[:, 1])
    if settled:
        # steady errors once the planned move (it starts at the switch) has arrived, inside the settled part
        i_ss = max(i0, int(np.searchsorted(t, t_switch + move_time - 1e-9)))
        sl = slice(i_ss if i_ss < n else i0, n)
        eg_e, ed_e = y_enc[sl, 0] - target.g, y_enc[sl, 1] - target.d
        rms = [float(np.sqrt(np.mean(v**2))) for v in (eg[sl], ed[sl], eg_e, ed_e)]
        mx = [float(np.max(np.abs(eg[sl]))), float(np.max(np.abs(ed[sl])))]
        ts = float(t[i0] - t_switch)
    else:
        rms = [None] * 4
        mx = [None, None]
        ts = None
    return TargetMetrics(
        index=index,
        g=float(target.g),
        d=float(target.d),
        hold=float(target.hold),
        t_switch=float(t_switch),
        move_time_s=float(move_time),
        settled=bool(settled),
        settle_time_s=ts,
        rms_error_g_m=rms[0],
        rms_error_d_m=rms[1],
        rms_error_g_enc_m=rms[2],
        rms_error_d_enc_m=rms[3],
        max_abs_error_g_settled_m=mx[0],
        max_abs_error_d_settled_m=mx[1],
        final_error_g_m=float(eg[-1]),
        final_error_d_m=float(ed[-1]),
        max_current_A=float(np.max(amp)),
        max_abs_i_q_A=float(np.max(np.abs(u[:, 0]))),
        max_abs_i_d_A=float(np.max(np.abs(u[:, 1]))),
        rms_tracking_error_g_m=None if ref is None else float(np.sqrt(np.mean((x_true[:, 0] - ref[:, 0]) ** 2))),
        rms_tracking_error_d_m=None if ref is None else float(np.sqrt(np.mean((x_true[:, 2] - ref[:, 1]) ** 2))),
    )


def compute_metrics(
    *,
    scenario: str,
    controller: str,
    seed: int,
    t: np.ndarray,
    x_true: np.ndarray,
    y_enc: np.ndarray,
    u: np.ndarray,
    plan: Any,
    tolerance: float,
    checks: Any,
    stats: dict[str, np.ndarray],
    step_time_us: np.ndarray,
    stop_events: list[Any],
    error: str | None = None,
    Ts: float = k.Ts,
    i_axis_max: float = k.i_axis_max,
    i_amp_max: float = k.i_amp_max,
) -> Metrics:
    """Compute every metric of a run.

    Parameters
    ----------
    scenario, controller : str
        Names (for the record).
    seed : int
        Seed of the run.
    t, x_true, y_enc, u : ndarray
        Logged time (N,), true state (N, 4), encoder readings (N, 2), commanded currents (N, 2).
    plan : ReferencePlan
        The run's reference plan (targets, switch times, moves).
    tolerance : float
        Positioning tolerance [m].
    checks : Checks
        The scenario's tolerance checks.
    stats : dict of str to ndarray
        Logged controller statistics (``solver_failure``, ``status``, ``fallback``, ``unreachable``, ...).
    step_time_us : ndarray
        Controller computation time per step [µs].
    stop_events : list
        The plant's stop events.
    error : str, optional
        Why the run stopped early, if it did.
    Ts : float
        Sample period [s].
    i_axis_max, i_amp_max : float
        Current limits checked [A].
    """
    t = np.asarray(t, float)
    tms = []
    for i, tg in enumerate(plan.targets):
        t0 = float(plan.switch_times[i])
        t1 = t0 + tg.hold
        sel = (t >= t0 - 1e-9) & (t < t1 - 1e-9)
        ref = plan.sample(t[sel])[:, [0, 3]] if sel.any() else None
        tms.append(
            target_metrics(
                i,
                t[sel],
                x_true[sel],
                y_enc[sel],
                u[sel],
                tg,
                t0,
                plan.moves[i].T,
                tolerance,
                checks.min_settled_s,
                Ts,
                ref=ref,
            )
        )
    n = len(t)
    fail = np.zeros(n, bool)
    inacc = np.zeros(n, bool)
    if "solver_failure" in stats:
        fail |= _truthy(stats["solver_failure"])
    if "status" in stats:
        st = np.array([str(v).strip().lower() for v in stats["status"]])
        fail |= np.isin(st, list(FAILURE_STATUSES))
        inacc |= st == "inaccurate"
    fb = _truthy(stats["fallback"]) if "fallback" in stats else np.zeros(n, bool)
    unr = _truthy(stats["unreachable"]) if "unreachable" in stats else np.zeros(n, bool)
    stt = np.asarray(step_time_us, float)
    stt = stt[np.isfinite(stt)]
    step = {
        "median": _none_if_nan(float(np.median(stt))) if stt.size else None,
        "p99": _none_if_nan(float(np.percentile(stt, 99))) if stt.size else None,
        "max": _none_if_nan(float(np.max(stt))) if stt.size else None,
    }
    amp = np.hypot(u[:, 0], u[:, 1]) if n else np.zeros(0)
    max_amp = float(np.max(amp)) if n else 0.0
    max_q = float(np.max(np.abs(u[:, 0]))) if n else 0.0
    max_d = float(np.max(np.abs(u[:, 1]))) if n else 0.0
    within = max_amp <= i_amp_max + _LIMIT_SLACK and max(max_q, max_d) <= i_axis_max + _LIMIT_SLACK
    settled_all = bool(tms) and all(tm.settled for tm in tms)
    sts = [tm.settle_time_s for tm in tms if tm.settle_time_s is not None]
    rg = [tm.rms_error_g_m for tm in tms if tm.rms_error_g_m is not None]
    rd = [tm.rms_error_d_m for tm in tms if tm.rms_error_d_m is not None]
    m = Metrics(
        scenario=scenario,
        controller=controller,
        seed=int(seed),
        tolerance_m=float(tolerance),
        duration_s=float(n * Ts),
        n_steps=n,
        targets=tms,
        all_settled=settled_all,
        stop_hits=len(stop_events),
        stop_events=[str(e) for e in stop_events],
        solver_failures=int(fail.sum()),
        solver_inaccurate=int(inacc.sum()),
        fallbacks=int(fb.sum()),
        unreachable_steps=int(unr.sum()),
        step_time_us=step,
        max_current_A=max_amp,
        max_abs_i_q_A=max_q,
        max_abs_i_d_A=max_d,
        currents_within_limits=bool(within),
        max_settle_time_s=max(sts) if sts and settled_all else None,
        max_rms_error_g_m=max(rg) if rg else None,
        max_rms_error_d_m=max(rd) if rd else None,
        error=error,
    )
    m.failed_checks = failed_checks(m, checks)
    return m


def failed_checks(m: Metrics, checks: Any) -> list[str]:
    """The scenario's tolerance checks that ``m`` fails, each as a short sentence."""
    out = []
    if m.error:
        out.append(f"run stopped: {m.error}")
    if checks.all_settled and not m.all_settled:
        bad = [str(t.index) for t in m.targets if not t.settled]
        out.append(f"targets not settled within {m.tolerance_m * 1e3:g} mm: {', '.join(bad)}")
    if checks.no_stop_hits and m.stop_hits:
        out.append(f"{m.stop_hits} stop hit(s)")
    if checks.currents_within_limits and not m.currents_within_limits:
        out.append(f"currents beyond the limits (max |i| {m.max_current_A:.3f} A)")
    if checks.max_settle_time_s is not None:
        slow = [
            f"{t.index} ({t.settle_time_s:.3f} s)"
            for t in m.targets
            if t.settle_time_s is not None and t.settle_time_s > checks.max_settle_time_s
        ]
        if slow:
            out.append(f"settle time above {checks.max_settle_time_s:g} s: {', '.join(slow)}")
    if checks.max_rms_error_m is not None:
        lim = checks.max_rms_error_m
        big = [str(t.index) for t in m.targets if (t.rms_error_g_m or 0) > lim or (t.rms_error_d_m or 0) > lim]
        if big:
            out.append(f"steady-state RMS error above {lim * 1e6:g} µm: targets {', '.join(big)}")
    return out


# ------------------------------------------------------------------ disturbances
@dataclass
class DisturbanceMetrics:
    """How a controller rode out one scheduled disturbance (``plant.disturbances``).

    The hold window runs from the disturbance's start to the next disturbance,
    the next target switch or the end of the run, whichever comes first. A
    payload or a cable stays on through the later moves, so its window is the
    rest of the run (recovery is still judged in the hold window). Errors are
    of the TRUE state against the reference (the held target). Disturbances
    that start together count as one (``kind`` joined by ``+``).

    Attributes
    ----------
    index : int
        Position in ``plant.disturbances``.
    kind : str
        Its ``type`` (``force_pulse``, ``force_step``, ``payload``, ``cable``).
    t_start, t_end : float
        The window [s].
    peak_error_g_m, peak_error_d_m : float
        Largest absolute error per axis in the window [m].
    recovery_time_s : float or None
        From the start until both axes are back within the tolerance for good
        (to the end of the hold window); 0 if they never left it, None if they
        are not back by the end of it, and None for a cable (its effect on
        each move shows in the targets' settle times).
    stop_hits : int
        Stop impacts in the window.
    max_current_A : float
        Largest commanded current amplitude in the window [A].
    time_at_limit_s : float
        Time the commanded currents sat on a current limit (either axis within
        1 mA of ``i_axis_max`` or the amplitude within 1 mA of ``i_amp_max``) [s].
    rms_error_after_m : float or None
        RMS error (both axes together) from recovery to the end of the window [m] (a payload's or a
        cable's window holds the later moves: then it is a tracking error against the plan).
    """

    index: int
    kind: str
    t_start: float
    t_end: float
    peak_error_g_m: float
    peak_error_d_m: float
    recovery_time_s: float | None
    stop_hits: int
    max_current_A: float
    time_at_limit_s: float
    rms_error_after_m: float | None

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON)."""
        return dict(self.__dict__)


def disturbance_events(disturbances: list) -> list[tuple[int, str, float]]:
    """``(index, type, start time)`` of the scheduled disturbances, in time order.

    Disturbances that start together are one event: the index of the first,
    their types joined by ``+``.
    """
    ev: dict[float, tuple[int, list[str]]] = {}
    for i, d in enumerate(disturbances):
        t0 = float(d.time if d.type == "payload" else d.start)
        _, kinds = ev.setdefault(t0, (i, []))
        kinds.append(d.type)
    return [(i, "+".join(kinds), t0) for t0, (i, kinds) in sorted(ev.items())]


def disturbance_metrics(
    columns: dict[str, np.ndarray],
    disturbances: list,
    stop_times: list[float],
    tolerance: float = k.position_tolerance,
    i_axis_max: float = k.i_axis_max,
    i_amp_max: float = k.i_amp_max,
    Ts: float = k.Ts,
) -> list[DisturbanceMetrics]:
    """Metrics of each scheduled disturbance of a run (see :class:`DisturbanceMetrics`).

    Parameters
    ----------
    columns : dict of str to ndarray
        The run's log columns (``t``, ``g_true``, ``d_true``, ``g_ref``, ``d_ref``,
        ``g_target``, ``d_target``, ``i_q``, ``i_d``), as the runner writes them.
    disturbances : list
        The plant's ``disturbances`` settings.
    stop_times : list of float
        Times of the run's stop impacts [s].
    tolerance : float
        Positioning tolerance [m].
    i_axis_max, i_amp_max : float
        Current limits [A] (the time at the limit is counted against them).
    Ts : float
        Control period [s].
    """
    t = np.asarray(columns["t"], dtype=float)
    if not len(t):
        return []
    eg = np.abs(columns["g_true"] - columns["g_ref"])
    ed = np.abs(columns["d_true"] - columns["d_ref"])
    iq, id_ = np.asarray(columns["i_q"], float), np.asarray(columns["i_d"], float)
    amp = np.hypot(iq, id_)
    at_lim = (np.maximum(np.abs(iq), np.abs(id_)) >= 0.995 * i_axis_max) | (amp >= 0.995 * i_amp_max)
    tg = np.stack([columns["g_target"], columns["d_target"]], axis=1)
    switches = t[1:][np.any(tg[1:] != tg[:-1], axis=1)]
    events = disturbance_events(disturbances)
    t_run_end = float(t[-1]) + Ts
    out = []
    for j, (idx, kind, t0) in enumerate(events):
        ends = [t_run_end, *[e[2] for e in events[j + 1 :] if e[2] > t0], *switches[switches > t0 + 1e-9]]
        t_hold = min(ends)
        persistent = "payload" in kind or "cable" in kind
        t1 = t_run_end if persistent else t_hold
        w = (t >= t0 - 1e-9) & (t < t1 - 1e-9)
        if not w.any():
            continue
        tw, egw, edw = t[w], eg[w], ed[w]
        n_hold = int(np.sum(tw < t_hold - 1e-9))
        outside = np.nonzero((egw[:n_hold] > tolerance) | (edw[:n_hold] > tolerance))[0]
        if not len(outside):
            rec: float | None = 0.0
            after = slice(0, len(tw))
        elif outside[-1] == n_hold - 1:
            rec, after = None, slice(len(tw), len(tw))
        else:
            rec = float(tw[outside[-1] + 1] - t0)
            after = slice(outside[-1] + 1, len(tw))
        if "cable" in kind:
            rec, after = None, slice(0, len(tw))
        e2 = egw[after] ** 2 + edw[after] ** 2
        out.append(
            DisturbanceMetrics(
                index=idx,
                kind=kind,
                t_start=t0,
                t_end=t1,
                peak_error_g_m=float(egw.max()),
                peak_error_d_m=float(edw.max()),
                recovery_time_s=rec,
                stop_hits=sum(1 for ts in stop_times if t0 - 1e-9 <= ts < t1 + Ts),
                max_current_A=float(amp[w].max()),
                time_at_limit_s=float(at_lim[w].sum() * Ts),
                rms_error_after_m=float(np.sqrt(e2.mean())) if len(e2) else None,
            )
        )
    return out


def run_disturbance_metrics(result: Any) -> list[DisturbanceMetrics]:
    """:func:`disturbance_metrics` of a :class:`maglev_ocp.runner.RunResult` (its plant's disturbances).

    The current limits are the controller's own (``i_axis_max``, ``i_amp_max``
    or ``current_limit`` in its settings) where it has them, else the amplifier's.
    """
    sc = result.scenario
    st = sc.controller.settings
    i_amp = float(getattr(st, "i_amp_max", getattr(st, "current_limit", k.i_amp_max)))
    i_axis = float(getattr(st, "i_axis_max", k.i_axis_max))
    # StopEvent text: "t = 0.123 s: g hit its lower stop at ..."
    stops = [float(m.group(1)) for e in result.metrics.stop_events if (m := re.match(r"t = ([-\d.eE+]+) s", e))]
    return disturbance_metrics(result.columns, list(sc.plant_config().disturbances), stops, sc.tolerance, i_axis, i_amp)


def disturbance_rows(name: str, result: Any) -> list[dict[str, Any]]:
    """One plain row per scheduled disturbance of a run (scenario, controller, targets settled, the metrics)."""
    n_ok = sum(tm.settled for tm in result.metrics.targets)
    base = {
        "scenario": name,
        "controller": result.metrics.controller,
        "settled": f"{n_ok}/{len(result.metrics.targets)}",
    }
    return [{**base, **dm.to_dict()} for dm in run_disturbance_metrics(result)]


# Cells of the disturbance table: ``cell(value, row) -> text``.
def _text(v: Any, row: dict[str, Any]) -> str:
    return str(v)


def _um(v: float | None, row: dict[str, Any]) -> str:
    return "-" if v is None else f"{v * 1e6:.1f}"


def _ms(v: float, row: dict[str, Any]) -> str:
    return f"{v * 1e3:.0f}"


def _recovery_ms(v: float | None, row: dict[str, Any]) -> str:
    return "-" if "cable" in row["kind"] else "never" if v is None else f"{v * 1e3:.0f}"


def _fixed(spec: str) -> Callable[[float, dict[str, Any]], str]:
    return lambda v, row: f"{v:{spec}}"


#: Columns of :func:`disturbance_table`: header, row key, text width/alignment, cell format.
_DIST_COLS: tuple[tuple[str, str, str, Callable[[Any, dict[str, Any]], str]], ...] = (
    ("scenario", "scenario", "<24", _text),
    ("ctrl", "controller", ">5", _text),
    ("disturbance", "kind", ">12", _text),
    ("t0 [s]", "t_start", ">7", _fixed(".3f")),
    ("peak g [µm]", "peak_error_g_m", ">11", _um),
    ("peak d [µm]", "peak_error_d_m", ">11", _um),
    ("back in tol [ms]", "recovery_time_s", ">16", _recovery_ms),
    ("stops", "stop_hits", ">5", _text),
    ("max|i| [A]", "max_current_A", ">10", _fixed(".2f")),
    ("at limit [ms]", "time_at_limit_s", ">13", _ms),
    ("rms after [µm]", "rms_error_after_m", ">14", _um),
    ("settled", "settled", ">8", _text),
)


def disturbance_table(rows: list[dict[str, Any]], markdown: bool = False) -> str:
    """Table of :func:`disturbance_rows`: who rides each disturbance out better (NMPC vs FL side by side).

    Rows are sorted by scenario name, so name the runs of one disturbance
    alike (``push_g_fl``, ``push_g_nmpc``). ``markdown=True`` gives a Markdown table.
    """
    rows = sorted(rows, key=lambda r: (r["scenario"], r["index"]))
    if markdown:
        from .markdown import md_table

        return md_table(
            [h for h, _, _, _ in _DIST_COLS], ([cell(r[key], r) for _, key, _, cell in _DIST_COLS] for r in rows)
        )
    head = " ".join(f"{h:{fmt}}" for h, _, fmt, _ in _DIST_COLS)
    lines = [head, "-" * len(head)]
    lines += [" ".join(f"{cell(r[key], r):{fmt}}" for _, key, fmt, cell in _DIST_COLS) for r in rows]
    return "\n".join(lines)


__all__ = [
    "FAILURE_STATUSES",
    "DisturbanceMetrics",
    "Metrics",
    "TargetMetrics",
    "compute_metrics",
    "disturbance_events",
    "disturbance_metrics",
    "disturbance_rows",
    "disturbance_table",
    "failed_checks",
    "run_disturbance_metrics",
    "target_metrics",
]
