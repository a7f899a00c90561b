"""The fifth law set's mark and its two effects outside the library (issue 27, ``laws="v5"``; see :mod:`.laws_v5`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .physics import NOMINAL, shape


class _V5:
    """Mixin: marks a law of the fifth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v5"``)."""
        return {**super().describe(), "law_set": "v5"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class CoreHysteresis(_V5, Law):
    """Magnetic hysteresis of the stator core in the levitation force (not in the library).

    The iron's magnetization lags the levitation current's field: on a rising current the field is lower than the
    linear law's, on a falling one higher, a loop of the force against the current (active magnetic bearings:
    Schweitzer & Maslen, "Magnetic Bearings: Theory, Design, and Application to Rotating Machinery", Springer
    2009, the iron's hysteresis in the force-current relation). Its elementary rate-independent form is the play
    operator (Krasnosel'skii & Pokrovskii, "Systems with Hysteresis", Springer 1989; the hysteron of the
    Prandtl-Ishlinskii model): ``p <- clip(p, i_d - w, i_d + w)``, advanced once per period from the delivered
    current (hook ``advance``), and the iron acts as the current ``i_d - i_c s``, ``s = clip((i_d - p) / w, -1,
    1)``: elastic within ``+-w`` of the last reversal, an offset ``-+i_c`` (the coercive field's current) on
    sweeps beyond. Each run starts with the iron at ``s = 0``.
    """

    name = "core_hysteresis"
    library = False
    families = ("play",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"play": {"i_c": 0.05, "w": 0.15}}
    has_rotate_at = True
    has_advance = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.state = np.zeros(0)
        self.started = False
        self.peak = np.zeros(2)

    def reset(self, n_runs: int) -> None:
        """Iron state unset (the first :meth:`advance` puts it at the run's first current)."""
        self.state, self.started, self.peak = np.zeros(n_runs), False, np.zeros(2)

    def advance(self, i, t, Ts: float) -> None:
        """Play operator on the delivered levitation current ``i[:, 1]`` once per period."""
        i_d = np.asarray(i, dtype=float)[:, 1]
        w = self.p["w"]
        self.state = i_d.copy() if not self.started else np.clip(self.state, i_d - w, i_d + w)
        self.started = True

    def offset(self, i_d):
        """Current the iron takes off ``i_d`` [A]."""
        s = np.clip((np.asarray(i_d, dtype=float) - self.state) / self.p["w"], -1.0, 1.0)
        return self.p["i_c"] * s

    def rotate_at(self, i_q, i_d, X, t):
        """Currents the magnetic circuit sees: ``(i_q, i_d - i_c s)``."""
        off = self.offset(i_d)
        g = X[..., 0]
        lift = NOMINAL.Mv * NOMINAL.C3 * shape(g).f3  # N per A of i_d (seed eq. (2))
        self.peak = np.maximum(self.peak, [float(np.max(np.abs(off))), float(np.max(np.abs(off * lift)))])
        return i_q, np.asarray(i_d, dtype=float) - off

    def recorded(self) -> dict[str, float]:
        """Size recorded while simulated: the peak current offset [A] and its lift [N]."""
        f = float(self.peak[1])
        return {"peak_current_offset_a": float(self.peak[0]), "peak_force_n": f, "peak_force_g_n": f,
                "peak_force_d_n": 0.0}  # fmt: skip


N_WAVES = 6  #: components of the target's waviness


class TargetRunout(_V5, Law):
    """The gap probe reads a target surface that is not flat along the stroke (not in the library).

    An inductive / eddy-current gap probe measures the distance to its target; the target's waviness (its form
    error along the travel) adds to the reading as the stroke moves the target under the probe (the "mechanical
    runout" of a probe track: API Standard 670, "Machinery Protection Systems", 5th ed., 2014; waviness spectra:
    Whitehouse, "Handbook of Surface and Nanometrology", 2nd ed., CRC Press 2011): ``g_read = g + e(d)``,
    ``e(d) = sum_m a_m sin(2 pi d / lam_m + ph_m)`` with a ``1/k`` amplitude spectrum (``a_m ~ lam_m``) seen
    through the probe's spot of diameter ``D`` (the average over a disc: ``2 J1(k D/2) / (k D/2)``), scaled to the
    RMS ``rms``. No force on the mover.
    """

    name = "target_runout"
    library = False
    families = ("waviness",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "waviness": {
            "rms": 6e-6,
            "spot": 8e-3,
            **{f"lam{j}": 0.08 / 1.6**j for j in range(N_WAVES)},
            **{f"ph{j}": 0.0 for j in range(N_WAVES)},
        }
    }
    has_read = True

    def amplitudes(self) -> np.ndarray:
        """``a_m`` [m] of the components as the probe sees them."""
        from scipy.special import j1

        p = self.p
        lam = np.array([p[f"lam{j}"] for j in range(N_WAVES)])
        x = math.pi * p["spot"] / lam  # k D / 2
        a = lam * 2.0 * j1(x) / x
        return p["rms"] * a / math.sqrt(float(np.sum(a * a)) / 2.0)

    def profile(self, d):
        """Reading error ``e(d)`` [m]."""
        d = np.asarray(d, dtype=float)
        out = 0.0 * d
        for j, a in enumerate(self.amplitudes()):
            out = out + a * np.sin(2 * math.pi * d / self.p[f"lam{j}"] + self.p[f"ph{j}"])
        return out

    def read(self, g, d):
        """Readings: the target's form error adds to ``g``."""
        return np.asarray(g) + self.profile(d), d


__all__ = ["N_WAVES", "CoreHysteresis", "TargetRunout"]
