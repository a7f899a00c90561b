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
from ..observers import HighGainObserver, ObserverSettings, observer_update
from ..params import NOMINAL

#: Names of the inputs and outputs of :func:`observer_step_function`.
OBSERVER_IN: tuple[str, ...] = ("x_hat", "dist", "u_prev", "y", "p")
OBSERVER_OUT: tuple[str, ...] = ("x_hat_next", "dist_next")


def observer_gain(settings: ObserverSettings, Ts: float = k.Ts):
    """The gain vector ``L`` of :class:`HighGainObserver` for ``settings`` (2 or 3 entries).

    Built by constructing the Python observer, so there is exactly one gain design.
    """
    return HighGainObserver(NOMINAL, settings, Ts).L.copy()


def observer_step_function(
    settings: ObserverSettings | None = None, Ts: float = k.Ts, name: str = "observer_step"
) -> ca.Function:
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
    x, dist, u, y, p = (
        ca.SX.sym("x_hat", 4),
        ca.SX.sym("dist", 2),
        ca.SX.sym("u_prev", 2),
        ca.SX.sym("y", 2),
        ca.SX.sym("p", np_),
    )
    xn, dn = observer_update(x, dist, u, y, p, L, Ts, settings.disturbance)
    return ca.Function(name, [x, dist, u, y, p], [xn, dn], list(OBSERVER_IN), list(OBSERVER_OUT))


__all__ = ["OBSERVER_IN", "OBSERVER_OUT", "observer_gain", "observer_step_function", "observer_update"]
