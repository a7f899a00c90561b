"""Closed loops at compiled speed: a whole scenario in one C call.

:func:`run_scenario_compiled` runs a scenario like
:func:`maglev_ocp.runner.run_scenario`, except the loop: the plan, the plant's
run (:func:`maglev_ocp.loop.compiled.plant_inputs`: initial state, pre-drawn
noise, limits, stops, delay, disturbances) and the controller's reference
input of every step are prepared in Python as arrays; then ``run_loop``
(:mod:`.loop_c_source`) steps the plant's code-generated step Function
(:func:`maglev_ocp.plant.plant.build_step`, CasADi's code generator) and the
controller's compiled step (the ``nmpc``/``fl``/``pid`` code of :mod:`.functions`)
``n`` times, logging into preallocated arrays; the trace, columns and
metrics are then computed by the runner's own stages. The result equals the
Python loop's with the same compiled controller (``tests/test_compiled_loop.py``).

:func:`run_closed_loop_compiled` is the same for a rig-log run
(:func:`maglev_ocp.loop.run_closed_loop`'s signature and log) of the PID
regulators on a reference function, e.g. the diagnosis datasets'; :func:`rig_loop`
picks it or the Python loop (``loop: auto/python/compiled``).

Three shared libraries, each built once per machine in the code-generation
cache and loaded by each process:

* the controller's (``nmpc_init/nmpc_step``, ``fl_init/fl_step`` or ``pid_init/pid_step``): the very
  library ``backend: c`` uses (:func:`.backend.compile_codes`), found through a
  *design index* keyed by controller type, settings, believed parameters,
  reference mode, flags and a hash of the code that generates it, so a process
  that finds it loads it without building the CasADi Functions (the NMPC's take
  several seconds to build);
* the plant's step for its effect set, together with ``run_loop``
  (``-ffp-contract=off``: each operation rounds as in CasADi's virtual machine);
* both called by function pointer from ``run_loop``.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from maglev_ocp.controllers.fl import fl_delay_samples
from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.controllers.nmpc.layout import STATS_NAMES, STATUS_TEXT
from maglev_ocp.controllers.nmpc.reference import resolve_mode
from maglev_ocp.controllers.pid import PIDController, hover_error, pid_lead_samples
from maglev_ocp.controllers.preview import PlanPreview

from .. import constants as k
from ..blocks import Reference
from ..effects import EffectSet
from ..errors import UserError
from ..loop import run_closed_loop
from ..loop.compiled import PlantInputs, compiled_trace, plant_inputs, stop_events
from ..loop.drive import _events, _n_steps
from ..loop.recorders import RigLogRecorder
from ..plant import Plant
from ..plant.plant import build_step
from ..runner import RunPlan, RunResult, finish_run, plan_run
from ..scenario import Scenario
from .backend import compile_codes, default_cflags
from .build import cache_root, compiler_id, find_compiler
from .functions import fl_code, nmpc_code, pid_code
from .loader import CompiledFunction, CompiledLibrary
from .loop_c_source import LOOP_FIELDS, loop_c_source
from .sources import generate_function_source

#: Controller types the compiled loop runs (their steps are CasADi Functions).
COMPILED_TYPES = ("nmpc", "fl", "pid")

#: Flags of the loop + plant library: no FMA contraction, no fast-math (same rounding as CasADi's VM).
LOOP_CFLAGS = "-O2 -fno-math-errno -ffp-contract=off -fPIC"

_log = logging.getLogger(__name__)

_FT = {"i": ctypes.c_longlong, "d": ctypes.c_double, "p": ctypes.c_void_p}


class LoopStruct(ctypes.Structure):
    """ctypes mirror of ``loop_t`` (:data:`maglev_ocp.codegen.loop_c_source.LOOP_FIELDS`)."""

    _fields_ = [(name, _FT[t]) for name, t in LOOP_FIELDS]


# ----------------------------------------------------------------------------- cache
@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """Hash of the Python code that generates the C (``maglev_ocp/``, the controllers included) and CasADi's version."""
    h = hashlib.sha256(ca.__version__.encode())
    roots = [Path(__file__).resolve().parents[1]]
    for root in roots:
        for p in sorted(root.rglob("*.py")):
            h.update(str(p.relative_to(root.parent)).encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:20]


def _index_path(kind: str, key: str) -> Path:
    return cache_root() / "index" / f"{kind}-{key}.txt"


def _design_key(*parts: Any) -> str:
    return hashlib.sha256("\0".join(map(str, (code_version(), *parts))).encode()).hexdigest()[:24]


def _lookup(kind: str, key: str, lib_name: str) -> Path | None:
    p = _index_path(kind, key)
    if p.is_file():
        lib = Path(p.read_text().strip())
        if (lib / lib_name).is_file():
            return lib / lib_name
    return None


def _remember(kind: str, key: str, folder: Path) -> None:
    p = _index_path(kind, key)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(str(folder) + "\n")
    os.replace(tmp, p)


def _compile_shared(files: dict[str, str], lib_name: str, cflags: str) -> Path:
    """Compile ``files`` (all ``*.c``) into ``lib_name`` in the cache folder named by their content hash."""
    cc = find_compiler()
    if cc is None:
        raise UserError("no C compiler found (set CC or install cc/gcc/clang)")
    h = hashlib.sha256(f"{compiler_id(cc)}\0{cflags}".encode())
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    final = cache_root() / "loop" / h.hexdigest()[:20]
    if (final / lib_name).is_file():
        return final / lib_name
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".loop.", dir=final.parent))
    try:
        for name, text in files.items():
            (tmp / name).write_text(text)
        srcs = sorted(n for n in files if n.endswith(".c"))
        cmd = [cc, *cflags.split(), "-shared", "-o", lib_name, *srcs, "-lm"]
        proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True)
        if proc.returncode:
            tail = " | ".join(proc.stderr.strip().splitlines()[-4:])
            raise UserError(f"building the compiled loop failed: {tail}")
        try:
            os.rename(tmp, final)
        except OSError:  # another process finished first
            if not (final / lib_name).is_file():
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return final / lib_name


@functools.lru_cache(maxsize=16)
def plant_library(effects: tuple[str, ...], n_sub: int, dt: float) -> tuple[CompiledLibrary, str]:
    """The loaded library of ``run_loop`` and the plant step for an effect set; ``(library, step symbol)``."""
    key = _design_key("plant", effects, n_sub, repr(dt), LOOP_CFLAGS)
    name = "plant_" + ("_".join(EffectSet(effects).names) or "nominal") + f"_{n_sub}"
    lib = _lookup("plant", key, "libmaglev_loop.so")
    if lib is None:
        F = build_step(effects, n_sub, dt)
        src, hdr = generate_function_source(F)
        files = {"maglev_loop.c": loop_c_source(), f"{F.name()}.c": src, f"{F.name()}.h": hdr}
        lib = _compile_shared(files, "libmaglev_loop.so", LOOP_CFLAGS)
        _remember("plant", key, lib.parent)
        name = F.name()
    return CompiledLibrary(lib), name


@functools.lru_cache(maxsize=16)
def _controller_library(
    ctype: str, settings_json: str, pvec: tuple[float, ...], mode: str, cflags: str, model_hash: str = ""
):
    from ..params import Params

    params = Params.from_vector(np.array(pvec))
    key = _design_key(ctype, settings_json, pvec, mode, cflags, model_hash)
    lib = _lookup(ctype, key, "libmaglev_controller.so")
    if lib is None:
        if ctype == "nmpc":
            from maglev_ocp.controllers.nmpc import NMPCSettings

            code = nmpc_code(NMPCSettings.model_validate_json(settings_json), params, mode)
        elif ctype == "pid":
            from maglev_ocp.controllers.pid import PIDSettings

            code = pid_code(PIDSettings.model_validate_json(settings_json), params)
        else:
            from maglev_ocp.controllers.fl import FLSettings

            code = fl_code(FLSettings.model_validate_json(settings_json), params)
        b = compile_codes([code], cflags, progress=False)
        _remember(ctype, key, b.folder)
        lib = b.library
    return CompiledLibrary(lib)


def model_file_hash(settings: Any) -> str:
    """SHA-256 of the content of the settings' model file (``""`` without one).

    Part of the design key: the generated step bakes in the file's effects and delay, so a file
    changed at the same path is a new design (the settings hold only the path).
    """
    path = getattr(settings, "model", None)
    if not path:
        return ""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def controller_library(ctype: str, settings: Any, params: Any, mode: str = "", cflags: str | None = None):
    """The loaded ``backend: c`` library of a controller design (found through the design index, else built).

    The design key holds the settings, the believed parameters, the reference mode, the flags, the
    code's hash and the content hash of a model file (:func:`model_file_hash`)."""
    flags = cflags if cflags is not None else default_cflags()
    pvec = tuple(float(v) for v in params.vector())
    return _controller_library(ctype, settings.model_dump_json(), pvec, mode, flags, model_file_hash(settings))


# ----------------------------------------------------------------------- controllers
@dataclass
class ControllerRun:
    """A controller's part of one compiled run: its step, initial state, per-step inputs, outputs' layout."""

    step: CompiledFunction
    state0: np.ndarray
    consts: dict[int, np.ndarray]
    meas_n: int
    refs: np.ndarray
    fault: np.ndarray
    out_sizes: list[int]


def nmpc_refs(mode: str, rp: RunPlan, N: int, ahead: int = 0, period_mean: bool = False) -> np.ndarray:
    """The NMPC's ``ref`` input of every step (``n x 6(N+1)``, column-major per step), as its reference reads it.

    ``plan``: the active target on every node; ``preview``: the runner's plan at
    ``t + (ahead + j) Ts`` (``ahead``: the NMPC's computation delay; with
    ``period_mean`` the accelerations averaged over each period), held at its
    value just before the next target switch
    (:meth:`maglev_ocp.controllers.nmpc.reference.HorizonReference.matrix`).
    """
    n, Ts, plan = rp.n, k.Ts, rp.plan
    out = np.zeros((n, N + 1, 6))
    if mode == "plan":
        tgt = np.array([[tg.g, tg.d] for tg in plan.targets])
        idx = np.clip(np.searchsorted(plan.switch_times, rp.t, side="right") - 1, 0, len(plan.targets) - 1)
        out[:, :, 0] = tgt[idx, 0][:, None]
        out[:, :, 3] = tgt[idx, 1][:, None]
        return out.reshape(n, -1)
    S = plan.sample(np.arange(n + ahead + N + 1) * Ts, zoh=Ts if period_mean else None)
    j = np.arange(N + 1)
    out[:] = S[np.arange(n)[:, None] + ahead + j[None, :]]
    sw = np.asarray(plan.switch_times, dtype=float)
    t = (np.arange(n) + ahead) * Ts
    nxt = np.searchsorted(sw, t + 1e-9, side="right")  # first switch strictly after t + 1e-9
    held = {}  # the plan just before each switch, sampled once per switch
    for i in np.nonzero(nxt < len(sw))[0]:
        later = float(sw[nxt[i]])
        cut = (i + ahead + j) * Ts >= later - 1e-9
        if cut.any():
            if later not in held:
                held[later] = plan.sample(np.array([later - 1e-9]))[0]
            out[i, cut] = held[later]
    return out.reshape(n, -1)


def nmpc_loop_settings(settings: Any) -> Any:
    """The NMPC settings its step is built from: a model file's delay (transport delay plus the lag's time
    constant in whole periods) added to ``delay_samples`` (as :class:`~maglev_ocp.controllers.nmpc.NMPC` does), so
    the compiled loop's step predicts through it and its reference is read that many periods ahead."""
    from maglev_ocp.controllers.nmpc import NMPCSettings

    n = load_controller_model(settings.model).delay_periods() if settings.model else 0
    if not n:
        return settings
    return NMPCSettings.model_validate({**settings.model_dump(), "delay_samples": settings.delay_samples + n})


def _nmpc_run(sc: Scenario, rp: RunPlan, y0: np.ndarray, cflags: str | None) -> ControllerRun:
    s = nmpc_loop_settings(sc.controller.settings)
    params = _believed_params(sc)
    mode = resolve_mode(s.reference, rp.plan.shaping)
    lib = controller_library("nmpc", s, params, mode, cflags)
    init, step = lib.function("nmpc_init"), lib.function("nmpc_step")
    p = (params if s.use_cogging else params.without_cogging()).vector()
    refs = nmpc_refs(mode, rp, s.horizon, s.delay_samples, s.feedforward == "period_mean")
    (st0,) = init(np.array([y0[0], y0[1], 0.0]), refs[0], p)
    fault = np.zeros(rp.n)
    for i in s.force_failure_steps:
        if 0 <= i < rp.n:
            fault[i] = 1.0
    return ControllerRun(step, st0.copy(), {3: p}, 3, np.ascontiguousarray(refs), fault, step.out_sizes)


def _believed_params(sc: Scenario) -> Any:
    """The parameters a controller runs on: a model file's constants as the controllers load them
    (FL, PID and NMPC take the file's, whatever they are handed), else
    :meth:`~maglev_ocp.scenario.Scenario.controller_model_params`."""
    path = getattr(sc.controller.settings, "model", None)
    return load_controller_model(path).params if path else sc.controller_model_params()


def _fl_run(sc: Scenario, rp: RunPlan, y0: np.ndarray, cflags: str | None) -> ControllerRun:
    s = sc.controller.settings
    params = _believed_params(sc)
    lib = controller_library("fl", s, params, "", cflags)
    init, step = lib.function("fl_init"), lib.function("fl_step")
    (st0,) = init(np.asarray(y0, dtype=float))
    consts = {3: params.vector(), 4: np.asarray(s.gains(k.Ts), dtype=float)}
    refs = fl_refs(rp, fl_delay_samples(s))
    return ControllerRun(step, st0.copy(), consts, 2, np.ascontiguousarray(refs), np.zeros(rp.n), step.out_sizes)


def _pid_controller_run(
    settings: Any, params: Any, y0: np.ndarray, refs: np.ndarray, cflags: str | None, refs_ff: np.ndarray | None = None
):
    """The PID's part of a compiled run on ``refs`` (``n x 6``, ``signals.REF_FIELDS`` order).

    With a model file's lag (:func:`~maglev_ocp.controllers.pid.pid_lead_samples`) the step also takes the
    feed-forward's rows ``refs_ff`` (the plan that far ahead; without a plan, ``refs`` themselves, as the
    Python PID without one)."""
    if pid_lead_samples(settings):
        refs = np.hstack([refs, refs if refs_ff is None else refs_ff])
    lib = controller_library("pid", settings, params, "", cflags)
    init, step = lib.function("pid_init"), lib.function("pid_step")
    p = params.vector()
    (st0,) = init(np.asarray(y0, dtype=float), p)
    if not np.all(np.isfinite(st0)):  # as PIDController.reset
        raise hover_error(float(y0[0]), float(y0[1]))
    n = len(refs)
    return ControllerRun(step, st0.copy(), {3: p}, 2, np.ascontiguousarray(refs), np.zeros(n), step.out_sizes)


def _pid_run(sc: Scenario, rp: RunPlan, y0: np.ndarray, cflags: str | None) -> ControllerRun:
    s = sc.controller.settings
    lead = pid_lead_samples(s)
    refs_ff = fl_refs(rp, lead) if lead else None  # the rows PIDController's PlanPreview reads
    return _pid_controller_run(s, _believed_params(sc), y0, rp.refs, cflags, refs_ff)


def fl_refs(rp: RunPlan, delay: float) -> np.ndarray:
    """FL's ``ref`` input of every step (``n x 6``): the runner's rows, or with a delay of ``N`` samples the plan
    ``N`` samples ahead, as :meth:`maglev_ocp.controllers.fl.FeedbackLinearization.set_reference_plan` makes it read
    (and the PID's feed-forward rows, :class:`maglev_ocp.controllers.preview.PlanPreview`, ``N`` a fraction too)."""
    if not delay:
        return rp.refs
    pv = PlanPreview(rp.plan, delay, k.Ts)  # the very rows the controllers sample once
    n_plan = len(pv.rows)
    if rp.n <= n_plan:
        return pv.rows[: rp.n]
    later = rp.plan.sample(rp.t[n_plan:] + pv.lead * k.Ts, zoh=k.Ts)  # past the plan's end (PlanPreview.at there)
    return np.concatenate([pv.rows, later])


def _nmpc_stats(log: np.ndarray, t_us: np.ndarray) -> tuple[np.ndarray, dict, dict]:
    """x_hat, statistics and timings of the NMPC's logged outputs ``[u(2), stats, x_hat(4)]``."""
    ns = len(STATS_NAMES)
    sv = {name: log[:, 2 + i] for i, name in enumerate(STATS_NAMES)}
    status = sv["status"].astype(int)
    stats = {
        "status": [STATUS_TEXT.get(v, str(v)) for v in status.tolist()],
        "fallback": (sv["fallback"] != 0).astype(float),
        "iterations": np.trunc(sv["iterations"]),
        "iters_to_tol": np.trunc(sv["iters_to_tol"]),
        "qp_r_prim": sv["qp_r_prim"],
        "qp_r_dual": sv["qp_r_dual"],
        "dist_g": sv["dist_g"],
        "dist_d": sv["dist_d"],
    }
    timings = {"step_time_us": t_us, "kernel_us": t_us, "kernel_cpu_us": np.full(len(t_us), np.nan)}
    return log[:, 2 + ns : 6 + ns], stats, timings


def _fl_stats(log: np.ndarray, t_us: np.ndarray) -> tuple[np.ndarray, dict, dict]:
    """x_hat, statistics and timings of FL's logged outputs ``[u(2), x_hat(4), dist(2), v(2), flags]``."""
    zeros = np.zeros(len(t_us))
    stats = {
        "unreachable": np.trunc(log[:, 10]),
        "sat_g": np.trunc(log[:, 11]),
        "sat_d": np.trunc(log[:, 12]),
        "v_g": log[:, 8],
        "v_d": log[:, 9],
        "dist_g": log[:, 6],
        "dist_d": log[:, 7],
        "solver_failure": zeros,
        "fallback": zeros,
    }
    timings = {"kernel_us": t_us, "kernel_cpu_us": np.full(len(t_us), np.nan)}
    return log[:, 2:6], stats, timings


def _pid_stats(log: np.ndarray, t_us: np.ndarray) -> tuple[np.ndarray, dict, dict]:
    """x_hat, statistics and timings of the PID's logged outputs ``[u(2), x_hat(4), u_eq(2), flags(2)]``
    (as :meth:`maglev_ocp.controllers.pid.PIDController.step` reports them; ``fallback`` only if it happened)."""
    stats = {"i_q_eq": log[:, 6], "i_d_eq": log[:, 7], "saturated": (log[:, 8] != 0).astype(float)}
    if np.any(log[:, 9] != 0):
        stats["fallback"] = np.where(log[:, 9] != 0, 1.0, np.nan)
    return log[:, 2:6], stats, {}


# ------------------------------------------------------------------------------ loop
def _ptr(a: np.ndarray) -> int:
    return a.ctypes.data


class _Work:
    """Pointer tables and work arrays of one CasADi-convention C function."""

    def __init__(self, lib: CompiledLibrary, name: str):
        f = lib.function(name)
        self.fn = f
        self.addr = ctypes.cast(getattr(lib.lib, name), ctypes.c_void_p).value
        self.arg, self.res, self.iw, self.w = f._arg, f._resp, f._iw, f._w

    def fields(self, fn_field: str, prefix: str) -> dict[str, int]:
        """The ``loop_t`` fields that hand this function to the C loop: its address and work arrays."""
        return {
            fn_field: self.addr,
            f"{prefix}_arg": ctypes.addressof(self.arg),
            f"{prefix}_res": ctypes.addressof(self.res),
            f"{prefix}_iw": _ptr(self.iw),
            f"{prefix}_w": _ptr(self.w),
        }


def run_compiled_loop(pi: PlantInputs, plant: Plant, cr: ControllerRun, *, timing: bool = True) -> dict[str, Any]:
    """Run ``pi.n`` steps of plant and controller in one C call; the logged arrays and how the run ended.

    Returns
    -------
    dict
        ``Y, X, U, UA, limited, LOG, t_us, IMP`` (``done`` rows), ``done``, ``error`` (0 ok, 1 the
        controller's step failed, 2 non-finite currents, 3 the plant's step failed) and ``u_last``.
    """
    n = pi.n
    lib, pname = plant_library(plant.effects.names, plant.config.integrator.n_sub, plant.Ts)
    pw = _Work(lib, pname)
    # plant buffers (arguments of the step: xa, u, p, theta, w, free, lim; results: xa_next, impact, i_applied)
    xa, xa_out = pi.xa.copy(), np.zeros_like(pi.xa)
    u_in, pbuf, wbuf = np.zeros(2), pi.p_seq[0].copy(), np.zeros(4)
    imp, iapp = np.zeros(4), np.zeros(2)
    theta, free, lim = pi.theta.copy(), pi.free.copy(), pi.lim.copy()
    for i, a in enumerate((xa, u_in, pbuf, theta, wbuf, free, lim)):
        pw.arg[i] = _ptr(a)
    for i, a in enumerate((xa_out, imp, iapp)):
        pw.res[i] = _ptr(a)
    # controller buffers
    cw = _Work(cr.step.library, cr.step.name)
    ns = len(cr.state0)
    sa, sb = cr.state0.copy(), np.zeros(ns)
    meas = np.zeros(3)
    log_sizes = cr.out_sizes[:1] + cr.out_sizes[2:]
    lrow = np.zeros(sum(log_sizes))
    for i, c in cr.consts.items():
        c = np.ascontiguousarray(c, dtype=float)
        cr.consts[i] = c
        cw.arg[i] = _ptr(c)
    cw.arg[1] = _ptr(meas)
    cw.arg[2] = _ptr(cr.refs)
    off = 0
    for i, size in enumerate(cr.out_sizes):
        if i == 1:
            continue
        cw.res[i] = _ptr(lrow) + 8 * off
        off += size
    out = {
        "Y": np.zeros((n, 2)),
        "X": np.zeros((n, 4)),
        "U": np.zeros((n, 2)),
        "UA": np.zeros((n, 2)),
        "limited": np.zeros(n),
        "LOG": np.zeros((n, len(lrow))),
        "t_us": np.zeros(n),
        "IMP": np.zeros((n, 4)),
    }
    queue = np.ascontiguousarray(pi.queue).copy().reshape(-1)
    queue = queue if queue.size else np.zeros(2)
    cables = pi.cables.reshape(-1) if pi.cables.size else np.zeros(7)
    cstart = pi.cable_start if pi.cable_start.size else np.zeros(1, dtype=np.int64)
    std = np.ascontiguousarray(pi.std.reshape(-1))
    contact, y, ia = pi.contact.copy(), pi.y0.copy(), pi.ia0.copy()
    f_time = np.ascontiguousarray(pi.f_time)
    fl = pi.flags
    # the arrays the C loop reads and writes, by their ``loop_t`` field
    buffers = {
        **dict(xa=xa, xa_out=xa_out, u_in=u_in, pbuf=pbuf, wbuf=wbuf, imp=imp, iapp=iapp, lim=lim, queue=queue),
        **dict(pseq=pi.p_seq, std=std, n_proc=pi.noise["proc"], n_cur=pi.noise["cur"], n_meas=pi.noise["meas"]),
        **dict(f_time=f_time, cables=cables, cable_start=cstart, contact=contact, y=y, ia=ia),
        **dict(state_a=sa, state_b=sb, meas=meas, lrow=lrow, fault=cr.fault, refs=cr.refs),
        **out,
    }
    keep = [theta, free, *buffers.values()]  # alive until the C call returns
    s = LoopStruct(
        n=n,
        nxa=len(xa),
        np=len(pbuf),
        delay=len(pi.queue),
        log_size=len(lrow),
        ref_n=cr.refs.shape[1],
        meas_n=cr.meas_n,
        n_cables=len(pi.cables),
        state_in=0,
        state_out=1,
        meas_in=1,
        ref_in=2,
        u_off=0,
        timing=int(timing),
        **{key: fl[key] for key in ("lim_on", "proc_on", "cur_on", "meas_on", "lock_g", "lock_d", "stops_on")},
        has_force=fl["has_force"],
        has_payload=fl["has_payload"],
        i_axis=fl["i_axis"],
        i_amp=fl["i_amp"],
        q=fl["q"],
        **pw.fields("plant_f", "p"),
        **cw.fields("c_f", "c"),
        **{key: _ptr(a) for key, a in buffers.items()},
    )
    run = lib.lib.run_loop
    run.restype = ctypes.c_int
    run.argtypes = [ctypes.POINTER(LoopStruct)]
    run(ctypes.byref(s))
    del keep
    done = int(s.steps)
    res = {key: v[:done] for key, v in out.items()}
    res.update(done=done, error=int(s.error), u_last=lrow[:2].copy())
    return res


def _error_text(code: int, done: int, u_last: np.ndarray) -> str | None:
    if code == 0:
        return None
    t = done * k.Ts
    if code == 2:
        return f"controller returned non-finite currents {u_last.tolist()} at t = {t:.3f} s"
    what = "the compiled controller step" if code == 1 else "the compiled plant step"
    return f"controller raised at t = {t:.3f} s: RuntimeError: {what} returned an error"


def compiled_unsupported(sc: Scenario) -> str | None:
    """Why the compiled loop cannot run ``sc`` (None: it can).

    The compiled loop runs the controllers whose whole step is a CasADi Function with C code
    (:data:`COMPILED_TYPES`), model files included (their constants, delay and static effects
    are in the generated FL, PID and NMPC steps); not an NMPC on ``solver: osqp``, whose QP is a
    Python callback.
    """
    c = sc.controller
    if c.type not in COMPILED_TYPES:
        return f"the controller {c.type} has no compiled step (the compiled loop runs {', '.join(COMPILED_TYPES)})"
    if c.type == "nmpc" and c.settings.solver != "admm":
        return f"nmpc with solver: {c.settings.solver} (a Python callback; solver: admm is compiled)"
    return None


def compiled_supported(sc: Scenario) -> bool:
    """Whether the compiled loop can run ``sc`` (:func:`compiled_unsupported` has no reason against it)."""
    return compiled_unsupported(sc) is None


def run_scenario_compiled(
    sc: Scenario,
    seed: int | None = None,
    out_dir: str | os.PathLike | None = None,
    figures: bool = True,
    cflags: str | None = None,
) -> RunResult:
    """Run ``sc`` like :func:`maglev_ocp.runner.run_scenario`, the loop in one C call (see the module docstring).

    The controller is the scenario's on its compiled step (``backend: c``'s code, whatever the
    scenario's backend says); the plant is the Python plant's step Function code-generated.
    """
    t_wall = time.perf_counter()
    sc = sc.with_seed(seed)
    reason = compiled_unsupported(sc)
    if reason is not None:
        raise UserError(f"{sc.source}: the compiled loop cannot run this scenario: {reason}")
    rp = plan_run(sc)
    ss_plant, _ = sc.seed_sequences()
    plant = Plant(sc.plant_config(), params=sc.plant_params(), seed=ss_plant, Ts=k.Ts)
    pi = plant_inputs(plant, rp.n, np.array([sc.start.g, 0.0, sc.start.d, 0.0]))
    make = {"nmpc": _nmpc_run, "fl": _fl_run, "pid": _pid_run}[sc.controller.type]
    cr = make(sc, rp, pi.y0, cflags)
    r = run_compiled_loop(pi, plant, cr)
    done = r["done"]
    split = {"nmpc": _nmpc_stats, "fl": _fl_stats, "pid": _pid_stats}[sc.controller.type]
    x_hat, stats, timings = split(r["LOG"], r["t_us"])
    arrays = {key: r[key] for key in ("Y", "X", "U", "UA", "limited")}
    arrays["step_time_us"] = r["t_us"]
    trace = compiled_trace(rp.n, arrays, x_hat, stats, timings)
    plant.events = stop_events(r["IMP"], done, k.Ts)
    error = _error_text(r["error"], done, r["u_last"])
    return finish_run(sc, rp, trace, done, plant, error, t_wall, out_dir, figures)


# ------------------------------------------------------------------------- rig-log runs
def run_closed_loop_compiled(
    plant: Plant,
    controller: PIDController,
    reference: Callable[[float], Reference],
    duration: float,
    *,
    x0: np.ndarray | None = None,
    lock: str | None = None,
    file: str = "run.csv",
    progress: bool = False,
    desc: str | None = None,
    cflags: str | None = None,
):
    """:func:`maglev_ocp.loop.run_closed_loop` in one C call: the same log for the same plant and seeds.

    The PID regulators ``controller`` (its settings and believed parameters) run on their compiled step
    (``pid_step``); the plant's run is decided beforehand (:func:`maglev_ocp.loop.compiled.plant_inputs`:
    its next seed stream, pre-drawn noise, lock, limits, stops) and the reference is sampled in
    Python at every step exactly as the Python loop asks for it (a reference with a ``sample(t)`` method,
    rows ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` equal to its calls, is sampled at once). A failed step raises (as
    ``on_error="raise"``). ``progress`` and ``desc`` are accepted for the same signature (one C call
    of well under a second per run has no progress to show).

    Returns
    -------
    RunLog
        As :func:`maglev_ocp.loop.run_closed_loop`.
    """
    if not isinstance(controller, PIDController) or type(plant) is not Plant:
        raise UserError(
            f"the compiled rig-log loop runs PIDController on Plant, not {type(controller).__name__} "
            f"on {type(plant).__name__}"
        )
    Ts = plant.Ts
    if abs(Ts - k.Ts) > 1e-15 or abs(controller.Ts - k.Ts) > 1e-15:
        raise UserError(f"the compiled loop is generated for Ts = {k.Ts} s, got {Ts} / {controller.Ts}")
    n = _n_steps(duration, Ts)
    r0 = reference(0.0)
    if x0 is None:
        x0 = np.array([r0.g, 0.0, r0.d, 0.0])
    pi = plant_inputs(plant, n, np.asarray(x0, dtype=float), lock=lock)
    if hasattr(reference, "sample"):  # vectorized, equal to the calls (e.g. SumOfSines.sample)
        refs = np.asarray(reference.sample(np.arange(n) * Ts), dtype=float).reshape(n, 6)
    else:  # the Python loop's reference(i * Ts) if i else r0
        rows = [r0] + [reference(i * Ts) for i in range(1, n)]
        refs = np.array([(r.g, r.g_dot, r.g_ddot, r.d, r.d_dot, r.d_ddot) for r in rows], dtype=float)
    cr = _pid_controller_run(controller.settings, controller.params, pi.y0, refs, cflags)
    r = run_compiled_loop(pi, plant, cr, timing=False)
    done = r["done"]
    if r["error"]:
        raise RuntimeError(f"{file}: " + str(_error_text(r["error"], done, r["u_last"])))
    # the plant's log of the run (Plant.step's rows: reading, command after the limiter, true state)
    cmd = r["U"].copy()
    fl = pi.flags
    if fl["lim_on"]:  # Plant.limit where it can act (elsewhere it returns the command unchanged)
        U = r["U"]
        act = (np.abs(U) > fl["i_axis"]).any(axis=1) | (np.hypot(U[:, 0], U[:, 1]) > fl["i_amp"])
        for i in np.nonzero(act)[0]:
            cmd[i] = plant.limit(U[i])[0]
    plant._rows = np.column_stack([np.arange(done) * Ts, r["Y"], cmd, r["X"]])
    plant.events = stop_events(r["IMP"], done, Ts)
    rec = RigLogRecorder(n)
    rec.extra[:] = np.column_stack([refs[:, 0], refs[:, 3], r["LOG"][:, 3], r["LOG"][:, 5]])
    return rec.log(plant, file, controller=controller.name, stop_events=_events(plant))


def rig_loop(loop: str, plant: Plant, controller: Any = None) -> Callable[..., Any]:
    """The rig-log runner for ``loop``: :func:`run_closed_loop_compiled` or :func:`maglev_ocp.loop.run_closed_loop`.

    Parameters
    ----------
    loop : {"auto", "compiled", "python"}
        ``auto``: compiled where it can run (a :class:`Plant` - not a subclass with its own step -,
        the PID regulators, a C compiler), else Python with a logged note; ``compiled``: compiled or
        a :class:`UserError` saying why not.
    plant : Plant
        The plant the runs use.
    controller : optional
        A controller of the runs (default: the PID regulators).
    """
    if loop not in ("auto", "compiled", "python"):
        raise UserError(f"loop: {loop!r} is not one of auto, compiled, python")
    if loop == "python":
        return run_closed_loop
    reason = None
    if type(plant) is not Plant:
        reason = f"the plant is a {type(plant).__name__}, whose step is Python"
    elif controller is not None and not isinstance(controller, PIDController):
        reason = f"the controller {type(controller).__name__} has no compiled rig-log loop"
    elif find_compiler() is None:
        reason = "no C compiler found (set CC or install cc/gcc/clang)"
    if reason is None:
        return run_closed_loop_compiled
    if loop == "compiled":
        raise UserError(f"loop: compiled is not possible: {reason}")
    # a missing compiler is worth a warning; a plant or controller without a compiled step is by design
    level = logging.WARNING if reason.startswith("no C compiler") else logging.INFO
    _log.log(level, "loop: auto runs the Python closed loop: %s", reason)
    return run_closed_loop


def run_scenario_on(
    scenario: Scenario | dict,
    loop: str = "auto",
    seed: int | None = None,
    progress: bool = False,
    figures: bool = False,
) -> RunResult:
    """Run a scenario on the closed loop ``loop`` chooses: the compiled one wherever it can run it.

    The same maths either way (``tests/test_compiled_loop.py`` holds the two
    loops' logs equal to 1e-9 m); the compiled loop runs a scenario in one C
    call, tens of times faster than stepping the Python blocks.

    Parameters
    ----------
    scenario : Scenario or dict
        The scenario (a mapping is validated first).
    loop : {"auto", "compiled", "python"}
        ``auto``: :func:`run_scenario_compiled` where :func:`compiled_supported`
        and a C compiler is found, else :func:`maglev_ocp.runner.run_scenario`;
        ``compiled``: compiled or a :class:`UserError` saying why not.
    seed : int, optional
        Replace the scenario's seed.
    progress, figures : bool
        Progress bar (Python loop only) and figures when saving.
    """
    from ..runner import _as_scenario, run_scenario

    if loop not in ("auto", "compiled", "python"):
        raise UserError(f"loop: {loop!r} is not one of auto, compiled, python")
    sc = _as_scenario(scenario)
    if loop == "compiled":
        return run_scenario_compiled(sc, seed=seed, figures=figures)
    if loop == "auto":
        reason = compiled_unsupported(sc)
        if reason is None and find_compiler() is None:
            reason = "no C compiler found (set CC or install cc/gcc/clang)"
        if reason is None:
            return run_scenario_compiled(sc, seed=seed, figures=figures)
        level = logging.WARNING if reason.startswith("no C compiler") else logging.INFO
        _log.log(level, "loop: auto runs the Python closed loop: %s", reason)
    return run_scenario(sc, seed=seed, progress=progress, figures=figures)


__all__ = [
    "COMPILED_TYPES",
    "LOOP_CFLAGS",
    "ControllerRun",
    "LoopStruct",
    "code_version",
    "compiled_supported",
    "compiled_unsupported",
    "controller_library",
    "fl_refs",
    "model_file_hash",
    "nmpc_loop_settings",
    "nmpc_refs",
    "plant_library",
    "rig_loop",
    "run_closed_loop_compiled",
    "run_compiled_loop",
    "run_scenario_compiled",
    "run_scenario_on",
]
