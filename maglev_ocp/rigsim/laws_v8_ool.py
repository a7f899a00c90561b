"""The eighth law set's mark and its two effects outside the library (issue 27, ``laws="v8"``; see :mod:`.laws_v8`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law


class _V8:
    """Mixin: marks a law of the eighth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v8"``)."""
        return {**super().describe(), "law_set": "v8"}  # type: ignore[misc]


def per_run(v: np.ndarray, x) -> np.ndarray:
    """``v`` (one value per run) shaped to broadcast against ``x`` (runs along its first axis); the first run's value
    where ``x`` has no run axis of that length (a call outside a simulation of ``v.shape[0]`` runs)."""
    x = np.asarray(x)
    if x.ndim == 0 or x.shape[0] != v.shape[0]:
        return np.asarray(v[0] if v.shape[0] else 0.0 * v.sum(axis=0))
    return v.reshape(v.shape[:1] + (1,) * (x.ndim - 1) + v.shape[1:])


# --------------------------------------------------------------------- out of the library
class FloorVibration(_V8, Law):
    """Tonal vibration of the rig's base from nearby machinery (not in the library).

    A pump or compressor on the same floor shakes the base that carries the stator at its running frequency
    ``f1`` and its second harmonic (rotating unbalance and the blade/piston passing: Rivin, "Vibration isolation of
    precision equipment", Precision Engineering 17(1), 1995; Gordon, "Generic vibration criteria for
    vibration-sensitive equipment", Proc. SPIE 3786, 1999). The encoders and the stator move with the base, the
    levitated mover does not, so in the base's frame the mover feels the inertial force of the base's acceleration
    ``a_a(t)`` per axis: ``F_a = -M_a a_a(t)``, ``a_a = A_a (sin(2 pi f1 t + phi_a) + h2 sin(4 pi f1 t + 2 phi_a +
    phi2))`` (``M_g = Mv``, ``M_d = Mh``, nominal masses; ``t`` the dataset time, the runs recorded one after the
    other). The time comes from the hook ``advance`` at each period's start and the force is held over each
    sub-step at its midpoint (hook ``held``); its peak is recorded while simulated.
    """

    name = "floor_vibration"
    library = False
    families = ("machinery",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "machinery": {"f1": 15.0, "A_g": 0.08, "A_d": 0.12, "h2": 0.3, "phi_g": 0.0, "phi_d": 1.0, "phi2": 0.5}
    }
    has_held = True
    has_advance: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.t = np.zeros(0)
        self.peak = np.zeros(2)

    def reset(self, n_runs: int) -> None:
        """Time zero per run; no peak yet."""
        self.t = np.zeros(n_runs)
        self.peak = np.zeros(2)

    def acceleration(self, t):
        """Base accelerations ``(a_g, a_d)`` [m/s^2] at the dataset time ``t``."""
        p = self.p
        w = 2 * math.pi * p["f1"] * np.asarray(t, dtype=float)
        out = []
        for ax in ("g", "d"):
            ph = p[f"phi_{ax}"]
            out.append(p[f"A_{ax}"] * (np.sin(w + ph) + p["h2"] * np.sin(2 * w + 2 * ph + p["phi2"])))
        return out[0], out[1]

    def advance(self, i, t, Ts: float) -> None:
        """The period's start time per run."""
        self.t = np.array(t, dtype=float, copy=True).reshape(-1)

    def held(self, gd, dd, h: float):
        """The inertial force at the sub-step's midpoint; the clock moves on by ``h``."""
        gd = np.asarray(gd, dtype=float)
        t = self.t if self.t.shape == gd.shape else np.zeros_like(gd)
        ag, ad = self.acceleration(t + 0.5 * h)
        fg, fd = -k.Mv * ag, -k.Mh * ad
        if self.t.shape == gd.shape:
            self.t = self.t + h
        self.peak = np.maximum(
            self.peak, [float(np.max(np.abs(fg), initial=0.0)), float(np.max(np.abs(fd), initial=0.0))]
        )
        return fg, fd

    def recorded(self) -> dict[str, float]:
        """Peak inertial force per axis along the simulation [N]."""
        return {
            "peak_force_n": float(max(self.peak)),
            "peak_force_g_n": float(self.peak[0]),
            "peak_force_d_n": float(self.peak[1]),
        }


class DragChain(_V8, Law):
    """The polygon effect of a cable carrier (drag chain) on the mover (not in the library).

    The sensor cables run to the mover in a chain of rigid links of pitch ``p_c`` that rolls around a bend. The
    bend travels at half the mover's speed, so a link enters the bend every ``2 p_c`` of the mover's travel, and as
    it does the chain's line of pull swings about the bend's polygon: the force the chain puts on the mover ripples
    along the motion and across it with that period (the polygonal action of chains: Mahalingam, "Polygonal action
    in chain drives", J. Franklin Inst. 265(1), 1958; Binder, "Mechanics of the Roller Chain Drive",
    Prentice-Hall 1956). ``F_d = -F_a cos(pi (d - x_c) / p_c)``, ``F_g = F_t sin(pi (d - x_c) / p_c)`` (the
    transverse swing a quarter period from the axial one); the chain's mean pull, a constant, is left out.
    """

    name = "drag_chain"
    library = False
    families = ("polygon",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"polygon": {"F_a": 0.25, "F_t": 0.1, "p_c": 0.012, "x_c": 0.0}}
    has_force = True

    def force(self, g, gd, d, dd):
        """Polygon ripple ``(F_g, F_d)`` [N]."""
        p = self.p
        ph = math.pi * (np.asarray(d, dtype=float) - p["x_c"]) / p["p_c"]
        return p["F_t"] * np.sin(ph) + 0.0 * np.asarray(g, dtype=float), -p["F_a"] * np.cos(ph)


__all__ = ["DragChain", "FloorVibration", "per_run"]
