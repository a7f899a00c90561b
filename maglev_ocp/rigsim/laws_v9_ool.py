"""The ninth law set's mark and its two effects outside the library (issue 27, ``laws="v9"``; see :mod:`.laws_v9`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .laws import Law

G_REF = 15e-3  #: reference gap of this set's field-scaled laws [m]


class _V9:
    """Mixin: marks a law of the ninth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v9"``)."""
        return {**super().describe(), "law_set": "v9"}  # type: ignore[misc]


# --------------------------------------------------------------------- out of the library
class PurgeAir(_V9, Law):
    """Suction of the purge (cooling) air blown into the gap through a nozzle in the stator (not in the library).

    Air fed through a nozzle at ``x_n`` flows out radially through the narrow gap between the stator and the mover;
    the fast flow in the gap has a pressure below ambient (Bernoulli), so the mover is sucked towards the stator near
    the nozzle -- the "Bernoulli paradox" of radial flow between parallel plates (White, "Fluid Mechanics", 7th ed.,
    McGraw-Hill 2011, ch. 3, the radial-flow example; the same principle as non-contact Bernoulli grippers). At a
    fixed flow ``Q`` the gap speed is ``~ Q / g`` and the suction ``~ rho (Q / g)^2``: ``F_g = -F_a (G_REF / g)^2
    exp(-((d - x_n) / w_n)^2)`` (closing the gap), largest with the nozzle under the mover's middle, falling off
    over ``w_n`` as the mover leaves it; no force along d (the flow's shear on the mover is negligible).
    """

    name = "purge_air"
    library = False
    families = ("nozzle_suction",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"nozzle_suction": {"F_a": 0.3, "x_n": 0.0, "w_n": 0.02}}
    has_force = True

    def force(self, g, gd, d, dd):
        """Suction ``(F_g, 0)`` [N]."""
        p = self.p
        g, d = np.asarray(g, dtype=float), np.asarray(d, dtype=float)
        fg = -p["F_a"] * (G_REF / g) ** 2 * np.exp(-(((d - p["x_n"]) / p["w_n"]) ** 2))
        return fg, 0.0 * fg


class SensorEMI(_V9, Law):
    """The gap sensor disturbed by the actuator's own field (not in the library).

    An inductive (eddy-current) gap probe mounted beside the stator's coils sees, besides its target, the field of
    the coils' currents: the field changes the target's permeability and couples into the probe's coil, so the
    reading moves with the currents (the disturbance of displacement sensors by the actuator's field in magnetic
    levitation: Schweitzer & Maslen (eds.), "Magnetic Bearings: Theory, Design, and Application to Rotating
    Machinery", Springer 2009, ch. 5 (sensors); Fleming, "A review of nanometer resolution position sensors:
    operation and performance", Sens. Actuators A 190, 2013, sec. on inductive sensors). ``g_read = g + k_d i_d +
    k_q i_q`` with the delivered currents at the period's start (hook ``advance``); the horizontal encoder is not
    affected. The peak reading error is recorded while simulated.
    """

    name = "sensor_emi"
    library = False
    families = ("actuator_field",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"actuator_field": {"k_d": 5e-6, "k_q": 2e-6}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]
    has_advance: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.i = np.zeros((0, 2))
        self.peak = 0.0

    def reset(self, n_runs: int) -> None:
        """No current yet; no peak."""
        self.i = np.zeros((n_runs, 2))
        self.peak = 0.0

    def advance(self, i, t, Ts: float) -> None:
        """The delivered currents ``(i_q, i_d)`` per run at the period's start."""
        self.i = np.array(i, dtype=float, copy=True).reshape(-1, 2)

    def error(self, i_q, i_d):
        """Reading error [m] for the currents."""
        return self.p["k_d"] * np.asarray(i_d, dtype=float) + self.p["k_q"] * np.asarray(i_q, dtype=float)

    def read_at(self, g, d, t):
        """``(g + error, d)`` with the stored currents (zero currents where the shapes do not match)."""
        g = np.asarray(g, dtype=float)
        if self.i.shape[0] == g.shape[0] and g.ndim == 1:
            e = self.error(self.i[:, 0], self.i[:, 1])
            self.peak = max(self.peak, float(np.max(np.abs(e), initial=0.0)))
        else:
            e = 0.0 * g
        return g + e, d

    def recorded(self) -> dict[str, float]:
        """Peak reading error along the simulation [m] (no force)."""
        return {"peak_error_g_m": float(self.peak), "peak_error_d_m": 0.0}


__all__ = ["G_REF", "PurgeAir", "SensorEMI"]
