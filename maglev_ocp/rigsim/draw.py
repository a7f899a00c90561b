"""Random scenarios for a blind self-check on the independent rig.

:func:`draw` picks ``none``, one library effect, two or three library effects
at once, or an effect outside the library, each with a random law family and
parameters in physically plausible ranges that matter against the 10 µm
encoder quantization (the ranges follow NOTES.md and the library self-check's
sizes: cogging of a few N, friction of tenths of N, a few % of ripple, lags of
0.1-1 kHz and delays of up to 2.5 samples, saturation losing 10-35 % at the
upper stop, commutation errors of a few electrical degrees).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import constants as k
from ._rand import _pm, _u, draw_effects, pick_effects
from .draw_v4 import draw_v4
from .draw_v5 import draw_v5
from .draw_v6 import draw_v6
from .draw_v7 import draw_v7
from .draw_v8 import draw_v8
from .draw_v9 import draw_v9
from .draw_v10 import draw_v10
from .draw_v11 import draw_v11
from .draw_v12 import draw_v12
from .draw_v13 import draw_v13
from .draw_v14 import draw_v14
from .draw_v15 import draw_v15
from .draw_v16 import draw_v16
from .draw_v17 import draw_v17
from .draw_v18 import draw_v18
from .laws import LAWS, LIBRARY_EFFECTS, OUT_OF_LIBRARY
from .laws_new import ALL_EFFECTS, ALL_LIBRARY, ALL_OUT_OF_LIBRARY, NEW_LAWS
from .laws_v3 import EFFECTS_V3, V3_LAWS, V3_LIBRARY, V3_OUT_OF_LIBRARY
from .physics import NOMINAL, shape

Spec = dict[str, Any]


def _family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(LAWS[name].families))


def _cogging(rng):
    fam = _family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {
        "family": fam,
        "replace": float(replace),
        "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 1.5, 4.0),
        "h1": _u(rng, 0.7, 1.1) if replace else _u(rng, 0.0, 0.6),
        "h2": _pm(rng, 0.2, 0.6),
        "h3": _pm(rng, 0.0, 0.4),
        "phi1": 0.0,
        "phi2": _u(rng, -math.pi, math.pi),
        "phi3": _u(rng, -math.pi, math.pi),
        "kn": _u(rng, 0.5, 2.0),
    }
    if fam == "power":
        p["n"] = _u(rng, 1.5, 4.0)
    elif fam == "gauss":
        p["w"] = _u(rng, 3e-3, 7e-3)
    else:
        p.update(a=_u(rng, 0.3, 0.8), l1=_u(rng, 1.5e-3, 3e-3), l2=_u(rng, 5e-3, 10e-3))
    return p


def _friction(rng):
    fam = _family(rng, "friction")
    p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.4), "Fc_d": _u(rng, 0.1, 0.4)}
    p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0))
    if fam in ("stribeck", "lugre"):
        p.update(Fs_g=_u(rng, 0.05, 0.2), Fs_d=_u(rng, 0.05, 0.2), vs=_u(rng, 2e-3, 1e-2))
    if fam == "stribeck":
        p["delta"] = _u(rng, 1.0, 2.0)
    if fam == "dahl":
        p["sigma"] = float(math.exp(rng.uniform(math.log(5e3), math.log(5e4))))
    if fam == "lugre":
        p["sigma0"] = float(math.exp(rng.uniform(math.log(1e4), math.log(1e5))))
    return p


def _end_effect(rng):
    fam = _family(rng, "end_effect")
    p: Spec = {"family": fam, "r1": _u(rng, 0.02, 0.08), "p1": _u(rng, -math.pi, math.pi)}
    p.update(r2=_u(rng, 0.0, 0.04), p2=_u(rng, -math.pi, math.pi))
    if fam == "cosine":
        p.update(d_edge=_u(rng, 0.02, 0.035), w=_u(rng, 0.01, 0.025), loss=_u(rng, 0.1, 0.3))
    elif fam == "quadratic":
        edge = _u(rng, 0.02, 0.03)
        p.update(d_edge=edge, c2=_u(rng, 0.1, 0.3) / (0.05 - edge) ** 2)
    else:
        p.update(e_p=_u(rng, 0.025, 0.04), e_n=_u(rng, 0.025, 0.04), w=_u(rng, 3e-3, 8e-3))
        p.update(loss_p=_u(rng, 0.5, 1.5), loss_n=_u(rng, 0.5, 1.5))
    return p


def _saturation(rng):
    fam = _family(rng, "saturation")
    p: Spec = {"family": fam, "target": str(rng.choice(["magnet", "current", "both"]))}
    if fam == "exp":
        p.update(loss=_u(rng, 0.15, 0.35), ell=_u(rng, 2.5e-3, 4.5e-3))
    else:
        p.update(loss=_u(rng, 0.1, 0.3), g_knee=_u(rng, 11.5e-3, 13.5e-3), w=_u(rng, 0.5e-3, 1.5e-3))
    return p


def _amplifier(rng):
    fam = _family(rng, "amplifier_lag")
    if fam == "first":
        return {
            "family": fam,
            "bandwidth_hz": float(math.exp(rng.uniform(math.log(80), math.log(600)))),
            "delay_samples": _u(rng, 0.0, 2.5),
        }
    if fam == "second":
        return {
            "family": fam,
            "fn_hz": float(math.exp(rng.uniform(math.log(150), math.log(800)))),
            "zeta": _u(rng, 0.3, 0.9),
            "delay_samples": _u(rng, 0.0, 2.0),
        }
    return {"family": fam, "delay_samples": _u(rng, 0.5, 2.5)}


def _commutation(rng):
    fam = _family(rng, "commutation_offset")
    if fam == "constant":
        return {"family": fam, "delta0": _pm(rng, 0.04, 0.15)}
    return {"family": fam, "delta0": _pm(rng, 0.02, 0.08), "kappa": _pm(rng, 1.0, 3.0)}


def _resonance(rng):
    return {
        "family": "frame",
        "f_hz": _u(rng, 20.0, 80.0),
        "zeta": _u(rng, 0.005, 0.03),
        "m_frame": _u(rng, 40.0, 150.0),
        "rms": _u(rng, 0.7e-5, 1.5e-5),
    }


def _encoder(rng):
    fam = _family(rng, "encoder_error")
    if fam == "scale":
        return {"family": fam, "eps_g": _pm(rng, 0.01, 0.03), "eps_d": _pm(rng, 0.005, 0.02)}
    return {
        "family": fam,
        "a_g": _u(rng, 2e-5, 5e-5),
        "period_g": _u(rng, 4e-3, 10e-3),
        "a_d": _u(rng, 3e-5, 1e-4),
        "period_d": _u(rng, 15e-3, 40e-3),
    }


def _temperature(rng):
    return {
        "family": "exponential",
        "rise": _u(rng, 10.0, 40.0),
        "tau_th": _u(rng, 10.0, 60.0),
        "alpha": _u(rng, -1.2e-3, -0.8e-3),
    }


def _cable(rng):
    return {
        "family": "spring",
        "k_d": _u(rng, 5.0, 20.0),
        "k3": _u(rng, 0.0, 3000.0),
        "d0": _u(rng, -0.1, -0.06),
        "c_d": _u(rng, 0.5, 3.0),
        "w_c": _u(rng, 0.2, 0.6),
        "L_c": 0.1,
        "c_g": _u(rng, 0.0, 1.0),
    }


#: Random parameters of each effect: ``rng -> {"family": ..., param: value}``.
DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging,
    "friction": _friction,
    "end_effect": _end_effect,
    "saturation": _saturation,
    "amplifier_lag": _amplifier,
    "commutation_offset": _commutation,
    "resonance": _resonance,
    "encoder_error": _encoder,
    "temperature_drift": _temperature,
    "cable": _cable,
}


# ------------------------------------------------------------------ new families (issue 27)
def _new_family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(NEW_LAWS[name].families))


def _cogging_new(rng):
    fam = _new_family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "kn": _u(rng, 0.5, 2.0)}
    if fam == "slot_harmonic":
        p.update(xi0=_u(rng, 3.0, 6.0) if replace else _u(rng, 1.5, 4.0), c1=_u(rng, 0.6, 1.0))
        p.update(c2=_pm(rng, 0.2, 0.6), c3=_pm(rng, 0.0, 0.3), skew=_u(rng, 0.0, 0.3))
        p.update(phi2=_u(rng, -math.pi, math.pi), phi3=_u(rng, -math.pi, math.pi))
    else:
        p.update(xi0=_u(rng, 2.0, 5.0) if replace else _u(rng, 1.0, 3.0), n=_u(rng, 1.0, 3.0))
        p.update(a1=_u(rng, 0.6, 1.0), a2=_pm(rng, 0.1, 0.5), psi1=_u(rng, -math.pi, math.pi))
        p["psi2"] = _u(rng, -math.pi, math.pi)
    return p


def _friction_new(rng):
    fam = _new_family(rng, "friction")
    p: Spec = {"family": fam, "Fc_g": _u(rng, 0.1, 0.4), "Fc_d": _u(rng, 0.1, 0.4)}
    p.update(b_g=_u(rng, 0.0, 2.0), b_d=_u(rng, 0.0, 2.0))
    if fam == "maxwell_slip":
        p.update(Fs_g=_u(rng, 0.0, 0.15), Fs_d=_u(rng, 0.0, 0.15), vs=_u(rng, 2e-3, 1e-2))
        p.update(xb=float(math.exp(rng.uniform(math.log(5e-6), math.log(5e-5)))), q=_u(rng, 0.3, 0.9))
    else:
        p.update(Fs_g=p["Fc_g"] * _u(rng, 1.1, 1.8), Fs_d=p["Fc_d"] * _u(rng, 1.1, 1.8), dv=_u(rng, 2e-4, 2e-3))
    return p


def _end_effect_new(rng):
    fam = _new_family(rng, "end_effect")
    p: Spec = {"family": fam, "r1": _u(rng, 0.02, 0.08), "p1": _u(rng, -math.pi, math.pi)}
    p.update(r2=_u(rng, 0.0, 0.04), p2=_u(rng, -math.pi, math.pi), loss=_u(rng, 0.15, 0.4))
    if fam == "entry_exp":
        p.update(d_edge=_u(rng, 0.015, 0.03), delta=_u(rng, 5e-3, 2e-2))
    else:
        p.update(d_edge=_u(rng, 0.025, 0.045), w=_u(rng, 3e-3, 1e-2))
    return p


def _saturation_new(rng):
    fam = _new_family(rng, "saturation")
    p: Spec = {"family": fam, "target": str(rng.choice(["magnet", "current", "both"]))}
    if fam == "frohlich":
        p["beta"] = _u(rng, 0.15, 0.6)  # 10-28 % lost at the lower stop
    else:
        p["a"] = _u(rng, 1.5, 3.5)  # 12-37 % lost at the lower stop
    return p


def _amplifier_new(rng):
    fam = _new_family(rng, "amplifier_lag")
    if fam == "cascade":
        bw = float(math.exp(rng.uniform(math.log(80), math.log(600))))
        return {"family": fam, "bandwidth_hz": bw, "filter_hz": bw * _u(rng, 2.0, 16.0), "delay_samples": 0.0}
    n_comp = float(rng.integers(0, 3))
    bw = float(math.exp(rng.uniform(math.log(150), math.log(1500))))
    return {"family": fam, "n_comp": n_comp, "bandwidth_hz": bw, "delay_samples": n_comp + 0.5}


def _commutation_new(rng):
    fam = _new_family(rng, "commutation_offset")
    if fam == "pitch_error":
        return {
            "family": fam,
            "delta0": _pm(rng, 0.0, 0.06),
            "a": _u(rng, 0.04, 0.12),
            "psi": _u(rng, -math.pi, math.pi),
        }
    return {"family": fam, "delta0": _pm(rng, 0.0, 0.06), "kappa_i": _pm(rng, 0.02, 0.08)}


def _eddy(rng):
    fam = _new_family(rng, "eddy_drag")
    if fam == "thin_plate":
        # a thin conducting plate: c ~ sigma t B^2 A, tens of N s/m for copper; less for a laminated stator
        return {"family": fam, "c0": _u(rng, 4.0, 20.0), "v_c": _u(rng, 0.05, 0.5)}
    return {"family": fam, "F00": _u(rng, 1.0, 4.0), "w": _u(rng, 0.05, 0.3)}


def _cable_hysteresis(rng):
    return {
        "family": "jenkins",
        "k0": _u(rng, 3.0, 15.0),
        "d0": _u(rng, -0.1, -0.06),
        "k_h": float(math.exp(rng.uniform(math.log(100), math.log(2000)))),
        "F_y": _u(rng, 0.2, 0.6),
    }


def _crosstalk(rng):
    return {"family": "linear", "c_gd": _pm(rng, 1e-3, 5e-3), "c_dg": _pm(rng, 2e-3, 1e-2)}


#: Random parameters of the new families (:mod:`.laws_new`), by effect name.
NEW_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging_new,
    "friction": _friction_new,
    "end_effect": _end_effect_new,
    "saturation": _saturation_new,
    "amplifier_lag": _amplifier_new,
    "commutation_offset": _commutation_new,
    "eddy_drag": _eddy,
    "cable_hysteresis": _cable_hysteresis,
    "sensor_crosstalk": _crosstalk,
}


# ------------------------------------------------------------ third set (laws_v3, issue 27)
def _v3_family(rng: np.random.Generator, name: str) -> str:
    return str(rng.choice(V3_LAWS[name].families))


def _cogging_v3(rng):
    fam = _v3_family(rng, "cogging")
    replace = bool(rng.uniform() < 0.5)
    p: Spec = {"family": fam, "replace": float(replace), "xi0": _u(rng, 3.0, 6.0) if replace else _u(rng, 1.5, 4.0)}
    if fam == "energy_slot":  # slot opening 2-8 mm, magnet height 3-8 mm
        p.update(b0=_u(rng, 2e-3, 8e-3), hm=_u(rng, 3e-3, 8e-3), alpha_m=_u(rng, 0.2, 0.8))
        p["d0"] = _u(rng, 0.0, 2 * k.t1)
    else:
        p.update(M=float(rng.integers(2, 5)), skew=_u(rng, 0.2, 0.7), c1=_u(rng, 0.7, 1.0))
        p.update(c2=_pm(rng, 0.2, 0.6), c3=_pm(rng, 0.0, 0.4))
        p.update(phi2=_u(rng, -math.pi, math.pi), phi3=_u(rng, -math.pi, math.pi))
    return p


def _friction_v3(rng):
    fam = _v3_family(rng, "friction")
    p: Spec = {"family": fam, "b_g": _u(rng, 0.0, 2.0), "b_d": _u(rng, 0.0, 2.0)}
    if fam == "elastoplastic":
        p.update(Fc_g=_u(rng, 0.1, 0.4), Fc_d=_u(rng, 0.1, 0.4), Fs_g=_u(rng, 0.0, 0.2), Fs_d=_u(rng, 0.0, 0.2))
        s0 = float(math.exp(rng.uniform(math.log(1e4), math.log(1e5))))
        # bristle damping up to 0.3 of critical for the horizontal mass (Dupont et al.: sigma1 ~ sqrt(sigma0 m))
        p.update(vs=_u(rng, 2e-3, 1e-2), sigma0=s0, sigma1=_u(rng, 0.0, 0.3) * 2 * math.sqrt(s0 * NOMINAL.Mh))
        p["r_ba"] = _u(rng, 0.3, 0.8)
    else:
        for ax in ("g", "d"):
            fc = _u(rng, 0.1, 0.4)
            f2 = fc * _u(rng, 0.2, 0.8)  # start-up peak up to 1.8 Fc
            p.update({f"f1_{ax}": fc + f2, f"f2_{ax}": f2})
        p.update(eps=float(math.exp(rng.uniform(math.log(1e-5), math.log(1e-4)))), eta=_u(rng, 0.05, 0.3))
    return p


def _end_effect_v3(rng):
    fam = _v3_family(rng, "end_effect")
    p: Spec = {"family": fam, "r1": _u(rng, 0.02, 0.08), "p1": _u(rng, -math.pi, math.pi)}
    p.update(r2=_u(rng, 0.0, 0.04), p2=_u(rng, -math.pi, math.pi))
    if fam == "roters":  # 3-22 % lost at the stroke's end (d = ±60 mm), depending on the gap
        p.update(e_p=_u(rng, 0.015, 0.035), e_n=_u(rng, 0.015, 0.035), L=_u(rng, 0.15, 0.3))
    else:
        p.update(e_p=_u(rng, 0.005, 0.03), e_n=_u(rng, 0.005, 0.03), a_m=_u(rng, 0.7, 0.95))
    return p


def _saturation_v3(rng):
    fam = _v3_family(rng, "saturation")
    p: Spec = {"family": fam, "target": str(rng.choice(["magnet", "current", "both"]))}
    if fam == "brauer":
        p.update(s=_u(rng, 0.03, 0.15), kappa=_u(rng, 1.0, 3.0))
    else:
        p.update(a=_u(rng, 0.5, 0.9), hm=_u(rng, 2e-3, 8e-3))  # 6-19 % lost at the lower stop
    return p


def _amplifier_v3(rng):
    fam = _v3_family(rng, "amplifier_lag")
    if fam == "butterworth3":
        bw = float(math.exp(rng.uniform(math.log(100), math.log(800))))
        return {"family": fam, "bandwidth_hz": bw, "delay_samples": _u(rng, 0.0, 2.0)}
    # back-EMF constants from the force constants at the reference gap (reciprocity), 60-100 %
    sh = shape(0.01)
    kx, kg = NOMINAL.Mh * NOMINAL.C1 * float(sh.f1), NOMINAL.Mv * NOMINAL.C3 * float(sh.f3)
    return {
        "family": fam,
        "bandwidth_hz": float(math.exp(rng.uniform(math.log(200), math.log(800)))),
        "R": _u(rng, 2.0, 5.0),
        "L": _u(rng, 3e-3, 20e-3),
        "ke_q": kx * _u(rng, 0.6, 1.0),
        "ke_d": kg * _u(rng, 0.6, 1.0),
        "delay_samples": _u(rng, 0.0, 1.5),
    }


def _commutation_v3(rng):
    fam = _v3_family(rng, "commutation_offset")
    if fam == "latency":
        return {"family": fam, "delta0": _pm(rng, 0.0, 0.06), "t_lat": _u(rng, 1e-3, 3e-3)}
    p: Spec = {"family": fam, "delta0": _pm(rng, 0.0, 0.04), "x0": _u(rng, 0.0, 2 * k.tau)}
    p.update(eps1=_pm(rng, 0.02, 0.07), eps2=_pm(rng, 0.02, 0.07), eps3=_pm(rng, 0.02, 0.07))
    return p


def _eddy_v3(rng):
    fam = _v3_family(rng, "eddy_drag")
    if fam == "thick_plate":  # aluminium or copper, 1-6 mm; low-speed drag 3-15 N s/m at the reference gap
        sigma, T = float(rng.choice([3.5e7, 5.8e7])), _u(rng, 1e-3, 6e-3)
        kk = math.pi / k.tau
        th = math.tanh(kk * T)
        c0 = _u(rng, 3.0, 15.0)
        return {"family": fam, "F00": c0 * 2 * kk * (1 + th) / (4e-7 * math.pi * sigma * th), "T": T, "sigma": sigma}
    return {"family": fam, "c_cl": _u(rng, 1.0, 8.0), "c_ex": _u(rng, 0.2, 1.5), "hm": _u(rng, 3e-3, 8e-3), "v0": 1e-3}


def _steel(rng):
    # 3-8 N at the reference gap under the part: 0.6-2.8 N at the middle of the excitation's gap band (18 mm),
    # up to ~5 N at 12 mm; the part within the stroke the excitation visits (|d| <= 45 mm)
    return {"family": "dipole", "F_pk": _u(rng, 3.0, 8.0), "x_s": _u(rng, -0.04, 0.04), "z_s": _u(rng, 0.02, 0.04)}


def _gap_sensor(rng):
    return {
        "family": "bow_warmup",
        "n_l": _u(rng, 0.5e-3, 3e-3),
        "c": _u(rng, 0.01, 0.04),
        "tc": _u(rng, 0.5e-6, 2e-6),
        "rise": _u(rng, 5.0, 20.0),
        "tau_th": _u(rng, 10.0, 60.0),
    }


#: Random parameters of the third set (:mod:`.laws_v3`), by effect name.
V3_DRAWS: dict[str, Callable[[np.random.Generator], Spec]] = {
    "cogging": _cogging_v3,
    "friction": _friction_v3,
    "end_effect": _end_effect_v3,
    "saturation": _saturation_v3,
    "amplifier_lag": _amplifier_v3,
    "commutation_offset": _commutation_v3,
    "eddy_drag": _eddy_v3,
    "steel_preload": _steel,
    "gap_sensor_drift": _gap_sensor,
}

#: The sets with a draw module of their own, by name (``vN``: :mod:`.laws_vN` drawn by :mod:`.draw_vN`, v4 onwards).
_SET_DRAWS = {
    "v4": draw_v4,
    "v5": draw_v5,
    "v6": draw_v6,
    "v7": draw_v7,
    "v8": draw_v8,
    "v9": draw_v9,
    "v10": draw_v10,
    "v11": draw_v11,
    "v12": draw_v12,
    "v13": draw_v13,
    "v14": draw_v14,
    "v15": draw_v15,
    "v16": draw_v16,
    "v17": draw_v17,
    "v18": draw_v18,
}

#: Which laws :func:`draw` may use: ``old`` (the first families: same scenario per seed as before
#: issue 27), ``new`` (only the new families and effects), ``all`` (each drawn effect new with
#: probability :data:`P_NEW`), ``v3`` (only the third set, :mod:`.laws_v3`) and each later set ``vN`` alone
#: (:data:`_SET_DRAWS`). A new set is registered there only; the self-check's ``--laws`` reads this tuple.
LAW_SETS: tuple[str, ...] = ("all", "old", "new", "v3", *_SET_DRAWS)
P_NEW = 0.5

#: Probability of each kind of scenario.
KINDS: dict[str, float] = {"none": 0.15, "single": 0.35, "pair": 0.2, "triple": 0.1, "out_of_library": 0.2}


def draw(seed: int, kind: str | None = None, laws: str = "all") -> dict[str, Any]:
    """A random scenario: ``{"kind", "effects": {name: spec}, "seed"}``.

    Parameters
    ----------
    seed : int
        Seeds the draw (use a different seed for the dataset's own noise, or the same: they are
        spawned separately).
    kind : str, optional
        Force one of :data:`KINDS` (default: drawn with their probabilities).
    laws : str
        Law families to draw from, one of :data:`LAW_SETS`. ``old`` reproduces the scenarios drawn before
        the new families existed; ``all`` and ``new`` draw the effects and their laws from a second
        stream of the same seed, ``v3`` from a third, each later set ``vN`` from a stream of its own
        (its draw module's). Every effect's spec carries ``new_law``.
    """
    if laws not in LAW_SETS:
        raise ValueError(f"laws must be one of {list(LAW_SETS)}, got {laws!r}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157]))
    kinds = list(KINDS)
    kind = kind or str(rng.choice(kinds, p=np.array([KINDS[x] for x in kinds])))
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {kinds}, got {kind!r}")
    n = {"none": 0, "single": 1, "pair": 2, "triple": 3}.get(kind, 0)
    if laws == "old":
        effects = draw_effects(rng, kind, n, LIBRARY_EFFECTS, OUT_OF_LIBRARY, DRAWS, list(LAWS), False)
        return {"kind": kind, "seed": int(seed), "laws": laws, "effects": effects}
    if laws in _SET_DRAWS:
        return {"kind": kind, "seed": int(seed), "laws": laws, "effects": _SET_DRAWS[laws](seed, kind, n)}
    if laws == "v3":
        rng3 = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27, 3]))
        effects = draw_effects(rng3, kind, n, V3_LIBRARY, V3_OUT_OF_LIBRARY, V3_DRAWS, EFFECTS_V3, True)
        return {"kind": kind, "seed": int(seed), "laws": laws, "effects": effects}
    rng2 = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7157, 27]))
    only_new = laws == "new"
    lib = [x for x in ALL_LIBRARY if x in NEW_LAWS] if only_new else list(ALL_LIBRARY)
    ool = [x for x in ALL_OUT_OF_LIBRARY if x in NEW_LAWS] if only_new else list(ALL_OUT_OF_LIBRARY)
    effects = {}
    for nm in sorted(pick_effects(rng2, kind, n, lib, ool), key=list(ALL_EFFECTS).index):
        new = nm not in DRAWS or (nm in NEW_DRAWS and (only_new or rng2.uniform() < P_NEW))
        effects[nm] = {**(NEW_DRAWS if new else DRAWS)[nm](rng2), "new_law": bool(new)}
    return {"kind": kind, "seed": int(seed), "laws": laws, "effects": effects}


__all__ = ["DRAWS", "KINDS", "LAW_SETS", "NEW_DRAWS", "P_NEW", "V3_DRAWS", "draw"]
