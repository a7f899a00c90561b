"""Random parameters of the sixth law set (:mod:`.laws_v6`, ``rigsim.draw(..., laws="v6")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized
like the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none
driving the stage into its stops); the comment at each range says where it comes from. :func:`draw_v6` picks
the effects of a scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 6])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v6 import EFFECTS_V6, V6_LAWS, V6_LIBRARY, V6_OUT_OF_LIBRARY
from .laws_v6_ool import StatorFlatness

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V6_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # tangential peak at 15 mm 1-2.5 N (1.8-3 N replacing seed eq. (9), whose peak there is 1.0 N): the earlier sets'
    # sizes at the hover gaps (these harmonics decay faster with the gap: 10-15 times that at the lower stop); the
    # slot grid anywhere against the array
    p: Spec = {"family": fam, "replace": float(replace), "xi0": _u(rng, 1.8, 3.0) if replace else _u(rng, 1.0, 2.5)}
    p["x0"] = _u(rng, 0.0, k.t1)
    if fam == "paired_teeth":  # tooth widths 6.35 mm +- 1-3 mm (pairs shifted 0.5-1.5 mm), openings +-10-30 %
        p.update(delta_p=_u(rng, 5e-4, 1.5e-3), eps_b=_pm(rng, 0.1, 0.3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    # levels 0.1-0.4 N per guide and viscous 0-2 N s/m, as the earlier sets
    p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.4), "Fc_d": _u(rng, 0.1, 0.4)}
    p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0))
    if fam == "rail_position":  # ball passage: balls of 3-6 mm (period 2 ball pitches), +-10-30 %; the rail's
        # straightness over 40-150 mm, +-10-40 %
        p.update(a_b=_u(rng, 0.1, 0.3), p_b=_u(rng, 6e-3, 1.2e-2), ph_b=_u(rng, -math.pi, math.pi))
        p.update(a_r=_u(rng, 0.1, 0.4), p_r=_u(rng, 0.04, 0.15), ph_r=_u(rng, -math.pi, math.pi), v_reg=1e-3)
        return p
    # presliding 2-20 um (rolling guides' microslip), breakaway 20-80 % above the sliding level
    p.update(z0=_log(rng, 2e-6, 2e-5), a=_u(rng, 0.2, 0.8))
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    p: Spec = {"family": fam, "r1": _u(rng, 0.02, 0.08), "p1": _u(rng, -math.pi, math.pi)}
    p.update(r2=_u(rng, 0.0, 0.04), p2=_u(rng, -math.pi, math.pi))
    if fam == "segment_joint":  # a module joint of 6-20 mm anywhere within +-40 mm (1-4 % of the pull under it)
        p.update(x_j=_u(rng, -0.04, 0.04), w_j=_u(rng, 6e-3, 2e-2))
        return p
    # stator ends 10-35 mm past the array's ends (as v5), clamping yokes 10-30 mm long that carry 0.6-1.4 of their
    # saturation flux at the lower stop, 5-20 % of the linear circuit's reluctance
    p.update(e_p=_u(rng, 0.01, 0.035), e_n=_u(rng, 0.01, 0.035), l_y=_u(rng, 0.01, 0.03))
    p.update(b_lo=_u(rng, 0.6, 1.4), r=_u(rng, 0.05, 0.2))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "incremental_arctan":  # 55-85 % of saturation at the lower stop, iron 5-25 % of the reluctance
        return {"family": fam, "b_lo": _u(rng, 0.55, 0.85), "r": _u(rng, 0.05, 0.25), "target": "both"}
    # the most loaded tooth at 0.1-0.35 of the Frohlich curve's scale at the lower stop (the curve has no linear
    # part: 10-30 % of the pull lost there, 3-12 % at a hover in the gap band, as the earlier sets' saturation); the
    # tooth grid anywhere against the array
    return {"family": fam, "b_lo": _u(rng, 0.1, 0.35), "x0": _u(rng, 0.0, k.t1), "target": "magnet"}


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "sine_filter":  # loop 200-800 Hz; the filter's resonance 0.6-2.5 kHz, damped 0.1-0.5 (Steinke's range
        # between the control bandwidth and the PWM frequency)
        return {
            "family": fam,
            "bandwidth_hz": _log(rng, 200.0, 800.0),
            "fr_hz": _log(rng, 600.0, 2500.0),
            "zeta": _u(rng, 0.1, 0.5),
            "delay_samples": _u(rng, 0.0, 1.5),
        }
    # loop 100-600 Hz; winding L/R 2-10 ms; the copper 13-110 K warmer than when the loop was tuned (R^/R = 1 / (1 +
    # 0.0039 dT): 0.7-0.95), the inductance off by +-15 % (saturation)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 100.0, 600.0),
        "tau_w": _log(rng, 2e-3, 1e-2),
        "rho_R": _u(rng, 0.7, 0.95),
        "rho_L": _u(rng, 0.85, 1.15),
        "delay_samples": _u(rng, 0.0, 1.5),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "tracking_observer":  # tracking loops of 4-12 Hz (an analog Hall sensor's PLL tuned low against its
        # noise), damping 0.5-1: 0.005-0.05 rad at the moves' accelerations (~1 m/s^2)
        return {"family": fam, "delta0": _pm(rng, 0.0, 0.03), "fn_hz": _log(rng, 4.0, 12.0), "zeta": _u(rng, 0.5, 1.0)}
    # armature field at the sensor (in a slot, beside the coils) 2-8 % of the magnets' (at 10 mm) per ampere of q
    # current, 0.2-1 % per ampere of d current; sensor 3-8 mm behind the stator surface
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.03),
        "a_q": _pm(rng, 0.02, 0.08),
        "a_d": _u(rng, 2e-3, 1e-2),
        "c_s": _u(rng, 3e-3, 8e-3),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "plate_patch":  # a copper / aluminium plate 30-120 mm long starting anywhere within the stroke's
        # reach; 20-80 N s/m under the whole array at 10 mm (5-20 N s/m at 20 mm); image reach 10-25 mm
        return {
            "family": fam,
            "c0": _u(rng, 20.0, 80.0),
            "x_a": _u(rng, -0.1, 0.04),
            "l_p": _u(rng, 0.03, 0.12),
            "r_p": _u(rng, 0.01, 0.025),
        }
    # sheets of 1-5 mm of copper / aluminium: w 5-30 m/s, tau_e 0.5-4 ms; 15-50 N s/m at 10 mm (4-12 at 20 mm)
    return {"family": fam, "c0": _u(rng, 15.0, 50.0), "tau_e": _log(rng, 5e-4, 4e-3)}


def _current_sensor(rng):
    # Hall / shunt current sensors: gain errors of 0.5-3 % and offsets of 10-60 mA per sensor
    return {
        "family": "gain_offset",
        "eps_a": _pm(rng, 5e-3, 3e-2),
        "eps_b": _pm(rng, 0.0, 3e-2),
        "off_a": _pm(rng, 0.01, 0.06),
        "off_b": _pm(rng, 0.0, 0.06),
        "theta0": _u(rng, -math.pi, math.pi),
    }


def _flatness(rng):
    # a stator 100-500 urad off parallel, a bow of 10-40 um over +-60 mm, stacks of 60-120 mm with +-5-20 um steps
    p: Spec = {"family": "tilt_bow_steps", "tilt": _pm(rng, 1e-4, 5e-4), "bow": _pm(rng, 1e-5, 4e-5)}
    ls = _u(rng, 0.06, 0.12)
    p.update(ls=ls, x0=-0.06 - _u(rng, 0.0, ls))  # the first joint within a stack of the stroke's start
    for j in range(StatorFlatness.N_STEPS):
        p[f"h{j}"] = _pm(rng, 5e-6, 2e-5)
    return p


#: Random parameters of the sixth set, by effect name.
V6_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "phase_current_sensor": _current_sensor,
    "stator_flatness": _flatness,
}


def draw_v6(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v6 scenario of ``kind`` with ``n`` library effects, from the seed's sixth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 6]))
    return draw_effects(rng, kind, n, V6_LIBRARY, V6_OUT_OF_LIBRARY, V6_DRAWS, EFFECTS_V6, True)


__all__ = ["V6_DRAWS", "draw_v6"]
