"""The tenth law set's mark, its shared helpers and its two effects outside the library (issue 27, ``laws="v10"``;
see :mod:`.laws_v10`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law
from .laws_v4 import K_POLE
from .physics import NOMINAL, shape

G_REF = 15e-3  #: reference gap of this set's field-scaled laws [m]
SQ3 = math.sqrt(3.0)


class _V10:
    """Mixin: marks a law of the tenth set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v10"``)."""
        return {**super().describe(), "law_set": "v10"}  # type: ignore[misc]


class _Peaks:
    """Mixin: the peak force per axis recorded while simulated (``recorded``), at the integrator's stage states."""

    peak: np.ndarray
    n_runs: int

    def reset_peaks(self, n_runs: int) -> None:
        """No peak yet."""
        self.peak = np.zeros(2)
        self.n_runs = n_runs

    def record(self, dfg, dfd) -> None:
        """Raise the peaks by the forces ``dfg`` (gap axis) and ``dfd`` (along d) [N]."""
        self.peak = np.maximum(
            self.peak, [float(np.max(np.abs(dfg), initial=0.0)), float(np.max(np.abs(dfd), initial=0.0))]
        )

    def peaks(self) -> dict[str, float]:
        """Peak force per axis along the simulation (nominal constants)."""
        return {
            "peak_force_n": float(max(self.peak)),
            "peak_force_g_n": float(self.peak[0]),
            "peak_force_d_n": float(self.peak[1]),
        }


def current_force(g, i_q, i_d, iq2, id2) -> tuple[np.ndarray, np.ndarray]:
    """Force ``(F_g, F_d)`` [N] of carrying ``(iq2, id2)`` instead of ``(i_q, i_d)``: seed eq. (2)'s current terms
    with nominal constants (``F_g > 0`` opens the gap)."""
    sh, c = shape(g), NOMINAL
    dfg = k.Mv * (c.C3 * sh.f3 * (id2 - i_d) - c.C4 * sh.f4 * (iq2**2 + id2**2 - i_q**2 - i_d**2))
    dfd = -k.Mh * c.C1 * sh.f1 * (iq2 - i_q)
    return dfg, dfd


def dq_to_abc(i_q, i_d, th):
    """Phase currents ``(i_a, i_b, i_c)`` of the dq currents at electrical angle ``th`` (amplitude-invariant Park and
    Clarke: ``i_alpha = i_d cos th - i_q sin th``, ``i_beta = i_d sin th + i_q cos th``)."""
    ia = i_d * np.cos(th) - i_q * np.sin(th)
    ib_ = i_d * np.sin(th) + i_q * np.cos(th)
    return ia, -0.5 * ia + 0.5 * SQ3 * ib_, -0.5 * ia - 0.5 * SQ3 * ib_


def abc_to_dq(ia, ib, ic, th):
    """The inverse of :func:`dq_to_abc`: ``(i_q, i_d)``."""
    al = (2.0 / 3.0) * (ia - 0.5 * ib - 0.5 * ic)
    be = (ib - ic) / SQ3
    return -al * np.sin(th) + be * np.cos(th), al * np.cos(th) + be * np.sin(th)


# --------------------------------------------------------------------- out of the library
class InverterDeadtime(_V10, _Peaks, Law):
    """The inverter's dead time: each phase current falls short by a clamp that follows its sign (not in the library).

    Between the two switches of an inverter leg neither conducts for the dead time ``t_d``; the leg's voltage then
    follows the sign of its phase current, a voltage error ``-(t_d / T_pwm) V_dc sgn(i_x)`` per phase (Murai,
    Watanabe & Iwasaki, "Waveform distortion and correction circuit for PWM inverters with switching lag-times",
    IEEE Trans. Ind. Appl. IA-23(5), 1987; Jeong & Park, "The analysis and compensation of dead-time effects in PWM
    inverters", IEEE Trans. Ind. Electron. 38(2), 1991). A current loop of finite low-frequency gain leaves a current
    error of that voltage over the loop's gain, ``I_dt``, smoothed through the zero crossing where the current
    clamps over a band ``i_w``: ``i_x' = i_x - I_dt tanh(i_x / i_w)`` for x = a, b, c, the phases from the dq currents
    at ``th = pi d / tau + theta0`` and back (hook ``rotate_at``). In dq the error opposes the current vector with a
    ripple six times per electrical period (period ``tau / 3`` along d); the force of the error is recorded while
    simulated (seed eq. (2) with nominal constants).
    """

    name = "inverter_deadtime"
    library = False
    families = ("clamped_phases",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"clamped_phases": {"I_dt": 0.05, "i_w": 0.1, "theta0": 0.0}}
    has_rotate_at: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset_peaks(0)

    def reset(self, n_runs: int) -> None:
        """No peak yet."""
        self.reset_peaks(n_runs)

    def carried(self, i_q, i_d, d):
        """The dq currents the motor carries ``(i_q', i_d')`` for the delivered ``(i_q, i_d)`` at position ``d``."""
        p = self.p
        th = K_POLE * np.asarray(d, dtype=float) + p["theta0"]
        ph = [x - p["I_dt"] * np.tanh(x / p["i_w"]) for x in dq_to_abc(i_q, i_d, th)]
        return abc_to_dq(*ph, th)

    def rotate_at(self, i_q, i_d, X, t):
        """The currents through the dead time at the state ``X``."""
        X = np.asarray(X, dtype=float)
        iq2, id2 = self.carried(i_q, i_d, X[..., 2])
        if X.ndim == 2 and X.shape[0] == self.n_runs:
            self.record(*current_force(X[:, 0], i_q, i_d, iq2, id2))
        return iq2, id2

    def recorded(self) -> dict[str, float]:
        """Peak force per axis along the simulation."""
        return self.peaks()


class MoverPitch(_V10, Law):
    """The mover pitching under its own thrust, seen by the gap probe off the pitch axis (not in the library).

    The thrust acts in the magnets' plane, a height ``h`` from the mover's centre of mass: a pitching moment ``h F_x``
    that turns the mover on its guide's rotational stiffness, ``J th'' + c th' + k th = h F_x``; a gap probe at a
    lever ``x_s`` from the pitch axis reads ``g + x_s th`` (the Abbe error of a stage not driven through its centre of
    mass: Slocum, "Precision Machine Design", Prentice Hall 1992, ch. 2; Schmidt, Schitter & Rankers, "The Design of
    High Performance Mechatronics", 2nd ed., IOS Press 2014, centre-of-mass drive). In reading units ``e = x_s
    th``: ``e'' + 2 zeta w_p e' + w_p^2 e = w_p^2 a_s F_x``, ``a_s = x_s h / k`` the static reading error per newton of
    thrust, ``F_x = -Mh C1 f1(g) i_q`` from the delivered thrust current (seed eq. (2), nominal constants; the gap of
    the last reading), held over each control period and solved exactly (hook ``advance``); ``g_read = g + e`` (hook
    ``read_at``). The rotation is small: the pull's and thrust's changes are of second order and left out. The
    peak reading error is recorded while simulated.
    """

    name = "mover_pitch"
    library = False
    families = ("thrust_moment",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"thrust_moment": {"a_s": 4e-6, "f_p": 25.0, "zeta": 0.05}}
    has_read_at: ClassVar[bool] = True  # type: ignore[misc]
    has_advance: ClassVar[bool] = True  # type: ignore[misc]

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.reset(0)

    def reset(self, n_runs: int) -> None:
        """At rest, no thrust, no peak."""
        self.e = np.zeros((n_runs, 2))
        self.F = np.zeros(n_runs)
        self.g = np.full(n_runs, G_REF)
        self.started = False
        self.peak = 0.0
        self._maps: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def transition(self, Ts: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, bd)``: ``[e, e'](t + Ts) = Ad [e, e'](t) + bd F`` for a thrust ``F`` held over ``Ts``."""
        if Ts not in self._maps:
            from scipy.linalg import expm

            w = 2 * math.pi * self.p["f_p"]
            M = np.zeros((3, 3))
            M[0, 1] = 1.0
            M[1, :] = [-w * w, -2 * self.p["zeta"] * w, w * w * self.p["a_s"]]
            E = expm(M * Ts)
            self._maps[Ts] = (E[:2, :2], E[:2, 2])
        return self._maps[Ts]

    def thrust(self, i_q, g):
        """Thrust ``F_x`` [N] of the thrust current ``i_q`` at gap ``g`` (nominal constants)."""
        return -k.Mh * NOMINAL.C1 * shape(g).f1 * np.asarray(i_q, dtype=float)

    def advance(self, i, t, Ts: float) -> None:
        """Advance the pitch over the last period with its thrust, then hold the new period's thrust."""
        i = np.asarray(i, dtype=float).reshape(-1, 2)
        F = self.thrust(i[:, 0], self.g)
        if not self.started or self.e.shape[0] != F.shape[0]:  # at rest under the first thrust
            self.e = np.column_stack([self.p["a_s"] * F, np.zeros_like(F)])
            self.started = True
        else:
            Ad, bd = self.transition(Ts)
            self.e = self.e @ Ad.T + self.F[:, None] * bd[None, :]
        self.F = F

    def read_at(self, g, d, t):
        """``(g + e, d)`` with the pitch of the period (no error where the shapes do not match)."""
        g = np.asarray(g, dtype=float)
        if g.ndim == 1 and g.shape[0] == self.e.shape[0] and self.started:
            self.g = g.copy()
            err = self.e[:, 0]
            self.peak = max(self.peak, float(np.max(np.abs(err), initial=0.0)))
        else:
            err = 0.0 * g
        return g + err, d

    def recorded(self) -> dict[str, float]:
        """Peak reading error along the simulation [m] (no force)."""
        return {"peak_error_g_m": float(self.peak), "peak_error_d_m": 0.0}


__all__ = ["G_REF", "InverterDeadtime", "MoverPitch", "abc_to_dq", "current_force", "dq_to_abc"]
