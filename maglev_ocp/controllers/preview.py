"""The reference plan read ahead by a delay: what a controller's command computed now must meet when it acts.

A command computed at ``t`` reaches the mover ``N`` control periods later when the
amplifiers (or the computation) delay it by ``N`` samples (a model file's amplifier
lag, ``delay_samples``). A feed-forward computed from the reference at ``t`` then
arrives late by ``N Ts``: on a move at 1 m/s, a one-period delay leaves the mover
1 mm behind what the feed-forward asked, which the feedback has to catch up. Read
from the plan at ``t + N Ts`` instead, the feed-forward arrives when it is needed.
:class:`PlanPreview` samples the plan once on the control grid (not inside a timed
step) and looks the rows up; the FL's predictor and the PID's feed-forward read it.
"""

from __future__ import annotations

import numpy as np

from maglev_ocp import constants as k


class PlanPreview:
    """A reference plan's rows ``lead`` control periods ahead of each step's time.

    Parameters
    ----------
    plan : ReferencePlan
        The run's plan (:class:`maglev_ocp.reference.ReferencePlan`: ``duration`` and ``sample(t, zoh)``).
    lead : float
        How many control periods ahead [samples] (a fraction too: the plan is sampled there).
    Ts : float
        Control period [s].
    """

    def __init__(self, plan, lead: float, Ts: float = k.Ts):
        self.plan, self.lead, self.Ts = plan, float(lead), float(Ts)
        n = round(plan.duration / self.Ts) + 1
        # the accelerations as the zero-order hold needs them (mean over the period), as the runner's rows
        self.rows = plan.sample(np.arange(n) * self.Ts + self.lead * self.Ts, zoh=self.Ts)

    def at(self, t: float) -> tuple[float, ...]:
        """The plan's row ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` at ``t + lead Ts`` (looked up on the grid)."""
        i = round(t / self.Ts)
        if 0 <= i < len(self.rows) and abs(i * self.Ts - t) < 1e-9:
            return tuple(self.rows[i])
        return tuple(self.plan.sample(np.array([t + self.lead * self.Ts]), zoh=self.Ts)[0])


__all__ = ["PlanPreview"]
