"""A scenario's reference: one planned move per target (:class:`ReferencePlan`, :func:`plan_targets`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import constants as k
from ..blocks import Reference
from ..errors import ConfigError
from ..params import NOMINAL, Params
from .feasibility import PlanEffects
from .min_time import plan_min_time_move
from .profiles import Move
from .settings import ReferenceSettings
from .trajectory import plan_move


@dataclass(frozen=True)
class Target:
    """A positioning target held for ``hold`` seconds."""

    g: float
    d: float
    hold: float


@dataclass
class ReferencePlan:
    """Reference over a whole scenario: one move per target, each starting at the target's switch time.

    Attributes
    ----------
    targets : list of Target
        Targets in order.
    switch_times : ndarray
        Time at which each target becomes active [s].
    moves : list of Move
        The planned move to each target (duration 0 with ``shaping: step``).
    shaping : str
        ``trajectory`` or ``step``.
    """

    targets: list[Target]
    switch_times: np.ndarray
    moves: list[Move]
    shaping: str = "trajectory"
    start: tuple[float, float] = (0.020, 0.0)
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def duration(self) -> float:
        """End of the last hold [s]."""
        return float(self.switch_times[-1] + self.targets[-1].hold)

    def target_index(self, t: float) -> int:
        """Index of the target active at time ``t``."""
        return int(np.clip(np.searchsorted(self.switch_times, t, side="right") - 1, 0, len(self.targets) - 1))

    def sample(self, t: np.ndarray, zoh: float | None = None) -> np.ndarray:
        """Reference rows (g, g_dot, g_ddot, d, d_dot, d_ddot) at times ``t`` (array (n, 6)).

        Parameters
        ----------
        t : ndarray
            Times [s].
        zoh : float, optional
            If given (the control period), the accelerations are the reference's
            MEAN acceleration over ``[t, t + zoh]``, ``(v(t + zoh) - v(t)) / zoh``:
            the constant acceleration a zero-order-held current must produce for
            the reference velocity to be met at the next sample. The instantaneous
            acceleration at ``t`` lags that by half a period, which during the
            acceleration ramps of a fast move costs tens of micrometres of tracking.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = self._sample(t)
        if zoh:
            ahead = self._sample(t + zoh)
            out[:, 2] = (ahead[:, 1] - out[:, 1]) / zoh
            out[:, 5] = (ahead[:, 4] - out[:, 4]) / zoh
        return out

    def _sample(self, t: np.ndarray) -> np.ndarray:
        out = np.empty((len(t), 6))
        idx = np.clip(np.searchsorted(self.switch_times, t, side="right") - 1, 0, len(self.targets) - 1)
        before = t < self.switch_times[0]
        for i in np.unique(idx):
            sel = idx == i
            out[sel] = self.moves[i].sample(t[sel])
        if before.any():
            out[before] = [self.start[0], 0, 0, self.start[1], 0, 0]
        return out

    def at(self, t: float, zoh: float | None = k.Ts) -> Reference:
        """The :class:`~maglev_ocp.blocks.Reference` at time ``t``.

        Its accelerations are the mean over the coming control period ``zoh``
        (see :meth:`sample`; ``zoh=None`` for the instantaneous ones): what the
        runner hands every controller.
        """
        r = self.sample(np.array([t]), zoh)[0]
        return Reference(g=r[0], d=r[3], g_dot=r[1], d_dot=r[4], g_ddot=r[2], d_ddot=r[5])

    def table(self) -> str:
        """One line per target: switch time, target and planned move duration."""
        lines = [f"{'#':>3} {'t_switch [s]':>12} {'g [mm]':>8} {'d [mm]':>8} {'hold [s]':>8} {'move [s]':>9}"]
        for i, (tg, ts, mv) in enumerate(zip(self.targets, self.switch_times, self.moves, strict=True)):
            lines.append(f"{i:3d} {ts:12.3f} {tg.g * 1e3:8.3f} {tg.d * 1e3:8.3f} {tg.hold:8.3f} {mv.T:9.4f}")
        return "\n".join(lines)


def plan_targets(
    start: Sequence[float],
    targets: Sequence[Target],
    params: Params = NOMINAL,
    settings: ReferenceSettings | None = None,
    t_start: float = 0.0,
    source: str = "targets",
    effects: PlanEffects | None = None,
) -> ReferencePlan:
    """Plan the reference of a scenario: from ``start`` through every target in order.

    Parameters
    ----------
    start : sequence of float
        Initial ``(g, d)`` [m] (the mover at rest there).
    targets : sequence of Target
        Targets, each active for its ``hold``.
    params : Params
        The controller's model (moves are planned on what the controller believes).
    settings : ReferenceSettings
        Shaping options.
    t_start : float
        Switch time of the first target [s].
    source : str
        Name used in error messages (e.g. ``scenario.yaml: targets``).
    effects : PlanEffects, optional
        The static effects of the controller's model file (the moves' currents
        are checked on the model with them).

    Raises
    ------
    ConfigError
        If a planned move does not fit in its target's hold.
    """
    st = settings or ReferenceSettings()
    if not targets:
        raise ConfigError(f"{source}: at least one target is needed")
    t = t_start
    prev = (float(start[0]), float(start[1]))
    moves, switch = [], []
    for i, tg in enumerate(targets):
        if st.shaping == "step":
            mv = Move(t, 0.0, (tg.g, tg.d), (tg.g, tg.d), st.ramp_fraction)
        else:
            plan = plan_min_time_move if st.shaping == "min_time" else plan_move
            try:
                mv = plan(prev, (tg.g, tg.d), params, st, t0=t, effects=effects)
            except ConfigError as err:
                raise ConfigError(f"{source}[{i}]: {err}") from None
            if mv.T >= tg.hold:
                raise ConfigError(
                    f"{source}[{i}].hold: the planned move takes {mv.T:.3f} s, not less than the hold "
                    f"{tg.hold:.3f} s (lengthen the hold or raise reference.current_fraction)"
                )
        moves.append(mv)
        switch.append(t)
        t += tg.hold
        prev = (tg.g, tg.d)
    return ReferencePlan(list(targets), np.array(switch), moves, st.shaping, (float(start[0]), float(start[1])))
