"""Batch estimator of all parameters (C1..C4, xi0, ell) over all runs: filtered equation error.

Every free axis of every run gives an equation ``a(t) = f_axis(x(t), u(t); p)``
(the shared model's acceleration, cogging included). Accelerations are never
formed by differencing a quantized position: both sides are passed through the
same zero-phase filter ``h`` (a Gaussian kernel of width ``sigma_t``), and the
filter is moved onto the position by summation by parts, which is exact in
discrete time::

    h * (Delta^2 pos / Ts^2) = (Delta^2 h / Ts^2) * pos

``Delta^2 pos / Ts^2`` at sample k is the triangle-weighted mean of the
acceleration over ``[t_k-1, t_k+1]``, so the model side is the mean of
``f(x_k, u_k-1)`` and ``f(x_k, u_k)`` (currents held from sample to sample),
filtered by the same ``h``. The filtered signals are band-limited and are
decimated.

How the model enters the NLP (all from the shared model, nothing retyped):

* C1..C4 enter linearly: their filtered regressors are computed once from
  the model's ``linear_split``;
* the cogging term is linear in xi0 and nonlinear in ell. Its filtered
  regressor is an entire function of ``1/ell``; it is computed from the
  model's ``accel_terms`` at Chebyshev nodes of ``1/ell`` and interpolated
  (to ~1e-11 relative) by a Chebyshev series inside the NLP.

So the NLP (Ipopt, Gauss-Newton Hessian ``J^T J`` via ``hess_lag``) works on a
dense residual of a few ten thousand rows and is solved in well under a
second. Two passes: the second weights each (run, axis) block by the inverse
of its residual RMS from the first.

Standard errors come from the Gauss-Newton Hessian with a Newey-West
(Bartlett) sandwich per block: the filtered residuals are autocorrelated over
the kernel width and over any unmodelled slow effect, and a plain
``sigma^2 (J^T J)^-1`` would understate the uncertainty (both are reported).
"""

from __future__ import annotations

import functools
import json
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np
import scipy.sparse as sp
from tqdm import tqdm

from .. import constants as k
from ..effects import Friction
from ..model import get_model
from ..output import atomic_write_text
from ..params import NOMINAL, Params
from ..signals import PARAM_NAMES
from .data import RunData, eval_samples
from .ident import (
    ZeroPhaseFilter,
    correlation_length,
    filtered_acceleration,
    sandwich_covariance,
    stderr_from_variance,
)

#: Parameters the batch estimator can fit.
BATCH_PARAMS: tuple[str, ...] = ("C1", "C2", "C3", "C4", "xi0", "ell")
#: Bounds on each parameter relative to its nominal (prior) value; guards, not priors. A fit that ends on one
#: is flagged (``warnings``).
REL_BOUNDS: dict[str, tuple[float, float]] = {
    "C1": (0.2, 5.0),
    "C2": (0.2, 5.0),
    "C3": (0.0, 10.0),
    "C4": (-20.0, 50.0),
    "xi0": (0.0, 20.0),
    "ell": (0.3, 3.0),
}
#: Physical lower bounds (SI): every force constant, the cogging amplitude and its decay length are
#: non-negative. The NLP runs within the guards of :data:`REL_BOUNDS`; an estimate that ends below its
#: physical bound (data that do not fit the model) is refitted with the bound active and flagged.
PHYSICAL_LOWER: dict[str, float] = {"C1": 0.0, "C2": 0.0, "C3": 0.0, "C4": 0.0, "xi0": 0.0, "ell": 0.0}
#: Chebyshev nodes in 1/ell for the cogging regressor.
N_CHEB = 32
#: Nuisance parameters: Coulomb [N] and viscous [N s/m] friction of each guide (law of
#: :class:`maglev_ocp.effects.Friction`), fitted alongside when ``BatchSettings.friction``.
FRICTION_PARAMS: tuple[str, ...] = (
    "friction_coulomb_g",
    "friction_viscous_g",
    "friction_coulomb_d",
    "friction_viscous_d",
)
_FRICTION_SCALE = {"coulomb": 0.1, "viscous": 1.0}
REL_BOUNDS.update({n: (-50.0, 500.0) for n in FRICTION_PARAMS})


@dataclass
class BatchSettings:
    """Settings of the filtered-equation-error batch estimator.

    Attributes
    ----------
    names : tuple of str
        Parameters to fit (subset of :data:`BATCH_PARAMS`); the others stay at the prior.
    sigma_t : float
        Standard deviation of the Gaussian zero-phase filter [s] (10 ms: -3 dB
        near 19 Hz; filters 10 µm quantization to a few mm/s^2).
    support : float
        Half-width of the kernel in units of ``sigma_t``.
    decimate : int, optional
        Keep every n-th filtered sample (default ``round(0.8 sigma_t / Ts)``).
    hac_lags : int, optional
        Newey-West lags in decimated samples (default: the residuals'
        correlation length, at least twice the kernel half-width).
    weight_floor : float
        Lower bound on a block's residual RMS used for weighting [m/s^2].
    max_iter : int
        Ipopt iteration limit.
    friction : bool
        Also fit Coulomb and viscous friction of each free guide as nuisance
        parameters (:data:`FRICTION_PARAMS`). Real guides have friction (seed
        section III); left out, it biases C1 by a few per cent on the
        horizontal runs, whose accelerations are small.
    friction_v_reg : float
        Velocity [m/s] of the tanh that stands in for sign(v) in the Coulomb
        regressor (wider than the velocity estimates' noise).
    """

    names: tuple[str, ...] = BATCH_PARAMS
    sigma_t: float = 0.01
    support: float = 4.0
    decimate: int | None = None
    hac_lags: int | None = None
    weight_floor: float = 1e-3
    max_iter: int = 60
    friction: bool = True
    friction_v_reg: float = 1e-3

    def __post_init__(self) -> None:
        self.names = tuple(self.names)
        bad = [n for n in self.names if n not in BATCH_PARAMS]
        if bad or not self.names:
            raise ValueError(f"batch parameters {bad or '()'}: choose a non-empty subset of {BATCH_PARAMS}")
        if "ell" in self.names and "xi0" not in self.names:
            raise ValueError("ell can only be fitted together with xi0")
        if not (self.sigma_t > 0 and self.support >= 2):
            raise ValueError("batch filter needs sigma_t > 0 and support >= 2")


@dataclass
class _Block:
    """One (run, axis) equation block."""

    run: str
    axis: str
    row: int  # row of x_dot: 1 (g_ddot) or 3 (d_ddot)
    a_f: np.ndarray  # filtered measured acceleration at the kept samples
    x: np.ndarray  # (N, 4) state (positions measured, velocities estimated)
    u_prev: np.ndarray  # (N, 2) currents held before each sample
    u_next: np.ndarray  # (N, 2) currents held after each sample
    S: sp.csr_matrix  # filter + decimation operator, (len(a_f), N)


def _blocks(runs: Sequence[RunData], filt: ZeroPhaseFilter) -> list[_Block]:
    """Equation blocks of every free axis of every run long enough for the kernel."""
    D = filt.decimate
    out = []
    for r in runs:
        # sample k needs positions k-M-1 .. k+M+1 and currents k-M-1 .. k+M
        if (r.n - 2 - filt.M) - (filt.M + 1) < 4 * D:
            continue
        idx = filt.centers(r.n)
        x = r.measured_state()
        u_prev = np.vstack([r.u[:1], r.u[:-1]])
        S = filt.sample_matrix(r.n, idx)
        for axis, row, pos_col in (("g", 1, 0), ("d", 3, 1)):
            if axis in r.locked:
                continue
            a_f = filtered_acceleration(r.y[:, pos_col], filt.h, r.Ts)[idx - filt.M - 1]
            out.append(_Block(r.name, axis, row, a_f, x, u_prev, r.u, S))
    return out


@functools.cache
def _cogging_accel(n_ell: int) -> ca.Function:
    """``([g, d, sel], p, ells) -> sel * a_cogn + (1 - sel) * a_cogx`` for each ``ell`` in ``ells``.

    The model's cogging accelerations (``accel_terms`` on SX symbols, with
    ``ell`` replaced by each entry of ``ells``); the Function keeps only the
    cogging part of the graph and shares the common subexpressions, so mapping
    it over many samples is cheap.
    """
    m = get_model()
    z = ca.SX.sym("z", 3)
    p = ca.SX.sym("p", m.np_)
    ells = ca.SX.sym("ells", n_ell)
    i_ell = PARAM_NAMES.index("ell")
    outs = []
    for j in range(n_ell):
        pj = ca.vertcat(p[:i_ell], ells[j], p[i_ell + 1 :])
        terms = m.accel_terms(ca.vertcat(z[0], 0, z[1], 0), ca.SX.zeros(2), pj)
        outs.append(z[2] * terms[4] + (1 - z[2]) * terms[6])
    return ca.Function("cog_accel", [z, p, ells], [ca.vertcat(*outs)], {"cse": True})


@functools.cache
def _friction_regressors() -> ca.Function:
    """``(v, v_reg) -> [F(v; Fc=1), F(v; b=1)]``: unit Coulomb and viscous friction forces [N] (effects library)."""
    v, v_reg = ca.SX.sym("v"), ca.SX.sym("v_reg")
    return ca.Function(
        "friction_regressors",
        [v, v_reg],
        [ca.vertcat(Friction.force(v, 1.0, 0.0, 0.0, 1.0, v_reg), Friction.force(v, 0.0, 0.0, 1.0, 1.0, v_reg))],
    )


def _chebyshev(s: ca.MX | float, n: int) -> list:
    """Chebyshev polynomials ``T_0..T_n-1`` at ``s`` by the three-term recurrence."""
    T = [1.0 + 0 * s, s]
    while len(T) < n:
        T.append(2 * s * T[-1] - T[-2])
    return T[:n]


@dataclass
class BatchResult:
    """Estimates, standard errors and correlations of the batch fit.

    Attributes
    ----------
    params : Params
        Prior with the fitted entries replaced.
    names : tuple of str
        Fitted parameters (those the data determines at all).
    values, stderr : dict
        Estimates and standard errors (SI units) of the fitted parameters.
    stderr_naive : dict
        Standard errors without the autocorrelation correction (for comparison).
    correlation : ndarray, shape (n, n)
        Correlation matrix of the estimates.
    blocks : list of dict
        Per (run, axis) block: samples used and residual RMS [m/s^2].
    nuisance : dict
        Nuisance parameters fitted alongside (friction): ``{name: {value, stderr}}``.
    info : dict
        Solver status, iterations, timings, parameters held at the prior, settings.
    converged : bool
        Both Ipopt passes converged (:data:`IPOPT_CONVERGED`).
    warnings : list of str
        Why the estimates may not be trusted: solver not converged, a parameter
        at its bound, a standard error that is not defined, residuals correlated
        far beyond the filter (the data do not fit the model).
    """

    params: Params
    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    stderr_naive: dict[str, float]
    correlation: np.ndarray
    blocks: list[dict]
    nuisance: dict[str, dict[str, float]] = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    converged: bool = True
    warnings: list[str] = field(default_factory=list)

    def rel_stderr(self, name: str) -> float:
        """Standard error relative to the estimate."""
        return self.stderr[name] / max(abs(self.values[name]), 1e-300)

    def weakly_determined(self, threshold: float = 0.02) -> list[str]:
        """Parameters whose relative standard error exceeds ``threshold`` (or is not defined)."""
        return [n for n in self.names if not self.rel_stderr(n) <= threshold]

    def to_dict(self) -> dict:
        """Plain data for JSON."""
        return {
            "names": list(self.names),
            "values": self.values,
            "stderr": self.stderr,
            "stderr_naive": self.stderr_naive,
            "correlation": np.round(self.correlation, 6).tolist(),
            "weakly_determined": self.weakly_determined(),
            "nuisance": self.nuisance,
            "blocks": self.blocks,
            "info": self.info,
            "converged": self.converged,
            "warnings": self.warnings,
        }

    def table(self) -> str:
        """Markdown table: estimate, standard error, relative standard error, then the correlations."""
        lines = ["| parameter | estimate | std. error | rel. std. error [%] |", "|---|---|---|---|"]
        for n in self.names:
            lines.append(f"| {n} | {self.values[n]:.6g} | {self.stderr[n]:.3g} | {100 * self.rel_stderr(n):.3f} |")
        lines += [
            "",
            "Correlation of the estimates:",
            "",
            "| | " + " | ".join(self.names) + " |",
            "|---" * (len(self.names) + 1) + "|",
        ]
        for i, n in enumerate(self.names):
            lines.append(f"| {n} | " + " | ".join(f"{v:+.3f}" for v in self.correlation[i]) + " |")
        if self.nuisance:
            lines += [
                "",
                "Nuisance parameters fitted alongside:",
                "",
                "| nuisance | estimate | std. error |",
                "|---|---|---|",
            ]
            lines += [f"| {n} | {q['value']:.4g} | {q['stderr']:.2g} |" for n, q in self.nuisance.items()]
        if self.warnings:
            lines += ["", *[f"**Warning:** {w}" for w in self.warnings]]
        return "\n".join(lines)

    def save(self, path: str | os.PathLike) -> None:
        """Write the result as JSON."""
        atomic_write_text(Path(path), json.dumps(self.to_dict(), indent=2))


class _Problem:
    """The filtered equation error as numeric matrices: ``r(w) = r0 - R w_lin - xi0 * V(ell)``."""

    def __init__(
        self, blocks: list[_Block], names: tuple[str, ...], p_prior: np.ndarray, nom: np.ndarray, v_reg: float = 1e-3
    ):
        m = get_model()
        self.names = names
        n = len(names)
        self.lin_names = tuple(nm for nm in names if nm in ("C1", "C2", "C3", "C4"))
        self.fit_xi = "xi0" in names
        self.fit_ell = "ell" in names
        p_base = p_prior.copy()
        if self.fit_xi:
            p_base[PARAM_NAMES.index("xi0")] = 0.0  # the cogging term is handled separately
        lip = m.linear_split(self.lin_names) if self.lin_names else None
        lin_cols = [names.index(nm) for nm in self.lin_names]
        nl = len(self.lin_names)
        # Chebyshev nodes in u = 1/ell (or the prior's ell alone if ell is not fitted)
        i_ell = PARAM_NAMES.index("ell")
        if self.fit_ell:
            je = names.index("ell")
            u_lo = 1.0 / (REL_BOUNDS["ell"][1] * nom[je])
            u_hi = 1.0 / (REL_BOUNDS["ell"][0] * nom[je])
            self.u_mid, self.u_half = 0.5 * (u_hi + u_lo), 0.5 * (u_hi - u_lo)
            s_nodes = np.cos(np.pi * (np.arange(N_CHEB) + 0.5) / N_CHEB)
            ell_nodes = 1.0 / (self.u_mid + self.u_half * s_nodes)
        else:
            s_nodes = np.zeros(1)
            ell_nodes = np.array([p_prior[i_ell]])
        # evaluate the model once over all samples of all blocks (currents before and after each sample)
        X = np.vstack([b.x for b in blocks])
        U = np.vstack([np.vstack([b.u_prev for b in blocks]), np.vstack([b.u_next for b in blocks])])
        Ntot = len(X)
        XX = np.vstack([X, X])
        if lip is not None:
            A_all, b_all = eval_samples(lip, XX.T, U.T, p_base)
            A_all = A_all.reshape(4, 2 * Ntot, nl)
            A_avg_all = 0.5 * (A_all[:, :Ntot] + A_all[:, Ntot:])  # (4, N, nl)
        else:
            (b_all,) = eval_samples(m.f, XX.T, U.T, p_base)
            A_avg_all = np.zeros((4, Ntot, 0))
        b_avg_all = 0.5 * (b_all[:, :Ntot] + b_all[:, Ntot:])  # (4, N)
        if self.fit_xi:
            p_cog = p_prior.copy()
            p_cog[PARAM_NAMES.index("xi0")] = 1.0
            sel = np.concatenate([np.full(len(b.x), 1.0 if b.axis == "g" else 0.0) for b in blocks])
            Z = np.vstack([X[:, 0], X[:, 2], sel])
            (C_all,) = eval_samples(_cogging_accel(len(ell_nodes)), Z, p_cog, ell_nodes)
            C_all = C_all.T  # (N, nodes)
        r0, R, V = [], [], []
        start = 0
        for b in blocks:
            N = len(b.x)
            sl = slice(start, start + N)
            start += N
            r0.append(b.a_f - b.S @ b_avg_all[b.row, sl])
            Rb = np.zeros((len(b.a_f), n))
            Rb[:, lin_cols] = (b.S @ A_avg_all[b.row, sl]) * nom[lin_cols][None, :]
            fc, fv = f"friction_coulomb_{b.axis}", f"friction_viscous_{b.axis}"
            if fc in names:
                (F,) = eval_samples(_friction_regressors(), b.x[:, b.row], v_reg)
                M = p_prior[PARAM_NAMES.index("Mv" if b.axis == "g" else "Mh")]
                for j, nm in ((0, fc), (1, fv)):
                    c = names.index(nm)
                    Rb[:, c] = (b.S @ F[j]) / M * nom[c]
            R.append(Rb)
            if self.fit_xi:
                V.append(b.S @ C_all[sl])
        self.r0 = np.concatenate(r0)
        self.R = np.vstack(R)
        self.sizes = [len(a) for a in r0]
        self.bounds = np.cumsum([0, *self.sizes])
        if self.fit_xi:
            Vn = np.vstack(V)  # values at the nodes
            if self.fit_ell:
                T = np.column_stack(_chebyshev(s_nodes, N_CHEB))  # T[j, m] = T_m(s_j)
                self.Vc = np.linalg.solve(T, Vn.T).T  # Chebyshev coefficients per row
            else:
                self.Vc = Vn
        self.nom = nom
        self.n = n

    def residual(self, w: ca.MX) -> ca.MX:
        """Symbolic residual ``a_f - model`` of the normalized parameters ``w``."""
        r = ca.DM(self.r0) - ca.mtimes(ca.DM(self.R), w)
        if self.fit_xi:
            jx = self.names.index("xi0")
            if self.fit_ell:
                je = self.names.index("ell")
                u = 1.0 / (w[je] * self.nom[je])
                s = (u - self.u_mid) / self.u_half
                basis = ca.vertcat(*_chebyshev(s, N_CHEB))
            else:
                basis = ca.DM.ones(1)
            r = r - w[jx] * self.nom[jx] * ca.mtimes(ca.DM(self.Vc), basis)
        return r


#: Ipopt outcomes accepted as a converged fit.
IPOPT_CONVERGED: tuple[str, ...] = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
#: Whiteness check of the fit. A model that fits leaves residuals correlated over the filter's width only
#: (``2 * half`` decimated samples); an effect outside the model correlates them over longer. The fit is
#: flagged when more than :data:`CORRELATED_BLOCKS_WARN` of the (run, axis) blocks have a correlation
#: length above :data:`CORR_LENGTH_WIDTHS` filter widths (seed calibration dataset, seed 1: 5 % of the
#: blocks; with magnetic saturation 30 %; with strong guide friction 16 %).
CORR_LENGTH_WIDTHS = 1.5
CORRELATED_BLOCKS_WARN = 0.15


@dataclass
class _Setup:
    """Stage 1 of :func:`batch_estimate`: filter, equation blocks, fitted names and their scales."""

    filt: ZeroPhaseFilter
    blocks: list[_Block]
    names: tuple[str, ...]  # model parameters, then the nuisance parameters
    n_model: int
    idx: list[int]  # positions of the model parameters in the parameter vector
    p_prior: np.ndarray
    nom: np.ndarray  # scale of each fitted parameter (the NLP works on value / nom)


def _setup(runs: Sequence[RunData], prior: Params, st: BatchSettings) -> _Setup:
    """Stage 1: the filter, the equation blocks and the normalization of every fitted parameter."""
    Ts = runs[0].Ts if runs else k.Ts
    filt = ZeroPhaseFilter.gaussian(st.sigma_t, st.support, Ts, st.decimate)
    blocks = _blocks(runs, filt)
    if not blocks:
        raise ValueError("no run is long enough for the batch estimator's filter")
    names = st.names + (FRICTION_PARAMS if st.friction else ())
    nm_ = len(st.names)
    idx = [PARAM_NAMES.index(nm) for nm in st.names]
    p_prior = prior.vector()
    nom = np.concatenate(
        [
            np.where(np.abs(p_prior[idx]) > 0, p_prior[idx], NOMINAL.vector()[idx]),
            [_FRICTION_SCALE[nm.split("_")[1]] for nm in names[nm_:]],
        ]
    )
    return _Setup(filt, blocks, names, nm_, idx, p_prior, nom)


class _Fit:
    """Stage 2: the NLP of the filtered equation error (Ipopt, Gauss-Newton Hessian) and its bounds.

    Parameters the data cannot see (a zero Jacobian column at the start) are
    held at the prior through equal bounds.
    """

    def __init__(self, s: _Setup, st: BatchSettings) -> None:
        names, n, nm_ = s.names, len(s.names), s.n_model
        self.prob = prob = _Problem(s.blocks, names, s.p_prior, s.nom, st.friction_v_reg)
        w = ca.MX.sym("w", n)
        res = prob.residual(w)
        self.resid_fn = ca.Function("batch_resid", [w], [res])
        self.jac_fn = ca.Function("batch_jac", [w], [ca.jacobian(res, w)])
        lbw = np.array([REL_BOUNDS[nm][0] for nm in names])
        ubw = np.array([REL_BOUNDS[nm][1] for nm in names])
        w0 = np.concatenate([s.p_prior[s.idx] / s.nom[:nm_], np.zeros(n - nm_)])
        if prob.fit_xi:  # start the cogging amplitude away from zero so that ell has a gradient
            j = names.index("xi0")
            w0[j] = max(w0[j], 0.25)
        self.w0 = w0
        J0 = np.asarray(self.jac_fn(w0))
        col = np.linalg.norm(J0, axis=0)
        free = col > 1e-6 * max(float(col.max()), 1e-300)
        if prob.fit_ell and not free[names.index("xi0")]:
            free[names.index("ell")] = False
        self.free = free
        self.lbw = np.where(free, lbw, w0)
        self.ubw = np.where(free, ubw, w0)
        # one NLP, the block weights (already divided by sqrt(M)) as its parameter vector
        wt = ca.MX.sym("wt", len(prob.r0))
        r_w = wt * res
        J_w = ca.jacobian(r_w, w)
        lam_f = ca.MX.sym("lam_f")
        H = ca.Function("gn_hess", [w, wt, lam_f, ca.MX.sym("lam_g", 0)], [ca.triu(lam_f * ca.mtimes(J_w.T, J_w))])
        self.solver = ca.nlpsol(
            "batch_fit",
            "ipopt",
            {"x": w, "p": wt, "f": 0.5 * ca.sumsqr(r_w)},
            {
                "hess_lag": H,
                "print_time": False,
                # the bounds are only guards: a tiny barrier does not distort the fit
                "ipopt": {
                    "print_level": 0,
                    "sb": "yes",
                    "max_iter": st.max_iter,
                    "tol": 1e-9,
                    "acceptable_tol": 1e-7,
                    "acceptable_iter": 2,
                    "mu_init": 1e-9,
                    "bound_push": 1e-12,
                    "bound_frac": 1e-12,
                },
            },
        )

    def residual(self, w: np.ndarray) -> np.ndarray:
        """Unweighted residual at the normalized parameters ``w``."""
        return np.asarray(self.resid_fn(w)).ravel()

    def solve(self, weights: np.ndarray, w_init: np.ndarray) -> tuple[np.ndarray, dict]:
        """One Ipopt solve; the objective is half the mean squared weighted residual (scale-free tolerances)."""
        sol = self.solver(x0=w_init, p=weights / math.sqrt(len(weights)), lbx=self.lbw, ubx=self.ubw)
        stats = self.solver.stats()
        status = stats.get("return_status")
        return np.asarray(sol["x"]).ravel(), {
            "status": status,
            "iterations": int(stats.get("iter_count", -1)),
            "cost": float(sol["f"]),
            "converged": status in IPOPT_CONVERGED,
        }

    def two_passes(self, st: BatchSettings) -> tuple[np.ndarray, np.ndarray, dict, dict]:
        """Pass 1 with one common weight, pass 2 with each block weighted by its own residual RMS.

        Returns the estimate, the weights of pass 2 and both passes' solver info.
        """
        bounds = self.prob.bounds
        r_start = self.residual(self.w0)
        w_common = 1.0 / max(math.sqrt(np.mean(r_start**2)), st.weight_floor)
        w1, info1 = self.solve(np.full(len(r_start), w_common), self.w0)
        r1 = self.residual(w1)
        rms = np.array(
            [
                max(math.sqrt(np.mean(r1[bounds[i] : bounds[i + 1]] ** 2)), st.weight_floor)
                for i in range(len(bounds) - 1)
            ]
        )
        weights = np.concatenate([np.full(s, 1.0 / v) for s, v in zip(self.prob.sizes, rms, strict=True)])
        w2, info2 = self.solve(weights, w1)
        return w2, weights, info1, info2

    def enforce_physical(self, names: Sequence[str], nom: np.ndarray, w2: np.ndarray, weights: np.ndarray):
        """Refit with the physical lower bounds active where the estimate crossed them.

        Returns the (possibly refitted) estimate, the refit's solver info (None
        if nothing crossed) and ``{name: value before the refit}``.
        """
        lo = np.array([PHYSICAL_LOWER.get(nm, -math.inf) for nm in names]) / nom
        crossed = self.free & (w2 < lo)
        if not crossed.any():
            return w2, None, {}
        before = {nm: float(w2[i] * nom[i]) for i, nm in enumerate(names) if crossed[i]}
        self.lbw = np.where(crossed, lo, self.lbw)
        w3, info3 = self.solve(weights, np.clip(w2, self.lbw, self.ubw))
        # Ipopt relaxes bounds by ~1e-8: a physical bound holds exactly
        return np.clip(w3, self.lbw, self.ubw), info3, before


def _covariance(
    fit: _Fit, s: _Setup, st: BatchSettings, w2: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, list[dict], list[int], int]:
    """Stage 4: Gauss-Newton sandwich covariance with a Newey-West meat per (run, axis) block.

    Returns the covariance and the naive one (over the free parameters), the
    per-block info, the Newey-West lags used and the kernel half-width in
    decimated samples.
    """
    fi = np.flatnonzero(fit.free)
    bounds = fit.prob.bounds
    r2 = fit.residual(w2) * weights
    J2 = (np.asarray(fit.jac_fn(w2)) * weights[:, None])[:, fi]
    half_dec = math.ceil(s.filt.M / s.filt.decimate)
    blk_info, lags_used = [], []
    for i, b in enumerate(s.blocks):
        sl = slice(bounds[i], bounds[i + 1])
        rb = r2[sl]
        lags_used.append(st.hac_lags or max(2 * half_dec, correlation_length(rb, 20 * half_dec)))
        blk_info.append(
            {
                "run": b.run,
                "axis": b.axis,
                "samples": len(rb),
                "rms_m_s2": float(math.sqrt(np.mean((rb / weights[sl]) ** 2))),
                "correlation_lags": lags_used[-1],
            }
        )
    cov, cov_naive = sandwich_covariance(J2, r2, bounds, lags_used)
    return cov, cov_naive, blk_info, lags_used, half_dec


def _fit_warnings(
    names: Sequence[str],
    info1: dict,
    info2: dict,
    at_bound: list[str],
    se: dict[str, float],
    lags: list[int],
    half: int,
) -> list[str]:
    """Plain-language warnings: solver not converged, parameters at a bound, undefined errors, poor fit."""
    out = []
    for p, info in (("1", info1), ("2", info2)):
        if not info["converged"]:
            out.append(f"batch fit pass {p}: Ipopt did not converge ({info['status']}); the estimates are unreliable")
    for nm in at_bound:
        out.append(
            f"batch fit: {nm} is at its bound (physical or guard): the data do not fit the model "
            "(an unmodelled effect is absorbed by the parameters); run `maglev diagnose` on the dataset"
        )
    bad = [nm for nm in names if not math.isfinite(se.get(nm, math.nan))]
    if bad:
        out.append(f"batch fit: no standard error for {', '.join(bad)} (negative or undefined variance)")
    frac = float(np.mean(np.asarray(lags) > CORR_LENGTH_WIDTHS * 2 * half))
    if frac > CORRELATED_BLOCKS_WARN:
        out.append(
            f"batch fit: the residuals of {frac:.0%} of the (run, axis) blocks stay correlated beyond "
            f"{CORR_LENGTH_WIDTHS:g} filter widths (a model that fits leaves white residuals after the filter): "
            "an effect outside the model shapes the data and the estimates absorb it; run `maglev diagnose`"
        )
    return out


def batch_estimate(
    runs: Sequence[RunData],
    prior: Params = NOMINAL,
    settings: BatchSettings | None = None,
    progress: bool = False,
) -> BatchResult:
    """Fit the parameters to all runs by filtered equation error (CasADi NLP, Ipopt).

    Stages: (1) filter and equation blocks, (2) the NLP, (3) two passes
    (common weight, then per-block weights), (4) sandwich covariance,
    (5) the result with its warnings.

    Parameters
    ----------
    runs : sequence of RunData
        Logged runs (locked axes are left out of the equations).
    prior : Params
        Start values, normalization, and the values of the parameters not fitted.
    settings : BatchSettings, optional
        Filter and solver settings.
    progress : bool
        Show a tqdm bar over the steps.

    Returns
    -------
    BatchResult
        Parameters the data does not see at all (e.g. C1 without a moving d
        axis) are held at the prior and listed in ``info["held_at_prior"]``;
        ``converged`` and ``warnings`` say whether the fit can be trusted.
    """
    t_start = time.perf_counter()
    st = settings or BatchSettings()
    bar = tqdm(total=4, desc="batch fit", leave=False, disable=not progress)
    s = _setup(runs, prior, st)
    fit = _Fit(s, st)
    bar.update(1)
    w2, weights, info1, info2 = fit.two_passes(st)
    w2, info3, crossed = fit.enforce_physical(s.names, s.nom, w2, weights)
    bar.update(2)
    cov, cov_naive, blk_info, lags_used, half_dec = _covariance(fit, s, st, w2, weights)
    bar.update(1)
    bar.close()
    # ----- stage 5: the result
    names, nm_, fi = s.names, s.n_model, np.flatnonzero(fit.free)
    se = stderr_from_variance(np.diag(cov)) * s.nom[fi]
    se_naive = stderr_from_variance(np.diag(cov_naive)) * s.nom[fi]
    vals = w2 * s.nom
    p_new = s.p_prior.copy()
    p_new[s.idx] = vals[:nm_]
    fitted_all = [names[i] for i in fi]
    model_pos = [q for q, i in enumerate(fi) if i < nm_]  # positions of the model parameters among the fitted
    cov_m = cov[np.ix_(model_pos, model_pos)]
    dcov = np.sqrt(np.clip(np.diag(cov_m), 1e-300, None))
    held = [nm for nm, f in zip(names, fit.free, strict=True) if not f]
    lbw, ubw = fit.lbw, fit.ubw
    at_bound = [names[i] for i in fi if min(w2[i] - lbw[i], ubw[i] - w2[i]) < 1e-6 * max(1.0, abs(w2[i]))]
    stderr = {fitted_all[q]: float(se[q]) for q in model_pos}
    warnings = [
        f"batch fit: {nm} came out {v:.4g}, below its physical bound {PHYSICAL_LOWER[nm]:g}: refitted with "
        f"{nm} >= {PHYSICAL_LOWER[nm]:g}; the data do not fit the model"
        for nm, v in crossed.items()
    ]
    warnings += _fit_warnings(
        [fitted_all[q] for q in model_pos], info1, info3 or info2, at_bound, stderr, lags_used, half_dec
    )
    return BatchResult(
        params=Params.from_vector(p_new),
        names=tuple(fitted_all[q] for q in model_pos),
        values={fitted_all[q]: float(vals[fi[q]]) for q in model_pos},
        stderr=stderr,
        stderr_naive={fitted_all[q]: float(se_naive[q]) for q in model_pos},
        correlation=cov_m / np.outer(dcov, dcov),
        blocks=blk_info,
        nuisance={
            fitted_all[q]: {"value": float(vals[fi[q]]), "stderr": float(se[q])} for q in range(len(fi)) if fi[q] >= nm_
        },
        info={
            "pass1": info1,
            "pass2": info2,
            **({"physical_refit": info3, "below_physical_bound": crossed} if info3 is not None else {}),
            "n_residuals": len(weights),
            "n_blocks": len(s.blocks),
            "held_at_prior": [nm for nm in held if nm in st.names],
            "nuisance_not_seen": [nm for nm in held if nm not in st.names],
            "at_bound": at_bound,
            "decimate": s.filt.decimate,
            "sigma_t": st.sigma_t,
            "kernel_taps": len(s.filt.h),
            "hac_lags": [min(lags_used), max(lags_used)],
            "friction": st.friction,
            "seconds": time.perf_counter() - t_start,
        },
        converged=bool(info1["converged"] and (info3 or info2)["converged"]),
        warnings=warnings,
    )
