"""Model files for controllers: constants plus fitted effects, the format of the plant profiles' ``effects:``.

A model file is what ``maglev calibrate`` and ``maglev diagnose`` write
(``model.yaml``) and what every controller loads with ``controller: {model:
FILE}`` (in a scenario, a relative path is read from the scenario file's
folder): the model constants (the keys of a parameter file,
:class:`maglev_ocp.params.ParamsFile`) and an ``effects:`` block in the plant
profiles' format (``{name: {enabled: true, <param>: value, ...}}``, see
:mod:`maglev_ocp.effects`)::

    C1: 6.53e-6
    C4: 0.52
    effects:
      friction: {enabled: true, coulomb_d: 0.6, viscous_d: 2.0}
      commutation_offset: {enabled: true, angle: 0.05}

A plant file (what ``maglev diagnose`` writes as ``model.yaml``, and the
plant profiles) is a model file too: its constants are read from
``mismatch.overrides`` (the random spread of ``mismatch.relative`` is the rig's,
not the model's), its ``delay_samples`` (the loop's computation delay) adds to
the delay, and the keys that only describe the rig (noise, quantization,
limits, stops, integrator, disturbances) are ignored.

The static effects (everything but the amplifier lag) enter the controller
through :func:`maglev_ocp.effects.effect_delta_function` (re-exported here): the effect library's own CasADi
expressions (:meth:`maglev_ocp.effects.EffectSet.accel`, not retyped) minus
the shared model's accelerations, i.e. what the effects add at a state and a
current. The amplifier lag's transport delay is reported as ``delay_samples``
(a controller compensates it with its delay predictor).

How a controller evaluates them without feeding measurement noise into the
current (:class:`ModelEffects`): the fitted laws are kept, but a regularized
sign of a velocity (friction's ``tanh(v / v_reg)``, :data:`SIGN_WIDTHS`) is
widened to the resolution of the velocity the controller has
(:func:`velocity_noise`: a high-gain observer on 10 um readings at 1 kHz
estimates the velocity to about 1.2 mm/s, while a diagnosis fixes ``v_reg`` at
1 mm/s, so the fitted sign would flip on the noise at rest), and the caller
chooses the velocity the effects see (a controller takes the planned one in its
inverse, see :mod:`maglev_ocp.controllers.fl`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields
from typing import Literal

import casadi as ca
import numpy as np

from maglev_ocp import constants as k
from maglev_ocp.config import load_yaml, parse_model
from maglev_ocp.effects import EFFECTS, EffectSet, effect_delta_function
from maglev_ocp.errors import ConfigError
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.model import get_model
from maglev_ocp.params import Params, ParamsFile, warn_if_untrusted

#: Description of every controller's ``model`` setting (FL, NMPC, PID): the one key that loads a model file.
MODEL_SETTING_DESCRIPTION: str = (
    "model file (maglev_ocp.controllers.model_file): the constants and fitted effects that maglev calibrate and "
    "maglev diagnose write as model.yaml; its constants replace the controller's parameters. In a scenario a "
    "relative path is read from the scenario file's folder"
)
#: Description of every controller's ``untrusted_model`` setting (what to do with a file marked ``trusted: false``).
UNTRUSTED_MODEL_DESCRIPTION: str = (
    "what the controller does with a model file its writer marked trusted: false (maglev diagnose when the "
    "constants absorbed an effect outside the library, maglev calibrate --force): refuse (default: the scenario "
    "is rejected with the file's reasons, nothing runs) or use (the file is loaded with a warning and every "
    "result of the run says UNTRUSTED MODEL in its own files)"
)
#: Allowed values of ``untrusted_model``.
UntrustedPolicy = Literal["refuse", "use"]

#: Plant-file keys that describe the rig, not its model (ignored when a plant file is loaded as a model file).
RIG_KEYS: tuple[str, ...] = (
    "process_noise",
    "current_noise",
    "measurement_noise",
    "quantization",
    "current_limits",
    "stops",
    "lock",
    "integrator",
    "disturbances",
)
#: Keys of a plant file's ``mismatch`` block.
MISMATCH_KEYS: tuple[str, ...] = ("relative", "distribution", "overrides")

#: Effects with plant states: not part of the static prediction (the lag's delay is reported instead).
DYNAMIC_EFFECTS: tuple[str, ...] = tuple(n for n, cls in EFFECTS.items() if cls.dynamic)


#: Effect parameters that are the width of a regularized sign of a velocity (``tanh(v / width)``) [m/s].
SIGN_WIDTHS: tuple[str, ...] = ("friction.v_reg",)
#: A sign's width in standard deviations of the velocity estimate's noise: a 1-sigma error of the
#: estimate moves the smoothed sign by at most tanh(1/3) = 0.32 of its full swing (instead of flipping it).
SIGN_WIDTH_SIGMAS: float = 3.0
#: Standard deviation of the encoder's quantization error [m] (a uniform error over one 10 um count).
QUANTIZATION_STD: float = k.encoder_resolution / math.sqrt(12.0)


@dataclass(frozen=True)
class ControllerModel:
    """A loaded model file.

    Attributes
    ----------
    params : Params
        The model constants.
    effects : tuple of str
        The static effects switched on, in the effect library's order.
    theta : ndarray
        Their parameters in :attr:`maglev_ocp.effects.EffectSet.param_names` order.
    delay_samples : int
        Transport delay of a declared amplifier lag [control periods] (0 if none).
    source : str
        The file it came from.
    lag_time_s : float
        Time constant of a declared amplifier lag's first-order part, ``1 / (2 pi bandwidth_hz)`` [s] (0 if
        none): below its bandwidth the lag delays a signal by about this much beyond ``delay_samples``.
    """

    params: Params
    effects: tuple[str, ...]
    theta: np.ndarray
    delay_samples: int = 0
    source: str = ""
    lag_time_s: float = 0.0

    def delay_periods(self, Ts: float = k.Ts) -> int:
        """The whole control periods a controller's delay predictor runs through for this file's lag.

        The transport delay plus the first-order part's time constant rounded to whole periods: below
        its bandwidth a lag delays a signal by about its time constant, so a Smith predictor that
        ignored it would meet the plan that much late. Measured on the digital_eddy rig (a 1.5-period
        delay and a 500 Hz PWM lag; its diagnosis: one period and 188 Hz, 0.85 ms): FL's tracking RMS
        along the plan g / d 13.8 / 42.2 um through one period, 4.6 / 10.1 um through two
        (``results/benchmarks/diagnosed_vs_blind.md``). Predicting through a whole number of periods
        keeps the predictors (FL, NMPC, their generated steps) as they are; the PID, which only reads
        the plan ahead, uses the fractional sum (:func:`maglev_ocp.controllers.pid.pid_lead_samples`).
        """
        return int(self.delay_samples) + round(self.lag_time_s / Ts)


def load_controller_model(path: str | os.PathLike) -> ControllerModel:
    """Read a model file (see the module docstring); one-line :class:`ConfigError` on any problem."""
    data = load_yaml(path) or {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a model file is a mapping of constants and 'effects'")
    effects = data.pop("effects", None) or {}
    if not isinstance(effects, dict):
        raise ConfigError(f"{path}: effects: a mapping of effect names to their laws")
    for key in ("name", "description", "profile", *RIG_KEYS):
        data.pop(key, None)
    delay = _plant_delay(path, data.pop("delay_samples", 0))
    lag_time = 0.0
    data = {**_mismatch_constants(path, data.pop("mismatch", None)), **data}
    consts = parse_model(ParamsFile, data, str(path))  # one line: file, key, what is allowed
    warn_if_untrusted(consts, path)  # trusted: false (e.g. maglev calibrate --force): said on every load
    params = Params(**{f.name: getattr(consts, f.name) for f in fields(Params)})
    on: dict[str, dict[str, float]] = {}
    for name, block in effects.items():
        if name not in EFFECTS:
            raise ConfigError(f"{path}: effects.{name}: unknown effect; choose from {', '.join(EFFECTS)}")
        block = dict(block or {})
        if not block.pop("enabled", False):
            continue
        if name in DYNAMIC_EFFECTS:
            delay += _plant_delay(f"{path}: effects.{name}", block.get("delay_samples", 0))
            bw = block.get("bandwidth_hz")
            if bw is not None:
                if not (isinstance(bw, (int, float)) and math.isfinite(bw) and bw > 0):
                    raise ConfigError(f"{path}: effects.{name}.bandwidth_hz: a positive finite frequency [Hz]")
                lag_time += 1.0 / (2 * math.pi * float(bw))
            continue
        on[name] = {k: float(v) for k, v in block.items()}
    try:
        es = EffectSet(on)
        theta = es.vector(on)
    except KeyError as err:
        raise ConfigError(f"{path}: effects: {err}") from None
    lo, hi = es.bounds()
    bad = [f"{n} = {v:g} (allowed {a:g}..{b:g})" for n, v, a, b in zip(es.param_names, theta, lo, hi, strict=True)
           if not a <= v <= b]  # fmt: skip
    if bad:
        raise ConfigError(f"{path}: effects: {', '.join(bad)}: outside the effect library's bounds")
    return ControllerModel(params, es.names, theta, delay, str(path), lag_time)


def velocity_noise(L: np.ndarray, Ts: float = k.Ts, sigma: float = QUANTIZATION_STD) -> float:
    """Standard deviation of a high-gain observer's velocity estimate from white reading noise [m/s].

    The observer of one axis (:class:`maglev_ocp.observers.HighGainObserver`, gain ``L`` of 2 or 3 entries:
    position, velocity, disturbance) has the estimation error ``e+ = (I - L H) F e - L n`` for a reading error
    ``n``; its stationary covariance solves the discrete Lyapunov equation ``S = A S A^T + sigma^2 L L^T`` with
    ``A = (I - L H) F`` (summed by doubling), and the velocity's standard deviation is ``sqrt(S[1, 1])``. With
    ``sigma`` the quantization of a 10 µm encoder (2.9 µm) this is the resolution of the velocity the controller
    knows: 1.2 mm/s for the FL's observer (2 ms, with disturbance), 0.45 mm/s at 4 ms.
    """
    L = np.asarray(L, dtype=float).ravel()
    n = len(L)
    F = np.eye(n)
    F[0, 1] = Ts
    if n == 3:
        F[0, 2], F[1, 2] = Ts**2 / 2, Ts
    H = np.zeros((1, n))
    H[0, 0] = 1.0
    A = (np.eye(n) - L[:, None] @ H) @ F
    # Smith's doubling: S_{j+1} = S_j + A_j S_j A_j^T, A_{j+1} = A_j^2 sums A^i Q A^iT over i < 2^j
    # (the error poles are inside the unit circle; 2^12 terms is far past convergence at any eps >= Ts / 8)
    S = sigma**2 * np.outer(L, L)
    for _ in range(12):
        S = S + A @ S @ A.T
        A = A @ A
    return float(math.sqrt(max(S[1, 1], 0.0)))


class ModelEffects:
    """A model file's static effects as a controller evaluates them: what they add to the accelerations.

    The effect library's expressions (:func:`effect_delta_function`, not retyped) with the
    parameters of the file, except that every regularized sign of a velocity
    (:data:`SIGN_WIDTHS`) is at least ``sign_width`` wide, so that the noise of an
    estimated velocity cannot switch it.

    Parameters
    ----------
    model : ControllerModel
        The loaded model file (its ``effects`` must not be empty).
    params : ndarray
        The model parameter vector the effects are evaluated with.
    sign_width : float
        Smallest width of a regularized sign [m/s] (e.g. ``SIGN_WIDTH_SIGMAS * velocity_noise(L)``).

    Attributes
    ----------
    theta : ndarray
        The parameters evaluated (the file's, the sign widths widened).
    widened : dict of str to tuple of float
        ``{parameter: (file's value, value used)}`` for each width that was widened.
    function : casadi.Function
        ``model_effects(x, u, p) -> delta``: the effects' accelerations with :attr:`theta` baked in.
    """

    def __init__(self, model: ControllerModel, params: np.ndarray, sign_width: float):
        if not model.effects:
            raise ValueError("ModelEffects needs a model file with static effects")
        names = EffectSet(model.effects).param_names
        theta = np.array(model.theta, dtype=float)
        self.widened: dict[str, tuple[float, float]] = {}
        for name in SIGN_WIDTHS:
            if name in names:
                i = names.index(name)
                if theta[i] < sign_width:
                    self.widened[name] = (float(theta[i]), float(sign_width))
                    theta[i] = sign_width
        self.theta = theta
        self.p = np.asarray(params, dtype=float).copy()
        self.names = tuple(model.effects)
        # one Function with the parameters baked in, evaluated here and inlined into generated steps (expr):
        # the same expression graph (constants folded alike) on both sides
        m = get_model()
        x, u, p = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("p", m.np_)
        d = effect_delta_function(self.names)(x, u, p, ca.DM(theta))
        self.function = ca.Function("model_effects", [x, u, p], [d], ["x", "u", "p"], ["delta"])
        self._fn = BufferedFunction(self.function)

    def __call__(self, x: np.ndarray, u: np.ndarray, velocity: tuple[float, float] | None = None) -> np.ndarray:
        """Accelerations ``(dg_ddot, dd_ddot)`` [m/s^2] the effects add at state ``x`` and currents ``u``.

        ``velocity = (g_dot, d_dot)`` replaces the state's velocities (e.g. the planned ones);
        zeros where ``x`` or ``u`` is not finite.
        """
        x = np.asarray(x, dtype=float)
        if velocity is not None:
            x = np.array([x[0], velocity[0], x[2], velocity[1]])
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(u))):
            return np.zeros(2)
        (d,) = self._fn(x, u, self.p)
        return d

    def expr(self, x: ca.SX, u: ca.SX, p: ca.SX, velocity: tuple | None = None) -> ca.SX:
        """The same accelerations as a CasADi expression (for a controller's generated step).

        The very Function :meth:`__call__` evaluates (:attr:`function`: :func:`effect_delta_function`
        with the widened :attr:`theta` baked in as constants), called on symbols: state ``x`` (4),
        currents ``u`` (2), parameter vector ``p``; ``velocity = (g_dot, d_dot)`` replaces the
        state's velocities. Zero where ``x`` (with the velocities replaced) or ``u`` is not
        finite, as :meth:`__call__`.
        """
        if velocity is not None:
            x = ca.vertcat(x[0], velocity[0], x[2], velocity[1])
        ok = ca.sum1(ca.fabs(ca.vertcat(x, u))) < ca.inf  # NaN compares false
        return ca.if_else(ok, self.function(x, u, p), ca.SX.zeros(2))


def check_model_path(path: str | None) -> str | None:
    """Settings validator of a ``model:`` key: the file must exist (its content is checked when loaded).

    A scenario hands the path already joined to its own folder (a relative
    ``model:`` is read from the scenario file's folder); settings built in
    Python take it as given (from the working directory).
    """
    if path is not None and not os.path.isfile(path):
        raise ValueError(f"no such model file: {path!r} (in a scenario, a relative path is read from its folder)")
    return path


def model_file_untrusted(path: str | os.PathLike) -> str | None:
    """Why the model file ``path`` is marked untrusted by its writer (``trusted: false``), or None if it is not.

    The file's own ``untrusted_because`` reasons joined (``"no reason given"`` without any); a file that
    cannot be read as a mapping is left to the loader's one-line error.
    """
    try:
        data = load_yaml(path)
    except ConfigError:
        return None
    if not isinstance(data, dict) or data.get("trusted", True) is not False:
        return None
    why = data.get("untrusted_because") or ["no reason given"]
    return "; ".join(str(w) for w in (why if isinstance(why, list) else [why]))


def check_model_trust(path: str | None, policy: UntrustedPolicy) -> None:
    """Settings check of a controller's ``model`` against its ``untrusted_model`` policy.

    A model file marked ``trusted: false`` is refused unless ``policy`` is ``"use"`` (then the loader
    warns and the run's results carry the mark, :meth:`maglev_ocp.scenario.Scenario.model_untrusted`).
    Refusing is the default because a file the diagnosis could not vouch for made every controller worse
    than blind on the validation rig whose constants absorbed an effect outside the library
    (``results/benchmarks/diagnosed_vs_blind.md``, cascade_karnopp: C1 -80 %, FL d 85 -> 647 um): the user
    must say, in the scenario, that they want it anyway.

    Raises
    ------
    ValueError
        One line naming the file, its reasons and the setting that accepts it.
    """
    if path is None or policy == "use":
        return
    why = model_file_untrusted(path)
    if why is not None:
        raise ValueError(
            f"model file {path} is marked untrusted by its writer ({why}); refused: untrusted_model is "
            "'refuse' (allowed: refuse, use; use runs with it and flags every result UNTRUSTED MODEL)"
        )


def _plant_delay(where: str | os.PathLike, value: object) -> int:
    """A delay in whole control periods (``delay_samples``), 0..10."""
    try:
        n = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: delay_samples: not a number: {value!r}") from None
    if not (math.isfinite(n) and n == round(n) and 0 <= n <= 10):
        raise ConfigError(f"{where}: delay_samples: {value!r} is not a whole number of periods in 0..10")
    return int(n)


def _mismatch_constants(path: str | os.PathLike, block: object) -> dict:
    """The constants of a plant file's ``mismatch`` block (its ``overrides``)."""
    if block is None:
        return {}
    if not isinstance(block, dict):
        raise ConfigError(f"{path}: mismatch: a mapping with {', '.join(MISMATCH_KEYS)}")
    bad = sorted(set(block) - set(MISMATCH_KEYS))
    if bad:
        raise ConfigError(f"{path}: mismatch.{bad[0]}: unknown key; allowed: {', '.join(MISMATCH_KEYS)}")
    over = block.get("overrides") or {}
    if not isinstance(over, dict):
        raise ConfigError(f"{path}: mismatch.overrides: a mapping of constants")
    return dict(over)


__all__ = [
    "DYNAMIC_EFFECTS",
    "MODEL_SETTING_DESCRIPTION",
    "QUANTIZATION_STD",
    "RIG_KEYS",
    "SIGN_WIDTHS",
    "SIGN_WIDTH_SIGMAS",
    "UNTRUSTED_MODEL_DESCRIPTION",
    "ControllerModel",
    "ModelEffects",
    "UntrustedPolicy",
    "check_model_path",
    "check_model_trust",
    "effect_delta_function",
    "load_controller_model",
    "model_file_untrusted",
    "velocity_noise",
]
