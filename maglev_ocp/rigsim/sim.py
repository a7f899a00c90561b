"""The independent rig simulator: plant, effects, amplifier, encoders and the closed loop.

The runs of a dataset are simulated side by side (arrays over runs), one
control period at a time. Within a period the currents the amplifiers deliver
follow their exact solution for the held command (:class:`~.laws.AmplifierLag`),
and the mechanics are integrated with a fixed-step Dormand-Prince 5(4) scheme
(its fifth-order solution; Dormand & Prince 1980) over one or more sub-steps; a
fractional transport delay splits the period where the delayed command arrives.
Hysteretic friction states are advanced exactly over each sub-step and their
force held over it, like the force noise, which is held over each period.

State per run: ``[g, g_dot, d, d_dot, s, s_dot]``; ``s`` is the displacement of
the stator frame (the structural mode of :class:`~.laws.Resonance`, zero
without it). The gap obeys seed eq. (2) plus the effects and the frame's
acceleration: ``g_ddot = G - a_mag + F_g / Mv + s_ddot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import constants as k
from .control import ControllerSettings, FLController
from .excite import ExcitationSettings
from .laws import AmplifierLag, Cogging, Law, Resonance, TemperatureDrift
from .physics import NOMINAL, Constants, cogging, shape

# Dormand-Prince 5(4): nodes, stage matrix and the fifth-order weights.
_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0)
_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
)
_B = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84)


@dataclass
class RigSettings:
    """What the simulated rig has besides its effects.

    Attributes
    ----------
    Ts : float
        Control period [s].
    n_runs, duration : int, float
        Runs per dataset and their length [s].
    mismatch : float
        True constants are the nominal ones times ``1 + U(-mismatch, mismatch)``.
    force_noise : tuple of float
        Std of the force noise per axis (g, d) [N], held over each period.
    current_noise : float
        Std of the noise on the currents the motor carries [A], held over each period.
    encoder_noise : float
        Std of the encoder noise before quantization [m].
    resolution : float or None
        Encoder resolution [m] (None: no quantization).
    limits, stops : bool
        Current limits (±8 A per axis, 8 A amplitude) and mechanical stops.
    n_sub : int
        Integration sub-steps per period (a fractional delay makes it two).
    locked : list of str
        Fixture per run: ``""``, ``"g"`` or ``"d"`` (default: all free).
    nominal_cogging : bool
        The rig has the cogging of seed eq. (9) (MODEL.md makes it part of the shared model); off,
        the only cogging is a ``cogging`` effect's.
    """

    Ts: float = k.Ts
    n_runs: int = 6
    duration: float = 10.0
    mismatch: float = 0.05
    force_noise: tuple[float, float] = (0.05, 0.02)
    current_noise: float = 0.005
    encoder_noise: float = 1e-6
    resolution: float | None = k.encoder_resolution
    limits: bool = True
    stops: bool = True
    n_sub: int = 1
    locked: list[str] = field(default_factory=list)
    nominal_cogging: bool = True
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    excitation: ExcitationSettings = field(default_factory=ExcitationSettings)

    @classmethod
    def ideal(cls, **kw) -> RigSettings:
        """No noise, no quantization, no mismatch (for checking the integrator)."""
        base = {"mismatch": 0.0, "force_noise": (0.0, 0.0), "current_noise": 0.0, "encoder_noise": 0.0}
        return cls(**{**base, "resolution": None, **kw})


class Rig:
    """A simulated rig: true constants, effects, noise; steps runs side by side.

    Parameters
    ----------
    constants : Constants
        True constants.
    laws : list of Law
        Effects switched on.
    settings : RigSettings
        Noise, limits, integration.
    """

    def __init__(self, constants: Constants, laws: list[Law], settings: RigSettings):
        self.c, self.s = constants, settings
        self.laws = list(laws)
        by = {law.name: law for law in self.laws}
        self.amp: AmplifierLag = by.get("amplifier_lag") or AmplifierLag("delay", delay_samples=0.0)
        self.res: Resonance | None = by.get("resonance")  # type: ignore[assignment]
        self.temp: TemperatureDrift | None = by.get("temperature_drift")  # type: ignore[assignment]
        cog = by.get("cogging")
        self.nominal_cogging = settings.nominal_cogging and not (isinstance(cog, Cogging) and cog.p["replace"])
        self.factor_laws = [law for law in self.laws if law.has_factors]
        self.force_laws = [law for law in self.laws if law.has_force]
        self.held_laws = [law for law in self.laws if law.has_held]
        self.rotate_laws = [law for law in self.laws if law.has_rotate]
        self.read_laws = [law for law in self.laws if law.has_read]
        # hooks of the third law set (:mod:`.laws_v3`): the whole state and the dataset time
        self.rotate_at_laws = [law for law in self.laws if getattr(law, "has_rotate_at", False)]
        self.read_at_laws = [law for law in self.laws if getattr(law, "has_read_at", False)]
        # hooks of the fourth law set (:mod:`.laws_v4`): factors that see the currents, a per-period state
        self.factor_i_laws = [law for law in self.laws if getattr(law, "has_factors_i", False)]
        self.advance_laws = [law for law in self.laws if getattr(law, "has_advance", False)]
        # hook of the fifth law set (:mod:`.laws_v5`): forces that see the carried currents
        self.force_i_laws = [law for law in self.laws if getattr(law, "has_force_i", False)]
        self.lti = bool(getattr(self.amp, "lti", False))
        self.t_now = np.zeros(1)  #: dataset time of the current period per run [s] (set by :func:`simulate`)
        delay = float(self.amp.p["delay_samples"])
        self.n_delay, self.frac = math.floor(delay), delay - math.floor(delay)
        Ts = settings.Ts
        if self.frac > 1e-12:  # the delayed command arrives at frac * Ts into the period
            self.sub = [(0.0, self.frac * Ts, "old"), (self.frac * Ts, (1 - self.frac) * Ts, "new")]
        else:
            h = Ts / settings.n_sub
            self.sub = [(j * h, h, "new") for j in range(settings.n_sub)]
        # amplifier transitions at the stage nodes and at the end of each sub-step
        if self.lti:  # a state-space amplifier (laws_v3): exact maps (Ad, Bd) per axis
            amp = self.amp
            self.phi = [
                [[amp.discrete(ax, c * h) for ax in (0, 1)] for c in _C] + [[amp.discrete(ax, h) for ax in (0, 1)]]
                for _, h, _ in self.sub
            ]
        else:
            self.phi = [[self.amp.transition(c * h) for c in _C] + [self.amp.transition(h)] for _, h, _ in self.sub]
        if self.res is not None:
            p = self.res.p
            w = 2 * math.pi * p["f_hz"]
            self.k_frame, self.c_frame = p["m_frame"] * w * w, 2 * p["zeta"] * w * p["m_frame"]
            self.amb_std = self.res.ambient_std(Ts)

    # ---------------------------------------------------------------- amplifier
    def rest_state(self, u) -> np.ndarray:
        """Amplifier state at rest delivering the currents ``u`` (n_runs, 2): ``Z`` for :meth:`period`."""
        if self.lti:
            return self.amp.equilibrium(u)
        return np.stack([u, np.zeros_like(u)], axis=-1)

    def delivered(self, Z) -> np.ndarray:
        """Currents ``(n_runs, 2)`` the amplifiers deliver in state ``Z``."""
        return self.amp.output(Z) if self.lti else Z[:, :, 0]

    # ------------------------------------------------------------------ physics
    def magnetic(self, g, d, i_q, i_d, km):
        """Magnetic accelerations ``(a_up, a_thrust)``: upward pull on the mover and -thrust, per unit mass."""
        c = self.c
        sh = shape(g)
        f = [km, 1.0, 1.0, 1.0]
        for law in self.factor_laws:
            law.factors(g, d, f)
        for law in self.factor_i_laws:
            law.factors_i(g, d, i_q, i_d, f)
        km, kc, rho, thr = f
        a_up = rho * (
            c.C2 * sh.f2 * km * km - c.C3 * sh.f3 * i_d * km * kc + c.C4 * sh.f4 * (i_q * i_q + i_d * i_d) * kc * kc
        )
        a_x = rho * c.C1 * sh.f1 * i_q * km * kc * thr
        if self.nominal_cogging:
            fx, fn = cogging(g, d, c)
            a_up = a_up + fn * km * km / c.Mv
            a_x = a_x - fx * km * km / c.Mh
        return a_up, a_x

    def rhs(self, X, i_q, i_d, Fg_held, Fd_held, km, F_amb):
        """Time derivative of the state ``X`` (n_runs, 6) for the motor currents and held forces."""
        g, gd, d, dd, s, sd = X.T
        a_up, a_x = self.magnetic(g, d, i_q, i_d, km)
        Fg, Fd = Fg_held, Fd_held
        for law in self.force_laws:
            fg, fd = law.force(g, gd, d, dd)
            Fg, Fd = Fg + fg, Fd + fd
        for law in self.force_i_laws:
            fg, fd = law.force_i(g, gd, d, dd, i_q, i_d)
            Fg, Fd = Fg + fg, Fd + fd
        c = self.c
        dX = np.empty_like(X)
        dX[:, 0], dX[:, 2], dX[:, 4] = gd, dd, sd
        s_dd = 0.0
        if self.res is not None:  # frame: reaction of the pull beyond the static load, ambient force
            s_dd = (-self.k_frame * s - self.c_frame * sd - c.Mv * (a_up - k.G) + F_amb) / self.res.p["m_frame"]
            dX[:, 5] = s_dd
        else:
            dX[:, 5] = 0.0
        dX[:, 1] = k.G - a_up + Fg / c.Mv + s_dd
        dX[:, 3] = -a_x + Fd / c.Mh
        return dX

    def motor_currents(self, I, d, noise, X=None, t=None):
        """Currents the motor carries: the delivered ones rotated (commutation) plus the current noise.

        ``X`` (the state) and ``t`` (the dataset time) are read by laws with ``has_rotate_at``.
        """
        i_q, i_d = I[:, 0], I[:, 1]
        for law in self.rotate_laws:
            i_q, i_d = law.rotate(i_q, i_d, d)
        for law in self.rotate_at_laws:
            i_q, i_d = law.rotate_at(i_q, i_d, X, t)
        return i_q + noise[:, 0], i_d + noise[:, 1]

    def read(self, X) -> np.ndarray:
        """Encoder readings (n_runs, 2) of ``(g, d)`` before noise and quantization (frame included in g)."""
        g, d = X[:, 0], X[:, 2]
        for law in self.read_laws:
            g, d = law.read(g, d)
        for law in self.read_at_laws:
            g, d = law.read_at(g, d, self.t_now)
        return np.column_stack([g, d])

    # ---------------------------------------------------------------- one period
    def period(self, X, Z, w_old, w_new, km, noise_i, F_noise, F_amb, locked):
        """Advance the state over one control period; returns ``(X, Z, held force of the period)``.

        ``Z`` (n_runs, 2 axes, 2) is the amplifier state (current, its rate), or (n_runs, 2 axes, n) for a
        state-space amplifier (``lti``); ``w_old`` / ``w_new`` the amplifier inputs before / after the
        delayed command arrives.
        """
        F_held_sum = np.zeros((X.shape[0], 2))
        for (t0, h, which), maps in zip(self.sub, self.phi, strict=True):
            w = w_old if which == "old" else w_new
            Fg, Fd = F_noise[:, 0].copy(), F_noise[:, 1].copy()
            for law in self.held_laws:
                fg, fd = law.held(X[:, 1], X[:, 3], h)
                Fg, Fd = Fg + fg, Fd + fd
                F_held_sum[:, 0] += fg * h
                F_held_sum[:, 1] += fd * h
            current_at, state_end = self._amplifier(Z, w, X, maps)
            K = []
            for j in range(6):
                Xs = X
                for a_jm, Kj in zip(_A[j], K, strict=False):
                    Xs = Xs + (h * a_jm) * Kj
                t_at = self.t_now + t0 + _C[j] * h if self.rotate_at_laws else None
                iq, idd = self.motor_currents(current_at(j), Xs[:, 2], noise_i, Xs, t_at)
                K.append(self.rhs(Xs, iq, idd, Fg, Fd, km, F_amb))
            X = X + h * sum(b * Kj for b, Kj in zip(_B, K, strict=True) if b)
            Z = state_end()
            X = self._constrain(X, locked)
        return X, Z, F_held_sum / self.s.Ts

    def _amplifier(self, Z, w, X, maps):
        """The amplifier over one sub-step for the held input ``w``: ``(current_at(j), state_end())``, the
        delivered currents at stage node ``j`` and the state at the sub-step's end.

        :class:`~.laws.AmplifierLag` laws: ``maps`` are the transitions ``Phi`` of the state ``(i - u, i')``.
        State-space laws (``lti``): ``maps`` are ``(Ad, Bd)`` per axis, the second input the axis' velocity
        (the amplifier's ``axis_velocity``) held over the sub-step.
        """
        if self.lti:
            vel = self.amp.axis_velocity(X)
            inp = [np.column_stack([w[:, ax], vel[:, ax]]) for ax in (0, 1)]
            C = [self.amp.ss(ax)[2] for ax in (0, 1)]

            def states(m):
                return [Z[:, ax, :] @ m[ax][0].T + inp[ax] @ m[ax][1].T for ax in (0, 1)]

            def lti_current(j):
                return np.column_stack([z @ c for z, c in zip(states(maps[j]), C, strict=True)])

            return lti_current, lambda: np.stack(states(maps[6]), axis=1)
        dev0, rate0 = Z[:, :, 0] - w, Z[:, :, 1]

        def current(j):
            P = maps[j]
            return w + P[0, 0] * dev0 + P[0, 1] * rate0

        def end():
            P = maps[6]
            return np.stack([w + P[0, 0] * dev0 + P[0, 1] * rate0, P[1, 0] * dev0 + P[1, 1] * rate0], axis=-1)

        return current, end

    def _constrain(self, X, locked):
        if self.s.stops:
            for j, (lo, hi) in ((0, k.g_stop), (2, k.d_stop)):
                out = (X[:, j] < lo) | (X[:, j] > hi)
                if out.any():
                    X[:, j] = np.clip(X[:, j], lo, hi)
                    X[out, j + 1] = 0.0
        if locked is not None:  # a fixture holds the axis where it started
            mg, md, X0 = locked
            X[mg, 0], X[mg, 1] = X0[mg, 0], 0.0
            X[md, 2], X[md, 3] = X0[md, 2], 0.0
        return X


@dataclass
class Trajectory:
    """What a closed-loop simulation recorded (arrays over runs and samples).

    Attributes
    ----------
    t : ndarray (N,)
        Time of each sample [s].
    X : ndarray (R, N, 6)
        True state at each sample.
    y : ndarray (R, N, 2)
        Encoder readings (g, d).
    u : ndarray (R, N, 2)
        Commanded currents.
    i_amp : ndarray (R, N, 2)
        Currents the amplifiers deliver at each sample.
    F_held : ndarray (R, N, 2)
        Mean hysteretic friction force over each period [N].
    km : ndarray (R, N)
        Magnet field factor of the temperature drift.
    ref : ndarray (R, N, 6)
        References.
    """

    t: np.ndarray
    X: np.ndarray
    y: np.ndarray
    u: np.ndarray
    i_amp: np.ndarray
    F_held: np.ndarray
    km: np.ndarray
    ref: np.ndarray


def simulate(rig: Rig, ref: np.ndarray, rng: np.random.Generator, model: Constants = NOMINAL) -> Trajectory:
    """Run the generator's controller on ``rig`` along the references ``ref`` (R, N, 6).

    Parameters
    ----------
    rig : Rig
        The simulated rig.
    ref : ndarray (R, N, 6)
        Reference rows ``g, g_dot, g_ddot, d, d_dot, d_ddot`` per run and sample.
    rng : numpy Generator
        Noise stream.
    model : Constants
        The controller's model (nominal).

    Returns
    -------
    Trajectory
    """
    s = rig.s
    R, N, _ = ref.shape
    Ts = s.Ts
    for law in rig.laws:
        law.reset(R)
    locks = (s.locked + [""] * R)[:R]
    ctrl = FLController(R, Ts, model, s.controller)
    X = np.zeros((R, 6))
    X[:, 0], X[:, 2] = ref[:, 0, 0], ref[:, 0, 3]
    locked = (np.array([x == "g" for x in locks]), np.array([x == "d" for x in locks]), X.copy())
    y_lock = None
    rec = {n: np.empty((R, N, m)) for n, m in (("X", 6), ("y", 2), ("u", 2), ("i", 2), ("F", 2))}
    km_rec = np.ones((R, N))
    # hover currents at the start: the controller's own inverse of zero acceleration
    u0 = np.column_stack(ctrl.inverse(X[:, 0], np.zeros((R, 2))))
    Z = rig.rest_state(u0)
    buf = [u0.copy() for _ in range(rig.n_delay + 1)]
    t_base = np.arange(R)[:, None] * s.duration  # runs recorded one after the other (temperature)
    for n in range(N):
        rig.t_now = t_base[:, 0] + n * Ts
        for law in rig.advance_laws:  # slow states (laws_v4), from the currents delivered at the period's start
            law.advance(rig.delivered(Z), rig.t_now, Ts)
        y = rig.read(X)
        if s.encoder_noise:
            y = y + s.encoder_noise * rng.standard_normal((R, 2))
        if s.resolution:
            y = np.round(y / s.resolution) * s.resolution + 0.0  # + 0.0: no negative zeros
        if n == 0:
            ctrl.reset(y)
            y_lock = y.copy()
        y = np.where(np.column_stack(locked[:2]), y_lock, y)
        u = ctrl.step(y, ref[:, n])
        if s.limits:
            u = _limit(u)
        buf.append(u)
        w_new, w_old = buf[-1 - rig.n_delay], buf[-2 - rig.n_delay]
        buf.pop(0)
        km = rig.temp.km(t_base[:, 0] + n * Ts) if rig.temp is not None else np.ones(R)
        noise_i = s.current_noise * rng.standard_normal((R, 2))
        F_noise = np.asarray(s.force_noise) * rng.standard_normal((R, 2))
        F_amb = rig.amb_std * rng.standard_normal(R) if rig.res is not None else 0.0
        i_now = rig.delivered(Z)
        rec["X"][:, n], rec["y"][:, n], rec["u"][:, n], rec["i"][:, n] = X, y, u, i_now
        km_rec[:, n] = km
        X, Z, Fh = rig.period(X, Z, w_old, w_new, km, noise_i, F_noise, F_amb, locked)
        rec["F"][:, n] = Fh
    t = np.arange(N) * Ts
    return Trajectory(t, rec["X"], rec["y"], rec["u"], rec["i"], rec["F"], km_rec, ref)


def _limit(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, -k.i_axis_max, k.i_axis_max)
    amp = np.hypot(u[:, 0], u[:, 1])
    return u * np.where(amp > k.i_amp_max, k.i_amp_max / np.maximum(amp, 1e-12), 1.0)[:, None]


__all__ = ["Rig", "RigSettings", "Trajectory", "simulate"]
