"""The model's parameter vector ``p``: lumped constants, cogging law and masses.

``p`` is a symbolic input of every model Function (never baked in), so the
plant can perturb it, the estimator can identify it and the controllers can be
given a calibrated one.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, fields, replace

import numpy as np
from pydantic import Field

from . import constants as k
from .config import Strict, load_model
from .output import dump_yaml
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


def load_params(path: str | os.PathLike) -> Params:
    """Load a parameter YAML file (one-line ConfigError on any problem)."""
    f = load_model(ParamsFile, path)
    return Params(**{fld.name: getattr(f, fld.name) for fld in fields(Params)})


NOMINAL = Params()
"""Seed Table III (eps = 0.01) with the spec's default cogging law."""
