"""Random parameters of the twelfth law set (:mod:`.laws_v12`, ``rigsim.draw(..., laws="v12")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v12` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 12])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v12 import EFFECTS_V12, V12_LAWS, V12_LIBRARY, V12_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V12_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # harmonics summing to 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets; a second harmonic
    # +-0-30 %
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    p["xi0"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)
    p.update(c2=_pm(rng, 0.0, 0.3), phi2=_u(rng, -math.pi, math.pi))
    if fam == "warm_magnets":  # NdFeB's -0.09 ... -0.12 %/K; the magnets across the gap 0.1-0.4 K per watt of copper
        # loss (a winding of 2-5 ohm per phase), 20-60 s to warm
        p.update(
            alpha_B=_u(rng, 9e-4, 1.2e-3), R_c=_u(rng, 2.0, 5.0), dT_w=_u(rng, 0.1, 0.4), tau_th=_u(rng, 20.0, 60.0)
        )
        return p
    # tooth tips bending 30-100 µm towards the array at 15 mm (thin tips over 12.7 mm openings)
    p["delta_t"] = _u(rng, 3e-5, 1e-4)
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "debris_spots":  # the earlier sets' Coulomb and viscous ranges; three spots anywhere in +-40 mm, each
        # raising the level 1.5-4 times over 1-4 mm
        p: Spec = {
            "family": fam,
            "Fc_g": _u(rng, 0.1, 0.25),
            "Fc_d": _u(rng, 0.1, 0.25),
            "b_g": _u(rng, 0.0, 1.5),
            "b_d": _u(rng, 0.0, 1.5),
        }
        for j in (1, 2, 3):
            p.update({f"a_{j}": _u(rng, 0.5, 3.0), f"x_{j}": _u(rng, -0.04, 0.04), f"w_{j}": _u(rng, 1e-3, 4e-3)})
        p["v_reg"] = 1e-3
        return p
    # the level 0.1-0.25 N reached over a presliding distance of 10-60 µm (ball guides: a few to tens of µm)
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.1, 0.25),
        "b_g": _u(rng, 0.3, 1.5),
        "b_d": _u(rng, 0.3, 1.5),
        "x_max": _u(rng, 1e-5, 6e-5),
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 15-35 mm past the array's ends at d = 0: the moves (+-45 mm) overhang them by up to ~30 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.015, 0.035), "e_n": _u(rng, 0.015, 0.035)}
    if fam == "half_filled_slots":  # one half-filled slot per end (a coil pitch of two slots), the ends 25-40 mm past
        # the array's (first 1-3 slots, then 1-2 slots, with the ends at 15-35 mm: 12.9 N on the gap in a trial)
        p.update(e_p=0.025 + 0.75 * (p["e_p"] - 0.015), e_n=0.025 + 0.75 * (p["e_n"] - 0.015), n_h=1.0)
        return p
    # the last 10-30 mm tapered to 60-85 % of the depth, a fringe of 0.4-1 gap past each side face (first 40-80 %:
    # 6.3 N on the gap in a trial)
    p.update(l_t=_u(rng, 0.01, 0.03), r_t=_u(rng, 0.15, 0.4), c_f=_u(rng, 0.4, 1.0))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    # the iron loses 8-20 % of the field at the lower stop, falling as b^2-3, as v9's ... v11's (disaccommodation:
    # 6-15 % at its start, as it loses more later)
    lo = _u(rng, 0.08, 0.2)
    p: Spec = {"family": fam, "l_lo": lo, "n": _u(rng, 2.0, 3.0), "target": "both"}
    if fam == "disaccommodation":  # 1-3 % per e-fold of time after 0.3-3 s (soft iron's aftereffect)
        p.update(l_lo=0.06 + (lo - 0.08) * 0.75, D=_u(rng, 0.01, 0.03), t0=_log(rng, 0.3, 3.0))
        return p
    p["rho"] = _u(rng, 0.2, 0.5)  # Rayleigh's quadratic share at the lower stop's flux
    return p


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "setpoint_weight":  # loops of 300-800 Hz on a winding of R/L 150-400 /s, weight 0.88-0.97 (group delay
        # 0.2-1.3 ms), 0-1 sample of transport delay
        return {
            "family": fam,
            "bandwidth_hz": _log(rng, 300.0, 800.0),
            "a_r": _u(rng, 150.0, 400.0),
            "b": _u(rng, 0.88, 0.97),
            "delay_samples": _u(rng, 0.0, 1.0),
        }
    # an equivalent time constant of 0.3-1.2 ms (the group delay), 0-1 sample of transport delay
    return {"family": fam, "tau_e": _log(rng, 3e-4, 1.2e-3), "delay_samples": _u(rng, 0.0, 1.0)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "pole_pitch_mismatch":  # the pitch 0.5-1.5 % off, phase found within +-20 mm of the middle
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "eps": _pm(rng, 0.005, 0.015),
            "d_h": _u(rng, -0.02, 0.02),
        }
    # a filter corner of 0.2-0.8 rad/s (1-3 % of the electrical speed at 0.5 m/s); the estimator takes over from the
    # Halls between 0.08-0.15 m/s and 0.1-0.2 m/s above
    v_lo = _u(rng, 0.08, 0.15)
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.02),
        "w_c": _u(rng, 0.2, 0.8),
        "v_lo": v_lo,
        "v_hi": v_lo + _u(rng, 0.1, 0.2),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "interturn_short":  # 1-5 N s/m at 15 mm (a few shorted turns of tens of milliohm), the coil within
        # +-30 mm of the middle
        return {"family": fam, "c0": _u(rng, 1.0, 5.0), "x_s": _u(rng, -0.03, 0.03)}
    # 2-6 N s/m at d = 0 and 15 mm, a slope of 0.05-0.15 either way (the drag 1.6-4.4 times larger at one end than
    # at the other over +-45 mm)
    return {"family": fam, "c0": _u(rng, 2.0, 6.0), "s_t": _pm(rng, 0.05, 0.15)}


def _hum(rng):
    # 4-15 µm of hum on the gap reading (a few mV on a probe of 2 mm/V), 50 or 60 Hz mains, a third harmonic of 0-50 %
    return {
        "family": "ground_loop",
        "a_g": _u(rng, 4e-6, 1.5e-5),
        "f_m": float(rng.choice([50.0, 60.0])),
        "phi": _u(rng, -math.pi, math.pi),
        "h3": _u(rng, 0.0, 0.5),
        "phi3": _u(rng, -math.pi, math.pi),
    }


def _bumpers(rng):
    # contact at 40-44 mm from the middle (the longest moves reach ~45-47 mm), 0.4-0.8 N at 2 mm and under 50 N
    # pressed to the hard stop at 60 mm (a soft foam pad; first 1.2-5.5e4 N/m^1.5: 60 N at the stop; then 5-13e3 N/m^1.5
    # and contact from 39 mm: 6.4 N in a trial), Hunt-Crossley damping 0.1-0.4 s/m
    return {
        "family": "hunt_crossley",
        "x_p": _u(rng, 0.04, 0.044),
        "x_n": _u(rng, 0.04, 0.044),
        "k_b": _u(rng, 4e3, 9e3),
        "alpha": _u(rng, 0.1, 0.4),
    }


#: Random parameters of the twelfth set, by effect name.
V12_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "mains_hum": _hum,
    "end_bumpers": _bumpers,
}


def draw_v12(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v12 scenario of ``kind`` with ``n`` library effects, from the seed's twelfth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 12]))
    return draw_effects(rng, kind, n, V12_LIBRARY, V12_OUT_OF_LIBRARY, V12_DRAWS, EFFECTS_V12, True)


__all__ = ["V12_DRAWS", "draw_v12"]
