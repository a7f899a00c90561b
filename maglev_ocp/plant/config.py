"""Plant settings: what the simulated rig has (noise, limits, stops, fixtures, effects).

A :class:`PlantConfig` is read from YAML. Rig profiles (``profiles/<name>.yaml``)
hold complete settings; a user's plant file names a profile in its ``profile``
key (default ``default``) and overrides only what it changes, e.g.::

    profile: default
    process_noise: {g: 0.1}
    effects:
      saturation: {enabled: true, loss_8mm: 0.2}

Every key is validated (unknown keys, wrong types and out-of-range values are
one-line :class:`~maglev_ocp.errors.ConfigError` s naming file and key).
"""

from __future__ import annotations

import copy
import functools
import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, create_model, field_validator, model_validator

from .. import constants as k
from ..config import Strict, load_yaml, parse_model
from ..effects import EFFECTS, EffectSet
from ..errors import ConfigError
from ..model import get_model
from ..output import dump_yaml
from ..params import ParamOverrides, Params, warn_if_untrusted
from .disturbances import Cable, Disturbance

PROFILE_DIR = Path(__file__).with_name("profiles")


# ----------------------------------------------------------------------- sections
class RelativeSpread(Strict):
    """Relative random spread of each parameter (a fraction, e.g. 0.05 for 5 %)."""

    C1: float = Field(0.0, ge=0, le=0.5)
    C2: float = Field(0.0, ge=0, le=0.5)
    C3: float = Field(0.0, ge=0, le=0.5)
    C4: float = Field(0.0, ge=0, le=0.9)
    xi0: float = Field(0.0, ge=0, le=0.9)
    ell: float = Field(0.0, ge=0, le=0.5)
    Mh: float = Field(0.0, ge=0, le=0.5)
    Mv: float = Field(0.0, ge=0, le=0.5)


class Mismatch(Strict):
    """How the true parameters of the simulated rig differ from the nominal set.

    The random perturbation (``true = nominal * (1 + relative * r)`` with ``r``
    uniform in [-1, 1] or standard normal, drawn from the plant's seed) is
    applied first; explicit ``overrides`` then replace entries exactly.
    """

    relative: RelativeSpread = RelativeSpread()
    distribution: Literal["uniform", "normal"] = "uniform"
    overrides: ParamOverrides = ParamOverrides()

    def apply(self, base: Params, rng: np.random.Generator) -> Params:
        """Return the true parameters drawn from ``rng`` (always the same number of draws)."""
        rel = self.relative.model_dump()
        names = list(rel)
        r = rng.uniform(-1.0, 1.0, len(names)) if self.distribution == "uniform" else rng.standard_normal(len(names))
        factors = {n: 1.0 + rel[n] * float(ri) for n, ri in zip(names, r, strict=True) if rel[n] > 0}
        return self.overrides.apply(base.scaled(factors))


class AxisForce(Strict):
    """A force per axis [N]."""

    g: float = Field(0.0, ge=0, le=50)
    d: float = Field(0.0, ge=0, le=50)


class CurrentNoise(Strict):
    """Standard deviation of the current noise per axis [A]."""

    i_q: float = Field(0.0, ge=0, le=2)
    i_d: float = Field(0.0, ge=0, le=2)


class MeasurementNoise(Strict):
    """Standard deviation of the encoder noise before quantization [m]."""

    g: float = Field(0.0, ge=0, le=1e-3)
    d: float = Field(0.0, ge=0, le=1e-3)


class Quantization(Strict):
    """Encoder quantization: ``round(value / resolution) * resolution``."""

    enabled: bool = False
    resolution: float = Field(k.encoder_resolution, gt=0, le=1e-3)


class CurrentLimits(Strict):
    """Amplifier limits: each axis within ``±axis``, then the amplitude within ``amplitude`` [A]."""

    enabled: bool = False
    axis: float = Field(k.i_axis_max, gt=0, le=100)
    amplitude: float = Field(k.i_amp_max, gt=0, le=100)


class Stops(Strict):
    """Mechanical stops [m] (``[lower, upper]`` per axis)."""

    enabled: bool = False
    g: list[float] = Field(default_factory=lambda: list(k.g_stop), min_length=2, max_length=2)
    d: list[float] = Field(default_factory=lambda: list(k.d_stop), min_length=2, max_length=2)

    @field_validator("g")
    @classmethod
    def _g_range(cls, v: list[float]) -> list[float]:
        if not (1e-3 <= v[0] < v[1] <= 0.1):
            raise ValueError("needs 1 mm <= lower < upper <= 100 mm (in metres)")
        return v

    @field_validator("d")
    @classmethod
    def _d_range(cls, v: list[float]) -> list[float]:
        if not (-1.0 <= v[0] < v[1] <= 1.0):
            raise ValueError("needs -1 m <= lower < upper <= 1 m")
        return v


class Lock(Strict):
    """Locked-axis fixture (seed section V): the axis is held at ``value`` [m].

    ``value: null`` locks the axis where the run starts (the initial state).
    """

    axis: Literal["none", "g", "d"] = "none"
    value: float | None = Field(None, ge=-1.0, le=1.0)


class Integrator(Strict):
    """Plant integrator: RK4 with ``n_sub`` sub-steps per control period (finer than the controllers')."""

    method: Literal["rk4"] = "rk4"
    n_sub: int = Field(10, ge=1, le=1000)


def _effect_model(name: str) -> type[Strict]:
    cls = EFFECTS[name]
    fields: dict[str, Any] = {"enabled": (bool, False)}
    for q in cls.params:
        typ = int if q.integer else float
        fields[q.name] = (typ, Field(typ(q.default), ge=q.lo, le=q.hi, description=f"{q.description} [{q.unit}]"))
    model = create_model(f"{cls.__name__}Config", __base__=Strict, __doc__=cls.__doc__, **fields)
    return model


EFFECT_CONFIGS: dict[str, type[Strict]] = {n: _effect_model(n) for n in EFFECTS}

EffectsConfig = create_model(
    "EffectsConfig",
    __base__=Strict,
    __doc__="Each unmodelled effect, switchable (``enabled``) with its parameters.",
    **{n: (m, Field(default_factory=m)) for n, m in EFFECT_CONFIGS.items()},
)


# ---------------------------------------------------------------------------- plant
class PlantConfig(Strict):
    """Everything the simulated rig has.

    Attributes
    ----------
    profile : str
        Name of the rig profile these settings start from.
    mismatch : Mismatch
        True parameters vs the nominal ones.
    process_noise : AxisForce
        Force noise std per axis [N], constant over each control period.
    current_noise : CurrentNoise
        Noise std on the applied currents [A], constant over each period.
    measurement_noise : MeasurementNoise
        Encoder noise std [m], added before quantization.
    quantization : Quantization
        Encoder resolution (10 µm), switchable.
    current_limits : CurrentLimits
        ±8 A per axis and 8 A amplitude, switchable.
    stops : Stops
        Mechanical stops, switchable.
    lock : Lock
        Locked-axis fixture.
    effects : EffectsConfig
        The unmodelled effects (see :mod:`maglev_ocp.effects`).
    integrator : Integrator
        RK4 sub-steps per 1 ms period.
    delay_samples : int
        Computation delay [control periods]: the current computed from the
        reading of sample k reaches the amplifiers at sample k + N (N = 1 on
        most rigs). It adds to the amplifier's own transport delay
        (``effects.amplifier_lag.delay_samples``); the plant holds one buffer
        of the sum, so neither is counted twice.
    disturbances : list
        Scheduled force pulses and steps, payloads and a cable
        (:mod:`maglev_ocp.plant.disturbances`).
    trusted, untrusted_because : bool, list of str
        A model file written by ``maglev diagnose`` is a plant file too; its writer
        marks it ``trusted: false`` with the reasons when it cannot vouch for it
        (loading it then warns, :class:`maglev_ocp.params.UntrustedModelWarning`).
    """

    profile: str = Field("custom", pattern=r"^[A-Za-z0-9_\-]+$")
    mismatch: Mismatch = Mismatch()
    process_noise: AxisForce = AxisForce()
    current_noise: CurrentNoise = CurrentNoise()
    measurement_noise: MeasurementNoise = MeasurementNoise()
    quantization: Quantization = Quantization()
    current_limits: CurrentLimits = CurrentLimits()
    stops: Stops = Stops()
    lock: Lock = Lock()
    effects: EffectsConfig = Field(default_factory=EffectsConfig)  # type: ignore[valid-type]
    integrator: Integrator = Integrator()
    delay_samples: int = Field(
        0,
        ge=0,
        le=10,
        description="computation delay [control periods]: the current computed at sample k is applied at k + N",
    )
    disturbances: list[Disturbance] = Field(
        default_factory=list, description="scheduled force pulses / steps, payloads and a cable (SI units)"
    )
    trusted: bool = Field(True, description="false: the file's writer (maglev diagnose) cannot vouch for it")
    untrusted_because: list[str] = Field(default_factory=list, description="why the file is marked untrusted")

    @model_validator(mode="after")
    def _consistent(self) -> PlantConfig:
        fr = self.effects.friction
        if fr.enabled:
            # tanh-regularized friction is stiff: keep RK4 inside its stability region.
            h = k.Ts / self.integrator.n_sub
            lam = EFFECTS["friction"].stiffness(fr.model_dump())
            if lam * h > 2.0:
                raise ValueError(
                    f"effects.friction: stiffness {lam:.3g} 1/s is too high for {self.integrator.n_sub} RK4 "
                    f"sub-steps (need stiffness * h <= 2); raise effects.friction.v_reg or integrator.n_sub"
                )
        if self.lock.axis != "none" and self.lock.value is not None and self.stops.enabled:
            lo, hi = getattr(self.stops, self.lock.axis)
            if not lo <= self.lock.value <= hi:
                raise ValueError(f"lock.value {self.lock.value} is outside stops.{self.lock.axis} [{lo}, {hi}]")
        if sum(isinstance(d, Cable) for d in self.disturbances) > 1:
            raise ValueError("disturbances: at most one cable (give its spring, drag and weight in one entry)")
        return self

    def total_delay(self) -> int:
        """Commands between computation and the amplifier output [control periods].

        The computation delay (``delay_samples``) plus the amplifier's transport
        delay (``effects.amplifier_lag.delay_samples``, only when the lag is on):
        both hold whole commands, so they add up in one buffer.
        """
        amp = self.effects.amplifier_lag
        return int(self.delay_samples) + (int(amp.delay_samples) if amp.enabled else 0)

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_profile(cls, name: str = "default", overrides: dict[str, Any] | None = None) -> PlantConfig:
        """Settings of the rig profile ``name``, with ``overrides`` (nested dict) merged on top."""
        data = profile_data(name)
        source = f"plant profile '{name}'"
        if overrides:
            if not isinstance(overrides, dict):
                raise ConfigError(f"{source}: overrides must be a mapping, got {type(overrides).__name__}")
            data = deep_merge(data, overrides)
            source += " with overrides"
        return parse_model(cls, data, source)

    def enabled_effects(self) -> tuple[str, ...]:
        """Names of the switched-on effects, in composition order."""
        return tuple(n for n in EFFECTS if getattr(self.effects, n).enabled)

    def effect_values(self) -> dict[str, dict[str, float]]:
        """Parameters of the switched-on effects, ``{effect: {param: value}}``."""
        out = {}
        for n in self.enabled_effects():
            d = getattr(self.effects, n).model_dump()
            d.pop("enabled")
            out[n] = d
        return out

    def effect_set(self) -> tuple[EffectSet, np.ndarray]:
        """The switched-on effects as an :class:`EffectSet` and their parameter vector ``theta``."""
        es = EffectSet(self.enabled_effects())
        return es, es.vector(self.effect_values())

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict (YAML / JSON), loadable by :func:`load_plant_config`.

        The trust keys only when the file is marked untrusted (a trusted plant's dict, and every key and
        result derived from it, stays what it was before the keys existed)."""
        d = self.model_dump(mode="json")
        if self.trusted:
            d.pop("trusted")
            d.pop("untrusted_because")
        return d

    def save(self, path: str | os.PathLike) -> None:
        """Write these settings as a complete plant YAML file."""
        dump_yaml(path, self.to_dict())

    def table(self) -> str:
        """Short text view of what is switched on."""
        rows = [
            ("profile", self.profile),
            (
                "mismatch",
                ", ".join(f"{n} ±{v:g}" for n, v in self.mismatch.relative.model_dump().items() if v) or "none",
            ),
            ("process noise [N]", f"g {self.process_noise.g:g}, d {self.process_noise.d:g}"),
            ("current noise [A]", f"i_q {self.current_noise.i_q:g}, i_d {self.current_noise.i_d:g}"),
            ("measurement noise [m]", f"g {self.measurement_noise.g:g}, d {self.measurement_noise.d:g}"),
            ("quantization [m]", f"{self.quantization.resolution:g}" if self.quantization.enabled else "off"),
            (
                "current limits [A]",
                f"±{self.current_limits.axis:g}, |i| <= {self.current_limits.amplitude:g}"
                if self.current_limits.enabled
                else "off",
            ),
            ("stops [m]", f"g {self.stops.g}, d {self.stops.d}" if self.stops.enabled else "off"),
            ("lock", self.lock.axis if self.lock.axis == "none" else f"{self.lock.axis} at {self.lock.value}"),
            ("effects", ", ".join(self.enabled_effects()) or "none"),
            ("integrator", f"{self.integrator.method}, {self.integrator.n_sub} sub-steps per period"),
        ]
        if self.delay_samples:
            rows.append(("computation delay", f"{self.delay_samples} samples"))
        if self.disturbances:
            rows.append(("disturbances", ", ".join(d.type for d in self.disturbances)))
        w = max(len(a) for a, _ in rows)
        return "\n".join(f"{a:<{w}}  {b}" for a, b in rows)


# ------------------------------------------------------------ physical parameters
def _envelope_grid(n_g: int = 21) -> list[tuple[float, float]]:
    """Points ``(g, d)`` that bound the hover currents over the tracking envelope.

    Every gap of ``g_envelope`` at ``d = 0`` (no cogging, seed eq. (8)) and at
    ``d = t1 / 2`` (where both cogging terms of seed eq. (9) peak, see MODEL.md).
    """
    gs = np.linspace(k.g_envelope[0], k.g_envelope[1], n_g)
    return [(float(g), d) for g in gs for d in (0.0, k.t1 / 2)]


def hover_envelope_error(params: Params, limit: float | None = None) -> str | None:
    """Why ``params`` cannot hold the mover somewhere in the tracking envelope, or None if they can.

    Uses the shared model's hover currents (``get_model().u_eq``: the root of
    smaller magnitude of the vertical balance, seed eq. (8), with cogging): they
    must be real and finite at every gap of the envelope (15..25 mm), with and
    without cogging. With ``limit`` [A], the hover current's amplitude must
    also stay within it.

    Parameters
    ----------
    params : Params
        Parameter set to check.
    limit : float, optional
        Largest current amplitude the hover may need [A].

    Returns
    -------
    str or None
        One-line reason naming the keys involved and what is allowed.
    """
    p = params.vector()
    if not np.all(np.isfinite(p)):
        bad = [n for n, v in params.as_dict().items() if not math.isfinite(v)]
        return f"{', '.join(bad)}: NaN/inf is not allowed"
    nonpos = [n for n in ("C1", "C2", "C3", "C4", "ell", "Mh", "Mv") if getattr(params, n) <= 0]
    if nonpos or params.xi0 < 0:
        keys = ", ".join([*nonpos, *(["xi0"] if params.xi0 < 0 else [])])
        return f"{keys}: C1..C4, ell, Mh, Mv must be > 0 and xi0 >= 0 (got {_values(params, keys)})"
    grid = _envelope_grid()
    # one call for the whole grid (CasADi evaluates horizontally repeated arguments column by column)
    U = np.asarray(get_model().u_eq(np.array([[g for g, _ in grid]]), np.array([[d for _, d in grid]]), p), float)
    for (g, d), u in zip(grid, U.T, strict=True):
        where = f"g = {g * 1e3:.1f} mm, d = {d * 1e3:.1f} mm"
        if not np.all(np.isfinite(u)):
            # vertical balance C4 f4 i^2 - C3 f3 i + (C2 f2 + ... - G) = 0 has no real root there
            keys = "C2, C3, C4" if d == 0.0 else "C2, C3, C4, xi0, ell"
            return (
                f"{keys}: no current holds the mover at {where} (seed eq. (8) has no real root; got "
                f"{_values(params, keys)}); the hover current must be real and finite over the envelope "
                f"g {k.g_envelope[0] * 1e3:g}..{k.g_envelope[1] * 1e3:g} mm"
            )
        if limit is not None and math.hypot(u[0], u[1]) > limit:
            return (
                f"C2, C3, C4: hovering at {where} needs {math.hypot(u[0], u[1]):.2f} A, more than the "
                f"{limit:g} A current limit (got {_values(params, 'C2, C3, C4')})"
            )
    return None


def _values(params: Params, keys: str) -> str:
    return ", ".join(f"{n} = {getattr(params, n):.6g}" for n in keys.split(", "))


def check_hover_envelope(params: Params, source: str, limit: float | None = None) -> None:
    """Raise a one-line :class:`ConfigError` ``source: <reason>`` if :func:`hover_envelope_error` finds one."""
    why = hover_envelope_error(params, limit)
    if why is not None:
        raise ConfigError(f"{source}: {why}")


# ---------------------------------------------------------------------- file access
def available_profiles() -> list[str]:
    """Names of the shipped rig profiles."""
    return sorted(p.stem for p in PROFILE_DIR.glob("*.yaml"))


def profile_data(name: str) -> dict[str, Any]:
    """Raw settings of the rig profile ``name`` (ConfigError naming the choices if unknown)."""
    choices = available_profiles()
    if name not in choices:
        raise ConfigError(f"unknown plant profile {name!r}; choose from {', '.join(choices)}")
    path = PROFILE_DIR / f"{name}.yaml"
    data = _load_profile(path, path.stat().st_mtime_ns)
    if not isinstance(data, dict):  # pragma: no cover - shipped files are mappings
        raise ConfigError(f"{PROFILE_DIR / name}.yaml: expected a mapping")
    return copy.deepcopy(data)


@functools.lru_cache(maxsize=32)
def _load_profile(path: Path, mtime_ns: int) -> Any:
    """A profile file, parsed once per version of the file (a campaign worker reads it for every run)."""
    return load_yaml(path)


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Nested dict ``base`` with ``over`` merged on top (mappings merge, anything else replaces)."""
    out = copy.deepcopy(base)
    for key, val in over.items():
        if isinstance(val, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], val)
        else:
            out[key] = copy.deepcopy(val)
    return out


def load_plant_config(path: str | os.PathLike) -> PlantConfig:
    """Load a plant YAML file: its ``profile`` (default ``default``) with the file's keys on top.

    Raises
    ------
    ConfigError
        One line naming the file and the key, for anything that does not parse or validate.
    """
    data = load_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    base = data.get("profile", "default")
    if not isinstance(base, str) or base not in available_profiles():
        raise ConfigError(
            f"{path}: profile: unknown plant profile {base!r}; choose from {', '.join(available_profiles())}"
        )
    merged = deep_merge(profile_data(base), data)
    cfg = parse_model(PlantConfig, merged, str(path))
    warn_if_untrusted(cfg, path)
    return cfg


__all__ = [
    "EFFECT_CONFIGS",
    "PROFILE_DIR",
    "AxisForce",
    "CurrentLimits",
    "CurrentNoise",
    "EffectsConfig",
    "Integrator",
    "Lock",
    "MeasurementNoise",
    "Mismatch",
    "PlantConfig",
    "Quantization",
    "RelativeSpread",
    "Stops",
    "available_profiles",
    "check_hover_envelope",
    "deep_merge",
    "hover_envelope_error",
    "load_plant_config",
    "profile_data",
]
