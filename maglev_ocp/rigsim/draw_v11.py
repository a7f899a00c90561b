"""Random parameters of the eleventh law set (:mod:`.laws_v11`, ``rigsim.draw(..., laws="v11")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v11` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 11])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v11 import EFFECTS_V11, V11_LAWS, V11_LIBRARY, V11_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V11_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # harmonics summing to 2-5 N at 10 mm (3-6 N replacing seed eq. (9)), as the earlier sets
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    p["xi0"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)
    if fam == "segmented_magnets":  # 2-4 segments per magnet, glued gaps of 0.3-1.5 mm
        p.update(n_s=float(rng.integers(2, 5)), w_s=_u(rng, 3e-4, 1.5e-3))
        return p
    # a second harmonic +-0-30 %, the magnets 2-8 mm deeper than the stack on each side (of 50 mm)
    p.update(c2=_pm(rng, 0.0, 0.3), phi2=_u(rng, -math.pi, math.pi), o_z=_u(rng, 2e-3, 8e-3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "thixotropic_grease":  # broken-down level 0.1-0.25 N (the earlier sets' Coulomb range), 1.5-2.5 times
        # that after a rest; viscous 0.3-1.5 N s/m broken down, 2-4 times that built; the structure breaks down over
        # 5-30 mm of travel and rebuilds over 0.5-5 s of rest (a lithium grease's structural recovery)
        return {
            "family": fam,
            "Fc_g": _u(rng, 0.1, 0.25),
            "Fc_d": _u(rng, 0.1, 0.25),
            "a_s": _u(rng, 0.5, 1.5),
            "b_g": _u(rng, 0.3, 1.5),
            "b_d": _u(rng, 0.3, 1.5),
            "beta": _u(rng, 1.0, 3.0),
            "s_b": _u(rng, 0.005, 0.03),
            "tau_r": _log(rng, 0.5, 5.0),
            "v_reg": 1e-3,
        }
    # cold level 0.1-0.25 N, viscous 0-2 N s/m; the preload interference 1-3 % larger per kelvin of the rails, which
    # warm by 0.2-0.6 K per watt of copper loss (a winding of 2-5 ohm per phase) with a 20-60 s time constant
    return {
        "family": fam,
        "Fc_g": _u(rng, 0.1, 0.25),
        "Fc_d": _u(rng, 0.1, 0.25),
        "b_g": _u(rng, 0.0, 2.0),
        "b_d": _u(rng, 0.0, 2.0),
        "kappa": _u(rng, 0.01, 0.03),
        "R_c": _u(rng, 2.0, 5.0),
        "dT_w": _u(rng, 0.2, 0.6),
        "tau_th": _u(rng, 20.0, 60.0),
        "v_reg": 1e-3,
    }


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 15-35 mm past the array's ends at d = 0: the moves (+-45 mm) overhang them by up to ~30 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.015, 0.035), "e_n": _u(rng, 0.015, 0.035)}
    if fam == "cantilever_end":  # the last 10-30 mm past the last support, sagging 0.3-1 mm when covered at 15 mm
        # (first 0.5-1.5 mm: 6.4 N on the gap in a trial, beside the overhang's loss)
        p.update(l_c=_u(rng, 0.01, 0.03), delta=_u(rng, 3e-4, 1e-3))
        return p
    # end teeth 8-16 mm wide, saturating at 3-8 times the lower stop's flux density (first 2-6: 6.1 N on the gap in a
    # trial), the overhang's fringe reaching 1-3 gaps
    p.update(w_t=_u(rng, 0.008, 0.016), b_s=_u(rng, 3.0, 8.0), r_f=_u(rng, 1.0, 3.0))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    # the iron loses 8-20 % of the field at the lower stop, falling as b^2-3 (3-10 % at 12 mm), as v9's and v10's
    # (warm_iron: 6-15 % cold, as it loses more when warm: 8-20 % gave 7.0 N in a trial)
    lo = _u(rng, 0.08, 0.2)
    p: Spec = {"family": fam, "l_lo": lo, "n": _u(rng, 2.0, 3.0), "target": "both"}
    if fam == "magnetic_viscosity":  # 30-70 % of the change creeps, over 10-50 ms ... 2-20 s
        p.update(m_v=_u(rng, 0.3, 0.7), tau_1=_log(rng, 0.01, 0.05), tau_2=_log(rng, 2.0, 20.0))
        return p
    p["l_lo"] = 0.06 + (lo - 0.08) * 0.75
    # the saturation flux falls by 0.03-0.06 %/K (silicon steel near room temperature); the stator 0.5-1.5 K per watt
    # of copper loss (2-5 ohm per phase), 20-60 s to warm
    p.update(kappa_B=_u(rng, 3e-4, 6e-4), R_c=_u(rng, 2.0, 5.0), dT_w=_u(rng, 0.5, 1.5), tau_th=_u(rng, 20.0, 60.0))
    return p


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "itae3":  # natural frequency 300-700 Hz (group delay 0.49-1.14 ms), 0-1 sample of transport delay
        return {"family": fam, "f_n": _log(rng, 300.0, 700.0), "delay_samples": _u(rng, 0.0, 1.0)}
    # loops of 300-800 Hz on a winding of R/L 100-400 /s, 40-80 % of the inductance magnetizing, its core-loss time
    # constant 50-300 µs; 0-1 sample of transport delay
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 300.0, 800.0),
        "a_r": _u(rng, 100.0, 400.0),
        "m": _u(rng, 0.4, 0.8),
        "tau_fe": _u(rng, 5e-5, 3e-4),
        "delay_samples": _u(rng, 0.0, 1.0),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "emf_observer":  # the observer's resistance 2-6 % off a 2.5 ohm winding (0.04-0.15 ohm; first 0.05-0.2:
        # 4.1 N and a tracking RMS of 92 µm along d in a trial), a back-EMF
        # constant of 8.5-10.5 V s/m (seed eq. (2)'s thrust constant at 15 mm); the observer takes over from the
        # Halls between 0.08-0.15 m/s and 0.1-0.2 m/s above
        v_lo = _u(rng, 0.08, 0.15)
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "dR": _u(rng, 0.04, 0.15),
            "ke": _u(rng, 8.5, 10.5),
            "v_lo": v_lo,
            "v_hi": v_lo + _u(rng, 0.1, 0.2),
        }
    # the field at the sensors 0.4-0.75 times their linear range at 15 mm (0.5-0.9 at 12 mm: 0.02-0.06 rad; first
    # 0.8-1.6: 6.6 N and a tracking RMS of 265 µm along d in a trial), the sensors 2-6 mm behind the surface
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.02),
        "beta0": _u(rng, 0.4, 0.75),
        "c_s": _u(rng, 2e-3, 6e-3),
        "theta0": _u(rng, -math.pi, math.pi),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "mmf_harmonics":  # 0.3-1.5 N s/m at 3 A and 15 mm (first 0.5-2.5: 3.0 N in a trial pair; the field of
        # the 5th and 7th harmonics grows 5-fold from 15 to 12 mm), the conductors 0-3 mm behind the magnets' face
        return {"family": fam, "c0": _u(rng, 0.3, 1.5), "h_c": _u(rng, 0.0, 3e-3)}
    # 2-8 N s/m at 15 mm (an aluminium wall a few mm thick beside the array), a leakage length of 5-20 mm
    return {"family": fam, "c0": _u(rng, 2.0, 8.0), "l_l": _u(rng, 0.005, 0.02)}


def _ripple(rng):
    # a rectifier's ripple at twice or six times 50 or 60 Hz mains, a current error of 0.5-2 % of the current at the
    # ripple (a 5-20 % link ripple through a loop rejecting it 10-fold), 0-30 % at its second harmonic; ke/R 2-5
    return {
        "family": "rectifier_ripple",
        "eps": _u(rng, 0.005, 0.02),
        "f_r": float(rng.choice([100.0, 120.0, 300.0, 360.0])),
        "phi": _u(rng, -math.pi, math.pi),
        "h2": _u(rng, 0.0, 0.3),
        "phi2": _u(rng, -math.pi, math.pi),
        "ke_R": _u(rng, 2.0, 5.0),
    }


def _cushion(rng):
    # an air spring of 1.5-4 kN/m (a cover sealed well enough to hold a few percent of the trapped air's stiffness),
    # its leaks relaxing it in 8-20 ms (first 200-800 N/m and 5-20 ms: 0.2 N in a trial)
    return {"family": "leaky_cover", "k_a": _u(rng, 1500.0, 4000.0), "tau_l": _u(rng, 0.008, 0.02)}


#: Random parameters of the eleventh set, by effect name.
V11_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "dc_link_ripple": _ripple,
    "air_cushion": _cushion,
}


def draw_v11(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v11 scenario of ``kind`` with ``n`` library effects, from the seed's eleventh stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 11]))
    return draw_effects(rng, kind, n, V11_LIBRARY, V11_OUT_OF_LIBRARY, V11_DRAWS, EFFECTS_V11, True)


__all__ = ["V11_DRAWS", "draw_v11"]
