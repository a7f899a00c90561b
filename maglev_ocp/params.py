"""The model's parameter vector ``p``: lumped constants, cogging law and masses.

``p`` is a symbolic input of every model Function (never baked in), so the
plant can perturb it, the estimator can identify it and the controllers can be
given a calibrated one.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import Protocol

import numpy as np
import yaml
from pydantic import Field

from . import constants as k
from .config import Strict, load_yaml, parse_model
from .errors import ConfigError
from .output import atomic_write_text, dump_yaml, plain_data
from .signals import PARAM_NAMES


@dataclass(frozen=True)
class Params:
    """Parameter vector of the shared model (SI units).

    Defaults are the seed's Table III (eps = 0.01) and the spec's cogging law.
    ``xi0 = 0`` switches cogging off, which gives the seed's eq. (2).
    """

    C1: float = 14.20
    C2: float = 796.99
    C3: float = 31.04
    C4: float = 0.07
    xi0: float = 4.0
    ell: float = 3.6e-3
    Mh: float = k.Mh
    Mv: float = k.Mv

    def vector(self) -> np.ndarray:
        """Return ``p`` in the order of :data:`~maglev_ocp.signals.PARAM_NAMES`."""
        return np.array([getattr(self, n) for n in PARAM_NAMES], dtype=float)

    @classmethod
    def from_vector(cls, p: np.ndarray) -> Params:
        """Inverse of :meth:`vector`."""
        p = np.asarray(p, dtype=float).ravel()
        return cls(**{n: float(v) for n, v in zip(PARAM_NAMES, p, strict=True)})

    def as_dict(self) -> dict[str, float]:
        """Plain dict (for JSON / YAML)."""
        return {n: float(v) for n, v in asdict(self).items()}

    def with_(self, **changes: float) -> Params:
        """Copy with some entries replaced."""
        return replace(self, **changes)

    def without_cogging(self) -> Params:
        """Copy with ``xi0 = 0`` (the seed's eq. (2))."""
        return replace(self, xi0=0.0)

    def scaled(self, factors: dict[str, float]) -> Params:
        """Copy with entries multiplied by ``factors`` (e.g. ``{"C1": 1.05}``)."""
        return replace(self, **{n: getattr(self, n) * f for n, f in factors.items()})

    def save(self, path: str | os.PathLike) -> None:
        """Write a parameter file that :func:`load_params` reads back."""
        dump_yaml(path, {"format": "maglev-params/1", **self.as_dict()})


class ParamsFile(Strict):
    """Schema of a parameter YAML file (all keys optional; defaults from Table III).

    Every entry must be finite (NaN/inf refused by :class:`~maglev_ocp.config.Strict`)
    and physical: the lumped constants C1..C4 of seed eq. (2), the masses and the
    cogging decay length ``ell`` are positive (C3 = C4 = 0 would leave no current
    that can hold the mover, seed eq. (8)); the cogging amplitude ``xi0`` is
    non-negative (0: no cogging). Whether the set can hover over the whole
    envelope needs the model and is checked where parameters meet it
    (:func:`maglev_ocp.plant.config.hover_envelope_error`).
    """

    format: str = Field("maglev-params/1", pattern=r"^maglev-params/1$")
    trusted: bool = Field(
        True,
        description="false: the writer could not vouch for these constants (e.g. maglev calibrate --force on data "
        "that do not identify them); every loader warns",
    )
    untrusted_because: list[str] = Field(default_factory=list, description="why the file is marked untrusted")
    C1: float = Field(Params.C1, gt=0, lt=1e4)
    C2: float = Field(Params.C2, gt=0, lt=1e5)
    C3: float = Field(Params.C3, gt=0, lt=1e4)
    C4: float = Field(Params.C4, gt=0, lt=1e3)
    xi0: float = Field(Params.xi0, ge=0, lt=1e3)
    ell: float = Field(Params.ell, gt=0, lt=1.0)
    Mh: float = Field(Params.Mh, gt=0, lt=1e3)
    Mv: float = Field(Params.Mv, gt=0, lt=1e3)


class ParamOverrides(Strict):
    """Partial parameter set, e.g. a scenario's ``plant.params`` block (same bounds as :class:`ParamsFile`)."""

    C1: float | None = Field(None, gt=0, lt=1e4)
    C2: float | None = Field(None, gt=0, lt=1e5)
    C3: float | None = Field(None, gt=0, lt=1e4)
    C4: float | None = Field(None, gt=0, lt=1e3)
    xi0: float | None = Field(None, ge=0, lt=1e3)
    ell: float | None = Field(None, gt=0, lt=1.0)
    Mh: float | None = Field(None, gt=0, lt=1e3)
    Mv: float | None = Field(None, gt=0, lt=1e3)

    def apply(self, base: Params) -> Params:
        """Return ``base`` with the given entries replaced."""
        return replace(base, **{k_: v for k_, v in self.model_dump().items() if v is not None})


class UntrustedModelWarning(UserWarning):
    """A parameter or model file its writer marked ``trusted: false`` was loaded."""


class TrustMarked(Protocol):
    """A loaded file that carries its writer's trust mark (a parameter file, a plant or model file)."""

    trusted: bool
    untrusted_because: list[str]


def warn_if_untrusted(f: TrustMarked, source: str | os.PathLike) -> None:
    """Warn (:class:`UntrustedModelWarning`, one line) when a loaded file is marked ``trusted: false``."""
    if not f.trusted:
        why = "; ".join(f.untrusted_because) or "no reason given"
        warnings.warn(
            f"{source}: marked untrusted by its writer ({why}); results with it cannot be relied on",
            UntrustedModelWarning,
            stacklevel=3,
        )


def load_params(path: str | os.PathLike) -> Params:
    """Load a parameter YAML file (one-line ConfigError on any problem; a warning if it is marked untrusted).

    A model file with fitted effects is refused here with what to write instead
    (``controller: {model: FILE}``): a parameter file carries constants only.
    """
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    if data.get("effects"):
        raise ConfigError(
            f"{path}: effects: a model file with fitted effects, not a parameter file; a controller loads it with "
            f"controller: {{model: {os.path.basename(path)}}} (relative to the scenario file's folder)"
        )
    data.pop("effects", None)
    f = parse_model(ParamsFile, data, str(path))
    warn_if_untrusted(f, path)
    return Params(**{fld.name: getattr(f, fld.name) for fld in fields(Params)})


def model_file_instruction(name: str) -> str:
    """The one sentence every writer of a model file (file header, reports, command output) prints.

    Parameters
    ----------
    name : str
        The model file's name or path as the user should write it.
    """
    return (
        f"Use it in a scenario with `controller: {{model: {name}}}` (FL, NMPC and PID; a relative path is read "
        f"from the scenario file's folder)"
    )


def model_file_text(
    params: Params,
    effects: dict | None = None,
    *,
    written_by: str,
    trusted: bool = True,
    untrusted_because: Sequence[str] = (),
    name: str = "model.yaml",
    extra: dict | None = None,
) -> str:
    """Text of a model file: a header with :func:`model_file_instruction`, the constants, the effects.

    Parameters
    ----------
    params : Params
        The model constants.
    effects : dict, optional
        Fitted effects in the plant profiles' format (``{name: {enabled: true, ...}}``).
    written_by : str
        What wrote it (e.g. ``"maglev calibrate"``), for the header.
    trusted, untrusted_because
        ``trusted: false`` and the reasons when the writer cannot vouch for the constants.
    name : str
        File name the header's instruction shows.
    extra : dict, optional
        Further top-level keys (e.g. a plant file's).
    """
    head = [f"# Model file written by {written_by}: constants (maglev-params/1) and fitted effects."]
    head.append(f"# {model_file_instruction(name)}.")
    if not trusted:
        head.append("# UNTRUSTED: " + "; ".join(untrusted_because))
    data: dict = {"format": "maglev-params/1", "trusted": bool(trusted)}
    if not trusted:
        data["untrusted_because"] = list(untrusted_because)
    data.update(params.as_dict())
    data["effects"] = plain_data(effects or {})
    data.update(plain_data(extra or {}))
    return "\n".join(head) + "\n" + yaml.safe_dump(data, sort_keys=False)


def write_model_file(path: str | os.PathLike, params: Params, **kw) -> None:
    """Atomically write :func:`model_file_text` to ``path`` (keywords as there)."""
    atomic_write_text(path, model_file_text(params, name=os.path.basename(path), **kw))


NOMINAL = Params()
"""Seed Table III (eps = 0.01) with the spec's default cogging law."""
