"""The fourteenth law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v14"``; see :mod:`.laws_v14`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .laws_v13_ool import G_REF, _Peaks, current_force

__all__ = ["G_REF", "_V14", "BellowsOffload", "EncoderLatency", "_Peaks", "current_force"]


class _V14:
    """Mixin: marks a law of the fourteenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v14"``)."""
        return {**super().describe(), "law_set": "v14"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class BellowsOffload(_V14, Law):
    """A sealed air bellows between the base and the mover that carries part of its weight (not in the library).

    A closed air spring of effective area ``A`` and height ``h0 + (g - 15 mm)`` (it lengthens as the gap opens)
    holds the pressure of a polytropic gas, ``p V^n`` constant (``n`` 1 isothermal ... 1.4 adiabatic), so its force is
    ``F_g = F0 (h0 / (h0 + g - 15 mm))^n``: an upward offload ``F0`` at 15 mm that stiffens as the gap closes (air
    springs: Harris & Piersol, "Harris' Shock and Vibration Handbook", 5th ed., McGraw-Hill 2002, ch. 33 (air
    springs); Rivin, "Stiffness and Damping in Mechanical Design", Marcel Dekker 1999, ch. 6). Along d nothing (the
    bellows' lateral stiffness left out). Hook ``force``.
    """

    name = "bellows_offload"
    library = False
    families = ("sealed_air_spring",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"sealed_air_spring": {"F0": 0.8, "h0": 0.03, "n": 1.2}}
    has_force = True

    def force(self, g, gd, d, dd):
        """The bellows' force ``(F_g, F_d)`` [N]."""
        p = self.p
        x = p["h0"] + np.asarray(g, dtype=float) - G_REF
        fg = p["F0"] * (p["h0"] / x) ** p["n"]
        return fg + 0.0 * np.asarray(d, dtype=float), 0.0 * fg


class EncoderLatency(_V14, Law):
    """The horizontal encoder's position reaches the controller ``tau_l`` old (not in the library).

    A serial absolute encoder (EnDat, BiSS) latches the position, then transmits and the drive forwards it: the
    controller's reading at ``t`` is the position at ``t - tau_l`` (Heidenhain, "EnDat 2.2 -- bidirectional interface
    for position encoders", technical information, 2017; Ellis, "Control System Design Guide", 4th ed.,
    Butterworth-Heinemann 2012, ch. 4 (feedback delay)). Between readings the position is taken as linear (the
    reading interpolated between the last two positions; a latency of a control period or more reads the previous
    position). The gap probe (analog) is untouched. Hook ``read_at``; size: the largest reading error along d.
    """

    name = "encoder_latency"
    library = False
    families = ("serial_protocol",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"serial_protocol": {"tau_l": 4e-4}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """No reading yet."""
        self.d_prev: np.ndarray | None = None
        self.t_prev: np.ndarray | None = None

    def delayed(self, d, t):
        """The position ``tau_l`` before ``t`` along the last axis of ``d`` (a recorded trajectory, linear between
        samples, the first sample held before the start)."""
        d = np.asarray(d, dtype=float)
        t = np.broadcast_to(np.asarray(t, dtype=float), d.shape)
        out = np.empty_like(d)
        for idx in np.ndindex(d.shape[:-1]):
            out[idx] = np.interp(t[idx] - self.p["tau_l"], t[idx], d[idx])
        return out

    def read_at(self, g, d, t):
        """Readings ``(g_read, d_read)`` at the dataset time ``t`` (no latency without a time)."""
        d = np.asarray(d, dtype=float)
        if t is None:
            return g, d
        if d.ndim == 2:  # a recorded trajectory (runs, samples)
            return g, self.delayed(d, t)
        t = np.asarray(t, dtype=float).reshape(-1)
        out = d.copy()
        if self.d_prev is not None and self.t_prev is not None and self.d_prev.shape == d.shape:
            step = t - self.t_prev
            w = np.where(step > 0, np.clip(self.p["tau_l"] / np.where(step > 0, step, 1.0), 0.0, 1.0), 0.0)
            out = d - w * (d - self.d_prev)
        if self.t_prev is None or self.d_prev is None or self.d_prev.shape != d.shape or np.all(t > self.t_prev):
            self.d_prev, self.t_prev = d.copy(), t.copy()
        return g, out
