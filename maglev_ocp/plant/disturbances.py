"""Disturbances a rig sees, scheduled in the plant: force pulses and steps, a payload, a cable.

Settings (``plant: {disturbances: [...]}`` in a scenario or a plant file), each
validated on load (SI units)::

    disturbances:
      - {type: force_pulse, axis: g, amplitude: 30.0, start: 0.5, duration: 0.02}
      - {type: force_step, axis: d, amplitude: -5.0, start: 1.0}
      - {type: payload, mass: 0.5, time: 0.8}
      - {type: cable, stiffness_d: 200.0, rest_d: 0.0, damping_d: 2.0, weight_g: 1.0}

Sign conventions are those of the model (``shared/spec/MODEL.md``): a force on
``g`` is positive when it opens the gap (it pushes the mover down, along
gravity), a force on ``d`` is positive along ``+d``. Forces enter the plant like
its process noise: evaluated at the start of each 1 ms period and held over it
(an acceleration ``F / Mv`` on the gap axis, ``F / Mh`` on ``d``, seed eq. (2)).

A payload of mass ``m`` put on the mover at ``time`` makes it heavier on both
axes. The model's constants are accelerations per unit current (``C_i`` are the
forces divided by the moving mass, seed eq. (2)), so the magnetic terms scale
by ``M / (M + m)`` while gravity stays ``G``: ``C2, C3, C4`` by ``Mv / (Mv + m)``,
``C1`` by ``Mh / (Mh + m)``, and ``Mv``, ``Mh`` grow by ``m`` (which divides the
cogging, friction and disturbance forces). The hover current rises accordingly.

A cable dragged by the mover pulls it back towards where it hangs free:
``F_d = -stiffness_d (d - rest_d) - damping_d d_dot`` and on the gap
``F_g = weight_g - stiffness_g (g - rest_g) - damping_g g_dot``, evaluated from
the true state at the start of each period and held over it (the stiffness and
damping limits keep ``sqrt(k / M) Ts`` and ``c Ts / M`` below 0.1, where holding
them is accurate).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from ..config import Strict
from ..params import Params

_F_MAX = 500.0  # largest force amplitude accepted [N] (the magnets pull ~40 N)
_T_MAX = 3600.0  # latest start time accepted [s]


class ForcePulse(Strict):
    """A force of constant ``amplitude`` on one axis from ``start`` for ``duration`` (a push, a knock)."""

    type: Literal["force_pulse"]
    axis: Literal["g", "d"] = Field(description="axis it acts on: g (positive opens the gap) or d (positive along +d)")
    amplitude: float = Field(ge=-_F_MAX, le=_F_MAX, description="force [N]")
    start: float = Field(ge=0, le=_T_MAX, description="when it starts [s]")
    duration: float = Field(gt=0, le=_T_MAX, description="how long it lasts [s]")

    def active(self, t: float) -> bool:
        """Whether it acts over the period that starts at ``t`` [s]."""
        return self.start <= t + 1e-12 < self.start + self.duration


class ForceStep(Strict):
    """A force of constant ``amplitude`` on one axis from ``start`` to the end of the run (a load put on)."""

    type: Literal["force_step"]
    axis: Literal["g", "d"] = Field(description="axis it acts on: g (positive opens the gap) or d (positive along +d)")
    amplitude: float = Field(ge=-_F_MAX, le=_F_MAX, description="force [N]")
    start: float = Field(ge=0, le=_T_MAX, description="when it starts [s]")

    def active(self, t: float) -> bool:
        """Whether it acts over the period that starts at ``t`` [s]."""
        return self.start <= t + 1e-12


class Payload(Strict):
    """A mass put on the mover at ``time``: both moving masses grow by ``mass`` (see the module docstring)."""

    type: Literal["payload"]
    mass: float = Field(gt=0, le=20, description="added mass [kg]")
    time: float = Field(ge=0, le=_T_MAX, description="when it is put on [s]")


class Cable(Strict):
    """A cable dragged by the mover: spring and drag on d (and on g), plus its hanging weight on g."""

    type: Literal["cable"]
    start: float = Field(0.0, ge=0, le=_T_MAX, description="when it is attached [s]")
    stiffness_d: float = Field(0.0, ge=0, le=1e4, description="spring rate along d [N/m]")
    rest_d: float = Field(0.0, ge=-1, le=1, description="position where it pulls nothing along d [m]")
    damping_d: float = Field(0.0, ge=0, le=100, description="drag along d [N s/m]")
    stiffness_g: float = Field(0.0, ge=0, le=1e4, description="spring rate on the gap [N/m]")
    rest_g: float = Field(0.020, ge=0, le=0.1, description="gap where it pulls nothing on g [m]")
    damping_g: float = Field(0.0, ge=0, le=100, description="drag on the gap [N s/m]")
    weight_g: float = Field(0.0, ge=-50, le=50, description="constant force on g, its hanging weight [N] (> 0 opens)")

    def force(self, x: np.ndarray) -> tuple[float, float]:
        """``(F_g, F_d)`` [N] at the true state ``x = (g, g_dot, d, d_dot)``."""
        fg = self.weight_g - self.stiffness_g * (x[0] - self.rest_g) - self.damping_g * x[1]
        fd = -self.stiffness_d * (x[2] - self.rest_d) - self.damping_d * x[3]
        return float(fg), float(fd)


Disturbance = Annotated[ForcePulse | ForceStep | Payload | Cable, Field(discriminator="type")]


def with_payload(params: Params, mass: float) -> Params:
    """The parameters of the mover carrying ``mass`` [kg] more (see the module docstring).

    ``C2, C3, C4`` scale by ``Mv / (Mv + m)``, ``C1`` by ``Mh / (Mh + m)``;
    ``Mv`` and ``Mh`` grow by ``m``; gravity (a constant of the model) does not change.
    """
    if mass == 0:
        return params
    rv = params.Mv / (params.Mv + mass)
    rh = params.Mh / (params.Mh + mass)
    return params.with_(
        C1=params.C1 * rh,
        C2=params.C2 * rv,
        C3=params.C3 * rv,
        C4=params.C4 * rv,
        Mv=params.Mv + mass,
        Mh=params.Mh + mass,
    )


class DisturbanceSchedule:
    """What the scheduled disturbances do over one run (used by :class:`~maglev_ocp.plant.Plant`).

    Parameters
    ----------
    items : list of disturbance settings
        :class:`ForcePulse`, :class:`ForceStep`, :class:`Payload`, :class:`Cable`.
    """

    def __init__(self, items: list) -> None:
        self.forces = [d for d in items if isinstance(d, ForcePulse | ForceStep)]
        self.payloads = sorted((d for d in items if isinstance(d, Payload)), key=lambda d: d.time)
        self.cables = [d for d in items if isinstance(d, Cable)]
        self.has_force = bool(self.forces or self.cables)
        self.has_payload = bool(self.payloads)

    def __bool__(self) -> bool:
        return self.has_force or self.has_payload

    def force(self, t: float, x: np.ndarray) -> tuple[float, float]:
        """Total ``(F_g, F_d)`` [N] over the period starting at ``t`` with true state ``x``."""
        fg = fd = 0.0
        for f in self.forces:
            if f.active(t):
                if f.axis == "g":
                    fg += f.amplitude
                else:
                    fd += f.amplitude
        for c in self.cables:
            if c.start <= t + 1e-12:
                cg, cd = c.force(x)
                fg, fd = fg + cg, fd + cd
        return fg, fd

    def mass_at(self, t: float) -> float:
        """Payload mass on the mover over the period starting at ``t`` [kg]."""
        return math.fsum(p.mass for p in self.payloads if p.time <= t + 1e-12)

    def params_at(self, base: Params, t: float) -> Params:
        """True parameters over the period starting at ``t`` (``base`` with the payload on so far)."""
        return with_payload(base, self.mass_at(t))


def persistent_loads(items: list) -> list[tuple[int, float, float, Callable[[float], float]]]:
    """The gap-axis loads that stay on, at each time they change: what the mover must then hover under.

    Parameters
    ----------
    items : list of disturbance settings

    Returns
    -------
    list of (index, time, payload, extra_g)
        For each payload, force step on ``g`` and cable (``index`` in ``items``),
        at its ``time`` [s]: the payload carried from then [kg] and the
        constant force on ``g`` from then as a function of the gap,
        ``extra_g(g) -> F_g`` [N] (force steps plus the cable's weight and
        spring; pulses end, so they are not loads).
    """
    events = []
    for i, d in enumerate(items):
        if isinstance(d, Payload):
            events.append((i, d.time))
        elif isinstance(d, ForceStep) and d.axis == "g":
            events.append((i, d.start))
        elif isinstance(d, Cable) and (d.weight_g or d.stiffness_g):
            events.append((i, d.start))
    out = []
    for i, t in sorted(events, key=lambda e: e[1]):
        on = [d for d in items if _on_by(d, t)]
        mass = math.fsum(d.mass for d in on if isinstance(d, Payload))
        steps = math.fsum(d.amplitude for d in on if isinstance(d, ForceStep) and d.axis == "g")
        cables = [d for d in on if isinstance(d, Cable)]

        def extra_g(g: float, steps: float = steps, cables: list = cables) -> float:
            return steps + math.fsum(c.weight_g - c.stiffness_g * (g - c.rest_g) for c in cables)

        out.append((i, t, mass, extra_g))
    return out


def _on_by(d, t: float) -> bool:
    if isinstance(d, Payload):
        return d.time <= t
    if isinstance(d, ForceStep | Cable):
        return d.start <= t
    return False


__all__ = [
    "Cable",
    "Disturbance",
    "DisturbanceSchedule",
    "ForcePulse",
    "ForceStep",
    "Payload",
    "persistent_loads",
    "with_payload",
]
