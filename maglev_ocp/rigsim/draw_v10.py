"""Random parameters of the tenth law set (:mod:`.laws_v10`, ``rigsim.draw(..., laws="v10")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v10` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 10])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v10 import EFFECTS_V10, V10_LAWS, V10_LIBRARY, V10_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V10_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    if fam == "saturable_bridge":  # peak 0.7-1.8 N at 12 mm (1.5-3 N replacing seed eq. (9)): closed slots cog less
        # than open ones, and this law falls more slowly with the gap than an exponential one (2-5 N at 10 mm of an
        # exponential law is 1-2.6 N at 12 mm); bridges half open at 0.5-1.1 times the field at 15 mm, their opening's
        # sharpness n 1.5-2.5 (1.5-3 times the 12 mm peak at the lower stop). First b_b 0.75-1.3 with n 2.5-4 and
        # 1.5-4 N at 15 mm: 1583 N at the lower stop in a trial (the cogging nearly vanished at 15 mm and grew
        # 50-fold towards the stop); then 1.5-4 N at 12 mm: a tracking RMS of 183 µm along d; then 1-2.5 N (2-3.5 N
        # replacing): 163-173 µm in the trial triples
        p.update(xi0=_u(rng, 1.5, 3.0) if replace else _u(rng, 0.7, 1.8), b_b=_u(rng, 0.5, 1.1), n=_u(rng, 1.5, 2.5))
        return p
    # harmonics summing to 2-5 N at 10 mm (3-6 N replacing), as the earlier sets; a second harmonic +-0-30 %; the
    # back iron saturating at 1.1-1.5 times the flux of the lower stop, its reluctance 5-30 % of the gap's at low flux
    p.update(xi0=_u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0), c2=_pm(rng, 0.0, 0.3))
    p.update(phi2=_u(rng, -math.pi, math.pi), b_s=_u(rng, 1.1, 1.5), r_i=_u(rng, 0.05, 0.3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "spring_guide":  # 0.1-0.3 N at 15 mm (the earlier sets' Coulomb range); the spring's load 40-90 % more
        # per 10 mm of closing (0.1-0.6 times at 25 mm, 1.1-1.3 times at 12 mm); viscous 0-2 N s/m
        p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.3), "Fc_d": _u(rng, 0.1, 0.3), "kappa": _u(rng, 40.0, 90.0)}
        p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0), v_reg=1e-3)
        return p
    # a small Coulomb part 0.05-0.2 N; the cold oil film 2-6 N s/m (0.6-2.4 N at the moves' 0.1-0.4 m/s), its
    # viscosity down to 30-60 % when warm (beta dT 0.5-1.2: a mineral oil's 2-4 %/K over ~30 K) with a thermal time
    # constant of 15-60 s (the dataset's 60 s of runs)
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.05, 0.2),
        "Fc_d": _u(rng, 0.05, 0.2),
        "b_g": _u(rng, 2.0, 6.0),
        "b_d": _u(rng, 2.0, 6.0),
        "s": _u(rng, 0.5, 1.2),
        "tau_th": _u(rng, 15.0, 60.0),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 15-35 mm past the array's ends at d = 0: the moves (+-45 mm) overhang them by up to ~30 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.015, 0.035), "e_n": _u(rng, 0.015, 0.035)}
    if fam == "plate_lag":  # clamping plates 8-20 mm long, their flux's time constant 10-40 ms (solid steel a few
        # mm thick: mu sigma t^2 / pi^2)
        p.update(l_p=_u(rng, 0.008, 0.02), tau_e=_u(rng, 0.01, 0.04))
        return p
    # the end teeth 50-100 % of the end's length past the array (none under the array at d = 0)
    p["f_t"] = _u(rng, 0.5, 1.0)
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    # the iron loses 8-20 % of the field at the lower stop, falling as b^2-3 (3-10 % at 12 mm), as v9's ranges
    p: Spec = {"family": fam, "l_lo": _u(rng, 0.08, 0.2), "n": _u(rng, 2.0, 3.0), "target": "both"}
    if fam == "flux_play":  # a play of 2-6 % of the lower stop's flux (the gap band's flux spans ~30-75 %)
        p["w"] = _u(rng, 0.02, 0.06)
        return p
    p["tau_s"] = _u(rng, 0.015, 0.06)  # a solid yoke's flux time constant 15-60 ms
    return p


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "papoulis3":  # -3 dB at 350-800 Hz (the earlier sets' bandwidths), 0-1 sample of transport delay:
        # group delay 0.45-2.05 ms in all (250-800 Hz reached 2.47 ms in 4000 draws: narrowed)
        return {"family": fam, "f_c": _log(rng, 350.0, 800.0), "delay_samples": _u(rng, 0.0, 1.0)}
    # loops of 300-800 Hz (a predictor allows a faster loop), PWM of 8-20 kHz (delay 1.5 carrier periods), the
    # model's delay 30-70 % short or 30-100 % long; 0-1 sample of transport delay
    m = -_u(rng, 0.3, 0.7) if rng.uniform() < 0.5 else _u(rng, 0.3, 1.0)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 300.0, 800.0),
        "T": 1.5 / _u(rng, 8e3, 2e4),
        "m": m,
        "delay_samples": _u(rng, 0.0, 1.0),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "ground_bounce":  # 0.4-1.2 % of the Hall signals' amplitude per ampere on each channel (1-5 % at the
        # hover currents of 1.5-4.5 A), each sign at random; the sensors' electrical zero anywhere (0.5-2 % gave 6.8 N
        # of thrust error in a trial triple: narrowed)
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "r_s": _pm(rng, 0.004, 0.012),
            "r_c": _pm(rng, 0.004, 0.012),
            "theta0": _u(rng, -math.pi, math.pi),
        }
    # one magnet 5-15 % weaker (an irreversible loss of a hot or knocked magnet); the board within +-30 mm, its
    # sensors 2-6 mm behind the stator's surface
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.02),
        "j_w": float(rng.integers(0, k.pm)),
        "eps": _u(rng, 0.05, 0.15),
        "x_h": _u(rng, -0.03, 0.03),
        "c_s": _u(rng, 2e-3, 6e-3),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "delta_circulating":  # a mean 0.5-2 N s/m at 15 mm (a third-harmonic back-EMF ~10 % of the
        # fundamental's ~9.5 V s/m over a loop of 6-15 ohm), its ripple anywhere
        return {"family": fam, "c0": _u(rng, 0.5, 2.0), "x0": _u(rng, 0.0, k.tau / 3.0)}
    # 3-10 N s/m at 15 mm cold (copper 0.3-1 mm thick under the array); a winding of 2-5 ohm per phase, 1-3 K per
    # watt, 20-60 s to warm
    return {
        "family": fam,
        "c0": _u(rng, 3.0, 10.0),
        "R_c": _u(rng, 2.0, 5.0),
        "dT_w": _u(rng, 1.0, 3.0),
        "tau_th": _u(rng, 20.0, 60.0),
        "alpha": 0.0039,
    }


def _deadtime(rng):
    # a residual current error of 20-80 mA per phase (0.5-1 V of dead-time voltage over a loop gain of 10-40 ohm),
    # clamping over 50-200 mA around each zero crossing; the phases' zero anywhere
    return {
        "family": "clamped_phases",
        "I_dt": _u(rng, 0.02, 0.08),
        "i_w": _u(rng, 0.05, 0.2),
        "theta0": _u(rng, -math.pi, math.pi),
    }


def _pitch(rng):
    # 2-8 µm of gap reading per newton of thrust (a probe 30-60 mm off the pitch axis, the thrust 10-30 mm from the
    # centre of mass, a guide of 100-300 N m/rad), the pitch mode at 15-40 Hz, damped 3-15 %
    a_s = _u(rng, 2e-6, 8e-6)
    return {"family": "thrust_moment", "a_s": a_s, "f_p": _u(rng, 15.0, 40.0), "zeta": _u(rng, 0.03, 0.15)}


#: Random parameters of the tenth set, by effect name.
V10_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "inverter_deadtime": _deadtime,
    "mover_pitch": _pitch,
}


def draw_v10(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v10 scenario of ``kind`` with ``n`` library effects, from the seed's tenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 10]))
    return draw_effects(rng, kind, n, V10_LIBRARY, V10_OUT_OF_LIBRARY, V10_DRAWS, EFFECTS_V10, True)


__all__ = ["V10_DRAWS", "draw_v10"]
