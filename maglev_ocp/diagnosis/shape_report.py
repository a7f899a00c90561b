"""Fitted shapes of the effects found, as functions of their variable, and their physical sizes.

A diagnosis names effects with fitted parameters; a learned-shape member
(:class:`~.library.CandidateSpec` ``flexible``) is only meaningful to a reader
as the curve it fitted. One small function per effect kind (:data:`SHAPES`)
evaluates the effect's own law of :mod:`maglev_ocp.effects` (never a copy of
it) on its variable's range and states the effect's physical size.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import constants as k
from ..effects import EFFECTS, Cogging, CommutationOffset, EddyDrag, EndEffect, Friction, Saturation
from .attribution import EffectScore
from .fit import FitResult
from .result import Diagnosis


def fit_theta(fit: FitResult, name: str) -> dict[str, float]:
    """All parameters of effect ``name`` in a fit: defaults, then the spec's fixed, fitted and tied values (a tie
    whose source the fit does not hold keeps its default)."""
    theta = dict(EFFECTS[name].defaults())
    prefix = f"{name}."
    theta.update({key[len(prefix) :]: v for key, v in fit.spec.fixed if key.startswith(prefix)})
    fitted = fit.params()
    theta.update({key[len(prefix) :]: v for key, v in fitted.items() if key.startswith(prefix)})
    theta.update(
        {key[len(prefix) :]: fitted[src] for key, src in fit.spec.ties if key.startswith(prefix) and src in fitted}
    )
    return theta


def effect_theta(score: EffectScore, name: str) -> dict[str, float]:
    """All parameters of effect ``name`` in a fitted score: :func:`fit_theta` of its fit, then the score's values."""
    prefix = f"{name}."
    if score.fit is None:
        theta = dict(EFFECTS[name].defaults())
        theta.update({key[len(prefix) :]: float(v) for key, v in score.params.items() if key.startswith(prefix)})
        return theta
    # the fit's own values by full key: a single effect's score names its values without the prefix (and "xi0"
    # there is the model's p.xi0, not the effect's), so the score alone would leave the defaults
    theta = fit_theta(score.fit, name)
    theta.update({key[len(prefix) :]: float(v) for key, v in score.params.items() if key.startswith(prefix)})
    # a tie's source (e.g. the calibrated p.xi0 a cogging member shares) is fitted, but a score may carry only
    # its effect's own values: read it from the fit then
    fitted = {**score.fit.params(), **score.params}
    theta.update({key[len(prefix) :]: float(fitted[src]) for key, src in score.fit.spec.ties if key.startswith(prefix)})
    return theta


@dataclass(frozen=True)
class Shape:
    """How one effect kind is drawn: its variable, range, curve and physical size."""

    xlabel: str
    ylabel: str
    x: np.ndarray
    curve: Callable[[dict[str, float], np.ndarray], np.ndarray]
    size: Callable[[dict[str, float]], str]


def _sat_loss(theta: dict[str, float], g_mm: np.ndarray) -> np.ndarray:
    """Loss [%] of a magnetic term of unit share at gap ``g`` [mm] (:meth:`Saturation.factor`)."""
    return np.array([100.0 * (1.0 - float(Saturation.factor(g * 1e-3, theta))) for g in g_mm])


def _end_loss(theta: dict[str, float], d_mm: np.ndarray) -> np.ndarray:
    """Overhang loss [%] of the magnetic terms at position ``d`` [mm] (:meth:`EndEffect.force_factor`)."""
    return np.array([100.0 * (1.0 - float(EndEffect.force_factor(d, theta))) for d in d_mm * 1e-3])


def _sat_current_text(theta: dict[str, float]) -> str:
    """The current loss's size (:meth:`Saturation.current_loss`), empty when it is nil."""
    loss = 100.0 * float(Saturation.current_loss(k.i_amp_max, theta))
    return f"; current loss at |i| = {k.i_amp_max:.0f} A {loss:.2f} % of a term of unit share" if loss > 0 else ""


def _end_winding_text(theta: dict[str, float]) -> str:
    """The winding end force at the stops at the amplitude limit (:meth:`EndEffect.winding_force_x`)."""
    if theta.get("end_i2", 0.0) == 0.0:
        return ""
    f = [float(EndEffect.winding_force_x(d, k.i_amp_max, 0.0, theta)) for d in k.d_stop]
    return f"; winding end force at the stops at |i| = {k.i_amp_max:.0f} A: {f[0]:.3f} N, {f[1]:.3f} N"


def _eddy_profile_text(theta: dict[str, float]) -> str:
    """The drag's profile along the stroke (:meth:`EddyDrag.profile`), empty when it is flat."""
    prof = np.array([float(EddyDrag.profile(d * 1e-3, theta)) for d in _D_MM])
    if np.allclose(prof, 1.0):
        return ""
    return f"; along the stroke the drag is {prof.min():.2f}..{prof.max():.2f} times its value at d = 0"


def _offset_deg(theta: dict[str, float], d_mm: np.ndarray) -> np.ndarray:
    """Commutation offset [deg] along the stroke (:meth:`CommutationOffset.angle`: ``delta + drift d`` + spline)."""
    return np.degrees([float(CommutationOffset.angle(d * 1e-3, theta)) for d in d_mm])


def _friction_n(theta: dict[str, float], v_mm_s: np.ndarray) -> np.ndarray:
    """Friction force [N] of each guide (columns g, d) at velocity ``v`` [mm/s] (:meth:`Friction.axis_force`)."""
    return np.array([[float(Friction.axis_force(v * 1e-3, theta, ax)) for ax in ("g", "d")] for v in v_mm_s])


#: Gaps [mm] at which the cogging shape is drawn: the lower and upper end of the tracking envelope (MODEL.md), so
#: that the figure shows how each harmonic decays with the gap.
_COG_GAPS_MM = (k.g_envelope[0] * 1e3, k.g_envelope[1] * 1e3)


def _cogging_n(theta: dict[str, float], d_mm: np.ndarray) -> np.ndarray:
    """Extra cogging forces [N] along d (columns tangential, normal at each gap of :data:`_COG_GAPS_MM`, in turn)
    (:meth:`Cogging.forces`: the closed forms and the co-energy shape)."""
    c = Cogging()
    cols = [[float(f) for f in c.forces(g * 1e-3, d * 1e-3, theta)] for d in d_mm for g in _COG_GAPS_MM]
    return np.array(cols).reshape(len(d_mm), 2 * len(_COG_GAPS_MM))


def _eddy_coef(theta: dict[str, float], g_mm: np.ndarray) -> np.ndarray:
    """Low-speed eddy-drag coefficients [N s/m] at gap ``g`` [mm]: columns the drag along d
    (:meth:`EddyDrag.coefficient`) and the damping of the gap's motion (``c_vert`` times it, plus
    :meth:`EddyDrag.gap_coefficient`)."""
    out = []
    for g in g_mm * 1e-3:
        c = float(EddyDrag.coefficient(g, theta))
        out.append((c, theta.get("c_vert", 0.0) * c + float(EddyDrag.gap_coefficient(g, theta))))
    return np.array(out)


def _eddy_n(theta: dict[str, float], v: float, g_mm: float = k.g_cog_ref * 1e3) -> tuple[float, float]:
    """Eddy drag and lift [N] (magnitudes) at horizontal speed ``v`` [m/s] and gap ``g`` [mm]."""
    f_g, f_d = EddyDrag.forces(g_mm * 1e-3, v, theta)
    return abs(float(f_d)), abs(float(f_g))


def _peak(values: np.ndarray) -> np.ndarray:
    """Largest magnitude of each column."""
    return np.max(np.abs(np.atleast_2d(values.T).T), axis=0)


_G_MM = np.linspace(k.g_stop[0] * 1e3, k.g_stop[1] * 1e3, 121)
_D_MM = np.linspace(k.d_stop[0] * 1e3, k.d_stop[1] * 1e3, 241)
#: Velocities [mm/s] the friction figure spans (both signs: the law is odd), with the low speeds resolved.
_V_MM_S = np.concatenate([-np.geomspace(200.0, 0.05, 80), [0.0], np.geomspace(0.05, 200.0, 80)])

#: Effect kinds with a shape figure.
SHAPES: dict[str, Shape] = {
    "saturation": Shape(
        "gap g [mm]",
        "force loss (unit share) [%]",
        _G_MM,
        _sat_loss,
        lambda th: (
            f"loss at the lower stop (g = {k.g_stop[0] * 1e3:.0f} mm) "
            f"{_sat_loss(th, np.array([k.g_stop[0] * 1e3]))[0]:.2f} % of a term of unit share "
            "(shares "
            + ", ".join(f"{w} {th[w]:.2f}" for w in ("w_pm", "w_id", "w_rel", "w_thrust"))
            + ")"
            + _sat_current_text(th)
        ),
    ),
    "end_effect": Shape(
        "position d [mm]",
        "overhang force loss [%]",
        _D_MM,
        _end_loss,
        lambda th: (
            "overhang loss at the stops "
            + ", ".join(f"{v:.2f} %" for v in _end_loss(th, np.array([k.d_stop[0] * 1e3, k.d_stop[1] * 1e3])))
            + _end_winding_text(th)
        ),
    ),
    "commutation_offset": Shape(
        "position d [mm]",
        "commutation offset [deg]",
        _D_MM,
        _offset_deg,
        lambda th: (
            f"offset {_offset_deg(th, np.array([0.0]))[0]:.2f} deg at d = 0, largest "
            f"{_peak(_offset_deg(th, _D_MM))[0]:.2f} deg on the stroke (linear drift term "
            f"{math.degrees(th['drift']) * 1e-3:.3f} deg/mm)"
        ),
    ),
    "friction": Shape(
        "velocity [mm/s] (g guide, d guide)",
        "friction force [N]",
        _V_MM_S,
        _friction_n,
        lambda th: (
            "peak friction force at |v| <= 200 mm/s: vertical guide {:.3f} N, horizontal guide {:.3f} N; at 1 mm/s "
            "{:.3f} N, {:.3f} N".format(*_peak(_friction_n(th, _V_MM_S)), *np.abs(_friction_n(th, np.array([1.0]))[0]))
        ),
    ),
    "cogging": Shape(
        "position d [mm] ({})".format(
            ", ".join(f"{part} g = {g:.0f} mm" for g in _COG_GAPS_MM for part in ("tangential", "normal"))
        ),
        "extra cogging force [N]",
        _D_MM,
        _cogging_n,
        lambda th: (
            "peak extra cogging force: "
            + "; ".join(
                f"at g = {g:.0f} mm tangential {a:.3f} N, normal {b:.3f} N"
                for g, a, b in zip(_COG_GAPS_MM, *np.reshape(_peak(_cogging_n(th, _D_MM)), (-1, 2)).T, strict=True)
            )
        ),
    ),
    "eddy_drag": Shape(
        "gap g [mm] (drag along d, damping of the gap)",
        "low-speed coefficient [N s/m]",
        _G_MM,
        _eddy_coef,
        lambda th: (
            "low-speed drag coefficient along d {:.3f} N s/m at g = 8 mm, {:.3f} N s/m at g = 20 mm; damping of "
            "the gap {:.3f} N s/m at g = 8 mm, {:.3f} N s/m at g = 20 mm; at g = 10 mm and "
            "0.1 m/s drag {:.3f} N, lift {:.3f} N (critical velocity {})".format(
                *_eddy_coef(th, np.array([8.0, 20.0])).T.ravel(),
                *_eddy_n(th, 0.1),
                f"{1 / th['inv_vc']:.3f} m/s" if th.get("inv_vc", 0.0) > 0 else "none: linear in velocity",
            )
            + _eddy_profile_text(th)
        ),
    ),
}


def _found(d: Diagnosis) -> list[tuple[str, dict[str, float]]]:
    score = d.final_score
    if score is None:
        return []
    return [(n, effect_theta(score, n)) for n in d.effects_found if n in SHAPES]


def shape_sizes(d: Diagnosis) -> list[str]:
    """One Markdown line per effect found with a shape: its physical size."""
    return [f"- `{n}`: {SHAPES[n].size(th)}" for n, th in _found(d)]


def shape_figure(d: Diagnosis, plt):
    """The fitted shape of each effect found vs its variable (units on the axes), or ``None`` if there is none."""
    found = _found(d)
    if not found:
        return None
    fig, axes = plt.subplots(1, len(found), figsize=(4.5 * len(found), 3.5), squeeze=False)
    for ax, (n, th) in zip(axes[0], found, strict=True):
        s = SHAPES[n]
        y = s.curve(th, s.x)
        if np.ndim(y) == 1:
            ax.plot(s.x, y, color="tab:red")
        else:  # one line per column, named in the x label's parentheses
            names = s.xlabel[s.xlabel.index("(") + 1 : -1].split(", ")
            for j, name in enumerate(names):
                ax.plot(s.x, y[:, j], label=name)
            ax.legend(fontsize=8)
        if s is SHAPES.get("friction"):
            ax.set_xscale("symlog", linthresh=1.0)
        ax.set_xlabel(s.xlabel.split(" (")[0] if np.ndim(y) > 1 else s.xlabel)  # the legend names the columns
        ax.set_ylabel(s.ylabel)
        ax.set_title(n)
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


__all__ = ["SHAPES", "Shape", "effect_theta", "shape_figure", "shape_sizes"]
