"""Random parameters of the thirteenth law set (:mod:`.laws_v13`, ``rigsim.draw(..., laws="v13")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v13` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 13])``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v13 import EFFECTS_V13, V13_LAWS, V13_LIBRARY, V13_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V13_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # a fundamental of 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    p["xi0"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)
    if fam == "open_slot_series":  # slot openings of 25-60 % of the slot pitch (semi-closed to open slots)
        p["beta"] = _u(rng, 0.25, 0.6)
        return p
    # magnets graded to +-3-10 % in remanence: the pole pair's sidebands 10-30 % of the slot harmonic
    p.update(e=_u(rng, 0.1, 0.3), x_m=_u(rng, 0.0, 2 * k.tau))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    # the earlier sets' Coulomb and viscous ranges
    p: Spec = {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.1, 0.25),
        "b_g": _u(rng, 0.0, 1.5),
        "b_d": _u(rng, 0.0, 1.5),
    }
    if fam == "pull_loaded":  # 40-90 % of the horizontal guide's normal load from the magnets' pull
        p.update(kappa=_u(rng, 0.4, 0.9), v_reg=1e-3)
        return p
    # the contacts shaken at 2-10 mm/s by the PWM's ripple (µm at kHz)
    p["v_d"] = _u(rng, 2e-3, 1e-2)
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 15-35 mm past the array's ends at d = 0: the moves (+-45 mm) overhang them by up to ~30 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.015, 0.035), "e_n": _u(rng, 0.015, 0.035)}
    if fam == "delayed_entry":  # solid end plates: L/R of 5-30 ms
        p["tau_e"] = _log(rng, 5e-3, 3e-2)
        return p
    # the armature's field fringing over 0.3-1 effective gap past the end; the stator's ends 22-35 mm past the array's
    # (drawn from the same uniform draw, 0.022 + 0.65 (e - 0.015): 10.8 N on the gap in a first trial at 15-35 mm)
    p.update(e_p=0.022 + 0.65 * (p["e_p"] - 0.015), e_n=0.022 + 0.65 * (p["e_n"] - 0.015), c_a=_u(rng, 0.3, 1.0))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    # the iron loses 8-20 % of the field at the lower stop, falling as b^2-3, as v9's ... v12's
    p: Spec = {"family": fam, "l_lo": _u(rng, 0.08, 0.2), "n": _u(rng, 2.0, 3.0), "target": "both"}
    if fam == "villari_stress":  # the pull's stress shifting the knee by 20-60 % of its ratio to the lower stop's
        p["s_v"] = _u(rng, 0.2, 0.6)
        return p
    # eight relays over the gap band's flux (b 0.6-0.8 +- 0.08-0.15), switching widths 0.02-0.05, 10-30 % of the
    # magnetization irreversible
    p.update(b_c=_u(rng, 0.6, 0.8), w=_u(rng, 0.08, 0.15), h_w=_u(rng, 0.02, 0.05), h_p=_u(rng, 0.1, 0.3))
    return p


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "linkwitz_riley4":  # corners of 350-1000 Hz: group delay 0.45-1.3 ms; 0-1 sample of transport delay
        return {"family": fam, "f_c": _log(rng, 350.0, 1000.0), "delay_samples": _u(rng, 0.0, 1.0)}
    # a loop of 0.2-0.8 ms behind a PWM delay of 0.1-0.4 ms (half a period at 1.25-5 kHz plus computation)
    return {
        "family": fam,
        "tau_a": _log(rng, 2e-4, 8e-4),
        "T_d": _u(rng, 1e-4, 4e-4),
        "delay_samples": _u(rng, 0.0, 1.0),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "slanted_sensor":  # a bracket 8.5-22 degrees off the gap's normal, either way (0.08-0.22 rad at 25 mm)
        return {"family": fam, "delta0": _pm(rng, 0.0, 0.02), "tan_a": _pm(rng, 0.15, 0.4)}
    # two heads, each mounted 0.35-1.1 mm off (0.02-0.06 rad), opposite signs; the switch within +-15 mm of the
    # middle, a band of +-1-4 mm
    sa = float(rng.choice([-1.0, 1.0]))
    return {
        "family": fam,
        "delta_a": sa * _u(rng, 0.02, 0.06),
        "delta_b": -sa * _u(rng, 0.02, 0.06),
        "d_s": _u(rng, -0.015, 0.015),
        "h_s": _u(rng, 1e-3, 4e-3),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "inductive_loop":  # 2-6 N s/m along d, 0-2 on the gap, L/R 3-30 ms
        return {"family": fam, "c_d": _u(rng, 2.0, 6.0), "c_g": _u(rng, 0.0, 2.0), "tau_e": _log(rng, 3e-3, 3e-2)}
    # 1-3 N s/m at 15 mm without current; the armature's field 0.05-0.15 of the magnets' per ampere (the drag 1.2-1.7
    # times larger at the hover's 2 A of d current)
    return {"family": fam, "c0": _u(rng, 1.0, 3.0), "kappa": _u(rng, 0.05, 0.15)}


def _tilt(rng):
    # a base levelled to within 5-15 mrad along the stroke (either way), its feet giving 0.05-0.15 rad/m towards the
    # mover
    return {"family": "levelling_feet", "theta0": _pm(rng, 0.005, 0.015), "kappa": -_u(rng, 0.05, 0.15)}


def _probe(rng):
    # a demodulator corner of 60-200 Hz (industrial gap-probe conditioners set for low noise; a lag of 0.8-2.7 ms)
    return {"family": "demodulator_lpf", "f_p": _log(rng, 60.0, 200.0)}


#: Random parameters of the thirteenth set, by effect name.
V13_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "base_tilt": _tilt,
    "probe_filter": _probe,
}


def draw_v13(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v13 scenario of ``kind`` with ``n`` library effects, from the seed's thirteenth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 13]))
    return draw_effects(rng, kind, n, V13_LIBRARY, V13_OUT_OF_LIBRARY, V13_DRAWS, EFFECTS_V13, True)


__all__ = ["V13_DRAWS", "draw_v13"]
