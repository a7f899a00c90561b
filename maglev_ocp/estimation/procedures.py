"""The seed's model-verification procedures (section V) on any rig-log dataset.

Which procedure runs is decided by the runs themselves (their ``locked`` field
and content), never by file names or metadata:

* **V.A horizontal** - runs with the gap locked that contain a stretch of
  constant, non-zero ``i_q`` while d moves (the parabola runs): L1 at each
  gap from a parabola fit of d(t) (seed eq. (5)) and from NPFISI on the
  seed's eq. (4) (C1 alone, no cogging), for each eps (Fig. 3, 4);
* **V.B vertical** - runs with d locked where the cogging vanishes
  (``sin(pi d / t1) ~ 0``, e.g. d = 0): C2, C3, C4 by NPFISI for each eps
  (Table II); measured equilibrium currents against eq. (8) (Fig. 5);
* **V.C cogging** - runs with d locked at a cogging peak
  (``|sin(pi d / t1)| ~ 1``, e.g. 3 t1 / 2): C2 re-estimated with C3, C4
  from V.B; the peak cogging force xi(g) from the difference (seed-style,
  one C2 over all gaps, and gap by gap against the d = 0 run at the same
  gap), then the law ``xi0 exp(-(g - 10 mm) / ell)`` fitted (Fig. 6, 7);
* **V.D full span** - runs with both axes free: C1..C4 together by NPFISI
  for each eps (Table III), with the cogging law of V.C in the model when V.C
  ran (Fig. 8, 9).

Measured equilibrium currents are read off a hover run without assuming
anything about its controller: ``i_d`` is regressed on the gap deviation and
the filtered gap acceleration (the linearized vertical dynamics), and the
intercept is the current that holds the mean gap at rest.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import constants as k
from ..model import get_model
from ..params import Params
from .data import RunData
from .ident import filtered_acceleration, gaussian_kernel
from .npfisi import NPFISIResult, run_npfisi

#: The seed's three values of eps.
SEED_EPS: tuple[float, ...] = (0.001, 0.01, 0.05)
#: eps whose estimates the later procedures build on (the seed's choice).
MAIN_EPS = 0.01


# ------------------------------------------------------------------- run classes
def cogging_phase(d: float) -> float:
    """``|sin(pi d / t1)|``: 0 where the cogging force vanishes, 1 at its peaks (seed V.C)."""
    return abs(math.sin(math.pi * d / k.t1))


def constant_segment(i_q: np.ndarray, min_len: int = 50, min_abs: float = 1e-3) -> tuple[int, int] | None:
    """Longest stretch ``[i0, i1)`` of exactly constant, non-zero ``i_q`` (None if shorter than ``min_len``)."""
    if len(i_q) < min_len:
        return None
    change = np.flatnonzero(np.diff(i_q) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [len(i_q)]])
    best = None
    for a, b in zip(starts, ends, strict=True):
        if abs(i_q[a]) > min_abs and b - a >= min_len and (best is None or b - a > best[1] - best[0]):
            best = (int(a), int(b))
    return best


@dataclass
class RunGroups:
    """The runs of a dataset sorted by what they can be used for."""

    parabola: list[tuple[RunData, tuple[int, int]]] = field(default_factory=list)
    hover_d0: list[RunData] = field(default_factory=list)
    hover_cog: list[RunData] = field(default_factory=list)
    free: list[RunData] = field(default_factory=list)
    other: list[RunData] = field(default_factory=list)

    def summary(self) -> dict[str, list[str]]:
        """Run names per group."""
        return {
            "parabola": [r.name for r, _ in self.parabola],
            "hover_d0": [r.name for r in self.hover_d0],
            "hover_cog": [r.name for r in self.hover_cog],
            "free": [r.name for r in self.free],
            "other": [r.name for r in self.other],
        }


def classify(runs: Sequence[RunData]) -> RunGroups:
    """Sort runs by their locked axes and content (see the module docstring)."""
    grp = RunGroups()
    for r in runs:
        if r.locked == ("g",):
            seg = constant_segment(r.u[:, 0])
            if seg is not None and np.ptp(r.y[seg[0] : seg[1], 1]) > 0.01:
                grp.parabola.append((r, seg))
            else:
                grp.other.append(r)
        elif r.locked == ("d",):
            ph = cogging_phase(float(np.median(r.y[:, 1])))
            quiet_q = float(np.max(np.abs(r.u[:, 0]))) < 1e-6  # u1 = 0 as in the seed
            if ph < 0.05 and quiet_q:
                grp.hover_d0.append(r)
            elif ph > 0.95 and quiet_q:
                grp.hover_cog.append(r)
            else:
                grp.other.append(r)
        else:
            grp.free.append(r)
    key = lambda r: float(np.mean(r.y[:, 0]))  # noqa: E731
    grp.hover_d0.sort(key=key)
    grp.hover_cog.sort(key=key)
    grp.parabola.sort(key=lambda rs: float(rs[0].y[0, 0]))
    return grp


def segment(r: RunData, i0: int, i1: int) -> RunData:
    """Samples ``[i0, i1)`` of a run as a run of its own."""
    return RunData(
        r.name, r.t[i0:i1], r.y[i0:i1], r.u[i0:i1], r.locked, x_hat=None if r.x_hat is None else r.x_hat[i0:i1], Ts=r.Ts
    )


# ------------------------------------------------------------- model helpers
def equilibrium_i_d(g: float, d: float, p: np.ndarray, i_q: float = 0.0) -> float:
    """Current i_d that holds the gap ``g`` at rest with d held at ``d`` and the given i_q.

    The root of the model's vertical acceleration (shared ``f``) in i_d closest
    to the cogging-free eq. (8) root, by Newton's method from it; NaN if none.
    """
    m = get_model()
    i = float(m.i_d_eq(g, p))
    if not math.isfinite(i):
        return math.nan
    for _ in range(30):
        a = float(m.f([g, 0.0, d, 0.0], [i_q, i], p)[1])
        _, B = m.linearization([g, 0.0, d, 0.0], [i_q, i], p)
        da = float(B[1, 1])
        if da == 0:
            return math.nan
        step = a / da
        i -= step
        if abs(step) < 1e-12:
            break
    return i if abs(float(m.f([g, 0.0, d, 0.0], [i_q, i], p)[1])) < 1e-6 else math.nan


def f1_of(g: float) -> float:
    """Shape function ``f1(g)`` of the thrust (L1 = C1 f1)."""
    return float(get_model().shape(g)[3])


def measured_equilibrium(r: RunData, sigma_t: float = 0.01) -> dict[str, float]:
    """Mean gap and the equilibrium current of a hover run with d locked.

    ``i_d`` (filtered) is regressed on ``[1, g - g_mean, a_g]`` (filtered gap
    deviation and acceleration); the intercept is the current holding
    ``g_mean`` at rest. Works for any controller and for plain hover
    (then the regression reduces to the mean).
    """
    h = gaussian_kernel(sigma_t, 4.0, r.Ts)
    half = (len(h) - 1) // 2
    g = r.y[:, 0]
    if r.n < len(h) + 10:
        return {"g": float(g.mean()), "i_d": float(r.u[:, 1].mean()), "i_d_mean": float(r.u[:, 1].mean())}
    a = filtered_acceleration(g, h, r.Ts)  # centred on samples half+1 .. n-half-2
    sl = slice(half + 1, half + 1 + len(a))
    gf = np.convolve(g, h, mode="same")[sl]
    # current held over [t_k-1, t_k+1]: mean of the two samples, filtered
    u_avg = 0.5 * (r.u[:, 1] + np.concatenate([r.u[:1, 1], r.u[:-1, 1]]))
    idf = np.convolve(u_avg, h, mode="same")[sl]
    g0 = float(gf.mean())
    X = np.column_stack([np.ones_like(gf), gf - g0, a])
    coef, *_ = np.linalg.lstsq(X, idf, rcond=1e-10)
    return {"g": g0, "i_d": float(coef[0]), "i_d_mean": float(r.u[:, 1].mean())}


def _npfisi_by_eps(runs, names, prior, eps_list, progress, **kw) -> dict[float, NPFISIResult]:
    return {eps: run_npfisi(runs, names, eps, prior=prior, progress=progress, **kw) for eps in eps_list}


# ----------------------------------------------------------------------- V.A
@dataclass
class HorizontalResult:
    """V.A: L1 at locked gaps from parabola fits and from NPFISI on eq. (4).

    Attributes
    ----------
    rows : list of dict
        Per run: ``run, g, i_q, n, L1_fit, L1_model`` (prior C1) and ``L1_npfisi`` per eps.
    fits : list of dict
        Per run: time, position and fitted parabola (for Fig. 3).
    npfisi : dict
        ``{eps: [NPFISIResult per run]}``.
    """

    rows: list[dict]
    fits: list[dict]
    npfisi: dict[float, list[NPFISIResult]]

    def to_dict(self) -> dict:
        """Plain data for JSON."""
        return {"rows": self.rows}

    def table(self) -> str:
        """Markdown table of L1 by gap and method."""
        eps = sorted(self.npfisi)
        lines = [
            "| g [mm] | L1 parabola fit | " + " | ".join(f"L1 NPFISI eps={e:g}" for e in eps) + " | L1 prior model |",
            "|---" * (3 + len(eps)) + "|",
        ]
        for r in self.rows:
            lines.append(
                f"| {r['g'] * 1e3:.2f} | {r['L1_fit']:.4f} | "
                + " | ".join(f"{r['L1_npfisi'][e]:.4f}" for e in eps)
                + f" | {r['L1_model']:.4f} |"
            )
        return "\n".join(lines)


def procedure_va(
    groups: RunGroups, prior: Params, eps_list: Sequence[float] = SEED_EPS, progress: bool = False
) -> HorizontalResult | None:
    """Seed V.A on the parabola runs (None if there are none)."""
    if not groups.parabola:
        return None
    prior_eq4 = prior.without_cogging()  # the seed's eq. (4) has no cogging
    rows, fits = [], []
    npf: dict[float, list[NPFISIResult]] = {e: [] for e in eps_list}
    for r, (i0, i1) in groups.parabola:
        seg = segment(r, i0, i1)
        g = float(seg.y[0, 0])
        i_q = float(seg.u[0, 0])
        t = seg.t - seg.t[0]
        d = seg.y[:, 1]
        # seed eq. (5) with the start velocity free: d = d0 + v0 t + a t^2 / 2, a = -L1 i_q
        c2, c1, c0 = np.polyfit(t, d, 2)
        L1_fit = -2 * c2 / i_q
        f1 = f1_of(g)
        row = {
            "run": r.name,
            "g": g,
            "i_q": i_q,
            "n": seg.n,
            "L1_fit": float(L1_fit),
            "L1_model": prior.C1 * f1,
            "C1_fit": float(L1_fit / f1),
            "L1_npfisi": {},
            "C1_npfisi": {},
        }
        for e in eps_list:
            res = run_npfisi([seg], ("C1",), e, prior=prior_eq4, progress=progress, record_every=2)
            npf[e].append(res)
            row["L1_npfisi"][e] = res.final["C1"] * f1
            row["C1_npfisi"][e] = res.final["C1"]
        rows.append(row)
        fits.append({"run": r.name, "g": g, "t": t, "d": d, "d_fit": c0 + c1 * t + c2 * t**2})
    return HorizontalResult(rows, fits, npf)


# ----------------------------------------------------------------------- V.B
@dataclass
class VerticalResult:
    """V.B: C2, C3, C4 by NPFISI at d = 0 (Table II) and equilibrium currents (Fig. 5).

    Attributes
    ----------
    npfisi : dict
        ``{eps: NPFISIResult}`` over the d = 0 hover runs, chained by gap.
    equilibrium : list of dict
        Per run: mean gap, measured equilibrium i_d, and eq. (8) with the eps = 0.01 estimates.
    """

    npfisi: dict[float, NPFISIResult]
    equilibrium: list[dict]

    def params(self, eps: float = MAIN_EPS) -> dict[str, float]:
        """C2, C3, C4 estimated with ``eps``."""
        return self.npfisi[eps].final

    def to_dict(self) -> dict:
        """Plain data for JSON."""
        return {
            "table_II": {str(e): r.final for e, r in self.npfisi.items()},
            "npfisi": {str(e): r.to_dict() for e, r in self.npfisi.items()},
            "equilibrium": self.equilibrium,
        }

    def table(self) -> str:
        """Markdown Table II (parameters by eps), then the equilibrium currents."""
        eps = sorted(self.npfisi)
        lines = ["| parameter | " + " | ".join(f"eps = {e:g}" for e in eps) + " |", "|---" * (1 + len(eps)) + "|"]
        for n in ("C2", "C3", "C4"):
            lines.append(f"| {n} | " + " | ".join(f"{self.npfisi[e].final[n]:.5g}" for e in eps) + " |")
        lines += ["", "| g [mm] | measured i_d,eq [A] | eq. (8), eps=0.01 [A] | difference [mA] |", "|---|---|---|---|"]
        for q in self.equilibrium:
            lines.append(
                f"| {q['g'] * 1e3:.2f} | {q['i_d']:.4f} | {q['i_d_theory']:.4f} | "
                f"{1e3 * (q['i_d'] - q['i_d_theory']):+.1f} |"
            )
        return "\n".join(lines)


def procedure_vb(
    groups: RunGroups, prior: Params, eps_list: Sequence[float] = SEED_EPS, progress: bool = False
) -> VerticalResult | None:
    """Seed V.B on the hover runs with d locked where cogging vanishes (None if there are none)."""
    runs = groups.hover_d0
    if not runs:
        return None
    npf = _npfisi_by_eps(runs, ("C2", "C3", "C4"), prior, eps_list, progress)
    main = npf[MAIN_EPS] if MAIN_EPS in npf else npf[sorted(npf)[len(npf) // 2]]
    p_est = prior.with_(**main.final).without_cogging().vector()
    eq = []
    for r in runs:
        q = measured_equilibrium(r)
        q["run"] = r.name
        q["i_d_theory"] = float(get_model().i_d_eq(q["g"], p_est))  # seed eq. (8)
        eq.append(q)
    return VerticalResult(npf, eq)


# ----------------------------------------------------------------------- V.C
@dataclass
class CoggingResult:
    """V.C: C2 at a cogging peak, the peak cogging force xi(g) and the fitted law.

    Attributes
    ----------
    C2_peak : float
        C2 re-estimated over all peak-cogging runs (C3, C4 from V.B).
    C2_d0 : float
        C2 of V.B (eps = 0.01).
    per_gap : list of dict
        Per gap with runs at both positions: ``g``, C2 at d = 0 and at the
        peak, ``xi`` [N] from the difference.
    xi0, ell : float
        Fitted cogging law (NaN if it could not be fitted).
    equilibrium : list of dict
        Measured equilibrium currents at the cogging peak with predictions
        without and with the fitted cogging (Fig. 7).
    npfisi : NPFISIResult or None
        The NPFISI run over all peak runs.
    warning : str
        Why the cogging law is missing or doubtful (empty if it fitted).
    """

    eps: float
    C2_peak: float
    C2_d0: float
    per_gap: list[dict]
    xi0: float
    ell: float
    d_peak: float
    equilibrium: list[dict]
    npfisi: NPFISIResult | None = None
    warning: str = ""

    def xi_seed(self, g: np.ndarray | float) -> np.ndarray:
        """Seed-style estimate ``xi(g) = Mv (C2_peak - C2_d0) f2(g)`` [N] (one C2 over all gaps)."""
        f2 = np.array([float(get_model().shape(gi)[4]) for gi in np.atleast_1d(g)])
        return k.Mv * (self.C2_peak - self.C2_d0) * f2

    def xi_law(self, g: np.ndarray | float) -> np.ndarray:
        """Fitted law ``xi0 exp(-(g - 10 mm) / ell)`` [N]."""
        return self.xi0 * np.exp(-(np.asarray(g, float) - k.g_cog_ref) / self.ell)

    def to_dict(self) -> dict:
        """Plain data for JSON (every field but ``npfisi``, under its own name)."""
        keys = ("eps", "C2_peak", "C2_d0", "d_peak", "per_gap", "xi0", "ell", "equilibrium", "warning")
        return {key: getattr(self, key) for key in keys}

    def table(self) -> str:
        """Markdown table of the peak cogging force by gap."""
        lines = [
            f"C2 at the cogging peak (d = {self.d_peak * 1e3:.3f} mm): {self.C2_peak:.5g}; at d = 0: "
            f"{self.C2_d0:.5g}. Fitted law: xi0 = {self.xi0:.4g} N, ell = {self.ell * 1e3:.4g} mm.",
            "",
            "| g [mm] | C2 (d=0) | C2 (peak) | xi gap by gap [N] | xi seed-style [N] | xi law [N] |",
            "|---|---|---|---|---|---|",
        ]
        for q in self.per_gap:
            lines.append(
                f"| {q['g'] * 1e3:.2f} | {q['C2_d0']:.5g} | {q['C2_peak']:.5g} | {q['xi']:.4f} | "
                f"{float(self.xi_seed(q['g'])[0]):.4f} | {float(self.xi_law(q['g'])):.4f} |"
            )
        return "\n".join(lines)


#: Bounds of the V.C cogging law ``(xi0 [N], ell [m])``: physical (xi0 >= 0, ell > 0) and plausible.
COGGING_LAW_BOUNDS: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 2e-4), (1e3, 0.1))


def _fit_cogging_law(g: np.ndarray, xi: np.ndarray, w: np.ndarray) -> tuple[float, float, str]:
    """Weighted least squares of ``xi = xi0 exp(-(g - 10 mm)/ell)`` within :data:`COGGING_LAW_BOUNDS`.

    Returns ``(xi0, ell, warning)``: NaN, NaN and the reason when the law is not
    determined or the fit fails; the values and a warning when an estimate ends
    on a bound (the peak forces do not follow the law); ``warning`` is empty otherwise.
    """
    from scipy.optimize import least_squares

    ok = np.isfinite(xi) & np.isfinite(w)
    g, xi, w = g[ok], xi[ok], w[ok]
    if len(g) < 3 or np.max(xi) <= 0:
        return math.nan, math.nan, "V.C: the peak cogging forces do not determine the law (fewer than 3, or none > 0)"
    pos = xi > 0.05 * np.max(xi)
    if pos.sum() >= 2:  # start from a log-linear fit of the clearly positive points
        b, a = np.polyfit(g[pos] - k.g_cog_ref, np.log(xi[pos]), 1)
        x0 = [math.exp(a), -1.0 / b if b < 0 else 5e-3]
    else:
        x0 = [float(np.max(xi)), 5e-3]
    lo, hi = (np.array(b_) for b_ in COGGING_LAW_BOUNDS)
    # the log-linear start can fall outside the bounds (e.g. forces that hardly decay with the gap)
    x0 = np.clip(x0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))

    def res(v):
        return w * (xi - v[0] * np.exp(-(g - k.g_cog_ref) / v[1]))

    try:
        sol = least_squares(res, x0, bounds=(lo, hi), x_scale=[max(x0[0], 1e-3), 1e-3])
    except (ValueError, np.linalg.LinAlgError) as err:
        return math.nan, math.nan, f"V.C: the cogging law fit failed ({err})"
    if not (sol.success and np.all(np.isfinite(sol.x))):
        return math.nan, math.nan, f"V.C: the cogging law fit did not converge ({sol.message})"
    xi0, ell = float(sol.x[0]), float(sol.x[1])
    at = [n for n, v, a, b_ in zip(("xi0", "ell"), sol.x, lo, hi, strict=True) if min(v - a, b_ - v) <= 1e-6 * (b_ - a)]
    if at:
        return (
            xi0,
            ell,
            (
                f"V.C: cogging law {', '.join(at)} at its bound (xi0 = {xi0:.3g} N, ell = {ell * 1e3:.3g} mm): "
                "the peak cogging forces do not follow xi0 exp(-(g - 10 mm)/ell)"
            ),
        )
    return xi0, ell, ""


def procedure_vc(
    groups: RunGroups, prior: Params, vb: VerticalResult | None, eps: float = MAIN_EPS, progress: bool = False
) -> CoggingResult | None:
    """Seed V.C on the hover runs with d locked at a cogging peak (needs V.B; None otherwise)."""
    runs = groups.hover_cog
    if not runs or vb is None:
        return None
    base = prior.with_(**vb.params(MAIN_EPS) if MAIN_EPS in vb.npfisi else vb.npfisi[sorted(vb.npfisi)[0]].final)
    base0 = base.without_cogging()
    res_all = run_npfisi(runs, ("C2",), eps, prior=base0, progress=progress)
    C2_peak = res_all.final["C2"]
    C2_d0 = base.C2
    d_peak = float(np.median(runs[0].y[:, 1]))
    # gap by gap: C2 at the peak minus C2 at d = 0, both from runs at the same gap
    per_gap = []
    g_d0 = np.array([float(np.mean(r.y[:, 0])) for r in groups.hover_d0])
    for r in runs:
        g = float(np.mean(r.y[:, 0]))
        j = int(np.argmin(np.abs(g_d0 - g))) if len(g_d0) else -1
        if j < 0 or abs(g_d0[j] - g) > 0.3e-3:  # needs a d = 0 run at the same gap
            continue
        r0 = groups.hover_d0[j]
        c_peak = run_npfisi([r], ("C2",), eps, prior=base0).final["C2"]
        c_zero = run_npfisi([r0], ("C2",), eps, prior=base0).final["C2"]
        f2 = float(get_model().shape(g)[4])
        xi = k.Mv * (c_peak - c_zero) * f2  # attractive normal cogging: C2' f2 = C2 f2 + xi / Mv
        per_gap.append({"g": g, "C2_peak": c_peak, "C2_d0": c_zero, "xi": xi, "run_peak": r.name, "run_d0": r0.name})
    if len(per_gap) >= 3:
        g = np.array([q["g"] for q in per_gap])
        xi = np.array([q["xi"] for q in per_gap])
        xi0, ell, warning = _fit_cogging_law(g, xi, np.ones_like(g))
    else:
        xi0, ell, warning = math.nan, math.nan, "V.C: fewer than 3 gaps with runs at the peak and at d = 0"
    # Fig. 7: measured equilibrium currents at the peak vs predictions without / with cogging
    eq = []
    p_nc = base0.vector()
    p_c = base.with_(xi0=xi0, ell=ell).vector() if math.isfinite(xi0) else None
    for r in runs:
        q = measured_equilibrium(r)
        q["run"] = r.name
        q["d"] = float(np.median(r.y[:, 1]))
        q["i_d_no_cogging"] = equilibrium_i_d(q["g"], q["d"], p_nc)
        q["i_d_with_cogging"] = equilibrium_i_d(q["g"], q["d"], p_c) if p_c is not None else math.nan
        eq.append(q)
    return CoggingResult(eps, C2_peak, C2_d0, per_gap, xi0, ell, d_peak, eq, res_all, warning)


# ----------------------------------------------------------------------- V.D
@dataclass
class FullSpanResult:
    """V.D: C1..C4 together by NPFISI over the free runs (Table III)."""

    npfisi: dict[float, NPFISIResult]
    cogging: dict[str, float]

    def to_dict(self) -> dict:
        """Plain data for JSON."""
        return {
            "table_III": {str(e): r.final for e, r in self.npfisi.items()},
            "cogging_in_model": self.cogging,
            "npfisi": {str(e): r.to_dict() for e, r in self.npfisi.items()},
        }

    def table(self) -> str:
        """Markdown Table III (parameters by eps) with each estimate's last-stretch spread."""
        eps = sorted(self.npfisi)
        lines = ["| parameter | " + " | ".join(f"eps = {e:g}" for e in eps) + " |", "|---" * (1 + len(eps)) + "|"]
        for n in ("C1", "C2", "C3", "C4"):
            cells = []
            for e in eps:
                c = self.npfisi[e].convergence()[n]
                cells.append(f"{c['final']:.5g} (±{100 * c['rel_spread'] / 2:.2g} %)")
            lines.append(f"| {n} | " + " | ".join(cells) + " |")
        lines.append("")
        lines.append("(± half the relative spread of the estimate over the last 20 % of the data)")
        return "\n".join(lines)


def procedure_vd(
    groups: RunGroups,
    prior: Params,
    vc: CoggingResult | None,
    eps_list: Sequence[float] = SEED_EPS,
    progress: bool = False,
) -> FullSpanResult | None:
    """Seed V.D on the free runs (None if there are none); cogging from V.C in the model when available."""
    runs = groups.free
    if not runs:
        return None
    base = prior
    if vc is not None and math.isfinite(vc.xi0):
        base = prior.with_(xi0=vc.xi0, ell=vc.ell)
    npf = _npfisi_by_eps(runs, ("C1", "C2", "C3", "C4"), base, eps_list, progress)
    return FullSpanResult(npf, {"xi0": base.xi0, "ell": base.ell, "source": "V.C" if base is not prior else "prior"})


__all__ = [
    "MAIN_EPS",
    "SEED_EPS",
    "CoggingResult",
    "FullSpanResult",
    "HorizontalResult",
    "RunGroups",
    "VerticalResult",
    "classify",
    "constant_segment",
    "equilibrium_i_d",
    "measured_equilibrium",
    "procedure_va",
    "procedure_vb",
    "procedure_vc",
    "procedure_vd",
]
