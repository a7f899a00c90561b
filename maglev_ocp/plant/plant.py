"""The plant simulator: the stand-in for the rig.

One CasADi Function per set of switched-on effects integrates the shared model
(composed with the effects of :mod:`maglev_ocp.effects`) over one 1 ms control
period with zero-order hold on the commanded currents, by RK4 with
``integrator.n_sub`` sub-steps (default 10, finer than the controllers' own
models). The effects' parameters, the noise samples, the stop positions and
the lock mask are numeric inputs, so the Function is built once per effect set
and cached. Stops are handled inside the Function after every sub-step
(position clamped, velocity into the stop killed, impact speed reported);
the Python side turns impacts into :class:`StopEvent` s and never raises.

Around the Function, in Python: the current limiter, the computation delay
and the amplifier's transport delay (one buffer of whole samples holding their
sum), the scheduled disturbances (force pulses and steps, a cable and payloads,
:mod:`.disturbances`), the seeded noise streams, the encoder
(measurement noise, then quantization), the locked-axis fixture's constant
reading, and the log (a :class:`~maglev_ocp.riglog.RunLog`).
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import constants as k
from ..blocks import Measurement
from ..effects import EffectSet
from ..errors import ConfigError
from ..model import get_model, rk4
from ..params import NOMINAL, Params
from ..riglog import RunLog
from ..signals import PARAM_NAMES
from .config import PlantConfig
from .disturbances import DisturbanceSchedule, with_payload

_BIG = 1e3  # stop position used when stops are off [m]
_NOISE_BLOCK = 1024  # noise samples drawn at once per stream (same stream whatever the run length)


@dataclass(frozen=True)
class StopEvent:
    """The mover hit a mechanical stop.

    Attributes
    ----------
    t : float
        Time at the end of the control period in which it hit [s].
    axis : str
        ``"g"`` or ``"d"``.
    side : str
        ``"lower"`` or ``"upper"`` end of the axis.
    speed : float
        Impact speed into the stop [m/s] (>= 0).
    """

    t: float
    axis: str
    side: str
    speed: float

    def __str__(self) -> str:
        return f"t = {self.t:.3f} s: {self.axis} hit its {self.side} stop at {self.speed * 1e3:.1f} mm/s"


_SIDES = (("g", "lower"), ("g", "upper"), ("d", "lower"), ("d", "upper"))


@functools.lru_cache(maxsize=32)
def build_step(effects: tuple[str, ...], n_sub: int, dt: float = k.Ts) -> ca.Function:
    """The plant's one-period Function for a set of effects (cached).

    Parameters
    ----------
    effects : tuple of str
        Switched-on effects (any order).
    n_sub : int
        RK4 sub-steps per period.
    dt : float
        Control period [s].

    Returns
    -------
    casadi.Function
        ``(xa, u, p, theta, w, free, lim) -> (xa_next, impact, i_applied)`` where
        ``xa`` is the state (plus the two applied currents if the amplifier lag
        is on), ``u`` the current entering the amplifiers over the period (after
        the limiter and the delay), ``p`` the true model parameters, ``theta``
        the effect parameters, ``w = (F_g, F_d [N], n_q, n_d [A])`` process force
        and current noise held over the period, ``free`` 1/0 per axis (0 =
        locked), ``lim = (g_lo, g_hi, d_lo, d_hi)`` the stops [m]; ``impact``
        the largest speed killed at each stop (same order) and ``i_applied``
        the amplifier output current at the end of the period (noise included).
    """
    es = EffectSet(effects)
    lag = es.has_lag
    nxa = 6 if lag else 4
    xa = ca.SX.sym("xa", nxa)
    u = ca.SX.sym("u", 2)
    p = ca.SX.sym("p", len(PARAM_NAMES))
    th = ca.SX.sym("theta", es.n_theta)
    w = ca.SX.sym("w", 4)
    free = ca.SX.sym("free", 2)
    lim = ca.SX.sym("lim", 4)
    P = dict(zip(PARAM_NAMES, ca.vertsplit(p), strict=True))
    h = dt / n_sub
    noise_i = w[2:4]

    if lag:
        wc = 2 * math.pi * th[es.param_names.index("amplifier_lag.bandwidth_hz")]
        i0 = xa[4:6]

        def applied(t: float) -> ca.SX:
            # first-order lag under ZOH, solved exactly: stable for any bandwidth
            return u + (i0 - u) * ca.exp(-wc * t)
    else:

        def applied(t: float) -> ca.SX:
            return u

    def rhs(xs: ca.SX, t: float) -> ca.SX:
        a = es.accel(xs, applied(t) + noise_i, p, th)
        g_dd = (a[0] + w[0] / P["Mv"]) * free[0]
        d_dd = (a[1] + w[1] / P["Mh"]) * free[1]
        return ca.vertcat(xs[1] * free[0], g_dd, xs[3] * free[1], d_dd)

    xk = xa[0:4]
    impact = [ca.SX(0)] * 4
    for j in range(n_sub):
        xk = rk4(rhs, xk, h, t0=j * h)
        # mechanical stops: clamp the position, kill the velocity into the stop
        pos = [xk[0], xk[2]]
        vel = [xk[1], xk[3]]
        for ax in range(2):
            lo, hi = lim[2 * ax], lim[2 * ax + 1]
            below = pos[ax] < lo
            impact[2 * ax] = ca.fmax(impact[2 * ax], ca.if_else(below, ca.fmax(-vel[ax], 0), 0))
            pos[ax] = ca.if_else(below, lo, pos[ax])
            vel[ax] = ca.if_else(below, ca.fmax(vel[ax], 0), vel[ax])
            above = pos[ax] > hi
            impact[2 * ax + 1] = ca.fmax(impact[2 * ax + 1], ca.if_else(above, ca.fmax(vel[ax], 0), 0))
            pos[ax] = ca.if_else(above, hi, pos[ax])
            vel[ax] = ca.if_else(above, ca.fmin(vel[ax], 0), vel[ax])
        xk = ca.vertcat(pos[0], vel[0], pos[1], vel[1])
    i_end = applied(dt)
    xa_next = ca.vertcat(xk, i_end) if lag else xk
    name = "plant_" + ("_".join(es.names) or "nominal") + f"_{n_sub}"
    return ca.Function(
        name,
        [xa, u, p, th, w, free, lim],
        [xa_next, ca.vertcat(*impact), i_end + noise_i],
        ["xa", "u", "p", "theta", "w", "free", "lim"],
        ["xa_next", "impact", "i_applied"],
        {"cse": True},
    )


class _Normal:
    """Standard-normal draws from one seeded stream, in fixed blocks (deterministic per stream)."""

    def __init__(self, seq: np.random.SeedSequence, dim: int):
        self._rng = np.random.default_rng(seq)
        self._dim = dim
        self._buf = np.empty((0, dim))
        self._i = 0

    def next(self) -> np.ndarray:
        if self._i >= len(self._buf):
            self._buf = self._rng.standard_normal((_NOISE_BLOCK, self._dim))
            self._i = 0
        v = self._buf[self._i]
        self._i += 1
        return v

    def take(self, n: int) -> np.ndarray:
        """The next ``n`` draws as rows of one array (the same values ``n`` calls of :meth:`next` give)."""
        out = np.empty((n, self._dim))
        j = 0
        while j < n:
            if self._i >= len(self._buf):
                self._buf = self._rng.standard_normal((_NOISE_BLOCK, self._dim))
                self._i = 0
            m = min(n - j, len(self._buf) - self._i)
            out[j : j + m] = self._buf[self._i : self._i + m]
            self._i += m
            j += m
        return out


class Plant:
    """The simulated rig, stepped once per 1 ms control period.

    Parameters
    ----------
    config : PlantConfig
        What the rig has (profile, noise, limits, stops, lock, effects, integrator).
    params : Params
        Nominal parameters; the config's mismatch perturbs them into :attr:`true_params`.
    seed : int or numpy.random.SeedSequence
        Seed of every random draw (parameter mismatch, process, current and
        measurement noise: independent streams). Same seed, same data bit for bit.
    Ts : float
        Control period [s].

    Examples
    --------
    >>> plant = Plant(PlantConfig.from_profile("default"), NOMINAL, seed=7)
    >>> y = plant.reset()                        # hovering at 20 mm, d = 0
    >>> y = plant.step([0.0, 1.5])               # one period with i_q = 0, i_d = 1.5 A
    >>> plant.log.table()

    Notes
    -----
    Noise streams: each :meth:`reset` starts run number ``r`` on the ``r``-th
    child of the noise seed, so a run's noise depends only on the seed and the
    run's index, not on how long earlier runs were.
    """

    def __init__(
        self,
        config: PlantConfig | None = None,
        params: Params = NOMINAL,
        seed: int | np.random.SeedSequence = 0,
        Ts: float = k.Ts,
    ):
        self.config = config if config is not None else PlantConfig.from_profile("default")
        self.nominal_params = params
        self.Ts = float(Ts)
        if isinstance(seed, np.random.SeedSequence):
            # copy, so that spawning here never changes the caller's sequence
            ss = np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key, pool_size=seed.pool_size)
        else:
            ss = np.random.SeedSequence(int(seed))
        self.seed_sequence = ss
        ss_params, self._ss_noise = ss.spawn(2)
        self.true_params: Params = self.config.mismatch.apply(params, np.random.default_rng(ss_params))
        self.effects, self.theta = self.config.effect_set()
        self._F = build_step(self.effects.names, self.config.integrator.n_sub, self.Ts)
        self._has_lag = self.effects.has_lag
        # computation delay + amplifier transport delay: one buffer of their sum (PlantConfig.total_delay)
        self._delay = self.config.total_delay()
        self.disturbances = DisturbanceSchedule(list(self.config.disturbances))
        self._mass_now = 0.0  # payload on the mover so far [kg]

        cfg = self.config
        self._lock = cfg.lock.axis
        self._free = np.array([0.0 if self._lock == "g" else 1.0, 0.0 if self._lock == "d" else 1.0])
        st = cfg.stops
        self._lim = np.array([*st.g, *st.d], dtype=float) if st.enabled else np.array([-_BIG, _BIG, -_BIG, _BIG])
        self._q = cfg.quantization.resolution if cfg.quantization.enabled else 0.0
        self._lim_on = cfg.current_limits.enabled
        self._i_axis = cfg.current_limits.axis
        self._i_amp = cfg.current_limits.amplitude
        self._proc_std = np.array([cfg.process_noise.g, cfg.process_noise.d])
        self._cur_std = np.array([cfg.current_noise.i_q, cfg.current_noise.i_d])
        self._meas_std = np.array([cfg.measurement_noise.g, cfg.measurement_noise.d])
        self._proc_on = bool(self._proc_std.any())
        self._cur_on = bool(self._cur_std.any())
        self._meas_on = bool(self._meas_std.any())
        self._stops_on = st.enabled

        # CasADi buffers: evaluating through the buffer API costs ~20 µs instead of ~120 µs per call
        nxa = 6 if self._has_lag else 4
        self._xa = np.zeros(nxa)
        self._u = np.zeros(2)
        self._p = self.true_params.vector()
        self._th = np.asarray(self.theta, dtype=float).copy()
        self._w = np.zeros(4)
        self._xa_out = np.zeros(nxa)
        self._imp = np.zeros(4)
        self._iapp = np.zeros(2)
        buf, self._eval = self._F.buffer()
        for i, a in enumerate((self._xa, self._u, self._p, self._th, self._w, self._free, self._lim)):
            buf.set_arg(i, memoryview(a))
        for i, a in enumerate((self._xa_out, self._imp, self._iapp)):
            buf.set_res(i, memoryview(a))
        self._buf = buf  # keep alive
        self._n_runs = 0
        self._k = -1
        self.events: list[StopEvent] = []

    # ------------------------------------------------------------------ helpers
    def quantize(self, v: float) -> float:
        """Encoder reading of a position: ``round(v / res) * res`` (identity if quantization is off)."""
        q = self._q
        return float(np.round(v / q) * q) if q else float(v)

    def limit(self, u: np.ndarray) -> tuple[np.ndarray, bool]:
        """Current limiter: clip each axis to ±axis, then scale to the amplitude bound.

        Returns the limited currents and whether the limiter acted.
        """
        cq, cd, limited = self._limit(float(u[0]), float(u[1]))
        return np.array([cq, cd]), limited

    def _limit(self, iq: float, id_: float) -> tuple[float, float, bool]:
        if not self._lim_on:
            return iq, id_, False
        a = self._i_axis
        cq, cd = min(max(iq, -a), a), min(max(id_, -a), a)
        amp = math.hypot(cq, cd)
        if amp > self._i_amp:
            s = self._i_amp / amp
            cq, cd = cq * s, cd * s
        return cq, cd, (cq != iq or cd != id_)

    def hover_currents(self, x: np.ndarray) -> np.ndarray:
        """Currents that hold the true (nominal-model) plant still at ``x``.

        A locked axis needs no current (the fixture holds it). Raises
        :class:`~maglev_ocp.errors.ConfigError` if the free gap axis cannot hover
        there (seed eq. (8) has no real root with the true parameters): a NaN
        turned into 0 A would silently drop the mover onto the stop.
        """
        u = np.asarray(get_model().u_eq(x[0], x[2], self._p)).ravel()
        if self._lock == "d":
            u[0] = 0.0
        if self._lock == "g" and not math.isfinite(u[1]):
            u[1] = 0.0
        if not np.all(np.isfinite(u)):
            tp = self.true_params
            raise ConfigError(
                f"plant: the rig cannot hover at g = {x[0] * 1e3:.2f} mm, d = {x[2] * 1e3:.2f} mm: no real hover "
                f"current (seed eq. (8)) with the true parameters C2 = {tp.C2:.6g}, C3 = {tp.C3:.6g}, "
                f"C4 = {tp.C4:.6g}, xi0 = {tp.xi0:.6g}; check plant.params and plant.mismatch"
            )
        return u

    @property
    def t(self) -> float:
        """Time of the latest measurement [s]."""
        return self._k * self.Ts

    @property
    def x(self) -> np.ndarray:
        """True state ``(g, g_dot, d, d_dot)``."""
        return self._xa[:4].copy()

    def draw_noise(self, n: int) -> dict[str, np.ndarray]:
        """Pre-draw the standard-normal samples the next ``n`` steps of this run would use (consumed).

        For a compiled closed loop that runs the steps elsewhere: ``proc`` and ``cur`` (``n x 2``,
        one row per step, process force and current noise) and ``meas`` (``n x 2``, the readings at
        the end of each step); an empty stream (noise off) gives zeros. Call right after :meth:`reset`.
        """
        if self._k < 0:
            raise RuntimeError("call Plant.reset() before Plant.draw_noise()")
        streams = (("proc", self._proc_on, self._n_proc), ("cur", self._cur_on, self._n_cur))
        out = {name: (s.take(n) if on else np.zeros((n, 2))) for name, on, s in streams}
        out["meas"] = self._n_meas.take(n) if self._meas_on else np.zeros((n, 2))
        return out

    # -------------------------------------------------------------------- run
    def reset(self, x0: np.ndarray | None = None, u0: np.ndarray | None = None, lock: str | None = None) -> Measurement:
        """Start a run and return the measurement at t = 0.

        Parameters
        ----------
        x0 : array (4,), optional
            Initial true state; default: at rest at g = 20 mm, d = 0 (or at the lock value).
            A locked axis is put at the lock value (if the config gives one) at rest.
        u0 : array (2,), optional
            Current the amplifiers carry at t = 0 (fills the lag state and the delay
            buffer); default: the hover currents at ``x0`` (the rig was hovering).
        lock : {"none", "g", "d"}, optional
            Fixture for this run, overriding the config's ``lock.axis``; the axis is
            held where ``x0`` puts it. One plant (one set of true parameters) can so
            produce every run of a dataset, locked or free, as on the real rig.
        """
        cfg = self.config
        x = np.array([20e-3, 0.0, 0.0, 0.0]) if x0 is None else np.asarray(x0, dtype=float).reshape(4).copy()
        if lock is not None and lock not in ("none", "g", "d"):
            raise ValueError(f"lock must be 'none', 'g' or 'd', got {lock!r}")
        self._lock = cfg.lock.axis if lock is None else lock
        self._free[:] = [0.0 if self._lock == "g" else 1.0, 0.0 if self._lock == "d" else 1.0]
        if self._lock != "none":
            i = 0 if self._lock == "g" else 2
            if lock is None and cfg.lock.value is not None:
                x[i] = cfg.lock.value
            x[i + 1] = 0.0
        if not np.all(np.isfinite(x)):
            raise ValueError(f"x0 must be finite, got {x}")
        if cfg.stops.enabled:
            for ax, i in (("g", 0), ("d", 2)):
                lo, hi = getattr(cfg.stops, ax)
                if not lo <= x[i] <= hi:
                    raise ValueError(f"x0: {ax} = {x[i]} m is outside the stops [{lo}, {hi}]")
        u_init = self.hover_currents(x) if u0 is None else np.asarray(u0, dtype=float).reshape(2)
        u_init, _ = self.limit(u_init)
        self._xa[:4] = x
        if self._has_lag:
            self._xa[4:6] = u_init
        self._queue: deque[tuple[float, float]] = deque([(u_init[0], u_init[1])] * self._delay)
        if self.disturbances.has_payload:
            self._set_payload(self.disturbances.mass_at(0.0))
        noise = self._ss_noise.spawn(1)[0]
        s_proc, s_cur, s_meas = noise.spawn(3)
        self._n_proc, self._n_cur, self._n_meas = _Normal(s_proc, 2), _Normal(s_cur, 2), _Normal(s_meas, 2)
        self._n_runs += 1
        self._k = 0
        self.events = []
        self._rows: list[tuple[float, ...]] = []
        self._contact = self._at_stops()
        self._y = self._measure()
        return Measurement(
            0.0,
            self._y.copy(),
            x.copy(),
            {"i_q_applied": u_init[0], "i_d_applied": u_init[1], "limited": False, "stop": None},
        )

    def _at_stops(self) -> list[bool]:
        g, d = self._xa[0], self._xa[2]
        lim = self._lim
        return [g <= lim[0], g >= lim[1], d <= lim[2], d >= lim[3]]

    def _measure(self) -> np.ndarray:
        # plain floats: this runs every period and numpy's overhead on 2-vectors dominates
        g, d = float(self._xa[0]), float(self._xa[2])
        if self._meas_on:
            n = self._n_meas.next()
            if self._lock != "g":  # a locked axis reads a constant
                g += self._meas_std[0] * float(n[0])
            if self._lock != "d":
                d += self._meas_std[1] * float(n[1])
        q = self._q
        if q:
            g, d = round(g / q) * q, round(d / q) * q  # half-to-even, as numpy.round
        return np.array([g, d])

    def step(self, u_cmd: np.ndarray) -> Measurement:
        """Apply the commanded currents over one period (ZOH); return the next measurement.

        Parameters
        ----------
        u_cmd : array (2,)
            Commanded ``(i_q, i_d)`` [A]; the limiter clips them first.

        Returns
        -------
        Measurement
            At ``t + Ts``: ``y`` the encoder readings, ``x_true`` the true state,
            ``info`` with ``i_q_applied``, ``i_d_applied`` (amplifier output at
            the end of the period), ``i_q_cmd``, ``i_d_cmd`` (after the limiter),
            ``limited`` (the limiter acted) and ``stop`` (a :class:`StopEvent` or None).
        """
        if self._k < 0:
            raise RuntimeError("call Plant.reset() before Plant.step()")
        iq, id_ = float(u_cmd[0]), float(u_cmd[1])
        if not (math.isfinite(iq) and math.isfinite(id_)):
            raise ValueError(f"commanded currents must be finite, got {u_cmd}")
        cq, cd, limited = self._limit(iq, id_)
        if self._delay:
            self._queue.append((cq, cd))
            u_in = self._queue.popleft()
        else:
            u_in = (cq, cd)
        self._rows.append((self._k * self.Ts, *self._y.tolist(), cq, cd, *self._xa[:4].tolist()))

        self._u[0], self._u[1] = u_in
        if self._proc_on:
            self._w[:2] = self._proc_std * self._n_proc.next()
        if self._cur_on:
            self._w[2:] = self._cur_std * self._n_cur.next()
        if self.disturbances:
            self._apply_disturbances()
        self._eval()
        self._xa[:] = self._xa_out
        self._k += 1
        t = self._k * self.Ts

        stop = None
        imp = self._imp.tolist()
        if imp[0] or imp[1] or imp[2] or imp[3]:
            for j, (axis, side) in enumerate(_SIDES):
                if imp[j] > 0 and not self._contact[j]:
                    ev = StopEvent(t, axis, side, imp[j])
                    self.events.append(ev)
                    stop = stop or ev
            self._contact = self._at_stops()
        elif self._stops_on and (self._contact[0] or self._contact[1] or self._contact[2] or self._contact[3]):
            self._contact = self._at_stops()
        self._y = self._measure()
        ia = self._iapp.tolist()
        info = {
            "i_q_applied": ia[0],
            "i_d_applied": ia[1],
            "i_q_cmd": cq,
            "i_d_cmd": cd,
            "limited": limited,
            "stop": stop,
        }
        return Measurement(t, self._y.copy(), self._xa[:4].copy(), info)

    def _set_payload(self, mass: float) -> None:
        """Make the true parameters those of the mover carrying ``mass`` [kg] of payload (in place)."""
        self._p[:] = with_payload(self.true_params, mass).vector()
        self._mass_now = mass

    def _apply_disturbances(self) -> None:
        """Payload and disturbance forces over the period starting now (held over it, like the process force)."""
        dist, t = self.disturbances, self._k * self.Ts
        if dist.has_payload:
            m = dist.mass_at(t)
            if m != self._mass_now:
                self._set_payload(m)
        if dist.has_force:
            fg, fd = dist.force(t, self._xa)
            if not self._proc_on:
                self._w[:2] = 0.0
            self._w[0] += fg
            self._w[1] += fd

    @property
    def payload_mass(self) -> float:
        """Payload mass carried by the mover now [kg] (0 without payload disturbances)."""
        return self._mass_now

    @property
    def params_now(self) -> Params:
        """True parameters right now (the payload put on so far included)."""
        return Params.from_vector(self._p)

    # -------------------------------------------------------------------- log
    @property
    def log(self) -> RunLog:
        """The run so far: ``t, g, d, i_q, i_d`` (commanded, after the limiter) and the true state.

        Row ``k`` holds the reading at ``t_k`` and the command applied from ``t_k``.
        """
        names = ("t", "g", "d", "i_q", "i_d", "g_true", "g_dot_true", "d_true", "d_dot_true")
        rows = getattr(self, "_rows", [])
        arr = np.array(rows, dtype=float).reshape(len(rows), len(names))
        cols = {n: arr[:, j].copy() for j, n in enumerate(names)}
        order = ("t", "g", "d", "i_q", "i_d", "g_true", "d_true", "g_dot_true", "d_dot_true")
        locked = () if self._lock == "none" else (self._lock,)
        return RunLog("run.csv", {n: cols[n] for n in order}, locked)

    def dataset_meta(self) -> dict:
        """What a dataset written from this plant should record: config, nominal and true parameters."""
        return {
            "plant": self.config.to_dict(),
            "nominal_params": self.nominal_params.as_dict(),
            "true_params": self.true_params.as_dict(),
        }

    def summary(self) -> str:
        """Text view: settings, true parameters and stop events."""
        tp = self.true_params
        lines = [self.config.table(), "true parameters: " + ", ".join(f"{n}={getattr(tp, n):.6g}" for n in PARAM_NAMES)]
        lines += [f"stop event: {e}" for e in self.events] or ["stop events: none"]
        return "\n".join(lines)


__all__ = ["Plant", "StopEvent", "build_step"]
