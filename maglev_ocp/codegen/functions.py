"""What is generated for each controller: its CasADi Functions and their documented ports.

A :class:`ControllerCode` bundles, for one controller, the Functions that become
C (``<kind>_init`` and ``<kind>_step``), the documentation of every input and
output (size, unit, meaning, and the layout of packed vectors such as the
controller state), and the numeric constants the harness needs (parameter
vector, gains). :mod:`maglev_ocp.codegen.sources` turns a list of them into C
sources, the header ``maglev_controller.h``, the harness and the build files.

* ``nmpc``: ``nmpc_init(meas, ref, p) -> state`` and
  ``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats, x_hat)``, the
  NMPC developer's step Function (:mod:`maglev_ocp.controllers.nmpc.step`) as it is, its
  state ports documented by the NMPC's own layout table
  (:meth:`maglev_ocp.controllers.nmpc.layout.StateLayout.table`);
* ``fl``: ``fl_init``/``fl_step`` (:mod:`maglev_ocp.codegen.fl_fn`);
* ``pid``: ``pid_init``/``pid_step`` (:mod:`maglev_ocp.codegen.pid_fn`);
* ``observer``: ``observer_step`` (:mod:`maglev_ocp.codegen.observer_fn`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from maglev_ocp.controllers.fl import FLAG_FIELDS, GAIN_FIELDS, fl_adapted, fl_delay_samples
from maglev_ocp.controllers.model_file import load_controller_model
from maglev_ocp.controllers.nmpc import step_functions
from maglev_ocp.controllers.nmpc.layout import MEAS_TABLE, N_MEAS, STATS_TABLE
from maglev_ocp.controllers.nmpc.reference import resolve_mode
from maglev_ocp.controllers.pid import pid_lead_samples

from .. import constants as k
from ..errors import UserError
from ..observers import ObserverSettings
from ..params import Params
from ..signals import INPUTS, MEASUREMENTS, PARAMETERS, REF_FIELDS, REFERENCE, STATES, Signal
from .fl_fn import fl_functions, fl_state
from .observer_fn import observer_step_function
from .pid_fn import PID_FLAGS, PID_STATE, PID_STATE_SIZE, pid_functions

#: Controllers the standalone harness (`maglev codegen`) generates (``pid_code`` serves backend: c and the C loop).
KINDS: tuple[str, ...] = ("nmpc", "fl", "observer")


@dataclass(frozen=True)
class Piece:
    """A named slice of a packed vector.

    Attributes
    ----------
    name : str
        Name (a C macro ``..._<NAME>_OFFSET`` / ``_SIZE`` is generated).
    size : int
        Number of entries.
    unit : str
        Unit(s) of the entries.
    description : str
        What the entries are.
    """

    name: str
    size: int
    unit: str
    description: str


@dataclass(frozen=True)
class Port:
    """One input or output of a generated function (dense, column-major).

    Attributes
    ----------
    name : str
        Name as in the CasADi Function.
    rows, cols : int
        Shape (stored column-major, ``rows * cols`` doubles).
    unit, description : str
        Unit and meaning.
    pieces : tuple of Piece
        Layout, for packed vectors (empty: see ``description``).
    """

    name: str
    rows: int
    cols: int
    unit: str
    description: str
    pieces: tuple[Piece, ...] = ()

    @property
    def size(self) -> int:
        """Number of doubles."""
        return self.rows * self.cols


@dataclass
class CodeUnit:
    """A Function to generate and the documentation of its ports."""

    fn: ca.Function
    doc: str
    inputs: tuple[Port, ...]
    outputs: tuple[Port, ...]

    @property
    def name(self) -> str:
        """C symbol of the function."""
        return self.fn.name()

    def check(self) -> None:
        """Assert the documentation matches the Function (names and sizes)."""
        fn = self.fn
        assert tuple(fn.name_in()) == tuple(p.name for p in self.inputs), (fn.name_in(), self.inputs)
        assert tuple(fn.name_out()) == tuple(p.name for p in self.outputs), (fn.name_out(), self.outputs)
        for i, p in enumerate(self.inputs):
            assert fn.nnz_in(i) == p.size and fn.numel_in(i) == p.size, (fn.name(), p.name)
            if p.pieces:
                assert sum(q.size for q in p.pieces) == p.size, (fn.name(), p.name)
        for i, p in enumerate(self.outputs):
            assert fn.nnz_out(i) == p.size and fn.numel_out(i) == p.size, (fn.name(), p.name)
            if p.pieces:
                assert sum(q.size for q in p.pieces) == p.size, (fn.name(), p.name)


@dataclass
class ControllerCode:
    """Everything generated for one controller.

    Attributes
    ----------
    kind : str
        ``nmpc``, ``fl``, ``pid`` or ``observer``.
    init, step : CodeUnit or None
        Initialization (no init for the observer) and per-period step.
    constants : dict of str to (ndarray, str)
        Arrays written into the header (C name without prefix -> values, comment).
    defines : dict of str to number
        Integer / float macros written into the header.
    settings : dict
        The controller's settings (JSON), for the manifest and the cache key.
    notes : str
        Free text for the header (how to call, what is baked in).
    """

    kind: str
    init: CodeUnit | None
    step: CodeUnit
    constants: dict[str, tuple[np.ndarray, str]] = field(default_factory=dict)
    defines: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    notes: str = ""

    @property
    def units(self) -> list[CodeUnit]:
        """The functions to generate (init first)."""
        return [u for u in (self.init, self.step) if u is not None]


# ----------------------------------------------------------------------------- common ports
def _design(settings) -> dict[str, Any]:
    """The settings that define the generated code (JSON; ``backend`` left out: the same code serves both)."""
    d = settings.model_dump(mode="json")
    d.pop("backend", None)
    return d


def _unit_list(signals) -> str:
    return ", ".join(f"{s.name} [{s.unit}]" for s in signals)


def _signal_port(name: str, signals: tuple[Signal, ...], unit: str, what: str, rows: int | None = None) -> Port:
    """A packed column vector with one double per row of the signal table ``signals``.

    ``rows`` overrides the length (the parameter vector may be longer than its named head).
    """
    return Port(
        name,
        len(signals) if rows is None else rows,
        1,
        unit,
        f"{what}: " + _unit_list(signals),
        tuple(Piece(s.name, 1, s.unit, s.description) for s in signals),
    )


def params_port(np_: int) -> Port:
    """The model parameter vector input ``p``."""
    return _signal_port("p", PARAMETERS, "SI", "model parameters", rows=np_)


def _u_port(name: str = "u") -> Port:
    return _signal_port(name, INPUTS, "A", "commanded currents")


def _xhat_port(name: str = "x_hat") -> Port:
    return _signal_port(name, STATES, "m, m/s", "state estimate")


def _meas2_port(name: str = "meas") -> Port:
    return _signal_port(name, MEASUREMENTS, "m", "encoder readings")


def _dist_port(name: str = "dist") -> Port:
    return Port(
        name,
        2,
        1,
        "m/s^2",
        "acceleration disturbance estimate (gap, horizontal) [m/s^2]",
        (Piece("a_g", 1, "m/s^2", "gap axis"), Piece("a_d", 1, "m/s^2", "horizontal axis")),
    )


def _ref_row_port(what: str = "reference at this sample") -> Port:
    """The one-sample reference row (:data:`~maglev_ocp.signals.REF_FIELDS`) of the FL and PID steps."""
    units = dict(REF_ROW_UNITS)
    return Port(
        "ref",
        len(REF_FIELDS),
        1,
        "m, m/s, m/s^2",
        what,
        tuple(Piece(r, 1, units[r], "reference " + r) for r in REF_FIELDS),
    )


def _flags_port(fields: tuple[str, ...]) -> Port:
    """A step's 0/1 status flags, one piece each."""
    return Port(
        "flags", len(fields), 1, "-", "0/1 flags: " + ", ".join(fields), tuple(Piece(f, 1, "-", f) for f in fields)
    )


def _state_ports(size: int, pieces: tuple[Piece, ...]) -> tuple[Port, Port, Port]:
    """``(state, state_in, state_out)``: the controller memory as the init's output and the step's in/out."""
    return (
        Port("state", size, 1, "mixed", "initial controller memory", pieces),
        Port("state_in", size, 1, "mixed", "controller memory", pieces),
        Port("state_out", size, 1, "mixed", "controller memory for the next call", pieces),
    )


REF_ROW_UNITS: tuple[tuple[str, str], ...] = tuple((r.name, r.unit) for r in REFERENCE)


# ----------------------------------------------------------------------------- NMPC
def nmpc_code(settings, params: Params, mode: str) -> ControllerCode:
    """Code units of :class:`maglev_ocp.controllers.nmpc.NMPC` for reference mode ``mode`` (``plan`` or ``preview``).

    Parameters
    ----------
    settings : maglev_ocp.controllers.nmpc.NMPCSettings
        The controller's settings (the step Function is built from them, once per design).
    params : Params
        What the controller's model believes (cogging dropped if ``use_cogging`` is off).
    mode : {"plan", "preview"}
        Reference mode baked into the step (``auto`` is resolved by the caller).
    """
    if mode not in ("plan", "preview"):
        raise ValueError(f"NMPC reference mode must be 'plan' or 'preview', got {mode!r}")
    if settings.solver != "admm":  # OSQP runs as a Python callback inside the step: no C
        raise UserError(f"NMPC solver {settings.solver!r} has no C backend (use backend: python, or solver: admm)")
    model_params = params if settings.use_cogging else params.without_cogging()
    init, step, b = step_functions(settings, mode, model_params)
    lay = b.layout
    N = settings.horizon
    state_pieces = tuple(Piece(*row) for row in lay.table())
    state_port = Port("state_in", lay.size, 1, "mixed", "controller memory (warm start etc.)", state_pieces)
    ref_desc = (
        f"reference over the horizon: 6 rows ({', '.join(f'{r} [{u}]' for r, u in REF_ROW_UNITS)}) "
        f"x {N + 1} columns (nodes t + k Ts, k = 0..{N}), column-major"
        + ("; plan mode reads only the target (g, d) of column 0" if mode == "plan" else "")
    )
    ref_port = Port("ref", 6, N + 1, "m, m/s, m/s^2", ref_desc)
    meas_port = Port(
        "meas",
        N_MEAS,
        1,
        "m, m, -",
        "encoder readings g [m], d [m], then a fault flag (1 poisons the QP to exercise the fallback; 0 in operation)",
        tuple(Piece(n, 1, u, d) for n, u, d in MEAS_TABLE),
    )
    stats_pieces = tuple(Piece(n, 1, u, d) for n, u, d in STATS_TABLE)
    p_port = params_port(len(model_params.vector()))
    init_unit = CodeUnit(
        init,
        "state at rest at the reading, planning towards the reference's target",
        (meas_port, ref_port, p_port),
        (Port("state", lay.size, 1, "mixed", "initial controller memory", state_pieces),),
    )
    step_unit = CodeUnit(
        step,
        "one NMPC period: observer update, planner, RTI linearization, QP solve by "
        f"{settings.iterations} ADMM iterations, checks and fallback, warm-start shift",
        (state_port, meas_port, ref_port, p_port),
        (
            _u_port(),
            Port("state_out", lay.size, 1, "mixed", "controller memory for the next call", state_pieces),
            Port("stats", len(STATS_TABLE), 1, "mixed", "solver statistics", stats_pieces),
            _xhat_port(),
        ),
    )
    for u in (init_unit, step_unit):
        u.check()
    notes = (
        f"Reference mode '{mode}'. Baked in at generation: horizon N = {N}, weights, ADMM settings, the "
        "observer gain, the terminal weight and the LQR fallback gain (designed at 20 mm hover on the "
        "nominal parameters). The parameter vector p is an input (default: NMPC_PARAMS)."
    )
    return ControllerCode(
        "nmpc",
        init_unit,
        step_unit,
        constants={"PARAMS": (model_params.vector(), "model parameters p, " + _unit_list(PARAMETERS))},
        defines={
            "HORIZON": N,
            "STATE_SIZE": lay.size,
            "REF_COLS": N + 1,
            "N_STATS": len(STATS_TABLE),
            "REF_MODE_PREVIEW": int(mode == "preview"),
        },
        settings={"mode": mode, **_design(settings)},
        notes=notes,
    )


# ----------------------------------------------------------------------------- FL
def fl_code(settings, params: Params) -> ControllerCode:
    """Code units of :class:`maglev_ocp.controllers.fl.FeedbackLinearization` (observer + law in one step)."""
    init, step = fl_functions(settings, k.Ts)
    delay = fl_delay_samples(settings)
    pieces = tuple(Piece(*q) for q in fl_state(delay, len(fl_adapted(settings))))
    state_size = sum(q.size for q in pieces)
    state0, state_in, state_out = _state_ports(state_size, pieces)
    ref = _ref_row_port(
        f"reference {delay} samples ahead (when the command computed now takes effect)"
        if delay
        else "reference at this sample"
    )
    gain_units = {
        "kp_g": "1/s^2",
        "kd_g": "1/s",
        "ki_g": "1/s^3",
        "kp_d": "1/s^2",
        "kd_d": "1/s",
        "ki_d": "1/s^3",
        "i_axis_max": "A",
        "i_amp_max": "A",
        "Ts": "s",
    }
    gains = Port(
        "gains",
        len(GAIN_FIELDS),
        1,
        "mixed",
        "outer-loop gains and current limits",
        tuple(Piece(g, 1, gain_units[g], g) for g in GAIN_FIELDS),
    )
    p_port = params_port(len(params.vector()))
    init_unit = CodeUnit(
        init,
        "state at rest at the reading (integrators cleared)",
        (_meas2_port(),),
        (state0,),
    )
    step_unit = CodeUnit(
        step,
        "one feedback-linearization period: observer update, model inversion with cogging (and a model file's "
        "effects), limits with anti-windup",
        (state_in, _meas2_port(), ref, p_port, gains),
        (
            _u_port(),
            state_out,
            _xhat_port(),
            _dist_port(),
            Port("v", 2, 1, "m/s^2", "demanded output accelerations (gap, horizontal)"),
            _flags_port(FLAG_FIELDS),
        ),
    )
    for u in (init_unit, step_unit):
        u.check()
    return ControllerCode(
        "fl",
        init_unit,
        step_unit,
        constants={
            "PARAMS": (params.vector(), "model parameters p, " + _unit_list(PARAMETERS)),
            "GAINS": (settings.gains(k.Ts), "gains: " + ", ".join(f"{g} [{gain_units[g]}]" for g in GAIN_FIELDS)),
        },
        defines={"STATE_SIZE": state_size},
        settings=_design(settings),
        notes=f"Observer time constant eps = {settings.observer_eps} s baked in "
        f"(disturbance estimate: {settings.disturbance}); p and gains are inputs."
        + (f" Delay predictor: {delay} samples (ref is the reference {delay} samples ahead)." if delay else "")
        + _model_note(settings, "the observer's prediction, the delay predictor and the inverse"),
    )


def _model_note(settings, where: str) -> str:
    """What a controller's model file puts into its generated step (empty without one)."""
    path = getattr(settings, "model", None)
    if not path:
        return ""
    m = load_controller_model(path)
    if not m.effects:
        return f" Model file {path}: its constants (p) and delay, no static effects."
    return (
        f" Model file {path}: the static effects {', '.join(m.effects)} are baked into {where} "
        "(effect library expressions, parameters as constants; p is still an input)."
    )


# ----------------------------------------------------------------------------- PID
def pid_code(settings, params: Params) -> ControllerCode:
    """Code units of :class:`maglev_ocp.controllers.pid.PIDController` (observer, schedule, regulators: one step)."""
    init, step = pid_functions(settings, k.Ts)
    pieces = tuple(Piece(*q) for q in PID_STATE)
    state0, state_in, state_out = _state_ports(PID_STATE_SIZE, pieces)
    ref = _ref_row_port()
    lead = pid_lead_samples(settings) if settings.model else 0.0
    if lead:  # a model file's lag: the feed-forward's row the lag's delay ahead follows the row now
        ff = _ref_row_port()
        ref = Port(
            "ref",
            2 * ref.rows,
            1,
            ref.unit,
            f"reference now (feedback), then the plan {lead:.3g} control periods ahead (feed-forward: the model "
            "file's amplifier lag delays the command by that much)",
            ref.pieces + tuple(Piece("ff_" + pc.name, pc.size, pc.unit, pc.description + " ahead") for pc in ff.pieces),
        )
    p_port = params_port(len(params.vector()))
    init_unit = CodeUnit(
        init,
        "state at rest at the reading (integrators cleared, previous current the clipped hover current there)",
        (_meas2_port(), p_port),
        (state0,),
    )
    step_unit = CodeUnit(
        step,
        "one PID period: observer update, gain schedule at the reference, both regulators, limits with anti-windup",
        (state_in, _meas2_port(), ref, p_port),
        (
            _u_port(),
            state_out,
            _xhat_port(),
            Port("u_eq", 2, 1, "A", "hover currents (i_q, i_d) used as feedforward"),
            _flags_port(PID_FLAGS),
        ),
    )
    for u in (init_unit, step_unit):
        u.check()
    return ControllerCode(
        "pid",
        init_unit,
        step_unit,
        constants={"PARAMS": (params.vector(), "model parameters p, " + _unit_list(PARAMETERS))},
        defines={"STATE_SIZE": PID_STATE_SIZE},
        settings=_design(settings),
        notes=f"Tuning and observer time constant eps = {settings.observer_eps} s baked in; p is an input. "
        "pid_init gives a non-finite state where the model has no hover current at the reading: check it."
        + (_model_note(settings, "the feed-forward") if settings.feedforward else ""),
    )


# ----------------------------------------------------------------------------- observer
def observer_code(eps: float, disturbance: bool, params: Params) -> ControllerCode:
    """Code unit of the high-gain observer update alone."""
    fn = observer_step_function(ObserverSettings(eps=eps, disturbance=disturbance), k.Ts)
    unit = CodeUnit(
        fn,
        "one observer update with the reading y taken after u_prev was held for one period",
        (_xhat_port(), _dist_port(), _u_port("u_prev"), _meas2_port("y"), params_port(len(params.vector()))),
        (_xhat_port("x_hat_next"), _dist_port("dist_next")),
    )
    unit.check()
    return ControllerCode(
        "observer",
        None,
        unit,
        constants={"PARAMS": (params.vector(), "model parameters p, " + _unit_list(PARAMETERS))},
        defines={},
        settings={"eps": eps, "disturbance": disturbance},
        notes=f"Start at rest: x_hat = (g0, 0, d0, 0), dist = 0. eps = {eps} s baked in.",
    )


def resolve_nmpc_mode(settings, shaping: str | None) -> str:
    """The NMPC reference mode the controller picks (:func:`~maglev_ocp.controllers.nmpc.reference.resolve_mode`).

    ``shaping`` is the scenario's ``reference.shaping`` (``None``: no reference
    plan from a runner, e.g. a bare rig log).
    """
    return resolve_mode(settings.reference, shaping)


__all__ = [
    "KINDS",
    "CodeUnit",
    "ControllerCode",
    "Piece",
    "Port",
    "fl_code",
    "nmpc_code",
    "observer_code",
    "params_port",
    "pid_code",
    "resolve_nmpc_mode",
]
