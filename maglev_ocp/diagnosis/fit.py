"""The fitter: candidate effects (:mod:`.library` specs) fitted by least squares on top of the shared model.

Every candidate is an effect of :mod:`maglev_ocp.effects` (the same code that
makes the plant behave) composed on the shared model with
:meth:`~maglev_ocp.effects.EffectSet.accel`. Its physical parameters (a subset;
the rest fixed where the filtered data cannot resolve them, see each spec's
``note``) are fitted by weighted least squares on the filtered equation-error
residual of :mod:`.residuals`:

``min_w  1/2 sum_c sum_k s_c^2 (m_c[k] - (W a_c(Z; w))[k])^2``,  ``lo <= w <= hi``

solved by a bounded Levenberg-Marquardt method (:class:`CandidateFitter`):
the candidate's CasADi SX Function and its Jacobian in ``w`` are evaluated at
every sample at once with numpy (:mod:`.sxnumpy`), filtered by the sparse FIR
rows, and the Gauss-Newton step ``J^T J`` damped and kept within the bounds.
Nothing is built per fit, so re-solving on other data (the amplifier lag's
current filter) costs only the evaluations. (It replaced a CasADi
``sqpmethod`` per fit, whose builds and virtual-machine evaluations took 80 %
of a diagnosis; same objective; on six comparison datasets the same verdicts
and minima to 4 digits, except one lower and one slightly higher.) Standard errors come
from the same Gauss-Newton Jacobian in a Newey-West sandwich per run and
channel (:func:`maglev_ocp.estimation.ident.hac_stderr`).

The amplifier lag is the one dynamic effect: the plant filters the commanded
currents (:meth:`AmplifierLag.filter_currents`, reused here as it is), and the
candidate's ``bandwidth_hz`` is found by a bounded scalar search over the
effective delay, with the remaining parameters fitted at every trial. The
transfer-function members of its family (a lag of first or second order and a
fractional delay) are searched the same way over their group delay, the lag's
share of it and the damping (:mod:`.lagfit`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.optimize as spo

from ..effects import AmplifierLag, EffectSet
from ..estimation.ident import autocorr_factor, hac_stderr
from ..signals import PARAM_NAMES
from .fitdata import Dataset, one_blas_thread
from .lagfit import TF_LAWS, fit_lag_tf
from .library import CandidateSpec
from .residuals import Z_NAMES, PreparedRun, Residual, residual_of
from .sxnumpy import vectorized

_DEBUG = False  # print the SQP iterations
#: A chunk of Levenberg-Marquardt steps that lowers the objective (half the weighted sum of squares) by less
#: than this many times ``Dataset.prior_weight`` has stalled (:meth:`CandidateFitter.solve`): a tenth of one
#: independent sample's chi-square. An ill-conditioned fit crawls along a valley
#: by a few hundredths of that per step; at that rate it would need hundreds of steps to move its information
#: criterion by one unit, against selection margins of tens (seen: a cogging fit closing 63 % of a gap cut at the
#: iteration limit, lowering its objective by 0.06 per chunk where one independent sample weighs 17).
STALL_CHI2: float = 0.05

#: Solver outcomes of :meth:`CandidateFitter.solve` that count as a converged fit.
CONVERGED: tuple[str, ...] = ("converged", "stalled")
#: Levenberg-Marquardt steps of a profile search's trial (:meth:`CandidateFitter.solve_trial`).
TRIAL_ITERS: int = 3


# -------------------------------------------------------------------- functions
def _fname(name: str) -> str:
    """A CasADi Function name from a candidate name (``a+b`` -> ``a_b``)."""
    return "_".join(p for p in "".join(c if c.isalnum() else "_" for c in name).split("_") if p) or "x"


@functools.lru_cache(maxsize=64)
def _accel_function(spec: CandidateSpec) -> ca.Function:
    """``acc(z[8], p[8], w[n]) -> a[2]``: model + effects with the fitted values ``w`` (physical units)."""
    es = EffectSet(spec.effects)
    z = ca.SX.sym("z", 8)
    p = ca.SX.sym("p", len(PARAM_NAMES))
    w = ca.SX.sym("w", len(spec.free))
    values = {f.key: w[i] for i, f in enumerate(spec.free)}
    pe = [values.get(f"p.{n}", p[i]) for i, n in enumerate(PARAM_NAMES)]
    theta = []
    dflt = dict(zip(es.param_names, es.defaults(), strict=True))
    ties, fixed = dict(spec.ties), dict(spec.fixed)
    for key in es.param_names:
        if key in values:
            theta.append(values[key])
        elif key in ties:
            theta.append(values[ties[key]])
        elif key in fixed:
            theta.append(fixed[key])
        else:
            theta.append(dflt[key])
    x = z[0:4]
    u = z[4:6]
    a = es.accel(x, u, ca.vertcat(*pe), ca.vertcat(*theta) if theta else ca.SX(0, 1))
    return ca.Function(f"cand_{_fname(spec.name)}", [z, p, w], [a], ["z", "p", "w"], ["a"])


def accel_series(spec: CandidateSpec, Z: np.ndarray, p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per-period model acceleration ``(N-1, 2)`` of ``spec`` with values ``w`` on features ``Z``."""
    if len(Z) == 0:
        return np.zeros((0, 2))
    (a,) = evaluate(_accel_function(spec), np.ascontiguousarray(np.asarray(Z, float).T), p, w)
    return a[:, 0, :].T


def evaluate(f: ca.Function, Zt: np.ndarray, p: np.ndarray, w: np.ndarray) -> list[np.ndarray]:
    """Outputs of ``f(z, p, w)`` at every column of ``Zt`` (8 x N), each dense ``(rows, cols, N)``.

    Vectorized over the points with numpy (:func:`.sxnumpy.vectorized`, tens of
    times faster than CasADi's ``map`` on these small Functions); CasADi's
    ``map`` where the translation does not apply.
    """
    p, w = np.asarray(p, float), np.asarray(w, float)
    ev = vectorized(f)
    if ev is not None:
        return ev(Zt, p, w)
    N = Zt.shape[1]
    res = f.map(N)(Zt, p, w)
    res = res if isinstance(res, (list, tuple)) else [res]
    out = []
    for i, v in enumerate(res):
        sp = f.sparsity_out(i)
        out.append(np.asarray(v).reshape(sp.size1(), N, sp.size2()).transpose(0, 2, 1))
    return out


def lag_features(Z: np.ndarray, runs_u: np.ndarray, theta: Mapping[str, float]) -> np.ndarray:
    """``Z`` with the currents replaced by the amplifier's period-mean output (plant code reused)."""
    ua = AmplifierLag.filter_currents(runs_u, theta)
    Zl = Z.copy()
    Zl[:, 4:6] = ua[:-1]
    Zl[:, 6:8] = np.vstack([ua[:1], ua[:-2]])
    return Zl


@dataclass
class FitResult:
    """A fitted candidate.

    Attributes
    ----------
    spec : CandidateSpec
        What was fitted.
    w : ndarray
        Fitted values (physical units), order of ``spec.free``.
    stderr : ndarray
        Standard errors (Newey-West sandwich); NaN where the data do not determine a value.
    sse : float
        Weighted sum of squares on the training data.
    n : int
        Number of residual samples.
    inflation : float
        ``n / n_eff`` of the residual.
    extra : dict
        Values not in ``w`` (the lag's bandwidth and delay).
    success : bool
        The fit converged (SQP's test, or the objective stopped improving); see ``status``.
    status : str
        ``converged``, ``stalled``, ``iteration limit`` or ``failed`` (see :meth:`CandidateFitter.solve`).
    """

    spec: CandidateSpec
    w: np.ndarray
    stderr: np.ndarray
    sse: float
    n: int
    inflation: float
    extra: dict[str, float] = field(default_factory=dict)
    success: bool = True
    status: str = "converged"

    @property
    def k(self) -> int:
        """Number of fitted parameters."""
        lag = self.extra.get("lag_params", 1.0 if "effective_delay_s" in self.extra else 0.0)
        return len(self.w) + int(lag)

    def bic(self) -> float:
        """Information criterion with the effective sample size ``n_eff = n / inflation``.

        ``BIC = n_eff ln(SSE / n) + k ln(n_eff)``: the residual's autocorrelation
        makes ``n`` samples worth ``n_eff`` independent ones.
        """
        n_eff = max(self.n / self.inflation, 1.0)
        return n_eff * math.log(max(self.sse, 1e-300) / max(self.n, 1)) + self.k * math.log(n_eff)

    def params(self) -> dict[str, float]:
        """Fitted values by key, plus the lag's extra values."""
        out = {f.key: float(v) for f, v in zip(self.spec.free, self.w, strict=True)}
        out.update({k_: float(v) for k_, v in self.extra.items()})
        return out


class CandidateFitter:
    """Fits one candidate on one data set: bounded Levenberg-Marquardt on the filtered residual.

    Parameters
    ----------
    spec : CandidateSpec
        The candidate (with any jointly re-fitted model parameters in ``free``).
    data : Dataset
        Training data.
    p : ndarray
        Model parameter vector for the entries not fitted.
    prior : float
        Weight of a weak ridge ``prior/2 ||(w - w_start) / scale||^2`` that keeps
        directions the data do not determine (e.g. the phase of a harmonic whose
        amplitude is zero) well posed; against ``n`` unit-weighted residuals it
        does not move determined parameters.

    Notes
    -----
    The problem is ``min 1/2 ||r(s)||^2 + 1/2 sum pw (s - c0)^2`` over the
    scaled values ``s = w / scale`` within the bounds, with ``r`` the weighted
    filtered residual. The model acceleration and its Jacobian with respect to
    ``w`` are evaluated at every period by the candidate's SX Function
    vectorized over the periods (:func:`evaluate`), then filtered by the
    sparse FIR rows of the data (``W a``, ``W da/dw``). Each iteration takes the
    Gauss-Newton step damped by Marquardt's diagonal (``J^T J + lambda
    diag(J^T J)``), restricted to the bounds (a bounded least-squares
    subproblem on the Cholesky factor), accepted when it lowers the objective
    (the damping then shrinks by the gain ratio; a rejected step quadruples
    it). Nothing is built per fit but numpy arrays, so re-solving on other
    features (the amplifier lag's search) costs only the evaluations.
    """

    def __init__(self, spec: CandidateSpec, data: Dataset, p: np.ndarray, prior: float = 1.0):
        self.spec = spec
        self.data = data
        self.p = np.asarray(p, float)
        self.nw = len(spec.free)
        self.prior = prior
        self.chunk = 4  # accepted steps per chunk (max iterations = chunk * max_chunks)
        self.rtol = 1e-5  # relative: a chi-square change far below one unit on the data sizes of a diagnosis
        # absolute: a chunk that lowers the objective by less than STALL_CHI2 of one independent sample's
        # chi-square (``data.prior_weight`` weighted samples; the residual is autocorrelated) has stalled
        self.atol = STALL_CHI2 * data.prior_weight
        self.max_chunks = 16  # most fits stop long before (converged or stalled); hard joint fits need more
        self.scale = np.array([f.scale for f in spec.free])
        sc = np.where(self.scale > 0, self.scale, 1.0)
        self.s0 = np.array([f.start for f in spec.free]) / sc
        # Prior centre and weight of each scaled value: the weak ridge at the start, or a Free's Gaussian prior
        # (mean, sd) counted like one independent sample of the data (``data.prior_weight`` weighted ones).
        self.c0 = np.array([f.prior[0] if f.prior else f.start for f in spec.free]) / sc
        self.pw = np.array(
            [data.prior_weight * (sc[i] / f.prior[1]) ** 2 if f.prior else prior for i, f in enumerate(spec.free)]
        )
        self._spw = np.sqrt(self.pw)
        self._sw = [float(data.sqrt_w[c]) * data.row_w_c[c] for c in range(2)]
        self._cols = _jacobian_columns(spec)
        self._nonlin = sorted(set(self._cols[0][1]) | set(self._cols[1][1]))
        self._lin_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # channel -> (Zt, filtered linear columns)

    # ------------------------------------------------------------ evaluation
    def residual_jacobian(
        self, s: np.ndarray, Zt: np.ndarray, jac: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Weighted filtered residual (channel-major, then run) and its Jacobian in ``s`` (no prior rows)."""
        data, nw = self.data, self.nw
        w = np.asarray(s, float) * self.scale
        if jac:
            need = [c for c in range(2) if self._cols[c][0] and data.n_c[c]]
            hit = all((h := self._lin_cache.get(c)) is not None and h[0] is Zt for c in need)
            if hit and self._nonlin:
                # the linear columns are filtered already: the Jacobian of the others only
                A, dN = evaluate(_accel_nonlin_jac_function(self.spec), Zt, self.p, w)
                dA = np.zeros((2, nw, dN.shape[2]))
                dA[:, list(self._nonlin)] = dN
            elif hit:
                (A,) = evaluate(_accel_function(self.spec), Zt, self.p, w)
                dA = np.zeros((2, nw, A.shape[2]))
            else:
                A, dA = evaluate(_accel_jac_function(self.spec), Zt, self.p, w)
        else:
            (A,) = evaluate(_accel_function(self.spec), Zt, self.p, w)
        r_parts, j_parts = [], []
        for c in range(2):
            if data.n_c[c] == 0:
                continue
            sw = self._sw[c]
            if jac:
                # The acceleration and its Jacobian through the filter in one product, on the columns that can
                # be nonzero and change with w only: the filter is linear, so a column that is zero (the
                # parameter does not act on this channel, structurally or at these points) filters to zero,
                # and a column independent of w (a parameter entering linearly) is filtered once per features.
                lin, nonlin = self._cols[c]
                moving = [i for i in nonlin if np.any(dA[c, i])]
                F = data.filter(np.column_stack([np.ravel(A[c, 0]), dA[c, moving].T]), c)
                Jc = np.zeros((len(F), nw))
                Jc[:, moving] = F[:, 1:]
                if lin:
                    Jc[:, lin] = self._linear_columns(c, Zt, dA)
                r_parts.append(sw * (data.m_c[c] - F[:, 0]))
                j_parts.append(-(sw[:, None] * Jc) * self.scale[None, :])
            else:
                r_parts.append(sw * (data.m_c[c] - data.filter(np.ravel(A[c, 0]), c)))
        r = np.concatenate(r_parts) if r_parts else np.zeros(0)
        J = (np.vstack(j_parts) if j_parts else np.zeros((0, nw))) if jac else None
        return r, J

    def _linear_columns(self, c: int, Zt: np.ndarray, dA: np.ndarray) -> np.ndarray:
        """The filtered Jacobian columns of channel ``c`` that do not depend on ``w``, filtered once per ``Zt``."""
        hit = self._lin_cache.get(c)
        if hit is not None and hit[0] is Zt:
            return hit[1]
        lin = self._cols[c][0]
        F = self.data.filter(np.ascontiguousarray(dA[c, lin].T), c)
        self._lin_cache[c] = (Zt, F)
        return F

    def start_objective(self, w: np.ndarray) -> float:
        """The objective at values ``w`` (physical units, clipped to the bounds) on the training features: how
        good a start ``w`` is (``inf`` where not finite)."""
        lo, hi = self._scaled_bounds()
        s = np.clip(np.asarray(w, float) / self.scale, lo, hi)
        with one_blas_thread():
            r, _ = self.residual_jacobian(s, np.ascontiguousarray(np.asarray(self.data.Z, float).T), jac=False)
        f = self._objective(s, r)
        return f if math.isfinite(f) else math.inf

    def _scaled_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of the scaled values ``s = w / scale``."""
        return (np.array([f.lo for f in self.spec.free]) / self.scale,
                np.array([f.hi for f in self.spec.free]) / self.scale)  # fmt: skip

    def _objective(self, s: np.ndarray, r: np.ndarray) -> float:
        return 0.5 * float(r @ r) + 0.5 * float(np.sum(self.pw * (s - self.c0) ** 2))

    # --------------------------------------------------------------- solving
    def solve(self, Z: np.ndarray | None = None, starts: Sequence[np.ndarray] | None = None) -> FitResult:
        """Fit on the data (or on features ``Z`` of the same size); best of the given starts.

        The BLAS runs one thread here (:func:`one_blas_thread`): the products of a fit are small, and the
        fits' parallelism is the fit workers' (``fit_workers``).

        ``status`` is ``converged`` (the last accepted step lowered the
        objective by less than ``1e-12`` of it, or no step within the bounds
        lowers it), ``stalled`` (a chunk of :attr:`chunk` steps lowered it by
        less than :attr:`rtol` of it: directions the data leave undetermined
        then only crawl; accepted), or by less than :attr:`atol` (:data:`STALL_CHI2` of one independent
        sample's chi-square: what is left to gain cannot move a test), ``iteration limit`` (still improving after
        ``chunk * max_chunks`` steps) or ``failed`` (non-finite objective).
        """
        with one_blas_thread():
            return self._solve(Z, starts)

    def solve_trial(
        self, Z: np.ndarray, starts: Sequence[np.ndarray], done: Sequence[FitResult], iters: int | None = None
    ) -> FitResult:
        """A profile search's trial on features ``Z``: at most ``iters`` (default :data:`TRIAL_ITERS`)
        Levenberg-Marquardt steps from the best fit of ``done`` (the search's fits so far), without standard
        errors (``status`` ``trial``); a full :meth:`solve_from_best` when ``done`` holds no usable fit.

        A profile over a delay or a filter's shape is smooth, and the other parameters move little between
        neighbouring trials: a few steps from the best neighbour reach its minimum to the fit's own tolerance
        (the profile's value is at worst a little high where they do not, so the search still ranks trials
        right), where a full solve spends most of its steps confirming convergence. The search's chosen trial
        is then solved in full (:func:`finish_search`).
        """
        ok = [c for c in done if c.success and math.isfinite(c.sse)]
        if not ok:
            return self.solve_from_best(Z, starts, done)
        with one_blas_thread():
            fr = self._solve(Z, [min(ok, key=lambda c_: c_.sse).w], max_iter=iters or TRIAL_ITERS)
        return fr if fr.success else self.solve_from_best(Z, starts, done)

    def solve_from_best(self, Z: np.ndarray, starts: Sequence[np.ndarray], done: Sequence[FitResult]) -> FitResult:
        """:meth:`solve` on features ``Z`` (a delay search's trial) from the best converged fit of ``done``, the
        fits made so far in the search (a profile over the delay is smooth, and the other parameters move little
        with it), with the given ``starts`` as the fallback; every start when ``done`` holds none."""
        ok = [c for c in done if c.success]
        fr = self.solve(Z=Z, starts=starts if not ok else [min(ok, key=lambda c_: c_.sse).w])
        if ok and not fr.success:
            fr = self.solve(Z=Z, starts=starts)
        return fr

    def _solve(
        self, Z: np.ndarray | None, starts: Sequence[np.ndarray] | None, max_iter: int | None = None
    ) -> FitResult:
        spec = self.spec
        Z = self.data.Z if Z is None else Z
        Zt = np.ascontiguousarray(np.asarray(Z, float).T)
        if self.nw == 0:
            r, _ = self.residual_jacobian(np.zeros(0), Zt, jac=False)
            return FitResult(spec, np.zeros(0), np.zeros(0), float(r @ r), self.data.n, _inflation(r, self.data))
        scale = self.scale
        lo, hi = self._scaled_bounds()
        if starts is None:
            starts = [np.array([f.start for f in spec.free])]
        best = None
        for x0 in starts:
            x, f, status = self._solve_from(np.clip(np.asarray(x0) / scale, lo, hi), lo, hi, Zt, max_iter)
            if best is None or f < best[0] or not math.isfinite(best[0]):
                best = (f, x, status)
        f, s_opt, status = best
        if max_iter is not None:  # a search's trial: its objective only (no Jacobian, no standard errors)
            r, _ = self.residual_jacobian(s_opt, Zt, jac=False)
            sse = float(r @ r)
            ok = status != "failed" and math.isfinite(sse)
            nan = np.full(self.nw, math.nan)
            return FitResult(spec, s_opt * scale, nan, sse, self.data.n, 1.0, success=ok, status="trial")
        r, J = self.residual_jacobian(s_opt, Zt)
        sse = float(r @ r)
        infl = _inflation(r, self.data)
        half = math.ceil(self.data.filt.M / self.data.filt.decimate)
        stderr = hac_stderr(J, r, self.data.block_bounds, half) * scale
        ok = status in CONVERGED and math.isfinite(sse)
        return FitResult(spec, s_opt * scale, stderr, sse, self.data.n, infl, success=ok, status=status)

    def _solve_from(
        self, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, Zt: np.ndarray, max_iter: int | None = None
    ) -> tuple[np.ndarray, float, str]:
        """Bounded Levenberg-Marquardt from ``x``: ``(x, f, status)`` (see :meth:`solve`); at most
        ``max_iter`` steps when given (a search's trial: ``iteration limit`` after them)."""
        x = np.asarray(x, float).copy()
        r, J = self.residual_jacobian(x, Zt)
        f = self._objective(x, r)
        if not math.isfinite(f):
            return x, math.inf, "failed"
        lam = 1e-3
        f_chunk = f
        n_iter = self.chunk * self.max_chunks if max_iter is None else max_iter
        for it in range(1, n_iter + 1):
            # Gauss-Newton model of data + prior: H = J^T J + diag(pw), g = J^T r + pw (s - c0).
            H = J.T @ J + np.diag(self.pw)
            g = J.T @ r + self.pw * (x - self.c0)
            dh = np.maximum(np.diag(H), 1e-12 * max(float(np.max(np.diag(H))), 1e-300))
            step = None
            while lam < 1e12:
                d = _bounded_step(H + lam * np.diag(dh), g, lo - x, hi - x)
                x_new = np.clip(x + d, lo, hi)
                r_new, _ = self.residual_jacobian(x_new, Zt, jac=False)  # the Jacobian only where a step is taken
                f_new = self._objective(x_new, r_new)
                if math.isfinite(f_new) and f_new < f:
                    pred = -float(g @ d + 0.5 * d @ H @ d)
                    rho = (f - f_new) / pred if pred > 0 else 0.0
                    lam = max(lam * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), 1e-12)
                    step = (x_new, f_new)
                    break
                lam *= 4.0
            if step is None:
                return x, f, "converged"  # no step within the bounds lowers the objective
            rel = (f - step[1]) / max(abs(f), 1e-300)
            x, f = step
            if rel <= 1e-12:
                return x, f, "converged"
            if it % self.chunk == 0:
                # a chunk of steps that no longer lowers the objective: directions the data leave undetermined
                if f_chunk - f <= max(self.rtol * abs(f), self.atol):
                    return x, f, "stalled"
                f_chunk = f
            if it == n_iter:
                break  # the last step's Jacobian is not needed
            r, J = self.residual_jacobian(x, Zt)
        return x, f, "iteration limit"


def _bounded_step(M: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``argmin 1/2 d^T M d + g^T d`` over ``lo <= d <= hi`` (``M`` positive definite)."""
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        M = M + 1e-9 * np.trace(M) / len(M) * np.eye(len(M))
        L = np.linalg.cholesky(M)
    d = -np.linalg.solve(M, g)
    if np.all(d >= lo - 1e-15) and np.all(d <= hi + 1e-15):
        return np.clip(d, lo, hi)
    # 1/2 d^T L L^T d + g^T d = 1/2 ||L^T d + L^-1 g||^2 + const
    b = -np.linalg.solve(L, g)
    lo_, hi_ = np.minimum(lo, hi - 1e-300), hi
    res = spo.lsq_linear(L.T, b, bounds=(lo_, np.maximum(hi_, lo_ + 1e-300)), method="bvls")
    return np.clip(res.x, lo, hi)


@functools.lru_cache(maxsize=64)
def _accel_jac_function(spec: CandidateSpec) -> ca.Function:
    """``(z, p, w) -> (a[2], da/dw [2 x n])`` at the SX level (cheap to map over many periods)."""
    f = _accel_function(spec)
    z, p, w = ca.SX.sym("z", 8), ca.SX.sym("p", len(PARAM_NAMES)), ca.SX.sym("w", len(spec.free))
    a = f(z, p, w)
    return ca.Function(f"candj_{_fname(spec.name)}", [z, p, w], [a, ca.jacobian(a, w)], ["z", "p", "w"], ["a", "da_dw"])


@functools.lru_cache(maxsize=64)
def _accel_nonlin_jac_function(spec: CandidateSpec) -> ca.Function:
    """``(z, p, w) -> (a[2], da/dw_N [2 x |N|])`` with ``N`` the parameters that enter nonlinearly in a channel."""
    nonlin = sorted(set(_jacobian_columns(spec)[0][1]) | set(_jacobian_columns(spec)[1][1]))
    f = _accel_function(spec)
    z, p, w = ca.SX.sym("z", 8), ca.SX.sym("p", len(PARAM_NAMES)), ca.SX.sym("w", len(spec.free))
    a = f(z, p, w)
    jac = ca.jacobian(a, w[nonlin]) if nonlin else ca.SX(2, 0)
    return ca.Function(f"candn_{_fname(spec.name)}", [z, p, w], [a, jac], ["z", "p", "w"], ["a", "da_dwn"])


@functools.lru_cache(maxsize=64)
def _jacobian_columns(spec: CandidateSpec) -> tuple[tuple[list[int], list[int]], ...]:
    """Per channel, the parameters whose ``da_c/dw_i`` is structurally nonzero: ``(linear, nonlinear)``.

    ``linear``: the derivative does not depend on ``w`` (the parameter enters the acceleration linearly: its
    filtered column changes only with the features); ``nonlinear``: the rest. A parameter in neither does not
    act on that channel (its column is zero).
    """
    f = _accel_jac_function(spec)
    z, p, w = ca.SX.sym("z", 8), ca.SX.sym("p", len(PARAM_NAMES)), ca.SX.sym("w", len(spec.free))
    _, jac = f(z, p, w)
    sp = f.sparsity_out(1)
    out = []
    for c in range(2):
        lin, nonlin = [], []
        for i in range(len(spec.free)):
            if not sp.has_nz(c, i):
                continue
            (lin if not ca.depends_on(jac[c, i], w) else nonlin).append(i)
        out.append((lin, nonlin))
    return tuple(out)


def _inflation(r: np.ndarray, data: Dataset) -> float:
    """Autocorrelation inflation of the stacked weighted residual (mean over channels, sample-weighted)."""
    out, tot, i = 0.0, 0, 0
    for c in range(2):
        n = data.n_c[c]
        if n:
            out += n * autocorr_factor(r[i : i + n])
            tot += n
            i += n
    return out / tot if tot else 1.0


def fit_candidate(
    spec: CandidateSpec,
    data: Dataset,
    p: np.ndarray,
    u_runs: Sequence[np.ndarray] | None = None,
    max_delay: int = 3,
    warm: Mapping[str, float] | None = None,
    hold_lag: bool = False,
    alt: Mapping[str, float] | None = None,
) -> FitResult:
    """Fit one candidate on training data.

    Parameters
    ----------
    spec : CandidateSpec
        The candidate (possibly with C1..C4 free).
    data : Dataset
        Training data.
    p : ndarray
        Model parameter vector (baseline) for everything not fitted.
    u_runs : sequence of ndarray, optional
        Commanded currents of each run of ``data`` (needed by the amplifier lag).
    max_delay : int
        Largest whole-sample delay tried by the amplifier lag.
    warm : mapping, optional
        Values by key to start from (a warm start from earlier fits: the
        forward selection's joint refits start where the single fits ended);
        the lag's ``effective_delay_s`` then centres its search.
    hold_lag : bool
        Hold the lag's effective delay at the warm ``effective_delay_s`` (the
        other parameters refitted; its standard error is then NaN): a cheap
        trial refit of a model whose delay another fit has already searched.
    alt : mapping, optional
        Another start (a static candidate only): the one of ``warm`` and ``alt`` whose objective is lower is
        fitted from. A joint refit starts from the current model and the candidate's single fit (``warm``);
        that fit moved the constants to make room for the candidate (a saturation of the magnet field refits
        the PM attraction), and with the current model's constants its values can put the start orders of
        magnitude above the current model's objective (seen: 4e8 against 400), which the iteration limit
        did not undo. ``alt`` is the current model with the candidate at its spec's start.

    Returns
    -------
    FitResult
    """
    fitter = CandidateFitter(spec, data, p)
    starts = _starts(spec)
    if warm:
        starts = _starts(spec, np.array([warm.get(f.key, f.start) for f in spec.free]))
    if not spec.lag:
        if alt is not None:
            starts = min(starts, _starts(spec, np.array([alt.get(f.key, f.start) for f in spec.free])),
                         key=lambda st: fitter.start_objective(st[0]))  # fmt: skip
        return fitter.solve(starts=starts)
    if u_runs is None:
        raise ValueError("the amplifier lag needs the commanded currents of each run")
    if spec.law in TF_LAWS:  # a transfer function with a fractional delay (.lagfit)
        fr, extra = fit_lag_tf(
            fitter, finish_search, data, u_runs, _lag_Z_theta, max_delay, starts, warm, hold=hold_lag
        )
        return FitResult(fitter.spec, fr.w, fr.stderr, fr.sse, fr.n, fr.inflation, extra, fr.success, fr.status)
    t0 = warm.get("effective_delay_s") if warm else None
    return _fit_lag(fitter, data, u_runs, max_delay, starts, t0, hold=hold_lag)


def _starts(spec: CandidateSpec, x0: np.ndarray | None = None) -> list[np.ndarray]:
    """Initial guesses: ``x0`` (default the spec's), and other phases of the periodic terms.

    With a non-negative amplitude (``*_phase``) a start half a period off would
    drive the amplitude onto its bound, where the phase gradient vanishes, so a
    second start half a period away is added. A harmonic whose amplitude may
    change sign (``phi2``, ``phi3`` of cogging) has its phase defined modulo
    half a period, but the normal force (``|h| sin^2``) and the decay couple
    the harmonics, and a fit from one phase was seen to stop in another basin
    (held-out reduction 0.63 against 0.93 from the right one): each such phase
    also starts a quarter period away (every combination).
    """
    x0 = np.array([f.start for f in spec.free]) if x0 is None else np.asarray(x0, float)
    starts = [x0]
    phase_idx = [i for i, f in enumerate(spec.free) if f.key.endswith("_phase")]
    if phase_idx:
        x = x0.copy()
        x[phase_idx] += math.pi
        starts.append(x)
    signed = [i for i, f in enumerate(spec.free) if f.key.split(".")[-1] in ("phi2", "phi3")]
    for i in signed:
        shifted = []
        for x in starts:
            y = x.copy()
            y[i] += 0.5 * math.pi
            shifted.append(y)
        starts += shifted
    return starts


def lag_Z(data: Dataset, u_runs: Sequence[np.ndarray], bw: float, delay: int) -> np.ndarray:
    """Stacked features of ``data`` with the currents passed through the amplifier model."""
    theta = {"bandwidth_hz": bw, "delay_samples": delay}
    return np.vstack([lag_features(r.Z, u, theta) for r, u in zip(data.runs, u_runs, strict=True)])


def _lag_Z_theta(data: Dataset, u_runs: Sequence[np.ndarray], theta: Mapping[str, float]) -> np.ndarray:
    """Stacked features of ``data`` with the currents through the amplifier model ``theta`` (any member)."""
    return np.vstack([lag_features(r.Z, u, theta) for r, u in zip(data.runs, u_runs, strict=True)])


def lag_theta(t_eff: float, Ts: float = 1e-3) -> dict[str, float]:
    """Amplifier parameters for an effective delay ``t_eff`` [s]: whole samples of delay plus a lag.

    Below the residual's cut-off a first-order lag of time constant ``T`` and a
    transport delay ``T`` look alike (they differ at second order in
    ``omega T``), so the search runs over the effective delay and splits it
    into ``delay_samples = floor(t_eff / Ts)`` and ``bandwidth_hz = 1 / (2 pi r)``
    with the remainder ``r`` (capped at the library's upper bandwidth).
    """
    return AmplifierLag.equivalent(t_eff, Ts)


def finish_search(
    fitter: CandidateFitter, Z: np.ndarray, trial: FitResult, starts: Sequence[np.ndarray] | None
) -> FitResult:
    """The full solve (standard errors, convergence) at a profile search's chosen trial, from the trial's values;
    from ``starts`` as well if that one does not converge. A trial that was solved in full is returned as it is."""
    if trial.status != "trial":
        return trial
    fr = fitter.solve(Z=Z, starts=[trial.w])
    if not fr.success and starts is not None:
        alt = fitter.solve(Z=Z, starts=starts)
        fr = alt if alt.success or alt.sse < fr.sse else fr
    return fr


def _fit_lag(
    fitter: CandidateFitter,
    data: Dataset,
    u_runs: Sequence[np.ndarray],
    max_delay: int,
    starts: Sequence[np.ndarray] | None = None,
    t0: float | None = None,
    hold: bool = False,
) -> FitResult:
    Ts = data.filt.Ts
    t_max = (max_delay + 1) * Ts
    cache: dict[float, FitResult] = {}

    def features(key: float) -> np.ndarray:
        th = lag_theta(key, Ts)
        return lag_Z(data, u_runs, th["bandwidth_hz"], int(th["delay_samples"]))

    def sse(t_eff: float) -> float:
        # a trial of the profile search: a few steps from the best trial so far (the chosen one is solved in full)
        key = round(float(t_eff), 9)
        if key not in cache:
            cache[key] = fitter.solve_trial(features(key), starts, list(cache.values()))
        return cache[key].sse

    # A warm start (the single fit's delay) searches around it only; otherwise a grid over [0, t_max].
    # ``hold``: the effective delay held at ``t0`` (the other parameters refitted).
    if hold and t0 is not None:
        key = round(float(t0), 9)
        fr = fitter.solve_from_best(features(key), starts, [])
        th = lag_theta(key, Ts)
        extra = {**th, "effective_delay_s": float(t0), "effective_delay_s_stderr": math.nan}
        return FitResult(fitter.spec, fr.w, fr.stderr, fr.sse, fr.n, fr.inflation, extra, fr.success, fr.status)
    grid = np.linspace(max(t0 - 0.25 * Ts, 0.0), t0 + 0.25 * Ts, 3) if t0 is not None else np.linspace(0.0, t_max, 9)
    vals = [sse(t) for t in grid]
    j = int(np.argmin(vals))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    res = spo.minimize_scalar(sse, bounds=(a, b), method="bounded", options={"xatol": 2e-6})
    t_best = min(cache, key=lambda t_: cache[t_].sse)
    del res
    fr = cache[t_best] = finish_search(fitter, features(t_best), cache[t_best], starts)
    # Standard error of the effective delay from the curvature of the profile SSE.
    h = 2e-5
    c2 = (sse(t_best + h) - 2 * fr.sse + sse(max(t_best - h, 0.0))) / h**2 if t_best >= h else math.nan
    s2 = fr.sse / max(fr.n - fr.k - 1, 1) * fr.inflation
    se_t = math.sqrt(2 * s2 / c2) if c2 > 0 else math.nan
    th = lag_theta(t_best, Ts)
    extra = {**th, "effective_delay_s": t_best, "effective_delay_s_stderr": se_t}
    return FitResult(fitter.spec, fr.w, fr.stderr, fr.sse, fr.n, fr.inflation, extra, fr.success, fr.status)


def residuals_with(
    spec: CandidateSpec,
    fit: FitResult | None,
    runs: Sequence[PreparedRun],
    p: np.ndarray,
    u_runs: Sequence[np.ndarray] | None = None,
) -> list[Residual]:
    """Residuals of ``runs`` under a fitted candidate (or the baseline if ``fit`` is None)."""
    out = []
    w = fit.w if fit is not None else np.zeros(len(spec.free))
    for i, run in enumerate(runs):
        Z = run.Z
        if spec.lag and fit is not None and u_runs is not None and run.n > 0:
            Z = lag_features(run.Z, u_runs[i], fit.extra)  # the fitted member's amplifier (any law)
        if run.n == 0:
            out.append(Residual(run, np.zeros((0, 2)), np.zeros((0, 2))))
            continue
        out.append(residual_of(run, accel_series(spec, Z, p, w)))
    return out


def resolution_spread(
    spec: CandidateSpec,
    fit: FitResult | None,
    runs: Sequence[PreparedRun],
    p: np.ndarray,
    dv: float,
    u_runs: Sequence[np.ndarray] | None = None,
    wide: float = 10.0,
) -> list[np.ndarray]:
    """How much each filtered residual sample's model acceleration can change within the velocity resolution.

    The velocities of the residual are differentiated, smoothed encoder
    readings: below a resolution ``dv`` (one encoder count per smoother time
    constant) they are not measured, and a law that is steep there (friction's
    sign and Stribeck terms: the force of a guide that sticks is anything up to
    the breakaway force, NOTES.md) is not determined by the data. Per period,
    the largest change of the model acceleration when either velocity moves by
    ``+-dv``, beyond what the law's slope over ``+-wide dv`` gives (a law linear
    in the velocity, viscous friction or eddy drag, is resolved: a velocity
    error only adds noise) and at most the change itself; through the absolute filter rows, its bound on each
    residual sample (same shape as the residual, ``(n_c, 2)`` per run, m/s^2).
    """
    out = []
    w = fit.w if fit is not None else np.zeros(len(spec.free))
    for i, run in enumerate(runs):
        if run.n == 0:
            out.append(np.zeros((0, 2)))
            continue
        Z = run.Z
        if spec.lag and fit is not None and u_runs is not None:
            Z = lag_features(run.Z, u_runs[i], fit.extra)  # the fitted member's amplifier (any law)
        a0 = accel_series(spec, Z, p, w)
        s = np.zeros_like(a0)
        for col in (Z_NAMES.index("g_dot"), Z_NAMES.index("d_dot")):
            at = {}
            for m in (-wide, -1.0, 1.0, wide):
                Zp = np.array(Z, float)
                Zp[:, col] += m * dv
                at[m] = accel_series(spec, Zp, p, w)
            slope_dv = (at[wide] - at[-wide]) / (2.0 * wide)  # the law's slope over +-wide resolutions, times dv
            for m in (-1.0, 1.0):
                step = at[m] - a0
                # The change beyond the slope, and never more than the change itself (a wide chord across a
                # sign change has a slope that the law away from it does not have).
                s = np.maximum(s, np.minimum(np.abs(step), np.abs(step - m * slope_dv)))
        out.append(np.asarray(abs(run.W) @ s))
    return out


__all__ = [
    "CONVERGED",
    "STALL_CHI2",
    "CandidateFitter",
    "Dataset",
    "FitResult",
    "accel_series",
    "evaluate",
    "fit_candidate",
    "lag_Z",
    "lag_features",
    "lag_theta",
    "residuals_with",
    "resolution_spread",
]
