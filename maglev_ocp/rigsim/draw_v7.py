"""Random parameters of the seventh law set (:mod:`.laws_v7`, ``rigsim.draw(..., laws="v7")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized
like the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none
driving the stage into its stops); the comment at each range says where it comes from. :func:`draw_v7` picks
the effects of a scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 7])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v7 import EFFECTS_V7, V7_LAWS, V7_LIBRARY, V7_OUT_OF_LIBRARY
from .physics import NOMINAL, shape

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V7_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # harmonics' amplitudes summing to 2-5 N at 10 mm (3-6 N replacing seed eq. (9), whose peak there is 4 N), as
    # the first sets' sizes; the second slot harmonic +-0-40 % of it at 10 mm (it decays twice as fast); the slot
    # grid anywhere
    p: Spec = {"family": fam, "replace": float(replace), "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)}
    p.update(c2=_pm(rng, 0.0, 0.4), phi2=_u(rng, -math.pi, math.pi), x0=_u(rng, 0.0, k.t1))
    if fam == "lossy_teeth":  # solid tooth tips 3-8 mm wide, mu_r 300-1000, sigma 5e6 S/m: mu sigma w^2 / 12 spans
        # 1-30 ms; 1-8 ms keeps omega tau 0.1-0.8 at the moves' 0.1-0.3 m/s
        p["tau_e"] = _log(rng, 1e-3, 8e-3)
    else:  # the tips saturate at 0.5-1.5 times the unsaturated energy swing at 10 mm (little at 15 mm and above)
        p["xi_s"] = p["xi0"] * _u(rng, 0.5, 1.5)
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "power_law":  # levels 0.1-0.4 N per guide as the earlier sets; the grease's viscous part 0.05-0.4 N at
        # 0.1 m/s with flow index 0.4-0.8 (lithium-soap greases are shear thinning, n < 1: Harnoy 2002)
        p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.4), "Fc_d": _u(rng, 0.1, 0.4)}
        p.update(F1_g=_u(rng, 0.05, 0.4), F1_d=_u(rng, 0.05, 0.4), n=_u(rng, 0.4, 0.8), v0=1e-3, v_reg=1e-3)
        return p
    # Coulomb 0.1-0.3 N plus a Stribeck excess 0.05-0.25 N below 2-10 mm/s (the earlier sets' ranges); the film's
    # time lag 5-50 ms (Hess & Soom measured lags of milliseconds to tens of ms); viscous 0-2 N s/m
    p = {"family": fam, "Fc_g": _u(rng, 0.1, 0.3), "Fc_d": _u(rng, 0.1, 0.3)}
    p.update(Fs_g=_u(rng, 0.05, 0.25), Fs_d=_u(rng, 0.05, 0.25), vs=_u(rng, 2e-3, 1e-2), tau_L=_log(rng, 5e-3, 5e-2))
    p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0), v_reg=1e-3)
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 10-35 mm past the array's ends at d = 0 (as v5 and v6): the moves overhang them by up to ~40 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.01, 0.035), "e_n": _u(rng, 0.01, 0.035)}
    if fam == "phase_unbalance":  # the slot grid anywhere against the pole pitch
        p["x_w"] = _u(rng, 0.0, k.tau)
        return p
    # a 10 mH winding losing 0.5-3 mH (5-30 %) where the back iron leaves it, over a fringe of 5-15 mm (the gap's
    # order): 0.2-2 N at the moves' 3-4 A
    p.update(dL_p=_u(rng, 5e-4, 3e-3), dL_n=_u(rng, 5e-4, 3e-3), w=_u(rng, 5e-3, 1.5e-2))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "leakage_knee":  # knee at 8-16 A (at or above the 8 A limit), sharpness 2-4: 0-6 % of the currents'
        # field lost at the hover's 2-4 A, 3-30 % at the limit (a knee at 5 A took the stage to its lower stop: the
        # levitation current at 12 mm could no longer hold it)
        return {"family": fam, "i_k": _u(rng, 8.0, 16.0), "p": _u(rng, 2.0, 4.0), "target": "current"}
    # the iron's magnetic voltage 5-20 % of the gap's at the lower stop (10-30 % of the pull lost there, a few % in
    # the gap band, as the earlier sets), growing as B^2-B^4
    return {"family": fam, "k_lo": _u(rng, 0.05, 0.2), "n": _u(rng, 2.0, 4.0), "target": "both"}


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "feedforward":  # loops of 150-600 Hz; the model's inductance 70-130 % of the winding's (its saturation
        # and tolerance); the feedforward's derivative filter at 1-4 kHz (below the PWM frequency)
        return {
            "family": fam,
            "bandwidth_hz": _log(rng, 150.0, 600.0),
            "alpha": _u(rng, 0.7, 1.3),
            "ff_hz": _log(rng, 1000.0, 4000.0),
            "delay_samples": _u(rng, 0.0, 1.5),
        }
    # an analog proportional loop of 300-1000 Hz on 5-20 mH (Kp + R 10-125 ohm), R 2-8 % of Kp; back-EMF constants
    # from the force constants at the reference gap (reciprocity), 60-100 %, as v3's pi_backemf
    sh = shape(k.g_cog_ref)
    kx, kg = NOMINAL.Mh * NOMINAL.C1 * float(sh.f1), NOMINAL.Mv * NOMINAL.C3 * float(sh.f3)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 300.0, 1000.0),
        "rho": _u(rng, 0.02, 0.08),
        "L": _log(rng, 5e-3, 2e-2),
        "ke_q": kx * _u(rng, 0.6, 1.0),
        "ke_d": kg * _u(rng, 0.6, 1.0),
        "delay_samples": _u(rng, 0.0, 1.5),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "tape_defect":  # magnetic tapes of 0.8-1.6 mm pole pitch (0.044-0.088 rad per missed pole), one or two
        # damaged patches within the moves' +-40 mm, 0.1-0.5 mm wide
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.03),
            "p_t": _u(rng, 8e-4, 1.6e-3),
            "x_1": _u(rng, -0.04, 0.04),
            "m_1": float(rng.choice([-1.0, 1.0])),
            "x_2": _u(rng, -0.04, 0.04),
            "m_2": float(rng.choice([-1.0, 0.0, 1.0])),
            "w": _u(rng, 1e-4, 5e-4),
        }
    # uncalibrated sin/cos sensor: offsets and gain mismatch 0-3 % of the amplitude, quadrature 0-30 mrad
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.03),
        "p": _pm(rng, 0.0, 0.03),
        "q": _pm(rng, 0.0, 0.03),
        "r": _pm(rng, 0.0, 0.03),
        "alpha": _pm(rng, 0.0, 0.03),
        "theta0": _u(rng, -math.pi, math.pi),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "damper_bars":  # copper / aluminium wedges: 8-30 N s/m under the whole array at 15 mm (the earlier
        # sets' plates at 10 mm: 20-80); the bars anywhere against the array
        return {"family": fam, "c0": _u(rng, 8.0, 30.0), "x0": _u(rng, 0.0, k.t1)}
    # groups of two half-windings: a phase's force constant ~10-15 N/A at 15 mm over a circulating loop of 10-40 ohm
    # gives 4-20 N s/m for a completely unequal cover (1-5 N s/m at the stroke's ends); the split within +-40 mm
    return {"family": fam, "c0": _u(rng, 4.0, 20.0), "x_m": _u(rng, -0.04, 0.04), "x_a": _u(rng, 0.0, 2 * k.tau)}


def _payload_swap(rng):
    # a sample holder / tool of 80-300 g (2-7 % of the vertical moving mass, 5-19 % of the horizontal), on in
    # every other run
    return {"family": "alternate_runs", "m_p": _u(rng, 0.08, 0.3), "first": float(rng.choice([0.0, 1.0]))}


def _flexible_payload(rng):
    # 50-200 g on a bracket or a flexure with modes at 20-60 Hz (gap) and 15-50 Hz (along d), inside the position
    # loop's bandwidth region, lightly damped (1-5 %, bolted steel / aluminium)
    return {
        "family": "tool_mount",
        "m_p": _u(rng, 0.05, 0.2),
        "f_g": _u(rng, 20.0, 60.0),
        "f_d": _u(rng, 15.0, 50.0),
        "zeta": _u(rng, 0.01, 0.05),
    }


#: Random parameters of the seventh set, by effect name.
V7_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "payload_swap": _payload_swap,
    "flexible_payload": _flexible_payload,
}


def draw_v7(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v7 scenario of ``kind`` with ``n`` library effects, from the seed's seventh stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 7]))
    return draw_effects(rng, kind, n, V7_LIBRARY, V7_OUT_OF_LIBRARY, V7_DRAWS, EFFECTS_V7, True)


__all__ = ["V7_DRAWS", "draw_v7"]
