"""Minimum-time point-to-point OCP on the shared model (CasADi Opti + IPOPT).

The bound any controller is measured against: the shortest rest-to-rest move
between two hover positions that the current limits allow::

    min T   s.t.  x_{k+1} = RK4(x_k, u_k, p; T/N)        (multiple shooting, ZOH currents)
                  x_0 = (g0, 0, d0, 0),  x_N = (g1, 0, d1, 0)
                  |i_q|, |i_d| <= 8 A,  i_q^2 + i_d^2 <= (8 A)^2
                  gap inside the stops (with a margin)

on the shared model (seed eq. (2) with cogging unless the parameters switch
it off). A tiny penalty on current changes picks a clean solution among the
near-optimal ones without moving ``T`` measurably. The result also serves as a
planned reference: :meth:`MinTimeResult.sample` gives states, accelerations
and feed-forward currents at any time.
"""

from __future__ import annotations

import functools
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from .. import constants as k
from ..model import get_model, rk4
from ..output import atomic_write_bytes, atomic_write_text, make_dir
from ..params import NOMINAL, Params


@dataclass(frozen=True)
class MinTimeSettings:
    """Discretization and solver options of :func:`solve_min_time`.

    Attributes
    ----------
    n_intervals : int
        Shooting intervals (currents held constant on each).
    n_sub : int
        RK4 sub-steps per interval.
    i_axis, i_amp : float
        Current limits [A] (per axis and amplitude).
    i_d_max : float or None
        A tighter bound of ``|i_d|`` [A] if given: ``i_d`` holds the open-loop
        unstable gap, whose feedback needs headroom when a planned move is
        tracked (:func:`maglev_ocp.reference.plan_min_time_move`).
    gap_band : float or None
        If given, the gap stays within ``band`` of the segment between the
        start and end gaps [m] (a traverse "at 20 mm" holds the gap to the
        0.1 mm positioning tolerance); ``None`` lets it use the tracking
        envelope ``g_envelope`` (15..25 mm), which is faster: a smaller gap
        gives more thrust per ampere.
    gap_margin : float
        Distance kept from the gap stops when no band applies [m].
    d_band : float or None
        If given, ``d`` stays within ``band`` of the segment between the start
        and end positions [m]: a move of the gap alone then leaves ``d`` where
        it is. ``None`` lets ``d`` wander between the stops (kept
        ``gap_margin`` away) where that is faster: on a gap move the
        minimum-time currents use ``i_q`` for its reluctance pull (``C4 f4
        i_q^2``, seed eq. (2)) with alternating signs, which swings ``d`` by
        up to 0.2 mm while the gap moves.
    smooth : float
        Weight of the current-change penalty relative to ``T`` [s/A^2].
    max_iter : int
        IPOPT iteration limit.
    tol : float
        IPOPT's convergence tolerance.
    hessian : {"exact", "limited-memory"}
        IPOPT's Hessian of the Lagrangian: exact (CasADi's second derivatives of the mapped RK4, most of the
        solve time: 4 ms of 6 ms per iteration at 50 intervals) or L-BFGS (about as many iterations, half
        the solve time; the planner's moves, :func:`maglev_ocp.reference.plan_min_time_move`, agree with the
        exact Hessian's within 0.02 % of their duration).
    """

    n_intervals: int = 150
    n_sub: int = 2
    i_axis: float = k.i_axis_max
    i_amp: float = k.i_amp_max
    i_d_max: float | None = None
    gap_band: float | None = k.position_tolerance
    gap_margin: float = 2e-3
    d_band: float | None = None
    smooth: float = 1e-7
    max_iter: int = 500
    tol: float = 1e-9
    hessian: str = "exact"


@dataclass
class MinTimeResult:
    """Solution of the minimum-time OCP.

    Attributes
    ----------
    start, end : tuple of float
        ``(g, d)`` at the start and the end [m].
    T : float
        Minimum move time [s].
    t : ndarray, shape (N+1,)
        Node times [s].
    X : ndarray, shape (N+1, 4)
        States at the nodes.
    U : ndarray, shape (N, 2)
        Currents on each interval [A].
    success : bool
        IPOPT reported an optimal (or acceptable) solution.
    status : str
        IPOPT's return status.
    iterations : int
        IPOPT iterations.
    solve_time_s : float
        Wall time of the solve [s].
    params : Params
        The model parameters used.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    T: float
    t: np.ndarray
    X: np.ndarray
    U: np.ndarray
    success: bool
    status: str
    iterations: int
    solve_time_s: float
    params: Params = field(default_factory=lambda: NOMINAL)

    # ------------------------------------------------------------------ views
    def max_amplitude(self) -> float:
        """Largest current amplitude along the solution [A]."""
        return float(np.max(np.hypot(self.U[:, 0], self.U[:, 1])))

    def summary(self) -> dict:
        """Key numbers as a JSON-able dict."""
        return {
            "g0_mm": self.start[0] * 1e3,
            "d0_mm": self.start[1] * 1e3,
            "g1_mm": self.end[0] * 1e3,
            "d1_mm": self.end[1] * 1e3,
            "T_s": self.T,
            "success": self.success,
            "status": self.status,
            "iterations": self.iterations,
            "solve_time_s": self.solve_time_s,
            "max_amplitude_A": self.max_amplitude(),
            "max_abs_i_q_A": float(np.max(np.abs(self.U[:, 0]))),
            "max_abs_i_d_A": float(np.max(np.abs(self.U[:, 1]))),
            "gap_range_mm": [float(self.X[:, 0].min() * 1e3), float(self.X[:, 0].max() * 1e3)],
            "n_intervals": len(self.U),
        }

    def table(self) -> str:
        """One-line text view."""
        s = self.summary()
        return (
            f"({s['g0_mm']:.1f}, {s['d0_mm']:.1f}) -> ({s['g1_mm']:.1f}, {s['d1_mm']:.1f}) mm: "
            f"T_min = {self.T * 1e3:.2f} ms, max |i| = {s['max_amplitude_A']:.3f} A, "
            f"gap {s['gap_range_mm'][0]:.2f}..{s['gap_range_mm'][1]:.2f} mm, {self.status} "
            f"({self.iterations} it, {self.solve_time_s:.2f} s)"
        )

    def sample(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Reference at times ``t`` (clipped to [0, T]) for a tracking controller.

        Returns
        -------
        dict
            ``x`` (n x 4, states by cubic Hermite interpolation between nodes
            using the model's rates), ``acc`` (n x 2, model accelerations
            ``(g_ddot, d_ddot)``) and ``u`` (n x 2, the ZOH feed-forward currents).
        """
        m = get_model()
        p = self.params.vector()
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.T)
        N = len(self.U)
        h = self.T / N
        idx = np.minimum((t / h).astype(int), N - 1)
        s = (t - idx * h) / h
        u = self.U[idx]
        x0, x1 = self.X[idx], self.X[idx + 1]

        def rates(xs: np.ndarray) -> np.ndarray:
            # the shared model's f on every sample at once (CasADi evaluates horizontally repeated arguments)
            return np.asarray(m.f(xs.T, u.T, p)).T.reshape(len(t), 4)

        f0, f1 = rates(x0), rates(x1)
        sc = s[:, None]
        h00, h10 = 2 * sc**3 - 3 * sc**2 + 1, sc**3 - 2 * sc**2 + sc
        h01, h11 = -2 * sc**3 + 3 * sc**2, sc**3 - sc**2
        x = h00 * x0 + h10 * h * f0 + h01 * x1 + h11 * h * f1
        acc = rates(x)[:, [1, 3]]
        return {"x": x, "acc": acc, "u": u}

    # ---------------------------------------------------------------- outputs
    def figure(self):
        """Matplotlib figure: positions, velocities and currents over the move."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        tm = self.t * 1e3
        ax[0].plot(tm, self.X[:, 2] * 1e3, label="d")
        ax0b = ax[0].twinx()
        ax0b.plot(tm, self.X[:, 0] * 1e3, color="tab:orange", label="g")
        ax[0].set_ylabel("d [mm]")
        ax0b.set_ylabel("g [mm]", color="tab:orange")
        ax[1].plot(tm, self.X[:, 3], label="d_dot")
        ax[1].plot(tm, self.X[:, 1], label="g_dot")
        ax[1].set_ylabel("velocity [m/s]")
        ax[1].legend()
        tu = np.repeat(self.t, 2)[1:-1] * 1e3
        for j, name in enumerate(("i_q", "i_d")):
            ax[2].plot(tu, np.repeat(self.U[:, j], 2), label=name)
        ax[2].plot(tu, np.repeat(np.hypot(self.U[:, 0], self.U[:, 1]), 2), "k--", lw=0.8, label="amplitude")
        ax[2].axhline(k.i_amp_max, color="r", lw=0.8)
        ax[2].axhline(-k.i_amp_max, color="r", lw=0.8)
        ax[2].set_ylabel("current [A]")
        ax[2].set_xlabel("t [ms]")
        ax[2].legend(ncol=3)
        for a in ax:
            a.grid(True, alpha=0.3)
        fig.suptitle(f"Minimum-time move: T = {self.T * 1e3:.2f} ms")
        fig.tight_layout()
        return fig

    def save(self, out_dir: str | os.PathLike, stem: str = "min_time") -> Path:
        """Write ``<stem>.json`` (summary), ``<stem>.csv`` (trajectory) and ``<stem>.png`` into ``out_dir``."""
        import matplotlib.pyplot as plt

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / f"{stem}.json", json.dumps(self.summary(), indent=2) + "\n")
        U = np.vstack([self.U, self.U[-1:]])
        rows = np.column_stack([self.t, self.X, U])
        head = "t,g,g_dot,d,d_dot,i_q,i_d"
        lines = [head] + [",".join(f"{v:.10g}" for v in r) for r in rows]
        atomic_write_text(out / f"{stem}.csv", "\n".join(lines) + "\n")
        fig = self.figure()
        atomic_write_bytes(out / f"{stem}.png", fig)
        plt.close(fig)
        return out


def _hover(g: float, d: float, p: np.ndarray) -> np.ndarray:
    u = np.asarray(get_model().u_eq(g, d, p)).ravel()
    if not np.all(np.isfinite(u)):
        raise ValueError(f"no hover possible at g = {g * 1e3:.2f} mm")
    return u


@dataclass(frozen=True)
class _Problem:
    """One minimum-time NLP (CasADi Opti) with its decision variables and parameters, built once per shape."""

    opti: ca.Opti
    X: ca.MX
    U: ca.MX
    T: ca.MX
    x_start: ca.MX
    x_end: ca.MX
    p: ca.MX
    i_axis: ca.MX
    i_amp: ca.MX
    i_d_max: ca.MX
    g_band: ca.MX
    d_band: ca.MX


@functools.lru_cache(maxsize=8)
def _problem(N: int, n_sub: int, smooth: float, max_iter: int, tol: float, n_p: int, hessian: str) -> _Problem:
    """The minimum-time NLP of ``N`` intervals, the end points, constants and limits as parameters.

    Built (and its IPOPT instance created) once per shape: Opti keeps its solver
    while only parameter values and initial guesses change, so a planner that
    solves one move per target pays the symbolic construction once.
    """
    m = get_model()
    opti = ca.Opti()
    X = opti.variable(4, N + 1)
    U = opti.variable(2, N)
    T = opti.variable()
    x_start, x_end, p = opti.parameter(4), opti.parameter(4), opti.parameter(n_p)
    i_axis, i_amp, i_d_max = opti.parameter(), opti.parameter(), opti.parameter()
    g_band, d_band = opti.parameter(2), opti.parameter(2)
    # RK4 with n_sub sub-steps, built on the shared model's f (the same expressions)
    xs, us, ps, hs = ca.SX.sym("x", 4), ca.SX.sym("u", 2), ca.SX.sym("p", n_p), ca.SX.sym("h")
    xk = rk4(lambda xx: m.f(xx, us, ps), xs, hs / n_sub, n_sub)
    F = ca.Function("F", [xs, us, ps, hs], [xk]).map(N)
    opti.subject_to(X[:, 1:] == F(X[:, :-1], U, ca.repmat(p, 1, N), T / N))
    opti.subject_to(X[:, 0] == x_start)
    opti.subject_to(X[:, N] == x_end)
    opti.subject_to(opti.bounded(-i_axis, ca.vec(U), i_axis))
    opti.subject_to(ca.sum1(U**2) <= i_amp**2)
    opti.subject_to(opti.bounded(-i_d_max, U[1, :], i_d_max))  # = i_axis when the settings leave i_d free
    opti.subject_to(opti.bounded(g_band[0], X[0, :], g_band[1]))
    opti.subject_to(opti.bounded(d_band[0], X[2, :], d_band[1]))
    opti.subject_to(opti.bounded(1e-3, T, 10.0))
    dU = U[:, 1:] - U[:, :-1]
    opti.minimize(T + smooth * ca.sumsqr(dU))
    # evaluation warnings off: IPOPT steps through points where the model is not defined and backs off
    opti.solver(
        "ipopt",
        {"print_time": False, "show_eval_warnings": False},
        {"print_level": 0, "max_iter": max_iter, "tol": tol, "sb": "yes", "hessian_approximation": hessian},
    )
    return _Problem(opti, X, U, T, x_start, x_end, p, i_axis, i_amp, i_d_max, g_band, d_band)


def solve_min_time(
    start: tuple[float, float],
    end: tuple[float, float],
    params: Params = NOMINAL,
    settings: MinTimeSettings | None = None,
    T_guess: float | None = None,
) -> MinTimeResult:
    """Solve the minimum-time rest-to-rest move from ``start`` to ``end`` (both ``(g, d)`` [m]).

    Parameters
    ----------
    start, end : tuple of float
        Hover positions ``(g, d)`` [m].
    params : Params
        Model parameters (``params.without_cogging()`` for the seed's eq. (2)).
    settings : MinTimeSettings
        Discretization and solver options.
    T_guess : float, optional
        Initial guess of the duration [s] (default: bang-bang estimate at 50 m/s^2).

    Returns
    -------
    MinTimeResult
    """
    st = settings or MinTimeSettings()
    p = params.vector()
    N = st.n_intervals
    g0, d0 = map(float, start)
    g1, d1 = map(float, end)
    dist = max(abs(d1 - d0), 1e-4)
    T0 = T_guess if T_guess is not None else max(2 * math.sqrt(dist / 50.0), 0.01)
    if st.gap_band is not None:
        g_lo, g_hi = min(g0, g1) - st.gap_band, max(g0, g1) + st.gap_band
    else:
        g_lo, g_hi = min(k.g_envelope[0], g0, g1), max(k.g_envelope[1], g0, g1)
    g_lo, g_hi = max(g_lo, k.g_stop[0] + st.gap_margin), min(g_hi, k.g_stop[1] - st.gap_margin)
    d_lo, d_hi = k.d_stop[0] + st.gap_margin, k.d_stop[1] - st.gap_margin
    if st.d_band is not None:
        d_lo, d_hi = max(d_lo, min(d0, d1) - st.d_band), min(d_hi, max(d0, d1) + st.d_band)
    d_lo, d_hi = min(d_lo, d0, d1), max(d_hi, d0, d1)  # the end points themselves are always allowed

    prob = _problem(N, st.n_sub, st.smooth, st.max_iter, st.tol, len(p), st.hessian)
    opti, X, U, T = prob.opti, prob.X, prob.U, prob.T
    opti.set_value(prob.x_start, [g0, 0, d0, 0])
    opti.set_value(prob.x_end, [g1, 0, d1, 0])
    opti.set_value(prob.p, p)
    opti.set_value(prob.i_axis, st.i_axis)
    opti.set_value(prob.i_amp, st.i_amp)
    opti.set_value(prob.i_d_max, st.i_axis if st.i_d_max is None else min(st.i_d_max, st.i_axis))
    opti.set_value(prob.g_band, [g_lo, g_hi])
    opti.set_value(prob.d_band, [d_lo, d_hi])

    # initial guess: straight line at rest-to-rest speed, hover currents
    s = np.linspace(0, 1, N + 1)
    sm = 3 * s**2 - 2 * s**3
    opti.set_initial(X[0, :], g0 + (g1 - g0) * sm)
    opti.set_initial(X[2, :], d0 + (d1 - d0) * sm)
    opti.set_initial(X[1, :], (g1 - g0) * 6 * s * (1 - s) / T0)
    opti.set_initial(X[3, :], (d1 - d0) * 6 * s * (1 - s) / T0)
    uh = 0.5 * (_hover(g0, d0, p) + _hover(g1, d1, p))
    opti.set_initial(U, np.tile(uh[:, None], (1, N)))
    opti.set_initial(T, T0)
    t0 = time.perf_counter()
    try:
        sol = opti.solve()
        ok = True
        get = sol.value
    except RuntimeError:
        ok = False
        get = opti.debug.value
    dt = time.perf_counter() - t0
    stats = opti.stats()
    status = str(stats.get("return_status", "unknown"))
    ok = ok and status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    Tv = float(get(T))
    return MinTimeResult(
        start=(g0, d0),
        end=(g1, d1),
        T=Tv,
        t=np.linspace(0, Tv, N + 1),
        X=np.asarray(get(X)).T.copy(),
        U=np.asarray(get(U)).T.copy(),
        success=ok,
        status=status,
        iterations=int(stats.get("iter_count", -1)),
        solve_time_s=dt,
        params=params,
    )


@dataclass
class TraverseBounds:
    """Minimum-time bounds of the 100 mm traverse at several gaps.

    Attributes
    ----------
    results : list of MinTimeResult
        One per gap.
    """

    results: list[MinTimeResult]

    def table(self) -> str:
        """Text table: gap, minimum time, largest current amplitude, solver status."""
        lines = [
            f"{'gap [mm]':>8} {'distance [mm]':>13} {'T_min [ms]':>10} {'max |i| [A]':>11} {'status':>26}",
            "-" * 72,
        ]
        for r in self.results:
            lines.append(
                f"{r.start[0] * 1e3:8.1f} {abs(r.end[1] - r.start[1]) * 1e3:13.1f} {r.T * 1e3:10.2f} "
                f"{r.max_amplitude():11.3f} {r.status:>26}"
            )
        return "\n".join(lines)

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write ``bounds.json``, ``bounds.txt`` and per gap ``min_time_g<mm>.{json,csv,png}``."""
        out = make_dir(out_dir)
        for r in self.results:
            r.save(out, stem=f"min_time_g{r.start[0] * 1e3:g}")
        atomic_write_text(out / "bounds.json", json.dumps([r.summary() for r in self.results], indent=2) + "\n")
        atomic_write_text(out / "bounds.txt", self.table() + "\n")
        return out


def traverse_bounds(
    gaps: tuple[float, ...] = (15e-3, 20e-3, 25e-3),
    distance: float = 0.1,
    params: Params = NOMINAL,
    settings: MinTimeSettings | None = None,
    progress: bool = True,
) -> TraverseBounds:
    """Minimum time of the ``distance`` traverse (``d = -distance/2 -> +distance/2``) at each gap."""
    from tqdm import tqdm

    out = []
    for g in tqdm(gaps, desc="min-time OCP", disable=not progress, unit="gap"):
        out.append(solve_min_time((g, -distance / 2), (g, distance / 2), params, settings))
    return TraverseBounds(out)


def main(argv: list[str] | None = None) -> int:
    """``python -m maglev_ocp.ocp [--out DIR] [--gaps MM ...] [--no-cogging]``: print and save the bounds."""
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m maglev_ocp.ocp", description="Minimum-time bound of the 100 mm traverse (shared model, IPOPT)."
    )
    ap.add_argument("--gaps", nargs="+", type=float, default=[15, 20, 25], metavar="MM")
    ap.add_argument("--distance", type=float, default=100.0, metavar="MM")
    ap.add_argument("--no-cogging", action="store_true", help="drop cogging from the model")
    ap.add_argument(
        "--gap-free", action="store_true", help="let the gap use the 15..25 mm envelope (default: held within 0.1 mm)"
    )
    ap.add_argument("--intervals", type=int, default=MinTimeSettings.n_intervals)
    ap.add_argument("--out", default=None, metavar="DIR", help="write JSON/CSV/PNG here")
    a = ap.parse_args(argv)
    for g in a.gaps:
        if not 10.0 <= g <= 30.0:
            print(f"--gaps: {g} mm is outside 10..30 mm")
            return 2
    params = NOMINAL.without_cogging() if a.no_cogging else NOMINAL
    st = MinTimeSettings(n_intervals=a.intervals, gap_band=None if a.gap_free else k.position_tolerance)
    res = traverse_bounds(tuple(g * 1e-3 for g in a.gaps), a.distance * 1e-3, params, st)
    print(res.table())
    if a.out:
        res.save(a.out)
    return 0 if all(r.success for r in res.results) else 1
