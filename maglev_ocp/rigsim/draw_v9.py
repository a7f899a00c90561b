"""Random parameters of the ninth law set (:mod:`.laws_v9`, ``rigsim.draw(..., laws="v9")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v9` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 9])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v9 import EFFECTS_V9, V9_LAWS, V9_LIBRARY, V9_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V9_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "x0": _u(rng, 0.0, k.t1)}
    if fam == "notched_teeth":  # the harmonics' amplitudes summing to 2-5 N at 10 mm (3-6 N replacing seed eq. (9)),
        # as the earlier sets; one or two notches a tooth, 15-35 % of the slot opening wide (wider notches cancel the
        # fundamental: no cogging left to see at the rig's gaps)
        p.update(xi0=_u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0), n=float(rng.choice([1.0, 2.0])))
        p["b_n"] = k.b0 * _u(rng, 0.15, 0.35)
        return p
    # wedges 2-5 mm thick of relative permeability 3-10 (semi-magnetic wedge material): e = 0.3-1.5 mm; the
    # amplitudes 2-5 N at 10 mm (3-6 N replacing), as the earlier sets; a second harmonic +-0-40 %
    p.update(xi0=_u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0), c2=_pm(rng, 0.0, 0.4))
    p.update(phi2=_u(rng, -math.pi, math.pi), e=_log(rng, 3e-4, 1.5e-3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "preload_taper":  # 0.1-0.3 N at the middle's preload (the earlier sets' Coulomb range); rails off
        # parallel so that the interference changes by 4-9 % per cm (load 0.46-1.66 times over the moves' +-45 mm),
        # tighter towards + or -; the reference anywhere within +-20 mm; viscous 0-2 N s/m
        p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.3), "Fc_d": _u(rng, 0.1, 0.3), "kappa": _pm(rng, 4.0, 9.0)}
        p.update(x_p=_u(rng, -0.02, 0.02), b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0), v_reg=1e-3)
        return p
    # one pad: 0.1-0.4 N (the earlier sets' range), viscous 0-2 N s/m per axis
    return {"family": fam, "Fc": _u(rng, 0.1, 0.4), "b_g": _u(rng, 0.0, 2.0), "b_d": _u(rng, 0.0, 2.0), "v_reg": 1e-3}


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 10-35 mm past the array's ends at d = 0 (as v5 ... v8): the moves overhang them by up to ~35 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.01, 0.035), "e_n": _u(rng, 0.01, 0.035)}
    if fam == "cross_coenergy":  # 10-35 % of the linkage lost over the overhang (the end coils' fringe keeps the
        # rest), smoothed over 3-8 mm: 0.7-2.3 N along d at the hover current of 15 mm (20-60 % gave up to 7 N along d
        # and 8 N on the gap in a trial: left out)
        p.update(eta=_u(rng, 0.1, 0.35), w=_u(rng, 3e-3, 8e-3))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "tip_carter":  # the tips saturate from 40-60 % of the lower stop's flux (gaps below 15-21 mm); the
        # opening 2-5 mm wider at the lower stop (b0 = 12.7 mm, the slot pitch 19.05 mm)
        b_k = _u(rng, 0.4, 0.6)
        return {"family": fam, "w_t": _u(rng, 2e-3, 5e-3) / (1.0 - b_k), "b_k": b_k, "s_w": 0.05, "target": "both"}
    # the weaker grade loses 8-20 % of the field at the lower stop, falling as b^2-3 (3-10 % at 12 mm; 15-35 % and
    # b^1.5-3 gave 7.3 N on the gap in a trial: narrowed); its stack begins within +-60 mm, on either side
    return {
        "family": fam,
        "l_lo": _u(rng, 0.08, 0.2),
        "n": _u(rng, 2.0, 3.0),
        "x_j": _u(rng, -0.06, 0.06),
        "side": float(rng.choice([-1.0, 1.0])),
        "target": "both",
    }


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "chebyshev3":  # ripple bandwidths of 300-800 Hz (the earlier sets' bandwidths), 0.1-1 dB of ripple,
        # 0-1 sample of transport delay (group delay 0.35-2.3 ms in all)
        return {
            "family": fam,
            "f_c": _log(rng, 300.0, 800.0),
            "ripple_db": _u(rng, 0.1, 1.0),
            "delay_samples": _u(rng, 0.0, 1.0),
        }
    # loops of 200-600 Hz, the sensor's filter 2-8 times faster, PWM of 8-20 kHz (delay 1.5 carrier periods:
    # sampling and the half-period average); 0-1 sample of transport delay (group delay 0.2-1.65 ms in all)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 200.0, 600.0),
        "filter_ratio": _u(rng, 2.0, 8.0),
        "T": 1.5 / _u(rng, 8e3, 2e4),
        "delay_samples": _u(rng, 0.0, 1.0),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "warmup_drift":  # an initial offset +-0-0.02 rad, drifting by +-0.03-0.08 rad (a Hall offset drift of
        # 1-3 % of the field over 20-40 K) with a thermal time constant of 10-40 s (the dataset's 60 s of runs)
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.02),
            "delta_T": _pm(rng, 0.03, 0.08),
            "tau_th": _u(rng, 10.0, 40.0),
        }
    # stray fields of 1.5-4.5 % of the array's field at the sensors at G_REF (2-6 % gave 4.3 N of thrust error in
    # a trial: narrowed), each component's sign at random, sensors 3-10 mm behind the stator's surface; the sensors'
    # electrical zero anywhere
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.02),
        "beta_s": _pm(rng, 0.015, 0.045),
        "beta_c": _pm(rng, 0.015, 0.045),
        "c_s": _u(rng, 3e-3, 1e-2),
        "theta0": _u(rng, -math.pi, math.pi),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "magnet_slot_eddy":  # 2.5-7 N s/m at 12 mm (0.35-1 at 15 mm, < 0.06 above 20 mm): sintered NdFeB under
        # a 12.7 mm slot opening's ripple; at most ~98 N s/m at the lower stop (2-6 gave a peak of 0.38 N in a
        # trial: raised)
        return {"family": fam, "c0": _u(rng, 2.5, 7.0)}
    # 3-12 N s/m at low speed and 15 mm; the peak drag at 0.1-0.4 m/s (the moves' speeds); rungs 6-12 mm apart,
    # 20-50 % of ripple, anywhere
    p_r = _u(rng, 6e-3, 1.2e-2)
    return {
        "family": fam,
        "c0": _u(rng, 3.0, 12.0),
        "v_m": _u(rng, 0.1, 0.4),
        "a_r": _u(rng, 0.2, 0.5),
        "p_r": p_r,
        "x_r": _u(rng, 0.0, p_r),
    }


def _purge_air(rng):
    # a purge-air nozzle anywhere within +-40 mm, its suction 0.25-0.8 N at 15 mm (0.4-1.25 N at 12 mm) with the
    # nozzle under the mover's middle, falling over 15-35 mm along d (0.15-0.6 N gave a peak of 0.22 N in a trial,
    # four times the force noise: raised)
    return {
        "family": "nozzle_suction",
        "F_a": _u(rng, 0.25, 0.8),
        "x_n": _u(rng, -0.04, 0.04),
        "w_n": _u(rng, 0.015, 0.035),
    }


def _sensor_emi(rng):
    # the probe's reading moves by +-3-10 µm per ampere of levitation current (10-45 µm at the hover currents of the
    # gap band's lower part) and +-1-5 µm per ampere of thrust current
    return {"family": "actuator_field", "k_d": _pm(rng, 3e-6, 1e-5), "k_q": _pm(rng, 1e-6, 5e-6)}


#: Random parameters of the ninth set, by effect name.
V9_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "purge_air": _purge_air,
    "sensor_emi": _sensor_emi,
}


def draw_v9(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v9 scenario of ``kind`` with ``n`` library effects, from the seed's ninth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 9]))
    return draw_effects(rng, kind, n, V9_LIBRARY, V9_OUT_OF_LIBRARY, V9_DRAWS, EFFECTS_V9, True)


__all__ = ["V9_DRAWS", "draw_v9"]
