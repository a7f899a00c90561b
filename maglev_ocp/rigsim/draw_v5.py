"""Random parameters of the fifth law set (:mod:`.laws_v5`, ``rigsim.draw(..., laws="v5")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized
like the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none
driving the stage into its stops); the comment at each range says where it comes from. :func:`draw_v5` picks
the effects of a scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 5])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v5 import EFFECTS_V5, N_CELLS, V5_LAWS, V5_LIBRARY, V5_OUT_OF_LIBRARY
from .laws_v5_ool import N_WAVES

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V5_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "c1": _u(rng, 0.6, 1.0), "c2": _pm(rng, 0.2, 0.6)}
    p.update(c3=_pm(rng, 0.0, 0.4), phi2=_u(rng, -math.pi, math.pi), phi3=_u(rng, -math.pi, math.pi))
    if fam == "on_load":  # tangential peak at a hover (any gap: the pull is the weight there) 1.5-4 N (3-6 replacing)
        p["xi_h"] = _u(rng, 3.0, 6.0) if replace else _u(rng, 1.5, 4.0)
        return p
    # seed eq. (9)'s decay (3-5 mm) and sizes; cells with +-25 % permeance and +-1 mm position (punched laminations
    # stacked in packs, a pack joint among them)
    p.update(xi0=_u(rng, 3.0, 6.0) if replace else _u(rng, 1.5, 4.0), ell=_u(rng, 3e-3, 5e-3))
    for j in range(2 * N_CELLS + 1):
        p[f"eps{j}"] = _u(rng, -0.25, 0.25)
        p[f"dx{j}"] = _u(rng, -1e-3, 1e-3)
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "palmgren":  # preload friction 0.05-0.3 N per guide; rolling friction coefficient 0.003-0.01 of the
        # thrust (linear ball guides); lubricant drag 0.05-0.25 N at 0.3 m/s
        p: Spec = {"family": fam, "Fc_g": _u(rng, 0.05, 0.3), "Fc_d": _u(rng, 0.05, 0.3), "mu": _u(rng, 3e-3, 1e-2)}
        p.update(cv_g=_u(rng, 0.1, 0.55), cv_d=_u(rng, 0.1, 0.55), v_reg=1e-3)
        return p
    # steady level 0.1-0.4 N at 1 mm/s; direct and state effects 1-5 % of it per e-fold (metals, Dieterich 1979;
    # Ruina 1983), memory length 2-20 um (asperity contacts of a guide), viscous 0-2 N s/m
    p = {"family": fam, "F0_g": _u(rng, 0.1, 0.4), "F0_d": _u(rng, 0.1, 0.4), "a": _u(rng, 0.01, 0.05)}
    p.update(b=_u(rng, 0.01, 0.06), Dc=_log(rng, 2e-6, 2e-5), v0=1e-3, bv_g=_u(rng, 0.0, 2.0), bv_d=_u(rng, 0.0, 2.0))
    p["v_reg"] = 1e-3
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    p: Spec = {"family": fam, "r1": _u(rng, 0.02, 0.08), "p1": _u(rng, -math.pi, math.pi)}
    p.update(r2=_u(rng, 0.0, 0.04), p2=_u(rng, -math.pi, math.pi))
    # stator ends 10-35 mm beyond the array's ends at d = 0: 5-30 % of the force lost at the stroke's end (45 mm)
    p.update(e_p=_u(rng, 0.01, 0.035), e_n=_u(rng, 0.01, 0.035))
    if fam == "chamfer":  # chamfers of 15-45 degrees over 5-20 mm
        p.update(s=_u(rng, 0.27, 1.0), c=_u(rng, 5e-3, 2e-2))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "cross_flux":
        # the teeth carry the gap field concentrated by t1 / (t1 - b0) = 3 (0.35 T at the lower stop: about 1 T):
        # the knee (1.1-1.4 T in the linear circuit's units: b_lo 1.5-2.2 after the concentration and the yoke);
        # 20-35 % lost at the lower stop without current, 3-12 % at a hover in the excitation's gap band
        return {
            "family": fam,
            "loss_lo": _u(rng, 0.2, 0.35),
            "b_lo": _u(rng, 1.5, 2.2),
            "alpha": _u(rng, 2.0, 3.0),
            "eps": 1e-3,
            "target": str(rng.choice(["magnet", "current", "both"])),
        }
    # hot NdFeB: coercive field 0.85-0.97 of the knee's: 0-16 % of remanence lost at a hover at 12 mm
    return {
        "family": fam,
        "w_g": _u(rng, 0.85, 0.97),
        "s_k": _u(rng, 0.8, 1.6),
        "w_s": 0.03,
        "l_max": _u(rng, 0.25, 0.4),
        "target": "magnet",
    }


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "feedback_filter":  # loop 100-600 Hz, the measurement filter's corner 1.5-4 times higher
        return {
            "family": fam,
            "bandwidth_hz": _log(rng, 100.0, 600.0),
            "filter_ratio": _u(rng, 1.5, 4.0),
            "delay_samples": _u(rng, 0.0, 1.5),
        }
    # loop 200-800 Hz with the PWM and computation delay inside it, wc Td 0.3-0.9 (phase margin 38-73 deg;
    # Td 0.06-0.7 ms: 1.5 periods of a 2-25 kHz PWM)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 200.0, 800.0),
        "q": _u(rng, 0.3, 0.9),
        "delay_samples": _u(rng, 0.0, 1.5),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "sw_lag":  # Hk / H 0.02-0.05 at 10 mm (a sensor in a strong field), sensor 3-8 mm behind the surface:
        # a 0.03-0.12 rad peak-to-peak error across the gap band
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.04),
            "h_ref": _u(rng, 0.02, 0.05),
            "c_s": _u(rng, 3e-3, 8e-3),
            "x0": _u(rng, 0.0, 2 * k.tau),
            "psi_e": _u(rng, 0.0, math.pi),
        }
    # alignment current 0.8-2 A against 0.5-2.5 N of friction and cogging: up to 0.17 rad per run
    return {
        "family": fam,
        "delta0": _pm(rng, 0.0, 0.03),
        "F_stick": _u(rng, 0.5, 2.5),
        "I_inj": _u(rng, 0.8, 2.0),
        "seed": float(rng.integers(0, 2**31)),
    }


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "end_brake":  # copper / aluminium plates starting 0-25 mm beyond the array's ends; 200-800 N s/m per m
        # of overlap: 2-16 N s/m at the stroke's end
        return {
            "family": fam,
            "c_l": _u(rng, 200.0, 800.0),
            "e_p": _u(rng, 0.0, 0.025),
            "e_n": _u(rng, 0.0, 0.025),
            "s": _u(rng, 3e-3, 8e-3),
        }
    # laminated stator: hysteresis drag 0.1-0.4 N at 10 mm (Steinmetz exponent 1.6-2), hysteresis angle 0.2-0.6 rad
    # (4-11 mm of travel), classical eddy drag 1-6 N s/m at 10 mm
    return {
        "family": fam,
        "F_h0": _u(rng, 0.1, 0.4),
        "beta": _u(rng, 1.6, 2.0),
        "theta_h": _u(rng, 0.2, 0.6),
        "c_e": _u(rng, 1.0, 6.0),
    }


def _core(rng):
    # coercive field of the core (40-150 A/m over a 0.2-0.3 m path and the winding's turns): 0.03-0.1 A; loops close
    # within 0.1-0.4 A of a reversal
    return {"family": "play", "i_c": _u(rng, 0.03, 0.1), "w": _u(rng, 0.1, 0.4)}


def _runout(rng):
    # a ground target strip: 4-12 um RMS of form error along the travel, wavelengths 8-120 mm, probe spots 5-10 mm
    p: Spec = {"family": "waviness", "rms": _u(rng, 4e-6, 1.2e-5), "spot": _u(rng, 5e-3, 1e-2)}
    for j in range(N_WAVES):
        p[f"lam{j}"] = _log(rng, 8e-3, 0.12)
        p[f"ph{j}"] = _u(rng, -math.pi, math.pi)
    return p


#: Random parameters of the fifth set, by effect name.
V5_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "core_hysteresis": _core,
    "target_runout": _runout,
}


def draw_v5(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v5 scenario of ``kind`` with ``n`` library effects, from the seed's fifth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 5]))
    return draw_effects(rng, kind, n, V5_LIBRARY, V5_OUT_OF_LIBRARY, V5_DRAWS, EFFECTS_V5, True)


__all__ = ["V5_DRAWS", "draw_v5"]
