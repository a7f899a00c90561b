"""The candidate library (catalogue): each effect's fitted parameters, bounds, starts and law-family members.

A :class:`CandidateSpec` says how one candidate effect of :mod:`maglev_ocp.effects`
is fitted on top of the shared model: which parameters are free (:class:`Free`,
bounds in physical units, start, scale, prior), which are held fixed or tied,
and which member of the effect's law family it is (:func:`family_specs`).
:func:`calibration_free` gives the baseline's calibrated constants. The fitter
that solves these specs is :mod:`.fit`; nothing here evaluates the model.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from ..effects import Cogging, CommutationOffset, EddyDrag, EndEffect, Friction, Saturation
from ..effects.cogging import ENERGY_DECAY_RANGE, ENERGY_PERIOD, G_ENERGY_REF, POLE_PERIOD
from ..params import Params
from .library_bounds import FREE as _FREE


# ------------------------------------------------------------------------- specs
@dataclass(frozen=True)
class Free:
    """A fitted parameter.

    Attributes
    ----------
    key : str
        ``"p.<name>"`` for an entry of the model's parameter vector, or
        ``"<effect>.<param>"`` for an effect parameter.
    lo, hi : float
        Bounds (physical units).
    start : float
        Initial guess.
    scale : float
        Typical magnitude (the NLP works on ``value / scale``).
    prior : tuple of float or None
        Gaussian prior ``(mean, sd)`` in physical units (the baseline's
        constants: a prior at nominal), weighted like ``n_eff`` independent
        samples of the data (see :class:`CandidateFitter`).
    """

    key: str
    lo: float
    hi: float
    start: float
    scale: float
    prior: tuple[float, float] | None = None


@dataclass(frozen=True)
class CandidateSpec:
    """How one candidate effect is fitted.

    Attributes
    ----------
    name : str
        Effect name (the verdict's vocabulary).
    effects : tuple of str
        :class:`EffectSet` composed on the model.
    free : tuple of Free
        Fitted parameters.
    fixed : tuple of (str, float)
        ``("<effect>.<param>", value)`` held fixed (others at the library defaults).
    ties : tuple of (str, str)
        ``("<effect>.<param>", "<key of a Free>")``: shares a fitted value.
    lag : bool
        Amplifier lag (searched over bandwidth and delay, see module docstring).
    note : str
        What was held fixed and why.
    law : str
        Member of the effect's law family (see :func:`family_specs`).
    flexible : bool
        A learned-shape member (splines or Fourier series inside the effect's
        physical signature) rather than a closed-form law: it may only enter a
        verdict by beating the refitted other effects on held-out runs (the
        no-false-claim guard), and the closed-form members are the
        parsimonious alternatives it must beat.
    period_m : float
        The longest period in ``d`` [m] of a learned periodic shape (0: none). A periodic shape is a claim
        that the force repeats; data that do not span :data:`MIN_PERIODS` of its period cannot test it, and
        the member is not offered there (:func:`offered`).
    """

    name: str
    effects: tuple[str, ...] = ()
    free: tuple[Free, ...] = ()
    fixed: tuple[tuple[str, float], ...] = ()
    ties: tuple[tuple[str, str], ...] = ()
    lag: bool = False
    note: str = ""
    law: str = "default"
    flexible: bool = False
    period_m: float = 0.0

    @property
    def keys(self) -> tuple[str, ...]:
        """Keys of the fitted parameters, in vector order."""
        return tuple(f.key for f in self.free)

    def with_free(self, extra: Sequence[Free]) -> CandidateSpec:
        """Copy with more fitted parameters (e.g. the baseline's C1..C4 re-fitted jointly)."""
        keys = {f.key for f in extra}
        free = tuple(extra) + tuple(f for f in self.free if f.key not in keys)
        return replace(self, free=free)

    def renamed(self, name: str) -> CandidateSpec:
        """Copy under another name."""
        return replace(self, name=name)


#: Periods a learned periodic shape's data must span along ``d`` before it is offered: over less, the shape is
#: one smooth bend of the stroke (a cosine of the array's period 2 tau = 114 mm over a 100 mm stroke is a bowl),
#: which an end effect's pull, a cable's or a spring's takes as well; the fit cannot tell it repeats.
MIN_PERIODS: float = 2.0


def offered(fam: Mapping[str, tuple[CandidateSpec, ...]], span_m: float) -> dict[str, tuple[CandidateSpec, ...]]:
    """The members of ``fam`` that data spanning ``span_m`` [m] along ``d`` can test: a learned periodic shape
    only where the data cover :data:`MIN_PERIODS` of its longest period (:attr:`CandidateSpec.period_m`)."""
    out = {}
    for effect, members in fam.items():
        kept = tuple(m for m in members if m.period_m <= 0 or span_m >= MIN_PERIODS * m.period_m)
        if kept:
            out[effect] = kept
    return out


#: Numbers of harmonics of the cogging co-energy members (the complexity the selection chooses between).
ENERGY_HARMONICS: tuple[int, ...] = (3, Cogging.HARMONICS)


def _free(*keys: str) -> tuple[Free, ...]:
    """The :class:`Free` of each key of :data:`_FREE`, in the order given (the fit's vector order)."""
    return tuple(Free(key, *_FREE[key]) for key in keys)


def library_specs() -> dict[str, CandidateSpec]:
    """The candidate library: one spec per effect of :mod:`maglev_ocp.effects`.

    ``parameter_error`` is only meaningful against a given model (``--params``):
    against a model calibrated on the same data it is absorbed by the
    calibration by construction.
    """
    specs = [
        CandidateSpec(
            "cogging",
            ("cogging",),
            free=_free("p.xi0", "p.ell", "cogging.h2", "cogging.h3", "cogging.phi2", "cogging.phi3"),
            fixed=(("cogging.h1", 0.0), ("cogging.power", 0.0), ("cogging.kn", 1.0)),
            ties=(("cogging.xi0", "p.xi0"), ("cogging.ell", "p.ell")),
            note=(
                "the seed's law (xi0, ell in p, eq. (9)) plus the library's 2nd/3rd slot harmonics relative to "
                "xi0 with the same decay; power-law decay (collinear with ell) and the harmonics' normal ratio "
                "kn (undetermined while the harmonics are small) held at 0 and 1"
            ),
        ),
        CandidateSpec(
            "friction",
            ("friction",),
            free=_free("friction.coulomb_g", "friction.coulomb_d", "friction.viscous_g", "friction.viscous_d"),
            fixed=(("friction.stribeck_g", 0.0), ("friction.stribeck_d", 0.0), ("friction.v_reg", 1e-3)),
            note=(
                "Coulomb + viscous per axis; the Stribeck excess (below a few mm/s) and the sign "
                "regularization are below the velocity resolution of 10 um encoders (v_reg fixed at 1 mm/s)"
            ),
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=_free("end_effect.ripple", "end_effect.ripple_phase", "end_effect.d_edge", "end_effect.edge_width"),
            note="thrust ripple with the pole pitch and loss of force at overhang, all four parameters",
        ),
        CandidateSpec(
            "amplifier_lag",
            (),
            lag=True,
            free=(),
            note=(
                "first-order lag + whole-sample delay, applied to the commanded currents exactly as the plant "
                "does; below the residual's cut-off lag and delay act alike, so the split between them is "
                "weakly determined"
            ),
        ),
        CandidateSpec(
            "saturation",
            ("saturation",),
            free=_free("saturation.loss_8mm", "saturation.ell_sat"),
            note="gap-dependent loss of every magnetic force",
        ),
        CandidateSpec(
            "commutation_offset",
            ("commutation_offset",),
            free=_free("commutation_offset.delta"),
            note="dq-frame rotation of the motor currents",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_eddy"),
            note="drag proportional to B(g)^2 times the horizontal velocity",
        ),
        CandidateSpec(
            "parameter_error",
            ("parameter_error",),
            free=_free(*(f"parameter_error.k_C{i}" for i in range(1, 5))),
            fixed=(("parameter_error.k_Mh", 1.0), ("parameter_error.k_Mv", 1.0)),
            note=(
                "factors on the C1..C4 terms; mass factors are not separable from them (a mass error "
                "scales the same terms) and are held at 1"
            ),
        ),
    ]
    return {s.name: s for s in specs}


def family_specs() -> dict[str, tuple[CandidateSpec, ...]]:
    """Law families: for each library effect, its members, the library's law (the nested one) first.

    A rig's effects rarely follow the library's law exactly; each family nests the library's law in a more general
    one, so that an effect whose law differs is still named (the member is chosen by held-out score and the
    information criterion, see :func:`maglev_ocp.diagnosis.diagnose.diagnose`):

    - ``cogging``: ``free decay``: the decay as a free smooth function of g (exponential, power law and a curvature
      of the log-decay, :class:`~maglev_ocp.effects.Cogging`), the normal-to-tangential ratio and the 2nd/3rd
      harmonics free;
    - ``friction``: ``stribeck``: Coulomb + viscous + the Stribeck excess and velocity (a hysteretic Dahl/LuGre term
      needs a friction state the equation-error residual does not carry; below the 15 Hz cut-off its pre-sliding
      part acts like a smoothed Coulomb force); ``load``: the dry friction scaled by the guide's load as the gap
      changes;
    - ``saturation``: which terms it scales: ``field`` (the magnet field: its B^2 attraction and cogging lose twice
      what the B-linear PM-current and thrust terms lose, the reluctance term nothing), ``current terms`` (the field
      of the currents: the current-linear PM-current and thrust terms lose L, the reluctance term, quadratic in it,
      twice that, the magnets' attraction nothing) and ``per term`` (a free share for each); and the loss's profile
      in g: ``knee`` (and ``field``, ``current terms``) a logistic step whose knee is free, nesting the exponential
      at ``knee = 0``; ``shape`` and ``shape current terms`` (flexible): a learned loss of any shape that never
      falls as the gap closes (a cubic B-spline in g with non-negative steps,
      :meth:`~maglev_ocp.effects.Saturation.shape_loss`), on every magnetic term or on the current terms; ``current
      loss`` (flexible): a loss of the current terms non-decreasing in the current magnitude, whatever the gap
      (:meth:`~maglev_ocp.effects.Saturation.current_loss`);
    - ``commutation_offset``: ``drift``: the offset grows linearly along the stroke (a commutation encoder scale off
      the position encoder's);
    - ``end_effect``: ``free profile``: the overhang loss scaled and bent (``edge_gain``, ``edge_quad``); ``two
      ends``, ``two ends, end force`` and ``two ends, winding force``: ends of their own, with the magnets' end
      force and the winding's (a force along d quadratic in the currents, where the armature's inductance changes at
      a stator end); ``two ends, winding loss``: ends of their own, the magnets' pull keeping a share of its own
      (``edge_pm``: the winding's linkage lost at the ends, the iron's pull whole); ``spline profile``: a loss of
      any smooth shape in ``|d|`` that never falls as the overhang grows (a cubic B-spline with non-negative steps,
      the same at both ends, so it also takes a loss that levels off), and the cogging's share of the loss;
    - ``amplifier_lag``: the library's member searches a continuous effective delay (whole samples plus a lag, which
      act alike below the cut-off); ``fractional``: a first-order lag and a transport delay of any length;
      ``second``: a second-order response (natural frequency, damping) and a fractional delay (:mod:`.lagfit`: the
      search over the group delay, the lag's share of it and the damping);
    - ``eddy_drag``: ``reitz``: a drag shaped in velocity (linear at low speed, falling above a critical velocity)
      with a lift that opens the gap (Reitz 1970), its coefficient decaying with g at a rate bounded by the field's
      harmonics (:class:`~maglev_ocp.effects.EddyDrag`); ``two_axis``: the drag on both velocities; ``d profile``:
      the drag times a smooth profile along the stroke (:meth:`~maglev_ocp.effects.EddyDrag.profile`); ``side``: a
      conductor beside the array, its drag growing as the gap opens (never flat in g: a flat coefficient is viscous
      friction's); ``two conductors``: both, the sum of a drag falling and one growing with g (a conductor under the
      array and one above or beside it); ``normal``: a conductor damping the gap's own motion, its coefficient
      falling with g (never flat: a flat damping of the gap is the air's);
    - learned shapes (flexible) of ``cogging`` (``co-energy 3``, ``co-energy 6``: a co-energy periodic in d whose
      gradient is both the tangential and the normal force, each harmonic decaying in g at a rate of its own,
      :meth:`~maglev_ocp.effects.Cogging.energy_forces`; ``pole pair``: the same with harmonics of the array's
      period ``2 tau``, a stator that is not uniform; each offered only where the data span :data:`MIN_PERIODS` of
      its period, :func:`offered`), ``friction`` (``spline``: an odd function of each velocity, Coulomb + viscous +
      a non-negative spline of the speed, its load) and ``commutation_offset`` (``spline``: the angle a spline of
      d);
    - ``commutation_offset``: ``electrical harmonics``: an angle error periodic in the electrical angle (first and
      second harmonics) whose amplitude grows or falls with the gap at a fitted rate; ``latency``: the angle lags
      with the speed (a sensor's, a filter's or a shield's delay).
    """
    lib = library_specs()
    out = {n: (s,) for n, s in lib.items()}
    harm = tuple(f for f in lib["cogging"].free if f.key.startswith("cogging."))
    decay = _free("cogging.xi0", "cogging.ell", "cogging.power", "cogging.curv", "cogging.kn")
    out["cogging"] += (
        CandidateSpec(
            "cogging",
            ("cogging",),
            free=(*decay, *harm),
            fixed=(("cogging.h1", 1.0),),
            note="decay free (exponential x power law x log-curvature), normal ratio kn and harmonics free",
            law="free decay",
        ),
        CandidateSpec(
            "cogging",
            ("cogging",),
            free=(
                Free("cogging.ell", 1e-3, 0.05, 4e-3, 4e-3),
                Free("cogging.power", 0.0, 4.0, 0.0, 1.0),
                Free("cogging.kn", 0.0, 4.0, 1.0, 0.5),
                Free("cogging.h1", -5.0, 5.0, 0.0, 0.5),
                Free("cogging.h2", -5.0, 5.0, 0.3, 0.5),
                Free("cogging.h3", -5.0, 5.0, 0.1, 0.5),
                Free("cogging.phi2", -2 * math.pi, 2 * math.pi, 0.3, 1.0),
                Free("cogging.phi3", -2 * math.pi, 2 * math.pi, 0.3, 1.0),
            ),
            fixed=(("cogging.xi0", 1.0),),
            note=(
                "cogging beyond the model's eq. (9) with a decay of its own: fundamental and 2nd/3rd slot harmonics "
                "in N at g = 10 mm (xi0 = 1 N), exponential x power-law decay and normal ratio free"
            ),
            law="own decay",
        ),
    )
    # The learned shape (flexible): the co-energy of Cogging.energy_forces with 3 or 6 harmonics of seed eq. (9)'s
    # period 2 t1 (the slot pitch is the 2nd); the number of harmonics is chosen like a member, by the held-out
    # runs and the information criterion with its penalty per parameter (refine_laws).
    out["cogging"] += tuple(
        CandidateSpec(
            "cogging",
            ("cogging",),
            free=_free(*(f"cogging.{n}" for n in Cogging.energy_names(n_h)), "cogging.e_curv"),
            fixed=(("cogging.xi0", 0.0),),
            note=(
                f"learned cogging from one co-energy W(d, g) (slot-permeance method, Zhu & Howe 1992): harmonics "
                f"1..{n_h} of period {ENERGY_PERIOD * 1e3:.2f} mm / k (seed eq. (9)'s 2 t1; the slot pitch is k = 2), "
                "tangential -dW/dd and normal -dW/dg linked, each harmonic's decay in g its own within "
                f"{ENERGY_DECAY_RANGE[0]:g}..{ENERGY_DECAY_RANGE[1]:g} times its wavenumber, amplitudes in N at "
                f"g = {G_ENERGY_REF * 1e3:.0f} mm; zero mean in d, no velocity: it cannot take up friction or an "
                "end effect"
            ),
            law=f"co-energy {n_h}",
            flexible=True,
            period_m=ENERGY_PERIOD,
        )
        for n_h in ENERGY_HARMONICS
    )
    # The pole-pair co-energy (flexible): a stator that is not uniform pulls on each pole in turn, a cogging with
    # the array's period 2 tau (Cogging's docstring), with the slot co-energy's first three harmonics.
    out["cogging"] += (
        CandidateSpec(
            "cogging",
            ("cogging",),
            free=_free(
                *(f"cogging.{n}" for n in Cogging.pole_names()),
                *(f"cogging.{n}" for n in Cogging.energy_names(ENERGY_HARMONICS[0])),
                "cogging.e_curv",
            ),
            fixed=(("cogging.xi0", 0.0),),
            note=(
                f"learned cogging of a stator that is not uniform (unequal teeth, a tooth's remanence: Gasparin et "
                f"al. 2009): one co-energy W(d, g) with harmonics 1, 2 of the array's period "
                f"{POLE_PERIOD * 1e3:.1f} mm (2 tau) and 1..{ENERGY_HARMONICS[0]} of {ENERGY_PERIOD * 1e3:.2f} mm "
                "(2 t1), tangential and normal forces linked, each harmonic's decay its own; no velocity, no current"
            ),
            law="pole pair",
            flexible=True,
            period_m=POLE_PERIOD,
        ),
    )
    stribeck = _free("friction.stribeck_g", "friction.stribeck_d", "friction.v_stribeck")
    out["friction"] += (
        CandidateSpec(
            "friction",
            ("friction",),
            free=(*lib["friction"].free, *stribeck),
            fixed=(("friction.v_reg", 1e-3),),
            note="Coulomb + viscous + Stribeck excess and velocity per axis (v_reg fixed at 1 mm/s)",
            law="stribeck",
        ),
        CandidateSpec(
            "friction",
            ("friction",),
            free=(*lib["friction"].free, *_free("friction.dir_g", "friction.dir_d")),
            fixed=(("friction.stribeck_g", 0.0), ("friction.stribeck_d", 0.0), ("friction.v_reg", 1e-3)),
            note=(
                "Coulomb + viscous with a level of its own in each sliding direction (a seal lip or wiper that "
                "rubs harder one way): -dir tanh(v / v_reg)^2 per axis, even in v and nil at rest"
            ),
            law="directional",
        ),
        CandidateSpec(
            "friction",
            ("friction",),
            free=(*lib["friction"].free, *_free("friction.load_g", "friction.load_d")),
            fixed=(("friction.stribeck_g", 0.0), ("friction.stribeck_d", 0.0), ("friction.v_reg", 1e-3)),
            note="Coulomb + viscous per axis, the Coulomb level scaled by the guide's load: exp(load (20 mm - g))",
            law="load",
        ),
        CandidateSpec(
            "friction",
            ("friction",),
            free=(
                *lib["friction"].free,
                *_free(*(f"friction.{n}" for ax in "gd" for n in Friction.shape_names(ax))),
                *_free("friction.dir_g", "friction.dir_d"),
                *_free("friction.load_g", "friction.load_d"),
            ),
            fixed=(("friction.stribeck_g", 0.0), ("friction.stribeck_d", 0.0), ("friction.v_reg", 1e-3)),
            note=(
                "learned friction: Coulomb + viscous plus a non-negative cubic B-spline of the speed per axis "
                f"(knots uniform in |v| / (|v| + {Friction.V0 * 1e3:.0f} mm/s)), an odd function of each velocity, "
                "a level of its own in each sliding direction (even in v, nil at rest), and the dry part following "
                "the guide's load with the gap"
            ),
            law="spline",
            flexible=True,
        ),
    )
    out["amplifier_lag"] += (
        CandidateSpec(
            "amplifier_lag",
            (),
            lag=True,
            note=(
                "first-order lag of bandwidth f_b and a transport delay of any length (the fraction of a sample "
                "solved exactly within the ZOH period): 2 parameters searched"
            ),
            law="fractional",
        ),
        CandidateSpec(
            "amplifier_lag",
            (),
            lag=True,
            note=(
                "second-order response wn^2 / (s^2 + 2 zeta wn s + wn^2) (a PI current loop with the inverter's "
                "lag) of natural frequency f_n and damping zeta, and a fractional transport delay: 3 parameters"
            ),
            law="second",
        ),
    )
    out["eddy_drag"] += (
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_ref", "eddy_drag.kappa", "eddy_drag.inv_vc", "eddy_drag.lift"),
            fixed=(("eddy_drag.c_eddy", 0.0),),
            note=(
                "Reitz's moving-magnet law: drag c(g) v / (1 + (v / v_c)^2) (linear at low speed, falling above "
                "v_c) and a lift opening the gap, c(g) v^2 / v_c / (1 + (v / v_c)^2) times a share; c(g) decays "
                "with the gap between the field's fundamental and third harmonic squared (never flat in g: "
                "that would be viscous friction)"
            ),
            law="reitz",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_eddy", "eddy_drag.c_vert"),
            note=(
                "the drag of B(g)^2 on both velocities: c(g) v along d and c_vert c(g) g_dot along g (a velocity "
                "normal to the conductor induces eddy currents as a tangential one does; the ratio depends on the "
                "conductor's extent and thickness): 2 parameters"
            ),
            law="two_axis",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_eddy", *(f"eddy_drag.{n}" for n in EddyDrag.profile_names() if n != "dprof_0")),
            note=(
                "the drag of B(g)^2 times a smooth profile along the stroke, c(g) (1 + p(d)) v (a cubic B-spline "
                "in d, knots every 20 mm, its value at d = 0 held: the size is c_eddy's): a conductor that ends "
                "with the stator or whose circuits close differently along d; still falling with the gap"
            ),
            law="d profile",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_side", "eddy_drag.kappa_side"),
            fixed=(("eddy_drag.c_eddy", 0.0),),
            note=(
                "a conductor beside the array, in its leakage field: the more the mover rises, the more of its side "
                "faces the conductor, so the drag grows as the gap opens, c_side exp(kappa_side (g - g_ref)) v, "
                "kappa_side 41 /m (a factor 1.5 over the targets' gaps 15..25 mm) to 2 pi / tau (never flat in g: "
                "that would be viscous friction): 2 parameters"
            ),
            law="side",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_eddy", "eddy_drag.c_side", "eddy_drag.kappa_side"),
            note=(
                "two conductors on either side of the mover: one under the array, its drag of B(g)^2 falling as "
                "the gap opens, and one above or beside it, its drag growing, c_side exp(kappa_side (g - g_ref)) "
                "(a cover over the stage, a side rail): the sum falls, grows or has a valley over the gaps: "
                "3 parameters"
            ),
            law="two conductors",
        ),
        CandidateSpec(
            "eddy_drag",
            ("eddy_drag",),
            free=_free("eddy_drag.c_gap", "eddy_drag.kappa_gap"),
            fixed=(("eddy_drag.c_eddy", 0.0),),
            note=(
                "a conductor damping the gap's own motion (the flux through it changes as the gap does: the "
                "stator's sheet, the mover's solid back iron), c_gap exp(-kappa_gap (g - g_ref)) g_dot on the gap "
                "axis, none along d; kappa_gap 41 /m (a factor 1.5 over 15..25 mm) to 6 pi / tau (never flat in "
                "g: a flat damping of the gap is not a conductor's): 2 parameters"
            ),
            law="normal",
        ),
    )
    sat = lib["saturation"].free
    knee = (*sat, *_free("saturation.knee"))
    w0 = (("saturation.w_pm", 1.0), ("saturation.w_id", 0.5), ("saturation.w_thrust", 0.5), ("saturation.w_rel", 0.0))
    w1 = (("saturation.w_pm", 0.0), ("saturation.w_id", 1.0), ("saturation.w_thrust", 1.0), ("saturation.w_rel", 2.0))
    per_term = _free("saturation.w_pm", "saturation.w_id", "saturation.w_rel", "saturation.w_thrust")
    out["saturation"] += (
        CandidateSpec(
            "saturation",
            ("saturation",),
            knee,
            note="every magnetic term, the loss a logistic step in g (knee free; 0 is the library's exponential)",
            law="knee",
        ),
        CandidateSpec(
            "saturation",
            ("saturation",),
            knee,
            w0,
            note="saturation of the magnet field (B scaled), exponential or logistic loss (knee free)",
            law="field",
        ),
        CandidateSpec(
            "saturation",
            ("saturation",),
            knee,
            w1,
            note="saturation of the current terms (PM-current, reluctance, thrust), exponential or logistic loss",
            law="current terms",
        ),
        CandidateSpec(
            "saturation",
            ("saturation",),
            free=(sat[1], *per_term),
            fixed=(("saturation.loss_8mm", 1.0),),
            note="a free loss at g = 8 mm for each magnetic term (w_*), one decay length",
            law="per term",
        ),
        *(
            CandidateSpec(
                "saturation",
                ("saturation",),
                free=_free(*(f"saturation.{n}" for n in Saturation.shape_names())),
                fixed=(("saturation.loss_8mm", 0.0), *w),
                note=(
                    f"learned loss of {what}: a cubic B-spline in g (knots every "
                    f"{Saturation.KNOT_STEP * 1e3:.0f} mm), non-increasing in g (non-negative steps)"
                ),
                law=law,
                flexible=True,
            )
            for law, what, w in (
                ("shape", "every magnetic term", ()),
                ("shape current terms", "the current terms (shares as 'current terms')", w1),
            )
        ),
        CandidateSpec(
            "saturation",
            ("saturation",),
            free=_free(*(f"saturation.{n}" for n in Saturation.current_names())),
            fixed=(("saturation.loss_8mm", 0.0), *w1),
            note=(
                "learned loss of the current terms in the current magnitude |i| (the winding's own flux saturating "
                "its paths, whatever the gap): a cubic B-spline in |i| (knots every 2 A), non-decreasing, 0 at no "
                "current"
            ),
            law="current loss",
            flexible=True,
        ),
    )
    out["commutation_offset"] += (
        CandidateSpec(
            "commutation_offset",
            ("commutation_offset",),
            free=_free("commutation_offset.delta", "commutation_offset.drift"),
            note="dq-frame rotation growing along the stroke, delta + drift d",
            law="drift",
        ),
        CandidateSpec(
            "commutation_offset",
            ("commutation_offset",),
            free=_free(*(f"commutation_offset.{n}" for n in CommutationOffset.shape_names())),
            fixed=(("commutation_offset.delta", 0.0), ("commutation_offset.drift", 0.0)),
            note=(
                "learned commutation offset: a cubic B-spline of d (knots every "
                f"{CommutationOffset.KNOT_STEP * 1e3:.0f} mm; nests the constant and the drift exactly)"
            ),
            law="spline",
            flexible=True,
        ),
        CandidateSpec(
            "commutation_offset",
            ("commutation_offset",),
            free=_free(
                "commutation_offset.delta", *(f"commutation_offset.{n}" for n in CommutationOffset.harmonic_names())
            ),
            note=(
                "an offset plus an angle error periodic in the electrical angle (first and second harmonics), "
                "growing or falling with the gap at a fitted rate (Hall sensors' offsets and stray fields)"
            ),
            law="electrical harmonics",
        ),
        CandidateSpec(
            "commutation_offset",
            ("commutation_offset",),
            free=_free("commutation_offset.delta", "commutation_offset.latency"),
            note=(
                "an offset plus a latency: the angle lags by the electrical angle travelled while it is read, "
                "filtered or shielded, delta - (pi / tau) latency d_dot (a rotation that follows the speed): "
                "2 parameters"
            ),
            law="latency",
        ),
    )
    knots = tuple(f"end_effect.{n}" for n in EndEffect.profile_names())
    # the free profile with ends of their own: the base of the "two ends" members
    two_ends = (
        *lib["end_effect"].free,
        *_free("end_effect.edge_gain", "end_effect.edge_quad", "end_effect.edge_skew", "end_effect.gain_skew"),
    )
    out["end_effect"] += (
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(*lib["end_effect"].free, *_free("end_effect.edge_gain", "end_effect.edge_quad")),
            note="thrust ripple and an overhang loss of free size and curvature",
            law="free profile",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(
                *two_ends,
                *_free("end_effect.ripple2", "end_effect.ripple2_phase"),
            ),
            note=(
                "the free profile with ends of their own (onset and loss per overhang differ between d > 0 and "
                "d < 0) and the thrust ripple's second harmonic"
            ),
            law="two ends",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(
                *two_ends,
                *_free("end_effect.end_force", "end_effect.end_ell"),
            ),
            note=(
                "the two ends' overhang loss with the end force that goes with it: the overlap's co-energy "
                "pulls an overhanging array back along d (virtual work), with the loss's onset at each end"
            ),
            law="two ends, end force",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(
                *two_ends,
                *_free("end_effect.end_force", "end_effect.end_ell", "end_effect.end_i2"),
            ),
            note=(
                "the two ends' overhang loss and end force with the winding's end force: the armature's "
                "inductance changes where the back iron leaves the winding, a force along d quadratic in the "
                "currents (co-energy (1/2) L(d) i^2), with the loss's onset at each end"
            ),
            law="two ends, winding force",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(
                *two_ends,
                *_free("end_effect.edge_pm"),
            ),
            note=(
                "the two ends' overhang loss with the magnets' pull keeping a share of its own: where the "
                "winding's linkage ends before the iron does (end coils, a double-layer winding's half-filled "
                "end slots) the currents' terms lose and the pull does not"
            ),
            law="two ends, winding loss",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(*_free("end_effect.ripple", "end_effect.ripple_phase"), *_free("end_effect.edge_cog", *knots)),
            fixed=(("end_effect.edge_gain", 0.0),),
            note=(
                "thrust ripple and an overhang loss of any smooth shape, the same at both ends (cubic "
                "B-spline in |d|, knots every 5 mm from 10 mm), the cogging's share of the loss free"
            ),
            law="spline profile",
        ),
        CandidateSpec(
            "end_effect",
            ("end_effect",),
            free=(
                *_free("end_effect.ripple", "end_effect.ripple_phase", "end_effect.ripple2"),
                *_free("end_effect.ripple2_phase", "end_effect.edge_cog", *knots),
            ),
            fixed=(("end_effect.edge_gain", 0.0),),
            note=(
                "the spline profile with the thrust ripple's second harmonic (period tau / 2): a motor's ripple "
                "has harmonics of the pole pitch, like its cogging"
            ),
            law="spline profile, ripple harmonics",
        ),
    )
    return out


#: Gaussian prior of the calibrated constants: sd relative to nominal (C4, a small term, is loosely known; the
#: cogging law's xi0 and ell of seed eq. (9), identifiable like C1..C4 (MODEL.md), vary more from rig to rig).
PRIOR_SD: dict[str, float] = {"C1": 0.1, "C2": 0.1, "C3": 0.1, "C4": 0.5, "xi0": 0.5, "ell": 0.5, "Mv": 0.1}


def calibration_free(
    params: Params,
    vertical: bool,
    horizontal: bool,
    ref: Params | None = None,
    prior_sd: Mapping[str, float] | None = None,
    cogging: bool = False,
) -> tuple[Free, ...]:
    """Free entries C1..C4 of ``p`` (and xi0, ell of the cogging law) for a calibration on data with the given channels.

    Starts at ``params``; the bounds are relative to ``ref`` (default: the nominal
    set), so that a joint re-fit can undo what a biased calibration absorbed
    (in closed loop an unmodelled force that the controller fights drags the
    thrust constant towards zero). ``prior_sd`` (relative to ``ref``, e.g.
    :data:`PRIOR_SD`) puts a Gaussian prior at ``ref`` on each constant.
    ``cogging`` also frees the amplitude ``xi0`` and decay ``ell`` of the
    shared model's cogging (seed eq. (9), MODEL.md), which acts on both channels.
    """
    from ..params import NOMINAL

    ref = ref or NOMINAL

    def pr(name: str, nominal: float) -> tuple[float, float] | None:
        if prior_sd is None or name not in prior_sd:
            return None
        return (nominal, prior_sd[name] * max(abs(nominal), 1e-12))

    out = []
    if horizontal:
        out.append(Free("p.C1", 0.2 * ref.C1, 3.0 * ref.C1, params.C1, ref.C1, pr("C1", ref.C1)))
    if vertical:
        out += [
            Free("p.C2", 0.3 * ref.C2, 3.0 * ref.C2, params.C2, ref.C2, pr("C2", ref.C2)),
            Free("p.C3", 0.0, 5.0 * max(ref.C3, 1.0), params.C3, max(ref.C3, 1.0), pr("C3", ref.C3)),
            Free("p.C4", 0.0, 20.0 * max(ref.C4, 0.05), params.C4, max(ref.C4, 0.05), pr("C4", ref.C4)),
        ]
    if cogging and (vertical or horizontal):
        xi_ref, ell_ref = max(ref.xi0, 1.0), ref.ell if ref.ell > 0 else 4e-3
        out += [
            Free("p.xi0", 0.0, 50.0, params.xi0, 4.0, pr("xi0", xi_ref)),
            Free("p.ell", 1e-3, 0.03, min(max(params.ell, 1e-3), 0.03), 4e-3, pr("ell", ell_ref)),
        ]
        if vertical:
            # The cogging force [N] acts through the masses: xi0 / Mh along d and xi0 / Mv on g. The lumped C's
            # carry the masses of the magnetic terms, not of the cogging; a rig whose Mv / Mh differs from the
            # nominal ratio (masses a few % off) leaves a slot-periodic residual in g that a calibrated xi0
            # cannot remove (seen on the independent rig without effects). Mv is calibrated with it (Mh stays:
            # xi0 / Mh is what the horizontal channel determines).
            out.append(Free("p.Mv", 0.7 * ref.Mv, 1.4 * ref.Mv, params.Mv, ref.Mv, pr("Mv", ref.Mv)))
    return tuple(out)


def combine(a: CandidateSpec, b: CandidateSpec) -> CandidateSpec:
    """Two candidates composed on the model at once (shared model parameters appear once)."""
    keys = set()
    free = []
    for f in (*a.free, *b.free):
        if f.key not in keys:
            keys.add(f.key)
            free.append(f)
    return CandidateSpec(
        f"{a.name}+{b.name}",
        tuple(dict.fromkeys((*a.effects, *b.effects))),
        tuple(free),
        a.fixed + b.fixed,
        a.ties + b.ties,
        a.lag or b.lag,
        f"{a.note}; {b.note}",
        "; ".join(x for x in (a.law, b.law) if x),
        a.flexible or b.flexible,
    )


__all__ = [
    "PRIOR_SD",
    "CandidateSpec",
    "Free",
    "calibration_free",
    "combine",
    "family_specs",
    "library_specs",
    "offered",
]
