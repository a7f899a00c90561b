"""Stage 2b of the step: the reference over the horizon and its feed-forward currents.

Symbolic part (in the step Function): :func:`fn_node` gives, per shooting node,
the reference state (from the internal move plan in ``plan`` mode, from the
``ref`` input in ``preview`` mode) and the currents that produce its
accelerations on the disk. Numeric part (in Python, around the call):
:class:`HorizonReference` fills the ``ref`` input, rows
:data:`maglev_ocp.signals.REF_FIELDS`, one column per node.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from maglev_ocp.blocks import Reference
from maglev_ocp.signals import REF_FIELDS

from .design import StepDesign
from .planner import move_at
from .prediction import u_feedforward
from .qp import project_disk

N_REF = len(REF_FIELDS)  #: rows of the ``ref`` input


def fn_node(d: StepDesign) -> ca.Function:
    """Reference node (SX, mapped over the horizon): ``(dt, plan, refcol, p, w) -> (r, uref)``."""
    s, m = d.settings, d.model
    dt, plan, rc, p, w = (
        ca.SX.sym("dt"),
        ca.SX.sym("plan", 7),
        ca.SX.sym("refcol", N_REF),
        ca.SX.sym("p", m.np_),
        ca.SX.sym("w", 2),
    )
    g_s, d_s, g_t, d_t, t0, h, tj = (plan[i] for i in range(7))
    if d.mode == "plan":
        pg, vg, ag = move_at(t0 + dt, g_t - g_s, h, tj)
        pd, vd, ad = move_at(t0 + dt, d_t - d_s, h, tj)
        r, a = ca.vertcat(g_s + pg, vg, d_s + pd, vd), ca.vertcat(ag, ad)
    else:
        r, a = ca.vertcat(rc[0], rc[1], rc[3], rc[4]), ca.vertcat(rc[2], rc[5])
    uref = project_disk(u_feedforward(d, r, a, p, w), s.current_limit, s.i_box)
    return ca.Function(
        "nmpc_node",
        [dt, plan, rc, p, w],
        [r, uref],
        ["dt", "plan", "refcol", "p", "w"],
        ["r", "uref"],
        {"cse": True},
    )


def resolve_mode(setting: str, shaping: str | None) -> str:
    """The reference mode a step is built for: the setting ``reference``, ``auto`` resolved.

    ``auto`` is ``preview`` when the runner gives a trajectory plan (``shaping``
    other than ``step``), else ``plan``; ``shaping=None``: no runner plan (e.g. a
    bare rig log).
    """
    if setting == "auto":
        return "preview" if (shaping is not None and shaping != "step") else "plan"
    return setting


class HorizonReference:
    """The ``ref`` input of the step: the reference at ``t + j Ts``, ``j = 0..N`` (rows :data:`REF_FIELDS`).

    Parameters
    ----------
    horizon : int
        Number of shooting intervals ``N``.
    Ts : float
        Control period [s].
    """

    CHUNK = 512  #: periods of the runner's plan sampled at once (the plan is read ahead in blocks)

    def __init__(self, horizon: int, Ts: float, period_mean: bool = False):
        self.N, self.Ts = horizon, Ts
        self.period_mean = period_mean
        self.plan = None
        self._cache: tuple[int, np.ndarray] | None = None

    def set_plan(self, plan) -> None:
        """Read ahead from the runner's plan (a :class:`maglev_ocp.reference.ReferencePlan`), or ``None``."""
        self.plan = plan
        self._cache = None

    def clear_cache(self) -> None:
        """Forget the sampled block (at reset)."""
        self._cache = None

    def resolve_mode(self, setting: str) -> str:
        """``plan``/``preview`` for the setting ``reference`` given the runner's plan (:func:`resolve_mode`)."""
        return resolve_mode(setting, None if self.plan is None else getattr(self.plan, "shaping", "trajectory"))

    def matrix(self, mode: str, t: float, ref: Reference, ahead: int = 0) -> np.ndarray:
        """Reference input of the step at time ``t``: ``N_REF`` rows, one column per node.

        ``ahead``: the step optimises from the state ``ahead`` periods on (its
        computation delay), so in ``preview`` mode with a runner plan the
        columns are read from ``t + ahead Ts`` on.
        """
        N, Ts = self.N, self.Ts
        if mode == "plan":
            if self.plan is not None:
                tg = self.plan.targets[self.plan.target_index(t)]
                g, d = tg.g, tg.d
            else:
                g, d = ref.g, ref.d
            out = np.zeros((N_REF, N + 1))
            out[0, :], out[3, :] = g, d
            return out
        if self.plan is not None:
            return self._preview(t + ahead * Ts)
        s = Ts * np.arange(N + 1)
        return np.vstack(
            [
                ref.g + ref.g_dot * s + ref.g_ddot * s**2 / 2,
                ref.g_dot + ref.g_ddot * s,
                np.full(N + 1, ref.g_ddot),
                ref.d + ref.d_dot * s + ref.d_ddot * s**2 / 2,
                ref.d_dot + ref.d_ddot * s,
                np.full(N + 1, ref.d_ddot),
            ]
        )

    def _preview(self, t: float) -> np.ndarray:
        """The runner's plan at ``t + j Ts``, held at its value just before the next target switch.

        The accelerations are the plan's instantaneous ones at ``t_j``, or with
        ``period_mean`` (``NMPCSettings.feedforward: period_mean``) its mean over
        each period (:meth:`maglev_ocp.reference.ReferencePlan.sample` with
        ``zoh``), as the runner hands them to every controller: the feed-forward
        current held over stage ``j`` must produce the mean acceleration of
        ``[t_j, t_j + Ts]`` for the node velocities to be met. The instantaneous
        acceleration lags that by half a period: during a move's jerk phases the
        QP's input reference then contradicts its state reference and the mover
        trails the plan by tens of micrometres (40 um at the acceleration ramps
        of the tour's 100 mm moves, 24 um left at their end).
        No preview across a target switch: the current target is held until it
        comes. The plan is sampled on the period grid in blocks (cached), so a
        step costs a slice, not a plan evaluation.
        """
        N, Ts, plan = self.N, self.Ts, self.plan
        kk = round(t / Ts)
        c = self._cache
        if c is None or not (c[0] <= kk and kk + N < c[0] + len(c[1])):
            grid = (kk + np.arange(self.CHUNK + N + 1)) * Ts
            c = self._cache = (kk, plan.sample(grid, zoh=Ts if self.period_mean else None))
        cols = c[1][kk - c[0] : kk - c[0] + N + 1].copy()
        sw = np.asarray(getattr(plan, "switch_times", []), dtype=float)
        later = sw[sw > t + 1e-9]
        if later.size:
            cut = (kk + np.arange(N + 1)) * Ts >= later[0] - 1e-9
            if cut.any():
                cols[cut] = plan.sample(np.array([later[0] - 1e-9]))[0]
        return cols.T


__all__ = ["N_REF", "HorizonReference", "fn_node", "resolve_mode"]
