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
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields

import numpy as np

from maglev_ocp.config import load_yaml, parse_model
from maglev_ocp.effects import EFFECTS, EffectSet, effect_delta_function
from maglev_ocp.errors import ConfigError
from maglev_ocp.params import Params, ParamsFile, warn_if_untrusted

#: Description of every controller's ``model`` setting (FL, NMPC, PID): the one key that loads a model file.
MODEL_SETTING_DESCRIPTION: str = (
    "model file (maglev_ocp.controllers.model_file): the constants and fitted effects that maglev calibrate and "
    "maglev diagnose write as model.yaml; its constants replace the controller's parameters. In a scenario a "
    "relative path is read from the scenario file's folder"
)

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
    """

    params: Params
    effects: tuple[str, ...]
    theta: np.ndarray
    delay_samples: int = 0
    source: str = ""


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
            continue
        on[name] = {k: float(v) for k, v in block.items()}
    try:
        es = EffectSet(on)
        theta = es.vector(on)
    except KeyError as err:
        raise ConfigError(f"{path}: effects: {err}") from None
    lo, hi = es.bounds()
    bad = [n for n, v, a, b in zip(es.param_names, theta, lo, hi, strict=True) if not a <= v <= b]
    if bad:
        raise ConfigError(f"{path}: effects: {', '.join(bad)} outside the effect library's bounds")
    return ControllerModel(params, es.names, theta, delay, str(path))


def check_model_path(path: str | None) -> str | None:
    """Settings validator of a ``model:`` key: the file must exist (its content is checked when loaded).

    A scenario hands the path already joined to its own folder (a relative
    ``model:`` is read from the scenario file's folder); settings built in
    Python take it as given (from the working directory).
    """
    if path is not None and not os.path.isfile(path):
        raise ValueError(f"no such model file: {path!r} (in a scenario, a relative path is read from its folder)")
    return path


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
    "RIG_KEYS",
    "ControllerModel",
    "check_model_path",
    "effect_delta_function",
    "load_controller_model",
]
