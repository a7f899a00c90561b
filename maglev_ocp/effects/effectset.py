"""The registry of effects and their composition on the shared model (:class:`EffectSet`)."""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping, Sequence

import casadi as ca
import numpy as np

from ..model import get_model
from .amplifier import AmplifierLag
from .base import HORIZONTAL_MODEL_TERMS, VERTICAL_MODEL_TERMS, Effect, Expr, Terms
from .cogging import Cogging
from .commutation import CommutationOffset
from .end_effect import EndEffect
from .friction import Friction
from .lumped import EddyDrag, ParameterError
from .saturation import Saturation

#: Registry of effects, in composition order (current transforms, added forces, scalings, parameter error).
EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (CommutationOffset, AmplifierLag, Cogging, Friction, EddyDrag, Saturation, EndEffect, ParameterError)
}
EFFECT_ORDER: tuple[str, ...] = tuple(EFFECTS)


def effect(name: str) -> type[Effect]:
    """The effect class called ``name`` (KeyError naming the choices otherwise)."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"unknown effect {name!r}; choose from {', '.join(EFFECT_ORDER)}") from None


class EffectSet:
    """A set of effects composed on top of the shared model.

    Parameters
    ----------
    names : iterable of str
        Effect names from :data:`EFFECTS` (any order; duplicates ignored).

    Attributes
    ----------
    effects : tuple of Effect
        Instances in composition order.
    param_names : tuple of str
        ``"<effect>.<param>"`` for every parameter, the order of ``theta``.

    Examples
    --------
    >>> es = EffectSet(["friction", "saturation"])
    >>> theta = es.vector({"friction": {"coulomb_d": 0.3}})   # others at their defaults
    >>> a = es.accel_function()(x, u, p, theta)                 # (g_ddot, d_ddot)
    """

    def __init__(self, names: Iterable[str] = ()):
        wanted = set(names)
        for n in wanted:
            effect(n)
        self.names: tuple[str, ...] = tuple(n for n in EFFECT_ORDER if n in wanted)
        self.effects: tuple[Effect, ...] = tuple(EFFECTS[n]() for n in self.names)
        self.param_names: tuple[str, ...] = tuple(f"{e.name}.{q}" for e in self.effects for q in e.param_names())
        self.n_theta = len(self.param_names)

    @property
    def has_lag(self) -> bool:
        """True if the amplifier lag is in the set (the plant then carries current states)."""
        return "amplifier_lag" in self.names

    def defaults(self) -> np.ndarray:
        """``theta`` with every parameter at its default."""
        return np.array([q.default for e in self.effects for q in e.params], dtype=float)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper physical bounds of ``theta``."""
        lo = np.array([q.lo for e in self.effects for q in e.params], dtype=float)
        hi = np.array([q.hi for e in self.effects for q in e.params], dtype=float)
        return lo, hi

    def vector(self, values: Mapping[str, Mapping[str, float]] | None = None) -> np.ndarray:
        """Build ``theta`` from ``{effect: {param: value}}``; missing entries take their defaults."""
        values = dict(values or {})
        unknown = set(values) - set(self.names)
        if unknown:
            raise KeyError(f"effects {sorted(unknown)} are not in this set {self.names}")
        out = []
        for e in self.effects:
            given = dict(values.get(e.name, {}))
            bad = set(given) - set(e.param_names())
            if bad:
                raise KeyError(f"effect {e.name!r} has no parameters {sorted(bad)}; it has {e.param_names()}")
            out.extend(float(given.get(q.name, q.default)) for q in e.params)
        return np.array(out, dtype=float)

    def split(self, theta: Expr | Sequence[float]) -> dict[str, dict[str, Expr]]:
        """``theta`` as ``{effect: {param: value}}`` (symbolic or numeric)."""
        if isinstance(theta, (ca.SX, ca.MX, ca.DM)):
            items = ca.vertsplit(theta) if self.n_theta else []
        else:
            items = list(np.asarray(theta, dtype=float).ravel())
        if len(items) != self.n_theta:
            raise ValueError(f"theta has {len(items)} entries, this effect set needs {self.n_theta}")
        out: dict[str, dict[str, Expr]] = {}
        i = 0
        for e in self.effects:
            out[e.name] = {}
            for q in e.params:
                out[e.name][q.name] = items[i]
                i += 1
        return out

    def terms(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Terms:
        """All acceleration terms with the effects applied (``u``: amplifier output currents)."""
        th = self.split(theta)
        for e in self.effects:
            u = e.currents(u, x, th[e.name])
        parts = get_model().accel_terms(x, u, p)
        names = (*VERTICAL_MODEL_TERMS, *HORIZONTAL_MODEL_TERMS)
        t = dict(zip(names, parts, strict=True))
        terms = Terms(
            vertical={n: t[n] for n in VERTICAL_MODEL_TERMS}, horizontal={n: t[n] for n in HORIZONTAL_MODEL_TERMS}
        )
        for e in self.effects:
            e.modify(terms, x, u, p, th[e.name])
        return terms

    def accel(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Expr:
        """Modified accelerations ``(g_ddot, d_ddot)`` as a 2-vector expression.

        Parameters
        ----------
        x : SX/MX (4)
            State ``(g, g_dot, d, d_dot)``.
        u : SX/MX (2)
            Currents the amplifiers deliver (after any lag).
        p : SX/MX (8)
            Model parameter vector.
        theta : SX/MX (n_theta)
            Effect parameters in :attr:`param_names` order.
        """
        terms = self.terms(x, u, p, theta)
        return ca.vertcat(terms.g_ddot(), terms.d_ddot())

    def x_dot(self, x: Expr, u: Expr, p: Expr, theta: Expr) -> Expr:
        """Continuous dynamics with the effects: ``(g_dot, g_ddot, d_dot, d_ddot)``."""
        a = self.accel(x, u, p, theta)
        return ca.vertcat(x[1], a[0], x[3], a[1])

    def accel_function(self) -> ca.Function:
        """Cached CasADi Function ``accel_<names>(x, u, p, theta) -> a`` (a = (g_ddot, d_ddot))."""
        return _accel_function(self.names)


@functools.lru_cache(maxsize=64)
def _accel_function(names: tuple[str, ...]) -> ca.Function:
    es = EffectSet(names)
    m = get_model()
    theta = ca.SX.sym("theta", es.n_theta)
    a = es.accel(m.x, m.u, m.p, theta)
    label = "_".join(names) or "none"
    return ca.Function(f"accel_{label}", [m.x, m.u, m.p, theta], [a], ["x", "u", "p", "theta"], ["a"])


@functools.lru_cache(maxsize=32)
def effect_delta_function(names: tuple[str, ...]) -> ca.Function:
    """``effect_delta(x, u, p, theta) -> (dg_ddot, dd_ddot)``: what the effects add to the model's accelerations.

    The effect library's accelerations (currents transformed, terms scaled,
    forces added, :meth:`EffectSet.accel`) minus the shared model's at the
    same state and currents: how a controller's model file
    (:mod:`maglev_ocp.controllers.model_file`) and the reference planner
    (:mod:`maglev_ocp.reference`) add fitted effects to the shared model.
    """
    m = get_model()
    es = EffectSet(names)
    x, u, p = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("p", m.np_)
    theta = ca.SX.sym("theta", es.n_theta)
    f = m.f(x, u, p)
    delta = es.accel(x, u, p, theta) - ca.vertcat(f[1], f[3])
    return ca.Function("effect_delta", [x, u, p, theta], [delta], ["x", "u", "p", "theta"], ["delta"])
