"""Random parameters of the eighteenth law set (:mod:`.laws_v18`, ``rigsim.draw(..., laws="v18")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v18` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 18])``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v18 import EFFECTS_V18, V18_LAWS, V18_LIBRARY, V18_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V18_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    # both: a peak of 2-5 N at 10 mm (3-6 N replacing seed eq. (9), half the draws), as the earlier sets
    replace = bool(rng.uniform() < 0.5)
    spec = {
        "family": fam,
        "replace": float(replace),
        "x0": _u(rng, 0.0, k.t1),
        "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0),
    }
    if fam == "recoil_circuit":  # NdFeB's and ferrite's recoil permeability 1.03-1.1
        spec["mu_r"] = _u(rng, 1.03, 1.1)
    return spec


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "oil_pad":  # the earlier sets' Coulomb ranges; the squeeze 0.2-0.8 N s/m and the shear 0.2-1.5 N s/m at
        # 15 mm (the earlier sets' viscous range), the film 4-10 mm thick at the lower stop
        return {
            "family": fam,
            "Fc_g": _u(rng, 0.1, 0.25),
            "Fc_d": _u(rng, 0.1, 0.25),
            "c_sq": _u(rng, 0.2, 0.8),
            "c_sh": _u(rng, 0.2, 1.5),
            "h_m": _u(rng, 0.004, 0.01),
            "v_reg": 1e-3,
        }
    # the earlier sets' Coulomb and viscous ranges (Coulomb along d 0.15-0.4 N at rest); halved at 0.05-0.4 m/s
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.15, 0.4),
        "b_g": _u(rng, 0.0, 1.5),
        "b_d": _u(rng, 0.0, 1.5),
        "v_T": _log(rng, 0.05, 0.4),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    if fam == "gap_fringe":  # the stator's ends 20-35 mm past the array's at d = 0, the fringe 0.3-1 gap long
        return {"family": fam, "e_p": _u(rng, 0.02, 0.035), "e_n": _u(rng, 0.02, 0.035), "c_f": _u(rng, 0.3, 1.0)}
    # ends 20-35 mm past the array's, a return reluctance of 2-6 % of the circuit's, over 5-15 mm (lowered after the
    # trials from 10-30 %: 10.6 N on the gap at 12 %)
    return {
        "family": fam,
        "e_p": _u(rng, 0.02, 0.035),
        "e_n": _u(rng, 0.02, 0.035),
        "r_e": _u(rng, 0.02, 0.06),
        "lam": _u(rng, 0.005, 0.015),
    }


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "soft_limiter":  # 3-7 % lost at the lower stop (as the seventeenth set), the knee's sharpness 1-4
        return {"family": fam, "l_lo": _u(rng, 0.03, 0.07), "p": _u(rng, 1.0, 4.0), "target": "both"}
    # 3-7 % lost at the lower stop, the molecular field 0.3-0.8 of the critical one
    return {"family": fam, "l_lo": _u(rng, 0.03, 0.07), "lam": _u(rng, 0.3, 0.8), "target": "both"}


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "cic_reference":  # the interpolator's window 50-250 µs, the loop 250-800 Hz; 0-1 sample of delay
        return {
            "family": fam,
            "T": _u(rng, 5e-5, 2.5e-4),
            "f_c": _log(rng, 250.0, 800.0),
            "delay_samples": _u(rng, 0.0, 1.0),
        }
    # the slower leg's loop 150-400 Hz, the faster 2-6 times it; 0-1 sample of delay
    f_1 = _log(rng, 150.0, 400.0)
    return {"family": fam, "f_1": f_1, "f_2": f_1 * _u(rng, 2.0, 6.0), "delay_samples": _u(rng, 0.0, 1.0)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "stationary_pi":  # loops of 40-150 Hz (0.03-0.11 rad behind at 0.5 m/s)
        return {"family": fam, "delta0": _pm(rng, 0.0, 0.02), "f_c": _u(rng, 40.0, 150.0)}
    # the arctangent's correction 0-0.2 (0.071-0.021 rad off; 0.273 the best), its zero anywhere in a pole pair
    return {"family": fam, "delta0": _pm(rng, 0.0, 0.02), "c": _u(rng, 0.0, 0.2), "x_0": _u(rng, 0.0, 2.0 * k.tau)}


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "solid_yoke":  # the solid plate's pull 5-15 N at 15 mm, its permeability 30-100, v_s 0.01-0.04 m/s
        # (steel's 5 MS/m; about 0.2-1.5 N of drag at 0.2 m/s and 15 mm)
        return {"family": fam, "F_a": _u(rng, 5.0, 15.0), "mu_r": _log(rng, 30.0, 100.0), "v_s": _log(rng, 0.01, 0.04)}
    # 4-12 N s/m above the threshold speed 0.05-0.2 m/s (at 15 mm): 1-4 N at 0.4 m/s
    return {"family": fam, "c_r": _u(rng, 4.0, 12.0), "v_th": _u(rng, 0.05, 0.2)}


def _reel(rng):
    # a reel's tension 0.3-1 N, stiffening 2-10 N/m, its outlet 150-300 mm along the stroke either side and
    # 10-60 mm below the mover's attachment
    return {
        "family": "negator",
        "T0": _u(rng, 0.3, 1.0),
        "k_s": _u(rng, 2.0, 10.0),
        "x_r": _pm(rng, 0.15, 0.3),
        "h_r": -_u(rng, 0.01, 0.06),
    }


def _scale(rng):
    # an aluminium-backed tape scale (alpha 23e-6 /K) warming by 5-13 K (alpha dT 1.2-3e-4; raised after the trials
    # from 0.5-1.5e-4 on 50-200 mm: 11 µm) over 10-60 s, clamped 100-250 mm either side of the middle (about 20-75 µm
    # read short at the stroke's far end once warm)
    return {
        "family": "warming_scale",
        "c_e": _u(rng, 1.2e-4, 3e-4),
        "tau_th": _u(rng, 10.0, 60.0),
        "x_f": _pm(rng, 0.1, 0.25),
    }


#: Random parameters of the eighteenth set, by effect name.
V18_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "spring_reel": _reel,
    "expanding_scale": _scale,
}


def draw_v18(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v18 scenario of ``kind`` with ``n`` library effects, from the seed's eighteenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 18]))
    return draw_effects(rng, kind, n, V18_LIBRARY, V18_OUT_OF_LIBRARY, V18_DRAWS, EFFECTS_V18, True)


__all__ = ["V18_DRAWS", "draw_v18"]
