"""Model files for controllers: constants plus fitted effects, the format of the plant profiles' ``effects:``.

A model file is what a diagnosis writes and what ``controller: {model: FILE}``
loads: the model constants (the keys of a parameter file,
:class:`maglev_ocp.params.ParamsFile`) and an ``effects:`` block in the plant
profiles' format (``{name: {enabled: true, <param>: value, ...}}``, see
:mod:`maglev_ocp.effects`)::

    C1: 6.53e-6
    C4: 0.52
    effects:
      friction: {enabled: true, coulomb_d: 0.6, viscous_d: 2.0}
      commutation_offset: {enabled: true, angle: 0.05}

The static effects (everything but the amplifier lag) enter the controller
through :func:`effect_delta_function`: the effect library's own CasADi
expressions (:meth:`maglev_ocp.effects.EffectSet.accel`, not retyped) minus
the shared model's accelerations, i.e. what the effects add at a state and a
current. The amplifier lag's transport delay is reported as ``delay_samples``
(a controller compensates it with its delay predictor).
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass, fields

import casadi as ca
import numpy as np

from maglev_ocp.config import load_yaml
from maglev_ocp.effects import EFFECTS, EffectSet
from maglev_ocp.errors import ConfigError
from maglev_ocp.model import get_model
from maglev_ocp.params import Params, ParamsFile

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
    for key in ("name", "description", "profile"):
        data.pop(key, None)
    try:
        consts = ParamsFile.model_validate(data)
    except Exception as err:  # pydantic's message, on one line
        raise ConfigError(f"{path}: {str(err).splitlines()[0]} ({err})") from None
    params = Params(**{f.name: getattr(consts, f.name) for f in fields(Params)})
    on: dict[str, dict[str, float]] = {}
    delay = 0
    for name, block in effects.items():
        if name not in EFFECTS:
            raise ConfigError(f"{path}: effects.{name}: unknown effect; choose from {', '.join(EFFECTS)}")
        block = dict(block or {})
        if not block.pop("enabled", False):
            continue
        if name in DYNAMIC_EFFECTS:
            delay = round(float(block.get("delay_samples", 0)))
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


@functools.lru_cache(maxsize=32)
def effect_delta_function(names: tuple[str, ...]) -> ca.Function:
    """``effect_delta(x, u, p, theta) -> (dg_ddot, dd_ddot)``: what the effects add to the model's accelerations.

    The effect library's accelerations (currents transformed, terms scaled,
    forces added, :meth:`maglev_ocp.effects.EffectSet.accel`) minus the shared
    model's at the same state and currents.
    """
    m = get_model()
    es = EffectSet(names)
    x, u, p = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("p", m.np_)
    theta = ca.SX.sym("theta", es.n_theta)
    f = m.f(x, u, p)
    delta = es.accel(x, u, p, theta) - ca.vertcat(f[1], f[3])
    return ca.Function("effect_delta", [x, u, p, theta], [delta], ["x", "u", "p", "theta"], ["delta"])


__all__ = ["DYNAMIC_EFFECTS", "ControllerModel", "effect_delta_function", "load_controller_model"]
