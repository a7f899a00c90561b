"""Reduced-order NPFISI parameter estimator (seed eq. (3)) on the shared model.

The model is written linear in the chosen parameters, ``x_dot = A(x, u) theta +
b(x, u)`` (the shared model's :meth:`~maglev_ocp.model.MaglevModel.linear_split`,
derived by differentiation, never retyped), and the estimator of the seed's
eq. (3) is integrated over the logged samples::

    theta_dot = (1/eps) Sigma^-1 A(y,u)^T M (y - x_hat)
    x_hat_dot = A(y,u) theta + b(y,u) + (1/eps) (y - x_hat)
    Sigma_dot = A(y,u)^T M A(y,u) - gamma^-2 Q,      Sigma(0) = Q0

``y`` is the measured state (encoder positions and observer velocities,
linearly interpolated between samples), ``u`` the commanded currents (zero-order
hold), ``M`` masks the rows of locked axes (a fixture's force is not in the
model). theta is normalized by its nominal values, so Q and Q0 are in units of
the normalized parameters (the C's differ by four orders of magnitude).

Integration: one CasADi ``integrator`` ('rk', RK4 with ``n_sub`` steps per
sample, chosen from eps and the initial adaptation gain) over one sample
interval, with the samples as parameters, expanded to SX and ``mapaccum``-ed
over the run in chunks. Runs are chained: theta and Sigma carry over, x_hat
restarts at each run's first measurement.
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from .. import constants as k
from ..model import LINEAR_PARAMS, get_model
from ..output import atomic_write_bytes, atomic_write_text
from ..params import NOMINAL, Params
from ..signals import PARAM_NAMES
from .data import RunData, call_numpy, eval_samples

#: Samples per mapaccum chunk, longest first (a run's tail is padded with no-op steps).
CHUNKS: tuple[int, ...] = (4000, 1000, 200)
#: Short chunk, used while Sigma is small and the estimator is stiff (more RK4 steps).
CHUNK_SHORT = CHUNKS[-1]
#: Cap on the RK4 steps per sample (powers of two, so that few integrators are built).
MAX_SUB = 64


@dataclass
class NPFISISettings:
    """Tuning of the reduced-order NPFISI estimator (seed eq. (3)).

    Attributes
    ----------
    names : tuple of str
        Parameters to estimate (subset of ``C1..C4, xi0``); the others are held
        at the prior's values.
    eps : float
        Measurement-confidence scalar of eq. (3) [s]: time constant of the
        prediction-error filter. The seed uses 0.001, 0.01, 0.05.
    gamma : float
        Attenuation level; acts only through ``gamma^-2 Q``.
    Q : float or ndarray
        Weight subtracted from Sigma's growth (scalar means ``Q * I``), in
        normalized-parameter units per second.
    Q0 : float or ndarray
        Initial Sigma (scalar means ``Q0 * I``): the confidence in the initial
        guess, in normalized units (information equivalent).
    theta0 : dict, optional
        Initial guess (default: the prior's values).
    n_sub : int, optional
        RK4 steps per sample (default: chosen so that the fastest mode of the
        estimator times the step stays below 1).
    record_every : int
        Keep every n-th sample of the trajectories.
    """

    names: tuple[str, ...] = ("C1", "C2", "C3", "C4")
    eps: float = 0.01
    gamma: float = 1.1
    Q: float | np.ndarray = 1e-5
    Q0: float | np.ndarray = 1e-2
    theta0: dict[str, float] | None = None
    n_sub: int | None = None
    record_every: int = 10

    def __post_init__(self) -> None:
        self.names = tuple(self.names)
        bad = [n for n in self.names if n not in LINEAR_PARAMS]
        if bad or not self.names:
            raise ValueError(f"NPFISI parameters {bad or '()'}: choose a non-empty subset of {LINEAR_PARAMS}")
        if not (self.eps > 0 and self.gamma > 0 and self.record_every >= 1):
            raise ValueError("NPFISI needs eps > 0, gamma > 0 and record_every >= 1")

    def matrix(self, value: float | np.ndarray) -> np.ndarray:
        """``value`` as an n x n matrix (scalar -> multiple of the identity)."""
        n = len(self.names)
        v = np.asarray(value, dtype=float)
        return v * np.eye(n) if v.ndim == 0 else v.reshape(n, n)


@functools.cache
def _step_function(names: tuple[str, ...], n_sub: int, Ts: float, chunk: int) -> ca.Function:
    """One-sample NPFISI step as an SX Function, ``mapaccum``-ed over ``chunk`` samples.

    Inputs of the single step: ``z = [x_hat (4), phi (n), vec(Sigma) (n*n)]``,
    per-sample ``s = [y_k (4), y_k+1 (4), u_k (2), mask (4), valid]`` and the
    constants ``c = [p (np), theta_nom (n), 1/eps, vec(gamma^-2 Q) (n*n)]``.
    """
    m = get_model()
    lip = m.linear_split(names)
    n = len(names)
    nz = 4 + n + n * n
    z = ca.SX.sym("z", nz)
    s = ca.SX.sym("s", 15)
    c = ca.SX.sym("c", m.np_ + n + 1 + n * n)
    t = ca.SX.sym("t")
    xh, phi, sig = z[:4], z[4 : 4 + n], ca.reshape(z[4 + n :], n, n)
    y0, y1, u, mask = s[:4], s[4:8], s[8:10], s[10:14]  # s[14]: valid flag, used below
    p = c[: m.np_]
    th_nom = c[m.np_ : m.np_ + n]
    inv_eps = c[m.np_ + n]
    Qg = ca.reshape(c[m.np_ + n + 1 :], n, n)

    yt = y0 + (y1 - y0) * (t / Ts)  # measurement, first-order hold between samples
    A, b = lip(yt, u, p)
    An = A @ ca.diag(th_nom)  # regressor of the normalized parameters
    Am = ca.diag(mask) @ An
    e = yt - xh
    dphi = inv_eps * ca.solve(sig, Am.T @ e)  # seed eq. (3)
    dxh = An @ phi + b + inv_eps * e
    dsig = Am.T @ Am - Qg
    ode = ca.vertcat(dxh, dphi, ca.vec(dsig))
    dae = {"x": z, "p": ca.vertcat(s, c), "t": t, "ode": ode}
    integ = ca.integrator("npfisi_interval", "rk", dae, 0.0, Ts, {"number_of_finite_elements": n_sub, "simplify": True})
    zs, ss, cs = ca.SX.sym("z", nz), ca.SX.sym("s", 15), ca.SX.sym("c", c.numel())
    zf = integ(x0=zs, p=ca.vertcat(ss, cs))["xf"]
    znext = ca.if_else(ss[14] > 0.5, zf, zs)  # padding samples are no-ops
    one = ca.Function("npfisi_step", [zs, ss, cs], [znext])
    return one.mapaccum("npfisi_chunk", chunk, [0], [0])


@dataclass
class NPFISIResult:
    """Trajectories and convergence of one NPFISI run over a sequence of logged runs.

    Attributes
    ----------
    settings : NPFISISettings
        Tuning used.
    t : ndarray, shape (K,)
        Recorded times [s], running on across the chained runs.
    theta : ndarray, shape (K, n)
        Parameter estimates (physical units) at the recorded times.
    sigma : ndarray, shape (K, n, n)
        Sigma (normalized units) at the recorded times.
    sigma_min_eig : ndarray, shape (K,)
        Smallest eigenvalue of Sigma (must stay positive).
    run_names : list of str
        Runs used, in order.
    run_start : ndarray of int
        Index into ``t`` where each run starts.
    n_sub : int
        RK4 steps per sample used.
    """

    settings: NPFISISettings
    t: np.ndarray
    theta: np.ndarray
    sigma: np.ndarray
    sigma_min_eig: np.ndarray
    run_names: list[str]
    run_start: np.ndarray
    n_sub: int
    stretch: float = 0.2
    extra: dict = field(default_factory=dict)

    @property
    def names(self) -> tuple[str, ...]:
        """Estimated parameter names."""
        return self.settings.names

    @property
    def final(self) -> dict[str, float]:
        """Final estimates ``{name: value}``."""
        return {n: float(v) for n, v in zip(self.names, self.theta[-1], strict=True)}

    @property
    def sigma_positive(self) -> bool:
        """True if Sigma stayed positive definite over the whole run."""
        return bool(np.all(self.sigma_min_eig > 0))

    def convergence(self, stretch: float | None = None) -> dict[str, dict[str, float]]:
        """How settled each parameter is over the last stretch of the trajectory.

        Parameters
        ----------
        stretch : float, optional
            Fraction of the total time that counts as the last stretch (default 0.2).

        Returns
        -------
        dict
            Per parameter: ``final``, ``mean`` and ``spread`` (max - min) over the
            stretch, and ``rel_spread = spread / |final|``.
        """
        frac = self.stretch if stretch is None else stretch
        t_end = self.t[-1]
        sel = self.t >= t_end - frac * (t_end - self.t[0])
        out = {}
        for j, n in enumerate(self.names):
            v = self.theta[sel, j]
            spread = float(v.max() - v.min())
            fin = float(self.theta[-1, j])
            out[n] = {
                "final": fin,
                "mean": float(v.mean()),
                "spread": spread,
                "rel_spread": spread / max(abs(fin), 1e-12),
            }
        return out

    def converged(self, tol: float = 0.01, stretch: float | None = None, names: Sequence[str] | None = None) -> bool:
        """True if Sigma stayed positive and every (named) parameter's relative spread < ``tol``."""
        conv = self.convergence(stretch)
        names = self.names if names is None else names
        return self.sigma_positive and all(conv[n]["rel_spread"] < tol for n in names)

    def to_dict(self) -> dict:
        """Summary as plain data (for JSON)."""
        s = self.settings
        return {
            "names": list(self.names),
            "eps": s.eps,
            "gamma": s.gamma,
            "Q": np.asarray(s.Q, float).tolist(),
            "Q0": np.asarray(s.Q0, float).tolist(),
            "n_sub": self.n_sub,
            "runs": self.run_names,
            "duration_s": float(self.t[-1] - self.t[0]),
            "final": self.final,
            "convergence": self.convergence(),
            "stretch": self.stretch,
            "sigma_min_eig_min": float(self.sigma_min_eig.min()),
            "sigma_min_eig_final": float(self.sigma_min_eig[-1]),
            "sigma_positive": self.sigma_positive,
            **self.extra,
        }

    def table(self) -> str:
        """Markdown table: final value and last-stretch spread per parameter."""
        conv = self.convergence()
        lines = [
            f"NPFISI eps={self.settings.eps:g} gamma={self.settings.gamma:g} over {len(self.run_names)} run(s), "
            f"{self.t[-1] - self.t[0]:.2f} s; min eig(Sigma) = {self.sigma_min_eig.min():.3g}",
            "",
            "| parameter | final | last-stretch spread [%] |",
            "|---|---|---|",
        ]
        for n in self.names:
            c = conv[n]
            lines.append(f"| {n} | {c['final']:.5g} | {100 * c['rel_spread']:.3f} |")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike) -> None:
        """Write ``<path>.json`` (summary) and ``<path>.npz`` (trajectories)."""
        path = Path(path)
        atomic_write_text(path.with_suffix(".json"), json.dumps(self.to_dict(), indent=2))
        import io

        buf = io.BytesIO()
        np.savez_compressed(
            buf,
            t=self.t,
            theta=self.theta,
            sigma=self.sigma,
            sigma_min_eig=self.sigma_min_eig,
            run_start=self.run_start,
            names=np.array(self.names),
        )
        atomic_write_bytes(path.with_suffix(".npz"), buf.getvalue())


class NPFISI:
    """Reduced-order NPFISI estimator (seed eq. (3)) on the shared model.

    Parameters
    ----------
    settings : NPFISISettings
        Which parameters and the tuning.
    prior : Params
        Values of the parameters not estimated, the nominal values used for
        normalization and the default initial guess.
    Ts : float
        Sample period of the logs [s].

    Examples
    --------
    >>> est = NPFISI(NPFISISettings(names=("C2", "C3", "C4"), eps=0.01))
    >>> res = est.run(runs)            # doctest: +SKIP
    >>> res.final["C2"]                # doctest: +SKIP
    """

    def __init__(self, settings: NPFISISettings | None = None, prior: Params = NOMINAL, Ts: float = k.Ts):
        self.settings = settings or NPFISISettings()
        self.prior = prior
        self.Ts = Ts
        idx = [PARAM_NAMES.index(n) for n in self.settings.names]
        nom = prior.vector()[idx]
        # normalize by the prior's values; a zero prior (e.g. xi0 = 0) normalizes by its default
        fallback = NOMINAL.vector()[idx]
        self.theta_nom = np.where(np.abs(nom) > 0, nom, fallback)

    def _regressors(self, r: RunData, step: int) -> np.ndarray:
        """Masked normalized regressors ``M A diag(theta_nom)`` of every ``step``-th sample, shape (K, 4, n)."""
        s = self.settings
        lip = get_model().linear_split(s.names)
        xs, us = r.measured_state()[::step], r.u[::step]
        A, _ = eval_samples(lip, xs.T, us.T, self.prior.vector())
        # map stacks the 4 x n blocks side by side: column k*n + j is A_k[:, j]
        An = A.reshape(4, len(xs), len(s.names)) * self.theta_nom[None, None, :]
        return np.transpose(An * r.state_mask[:, None, None], (1, 0, 2))

    def _n_sub(self, An: np.ndarray, sig: np.ndarray) -> int:
        """RK4 steps per sample so that the fastest estimator mode times the step stays below 0.9.

        The error / parameter loop of eq. (3) has modes ``-1/eps`` and, where
        the adaptation gain ``mu = max ||A Sigma^-1/2||^2`` is large, a pair of
        modulus ``sqrt(mu / eps)``. ``An`` holds the regressors of the samples
        ahead (see :meth:`_regressors`).
        """
        s = self.settings
        if s.n_sub is not None:
            return int(s.n_sub)
        try:
            Lc = np.linalg.cholesky(0.5 * (sig + sig.T))
            W = np.linalg.solve(Lc, np.transpose(An, (0, 2, 1)))  # L^-1 A^T, shape (K, n, 4)
            mu = float(np.max(np.linalg.norm(W, ord=2, axis=(1, 2)) ** 2)) if len(An) else 0.0
        except np.linalg.LinAlgError:  # Sigma no longer positive definite: the run is diverging anyway
            mu = 0.0
        rate = max(1.0 / s.eps, math.sqrt(mu / s.eps))
        need = max(1, math.ceil(self.Ts * rate / 0.9))
        return int(min(2 ** math.ceil(math.log2(need)), MAX_SUB))

    def run(self, runs: Sequence[RunData], progress: bool = False) -> NPFISIResult:
        """Run the estimator over ``runs`` in order (theta and Sigma carried from run to run).

        Parameters
        ----------
        runs : sequence of RunData
            Logged runs with state estimates (see :meth:`RunData.with_states`).
        progress : bool
            Show a tqdm bar over the chunks.

        Returns
        -------
        NPFISIResult
        """
        s = self.settings
        runs = [r for r in runs if r.n >= 2]
        if not runs:
            raise ValueError("NPFISI needs at least one run with two or more samples")
        n = len(s.names)
        Q0 = s.matrix(s.Q0)
        Qg = s.matrix(s.Q) / s.gamma**2
        n_base = self._n_sub(np.zeros((0, 4, n)), np.eye(n))  # once Sigma is large only 1/eps matters
        p = self.prior.vector()
        const = np.concatenate([p, self.theta_nom, [1.0 / s.eps], Qg.ravel(order="F")])
        theta0 = np.array([(s.theta0 or {}).get(nm, getattr(self.prior, nm)) for nm in s.names], dtype=float)
        phi = theta0 / self.theta_nom
        sig = Q0.copy()

        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(
                total=sum(r.n - 1 for r in runs),
                desc=f"NPFISI eps={s.eps:g}",
                unit="sample",
                leave=False,
                unit_scale=True,
            )
        ts, ths, sigs, starts = [], [], [], []
        t_off = 0.0
        rec = 0
        n_sub_max = n_base
        for r in runs:
            y = r.measured_state()
            An_run = self._regressors(r, 5)
            starts.append(rec)
            z = np.concatenate([y[0], phi, sig.ravel(order="F")])
            traj = [z[None, :]]
            c0 = 0
            while c0 < r.n - 1:
                sig_now = z[4 + n :].reshape(n, n, order="F")
                n_sub = self._n_sub(An_run[c0 // 5 : (c0 + CHUNK_SHORT) // 5 + 1], sig_now)
                if n_sub > n_base:  # still stiff: short steps until Sigma has grown
                    chunk = CHUNK_SHORT
                else:
                    left = r.n - 1 - c0
                    chunk = next((c for c in CHUNKS if c <= left), CHUNK_SHORT)
                    n_sub = max(n_sub, self._n_sub(An_run[c0 // 5 : (c0 + chunk) // 5 + 1], sig_now))
                n_sub_max = max(n_sub_max, n_sub)
                chunk_fn = _step_function(s.names, n_sub, float(self.Ts), chunk)
                c1 = min(c0 + chunk, r.n - 1)
                m = c1 - c0
                S = np.zeros((15, chunk))
                S[0:4, :m] = y[c0:c1].T
                S[4:8, :m] = y[c0 + 1 : c1 + 1].T
                S[8:10, :m] = r.u[c0:c1].T
                S[10:14, :] = r.state_mask[:, None]
                S[14, :m] = 1.0
                (Z,) = call_numpy(chunk_fn, z, S, const)
                traj.append(Z[:, :m].T)
                z = Z[:, m - 1]
                c0 = c1
                if bar is not None:
                    bar.update(m)
            Zr = np.vstack(traj)
            phi = Zr[-1, 4 : 4 + n]
            sig = Zr[-1, 4 + n :].reshape(n, n, order="F")
            keep = np.arange(0, r.n, s.record_every)
            if keep[-1] != r.n - 1:
                keep = np.append(keep, r.n - 1)
            ts.append(t_off + keep * self.Ts)
            ths.append(Zr[keep, 4 : 4 + n] * self.theta_nom)
            sigs.append(Zr[keep, 4 + n :].reshape(-1, n, n, order="F"))
            rec += len(keep)
            t_off += r.n * self.Ts
        if bar is not None:
            bar.close()
        sigma = np.concatenate(sigs)
        sym = 0.5 * (sigma + np.transpose(sigma, (0, 2, 1)))
        with np.errstate(invalid="ignore"):
            min_eig = np.array([np.linalg.eigvalsh(m_)[0] if np.all(np.isfinite(m_)) else -np.inf for m_ in sym])
        return NPFISIResult(
            settings=s,
            t=np.concatenate(ts),
            theta=np.concatenate(ths),
            sigma=sigma,
            sigma_min_eig=min_eig,
            run_names=[r.name for r in runs],
            run_start=np.array(starts, dtype=int),
            n_sub=n_sub_max,
        )


def run_npfisi(
    runs: Sequence[RunData], names: Sequence[str], eps: float, prior: Params = NOMINAL, progress: bool = False, **kw
) -> NPFISIResult:
    """Shortcut: build :class:`NPFISI` with ``names``, ``eps`` (and any other setting) and run it."""
    return NPFISI(NPFISISettings(names=tuple(names), eps=eps, **kw), prior=prior).run(runs, progress=progress)
