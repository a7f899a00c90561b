"""The eleventh law set's mark, its shared helpers and its two effects outside the library (issue 27,
``laws="v11"``; see :mod:`.laws_v11`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .laws import Law
from .laws_v10_ool import G_REF, _Peaks, current_force

__all__ = ["G_REF", "_V11", "AirCushion", "DcLinkRipple", "_Peaks", "_Warming", "current_force", "smoothstep"]


class _V11:
    """Mixin: marks a law of the eleventh set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v11"``)."""
        return {**super().describe(), "law_set": "v11"}  # type: ignore[misc]


class _Warming:
    """Mixin: a temperature rise ``dT`` per run, a first-order response to the coils' copper loss
    ``1.5 R_c (i_q^2 + i_d^2)`` (``dT_w`` kelvin per watt, time constant ``tau_th``), the delivered currents held over
    each period (hook ``advance``). Runs are recorded one after the other: a run starts warmed as if the dataset's
    earlier runs (its start time ``t``) had drawn its first period's loss (as :mod:`.laws_v10`'s cladding)."""

    p: dict[str, Any]
    dT: np.ndarray | None

    def warm_reset(self) -> None:
        """Cold."""
        self.dT = None

    def warm_advance(self, i, t, Ts: float) -> None:
        """The rise over the last period from the delivered currents ``i`` (n_runs, 2)."""
        p = self.p
        i = np.asarray(i, dtype=float).reshape(-1, 2)
        target = p["dT_w"] * 1.5 * p["R_c"] * np.sum(i * i, axis=1)
        if self.dT is None or self.dT.shape != target.shape:
            self.dT = target * -np.expm1(-np.asarray(t, dtype=float).reshape(-1) / p["tau_th"])
        else:
            self.dT = target + (self.dT - target) * math.exp(-Ts / p["tau_th"])


def smoothstep(x):
    """``3 x^2 - 2 x^3`` on ``[0, 1]``, 0 below, 1 above."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


# --------------------------------------------------------------------- out of the library
class DcLinkRipple(_V11, _Peaks, Law):
    """The DC link's rectifier ripple passing into the phase currents (not in the library).

    A diode rectifier leaves a ripple on the DC link at twice (single phase) or six times (three phase) the mains
    frequency (Mohan, Undeland & Robbins, "Power Electronics: Converters, Applications, and Design", 3rd ed., Wiley
    2003, ch. 5); the PWM turns the duty cycles into voltages through the rippling link, a voltage error of the
    applied voltage times ``dV(t) / V_dc`` (Enjeti & Shireen, "A new technique to reject DC-link voltage ripple for
    inverters operating on programmed PWM waveforms", IEEE Trans. Power Electron. 7(1), 1992). The current loop
    rejects it only partly at the ripple's frequency: the motor carries ``i (1 + eps r(t))`` plus, on the thrust
    current, the back-EMF's share ``eps r(t) e_q / R`` (``e_q = -ke v``, ``ke_R = ke / R``), ``r(t) = sin(2 pi f_r t
    + phi) + h2 sin(4 pi f_r t + phi2)``, ``t`` the dataset time (hook ``rotate_at``). The force of the error is
    recorded while simulated (seed eq. (2) with nominal constants).
    """

    name = "dc_link_ripple"
    library = False
    families = ("rectifier_ripple",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "rectifier_ripple": {"eps": 0.01, "f_r": 100.0, "phi": 0.0, "h2": 0.2, "phi2": 0.0, "ke_R": 3.0}
    }
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset_peaks(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.reset_peaks(n_runs)

    def ripple(self, t):
        """``r(t)``: the link's relative ripple shape at the dataset time ``t`` [s]."""
        p = self.p
        w = 2 * math.pi * p["f_r"] * np.asarray(t, dtype=float)
        return np.sin(w + p["phi"]) + p["h2"] * np.sin(2 * w + p["phi2"])

    def carried(self, i_q, i_d, v, t):
        """The dq currents the motor carries for the delivered ``(i_q, i_d)`` at speed ``v`` and time ``t``."""
        p = self.p
        e = p["eps"] * self.ripple(t)
        return i_q * (1.0 + e) - e * p["ke_R"] * np.asarray(v, dtype=float), i_d * (1.0 + e)

    def rotate_at(self, i_q, i_d, X, t):
        """The currents through the rippling link at the state ``X`` (no ripple without a time)."""
        if t is None:
            return i_q, i_d
        X = np.asarray(X, dtype=float)
        iq2, id2 = self.carried(i_q, i_d, X[..., 3], t)
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation."""
        return self.peaks()


class AirCushion(_V11, Law):
    """The air trapped under a dust cover, squeezed by the gap's motion and leaking out (not in the library).

    A cover (bellows and lip seals) closes the space around the gap; the trapped air is an air spring ``k_a = gamma
    p0 A^2 / V`` on the gap axis, its pressure relaxing through the cover's leaks as through an orifice with a time
    constant ``tau_l`` (the air spring with a flow restriction: Harris & Piersol (eds.), "Harris' Shock and Vibration
    Handbook", 5th ed., McGraw-Hill 2002 (air springs); Erin, Wilson & Zapfe, "An improved model of a pneumatic
    vibration isolator: theory and experiment", J. Sound Vib. 218(1), 1998): a Maxwell element, ``F_g = -k_a q``,
    ``q' = g' - q / tau_l`` -- a damper ``k_a tau_l`` below ``1 / (2 pi tau_l)``, a spring above. Small changes of the
    cavity (the spring linear). Solved exactly per sub-step (hook ``held``, the force its mean over the sub-step).
    """

    name = "air_cushion"
    library = False
    families = ("leaky_cover",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"leaky_cover": {"k_a": 400.0, "tau_l": 0.01}}
    has_held = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """Pressure settled."""
        self.q = np.zeros(n_runs)

    def held(self, gd, dd, h: float):
        """The cushion's force over a sub-step of length ``h`` at the gap speed ``gd`` (advances the state)."""
        p = self.p
        gd = np.asarray(gd, dtype=float)
        if self.q.shape != gd.shape:
            self.q = np.zeros_like(gd)
        tau = p["tau_l"]
        e = math.exp(-h / tau)
        qi = gd * tau
        q_mean = qi + (self.q - qi) * (tau / h) * (1.0 - e)
        self.q = qi + (self.q - qi) * e
        return -p["k_a"] * q_mean, 0.0 * q_mean
