"""Closed-loop scenarios: what to run, against which plant, to which targets.

A scenario is a YAML file (``scenarios/*.yaml``) validated on load; unknown
keys and bad values are one-line :class:`~maglev_ocp.errors.ConfigError` s
naming the file and the key. A minimal one::

    name: envelope_tour
    seed: 7
    controller: {type: nmpc}          # nmpc | fl | pid, plus their settings
    plant: {profile: default}         # rig profile, plant-file keys, true parameters
    targets:                          # visited in order, each held `hold` s
      - {g: 0.020, d: 0.000, hold: 0.3}
      - {g: 0.016, d: 0.045, hold: 0.3}

Every key (SI units):

``name``
    Folder name of the run's results.
``seed``
    Root of every random draw of the run (plant noise and mismatch, random targets).
``controller``
    ``type`` (``nmpc``, ``fl``, ``pid``), ``backend`` (``python``, ``c``) and the
    settings of that controller, validated by its own settings model
    (``maglev_ocp.controllers.nmpc.NMPCSettings``, ``maglev_ocp.controllers.fl.FLSettings``,
    ``maglev_ocp.controllers.pid.PIDSettings``); e.g. ``delay_samples`` (the loop's
    computation delay the controller predicts through, FL and NMPC) and, for
    every controller, ``model``: the one way from a result to a controller, a
    model file with constants and fitted effects (the ``model.yaml`` that
    ``maglev calibrate`` and ``maglev diagnose`` write,
    :mod:`maglev_ocp.controllers.model_file`); a relative path is read from
    the scenario file's folder, like every file a scenario names.
``controller_params``
    Single entries replacing the controller's constants (``C1: 14.5``) and
    ``cogging: false`` for a cogging-blind model; ``file`` (a parameter YAML,
    deprecated: write ``controller: {model: FILE}``).
``plant``
    ``profile`` (``default``, ``ideal``), ``file`` (a plant YAML), ``params``
    (the rig's nominal parameters, before the profile's random mismatch), and any
    key of a plant file (``process_noise``, ``effects``, ``mismatch``, ...), among
    them ``delay_samples`` (computation delay, control periods) and
    ``disturbances`` (force pulses / steps, payloads, a cable:
    :mod:`maglev_ocp.plant.disturbances`).
``reference``
    How targets become references (:class:`~maglev_ocp.reference.ReferenceSettings`);
    keys left open take the controller's own defaults if it has any (the NMPC:
    minimum-time moves near the limits, ``NMPCSettings.reference_defaults``).
``start``
    Where the mover hovers at t = 0 (``{g, d}``, default 20 mm, 0).
``targets`` / ``random_targets``
    Targets inside the tracking envelope (g in [15, 25] mm, d in [-50, 50] mm),
    each held ``hold`` s; ``random_targets: {n, hold, seed}`` draws ``n`` more,
    uniformly in the envelope, from the scenario seed (or its own ``seed``).
``tolerance``
    Positioning tolerance of the settle checks (0.1 mm).
``checks``
    Extra pass/fail limits (settle time, steady-state RMS error).
"""

from __future__ import annotations

import hashlib
import importlib
import json
import math
import os
import warnings
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails

from . import constants as k
from .config import Strict, format_validation_error, load_yaml, parse_model
from .errors import ConfigError, UserError
from .model import get_model
from .params import NOMINAL, ParamOverrides, Params, load_params
from .plant.config import check_hover_envelope
from .plant.disturbances import persistent_loads, with_payload
from .reference import PlanEffects, ReferenceSettings, Target

#: Controller types: module, settings class, controller class (imported lazily).
CONTROLLERS: dict[str, tuple[str, str, str]] = {
    "fl": ("maglev_ocp.controllers.fl", "FLSettings", "FeedbackLinearization"),
    "nmpc": ("maglev_ocp.controllers.nmpc", "NMPCSettings", "NMPC"),
    "pid": ("maglev_ocp.controllers.pid", "PIDSettings", "PIDController"),
}

_EPS = 1e-12  # slack on envelope checks (targets written in mm convert inexactly)


def controller_classes(ctype: str) -> tuple[type[BaseModel], type]:
    """Settings model and controller class of controller type ``ctype``.

    Raises
    ------
    UserError
        If the controller's module is not available (clear message, not a traceback).
    """
    mod_name, settings_name, cls_name = CONTROLLERS[ctype]
    try:
        mod = importlib.import_module(mod_name)
    except ModuleNotFoundError as err:
        raise UserError(f"controller type {ctype!r} is not available: module {mod_name} is missing ({err})") from None
    try:
        return getattr(mod, settings_name), getattr(mod, cls_name)
    except AttributeError as err:
        raise UserError(f"controller type {ctype!r} is not available: {err}") from None


def _reraise_nested(err: ValidationError, title: str) -> None:
    """Re-raise a nested model's errors so pydantic prefixes their location (``controller.<key>``)."""
    details = []
    for e in err.errors():
        ctx = e.get("ctx")
        d: dict[str, Any] = {"type": e["type"], "loc": e["loc"], "input": e.get("input")}
        if ctx:
            d["ctx"] = ctx
        details.append(InitErrorDetails(**d))  # type: ignore[typeddict-item]
    try:
        exc = ValidationError.from_exception_data(title, details)
    except (TypeError, KeyError, ValueError):  # custom error types: fall back to the first message
        first = err.errors()[0]
        loc = ".".join(str(x) for x in first["loc"])
        raise ValueError(f"{loc}: {first['msg']}") from None
    raise exc


class ControllerSpec(BaseModel):
    """``controller:`` block: type, backend and the controller's own settings.

    The settings keys are validated by the controller's settings model (imported
    lazily, so a scenario for one controller never needs another one's module).
    """

    model_config = ConfigDict(extra="allow")

    type: Literal["nmpc", "fl", "pid"]
    backend: Literal["python", "c"] = "python"
    _settings: Any = PrivateAttr(None)

    @model_validator(mode="wrap")
    @classmethod
    def _delegate(cls, data: Any, handler):
        obj = handler(data)
        settings_cls, _ = controller_classes(obj.type)
        extra = dict(obj.__pydantic_extra__ or {})
        fields = getattr(settings_cls, "model_fields", {})
        for key in ("type", "backend"):  # pass them on if the settings model declares them
            if key in fields:
                extra[key] = getattr(obj, key)
        try:
            settings = settings_cls.model_validate(extra)
        except ValidationError as err:
            _reraise_nested(err, cls.__name__)
        obj._settings = settings
        return obj

    @property
    def settings(self) -> Any:
        """The validated settings model of this controller type."""
        return self._settings

    def to_dict(self) -> dict[str, Any]:
        """``type``, ``backend`` and every setting (defaults filled in)."""
        s = self._settings.model_dump(mode="json") if self._settings is not None else {}
        return {
            "type": self.type,
            "backend": self.backend,
            **{k_: v for k_, v in s.items() if k_ not in ("type", "backend")},
        }


class ControllerParams(ParamOverrides):
    """``controller_params:`` what the controller's model believes.

    Attributes
    ----------
    file : str or None
        Parameter YAML (relative to the scenario file); default: seed Table III.
    cogging : bool
        Keep cogging in the controller's model (``false``: xi0 = 0, cogging-blind).
    C1 ... Mv : float or None
        Single entries replacing those of the file / the nominal set.
    """

    file: str | None = None
    cogging: bool = True

    def resolve(self, root: str | os.PathLike = ".") -> Params:
        """The controller's parameters."""
        base = NOMINAL
        if self.file:
            path = Path(self.file)
            try:
                base = load_params(path if path.is_absolute() else Path(root) / path)
            except ConfigError as err:
                raise ConfigError(f"controller_params.file: {err}") from None
        p = ParamOverrides(**{n: getattr(self, n) for n in ParamOverrides.model_fields}).apply(base)
        return p if self.cogging else p.without_cogging()


class PlantSpec(BaseModel):
    """``plant:`` block: rig profile or plant file, the rig's nominal parameters, and plant-file overrides.

    Any other key is a key of a plant file (see :mod:`maglev_ocp.plant.config`)
    and is validated by :class:`~maglev_ocp.plant.PlantConfig`.
    """

    model_config = ConfigDict(extra="allow")

    profile: str = "default"
    file: str | None = None
    params: ParamOverrides = ParamOverrides()

    def overrides(self) -> dict[str, Any]:
        """The plant-file keys given here (everything but ``profile``, ``file``, ``params``)."""
        return dict(self.__pydantic_extra__ or {})

    def config(self, root: str | os.PathLike = ".", source: str = "scenario"):
        """The :class:`~maglev_ocp.plant.PlantConfig` (ConfigError naming ``plant.<key>``)."""
        from .plant import PlantConfig, load_plant_config
        from .plant.config import deep_merge, profile_data

        if self.file:
            path = Path(self.file)
            try:
                base = load_plant_config(path if path.is_absolute() else Path(root) / path).to_dict()
            except ConfigError as err:
                raise ConfigError(f"{source}: plant.file: {err}") from None
        else:
            try:
                base = profile_data(self.profile)
            except ConfigError as err:
                raise ConfigError(f"{source}: plant.profile: {err}") from None
        data = deep_merge(base, self.overrides())
        try:
            return PlantConfig.model_validate(data)
        except ValidationError as err:
            raise ConfigError(format_validation_error(err, source, prefix="plant.")) from None

    def params_resolved(self) -> Params:
        """The rig's nominal parameters (the profile's mismatch perturbs them in the plant)."""
        return self.params.apply(NOMINAL)


class TargetSpec(Strict):
    """One target: gap and position [m] inside the tracking envelope, held ``hold`` s."""

    g: float
    d: float
    hold: float = Field(gt=0, le=3600)

    @field_validator("g", "d")
    @classmethod
    def _in_envelope(cls, v: float, info: ValidationInfo) -> float:
        lo, hi = k.g_envelope if info.field_name == "g" else k.d_envelope
        if not (math.isfinite(v) and lo - _EPS <= v <= hi + _EPS):
            span = "gap 15..25 mm" if info.field_name == "g" else "d -50..50 mm"
            raise ValueError(f"{v!r} m is outside the tracking envelope [{lo}, {hi}] m ({span})")
        return v


class RandomTargets(Strict):
    """``random_targets:`` ``n`` targets drawn uniformly in a box inside the envelope.

    Drawn from the scenario seed (or ``seed``), rounded to ``resolution``.
    """

    n: int = Field(ge=1, le=1000)
    hold: float = Field(0.4, gt=0, le=3600)
    seed: int | None = Field(None, ge=0, lt=2**63)
    g: tuple[float, float] = k.g_envelope
    d: tuple[float, float] = k.d_envelope
    resolution: float = Field(1e-5, gt=0, le=1e-3)

    @field_validator("g", "d")
    @classmethod
    def _inside(cls, v: tuple[float, float], info) -> tuple[float, float]:
        lo, hi = v
        env = k.g_envelope if info.field_name == "g" else k.d_envelope
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError("must be [low, high] with low <= high")
        if lo < env[0] - _EPS or hi > env[1] + _EPS:
            raise ValueError(f"must lie inside the tracking envelope {list(env)} m")
        return v


class StartSpec(Strict):
    """``start:`` where the mover hovers at rest at t = 0 [m] (inside the stops), and for how long [s]."""

    g: float = Field(0.020, gt=k.g_stop[0], lt=k.g_stop[1])
    d: float = Field(0.0, gt=k.d_stop[0], lt=k.d_stop[1])
    hover: float = Field(
        0.1,
        ge=0.0,
        le=10.0,
        description="time the mover hovers at the start before the first target's move begins [s], as a rig "
        "lifts off and settles before it moves: the controllers' observers and disturbance estimates start from "
        "the first reading, and a minimum-time move begun at that instant carries their start-up transient into "
        "the target (random_nmpc's first gap move: 10.8 µm steady RMS at 0 s, 3.6 µm at 0.06 s); 0: the first "
        "move starts at t = 0",
    )


class Checks(Strict):
    """``checks:`` the tolerance checks that decide a run's exit code.

    Attributes
    ----------
    all_settled : bool
        Every target must be reached and held within ``tolerance``.
    no_stop_hits : bool
        The mover must never hit a mechanical stop.
    currents_within_limits : bool
        Commanded currents within ±8 A per axis and 8 A amplitude.
    max_settle_time_s : float or None
        Upper bound on every target's settle time [s].
    max_rms_error_m : float or None
        Upper bound on every target's steady-state RMS error, both axes, true state [m].
    min_settled_s : float
        A target counts as settled only if it then stays within tolerance for at
        least this long [s].
    """

    all_settled: bool = True
    no_stop_hits: bool = True
    currents_within_limits: bool = True
    max_settle_time_s: float | None = Field(None, gt=0, le=3600)
    max_rms_error_m: float | None = Field(None, gt=0, le=0.1)
    min_settled_s: float = Field(0.05, ge=0, le=3600)


class Scenario(Strict):
    """A closed-loop scenario (see the module docstring for every key)."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.\-]{1,80}$")
    description: str = ""
    seed: int = Field(0, ge=0, lt=2**63)
    controller: ControllerSpec
    controller_params: ControllerParams = ControllerParams()
    plant: PlantSpec = PlantSpec()
    reference: ReferenceSettings = ReferenceSettings()
    start: StartSpec = StartSpec()
    targets: list[TargetSpec] = Field(default_factory=list)
    random_targets: RandomTargets | None = None
    tolerance: float = Field(k.position_tolerance, gt=0, le=0.01)
    checks: Checks = Checks()

    _root_dir: str = PrivateAttr(".")
    _source: str = PrivateAttr("scenario")

    @model_validator(mode="after")
    def _some_target(self) -> Scenario:
        if not self.targets and self.random_targets is None:
            raise ValueError("needs 'targets' or 'random_targets'")
        return self

    @model_validator(mode="after")
    def _controller_reference_defaults(self) -> Scenario:
        """Fill the ``reference:`` keys the scenario leaves unset with the controller's own defaults.

        A controller's settings may say how it wants its moves planned
        (``reference_defaults()``, e.g. the NMPC: minimum-time moves near the
        current limits, which its constraints handle); keys the scenario sets win.
        """
        fn = getattr(self.controller.settings, "reference_defaults", None)
        if fn is None:
            return self
        unset = {k_: v for k_, v in fn().items() if k_ not in self.reference.model_fields_set}
        if unset:
            ref = ReferenceSettings.model_validate({**self.reference.model_dump(exclude_unset=True), **unset})
            self.__dict__["reference"] = ref  # no re-validation of the whole scenario (validate_assignment)
        return self

    # ------------------------------------------------------------------ resolution
    @property
    def root_dir(self) -> str:
        """Folder relative paths (parameter and plant files) are resolved against."""
        return self._root_dir

    @property
    def source(self) -> str:
        """Where the scenario came from (file path), for messages."""
        return self._source

    def with_seed(self, seed: int | None) -> Scenario:
        """Copy with another seed (``None``: unchanged)."""
        if seed is None:
            return self
        new = self.model_copy(update={"seed": int(seed)})
        new._root_dir, new._source = self._root_dir, self._source
        return new

    def seed_sequences(self) -> tuple[np.random.SeedSequence, np.random.SeedSequence]:
        """Independent streams spawned from the scenario seed: (plant, random targets)."""
        plant, targets = np.random.SeedSequence(self.seed).spawn(2)
        return plant, targets

    def target_list(self) -> list[Target]:
        """Targets in order: the explicit ones, then the random draws (deterministic in the seed)."""
        out = [Target(t.g, t.d, t.hold) for t in self.targets]
        rt = self.random_targets
        if rt is not None:
            ss = np.random.SeedSequence(rt.seed) if rt.seed is not None else self.seed_sequences()[1]
            rng = np.random.default_rng(ss)
            u = rng.uniform(size=(rt.n, 2))
            for ug, ud in u:
                g = rt.g[0] + ug * (rt.g[1] - rt.g[0])
                d = rt.d[0] + ud * (rt.d[1] - rt.d[0])
                # rounded to the resolution (and to 12 digits, so 21.12 mm prints as 0.02112)
                g = round(float(np.clip(round(g / rt.resolution) * rt.resolution, *rt.g)), 12)
                d = round(float(np.clip(round(d / rt.resolution) * rt.resolution, *rt.d)), 12)
                out.append(Target(g, d, rt.hold))
        return out

    def controller_model_params(self) -> Params:
        """What the controller's model believes: the constants of ``controller.model`` if given (every
        consumer, the compiled loops included, then uses the model file's), else :class:`ControllerParams`."""
        path = getattr(self.controller.settings, "model", None)
        if not path:
            return self.controller_params.resolve(self.root_dir)
        from maglev_ocp.controllers.model_file import load_controller_model  # the controllers' format, lazily

        cp = self.controller_params
        p = ParamOverrides(**{n: getattr(cp, n) for n in ParamOverrides.model_fields}).apply(
            load_controller_model(path).params
        )
        return p if cp.cogging else p.without_cogging()

    def planning_model(self) -> tuple[Params, PlanEffects | None]:
        """The model the moves are planned on: the one the controller loads.

        With a model file (``controller: {model: FILE}``,
        :mod:`maglev_ocp.controllers.model_file`) its constants and its static effects (the
        planner checks the moves' currents on the model with them, so a plan
        near the limits stays within them on the model the controller predicts
        with); else :meth:`controller_model_params` and no effects.
        """
        path = getattr(self.controller.settings, "model", None)
        if not path:
            return self.controller_model_params(), None
        from maglev_ocp.controllers.model_file import load_controller_model  # the controllers' format, loaded lazily

        cm = load_controller_model(path)
        effects = PlanEffects(cm.effects, tuple(float(v) for v in cm.theta)) if cm.effects else None
        return cm.params, effects

    def model_untrusted(self) -> str | None:
        """Why the controller's model file cannot be relied on, or ``None``.

        A model file whose writer could not vouch for it (``trusted: false``,
        e.g. ``maglev calibrate --force`` on data that do not identify the
        constants) is loaded with a warning; a run with it carries the reasons in
        its own result files (``metrics.json``), so a table built from them later
        still shows it.
        """
        path = getattr(self.controller.settings, "model", None)
        if not path:
            return None
        data = load_yaml(path) or {}
        if not isinstance(data, dict) or data.get("trusted", True) is not False:
            return None
        why = data.get("untrusted_because") or ["no reason given"]
        return f"{path}: " + "; ".join(str(w) for w in why)

    def plant_config(self):
        """The plant's :class:`~maglev_ocp.plant.PlantConfig`."""
        return self.plant.config(self.root_dir, self.source)

    def plant_params(self) -> Params:
        """The rig's nominal parameters (before the profile's random mismatch)."""
        return self.plant.params_resolved()

    def check_resolvable(self) -> None:
        """Resolve everything that can fail (files, plant keys, controller module): ConfigError on failure.

        Then check that the settings can work together (:meth:`check_consistent`).
        """
        cp = self.controller_model_params()
        cfg = self.plant_config()
        self.check_consistent(cp, cfg)

    def positions(self) -> list[tuple[str, float, float]]:
        """Where the mover must hover: ``(key, g, d)`` for the start, every target and the random-target box corners."""
        out = [("start", self.start.g, self.start.d)]
        out += [(f"targets[{i}]", t.g, t.d) for i, t in enumerate(self.targets)]
        rt = self.random_targets
        if rt is not None:
            ds = sorted({*rt.d, *((0.0,) if rt.d[0] < 0.0 < rt.d[1] else ())})
            out += [("random_targets", g, d) for g in rt.g for d in ds]
        return out

    def check_consistent(self, ctrl_params: Params, plant_cfg: Any) -> None:
        """Refuse settings that cannot work together (one-line :class:`ConfigError` naming the keys).

        - the controller's and the rig's parameters must give a real, finite
          hover current over the whole tracking envelope (seed eq. (8));
        - hovering at the start and at every target must fit the controller's
          and (if switched on) the plant's current limits;
        - the start and the targets must lie inside the plant's stops (if switched on);
        - a payload, a force step on the gap or a cable's pull (``plant.disturbances``)
          must leave the rig able to hover at the start and every target within
          its current limits once it is on;
        - the NMPC's soft gap band must be a band (``g_min < g_max``) holding every target;
        - with ``checks.all_settled``, every hold must be longer than ``checks.min_settled_s``.
        """
        check_hover_envelope(ctrl_params, "controller_params")
        check_hover_envelope(self.plant_params(), "plant.params")
        self._check_limits(ctrl_params, plant_cfg)
        self._check_stops(plant_cfg)
        self._check_loads(plant_cfg)
        self._check_soft_gap()
        if self.checks.all_settled:
            holds = [(f"targets[{i}].hold", t.hold) for i, t in enumerate(self.targets)]
            if self.random_targets is not None:
                holds.append(("random_targets.hold", self.random_targets.hold))
            for key, hold in holds:
                if hold <= self.checks.min_settled_s:
                    raise ConfigError(
                        f"{key}: {hold:g} s is not longer than checks.min_settled_s = {self.checks.min_settled_s:g} s, "
                        "so the target can never count as settled"
                    )

    def _check_limits(self, ctrl_params: Params, plant_cfg: Any) -> None:
        """Hover currents at every position within the controller's and the plant's current limits."""
        u_eq = get_model().u_eq
        st = self.controller.settings
        ctrl_lims = [
            (f"controller.{n}", float(getattr(st, n))) for n in ("i_amp_max", "current_limit") if hasattr(st, n)
        ]
        ctrl_axis = [(f"controller.{n}", float(getattr(st, n))) for n in ("i_axis_max",) if hasattr(st, n)]
        cl = plant_cfg.current_limits
        plant_amp = [("plant.current_limits.amplitude", cl.amplitude)] if cl.enabled else []
        plant_axis = [("plant.current_limits.axis", cl.axis)] if cl.enabled else []
        for who, params, amp_lims, axis_lims in (
            ("the controller's model", ctrl_params, ctrl_lims, ctrl_axis),
            ("the rig", self.plant_params(), plant_amp, plant_axis),
        ):
            if not (amp_lims or axis_lims):
                continue
            p = params.vector()
            for where, g, d in self.positions():
                u = np.asarray(u_eq(g, d, p), dtype=float).ravel()
                need_amp, need_axis = math.hypot(u[0], u[1]), float(np.max(np.abs(u)))
                for key, lim in amp_lims:
                    if need_amp > lim:
                        raise ConfigError(
                            f"{key}: {lim:g} A is below the {need_amp:.2f} A {who} needs to hover at {where} "
                            f"(g = {g * 1e3:.2f} mm, d = {d * 1e3:.2f} mm); raise it or move the target"
                        )
                for key, lim in axis_lims:
                    if need_axis > lim:
                        raise ConfigError(
                            f"{key}: {lim:g} A is below the {need_axis:.2f} A per axis {who} needs to hover at "
                            f"{where} (g = {g * 1e3:.2f} mm, d = {d * 1e3:.2f} mm); raise it or move the target"
                        )

    def _check_loads(self, plant_cfg: Any) -> None:
        """Hover under every persistent gap load (payload, force step, cable) within the plant's limits.

        A force ``F`` on the gap axis asks the magnets for what a mass ``F / G``
        more would (the vertical balance of seed eq. (8) times the moving mass),
        so each load state is checked as the payload ``m + F / G``.
        """
        items = list(getattr(plant_cfg, "disturbances", []))
        if not items:
            return
        cl = plant_cfg.current_limits
        u_eq = get_model().u_eq
        base = self.plant_params()
        for i, t, mass, extra_g in persistent_loads(items):
            d_i = items[i]
            field = {"payload": "mass", "force_step": "amplitude"}.get(d_i.type, "weight_g/stiffness_g")
            key = f"plant.disturbances[{i}].{field}"
            for where, g, d in self.positions():
                m_eq = mass + extra_g(g) / k.G
                if m_eq <= -0.5 * base.Mv:
                    raise ConfigError(
                        f"{key}: from t = {t:g} s the gap load is an upward pull of {-m_eq * k.G:.1f} N, more than "
                        f"half the mover's weight; the stage is not built for that"
                    )
                u = np.asarray(u_eq(g, d, with_payload(base, m_eq).vector()), dtype=float).ravel()
                at = f"at {where} (g = {g * 1e3:.2f} mm, d = {d * 1e3:.2f} mm)"
                if not np.all(np.isfinite(u)):
                    raise ConfigError(
                        f"{key}: from t = {t:g} s no current holds the mover {at} (load {mass:g} kg payload and "
                        f"{extra_g(g):g} N on g; seed eq. (8) has no real root)"
                    )
                need = math.hypot(u[0], u[1])
                if cl.enabled and (need > cl.amplitude or float(np.max(np.abs(u))) > cl.axis):
                    raise ConfigError(
                        f"{key}: from t = {t:g} s hovering {at} needs {need:.2f} A (load {mass:g} kg payload and "
                        f"{extra_g(g):g} N on g), more than plant.current_limits ({cl.axis:g} A per axis, "
                        f"{cl.amplitude:g} A amplitude)"
                    )

    def _check_stops(self, plant_cfg: Any) -> None:
        """Start and targets strictly inside the plant's stops (if they are switched on)."""
        stops = plant_cfg.stops
        if not stops.enabled:
            return
        for where, g, d in self.positions():
            for axis, v in (("g", g), ("d", d)):
                lo, hi = getattr(stops, axis)
                if not lo < v < hi:
                    raise ConfigError(f"{where}.{axis}: {v:g} m is not inside plant.stops.{axis} [{lo:g}, {hi:g}] m")

    def _check_soft_gap(self) -> None:
        """The NMPC's soft gap band: ``g_min < g_max``, every position inside it (if the band is on)."""
        sg = getattr(self.controller.settings, "soft_gap", None)
        if sg is None:
            return
        if not sg.g_min < sg.g_max:
            raise ConfigError(
                f"controller.soft_gap: g_min = {sg.g_min:g} m must be below g_max = {sg.g_max:g} m "
                "(the band the predicted gap is kept in)"
            )
        if sg.stride <= 0:
            return
        for where, g, _ in self.positions():
            if not sg.g_min <= g <= sg.g_max:
                raise ConfigError(
                    f"{where}.g: {g:g} m is outside controller.soft_gap [{sg.g_min:g}, {sg.g_max:g}] m, "
                    "so the NMPC would be penalized for reaching it"
                )

    def resolved(self) -> dict[str, Any]:
        """The scenario with every default filled in and random targets drawn (loadable again).

        Controller parameters are written out as values (``cogging`` folded into
        ``xi0``), the plant as its complete settings.
        """
        cp = self.controller_model_params().as_dict()
        cfg = self.plant_config().to_dict()
        plant = {"params": self.plant_params().as_dict(), **cfg}
        return {
            "name": self.name,
            "description": self.description,
            "seed": self.seed,
            "controller": self.controller.to_dict(),
            "controller_params": cp,
            "plant": plant,
            "reference": self.reference.model_dump(mode="json"),
            "start": self.start.model_dump(mode="json"),
            "targets": [{"g": t.g, "d": t.d, "hold": t.hold} for t in self.target_list()],
            "tolerance": self.tolerance,
            "checks": self.checks.model_dump(mode="json"),
        }

    def key(self) -> str:
        """JSON of what a built controller depends on (type, backend, settings, believed parameters, and the
        content of its model file: a file rewritten between two runs, e.g. by a new ``maglev diagnose``, must
        not reuse the controller built from its old content)."""
        path = getattr(self.controller.settings, "model", None)
        model = hashlib.sha256(Path(path).read_bytes()).hexdigest() if path and Path(path).is_file() else None
        return json.dumps(
            {
                "controller": self.controller.to_dict(),
                "params": self.controller_model_params().as_dict(),
                "model_file_sha256": model,
            },
            sort_keys=True,
        )


def scenario_from_dict(data: Any, source: str = "scenario", root_dir: str | os.PathLike = ".") -> Scenario:
    """Validate a scenario mapping (one-line ConfigError naming ``source`` and the key)."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level, got {type(data).__name__}")
    data = _model_path_from(data, root_dir)
    try:
        sc = parse_model(Scenario, data, source)
    except ConfigError:
        raise
    except UserError as err:  # e.g. a controller module that is not available
        raise UserError(f"{source}: controller: {err}") from None
    sc._root_dir = str(root_dir)
    sc._source = source
    try:
        sc.check_resolvable()
    except ConfigError as err:
        msg = str(err)
        raise ConfigError(msg if msg.startswith(source) else f"{source}: {msg}") from None
    return sc


def _model_path_from(data: dict, root_dir: str | os.PathLike) -> dict:
    """``controller.model`` read from the scenario file's folder (``root_dir``) when relative, like every file
    a scenario names; ``controller_params.file`` with ``controller.model`` is refused (two sources of constants),
    and ``controller_params.file`` alone still works with a one-line deprecation warning."""
    ctrl = data.get("controller")
    cp = data.get("controller_params")
    old = cp.get("file") if isinstance(cp, dict) else None
    model = ctrl.get("model") if isinstance(ctrl, dict) else None
    if old is not None and model is not None:
        raise ConfigError(
            "controller_params.file: give the controller's constants once, in controller: {model: FILE} "
            "(drop controller_params.file)"
        )
    if old is not None:
        warnings.warn(
            f"controller_params.file is deprecated: write controller: {{model: {old}}} (same file, read from the "
            "scenario file's folder)",
            FutureWarning,
            stacklevel=3,
        )
    if isinstance(model, str) and model.strip() and not Path(model).is_absolute():
        data = {**data, "controller": {**ctrl, "model": str(Path(root_dir) / model)}}
    return data


def load_scenario(path: str | os.PathLike) -> Scenario:
    """Load and validate a scenario YAML file.

    Raises
    ------
    ConfigError
        One line naming the file and the key for anything that does not parse,
        validate or resolve (parameter / plant files, plant keys, targets).
    """
    path = Path(path)
    data = load_yaml(path)
    return scenario_from_dict(data, str(path), path.resolve().parent)


__all__ = [
    "CONTROLLERS",
    "Checks",
    "ControllerParams",
    "ControllerSpec",
    "PlantSpec",
    "RandomTargets",
    "Scenario",
    "StartSpec",
    "TargetSpec",
    "controller_classes",
    "load_scenario",
    "scenario_from_dict",
]
