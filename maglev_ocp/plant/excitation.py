"""Sum-of-sines references, the seed's excitation for identification (section IV).

The seed makes "the horizontal and vertical dynamics track a suitable reference
signal made of a summation of sinusoids at various frequencies" to guarantee
persistency of excitation. :class:`SumOfSines` is that reference, with random
phases drawn from a seed, a smooth fade-in (so the run starts at rest on the
centre) and analytic first and second derivatives for feedforward.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pydantic import Field, field_validator

from ..blocks import Reference
from ..config import Strict


class AxisExcitation(Strict):
    """Sum of sines on one axis: ``center + fade(t) * sum_i (amplitude / n) sin(2 pi f_i t + phi_i)``."""

    center: float = Field(ge=-0.1, le=0.1)
    amplitude: float = Field(ge=0, le=0.1)
    freqs_hz: list[float] = Field(min_length=1, max_length=32)

    @field_validator("freqs_hz")
    @classmethod
    def _freqs(cls, v: list[float]) -> list[float]:
        if any(not (0 < f <= 50) or not math.isfinite(f) for f in v):
            raise ValueError("frequencies must be in (0, 50] Hz")
        return v


class ExcitationSettings(Strict):
    """Both axes of a sum-of-sines excitation and its fade-in time [s].

    The default sweeps the gap 20 ± 4 mm and the position ± 30 mm slowly, as
    the seed's PID regulators can follow (they need not track it accurately).
    """

    g: AxisExcitation = AxisExcitation(center=20e-3, amplitude=4e-3, freqs_hz=[0.07, 0.19, 0.37, 0.61])
    d: AxisExcitation = AxisExcitation(center=0.0, amplitude=30e-3, freqs_hz=[0.05, 0.13, 0.29])
    fade_in: float = Field(1.0, ge=0, le=60)


class SumOfSines:
    """Reference generator ``t -> Reference`` for a sum-of-sines excitation.

    Parameters
    ----------
    settings : ExcitationSettings
        Centres, peak amplitudes (the sum never exceeds them) and frequencies.
    seed : int or numpy.random.SeedSequence
        Seed of the random phases.

    Examples
    --------
    >>> ref = SumOfSines(ExcitationSettings(), seed=1)
    >>> r = ref(2.5)          # Reference(g, d, g_dot, d_dot, g_ddot, d_ddot) at t = 2.5 s
    """

    def __init__(self, settings: ExcitationSettings | None = None, seed: int | np.random.SeedSequence = 0):
        self.settings = settings or ExcitationSettings()
        rng = np.random.default_rng(seed)
        s = self.settings
        self._axes = []
        for ax in (s.g, s.d):
            f = np.asarray(ax.freqs_hz, dtype=float)
            phi = rng.uniform(0, 2 * np.pi, len(f))
            self._axes.append((ax.center, ax.amplitude / len(f), 2 * np.pi * f, phi))

    def _fade(self, t: float) -> tuple[float, float, float]:
        """Smooth fade-in ``w(t)`` (quintic smoothstep) and its two derivatives."""
        T = self.settings.fade_in
        if T <= 0 or t >= T:
            return 1.0, 0.0, 0.0
        if t <= 0:
            return 0.0, 0.0, 0.0
        s = t / T
        w = s**3 * (10 - 15 * s + 6 * s**2)
        dw = 30 * s**2 * (1 - s) ** 2 / T
        ddw = 60 * s * (1 - s) * (1 - 2 * s) / T**2
        return w, dw, ddw

    def axis(self, i: int, t: float) -> tuple[float, float, float]:
        """Value, rate and acceleration of axis ``i`` (0: g, 1: d) at time ``t``."""
        c, a, w, phi = self._axes[i]
        arg = w * t + phi
        sn, cs = np.sin(arg), np.cos(arg)
        s0 = float(a * sn.sum())
        s1 = float(a * (w * cs).sum())
        s2 = float(-a * (w**2 * sn).sum())
        fw, dfw, ddfw = self._fade(t)
        return c + fw * s0, dfw * s0 + fw * s1, ddfw * s0 + 2 * dfw * s1 + fw * s2

    def sample(self, t: np.ndarray) -> np.ndarray:
        """The reference at every time of ``t`` as rows ``(g, g_dot, g_ddot, d, d_dot, d_ddot)`` (``n x 6``).

        The same operations as :meth:`axis` on whole arrays (the fade-in per sample with :meth:`_fade`),
        so the rows equal the calls ``self(t_k)`` (``tests/test_compiled_loop.py`` checks it).
        """
        t = np.asarray(t, dtype=float).reshape(-1)
        fade = np.array([self._fade(float(tk)) for tk in t[t < self.settings.fade_in]]).reshape(-1, 3)
        fw, dfw, ddfw = (np.ones(len(t)), np.zeros(len(t)), np.zeros(len(t)))
        early = np.nonzero(t < self.settings.fade_in)[0]
        fw[early], dfw[early], ddfw[early] = fade[:, 0], fade[:, 1], fade[:, 2]
        out = np.empty((len(t), 6))
        for i in range(2):
            c, a, w, phi = self._axes[i]
            arg = w[None, :] * t[:, None] + phi[None, :]
            sn, cs = np.sin(arg), np.cos(arg)
            s0 = a * sn.sum(axis=1)
            s1 = a * (w * cs).sum(axis=1)
            s2 = -a * (w**2 * sn).sum(axis=1)
            out[:, 3 * i] = c + fw * s0
            out[:, 3 * i + 1] = dfw * s0 + fw * s1
            out[:, 3 * i + 2] = ddfw * s0 + 2 * dfw * s1 + fw * s2
        return out

    def __call__(self, t: float) -> Reference:
        g, gd, gdd = self.axis(0, t)
        d, dd, ddd = self.axis(1, t)
        return Reference(g=g, d=d, g_dot=gd, d_dot=dd, g_ddot=gdd, d_ddot=ddd)


def constant_reference(g: float = 20e-3, d: float = 0.0) -> Callable[[float], Reference]:
    """Reference generator holding ``(g, d)``."""
    ref = Reference(g=g, d=d)
    return lambda t: ref


__all__ = ["AxisExcitation", "ExcitationSettings", "SumOfSines", "constant_reference"]
