"""Random parameters of the eighth law set (:mod:`.laws_v8`, ``rigsim.draw(..., laws="v8")``).

Each draw gives a family of the set and its physical parameters in ranges plausible for this stage and sized like
the earlier sets' (an effect visible above the sensor noise and the 10 µm encoder quantization, none driving the
stage into its stops); the comment at each range says where it comes from. :func:`draw_v8` picks the effects of a
scenario from its own stream of the seed (``SeedSequence([seed, 0x7157, 27, 8])``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _log, _pm, _u, draw_effects
from .laws_v8 import EFFECTS_V8, V8_LAWS, V8_LIBRARY, V8_OUT_OF_LIBRARY

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V8_LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    # the interior harmonics' amplitudes summing to 2-5 N at 10 mm (3-6 N replacing seed eq. (9), whose peak there
    # is 4 N), as the earlier sets; the second harmonic +-0-40 %; the slot grid anywhere
    p: Spec = {"family": fam, "replace": float(replace), "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 2.0, 5.0)}
    p.update(c2=_pm(rng, 0.0, 0.4), phi2=_u(rng, -math.pi, math.pi), x0=_u(rng, 0.0, k.t1))
    if fam == "hysteretic_teeth":  # a third harmonic +-0-20 %; the play 0.3-1.5 mm (a lag of 6-28 degrees of the
        # first harmonic, the order of soft iron's hysteresis angle at the teeth's flux swing)
        p.update(c3=_pm(rng, 0.0, 0.2), phi3=_u(rng, -math.pi, math.pi), delta_h=_u(rng, 3e-4, 1.5e-3))
    else:  # each end's detent 0.4-1.5 N at 10 mm (a third to a half of the interior's there, a few tenths of a N
        # at 20 mm where the interior's is gone), its phase anywhere; the end's charge line 3-8 mm below the face
        p.update(xi_p=_u(rng, 0.4, 1.5), xi_n=_u(rng, 0.4, 1.5), psi_p=_u(rng, -math.pi, math.pi))
        p.update(psi_n=_u(rng, -math.pi, math.pi), h_e=_u(rng, 3e-3, 8e-3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    if fam == "grease_churning":  # channelled levels 0.1-0.3 N per guide (the earlier sets' Coulomb range); fresh
        # grease 1.5-3 times that, channelling over 20-200 mm of travel (a few of the dataset's moves); viscous 0-2
        p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.3), "Fc_d": _u(rng, 0.1, 0.3)}
        p.update(a_g=_u(rng, 0.5, 2.0), a_d=_u(rng, 0.5, 2.0), s_c=_log(rng, 0.02, 0.2))
        p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0), v_reg=1e-3)
        return p
    # one direction 0.1-0.4 N (the earlier sets' range), the other 40-80 % of it, which way at random per axis
    p = {"family": fam, "b_g": _u(rng, 0.0, 2.0), "b_d": _u(rng, 0.0, 2.0), "v_reg": 1e-3}
    for ax in ("g", "d"):
        hi = _u(rng, 0.1, 0.4)
        lo = hi * _u(rng, 0.4, 0.8)
        if rng.uniform() < 0.5:
            hi, lo = lo, hi
        p.update({f"Fp_{ax}": hi, f"Fn_{ax}": lo})
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    # stator ends 10-35 mm past the array's ends at d = 0 (as v5 ... v7): the moves overhang them by up to ~35 mm
    p: Spec = {"family": fam, "e_p": _u(rng, 0.01, 0.035), "e_n": _u(rng, 0.01, 0.035)}
    if fam == "end_face":  # 0.5-3 N with the field's peak over a face at 15 mm (the size of the earlier sets' end
        # forces along d)
        p["F_e"] = _u(rng, 0.5, 3.0)
        return p
    # the base plate 5-25 mm below the stator's surface (a stator 5-25 mm thick on its plate)
    p["h_f"] = _u(rng, 5e-3, 2.5e-2)
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    if fam == "permeability_peak":  # the iron's reluctance 3-6 % of the gap's where the iron is best, at 40-55 % of
        # the lower stop's flux (gaps of 15-21 mm); the rise from the initial permeability gentle (log-width 0.65-0.9),
        # the fall into saturation steeper (0.45-0.65): 4-41 % of the pull lost at the lower stop, 2-18 % at the upper
        p: Spec = {"family": fam, "r": _u(rng, 0.03, 0.06), "b_m": _u(rng, 0.4, 0.55)}
        p.update(s_lo=_u(rng, 0.65, 0.9), s_hi=_u(rng, 0.45, 0.65))
        p["target"] = "both"
        return p
    # the knee at 65-85 % of the lower stop's flux (at gaps of 10-13.5 mm), the saturated slope 40-70 %, the corner
    # rounded over 0.02-0.05: 9-38 % of the pull lost at the lower stop, up to ~12 % at 12 mm, nothing above the knee
    return {
        "family": fam,
        "b_s": _u(rng, 0.65, 0.85),
        "m": _u(rng, 0.4, 0.7),
        "w_s": _u(rng, 0.02, 0.05),
        "target": "both",
    }


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "bessel4":  # group delay 0.3-1.2 ms (-3 dB at 280-1100 Hz, the earlier sets' bandwidths), plus 0-1
        # sample of transport delay
        return {"family": fam, "T": _log(rng, 3e-4, 1.2e-3), "delay_samples": _u(rng, 0.0, 1.0)}
    # loops of 150-600 Hz; a notch at 150-350 Hz (a stage's first structural modes), 0.15-0.4 wide, 0-30 % deep;
    # 0-0.5 sample of transport delay (group delay 0.5-2.4 ms in all)
    zp = _u(rng, 0.15, 0.4)
    return {
        "family": fam,
        "bandwidth_hz": _log(rng, 150.0, 600.0),
        "notch_hz": _log(rng, 150.0, 350.0),
        "zeta_p": zp,
        "zeta_z": zp * _u(rng, 0.0, 0.3),
        "delay_samples": _u(rng, 0.0, 0.5),
    }


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "angle_table":  # tables of 48-128 entries per electrical period, rounding (peak pi/N: 0.025-0.065
        # rad) or truncating (0 to -2 pi/N, mean -pi/N); 32 entries gave ~5 N of thrust ripple in a trial
        # (twice the earlier sets' commutation errors): left out
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.03),
            "N": float(rng.choice([48.0, 64.0, 96.0, 128.0])),
            "m": float(rng.choice([0.0, 1.0])),
            "theta0": _u(rng, -math.pi, math.pi),
            "r_s": 0.95,
        }
    # modules of two or three pole pitches, each mounted +-0.2-1.2 mm off (0.01-0.066 rad), joints anywhere
    lm = float(rng.choice([2.0, 3.0])) * k.tau
    p: Spec = {"family": fam, "delta0": _pm(rng, 0.0, 0.03), "l_m": lm, "x_b": _u(rng, 0.0, lm)}
    p.update({f"eps_{j}": math.pi / k.tau * _pm(rng, 2e-4, 1.2e-3) for j in range(6)})
    return p


def _eddy(rng):
    fam = _family(rng, "eddy_drag")
    if fam == "shorted_formers":  # aluminium formers (a loop of ~0.1 mohm, ~0.015 Wb/m of flux slope each): 5-20 N s/m
        # along d on average at 15 mm; the slot grid anywhere
        return {"family": fam, "c0": _u(rng, 5.0, 20.0), "x0": _u(rng, 0.0, k.t1)}
    # a 2-10 mm aluminium plate 5-20 mm under the coils: 4-16 N s/m at 15 mm without current; the armature's field
    # at the plate 3-12 % of the magnets' there per ampere (25-100 % at 8 A)
    return {
        "family": fam,
        "c0": _u(rng, 4.0, 16.0),
        "h_p": _u(rng, 5e-3, 2e-2),
        "kappa_d": _u(rng, 0.03, 0.12),
        "kappa_q": _u(rng, 0.03, 0.12),
    }


def _floor_vibration(rng):
    # a pump or compressor at 900-1800 rpm (15-30 Hz) or a floor mode at 8-15 Hz: 8-30 Hz; base accelerations 0.03-0.12
    # m/s^2 vertical (0.13-0.52 N on the vertical mass) and 0.05-0.25 m/s^2 horizontal (0.08-0.4 N), well above a
    # quiet lab's (VC curves) as next to machinery; second harmonic 0-50 %
    return {
        "family": "machinery",
        "f1": _u(rng, 8.0, 30.0),
        "A_g": _u(rng, 0.03, 0.12),
        "A_d": _u(rng, 0.05, 0.25),
        "h2": _u(rng, 0.0, 0.5),
        "phi_g": _u(rng, -math.pi, math.pi),
        "phi_d": _u(rng, -math.pi, math.pi),
        "phi2": _u(rng, -math.pi, math.pi),
    }


def _drag_chain(rng):
    # small cable chains have links of 10-25 mm; pitches whose ripple period 2 p_c is near the slot pitch, twice it or
    # the pole pitch are left out (10-13.5 mm and 21-26 mm: periods 20-27 mm and 42-52 mm); axial ripple 0.1-0.4 N,
    # transverse 0-0.2 N
    p_c = _u(rng, 0.010, 0.0135) if rng.uniform() < 0.5 else _u(rng, 0.021, 0.026)
    return {
        "family": "polygon",
        "F_a": _u(rng, 0.1, 0.4),
        "F_t": _u(rng, 0.0, 0.2),
        "p_c": p_c,
        "x_c": _u(rng, 0.0, 2 * p_c),
    }


#: Random parameters of the eighth set, by effect name.
V8_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "eddy_drag": _eddy,
    "floor_vibration": _floor_vibration,
    "drag_chain": _drag_chain,
}


def draw_v8(seed: int, kind: str, n: int) -> dict[str, Spec]:
    """The effects of a v8 scenario of ``kind`` with ``n`` library effects, from the seed's eighth stream."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 8]))
    return draw_effects(rng, kind, n, V8_LIBRARY, V8_OUT_OF_LIBRARY, V8_DRAWS, EFFECTS_V8, True)


__all__ = ["V8_DRAWS", "draw_v8"]
