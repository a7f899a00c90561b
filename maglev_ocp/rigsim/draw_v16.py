"""Random parameters of the sixteenth law set (:mod:`.laws_v16`, ``rigsim.draw(..., laws="v16")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v16` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 16])``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v16 import EFFECTS_V16, V16_LAWS, V16_LIBRARY, V16_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V16_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    if fam == "bread_loaf":  # a fundamental of 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets;
        # edges shaped over 2-8 mm of the 19 mm slot pitch
        replace = bool(rng.uniform() < 0.5)
        return {
            "family": fam,
            "replace": float(replace),
            "x0": _u(rng, 0.0, k.t1),
            "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0),
            "w_c": _u(rng, 0.002, 0.008),
        }
    # a remanent detent of 0.2-0.6 N at 15 mm (beside seed eq. (9)), its poles anywhere within a pole pair
    return {"family": fam, "replace": 0.0, "xi_r": _u(rng, 0.2, 0.6), "x_r": _u(rng, -k.tau, k.tau)}


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "lip_wiper":  # the earlier sets' Coulomb and viscous ranges (lower Coulomb: the lip adds its own);
        # a lip of 40-120 N/m touching below 16.5-20 mm (1.5-5 mm compressed at the hover gap), mu 0.3-0.8
        return {
            "family": fam,
            "Fc_g": _u(rng, 0.05, 0.15),
            "Fc_d": _u(rng, 0.05, 0.15),
            "b_g": _u(rng, 0.0, 1.5),
            "b_d": _u(rng, 0.0, 1.5),
            "k_w": _u(rng, 40.0, 120.0),
            "mu_w": _u(rng, 0.3, 0.8),
            "h_w": _u(rng, 0.0165, 0.02),
            "v_reg": 1e-3,
        }
    # the earlier sets' ranges; the preload 30-80 % up or down at the bow's crest, over 80-150 mm, the crest within
    # +-20 mm of the middle
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.1, 0.25),
        "b_g": _u(rng, 0.0, 1.5),
        "b_d": _u(rng, 0.0, 1.5),
        "kappa": _pm(rng, 0.3, 0.8),
        "x_b": _u(rng, -0.02, 0.02),
        "l_b": _u(rng, 0.08, 0.15),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    if fam == "weak_end_poles":  # stator ends 10-30 mm past the array's at d = 0 (the moves overhang them), the end
        # poles 20-50 % weaker at the very end
        return {"family": fam, "e_p": _u(rng, 0.01, 0.03), "e_n": _u(rng, 0.01, 0.03), "lam": _u(rng, 0.2, 0.5)}
    # 0.2-0.8 N at +-45 mm, the frames 20-30 mm past the array's ends there (5-15 mm at the stops), the end
    # magnet's size 15-25 mm
    return {"family": fam, "F_e": _u(rng, 0.2, 0.8), "a45": _u(rng, 0.02, 0.03), "c": _u(rng, 0.015, 0.025)}


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "fischer_moser":  # 3-7 % of the field lost at the lower stop, the iron's power 4-10
        return {"family": fam, "l_lo": _u(rng, 0.03, 0.07), "n": _u(rng, 4.0, 10.0), "target": "both"}
    # 3-7 % lost at the lower stop; the iron saturating at 1.1-2 times the lower stop's flux
    return {"family": fam, "l_lo": _u(rng, 0.03, 0.07), "u_s": _u(rng, 1.1, 2.0), "target": "both"}


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "cauer3":  # pass band to 300-1000 Hz, 0.1-1 dB ripple, 25-50 dB down; 0-1 sample of transport delay
        return {
            "family": fam,
            "f_p": _log(rng, 300.0, 1000.0),
            "r_p": _u(rng, 0.1, 1.0),
            "r_s": _u(rng, 25.0, 50.0),
            "delay_samples": _u(rng, 0.0, 1.0),
        }
    # R C 40-200 µs: group delay 0.24-1.2 ms; 0-1 sample of transport delay
    return {"family": fam, "rc": _log(rng, 4e-5, 2e-4), "delay_samples": _u(rng, 0.0, 1.0)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "pole_strength_hall":  # north and south magnets 4-12 % apart either way (two grades; lowered after the
        # trials from 5-15 %: 6.1 N at m_a = 0.116), heads within +-30 mm of the middle
        return {"family": fam, "delta0": _pm(rng, 0.0, 0.02), "m_a": _pm(rng, 0.04, 0.12), "x_h": _u(rng, -0.03, 0.03)}
    # a copper or aluminium plate of a few mm: tau_s 1.5-5 ms (0.05-0.15 rad at 0.5 m/s)
    return {"family": fam, "delta0": _pm(rng, 0.0, 0.02), "tau_s": _u(rng, 1.5e-3, 5e-3)}


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "slot_wedges":  # 2-8 N s/m along d at 15 mm (the earlier sets' sheets), stator ends 10-35 mm past the
        # array's, blurred over 3-8 mm
        return {
            "family": fam,
            "c_w": _u(rng, 2.0, 8.0),
            "e_p": _u(rng, 0.01, 0.035),
            "e_n": _u(rng, 0.01, 0.035),
            "l_e": _u(rng, 0.003, 0.008),
        }
    # 3-10 N s/m at 15 mm, tubes 5-15 mm under the face, 30-70 mm apart
    p_t = _u(rng, 0.03, 0.07)
    return {
        "family": fam,
        "c_t": _u(rng, 3.0, 10.0),
        "h_t": _u(rng, 0.005, 0.015),
        "p_t": p_t,
        "x_t": _u(rng, 0.0, p_t),
    }


def _debris(rng):
    # a chip pulled with 0.3-1.2 N at 15 mm, 70-150 mm either side of the middle (an array's end passes it within
    # the moves), the footprint's edge 3-8 mm
    return {"family": "steel_chip", "F_c": _u(rng, 0.3, 1.2), "x_c": _pm(rng, 0.07, 0.15), "l_c": _u(rng, 0.003, 0.008)}


def _joint(rng):
    # sections off by 20-60 µm either way, the joint 5-35 mm either side of the middle, a 0.5-2 mm reading window
    return {
        "family": "butt_joint",
        "s_j": _pm(rng, 2e-5, 6e-5),
        "x_j": _pm(rng, 0.005, 0.035),
        "w_h": _u(rng, 5e-4, 2e-3),
    }


#: Random parameters of the sixteenth set, by effect name.
V16_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "ferrous_debris": _debris,
    "scale_joint": _joint,
}


def draw_v16(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v16 scenario of ``kind`` with ``n`` library effects, from the seed's sixteenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 16]))
    return draw_effects(rng, kind, n, V16_LIBRARY, V16_OUT_OF_LIBRARY, V16_DRAWS, EFFECTS_V16, True)


__all__ = ["V16_DRAWS", "draw_v16"]
