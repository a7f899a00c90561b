"""The seventh law set's mark and its two effects outside the library (issue 27, ``laws="v7"``; see :mod:`.laws_v7`).

Written from their sources only, without reading the diagnosis or how it fits (the blindness rule of issue 27's
pre-registered check); each source is cited in the class docstring and in ``docs/validation/rigsim-laws.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import constants as k
from .laws import Law


class _V7:
    """Mixin: marks a law of the seventh set in its truth record."""

    new_law: ClassVar[bool] = True
    has_rotate_at: ClassVar[bool] = False
    has_read_at: ClassVar[bool] = False
    has_factors_i: ClassVar[bool] = False
    has_advance: ClassVar[bool] = False
    has_force_i: ClassVar[bool] = False

    def describe(self) -> dict[str, Any]:  # type: ignore[misc]
        """Family and parameters, for the truth record (with ``law_set = "v7"``)."""
        return {**super().describe(), "law_set": "v7"}  # type: ignore[misc]


def _per_run(v: np.ndarray, x) -> np.ndarray:
    """``v`` (one value per run) shaped to broadcast against ``x`` (runs along its first axis); the first run's value
    where ``x`` has no run axis of that length (a call outside a simulation of ``v.size`` runs)."""
    x = np.asarray(x)
    if x.ndim == 0 or x.shape[0] != v.shape[0]:
        return np.asarray(v[0] if v.size else 0.0)
    return v.reshape(v.shape + (1,) * (x.ndim - 1))


# --------------------------------------------------------------------- out of the library
class PayloadSwap(_V7, Law):
    """A rigid payload that is on the mover in some runs and not in others (not in the library).

    Between the runs of a dataset a payload of mass ``m_p`` (a sample holder, a tool) is put on the mover and
    taken off again: it is on in every other run, from run ``first`` (0 or 1) on. With the payload the moving
    masses are ``Mv + m_p`` and ``Mh + m_p``; Newton's second law for the loaded mover (the payload rides rigidly,
    its weight ``m_p G`` on the gap axis), ``(Mv + m_p) g'' = (Mv + m_p) G - Mv a_up + ...``, divides the magnetic
    accelerations of seed eq. (2) by ``1 + m_p / Mv`` (gap) and ``1 + m_p / Mh`` (thrust) while gravity stays ``G``
    (Meriam & Kraige, "Engineering Mechanics: Dynamics", 7th ed., Wiley 2012, ch. 4: a system of particles moving
    together). Hook ``factors``: ``rho *= s_v = Mv / (Mv + m_p)`` and ``thrust *= s_h / s_v``, ``s_h = Mh / (Mh +
    m_p)``, per run (nominal masses). The other forces (friction, seed eq. (9)'s cogging, noise) keep their
    division by the unloaded mass: an error of ``m_p / Mv`` (a few %) of those forces, left in.
    """

    name = "payload_swap"
    library = False
    families = ("alternate_runs",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {"alternate_runs": {"m_p": 0.2, "first": 1.0}}
    has_factors = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.mass = np.zeros(0)

    def masses(self, n_runs: int) -> np.ndarray:
        """Payload [kg] of each of ``n_runs`` runs: ``m_p`` in runs ``first, first + 2, ...``."""
        r = np.arange(n_runs)
        first = round(self.p["first"])
        return self.p["m_p"] * (((r - first) % 2 == 0) & (r >= first))

    def reset(self, n_runs: int) -> None:
        """The payload per run (:meth:`masses`)."""
        self.mass = self.masses(n_runs)

    def factors(self, g, d, f: list) -> None:
        """Divide the magnetic accelerations by the loaded masses (per run)."""
        m = _per_run(self.mass, g)
        s_v, s_h = k.Mv / (k.Mv + m), k.Mh / (k.Mh + m)
        f[2] = f[2] * s_v
        f[3] = f[3] * s_h / s_v


class FlexiblePayload(_V7, Law):
    """A payload on a compliant mount on the mover: a mode of the mover itself (not in the library).

    A payload of mass ``m_p`` sits on a mount of stiffness ``k_a = m_p (2 pi f_a)^2`` and damping ``c_a = 2 zeta
    sqrt(k_a m_p)`` per axis (``a`` = g, d): a two-mass system whose second mass is carried by the first (Den
    Hartog, "Mechanical Vibrations", 4th ed., McGraw-Hill 1956, ch. 3, the dynamic absorber; for a motion stage:
    Schmidt, Schitter & Rankers, "The Design of High Performance Mechatronics", 2nd ed., IOS Press 2014, the
    non-rigid body modes of a moving mass). With ``z = x_p - x`` the payload's deflection and ``w`` its absolute
    velocity: ``z' = w - v``, ``m_p w' = -k_a z - c_a (w - v) + m_p G_a`` (``G_a = G`` on the gap axis, whose
    positive sense is down, 0 along d); the mover feels ``F_a = k_a z + c_a (w - v)`` (the payload's weight at
    rest on the gap axis, ``m_p G``). The state starts at rest at the static deflection and is advanced exactly
    per sub-step for the held velocity ``v`` of the mover (hook ``held``; the force is the sub-step's mean of its
    start and end values).
    """

    name = "flexible_payload"
    library = False
    families = ("tool_mount",)
    DEFAULTS: ClassVar[dict[str, dict[str, float]]] = {
        "tool_mount": {"m_p": 0.1, "f_g": 30.0, "f_d": 25.0, "zeta": 0.03}
    }
    has_held = True

    def __init__(self, family: str | None = None, **params: float):
        super().__init__(family, **params)
        self.state = np.zeros((0, 2, 2))
        self._maps: dict[float, list[tuple[np.ndarray, np.ndarray]]] = {}

    def stiffness(self, axis: int) -> tuple[float, float]:
        """``(k_a, c_a)`` of axis ``axis`` (0: g, 1: d)."""
        p = self.p
        w = 2 * math.pi * (p["f_g"] if axis == 0 else p["f_d"])
        return p["m_p"] * w * w, 2.0 * p["zeta"] * p["m_p"] * w

    def reset(self, n_runs: int) -> None:
        """Payload at rest on its mount: ``z = m_p G / k_g`` on the gap axis."""
        self.state = np.zeros((n_runs, 2, 2))
        self.state[:, 0, 0] = self.p["m_p"] * k.G / self.stiffness(0)[0]

    def _map(self, h: float):
        """Exact maps ``[z, w](h) = Ad [z, w](0) + Bd [v, G_a]`` per axis (inputs held)."""
        if h not in self._maps:
            from scipy.linalg import expm

            out = []
            for ax in (0, 1):
                ka, ca = self.stiffness(ax)
                m = self.p["m_p"]
                M = np.zeros((4, 4))
                M[0, :] = [0.0, 1.0, -1.0, 0.0]
                M[1, :] = [-ka / m, -ca / m, ca / m, 1.0]
                E = expm(M * h)
                out.append((E[:2, :2], E[:2, 2:]))
            self._maps[h] = out
        return self._maps[h]

    def mount_force(self, z, w, v, axis: int):
        """Force of the mount on the mover [N]."""
        ka, ca = self.stiffness(axis)
        return ka * z + ca * (w - v)

    def held(self, gd, dd, h: float):
        """Advance the payload over ``h`` at the mover's velocities; return the mount's mean force over it."""
        maps = self._map(float(h))
        out = []
        for ax, v in enumerate((gd, dd)):
            v = np.asarray(v, dtype=float)
            z0, w0 = self.state[:, ax, 0], self.state[:, ax, 1]
            f0 = self.mount_force(z0, w0, v, ax)
            Ad, Bd = maps[ax]
            u = np.column_stack([v, np.full_like(v, k.G if ax == 0 else 0.0)])
            s1 = self.state[:, ax, :] @ Ad.T + u @ Bd.T
            self.state[:, ax, :] = s1
            out.append(0.5 * (f0 + self.mount_force(s1[:, 0], s1[:, 1], v, ax)))
        return out[0], out[1]


__all__ = ["FlexiblePayload", "PayloadSwap"]
