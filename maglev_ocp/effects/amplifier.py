"""The current amplifier's lag and delay (:class:`AmplifierLag`)."""

from __future__ import annotations

import functools
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

    @classmethod
    def equivalent(cls, t_eff: float, Ts: float = k.Ts) -> dict[str, float]:
        """This law's parameters for an effective delay ``t_eff`` [s]: whole samples of delay plus a lag.

        Below a residual's cut-off a first-order lag of time constant ``T`` and a transport delay ``T`` look
        alike (they differ at second order in ``omega T``): ``delay_samples = floor(t_eff / Ts)`` and
        ``bandwidth_hz = 1 / (2 pi r)`` with the remainder ``r`` (capped at the upper bandwidth). The plant's
        equivalent of any lag of that group delay (:func:`tf_group_delay`).
        """
        lo, hi = cls.bounds()["bandwidth_hz"]
        n = math.floor(t_eff / Ts + 1e-9)
        rem = t_eff - n * Ts
        bw = hi if rem <= 1.0 / (2 * math.pi * hi) else 1.0 / (2 * math.pi * rem)
        return {"bandwidth_hz": float(min(max(bw, lo), hi)), "delay_samples": float(n)}

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
            ``bandwidth_hz`` and ``delay_samples``; or, for a transfer-function member of the diagnosis
            (:func:`tf_filter_currents`), ``order``, ``tf_bandwidth_hz``, ``zeta`` and ``delay_s`` (those win).
        Ts : float
            Sample period [s].
        i0 : ndarray, shape (2,), optional
            Applied current at t = 0, and the command before it (default: the first command).

        Returns
        -------
        ndarray, shape (N, 2)
            Period-mean applied currents (exact for the first-order lag with ZOH).
        """
        if "order" in theta:  # a transfer-function member of the diagnosis (tf_filter_currents)
            return tf_filter_currents(
                u_cmd, int(theta["order"]), theta["tf_bandwidth_hz"], theta.get("zeta", 0.7), theta["delay_s"], Ts, i0
            )
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


#: Orders of :func:`tf_filter_currents`: ``1`` a first-order lag, ``2`` a second-order (``fn_hz``, ``zeta``),
#: ``3`` a third-order Butterworth response (``bandwidth_hz``).
TF_ORDERS: tuple[int, ...] = (1, 2, 3)


def tf_state_space(order: int, bandwidth_hz: float, zeta: float = 0.7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous ``(A, B, C)`` of a unit-DC-gain current response of low order.

    Parameters
    ----------
    order : int
        1: ``w / (s + w)``; 2: ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` with ``wn = 2 pi bandwidth_hz``;
        3: the third-order Butterworth ``wc^3 / (s^3 + 2 wc s^2 + 2 wc^2 s + wc^3)`` (Butterworth 1930).
    bandwidth_hz : float
        ``w / 2 pi`` (order 1 and 3: the -3 dB bandwidth; order 2: the natural frequency).
    zeta : float
        Damping of the second-order response (ignored otherwise).

    Returns
    -------
    tuple of ndarray
        ``A`` (n, n), ``B`` (n,), ``C`` (n,).
    """
    w = 2 * math.pi * float(bandwidth_hz)
    if order == 1:
        return np.array([[-w]]), np.array([w]), np.array([1.0])
    if order == 2:
        return np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]]), np.array([0.0, w * w]), np.array([1.0, 0.0])
    if order == 3:
        A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(w**3), -2 * w**2, -2 * w]])
        return A, np.array([0.0, 0.0, w**3]), np.array([1.0, 0.0, 0.0])
    raise ValueError(f"amplifier transfer function: order must be one of {TF_ORDERS}, got {order}")


def tf_group_delay(order: int, bandwidth_hz: float, zeta: float = 0.7, delay_s: float = 0.0) -> float:
    """Group delay at zero frequency [s] (the phase slope there): the transport delay plus ``1 / w`` (order 1),
    ``2 zeta / wn`` (order 2) or ``2 / wc`` (order 3). Below the residual's cut-off every lag acts as this delay."""
    w = 2 * math.pi * float(bandwidth_hz)
    lag = {1: 1.0 / w, 2: 2.0 * zeta / w, 3: 2.0 / w}[int(order)]
    return float(delay_s) + lag


@functools.lru_cache(maxsize=512)
def _period_mean_filter(order: int, bandwidth_hz: float, zeta: float, frac: float, Ts: float):
    """``(b, a)`` of the discrete map from the whole-sample-delayed commands ``v[k]`` to the period-mean current.

    The command reaching the amplifier is ``v`` delayed by a further ``frac * Ts`` (``0 <= frac < 1``): over
    period ``k`` it holds ``v[k-1]`` on ``[0, frac Ts)`` and ``v[k]`` on ``[frac Ts, Ts)``. Both sub-intervals
    are solved exactly with the matrix exponential of the state augmented by the output's integral and the
    held input (Van Loan 1978, "Computing integrals involving the matrix exponential", IEEE TAC 23(3)), so
    the period means are exact for a ZOH command. On the period means alone this is the first-order Lagrange
    (linear) interpolator of a fractional delay, ``(1 - frac) v[k] + frac v[k-1]`` (Laakso, Valimaki,
    Karjalainen & Laine, "Splitting the unit delay", IEEE Signal Processing Magazine 13(1), 1996), followed
    by the lag.
    """
    from scipy.linalg import expm
    from scipy.signal import ss2tf

    A, B, C = tf_state_space(order, bandwidth_hz, zeta)
    n = len(B)
    M = np.zeros((n + 2, n + 2))  # [x, q, w]: x' = A x + B w, q' = C x, w' = 0
    M[:n, :n], M[:n, n + 1], M[n, :n] = A, B, C

    def step(tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        E = expm(M * tau)
        return E[:n, :n], E[:n, n + 1], E[n, :n], float(E[n, n + 1])

    Axx1, Axw1, Aqx1, Aqw1 = step(frac * Ts)
    Axx2, Axw2, Aqx2, Aqw2 = step((1.0 - frac) * Ts)
    # state s = [x, v_prev]; input v[k]; output the period mean of C x
    F = np.zeros((n + 1, n + 1))
    F[:n, :n], F[:n, n] = Axx2 @ Axx1, Axx2 @ Axw1
    G = np.zeros((n + 1, 1))
    G[:n, 0], G[n, 0] = Axw2, 1.0
    H = np.zeros((1, n + 1))
    H[0, :n], H[0, n] = (Aqx1 + Aqx2 @ Axx1) / Ts, (Aqw1 + Aqx2 @ Axw1) / Ts
    D = np.array([[Aqw2 / Ts]])
    b, a = ss2tf(F, G, H, D)
    b, a = np.atleast_1d(np.squeeze(b)), np.atleast_1d(np.squeeze(a))
    return b / a[0], a / a[0]


def tf_filter_currents(
    u_cmd: np.ndarray,
    order: int,
    bandwidth_hz: float,
    zeta: float = 0.7,
    delay_s: float = 0.0,
    Ts: float = k.Ts,
    i0: np.ndarray | None = None,
) -> np.ndarray:
    """Mean applied current over each ZOH period through a low-order transfer function and a fractional delay.

    Parameters
    ----------
    u_cmd : ndarray, shape (N, 2)
        Commanded currents; row k is held over ``[k Ts, (k+1) Ts)``.
    order, bandwidth_hz, zeta : int, float, float
        The response (:func:`tf_state_space`).
    delay_s : float
        Transport delay [s], any non-negative value: whole samples by a shift, the fraction exactly within the
        period (:func:`_period_mean_filter`).
    Ts : float
        Sample period [s].
    i0 : ndarray, shape (2,), optional
        Current carried at rest before t = 0 (default: the first command).

    Returns
    -------
    ndarray, shape (N, 2)
        Period-mean applied currents (exact under ZOH).
    """
    from scipy.signal import lfilter, lfilter_zi

    u = np.asarray(u_cmd, dtype=float)
    if len(u) == 0:
        return np.empty_like(u)
    i = u[0].copy() if i0 is None else np.asarray(i0, float).reshape(2).copy()
    steps = max(float(delay_s), 0.0) / Ts
    n_del = math.floor(steps + 1e-9)
    frac = min(max(steps - n_del, 0.0), 1.0 - 1e-12)
    if n_del:
        u = np.vstack([np.repeat(i[None, :], n_del, axis=0), u])[: len(u)]
    b, a = _period_mean_filter(int(order), round(float(bandwidth_hz), 9), round(float(zeta), 9), round(frac, 12), Ts)
    zi = lfilter_zi(b, a)  # the steady state of a unit step: at rest on i0 before t = 0
    return np.column_stack([lfilter(b, a, u[:, c], zi=zi * i[c])[0] for c in range(2)])
