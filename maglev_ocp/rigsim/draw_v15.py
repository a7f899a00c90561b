"""Random parameters of the fifteenth law set (:mod:`.laws_v15`, ``rigsim.draw(..., laws="v15")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v15` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 15])``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v15 import EFFECTS_V15, V15_LAWS, V15_LIBRARY, V15_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V15_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    if fam == "arc_ratio":  # a fundamental of 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets;
        # the magnets' width 0.3-0.7 slot pitches past a whole number of them
        p["xi0"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)
        p["beta"] = _u(rng, 0.3, 0.7)
        return p
    # 0.8-2 N at 10 mm (1.2-2.5 N replacing): this law falls more slowly with the gap (0.55 of it at 15 mm against
    # the slot harmonic's 0.19), so about the earlier sets' 0.4-1 N at the hover gap; slot openings of 3-8 mm
    p["xi0"] = _u(rng, 1.2, 2.5) if replace else _u(rng, 0.8, 2.0)
    p["b0"] = _u(rng, 0.003, 0.008)
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "cage_creep":  # the earlier sets' Coulomb and viscous ranges; sliding 50-150 % more beyond the cage's
        # free +-15-35 mm round a centre within +-10 mm, over 2-6 mm
        return {
            "family": fam,
            "Fc_g": _u(rng, 0.1, 0.25),
            "Fc_d": _u(rng, 0.1, 0.25),
            "b_g": _u(rng, 0.0, 1.5),
            "b_d": _u(rng, 0.0, 1.5),
            "k_s": _u(rng, 0.5, 1.5),
            "x_c": _u(rng, -0.01, 0.01),
            "x_s": _u(rng, 0.015, 0.035),
            "w_s": _u(rng, 0.002, 0.006),
            "v_reg": 1e-3,
        }
    # Coulomb 0.05-0.15 N; the rollers' loss 0.05-0.15 N at its peak speed 3-30 mm/s
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.05, 0.15),
        "Fc_d": _u(rng, 0.05, 0.15),
        "Fh_g": _u(rng, 0.05, 0.15),
        "Fh_d": _u(rng, 0.05, 0.15),
        "v_h": _log(rng, 3e-3, 3e-2),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    if fam == "ragged_ends":  # stator ends 20-35 mm past the array's at d = 0 (the moves overhang them by up to
        # ~25 mm), the laminations' ends scattered by 2-8 mm
        return {"family": fam, "e_p": _u(rng, 0.02, 0.035), "e_n": _u(rng, 0.02, 0.035), "s_r": _u(rng, 0.002, 0.008)}
    # stator ends 10-35 mm past the array's (each bracket crosses one within the moves), brackets 6-15 mm long
    # pulled with 0.4-1.2 N each at 15 mm
    return {
        "family": fam,
        "e_p": _u(rng, 0.01, 0.035),
        "e_n": _u(rng, 0.01, 0.035),
        "l_b": _u(rng, 0.006, 0.015),
        "F_b": _u(rng, 0.4, 1.2),
    }


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "spread_knees":  # 3-7 % of the field lost at the lower stop, the knees at 0.5-0.85 of its flux, spread
        # by 0.08-0.25
        return {
            "family": fam,
            "l_lo": _u(rng, 0.03, 0.07),
            "x_k": _u(rng, 0.5, 0.85),
            "w": _u(rng, 0.08, 0.25),
            "target": "both",
        }
    # 3-7 % lost at the lower stop; Marrocco's exponent 2a 2-5 (lowered after the trials from 3-8: 0.4 N on the gap,
    # the loss all near the lower stop), t 0.3-3
    return {
        "family": fam,
        "l_lo": _u(rng, 0.03, 0.07),
        "a": _u(rng, 1.0, 2.5),
        "t": _log(rng, 0.3, 3.0),
        "target": "both",
    }


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "gaussian3":  # scale 250-900 Hz: group delay 0.35-1.26 ms; 0-1 sample of transport delay
        return {"family": fam, "f_g": _log(rng, 250.0, 900.0), "delay_samples": _u(rng, 0.0, 1.0)}
    # 250-1000 Hz, between Bessel-Thomson and Butterworth (m 0.2-0.8): group delay 0.2-1.2 ms; 0-1 sample of delay
    return {"family": fam, "f_c": _log(rng, 250.0, 1000.0), "m": _u(rng, 0.2, 0.8), "delay_samples": _u(rng, 0.0, 1.0)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "stator_hall_end":  # the end wave 0.15-0.4 rad at the array's end; heads 25-50 mm off the middle
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "a_e": _u(rng, 0.15, 0.4),
            "x_h": _pm(rng, 0.025, 0.05),
        }
    # magnetization directions +-0.6-2.9 degrees off (0.01-0.05 rad either way); heads within +-30 mm of the middle
    p: Spec = {"family": fam, "delta0": _pm(rng, 0.0, 0.02)}
    for j in range(4):
        p[f"eps{j}"] = _pm(rng, 0.01, 0.05)
    p["x_h"] = _u(rng, -0.03, 0.03)
    return p


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "cover_plate":  # the stator's sheet 1-4 N s/m at 15 mm; the cover 40-60 mm above the stator's face,
        # 5-20 N s/m at the array's face (0.1-0.3 of it at the hover gap)
        return {"family": fam, "c_s": _u(rng, 1.0, 4.0), "c_c": _u(rng, 5.0, 20.0), "h_c": _u(rng, 0.04, 0.06)}
    # 10-18 N s/m on the gap's motion at 15 mm (5 times that at the lower stop; the first draft's 10-40 N s/m gave
    # over 50 N at 0.5 m/s there, the envelope's bound)
    return {"family": fam, "c_g": _u(rng, 10.0, 18.0)}


def _limit_switch(rng):
    # a roller pressed with 0.5-2 N, lifted 2-5 mm over ramps 3-6 mm long and a plateau of 4-12 mm, the switch
    # 15-35 mm either side of the middle
    return {
        "family": "roller_cam",
        "F_s": _u(rng, 0.5, 2.0),
        "h_r": _u(rng, 0.002, 0.005),
        "l_r": _u(rng, 0.003, 0.006),
        "l_p": _u(rng, 0.004, 0.012),
        "x_s": _pm(rng, 0.015, 0.035),
    }


def _probe(rng):
    # 0.5-2 /m either way: 12-50 µm at 5 mm from the hover gap, 50-200 µm at 10 mm
    return {"family": "target_mismatch", "k2": _pm(rng, 0.5, 2.0), "g_c": 0.015}


#: Random parameters of the fifteenth set, by effect name.
V15_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "limit_switch": _limit_switch,
    "probe_nonlinearity": _probe,
}


def draw_v15(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v15 scenario of ``kind`` with ``n`` library effects, from the seed's fifteenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 15]))
    return draw_effects(rng, kind, n, V15_LIBRARY, V15_OUT_OF_LIBRARY, V15_DRAWS, EFFECTS_V15, True)


__all__ = ["V15_DRAWS", "draw_v15"]
