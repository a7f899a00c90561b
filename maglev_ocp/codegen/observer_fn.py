"""The high-gain observer's update as one CasADi Function (for code generation).

:class:`maglev_ocp.observers.HighGainObserver` is numeric Python (a CasADi RK4
call plus numpy arithmetic). For the generated C, the very same update is
written here as a CasADi Function built from the same pieces: the shared
model's ``step(Ts, 1)`` Function for the prediction and the observer's own
gain vector ``L`` (computed by ``HighGainObserver._gain``, i.e. Ackermann's
formula placing every error pole at ``exp(-Ts/eps)``). The arithmetic is in
the same order as the Python observer, so both agree to rounding (bit for bit
in practice).

``observer_step(x_hat, dist, u_prev, y, p) -> (x_hat_next, dist_next)``
"""

from __future__ import annotations

import casadi as ca

from .. import constants as k
from ..model import get_model
from ..observers import HighGainObserver, ObserverSettings
from ..params import NOMINAL

#: Names of the inputs and outputs of :func:`observer_step_function`.
OBSERVER_IN: tuple[str, ...] = ("x_hat", "dist", "u_prev", "y", "p")
OBSERVER_OUT: tuple[str, ...] = ("x_hat_next", "dist_next")


def observer_gain(settings: ObserverSettings, Ts: float = k.Ts):
    """The gain vector ``L`` of :class:`HighGainObserver` for ``settings`` (2 or 3 entries).

    Built by constructing the Python observer, so there is exactly one gain design.
    """
    return HighGainObserver(NOMINAL, settings, Ts).L.copy()


def observer_update(x_hat, dist, u_prev, y, p, L, Ts: float, disturbance: bool):
    """Symbolic predictor-corrector update of :class:`HighGainObserver` (SX or MX).

    Parameters
    ----------
    x_hat : casadi.SX, shape (4,)
        Estimate after the previous update ``(g, g_dot, d, d_dot)``.
    dist : casadi.SX, shape (2,)
        Acceleration disturbance estimate ``(a_g, a_d)`` [m/s^2] (ignored without ``disturbance``).
    u_prev : casadi.SX, shape (2,)
        Currents ``(i_q, i_d)`` held over the last period [A].
    y : casadi.SX, shape (2,)
        Encoder readings ``(g, d)`` [m].
    p : casadi.SX
        Model parameter vector.
    L : array_like
        Observer gain (position, velocity[, disturbance]).
    Ts : float
        Sample period [s].
    disturbance : bool
        Extended-state observer (a constant acceleration disturbance per axis).

    Returns
    -------
    x_next, dist_next : casadi.SX
        Updated estimate and disturbance.
    """
    F = get_model().step(Ts, 1)
    xp = F(x_hat, u_prev, p)
    if disturbance:
        # constant-acceleration disturbance over one period: Ts^2/2 on position, Ts on velocity
        # (written in the Python observer's order of operations, so the rounding is the same)
        xp = xp + ca.vertcat(dist[0] * Ts**2 / 2, dist[0] * Ts, dist[1] * Ts**2 / 2, dist[1] * Ts)
    e_g = y[0] - xp[0]
    e_d = y[1] - xp[2]
    x_next = ca.vertcat(xp[0] + L[0] * e_g, xp[1] + L[1] * e_g, xp[2] + L[0] * e_d, xp[3] + L[1] * e_d)
    if disturbance:
        d_next = ca.vertcat(dist[0] + L[2] * e_g, dist[1] + L[2] * e_d)
    else:
        d_next = dist * 0 if isinstance(dist, ca.MX) else ca.SX.zeros(2)
    return x_next, d_next


def observer_step_function(settings: ObserverSettings | None = None, Ts: float = k.Ts,
                           name: str = "observer_step") -> ca.Function:
    """The observer update as a CasADi Function (SX, so it generates flat C).

    ``observer_step(x_hat[4], dist[2], u_prev[2], y[2], p[np]) -> (x_hat_next[4], dist_next[2])``

    Parameters
    ----------
    settings : ObserverSettings
        Time constant ``eps`` and whether the disturbance is estimated.
    Ts : float
        Sample period [s].
    name : str
        Name of the Function (the C symbol).
    """
    settings = settings or ObserverSettings()
    L = observer_gain(settings, Ts)
    np_ = get_model().np_
    x, dist, u, y, p = (ca.SX.sym("x_hat", 4), ca.SX.sym("dist", 2), ca.SX.sym("u_prev", 2),
                        ca.SX.sym("y", 2), ca.SX.sym("p", np_))
    xn, dn = observer_update(x, dist, u, y, p, L, Ts, settings.disturbance)
    return ca.Function(name, [x, dist, u, y, p], [xn, dn], list(OBSERVER_IN), list(OBSERVER_OUT))


__all__ = ["OBSERVER_IN", "OBSERVER_OUT", "observer_gain", "observer_step_function", "observer_update"]
