"""The one symbolic CasADi model of the stage (``shared/spec/MODEL.md``).

Built once as CasADi SX and shared, not copied, by the plant simulator, the
estimator, the controllers, the code generator and the gap diagnosis. All
Functions take the parameter vector ``p`` (see :mod:`maglev_ocp.params`) as a
symbolic input, so nothing is baked in.

Named Functions (inputs / outputs):

``f``            (x, u, p) -> (x_dot)           continuous dynamics, seed eq. (2) + cogging
``accel_terms``  (x, u, p) -> (a_grav, a_pm, a_id, a_rel, a_cogn, a_thrust, a_cogx)
``shape``        (g) -> (lam, Kc, B, f1, f2, f3, f4)
``cogging``      (g, d, p) -> (Fx_cog, Fn_cog)   [N]
``i_d_eq``       (g, p) -> (i_d)                 seed eq. (8), d = 0, no cogging
``u_eq``         (g, d, p) -> (u)                hover currents with cogging
``linearization`` (x, u, p) -> (A, B)             linearization df/dx, df/du
``step_<dt>_<n>`` (x, u, p) -> (x_next)          RK4 with n sub-steps, ZOH on u
``lip_<names>``  (x, u, p) -> (A, b)             x_dot = A(x,u) theta + b(x,u)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import casadi as ca
import numpy as np

from . import constants as k
from .params import NOMINAL, Params
from .signals import INPUT_NAMES, PARAM_NAMES, STATE_NAMES

#: Parameters that enter the dynamics linearly (usable in the A(x,u) theta split).
LINEAR_PARAMS: tuple[str, ...] = ("C1", "C2", "C3", "C4", "xi0")


def rk4(rhs, x, h, n_sub: int = 1, t0: float | None = None):
    """Classical Runge-Kutta (RK4) integration over ``n_sub`` steps of length ``h``, ZOH inputs.

    The one RK4 of the suite: the model's discrete step, the plant simulator, the
    NMPC's prediction, the diagnosis's window simulation and the minimum-time OCP
    all call it, so the same expressions (and the same floating-point operations)
    appear wherever the model is integrated.

    Parameters
    ----------
    rhs : callable
        ``rhs(x)`` (or ``rhs(x, t)`` when ``t0`` is given) returning the state
        derivative; any CasADi or NumPy type that supports ``+`` and ``*``.
    x : casadi.SX | casadi.MX | numpy.ndarray
        Initial state.
    h : float | casadi.SX | casadi.MX
        Step length [s] of one RK4 step.
    n_sub : int
        Number of steps.
    t0 : float, optional
        Time of the first step [s], relative to the start of the sample; when
        given, ``rhs`` also receives the stage time (``t0 + j h``, ``+ h/2``, ``+ h``).

    Returns
    -------
    Same type as ``x``
        The state after ``n_sub`` steps.
    """
    xk = x
    for j in range(n_sub):
        if t0 is None:
            k1 = rhs(xk)
            k2 = rhs(xk + h / 2 * k1)
            k3 = rhs(xk + h / 2 * k2)
            k4 = rhs(xk + h * k3)
        else:
            t = t0 + j * h
            k1 = rhs(xk, t)
            k2 = rhs(xk + h / 2 * k1, t + h / 2)
            k3 = rhs(xk + h / 2 * k2, t + h / 2)
            k4 = rhs(xk + h * k3, t + h)
        xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return xk


def shape_expressions(g: ca.SX) -> dict[str, ca.SX]:
    """Shape functions of the gap, exactly as ``MODEL.md`` writes them.

    Parameters
    ----------
    g : casadi.SX
        Air gap [m].

    Returns
    -------
    dict
        ``lam, Kc, B, a, f1, f2, f3, f4`` as expressions of ``g``.
    """
    lam = 1 - k.b0**2 / (4 * k.t1 * (g + k.b0 / 2 + k.hm / k.mu_rec))  # slot permeance factor
    r = k.b0 / (2 * g)
    gam = (4 / math.pi) * (r * ca.atan(r) - ca.log(ca.sqrt(1 + r**2)))
    Kc = k.t1 / (k.t1 - gam * g)  # Carter's coefficient
    a = math.pi * (k.hm + g) / k.tau
    B = (
        (4 / math.pi) * k.Br * math.sin(math.pi * k.taup / (2 * k.tau)) * math.sinh(math.pi * k.hm / k.tau) / ca.sinh(a)
    )  # fundamental of the PM field B_pmy1 [T]
    coth = ca.cosh(a) / ca.sinh(a)
    return {
        "lam": lam,
        "Kc": Kc,
        "B": B,
        "a": a,
        "f1": lam / (Kc * ca.sinh(a)),
        "f2": lam * B**2,
        "f3": lam * B * coth / Kc,
        "f4": lam * coth**2 / Kc**2,
    }


class MaglevModel:
    """Symbolic model of the 2-DOF PMLSM maglev stage, built once.

    Use :func:`get_model` to obtain the shared instance. Attributes ``x``,
    ``u``, ``p`` are the SX symbols; the ``Function`` attributes are listed in
    the module docstring. Calling a Function on SX/MX arguments inlines the
    same expressions into a larger graph (the plant, the NMPC, the estimator),
    which is how the model is shared.
    """

    nx: int = 4
    nu: int = 2
    np_: int = len(PARAM_NAMES)

    def __init__(self) -> None:
        x = ca.SX.sym("x", self.nx)
        u = ca.SX.sym("u", self.nu)
        p = ca.SX.sym("p", self.np_)
        self.x, self.u, self.p = x, u, p
        P = dict(zip(PARAM_NAMES, ca.vertsplit(p), strict=True))
        g, g_dot, d, d_dot = ca.vertsplit(x)
        i_q, i_d = ca.vertsplit(u)
        s = shape_expressions(g)

        # Cogging (seed eq. (9) and section V.C): tangential along +d, normal attractive.
        xi = P["xi0"] * ca.exp(-(g - k.g_cog_ref) / P["ell"])
        sn = ca.sin(math.pi * d / k.t1)
        Fx_cog = xi * sn
        Fn_cog = xi * sn**2

        # Acceleration contributions of seed eq. (2) [m/s^2]; signs as in MODEL.md.
        a_grav = ca.SX(k.G)
        a_pm = -P["C2"] * s["f2"]  # PM attraction (pulls the mover up: gap shrinks)
        a_id = P["C3"] * s["f3"] * i_d  # i_d > 0 weakens the attraction
        a_rel = -P["C4"] * s["f4"] * (i_q**2 + i_d**2)  # reluctance attraction
        a_cogn = -Fn_cog / P["Mv"]
        a_thrust = -P["C1"] * s["f1"] * i_q
        a_cogx = Fx_cog / P["Mh"]
        g_ddot = a_grav + a_pm + a_id + a_rel + a_cogn
        d_ddot = a_thrust + a_cogx
        x_dot = ca.vertcat(g_dot, g_ddot, d_dot, d_ddot)
        self._x_dot = x_dot

        xs, us, ps = ["x"], ["u"], ["p"]
        self.f = ca.Function("f", [x, u, p], [x_dot], xs + us + ps, ["x_dot"])
        self.accel_terms = ca.Function(
            "accel_terms",
            [x, u, p],
            [a_grav, a_pm, a_id, a_rel, a_cogn, a_thrust, a_cogx],
            ["x", "u", "p"],
            ["a_grav", "a_pm", "a_id", "a_rel", "a_cogn", "a_thrust", "a_cogx"],
        )
        gs = ca.SX.sym("g")
        sg = shape_expressions(gs)
        self.shape = ca.Function(
            "shape",
            [gs],
            [sg[n] for n in ("lam", "Kc", "B", "f1", "f2", "f3", "f4")],
            ["g"],
            ["lam", "Kc", "B", "f1", "f2", "f3", "f4"],
        )
        ds = ca.SX.sym("d")
        cog = ca.substitute([Fx_cog, Fn_cog], [g, d], [gs, ds])
        self.cogging = ca.Function("cogging", [gs, ds, p], cog, ["g", "d", "p"], ["Fx_cog", "Fn_cog"])

        # Equilibrium currents. Vertical balance (MODEL.md):
        #   C4 f4 i_d^2 - C3 f3 i_d + (C2 f2 + C4 f4 i_q^2 + Fn/Mv - G) = 0,
        # root of smaller magnitude (seed eq. (8)) written as 2c / (L3 + sqrt(disc))
        # to avoid cancellation when C4 is small. NaN when disc < 0 (no hover possible).
        Fx_s, Fn_s = cog
        L1 = P["C1"] * sg["f1"]
        iq_eq = Fx_s / (P["Mh"] * L1)
        L3, L4 = P["C3"] * sg["f3"], P["C4"] * sg["f4"]
        c = P["C2"] * sg["f2"] + L4 * iq_eq**2 + Fn_s / P["Mv"] - k.G
        disc = L3**2 - 4 * L4 * c
        id_eq = ca.if_else(disc >= 0, 2 * c / (L3 + ca.sqrt(ca.fmax(disc, 0))), math.nan)
        self.u_eq = ca.Function("u_eq", [gs, ds, p], [ca.vertcat(iq_eq, id_eq)], ["g", "d", "p"], ["u"])
        c0 = P["C2"] * sg["f2"] - k.G
        disc0 = L3**2 - 4 * L4 * c0
        id0 = ca.if_else(disc0 >= 0, 2 * c0 / (L3 + ca.sqrt(ca.fmax(disc0, 0))), math.nan)
        self.i_d_eq = ca.Function("i_d_eq", [gs, p], [id0], ["g", "p"], ["i_d"])

        self.linearization = ca.Function(
            "linearization",
            [x, u, p],
            [ca.jacobian(x_dot, x), ca.jacobian(x_dot, u)],
            ["x", "u", "p"],
            ["A", "B"],
        )

    # ------------------------------------------------------------------ builders
    @functools.cache  # noqa: B019 - the model is a long-lived singleton
    def step(self, dt: float = k.Ts, n_sub: int = 1) -> ca.Function:
        """Explicit discrete step: RK4 with ``n_sub`` sub-steps over ``dt``, ZOH on u.

        Parameters
        ----------
        dt : float
            Step length [s].
        n_sub : int
            Number of RK4 sub-steps.

        Returns
        -------
        casadi.Function
            ``step_<...>(x, u, p) -> x_next``.
        """
        x, u, p = self.x, self.u, self.p
        xk = rk4(lambda xs: self.f(xs, u, p), x, dt / n_sub, n_sub)
        name = f"step_{round(dt * 1e6)}us_{n_sub}"
        return ca.Function(name, [x, u, p], [xk], ["x", "u", "p"], ["x_next"])

    @functools.cache  # noqa: B019
    def linear_split(self, names: Sequence[str] = ("C1", "C2", "C3", "C4")) -> ca.Function:
        """Linear-in-parameters split ``x_dot = A(x, u) theta + b(x, u)``.

        ``A`` is the Jacobian of ``f`` with respect to the parameters ``names``
        (derived by differentiation, not retyped); ``b = f - A theta``, which does
        not depend on theta because theta enters linearly. The parameters not in
        ``names`` are held at their values in ``p``.

        Parameters
        ----------
        names : sequence of str
            Subset of :data:`LINEAR_PARAMS`.

        Returns
        -------
        casadi.Function
            ``lip_<names>(x, u, p) -> (A [4 x n], b [4])``.
        """
        names = tuple(names)
        bad = [n for n in names if n not in LINEAR_PARAMS]
        if bad:
            raise ValueError(f"parameters {bad} do not enter linearly; choose from {LINEAR_PARAMS}")
        idx = [PARAM_NAMES.index(n) for n in names]
        theta = ca.vertcat(*[self.p[i] for i in idx])
        A = ca.jacobian(self._x_dot, theta)
        # theta enters linearly, so b = f(theta = 0): exact, and free of theta.
        zero = ca.SX.zeros(len(idx))
        b = ca.substitute(self._x_dot, theta, zero)
        A = ca.substitute(A, theta, zero)
        return ca.Function("lip_" + "_".join(names), [self.x, self.u, self.p], [A, b], ["x", "u", "p"], ["A", "b"])

    # ------------------------------------------------------------ numeric helpers
    def operating_point(self, g: float, params: Params = NOMINAL) -> dict[str, float]:
        """Operating data at gap ``g`` (d = 0, no cogging, u1 = 0) for the model table.

        Returns ``g_mm, lam, Kc, B_T, i_d_eq_A, L1, pole_rad_s``; the pole is the
        open-loop vertical pole of the linearization at hover (positive: unstable).
        """
        p = params.without_cogging().vector()
        lam, Kc, B, f1, *_ = (float(v) for v in self.shape(g))
        i_d = float(self.i_d_eq(g, p))
        A, _ = self.linearization([g, 0, 0, 0], [0, i_d], p)
        a21 = float(np.asarray(A)[1, 0])
        pole = math.sqrt(a21) if a21 > 0 else -math.sqrt(-a21)
        return {
            "g_mm": g * 1e3,
            "lam": lam,
            "Kc": Kc,
            "B_T": B,
            "i_d_eq_A": i_d,
            "L1": params.C1 * f1,
            "pole_rad_s": pole,
        }


@functools.lru_cache(maxsize=1)
def get_model() -> MaglevModel:
    """Return the shared model instance (built once per process)."""
    return MaglevModel()


def inverse_expressions(x: ca.SX, a: ca.SX, p: ca.SX, i_q: ca.SX | None = None) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Symbolic model inverse: currents that produce the model accelerations ``a = (a_g, a_d)``.

    The coefficients are taken from the shared model's ``accel_terms`` by
    differentiation (nothing is retyped): the horizontal acceleration is
    ``a_d = h0(x) - L1(x) i_q`` and the vertical one
    ``a_g = c0(x, i_q) + L3(x) i_d - L4(x) i_d^2`` (seed eq. (2) with cogging).

    Parameters
    ----------
    x, a, p : casadi.SX
        State (4), desired model accelerations (2) and parameter vector.
    i_q : casadi.SX, optional
        Use this ``i_q`` in the vertical equation instead of the one that
        inverts the horizontal equation (used after ``i_q`` has been limited).

    Returns
    -------
    i_q, i_d, unreachable : casadi.SX
        Currents and a 0/1 flag: 1 when the demanded vertical acceleration
        is beyond the largest the field can give (``disc < 0``); ``i_d`` is
        then the current of the largest achievable acceleration.
    """
    m = get_model()
    uq, ud = ca.SX.sym("uq"), ca.SX.sym("ud")
    terms = m.accel_terms(x, ca.vertcat(uq, ud), p)
    a_g = terms[0] + terms[1] + terms[2] + terms[3] + terms[4]
    a_d = terms[5] + terms[6]
    # Horizontal: a_d = h0 - L1 i_q, linear in i_q.
    L1 = -ca.substitute(ca.jacobian(a_d, uq), uq, 0)
    h0 = ca.substitute(a_d, uq, 0)
    iq_inv = (h0 - a[1]) / L1
    iq_used = iq_inv if i_q is None else i_q
    # Vertical: a_g = c0 + L3 i_d - L4 i_d^2 (the reluctance term also holds L4 i_q^2 inside c0).
    dg = ca.jacobian(a_g, ud)
    L3 = ca.substitute(dg, ud, 0)
    L4 = -0.5 * ca.jacobian(dg, ud)
    c0 = ca.substitute(a_g, ud, 0)
    L3, L4, c0 = (ca.substitute(e, uq, iq_used) for e in (L3, L4, c0))
    # L4 i_d^2 - L3 i_d + c = 0 with c = a_g* - c0. Root of smaller magnitude (continuous with the
    # linear solution c / L3, no field weakening against the magnets), written 2c / (L3 + sqrt(disc))
    # so that it does not cancel when L4 (C4) is small.
    c = a[0] - c0
    disc = L3**2 - 4 * L4 * c
    unreachable = disc < 0
    id_root = 2 * c / (L3 + ca.sqrt(ca.fmax(disc, 0)))
    # disc < 0: the demanded opening acceleration exceeds the maximum of L3 i_d - L4 i_d^2,
    # reached at i_d = L3 / (2 L4): give that (the current limits clip it further).
    id_vertex = L3 / (2 * ca.fmax(L4, 1e-12))
    i_d = ca.if_else(unreachable, id_vertex, id_root)
    return iq_used if i_q is not None else iq_inv, i_d, unreachable


@functools.lru_cache(maxsize=1)
def model_inverse_function() -> ca.Function:
    """CasADi Function ``model_inverse(x, a, p) -> (u, unreachable)`` without limits.

    ``u = (i_q, i_d)`` makes the model's accelerations equal to ``a = (a_g, a_d)``
    at state ``x`` (exactly, cogging included, when ``unreachable == 0``). The
    reference generator uses it to check that a planned move fits the current limits.
    """
    x, a, p = ca.SX.sym("x", 4), ca.SX.sym("a", 2), ca.SX.sym("p", get_model().np_)
    i_q, i_d, unr = inverse_expressions(x, a, p)
    return ca.Function("model_inverse", [x, a, p], [ca.vertcat(i_q, i_d), unr], ["x", "a", "p"], ["u", "unreachable"])


__all__ = [
    "INPUT_NAMES",
    "LINEAR_PARAMS",
    "STATE_NAMES",
    "MaglevModel",
    "get_model",
    "inverse_expressions",
    "model_inverse_function",
    "rk4",
    "shape_expressions",
]
