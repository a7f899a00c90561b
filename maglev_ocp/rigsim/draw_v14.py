"""Random parameters of the fourteenth law set (:mod:`.laws_v14`, ``rigsim.draw(..., laws="v14")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v14` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 14])``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v14 import EFFECTS_V14, V14_LAWS, V14_LIBRARY, V14_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V14_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # a fundamental of 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    p["xi0"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)
    if fam == "offset_openings":  # a second harmonic of 20-60 % of the first, shifted by 0.3-2.8 rad either way
        p.update(a2=_u(rng, 0.2, 0.6), phi2=_pm(rng, 0.3, 2.8))
        return p
    # two stacks out of step by 0.6-2 rad (0.2-0.6 mm of a 19 mm slot pitch), joined within +-30 mm of the middle
    p.update(psi=_pm(rng, 0.6, 2.0), x_j=_u(rng, -0.03, 0.03))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "eyring_grease":  # Coulomb 0.05-0.15 N, the grease's stress 0.03-0.08 N per decade-ish, v_e 1-5 mm/s
        return {
            "family": fam,
            "Fc_g": _u(rng, 0.05, 0.15),
            "Fc_d": _u(rng, 0.05, 0.15),
            "Fe_g": _u(rng, 0.03, 0.08),
            "Fe_d": _u(rng, 0.03, 0.08),
            "v_e": _log(rng, 1e-3, 5e-3),
            "v_reg": 1e-3,
        }
    # the earlier sets' Coulomb and viscous ranges; the run-in track 30-60 % smoother over 10-25 mm round the middle
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.1, 0.25),
        "b_g": _u(rng, 0.0, 1.5),
        "b_d": _u(rng, 0.0, 1.5),
        "w": _u(rng, 0.3, 0.6),
        "x_w": _u(rng, -0.015, 0.015),
        "s_w": _u(rng, 0.01, 0.025),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 20-35 mm past the array's ends at d = 0: the moves (+-45 mm) overhang them by up to ~25 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.02, 0.035), "e_n": _u(rng, 0.02, 0.035)}
    if fam == "stepped_ends":  # half the stack ending 4-12 mm earlier
        p["s"] = _u(rng, 0.004, 0.012)
        return p
    # the last 5-12 mm of each stack splayed, its stacking factor down by 20-50 % at the end face
    p.update(z=_u(rng, 0.005, 0.012), s_f=_u(rng, 0.2, 0.5))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    # (lowered after the trials from 8-20 % and 4-10 %: 8.5 and 6.3 N on the gap)
    if fam == "grain_oriented":  # 3-7 % of the pull lost at the lower stop, as b^2-3; the coupling 30-70 % of that
        return {
            "family": fam,
            "l_lo": _u(rng, 0.03, 0.07),
            "n": _u(rng, 2.0, 3.0),
            "r_c": _u(rng, 0.3, 0.7),
            "target": "both",
        }
    # the bulk 2.5-6 % at the lower stop (lowered after the trials from 6-15 % and 3-8 %: 6.5 and 4.2 N on the gap);
    # the damaged bands 1-3 % more, saturating by a flux of 0.2-0.5 of the stop's
    return {
        "family": fam,
        "l_lo": _u(rng, 0.025, 0.06),
        "n": _u(rng, 2.0, 3.0),
        "l_e": _u(rng, 0.01, 0.03),
        "x_e": _u(rng, 0.2, 0.5),
        "target": "both",
    }


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "inverse_chebyshev3":  # stopband edges 0.8-2.5 kHz, 20-40 dB down; 0-1 sample of transport delay
        return {
            "family": fam,
            "f_s": _log(rng, 800.0, 2500.0),
            "a_s": _u(rng, 20.0, 40.0),
            "delay_samples": _u(rng, 0.0, 1.0),
        }
    # three lags at 500-1500 Hz: group delay 0.32-0.95 ms; 0-1 sample of transport delay
    return {"family": fam, "f_c": _log(rng, 500.0, 1500.0), "delay_samples": _u(rng, 0.0, 1.0)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "slot_ripple_hall":  # 0.015-0.04 rad of slot ripple at 15 mm (0.1 at 12 mm, 0.4 at the lower stop)
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "a_s": _u(rng, 0.015, 0.04),
            "x_s": _u(rng, 0.0, k.t1),
        }
    # a third harmonic of 1-3 % of the fundamental at 15 mm seen by the heads (lowered after the trials from 2-6 %:
    # 5.4 N and a tracking RMS of 177 µm along d)
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.02),
        "h3": _u(rng, 0.01, 0.03),
        "x_h": _u(rng, 0.0, 2 * k.tau),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "segmented_plate":  # 2-6 N s/m at 15 mm, cut by 30-80 % over slits every 20-40 mm
        ps = _u(rng, 0.02, 0.04)
        return {"family": fam, "c0": _u(rng, 2.0, 6.0), "r": _u(rng, 0.3, 0.8), "p_s": ps, "x_s": _u(rng, 0.0, ps)}
    # a ring 10-35 mm past each array end at d = 0, 3-10 N s/m while an end passes, over 5-12 mm
    return {"family": fam, "c0": _u(rng, 3.0, 10.0), "x_r": _u(rng, 0.01, 0.035), "w_r": _u(rng, 0.005, 0.012)}


def _bellows(rng):
    # 0.4-1.2 N of offload at 15 mm (1-3 % of the mover's weight), a bellows 20-40 mm high, isothermal to adiabatic
    return {"family": "sealed_air_spring", "F0": _u(rng, 0.4, 1.2), "h0": _u(rng, 0.02, 0.04), "n": _u(rng, 1.0, 1.4)}


def _latency(rng):
    # a serial encoder's latency of 0.15-0.8 ms (EnDat / BiSS transmission plus the drive's forwarding)
    return {"family": "serial_protocol", "tau_l": _log(rng, 1.5e-4, 8e-4)}


#: Random parameters of the fourteenth set, by effect name.
V14_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "bellows_offload": _bellows,
    "encoder_latency": _latency,
}


def draw_v14(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v14 scenario of ``kind`` with ``n`` library effects, from the seed's fourteenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 14]))
    return draw_effects(rng, kind, n, V14_LIBRARY, V14_OUT_OF_LIBRARY, V14_DRAWS, EFFECTS_V14, True)


__all__ = ["V14_DRAWS", "draw_v14"]
