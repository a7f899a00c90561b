"""The current amplifier's lag and delay (:class:`AmplifierLag`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .. import constants as k
from .base import Effect, EffectParam


class AmplifierLag(Effect):
    """Current amplifier: first-order lag plus a transport delay of whole samples (NOTES.md).

    The applied current follows ``di/dt = 2 pi f_bw (u(t - delay Ts) - i)``
    (0.5-3 kHz bandwidth on typical linear amplifiers). In the plant the two
    applied currents are extra states integrated exactly over each ZOH period
    and the delay is a buffer of ``delay_samples`` commands.
    """

    name = "amplifier_lag"
    dynamic = True
    params = (
        EffectParam("bandwidth_hz", 2000.0, 50.0, 50000.0, "Hz", "-3 dB bandwidth of the current loop"),
        EffectParam("delay_samples", 0, 0, 10, "samples", "transport delay in control periods", integer=True),
    )

    @staticmethod
    def filter_currents(
        u_cmd: np.ndarray, theta: Mapping[str, float], Ts: float = k.Ts, i0: np.ndarray | None = None
    ) -> np.ndarray:
        """Mean applied current over each ZOH period, from the commanded sequence.

        Parameters
        ----------
        u_cmd : ndarray, shape (N, 2)
            Commanded currents; row k is held over ``[k Ts, (k+1) Ts)``.
        theta : mapping
            ``bandwidth_hz`` and ``delay_samples``.
        Ts : float
            Sample period [s].
        i0 : ndarray, shape (2,), optional
            Applied current at t = 0, and the command before it (default: the first command).

        Returns
        -------
        ndarray, shape (N, 2)
            Period-mean applied currents (exact for the first-order lag with ZOH).
        """
        u = np.asarray(u_cmd, dtype=float)
        i = u[0].copy() if i0 is None else np.asarray(i0, float).reshape(2).copy()
        n_del = round(float(theta["delay_samples"]))
        if n_del:
            # before t = 0 the amplifiers were given the current they carried (i0)
            u = np.vstack([np.repeat(i[None, :], n_del, axis=0), u])[: len(u)]
        w = 2 * math.pi * theta["bandwidth_hz"]
        a = math.exp(-w * Ts)
        mean_gain = 1 - (1 - a) / (w * Ts)  # weight of the new command in the period mean
        if len(u) == 0:
            return np.empty_like(u)
        # i[n+1] = a i[n] + (1 - a) u[n] (exact ZOH step), as one IIR filter per channel from i[0] = i
        from scipy.signal import lfilter

        nxt = lfilter([1.0 - a], [1.0, -a], u, axis=0, zi=(a * i)[None, :])[0]
        i_n = np.vstack([i[None, :], nxt[:-1]])
        return i_n + mean_gain * (u - i_n)
