"""Base of the effect library: parameters, acceleration terms, the effect base class and shared helpers."""

from __future__ import annotations

import functools
import operator
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import casadi as ca

from ..signals import PARAM_NAMES

Expr = Any  # casadi SX or MX expression

#: Model terms that are magnetic forces (scaled by saturation / end effects).
MAGNETIC_TERMS: frozenset[str] = frozenset(
    {"a_pm", "a_id", "a_rel", "a_cogn", "a_thrust", "a_cogx", "cog_extra_n", "cog_extra_x", "end_x"}
)
VERTICAL_MODEL_TERMS: tuple[str, ...] = ("a_grav", "a_pm", "a_id", "a_rel", "a_cogn")
HORIZONTAL_MODEL_TERMS: tuple[str, ...] = ("a_thrust", "a_cogx")


@dataclass(frozen=True)
class EffectParam:
    """One physical parameter of an effect.

    Attributes
    ----------
    name : str
        Parameter name, unique within its effect.
    default : float
        Typical value (used when a config leaves it out, and as the NLP's start).
    lo, hi : float
        Physical bounds (inclusive), for config validation and for the NLP.
    unit : str
        SI unit.
    description : str
        What it is.
    integer : bool
        Whole numbers only (the amplifier's delay in samples).
    """

    name: str
    default: float
    lo: float
    hi: float
    unit: str
    description: str
    integer: bool = False


@dataclass
class Terms:
    """Acceleration contributions [m/s^2] of one evaluation, by axis and name.

    ``vertical`` sums to ``g_ddot``, ``horizontal`` to ``d_ddot``. Effects scale
    existing entries or add new ones (forces divided by the model's masses).
    """

    vertical: dict[str, Expr] = field(default_factory=dict)
    horizontal: dict[str, Expr] = field(default_factory=dict)

    def scale(self, names: Iterable[str], factor: Expr) -> None:
        """Multiply the named terms (on either axis) by ``factor``."""
        for name in names:
            for axis in (self.vertical, self.horizontal):
                if name in axis:
                    axis[name] = axis[name] * factor

    def g_ddot(self) -> Expr:
        """Vertical acceleration: the sum of the vertical terms."""
        return functools.reduce(operator.add, self.vertical.values())

    def d_ddot(self) -> Expr:
        """Horizontal acceleration: the sum of the horizontal terms."""
        return functools.reduce(operator.add, self.horizontal.values())


class Effect:
    """Base class of an unmodelled effect.

    Subclasses set :attr:`name`, :attr:`params` and override :meth:`currents`
    (a static transformation of the motor currents) and/or :meth:`modify`
    (changes to the acceleration terms). ``theta`` is always a dict from the
    effect's parameter names to (symbolic or numeric) values.
    """

    name: ClassVar[str] = ""
    params: ClassVar[tuple[EffectParam, ...]] = ()
    dynamic: ClassVar[bool] = False  # True if it adds plant states (amplifier lag)

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """Names of the effect's parameters, in vector order."""
        return tuple(q.name for q in cls.params)

    @classmethod
    def defaults(cls) -> dict[str, float]:
        """Default value of each parameter."""
        return {q.name: q.default for q in cls.params}

    @classmethod
    def bounds(cls) -> dict[str, tuple[float, float]]:
        """Physical bounds ``(lo, hi)`` of each parameter."""
        return {q.name: (q.lo, q.hi) for q in cls.params}

    def currents(self, u: Expr, x: Expr, theta: Mapping[str, Expr]) -> Expr:
        """Currents the motor carries, from the currents the amplifier delivers (default: same)."""
        return u

    def modify(self, terms: Terms, x: Expr, u: Expr, p: Expr, theta: Mapping[str, Expr]) -> None:
        """Change ``terms`` in place (default: nothing)."""


def _P(p: Expr) -> dict[str, Expr]:
    return dict(zip(PARAM_NAMES, ca.vertsplit(p), strict=True))


def _smooth_abs(v: Expr, eps: float) -> Expr:
    return ca.sqrt(v**2 + eps**2)


def _abs0(v: Expr, eps: float = 1e-6) -> Expr:
    """``|v|``, smooth at 0 and exactly 0 there: ``v^2 / sqrt(v^2 + eps^2)`` (relative error ``eps^2 / 2v^2``)."""
    return v**2 / ca.sqrt(v**2 + eps**2)
