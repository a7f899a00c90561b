"""Effects of a real rig, each written from its physics as a family of laws.

Every effect is a small class with a ``family`` (which law of the family it
follows) and its parameters; :data:`LAWS` lists them. They are independent of
the suite's effect library (``maglev_ocp.effects``): the laws here are other
members of the physical families that NOTES.md names, plus effects the library
does not have at all (``library = False``).

An effect acts on the simulated rig through one or more hooks, all elementwise
over the runs simulated side by side:

* ``factors(g, d, f)``: multiplies the field factors ``f = [km, kc, rho, thrust]``
  (magnet field, current-produced field, fraction of the magnets over the
  stator, thrust ripple); the magnetic terms of seed eq. (2) scale as
  ``C2 f2 km^2 rho``, ``C3 f3 i_d km kc rho``, ``C4 f4 |i|^2 kc^2 rho`` and
  ``C1 f1 i_q km kc rho thrust``;
* ``force(g, gd, d, dd)``: a smooth force ``(F_g, F_d)`` [N] in the right-hand
  side (``F_g > 0`` opens the gap);
* ``held(gd, dd, h)``: a hysteretic force with its own state, advanced exactly
  over a sub-step of length ``h`` and held over it;
* ``rotate(i_q, i_d, d)``: the currents the motor carries for the ones the
  amplifier delivers;
* ``read(g, d)``: what the encoders read for the true positions.

The amplifier (its order, bandwidth and fractional delay) and the structural
resonance have states of their own and are handled by the simulator
(:mod:`.sim`), which reads their parameters from these classes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from .. import constants as k

G_STOP_LO = k.g_stop[0]


def _softplus(z):
    return np.logaddexp(0.0, z)


class Law:
    """Base class of an effect: a family name and its parameters.

    Parameters
    ----------
    family : str, optional
        Member of the law family (default: the class's first family).
    **params : float
        Parameters (defaults from ``DEFAULTS[family]``).
    """

    name: ClassVar[str] = ""
    library: ClassVar[bool] = True
    new_law: ClassVar[bool] = False  #: one of the families added for issue 27's blind check (:mod:`.laws_new`)
    families: ClassVar[tuple[str, ...]] = ()
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {}
    has_factors: ClassVar[bool] = False
    has_force: ClassVar[bool] = False
    has_held: ClassVar[bool] = False
    has_rotate: ClassVar[bool] = False
    has_read: ClassVar[bool] = False

    def __init__(self, family: str | None = None, **params: float):
        family = family or self.families[0]
        if family not in self.families:
            raise ValueError(f"{self.name}: family must be one of {list(self.families)}, got {family!r}")
        defaults = self.DEFAULTS[family]
        unknown = sorted(set(params) - set(defaults))
        if unknown:
            raise ValueError(f"{self.name} ({family}): unknown parameters {unknown}; known {sorted(defaults)}")
        self.family = family
        self.p: dict[str, Any] = {**defaults, **{n: _num(v) for n, v in params.items()}}

    def describe(self) -> dict[str, Any]:
        """Family and parameters, for the truth record."""
        return {"family": self.family, "library": self.library, "new_law": self.new_law, "params": dict(self.p)}

    def reset(self, n_runs: int) -> None:
        """Clear internal states before a simulation of ``n_runs`` runs side by side."""

    # hooks (overridden where ``has_*`` is True)
    def factors(self, g, d, f: list) -> None:  # pragma: no cover - interface
        """Multiply the field factors ``f`` in place."""

    def force(self, g, gd, d, dd):  # pragma: no cover - interface
        """Smooth force ``(F_g, F_d)`` [N]."""

    def held(self, gd, dd, h: float):  # pragma: no cover - interface
        """Hysteretic force ``(F_g, F_d)`` [N] held over a sub-step of length ``h`` (advances the state)."""

    def rotate(self, i_q, i_d, d):  # pragma: no cover - interface
        """Currents the motor carries ``(i_q', i_d')``."""

    def read(self, g, d):  # pragma: no cover - interface
        """Encoder readings ``(g_read, d_read)`` before noise and quantization."""


def _num(v: Any) -> Any:
    return float(v) if isinstance(v, (int, float, np.number)) and not isinstance(v, bool) else v


# ----------------------------------------------------------------------------- cogging
class Cogging(Law):
    """Cogging beyond seed eq. (9): another decay with the gap, harmonics, a normal/tangential ratio.

    ``xi(g)`` is the peak force [N] at the gap (``g_ref = 10 mm``):

    * ``power``: ``xi0 (g_ref / g)^n`` (the seed's "inversely proportional to the air-gap");
    * ``gauss``: ``xi0 exp(-((g - g_ref) / w)^2)``;
    * ``twoexp``: ``xi0 (a exp(-(g - g_ref)/l1) + (1 - a) exp(-(g - g_ref)/l2))``.

    Forces: ``Fx = xi sum_k h_k sin(k pi d / t1 + phi_k)`` and
    ``Fn = kn xi sum_k |h_k| sin^2(k pi d / t1 + phi_k)`` (attractive), k = 1..3.
    With ``replace = 1`` the rig's cogging is this law *instead of* eq. (9); otherwise it adds to it.
    """

    name = "cogging"
    families = ("power", "gauss", "twoexp")
    _common: ClassVar[dict[str, float]] = {
        "xi0": 2.0,
        "h1": 0.0,
        "h2": 0.6,
        "h3": 0.3,
        "phi1": 0.0,
        "phi2": 0.7,
        "phi3": -1.1,
        "kn": 1.0,
        "replace": 0.0,
    }
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "power": {**_common, "n": 2.5},
        "gauss": {**_common, "w": 5e-3},
        "twoexp": {**_common, "a": 0.6, "l1": 2e-3, "l2": 8e-3},
    }
    has_force = True

    def xi(self, g):
        """Peak force of the law at gap ``g`` [N]."""
        p, dg = self.p, g - k.g_cog_ref
        if self.family == "power":
            return p["xi0"] * (k.g_cog_ref / g) ** p["n"]
        if self.family == "gauss":
            return p["xi0"] * np.exp(-((dg / p["w"]) ** 2))
        return p["xi0"] * (p["a"] * np.exp(-dg / p["l1"]) + (1 - p["a"]) * np.exp(-dg / p["l2"]))

    def force(self, g, gd, d, dd):
        """Tangential force along d and normal force (as F_g, negative = closes the gap)."""
        p = self.p
        xi = self.xi(g)
        arg = math.pi * d / k.t1
        fx = 0.0
        fn = 0.0
        for j in (1, 2, 3):
            h = p[f"h{j}"]
            if h:
                s = np.sin(j * arg + p[f"phi{j}"])
                fx = fx + h * s
                fn = fn + abs(h) * s * s
        return -p["kn"] * xi * fn, xi * fx


# ---------------------------------------------------------------------------- friction
class Friction(Law):
    """Friction of the linear guides, per axis (seed section III; NOTES.md).

    * ``coulomb_viscous``: ``F = -(Fc sgn_r(v) + b v)``;
    * ``stribeck``: ``F = -((Fc + Fs exp(-|v/vs|^delta)) sgn_r(v) + b v)``;
    * ``dahl``: hysteretic, ``dF/dx = sigma (1 - F/Fc sgn(v))`` in the displacement x (rate
      independent), advanced exactly over each sub-step; plus viscous ``b v``;
    * ``lugre``: bristle state ``dz/dt = v - sigma0 |v| z / s(v)``, ``s(v) = Fc + Fs exp(-(v/vs)^2)``,
      ``F = -(sigma0 z + b v)``; ``z`` advanced exactly for the sub-step's velocity.

    ``sgn_r(v) = tanh(v / v_reg)`` is the smooth sign of the first two (``v_reg`` a presliding
    velocity). Parameters ending in ``_g`` / ``_d`` belong to the vertical / horizontal guide.
    """

    name = "friction"
    families = ("coulomb_viscous", "stribeck", "dahl", "lugre")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "coulomb_viscous": {"Fc_g": 0.2, "Fc_d": 0.2, "b_g": 1.0, "b_d": 1.0, "v_reg": 1e-3},
        "stribeck": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "Fs_g": 0.15,
            "Fs_d": 0.15,
            "vs": 5e-3,
            "delta": 2.0,
            "b_g": 0.5,
            "b_d": 0.5,
            "v_reg": 1e-3,
        },
        "dahl": {"Fc_g": 0.25, "Fc_d": 0.25, "sigma": 2e4, "b_g": 0.5, "b_d": 0.5},
        "lugre": {
            "Fc_g": 0.15,
            "Fc_d": 0.15,
            "Fs_g": 0.1,
            "Fs_d": 0.1,
            "vs": 5e-3,
            "sigma0": 3e4,
            "b_g": 0.5,
            "b_d": 0.5,
        },
    }

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.has_force = self.family in ("coulomb_viscous", "stribeck")
        self.has_held = not self.has_force
        self.state = np.zeros((0, 2))

    def reset(self, n_runs: int) -> None:
        """Zero the hysteresis states (Dahl force / LuGre bristle deflection) per run and axis."""
        self.state = np.zeros((n_runs, 2))

    def _level(self, v, ax: str):
        p = self.p
        if self.family in ("coulomb_viscous", "dahl"):
            return p[f"Fc_{ax}"]
        if self.family == "stribeck":
            return p[f"Fc_{ax}"] + p[f"Fs_{ax}"] * np.exp(-(np.abs(v / p["vs"]) ** p["delta"]))
        return p[f"Fc_{ax}"] + p[f"Fs_{ax}"] * np.exp(-((v / p["vs"]) ** 2))

    def force(self, g, gd, d, dd):
        """Smooth Coulomb / Stribeck / viscous friction on both axes."""
        p = self.p
        out = []
        for v, ax in ((gd, "g"), (dd, "d")):
            out.append(-(self._level(v, ax) * np.tanh(v / p["v_reg"]) + p[f"b_{ax}"] * v))
        return out[0], out[1]

    def held(self, gd, dd, h: float):
        """Advance the Dahl / LuGre state over ``h`` at the current velocities; return the held force."""
        p = self.p
        out = []
        for j, (v, ax) in enumerate(((gd, "g"), (dd, "d"))):
            sgn = np.sign(v)
            if self.family == "dahl":
                Fc = p[f"Fc_{ax}"]
                decay = np.exp(-p["sigma"] * np.abs(v) * h / Fc)
                self.state[:, j] = Fc * sgn + (self.state[:, j] - Fc * sgn) * decay
                fr = self.state[:, j]
            else:  # lugre: z -> s(v) sgn(v) / sigma0 exponentially in the displacement
                s = self._level(v, ax)
                zss = s * sgn / p["sigma0"]
                decay = np.exp(-p["sigma0"] * np.abs(v) * h / s)
                self.state[:, j] = zss + (self.state[:, j] - zss) * decay
                fr = p["sigma0"] * self.state[:, j]
            out.append(-(fr + p[f"b_{ax}"] * v))
        return out[0], out[1]


# -------------------------------------------------------------------------- end effects
class EndEffect(Law):
    """End effects of the short stator / mover: loss of force at overhang, and ripple with the pole pitch.

    Fraction of the magnets over the stator ``rho(d)`` (all magnetic terms scale with it):

    * ``cosine``: beyond ``|d| = d_edge`` the force falls by ``loss`` along a half cosine of width ``w``;
    * ``quadratic``: ``rho = 1 - c2 max(0, |d| - d_edge)^2`` [c2 in 1/m^2];
    * ``asymmetric``: the two ends differ, ``rho = 1 - loss_p sp((d - e_p)/w) w/L - loss_n sp((-d - e_n)/w) w/L``
      (``sp`` a softplus, ``L`` the length of the magnet array).

    Thrust ripple: ``1 + r1 cos(2 pi d / tau + p1) + r2 cos(4 pi d / tau + p2)``.
    """

    name = "end_effect"
    families = ("cosine", "quadratic", "asymmetric")
    _ripple: ClassVar[dict[str, float]] = {"r1": 0.05, "p1": 0.4, "r2": 0.02, "p2": -1.0}
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "cosine": {**_ripple, "d_edge": 0.03, "w": 0.02, "loss": 0.15},
        "quadratic": {**_ripple, "d_edge": 0.025, "c2": 150.0},
        "asymmetric": {**_ripple, "e_p": 0.03, "e_n": 0.04, "w": 5e-3, "loss_p": 1.0, "loss_n": 0.6},
    }
    has_factors = True

    def rho(self, d):
        """Fraction of the magnetic force left at horizontal position ``d``."""
        p = self.p
        if self.family == "cosine":
            z = np.clip((np.abs(d) - p["d_edge"]) / p["w"], 0.0, 1.0)
            return 1.0 - p["loss"] * 0.5 * (1.0 - np.cos(math.pi * z))
        if self.family == "quadratic":
            return 1.0 - p["c2"] * np.maximum(np.abs(d) - p["d_edge"], 0.0) ** 2
        L, w = k.pm * k.tau, p["w"]
        return (
            1.0 - (p["loss_p"] * _softplus((d - p["e_p"]) / w) + p["loss_n"] * _softplus((-d - p["e_n"]) / w)) * w / L
        )

    def ripple(self, d):
        """Relative thrust at ``d`` (pole-pitch ripple)."""
        p = self.p
        a = 2 * math.pi * d / k.tau
        return 1.0 + p["r1"] * np.cos(a + p["p1"]) + p["r2"] * np.cos(2 * a + p["p2"])

    def factors(self, g, d, f: list) -> None:
        """Scale every term by ``rho(d)`` and the thrust by the ripple."""
        f[2] = f[2] * self.rho(d)
        f[3] = f[3] * self.ripple(d)


# --------------------------------------------------------------------------- saturation
class Saturation(Law):
    """Magnetic saturation of the stator iron at small gaps.

    The loss profile ``L(g)`` (fraction of field lost):

    * ``exp``: ``loss exp(-(g - 8 mm) / ell)``;
    * ``logistic``: ``loss / (1 + exp((g - g_knee) / w))``.

    ``target`` says which field saturates: ``magnet`` (the PM field: ``km *= 1 - L``, so the
    ``C2`` term loses ``(1-L)^2``, the ``C1``, ``C3`` terms ``1 - L``, the ``C4`` term nothing),
    ``current`` (the field of the currents: ``kc *= 1 - L``) or ``both``.
    """

    name = "saturation"
    families = ("exp", "logistic")
    DEFAULTS: ClassVar[dict[str, dict[str, Any]]] = {
        "exp": {"loss": 0.15, "ell": 3e-3, "target": "magnet"},
        "logistic": {"loss": 0.15, "g_knee": 11e-3, "w": 1e-3, "target": "both"},
    }
    has_factors = True

    def __init__(self, family: str | None = None, **params: Any):
        super().__init__(family, **params)
        if self.p["target"] not in ("magnet", "current", "both"):
            raise ValueError(f"saturation: target must be magnet, current or both, got {self.p['target']!r}")

    def loss(self, g):
        """Fraction of the saturating field lost at gap ``g``."""
        p = self.p
        if self.family == "exp":
            return p["loss"] * np.exp(-(g - G_STOP_LO) / p["ell"])
        return p["loss"] / (1.0 + np.exp((g - p["g_knee"]) / p["w"]))

    def factors(self, g, d, f: list) -> None:
        """Scale the magnet and/or current field."""
        kk = 1.0 - self.loss(g)
        if self.p["target"] in ("magnet", "both"):
            f[0] = f[0] * kk
        if self.p["target"] in ("current", "both"):
            f[1] = f[1] * kk


# ------------------------------------------------------------------- amplifier and delay
class AmplifierLag(Law):
    """Current amplifier dynamics and a transport delay of a possibly fractional number of samples.

    * ``first``: ``di/dt = w (u - i)``, ``w = 2 pi bandwidth_hz``;
    * ``second``: ``i'' + 2 zeta wn i' + wn^2 i = wn^2 u``, ``wn = 2 pi fn_hz``;
    * ``delay``: a pure delay (no lag).

    ``delay_samples`` may be fractional: the command reaches the amplifier ``delay_samples * Ts``
    after it is issued (the simulator splits the period at the fractional part).
    """

    name = "amplifier_lag"
    families = ("first", "second", "delay")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "first": {"bandwidth_hz": 300.0, "delay_samples": 0.0},
        "second": {"fn_hz": 400.0, "zeta": 0.5, "delay_samples": 0.0},
        "delay": {"delay_samples": 1.0},
    }

    def transition(self, tau: float) -> np.ndarray:
        """Matrix ``Phi(tau)`` of the amplifier state ``(i - u, i')`` after ``tau`` seconds (constant input)."""
        if self.family == "delay" or tau == 0.0:
            return np.zeros((2, 2)) if self.family == "delay" else np.eye(2)
        if self.family == "first":
            w = 2 * math.pi * self.p["bandwidth_hz"]
            return np.array([[math.exp(-w * tau), 0.0], [0.0, 0.0]])
        wn, z = 2 * math.pi * self.p["fn_hz"], self.p["zeta"]
        A = np.array([[0.0, 1.0], [-wn * wn, -2 * z * wn]])
        return _expm2(A * tau)


def _expm2(M: np.ndarray) -> np.ndarray:
    """Matrix exponential of a 2x2 matrix (eigen-decomposition; distinct or complex eigenvalues)."""
    lam, V = np.linalg.eig(M)
    if abs(lam[0] - lam[1]) < 1e-9 * (abs(lam[0]) + 1.0):  # repeated root: exp(l t)(I + (M - l I))
        lm = lam[0].real
        return math.exp(lm) * (np.eye(2) + (M - lm * np.eye(2)))
    return (V @ np.diag(np.exp(lam)) @ np.linalg.inv(V)).real


class CommutationOffset(Law):
    """Commutation angle offset: the motor carries the delivered dq currents rotated by ``delta(d)``.

    * ``constant``: ``delta = delta0`` [rad electrical];
    * ``drift``: ``delta = delta0 + kappa d`` (an encoder scale mismatch in the commutation,
      the angle error grows along the stroke; kappa in rad/m).
    """

    name = "commutation_offset"
    families = ("constant", "drift")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "constant": {"delta0": 0.08},
        "drift": {"delta0": 0.03, "kappa": 2.0},
    }
    has_rotate = True

    def angle(self, d):
        """Electrical angle error at position ``d``."""
        return self.p["delta0"] + (self.p["kappa"] * d if self.family == "drift" else 0.0)

    def rotate(self, i_q, i_d, d):
        """Rotate the dq currents by ``delta(d)``."""
        a = self.angle(d)
        c, s = np.cos(a), np.sin(a)
        return c * i_q - s * i_d, s * i_q + c * i_d


# --------------------------------------------------------------------- out of the library
class Resonance(Law):
    """A lightly damped structural mode of the stator frame in the gap direction (not in the library).

    The frame (modal mass ``m_frame``, frequency ``f_hz``, damping ratio ``zeta``) carries the
    reaction of the magnetic pull and an ambient floor force (white, held per period) scaled so that
    the ambient part alone moves the frame by ``rms`` [m] RMS; the gap is measured between frame and
    mover, so the mode appears in the encoder and, through the controller, in the currents.
    """

    name = "resonance"
    library = False
    families = ("frame",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "frame": {"f_hz": 35.0, "zeta": 0.02, "m_frame": 60.0, "rms": 1e-5},
    }

    def ambient_std(self, Ts: float) -> float:
        """Std [N] of the held ambient force giving the target RMS: var = S / (m^2 4 zeta w^3), S = std^2 Ts."""
        p = self.p
        w = 2 * math.pi * p["f_hz"]
        return p["rms"] * p["m_frame"] * math.sqrt(4 * p["zeta"] * w**3 / Ts)


class EncoderError(Law):
    """Encoder errors (not in the library): what the gap and position encoders read.

    * ``scale``: ``g_read = g0 + (1 + eps_g)(g - g0)`` with ``g0 = 20 mm`` and ``d_read = (1 + eps_d) d``;
    * ``nonlinear``: a graduation error ``a sin(2 pi (x - x0) / period)`` on each axis.
    """

    name = "encoder_error"
    library = False
    families = ("scale", "nonlinear")
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "scale": {"eps_g": 0.02, "eps_d": 0.01},
        "nonlinear": {"a_g": 3e-5, "period_g": 6e-3, "a_d": 6e-5, "period_d": 25e-3},
    }
    has_read = True
    G0 = 20e-3

    def read(self, g, d):
        """Readings for the true ``(g, d)``."""
        p = self.p
        if self.family == "scale":
            return self.G0 + (1 + p["eps_g"]) * (g - self.G0), (1 + p["eps_d"]) * d
        return (
            g + p["a_g"] * np.sin(2 * math.pi * (g - self.G0) / p["period_g"]),
            d + p["a_d"] * np.sin(2 * math.pi * d / p["period_d"]),
        )


class TemperatureDrift(Law):
    """Magnet temperature drift (not in the library): Br changes by ``alpha`` per kelvin.

    ``dT(t) = rise (1 - exp(-t / tau_th))`` over the dataset's time (runs recorded one after the
    other); the magnet field factor is ``km = 1 + alpha dT`` (alpha about -0.1 %/K), which also
    scales the cogging force with ``km^2``.
    """

    name = "temperature_drift"
    library = False
    families = ("exponential",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "exponential": {"rise": 20.0, "tau_th": 30.0, "alpha": -1e-3},
    }

    def km(self, t_global):
        """Magnet field factor at the dataset time ``t_global`` [s]."""
        p = self.p
        return 1.0 + p["alpha"] * p["rise"] * (1.0 - np.exp(-np.asarray(t_global) / p["tau_th"]))


class Cable(Law):
    """Cable carrier (not in the library): a position-dependent spring and drag, and a varying load.

    ``F_d = -k_d (d - d0) - k3 (d - d0)^3 - c_d dd`` and ``F_g = w_c (d - d0) / L_c - c_g gd``
    (the share of the cable's weight carried by the mover changes along the stroke).
    """

    name = "cable"
    library = False
    families = ("spring",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "spring": {"k_d": 12.0, "k3": 2000.0, "d0": -0.08, "c_d": 1.0, "w_c": 0.4, "L_c": 0.1, "c_g": 0.5},
    }
    has_force = True

    def force(self, g, gd, d, dd):
        """Cable forces ``(F_g, F_d)`` [N]."""
        p = self.p
        x = d - p["d0"]
        return p["w_c"] * x / p["L_c"] - p["c_g"] * gd, -p["k_d"] * x - p["k3"] * x**3 - p["c_d"] * dd


#: Every effect by name, in the order the simulator applies them.
LAWS: dict[str, type[Law]] = {
    c.name: c
    for c in (
        Cogging,
        Friction,
        EndEffect,
        Saturation,
        AmplifierLag,
        CommutationOffset,
        Resonance,
        EncoderError,
        TemperatureDrift,
        Cable,
    )
}
LIBRARY_EFFECTS: tuple[str, ...] = tuple(n for n, c in LAWS.items() if c.library)
OUT_OF_LIBRARY: tuple[str, ...] = tuple(n for n, c in LAWS.items() if not c.library)


#: Keys of a law spec that describe the law (its family, its truth record) and are no parameter of its class.
SPEC_KEYS: tuple[str, ...] = ("family", "library", "new_law", "law_set")


def resolve_law(
    name: str, family: str | None, registries: Sequence[Mapping[str, type[Law]]], known: Sequence[str]
) -> type[Law]:
    """The class that implements ``family`` of effect ``name``: the first of ``registries`` (``{effect: class}``,
    in the law sets' order) whose class has that family; no family: the first class of the effect. ``known``
    names the effects for the error message."""
    cands = [r[name] for r in registries if name in r]
    if not cands:
        raise ValueError(f"unknown effect {name!r}; known: {', '.join(known)}")
    if family is None:
        return cands[0]
    for c in cands:
        if family in c.families:
            return c
    fams = [f for c in cands for f in c.families]
    raise ValueError(f"{name}: family must be one of {fams}, got {family!r}")


def build_law(
    name: str,
    spec: Mapping[str, Any] | None,
    registries: Sequence[Mapping[str, type[Law]]],
    known: Sequence[str],
) -> Law:
    """Build effect ``name`` from ``{"family": ..., <param>: value, ...}`` or ``{"params": {...}}`` (defaults for
    the rest; :data:`SPEC_KEYS` are no parameters), its class from :func:`resolve_law`."""
    spec = dict(spec or {})
    params = dict(spec.pop("params", {}) or {})
    params.update({a: b for a, b in spec.items() if a not in SPEC_KEYS})
    return resolve_law(name, spec.get("family"), registries, known)(spec.get("family"), **params)


__all__ = [
    "LAWS",
    "LIBRARY_EFFECTS",
    "OUT_OF_LIBRARY",
    "SPEC_KEYS",
    "AmplifierLag",
    "Cable",
    "Cogging",
    "CommutationOffset",
    "EncoderError",
    "EndEffect",
    "Friction",
    "Law",
    "Resonance",
    "Saturation",
    "TemperatureDrift",
    "build_law",
    "resolve_law",
]
