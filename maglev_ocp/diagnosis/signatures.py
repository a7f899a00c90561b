"""What each library effect looks like in the residual: its physical signature, and a test of it.

A claim that an effect is in the data must rest on the effect's own physics, not on a fit that happens to
lower the residual: a flexible member can soak up another effect's law misfit, or a resonance outside the
library (issue 27). Each library effect is described here by its **signature** (:class:`Signature`): the
variables it depends on (gap ``g``, position ``d``, velocities, currents, current rates), its period in ``d``
(harmonics of seed eq. (9)'s ``2 t1`` for cogging, the slot pitch ``t1`` among them; the pole pitch ``tau``
for the end effect's ripple, MODEL.md), its
symmetry (friction odd in each velocity, eddy drag odd in each velocity and its lift even in the horizontal one, the
end effect localized at each end of the stroke, :func:`end_columns`), its monotonicity (saturation: a smooth
monotone loss in ``g``) and the channels it acts on. A signature is turned into a small
linear basis of the residual samples' features (:attr:`~.residuals.PreparedRun.feat`), a local linearization of
every law with that signature.

:func:`evidence` measures how much of a residual (of the model *without* the effect, on the held-out runs) the
signature's basis explains beyond the bases of the other effects named with it, and compares it with a null
reference: the same statistic with the residual circularly shifted against the features (which keeps the
residual's own spectrum, so a smooth remainder of another effect cannot pass as evidence). :func:`locate_gap`
names what no signature can: a period in ``d`` that is not a library period, a dependence on time alone.
Pure numpy; a few milliseconds per test.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import BSpline

from .. import constants as k
from .library import MIN_PERIODS
from .residuals import CHANNELS, Residual

Feat = dict[str, np.ndarray]
#: A basis column: a function of a residual sample's features.
Column = Callable[[Feat], np.ndarray]

_G_REF = 10e-3  # gap at which the shapes are referred [m] (the model's nominal gap, MODEL.md)
_V_SIGN = 2e-3  # velocity scale of the smoothed sign of a friction force [m/s]


def _sincos(period: float, harmonic: int, var: str = "d") -> list[Column]:
    w = 2 * math.pi * harmonic / period
    return [lambda f, w=w: np.sin(w * f[var]), lambda f, w=w: np.cos(w * f[var])]


def _spanned(col: Column, period: float) -> Column:  # nil where the samples span < MIN_PERIODS of the period
    return lambda f: col(f) if np.ptp(f["d"]) >= MIN_PERIODS * period else np.zeros(len(f["d"]))


def _times(cols: Sequence[Column], by: Column) -> list[Column]:
    return [lambda f, c=c: c(f) * by(f) for c in cols]


def _dg(f: Feat) -> np.ndarray:
    return (f["g"] - _G_REF) / 1e-3


#: Smooth steps per end of the end effect's signature (:func:`end_columns`).
END_STEPS: int = 2
#: The end effect's columns are nil for ``|d|`` below this fraction of the farther end of the stroke the data cover.
END_MIDDLE: float = 0.25


def _dg_mean(f: Feat) -> np.ndarray:
    """The gap about the samples' mean, per 10 mm (0 for samples at one gap)."""
    g = f["g"]
    return (g - float(np.mean(g))) / 10e-3 if len(g) else g


def _beyond_flat(v: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``v (h - c)`` with ``c`` such that it is orthogonal to ``v`` over the samples: a drag whose coefficient
    follows ``h``, without its flat part."""
    vv = float(v @ v)
    return v * (h - (float((v * v) @ h) / vv if vv > 0 else 0.0))


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """``0`` below 0, ``1`` above 1, ``x^3 (10 - 15 x + 6 x^2)`` between (twice continuously differentiable)."""
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def _end_step(f: Feat, side: int, j: int, n: int = END_STEPS, middle: float = END_MIDDLE) -> np.ndarray:
    """Step ``j`` of ``n`` at the end ``side`` (+1: ``d > 0``, -1: ``d < 0``) of the stroke the samples cover
    (nil where that side does not reach beyond the middle)."""
    d = f["d"]
    if not len(d):
        return np.zeros_like(d)
    reach = {s: float(np.percentile(s * d, 99.5)) for s in (1, -1)}
    lo, hi = middle * max(reach.values()), reach[side]
    if not hi > lo:
        return np.zeros_like(d)
    width = (hi - lo) / n
    return _smoothstep((side * d - lo - j * width) / width)


def end_columns(n: int = END_STEPS, middle: float = END_MIDDLE) -> list[Column]:
    """The end effect's localized columns: ``n`` smooth steps in the overhang at each end, each end on its own.

    An end effect is a function of each end's overhang: the array (length ``pm tau``, MODEL.md) leaves the
    stator at ``d = e_+`` on one side and ``d = -e_-`` on the other, and what it loses there (the pull's and the
    thrust's share of the overlap, ``-dW/dg`` of the overlap's co-energy ``W``) and the end force it feels
    (``F_d = -dW/dd``, virtual work: Furlani, *Permanent Magnet and Electromechanical Devices*, 2001, ch. 4; the
    end detent force of PM linear motors) are nil while the array fully overlaps the stator and grow with the
    overhang of that end, with an onset, a fringing width and a size of each end's own. Per end ``s = +-1``:
    ``u = s d``; over ``[lo, hi]`` with ``hi`` the 99.5 % quantile of ``u`` (the stroke the samples cover on that
    side) and ``lo`` a fraction ``middle`` of the farther side's (``d = 0`` is the centre of the stroke,
    MODEL.md; a side that does not reach beyond ``lo`` has no end in the data and its columns are nil),
    ``n`` steps ``S((u - lo - j w) / w)``, ``w = (hi - lo) / n``, ``S`` the
    smootherstep (:func:`_smoothstep`): each is 0 below its onset and 1 above it, so that a non-negative sum of
    them is any smooth profile that only grows with the overhang, and every column is exactly 0 in the middle
    of the stroke, ``|d| < lo``. In the signature (:data:`SIGNATURES`) the current-free columns (the end force
    along ``d``, the pull's loss along ``g``) also come times ``(g - 10 mm) / 1 mm``: their size falls as the gap
    opens (the co-energy's, as the pull it comes from); times ``i_q`` (the thrust's loss) and ``i_d`` (the
    PM-current pull's loss) they do not.

    That is what separates an end effect from other smooth functions of ``d``: a spring or a cable's pull acts
    over the whole stroke (in the middle too: the signature is judged beyond a linear function of ``d``,
    :data:`SIGNATURES`' ``beyond``), an encoder or sensor error follows the motion, cogging and the thrust ripple
    are periodic in ``d``. In the same way every localized column is judged beyond its uniform counterpart over
    the whole stroke: the steps times ``g - 10 mm`` beyond ``g - 10 mm`` itself (a loss or force that follows
    the gap everywhere is a saturation or a gap law), the thrust's and the PM-current pull's loss at the ends
    beyond a uniform scale of ``i_q`` and ``i_d`` (a constant's error). Without that, on a stroke that dwells at
    its ends (a sinusoid spends two thirds of its time beyond half its amplitude) the localized columns cover
    most samples and pass for functions of ``g`` and the currents alone. A spring whose stiffness follows the
    gap is magnetic, and on a stator of uniform slots only its ends give one: it is the end effect's. ``2 n``
    columns per channel and factor (``n = 2``: 16 horizontal, 12 vertical) keep the circular-shift null's power.
    """
    return [lambda f, s=s, j=j: _end_step(f, s, j, n, middle) for s in (1, -1) for j in range(n)]


#: Smooth steps per end of the end-localized loss saturation's signature is judged beyond (:data:`SIGNATURES`).
SATURATION_END_STEPS: int = 4

#: Cubic B-splines in the gap of an effect's amplitude at full freedom (:attr:`Signature.own`).
GAP_SPLINES: int = 5


def gap_range(g: np.ndarray) -> tuple[float, float] | None:
    """The 0.5..99.5 % range of the samples' gap over which :func:`_gap_spline`'s B-splines lie (``None``: no
    samples, or all at one gap)."""
    if not len(g):
        return None
    lo, hi = (float(x) for x in np.percentile(g, [0.5, 99.5]))
    return (lo, hi) if hi > lo else None


def _gap_spline(f: Feat, j: int, n: int = GAP_SPLINES) -> np.ndarray:
    """B-spline ``j`` of ``n`` cubic ones over the 0.5..99.5 % range of the samples' gap (:func:`gap_range`)."""
    g = f["g"]
    rng = gap_range(g)
    if rng is None:
        return np.ones_like(g) if j == 0 else np.zeros_like(g)  # empty, or every sample at one gap
    return _bsplines(g, *rng, n)[:, j]


def _spring(f: Feat) -> np.ndarray:
    """A force linear in ``d`` over the whole stroke (a spring, a cable's pull): what an end effect is not."""
    return f["d"] / 0.05


@dataclass(frozen=True)
class Signature:
    """The physical signature of one library effect.

    Attributes
    ----------
    effect : str
        Library effect name (the verdict's vocabulary).
    variables : tuple of str
        Features it depends on (keys of :attr:`~.residuals.PreparedRun.feat`).
    channels : tuple of str
        Channels it acts on (:data:`~.residuals.CHANNELS`).
    periods_m : tuple of float
        Its periods in ``d`` [m] (empty: not periodic).
    symmetry : str
        What it obeys, in words (odd in velocity, even in d, monotone in g, ...).
    basis : dict
        ``{channel: [columns]}``: a linear basis of laws with this signature, per channel.
    core : dict
        ``{channel: [columns]}``: the part of the signature that must show *at a fixed state*
        (:func:`core_evidence`): beyond a flexible function of ``fixed`` (empty: no such test).
    fixed : tuple of str
        The state variables held fixed by the core test.
    dynamic : bool
        The effect is no map of the state and the currents (the amplifier lag: a force following the current
        *rate*): its evidence must show at a fixed state, beyond a flexible static map (:func:`static_basis`).
    beyond : dict
        ``{channel: [columns]}``: laws of another kind that the basis also spans in part (the end effect's: a
        spring, a linear function of the gap and a uniform scale of the current's force over the whole stroke);
        the basis must show beyond them, as beyond the other effects' bases.
    own : dict
        ``{channel: [columns]}``: the effect's shape at full freedom in its own variables (cogging: its harmonics
        times cubic B-splines in the gap), for :func:`angle_lock`.
    angle_free : bool
        The effect is fixed to the mover's position, not to the currents' electrical angle (cogging): a ripple of
        its shape that moves along ``d`` with the current vector's angle is not its (:func:`angle_lock`).
    """

    effect: str
    variables: tuple[str, ...]
    channels: tuple[str, ...]
    periods_m: tuple[float, ...]
    symmetry: str
    basis: dict[str, list[Column]]
    core: dict[str, list[Column]] = field(default_factory=dict)
    fixed: tuple[str, ...] = ()
    dynamic: bool = False
    beyond: dict[str, list[Column]] = field(default_factory=dict)
    own: dict[str, list[Column]] = field(default_factory=dict)
    angle_free: bool = False

    def matrix(self, feat: Feat, channel: str, part: str = "basis") -> np.ndarray:
        """The basis (``part``: ``"beyond"`` or ``"own"``, those columns) evaluated on a run's
        residual samples, shape ``(n, p)`` (``p = 0`` off its channels)."""
        cols = getattr(self, part).get(channel, [])
        n = len(feat["t"]) if "t" in feat else 0
        if not cols or n == 0:
            return np.zeros((n, 0))
        return np.column_stack([np.asarray(c(feat), float) for c in cols])


def _saturation_core(sat: Sequence[Column], i_q: Column, i_d: Column) -> dict[str, list[Column]]:
    """What makes a loss saturation and not another law of the gap: it is a loss of the magnetic *terms*.

    The iron saturates on the total flux and every magnetic force is carried by that flux: the magnets'
    pull (``B^2``), the PM-current pull (``B i_d``), the thrust (``B i_q``) and the reluctance term. Whatever
    the law of the loss (a field, current-term or per-term member, an exponential, a knee or a learned shape),
    it scales the current-carrying terms too, so at a *fixed* gap and position the loss changes with the
    currents: ``s(g) i_d`` and ``s(g) i_d^2`` in the vertical channel, ``s(g) i_q`` and ``s(g) i_q i_d`` in the
    horizontal one (the thrust loses with the field whatever else does); a loss in the current magnitude (the
    winding's own flux saturating its paths, :meth:`~maglev_ocp.effects.Saturation.current_loss`) adds ``|i| i_d``,
    ``|i|^2 i_d`` and ``|i| i_q``, ``|i|^2 i_q``. A gap that is a function of the state
    alone (a sensor's bow, a soft-steel part's pull, a spring) does not follow the currents there: the
    flexible function of ``(g, d)`` fitted first takes all of it (:func:`core_evidence`).
    """
    return {"vertical": _times(sat, i_d) + _times(sat, lambda f: f["i_d"] ** 2) + _times(_I_MAG, i_d),
            "horizontal": _times(sat, i_q) + _times(sat, lambda f: f["i_q"] * f["i_d"])
            + _times(_I_MAG, i_q)}  # fmt: skip


def _i2(f: Feat) -> np.ndarray:
    """The squared current magnitude ``i_q^2 + i_d^2`` (the winding's co-energy ``L |i|^2``; the current loss)."""
    return f["i_q"] ** 2 + f["i_d"] ** 2


#: The current loss's columns (:meth:`~maglev_ocp.effects.Saturation.current_loss`): the current magnitude and its
#: square, which times a current term are what a loss growing with ``|i|`` takes from it.
_I_MAG: tuple[Column, ...] = (lambda f: np.hypot(f["i_q"], f["i_d"]), _i2)


def _catalogue() -> dict[str, Signature]:
    t1, tau = k.t1, k.tau
    # Cogging: harmonics 1..6 of seed eq. (9)'s period 2 t1 (its own law is sin(pi d / t1)); the slot pitch t1 and
    # its 2nd and 3rd harmonics are k = 2, 4, 6 (the co-energy member's harmonics, Cogging.energy_forces).
    cog = [c for h in range(1, 7) for c in _sincos(2 * t1, h)]
    cog_g = cog + _times(cog, _dg)  # amplitude a smooth function of g (eq. (9): exponential in g)
    # A stator that is not uniform: harmonics 1, 2 of the array's period 2 tau (the pole-pair co-energy), judged
    # beyond a spring, a linear gap law and friction's Coulomb and viscous columns; not in ``own`` nor the periods
    # (angle lock; gap locator). Nil where the data span less than MIN_PERIODS of it (a bend: library.offered).
    # Periodic: judged beyond a bend of the stroke (a spring, its square and cube: an end pull, a cable's sag).
    bend = [_spring, lambda f: _spring(f) ** 2, lambda f: _spring(f) ** 3]
    pole = [_spanned(c, 2 * tau) for h in (1, 2) for c in _sincos(2 * tau, h)]
    cog_g += pole + _times(pole, _dg)
    # At full freedom in its own variables: every harmonic times cubic B-splines in g (any smooth amplitude law).
    cog_own = [c for j in range(GAP_SPLINES) for c in _times(cog, lambda f, j=j: _gap_spline(f, j))]
    # Odd in each velocity (Coulomb, viscous). A friction's directional part (even, nil at rest: a level of its
    # own per sliding direction) is not a column: on a stroke swept back and forth it is a constant with dips at
    # the reversals, which any force at the turning points shares (a cogging residual showed as friction with
    # it); a dissipative friction has a Coulomb level at least its directional one, so the odd part shows.
    # The dry level may follow the guide's load with the gap (Friction's ``load``): its sign times (g - 10 mm).
    fr_g = [
        lambda f: np.tanh(f["g_dot"] / _V_SIGN),
        lambda f: f["g_dot"],
        lambda f: np.tanh(f["g_dot"] / _V_SIGN) * _dg(f),
    ]
    fr_d = [
        lambda f: np.tanh(f["d_dot"] / _V_SIGN),
        lambda f: f["d_dot"],
        lambda f: np.tanh(f["d_dot"] / _V_SIGN) * _dg(f),
    ]
    # A guide's friction (NOTES.md: Coulomb + viscous + Stribeck) has a dry level, its sign the velocity's, and a
    # viscous coefficient that does not follow the gap. On the gap axis a damping without a dry level is the air
    # under the mover (a squeeze film, a cover's trapped air), not a guide: friction is judged there beyond any
    # viscous drag, by its dry level alone. Along d a flat viscous drag stays friction's (or, at one gap, eddy
    # drag's: the confusable pair an experiment separates, issue 27 item 3); a drag whose coefficient follows
    # the gap (a conductor's) is not friction's, so friction is judged beyond it.
    # The coefficient's law in the gap: a cubic in the gap (a squeeze film's 1 / g^3, a conductor's power law);
    # along d only its part orthogonal to a flat drag (at one gap, none).
    visc_g = [lambda f, j=j: f["g_dot"] * _dg_mean(f) ** j for j in range(4)]
    visc_d = [lambda f, j=j: _beyond_flat(f["d_dot"], _dg_mean(f) ** j) for j in range(1, 4)]
    # A conductor's damping of the gap's own motion (EddyDrag's c_gap): its coefficient follows the gap (the flux's
    # change through the conductor: visc_g's linear and quadratic terms), a flat one is the air's: judged beyond a
    # flat g_dot (visc_g's first column, the signature's beyond).
    eddy_gap, flat_gap = visc_g[1:3], visc_g[:1]
    ends = end_columns()
    ends_g = ends + _times(ends, _dg)  # the current-free end force and pull loss, their size smooth in g
    # A loss at the ends of any smooth profile, which saturation is judged beyond: two steps per end in the end
    # effect's own basis (the null's power); four as *beyond* columns, to follow a ramp over the last slots.
    ends_fine = end_columns(SATURATION_END_STEPS)
    ripple = [c for h in (1, 2) for c in _sincos(tau, h)]
    sat = [lambda f, ell=ell: np.exp(-(f["g"] - 8e-3) / ell) for ell in (2e-3, 5e-3)]
    one: Column = lambda f: np.ones_like(f["t"])  # noqa: E731
    i_q: Column = lambda f: f["i_q"]  # noqa: E731
    i_d: Column = lambda f: f["i_d"]  # noqa: E731
    # A commutation offset turns i_d into thrust and i_q into lift: at a fixed position its error still follows the
    # currents, where a force of the position alone (a tilt, a cable, a spring) does not: its core is its basis
    # beyond a flexible function of d. A latency turns the angle with the speed: i_d d_dot, i_q d_dot.
    com = {"horizontal": [i_d, lambda f: f["i_d"] * f["d"] / 0.05, lambda f: f["i_d"] * f["d_dot"] / 0.1],
           "vertical": [i_q, lambda f: f["i_q"] * f["d"] / 0.05, lambda f: f["i_q"] * f["i_d"],
                        lambda f: f["i_q"] * f["d_dot"] / 0.1]}  # fmt: skip
    # saturation: the loss's gap law (``sat``, the magnets' pull) and its core, the loss of the current terms
    sat_core = _saturation_core(sat, i_q, i_d)
    sigs = [
        Signature("cogging", ("d", "g"), CHANNELS, tuple(2 * t1 / h for h in range(1, 7)),
                  "periodic in d with eq. (9)'s period 2 t1 (harmonics 1-6: the slot pitch t1 and its 2nd and 3rd "
                  "harmonics among them) or, from a stator that is not uniform, with the array's period 2 tau "
                  "(harmonics 1, 2, beyond a spring, where the data span two of its periods), amplitude smooth in g",
                  {c: cog_g for c in CHANNELS},
                  own={c: cog_own for c in CHANNELS}, angle_free=True,
                  beyond={"horizontal": [*bend, _dg, *fr_d[:2]], "vertical": [*bend, _dg, *fr_g[:2]]}),
        Signature("friction", ("g_dot", "d_dot", "g"), CHANNELS, (),
                  "odd in each axis' velocity, its dry level smooth in the guide's load (the gap); on the gap axis "
                  "a dry level beyond any viscous drag, along d beyond a drag that follows the gap",
                  {"vertical": fr_g, "horizontal": fr_d}, beyond={"vertical": visc_g, "horizontal": visc_d}),
        Signature("eddy_drag", ("d_dot", "g_dot", "g", "d"), CHANNELS, (), "a drag odd in the horizontal velocity "
                  "and a lift even in it, both falling as the gap opens, the drag's size smooth along the stroke; "
                  "on the gap axis a damping of the gap's motion whose coefficient follows the gap (beyond a flat "
                  "one: the air's)",
                  {"horizontal": [lambda f: f["d_dot"], lambda f: f["d_dot"] * _dg(f),
                                  lambda f: f["d_dot"] * f["d"] / 0.05, lambda f: f["d_dot"] * (f["d"] / 0.05) ** 2],
                   "vertical": [lambda f: f["d_dot"] ** 2, lambda f: f["d_dot"] ** 2 * _dg(f), *eddy_gap]},
                  beyond={"vertical": flat_gap}),
        Signature("end_effect", ("d", "g", "i_q", "i_d"), CHANNELS, (tau, tau / 2),
                  "forces localized at each end of the stroke, nil in its middle and growing with each end's "
                  "overhang (the end forces of the magnets and of the winding, the thrust and pull losses), and a "
                  "thrust ripple with the pole pitch",
                  {"horizontal": ends_g + _times(ends + ripple, i_q) + _times(ends, _i2),
                   "vertical": ends_g + _times(ends, i_d)},
                  beyond={"horizontal": [_spring, _dg, i_q], "vertical": [_spring, _dg, i_d]}),
        Signature("saturation", ("g", "i_q", "i_d"), CHANNELS, (),
                  "a loss of the magnetic terms monotone in g and in the current, in proportion to each term, the "
                  "same along the stroke: at a fixed state it follows the currents (the thrust and the PM-current "
                  "pull lose with the field), and not only at the stroke's ends",
                  {"vertical": sat + sat_core["vertical"], "horizontal": sat_core["horizontal"]},
                  core=sat_core, fixed=("g", "d"),
                  beyond={"vertical": ends_fine + _times(ends_fine, _dg) + _times(ends_fine, i_d),
                          "horizontal": _times(ends_fine, i_q)}),
        Signature("commutation_offset", ("i_q", "i_d", "d", "d_dot"), CHANNELS, (),
                  "a rotation of the currents: i_d into the thrust, i_q into the lift, constant or drifting in d or "
                  "lagging with the speed; at a fixed position it follows the currents (i_d changes with the gap "
                  "held)",
                  com, core=com, fixed=("d",)),
        Signature("amplifier_lag", ("di_q", "di_d"), CHANNELS, (),
                  "proportional to the current rates at a fixed state (no static map of state and currents)",
                  {"horizontal": [lambda f: f["di_q"], lambda f: f["di_q"] * f["i_d"]],
                   "vertical": [lambda f: f["di_d"], lambda f: f["di_d"] * f["i_d"], lambda f: f["di_q"]]},
                  dynamic=True),
        Signature("parameter_error", ("g", "i_q", "i_d"), CHANNELS, (), "the model's own terms scaled",
                  {"horizontal": [i_q, lambda f: f["i_q"] * f["i_d"]],
                   "vertical": [one, i_d, lambda f: f["i_d"] ** 2, lambda f: f["i_q"] ** 2]}),
    ]  # fmt: skip
    return {s.effect: s for s in sigs}


#: Velocity scales [m/s] of the odd shapes of :func:`static_basis`: from below the velocity resolution of a 1 um
#: encoder smoothed at 25 Hz to the stage's sweeps (a Stribeck dip, a Coulomb step, a LuGre pre-sliding slope).
STATIC_V_SCALES: tuple[float, ...] = (2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2)


def static_basis(feat: Feat) -> np.ndarray:
    """A flexible static map of the state and the currents, shape ``(n, p)``: what a dynamic signature must show
    beyond (its *fixed state*).

    Per velocity, odd shapes at every scale of :data:`STATIC_V_SCALES` (``tanh(v / s)``) with ``v``, ``v |v|``
    and ``v^3`` (any friction law of the library or outside it that is a function of the velocity: Coulomb,
    Stribeck, viscous, a smoothed LuGre's steady state); polynomials of the gap, the position and the currents
    to second order (saturation, end effects, parameter errors, a commutation offset). In closed loop the
    current rates are correlated with the velocities (a lag's force error ``-t dF/dt`` is a damping term at a
    single frequency): only what they explain beyond this map is a lag's own signature.
    """
    n = len(feat["t"])
    cols = [np.ones(n)]
    for v in ("g_dot", "d_dot"):
        x = feat[v]
        cols += [np.tanh(x / s) for s in STATIC_V_SCALES]
        cols += [x, x * np.abs(x), x**3]
    z = {"g": _dg(feat), "d": feat["d"] / 0.05, "i_q": feat["i_q"], "i_d": feat["i_d"]}
    names = list(z)
    for i, a in enumerate(names):
        cols.append(z[a])
        for b in names[i:]:
            cols.append(z[a] * z[b])
    return np.column_stack(cols)


#: The catalogue of signatures, one per library effect.
SIGNATURES: dict[str, Signature] = _catalogue()
#: Every period in d [m] some library signature has.
LIBRARY_PERIODS_M: tuple[float, ...] = tuple(sorted({p for s in SIGNATURES.values() for p in s.periods_m}))


@dataclass(frozen=True)
class SignatureEvidence:
    """How much of a residual one effect's signature explains, against its null reference.

    Attributes
    ----------
    effect : str
        The effect.
    per_channel : dict
        ``{channel: {explained, null_q, rms_explained_over_floor}}``: the share of the residual's energy the
        signature explains beyond the others' bases (a dynamic signature: also beyond :func:`static_basis`),
        the null's ``1 - alpha`` quantile of the same share, and the rms it explains beyond the others' bases
        over the channel's noise floor. A signature with :attr:`Signature.beyond` columns is tested on what
        they leave of the residual (shares of that remainder's energy), with ``beyond_share`` the share they
        took. A dynamic signature's record also holds ``explained_beyond_others``, ``null_q_beyond_others`` and
        ``shows_beyond_others``: the same test beyond the others' bases only.
    shows : bool
        The share exceeds the null quantile in some channel and what it explains is above ``min_over_floor``
        times the floor there.
    """

    effect: str
    per_channel: dict[str, dict[str, float]]
    shows: bool

    def to_dict(self) -> dict:
        """JSON form."""
        return {"effect": self.effect, "shows": self.shows, "per_channel": self.per_channel}


def _stack(res: Sequence[Residual], c: int) -> tuple[np.ndarray, Feat, np.ndarray]:
    """A channel's residual samples over runs, their features, and each sample's run index."""
    rs, fs, ids = [], [], []
    for i, r in enumerate(res):
        if r.run.n and r.run.valid[c] and r.run.feat:
            ok = np.isfinite(r.r[:, c])
            rs.append(r.r[ok, c])
            fs.append({key: v[ok] for key, v in r.run.feat.items()})
            ids.append(np.full(int(ok.sum()), i))
    if not rs:
        return np.zeros(0), {}, np.zeros(0, int)
    feat = {key: np.concatenate([f[key] for f in fs]) for key in fs[0]}
    return np.concatenate(rs), feat, np.concatenate(ids)


def _orth(x: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the column span of ``x`` (rank-revealing: dependent columns dropped)."""
    if x.shape[1] == 0:
        return x
    u, sv, _ = np.linalg.svd(x, full_matrices=False)
    return u[:, sv > 1e-9 * max(float(sv[0]), 1e-300)]


class _Increment:
    """Share of a vector's energy that the columns ``b`` explain beyond the columns ``a`` (least squares),
    with both spans factored once, so that many null draws cost two matrix-vector products each."""

    def __init__(self, a: np.ndarray, b: np.ndarray) -> None:
        self.qa = _orth(a)
        self.qab = _orth(np.column_stack([a, b]) if a.shape[1] else b)

    def __call__(self, y: np.ndarray) -> float:
        yy = float(y @ y)
        if yy <= 0:
            return 0.0
        pa = self.qa.T @ y if self.qa.shape[1] else np.zeros(0)
        pab = self.qab.T @ y if self.qab.shape[1] else np.zeros(0)
        return max(float(pab @ pab) - float(pa @ pa), 0.0) / yy


def _share(y: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Share of ``y``'s energy that the columns ``b`` explain beyond the columns ``a`` (least squares)."""
    return _Increment(a, b)(y) if b.shape[1] else 0.0


def _normalized(x: np.ndarray) -> np.ndarray:
    if x.shape[1] == 0:
        return x
    s = np.sqrt(np.mean(x**2, axis=0))
    return x / np.where(s > 0, s, 1.0)


def _shifted(y: np.ndarray, ids: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The residual circularly shifted within each run by a random lag of at least a tenth of the run."""
    out = np.empty_like(y)
    for i in np.unique(ids):
        sel = ids == i
        n = int(sel.sum())
        lo = max(n // 10, 1)
        out[sel] = np.roll(y[sel], int(rng.integers(lo, max(n - lo, lo + 1))))
    return out


def evidence(
    effect: str,
    residuals: Sequence[Residual],
    floors: dict[str, float],
    others: Sequence[str] = (),
    n_null: int = 60,
    alpha: float = 0.01,
    min_over_floor: float = 0.3,
    seed: int = 0,
) -> SignatureEvidence:
    """Does ``effect``'s signature show in ``residuals`` beyond the noise and beyond the ``others``' signatures?

    Parameters
    ----------
    effect : str
        A library effect (a key of :data:`SIGNATURES`).
    residuals : sequence of Residual
        The residual of the model *without* the effect, on held-out runs.
    floors : dict
        ``{channel: noise floor}`` [m/s^2] (the diagnosis's noise model).
    others : sequence of str
        Effects named with it: their bases are fitted first, and only what ``effect``'s basis explains beyond
        them counts (a basis correlated with another effect's remainder through the closed loop is not
        evidence). A dynamic signature (:attr:`Signature.dynamic`) is also judged beyond a flexible static map
        of the state and currents (:func:`static_basis`), whatever effects are named with it; every signature
        beyond its own :attr:`Signature.beyond` columns (the end effect: beyond a spring, a linear function of
        the gap and a uniform scale of the current's force over the whole stroke).
    n_null : int
        Circular shifts of the residual against the features (the null reference).
    alpha : float
        The null quantile exceeded is ``1 - alpha``.
    min_over_floor : float
        What the signature explains must also be at least this rms over the noise floor, where its share is
        just above the null quantile (lower where it is far beyond it: :func:`material_bar`).
    seed : int
        Seed of the shifts.

    Returns
    -------
    SignatureEvidence
        ``shows`` also needs the signature's core at a fixed state where it has one (:attr:`Signature.core`,
        :func:`core_evidence`: saturation's loss follows the currents at a fixed gap and position), with the
        core's figures in ``per_channel``.
    """
    sig = SIGNATURES[effect]
    rng = np.random.default_rng(np.random.SeedSequence([seed, len(effect)]))
    out: dict[str, dict[str, float]] = {}
    shows = False
    for c, ch in enumerate(CHANNELS):
        if ch not in sig.channels:
            continue
        y, feat, ids = _stack(residuals, c)
        if len(y) < 20:
            continue
        extra: dict[str, float] = {}
        w = sig.matrix(feat, ch, "beyond")
        if w.shape[1]:
            # The test is on what the laws of another kind leave (as :func:`core_evidence`'s on what the state map
            # leaves): shifted, a large spring-like residual would lend the signature's smooth columns a share
            # that no remainder has, and hide the signature in the null.
            y0 = float(y @ y)
            qw = _orth(np.column_stack([np.ones(len(y)), w]))
            y = y - qw @ (qw.T @ y)
            extra["beyond_share"] = 1.0 - float(y @ y) / y0 if y0 > 0 else 0.0
        b = _normalized(sig.matrix(feat, ch))
        a = [SIGNATURES[o].matrix(feat, ch) for o in others if o in SIGNATURES and o != effect]
        a.append(w)
        a_o = _normalized(np.column_stack(a)) if a and sum(x.shape[1] for x in a) else np.zeros((len(y), 0))
        a_o = np.column_stack([np.ones(len(y)), a_o])
        inc_o = _Increment(a_o, b)
        size = share_o = inc_o(y)
        if sig.dynamic:  # significance at a fixed state: beyond a flexible static map (:func:`static_basis`)
            inc = _Increment(np.column_stack([a_o, _normalized(static_basis(feat))]), b)
        else:
            inc = inc_o
        share = inc(y) if sig.dynamic else share_o
        shifts = [_shifted(y, ids, rng) for _ in range(n_null)]
        null = [inc(ys) for ys in shifts]
        q = float(np.quantile(null, 1 - alpha)) if null else math.inf
        fl = floors.get(ch, math.nan)
        # Its size is what its basis explains beyond the other effects (a dynamic signature's part at a fixed
        # state proves it is no static map; in closed loop that part is a fraction of the whole, e.g. 0.25 of
        # it where the current rate correlates -0.97 with the velocity).
        over = math.sqrt(size * float(np.mean(y**2))) / fl if np.isfinite(fl) and fl > 0 else math.nan
        big = not np.isfinite(over) or over >= material_bar(min_over_floor, share, q)
        ok = bool(share > q and big)
        out[ch] = {"explained": share, "null_q": q, "rms_explained_over_floor": over, "shows": ok, **extra}
        if sig.dynamic:
            # The same test beyond the other effects only (not beyond the static map): what the claim guard needs
            # to know whether only the fixed-state part failed (then the library's static rivals are fitted in
            # the effect's place, :func:`..stages.claims.check_claims`).
            q_o = float(np.quantile([inc_o(ys) for ys in shifts], 1 - alpha)) if shifts else math.inf
            out[ch].update(explained_beyond_others=share_o, null_q_beyond_others=q_o,
                           shows_beyond_others=bool(share_o > q_o and big))  # fmt: skip
        shows = shows or ok
    if sig.core:
        core = core_evidence(sig, residuals, floors, others, n_null, alpha, min_over_floor, seed)
        for ch, rec in core.items():
            out.setdefault(ch, {}).update(rec)
        shows = shows and any(rec["core_shows"] for rec in core.values())
    return SignatureEvidence(effect, out, shows)


def material_bar(min_over_floor: float, share: float, null_q: float) -> float:
    """The rms over the noise floor a signature must explain, given how far its share exceeds its null.

    ``min_over_floor`` is the bar of a share up to twice its null quantile (barely significant: a small
    structure the loop may have shaped out of noise and the other effects' remainders). Beyond that the bar
    falls with the square root of the share's ratio to twice the null quantile (the rms explained goes as the
    share's square root), to half of ``min_over_floor`` at eight times the null: a small effect measured far
    beyond its null (a saturation whose loss changes by about 1 % of the magnetic forces over the gaps visited,
    its share about three times the null's) is claimed; one neither large nor clearly beyond the null is not.
    The null's quantile stays the significance test; this only sets how small a significant signature may be.
    Made on the sixteenth law set's saturation singles (training material, not a blind figure).
    """
    if not (np.isfinite(share) and np.isfinite(null_q)) or null_q <= 0.0 or share <= 2.0 * null_q:
        return min_over_floor
    return min_over_floor * max(0.5, math.sqrt(2.0 * null_q / share))


def _bsplines(x: np.ndarray, lo: float, hi: float, n: int) -> np.ndarray:
    """``n`` cubic B-splines with equal knot spacing over ``[lo, hi]`` at ``x`` (clipped into the range)."""
    kk = 3
    t = np.concatenate([[lo] * kk, np.linspace(lo, hi, n - kk + 1), [hi] * kk])
    xx = np.clip(x, lo, hi - 1e-9 * (hi - lo))
    return BSpline.design_matrix(xx, t, kk).toarray()


#: Cubic B-splines per fixed variable, and per variable in the tensor product of two (the core test's state map).
STATE_SPLINES: tuple[int, int] = (8, 5)


def state_map_basis(feat: Feat, variables: Sequence[str]) -> np.ndarray:
    """A flexible function of the state ``variables``: cubic B-splines in each (:data:`STATE_SPLINES`) and their
    tensor products two by two, over the 0.5..99.5 % range of the samples."""
    n1, n2 = STATE_SPLINES
    one, two = [], []
    for v in variables:
        lo, hi = (float(x) for x in np.percentile(feat[v], [0.5, 99.5]))
        if not hi > lo:
            continue
        one.append(_bsplines(feat[v], lo, hi, n1))
        two.append(_bsplines(feat[v], lo, hi, n2))
    cols = list(one)
    for i in range(len(two)):
        for j in range(i + 1, len(two)):
            cols.append((two[i][:, :, None] * two[j][:, None, :]).reshape(len(two[i]), -1))
    return np.column_stack(cols) if cols else np.zeros((len(feat["t"]), 0))


def _other_bases(sig: Signature, feat: Feat, ch: str, others: Sequence[str]) -> list[np.ndarray]:
    """The columns a test of ``sig`` is judged beyond in channel ``ch``: the other named effects' bases and
    ``sig``'s :attr:`~Signature.beyond` columns, each block normalized (empty blocks left out)."""
    a = [SIGNATURES[o].matrix(feat, ch) for o in others if o in SIGNATURES and o != sig.effect]
    a.append(sig.matrix(feat, ch, "beyond"))
    return [_normalized(x) for x in a if x.shape[1]]


def core_evidence(
    sig: Signature,
    residuals: Sequence[Residual],
    floors: dict[str, float],
    others: Sequence[str] = (),
    n_null: int = 60,
    alpha: float = 0.01,
    min_over_floor: float = 0.3,
    seed: int = 0,
) -> dict[str, dict[str, float]]:
    """Does the core of ``sig``'s signature show at a fixed state (:attr:`Signature.core`)?

    Per channel of the core: the share of what a constant, the other named effects' bases and a flexible
    function of the fixed state variables (:func:`state_map_basis`) leave of the residual that the core's
    columns explain, against the same share on that remainder circularly shifted within its runs (the
    ``1 - alpha`` quantile), and the rms it explains over the noise floor (at least ``min_over_floor``).
    Returns ``{channel: {core_explained, core_null_q, core_rms_over_floor, core_shows}}``.
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, len(sig.effect), 1]))
    out: dict[str, dict[str, float]] = {}
    for c, ch in enumerate(CHANNELS):
        cols = sig.core.get(ch)
        if not cols:
            continue
        y, feat, ids = _stack(residuals, c)
        if len(y) < 100:
            continue
        b = _normalized(np.column_stack([np.asarray(col(feat), float) for col in cols]))
        a = [np.ones((len(y), 1)), state_map_basis(feat, sig.fixed), *_other_bases(sig, feat, ch, others)]
        inc = _Increment(np.column_stack(a), b)
        # The test is on what the state map and the others leave (``y_a``): shifted, a large structure of the
        # state would lend the core's smooth columns a share no remainder has, and hide the core in the null.
        y_a = y - inc.qa @ (inc.qa.T @ y)
        share = inc(y_a)
        null = [inc(_shifted(y_a, ids, rng)) for _ in range(n_null)]
        q = float(np.quantile(null, 1 - alpha)) if null else math.inf
        fl = floors.get(ch, math.nan)
        over = math.sqrt(share * float(np.mean(y_a**2))) / fl if np.isfinite(fl) and fl > 0 else math.nan
        ok = bool(share > q and (not np.isfinite(over) or over >= material_bar(min_over_floor, share, q)))
        out[ch] = {"core_explained": share, "core_null_q": q, "core_rms_over_floor": over, "core_shows": ok}
    return out


def period_scan(
    residuals: Sequence[Residual], c: int, periods_m: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares share of a channel's residual energy explained by a sinusoid in ``d`` of each period."""
    y, feat, _ = _stack(residuals, c)
    if periods_m is None:
        periods_m = np.geomspace(4e-3, 0.12, 160)
    shares = np.zeros(len(periods_m))
    yy = float(y @ y) if len(y) else 0.0
    if len(y) < 20 or yy <= 0:
        return periods_m, shares
    # Beyond a constant: everything centred; the 2x2 normal equations of (sin, cos) at all periods at once.
    ph = np.outer(feat["d"], 2 * math.pi / np.asarray(periods_m))
    sn, cs = np.sin(ph), np.cos(ph)
    sn -= sn.mean(axis=0)
    cs -= cs.mean(axis=0)
    yc = y - y.mean()
    ss, cc, sc = np.sum(sn * sn, 0), np.sum(cs * cs, 0), np.sum(sn * cs, 0)
    sy, cy = yc @ sn, yc @ cs
    det = ss * cc - sc**2
    ok = det > 1e-12 * np.maximum(ss * cc, 1e-300)
    expl = np.where(ok, (cc * sy**2 - 2 * sc * sy * cy + ss * cy**2) / np.where(ok, det, 1.0), 0.0)
    shares[:] = np.maximum(expl, 0.0) / yy
    return periods_m, shares


def locate_gap(
    residuals: Sequence[Residual],
    floors: dict[str, float],
    n_null: int = 40,
    alpha: float = 0.01,
    min_over_floor: float = 1.0,
    tol: float = 0.06,
    seed: int = 0,
) -> list[dict]:
    """Where a residual holds structure that no library signature has: a period in ``d`` that is no library
    period (:data:`LIBRARY_PERIODS_M`, within ``tol`` relative), or a drift in time alone.

    Each finding: ``{channel, kind, variable, period_m | ..., rms_over_floor, what}``. A finding needs the
    share it explains above the ``1 - alpha`` quantile of its circular-shift null and an rms of at least
    ``min_over_floor`` times the channel's floor.
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, 27]))
    out: list[dict] = []
    lib = np.array(LIBRARY_PERIODS_M)
    for c, ch in enumerate(CHANNELS):
        y, feat, ids = _stack(residuals, c)
        fl = floors.get(ch, math.nan)
        if len(y) < 40 or not (np.isfinite(fl) and fl > 0):
            continue
        ms = float(np.mean(y**2))
        periods, shares = period_scan(residuals, c)
        j = int(np.argmax(shares))
        p = float(periods[j])
        if not np.any(np.abs(p / lib - 1.0) < tol) and not np.any(np.abs(p / (2 * lib) - 1.0) < tol):
            w = 2 * math.pi / p
            b = np.column_stack([np.sin(w * feat["d"]), np.cos(w * feat["d"])])
            inc = _Increment(np.ones((len(y), 1)), b)
            null = [inc(_shifted(y, ids, rng)) for _ in range(n_null)]
            over = math.sqrt(shares[j] * ms) / fl
            if shares[j] > float(np.quantile(null, 1 - alpha)) and over >= min_over_floor:
                out.append(dict(channel=ch, kind="period", variable="d", period_m=p, rms_over_floor=over,
                                what=f"{ch}: a period of {p * 1e3:.1f} mm in d that is no library period "
                                     f"({over:.1f}x the floor)"))  # fmt: skip
        # Time alone: a smooth drift within each run (low-order polynomial in t per run) beyond every signature.
        cols = []
        for i in np.unique(ids):
            sel = (ids == i).astype(float)
            t = feat["t"] - np.mean(feat["t"][ids == i])
            span = max(float(np.ptp(feat["t"][ids == i])), 1e-9)
            cols += [sel, sel * t / span, sel * (t / span) ** 2]
        b = np.column_stack(cols)
        a = _normalized(np.column_stack([np.ones(len(y))] + [s.matrix(feat, ch) for s in SIGNATURES.values()]))
        inc = _Increment(a, b)
        share = inc(y)
        over = math.sqrt(share * ms) / fl
        if over >= min_over_floor:
            null = [inc(_shifted(y, ids, rng)) for _ in range(n_null)]
            if share > float(np.quantile(null, 1 - alpha)):
                out.append(dict(channel=ch, kind="drift", variable="t", rms_over_floor=over,
                                what=f"{ch}: a drift in time that no signature's variables explain "
                                     f"({over:.1f}x the floor)"))  # fmt: skip
    return out


__all__ = [
    "END_MIDDLE",
    "END_STEPS",
    "LIBRARY_PERIODS_M",
    "SATURATION_END_STEPS",
    "SIGNATURES",
    "STATE_SPLINES",
    "STATIC_V_SCALES",
    "Signature",
    "SignatureEvidence",
    "core_evidence",
    "end_columns",
    "evidence",
    "locate_gap",
    "period_scan",
    "state_map_basis",
    "static_basis",
]
