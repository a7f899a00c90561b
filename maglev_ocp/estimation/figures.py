"""The seed's calibration figures (Fig. 3-9) and the estimator diagnostics, as PNG files.

Each function takes the result objects of :mod:`.procedures` / :mod:`.batch`
and writes one figure atomically (Agg backend, axes labelled with units).
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ..model import get_model
from ..output import atomic_write_bytes
from ..params import Params
from .batch import BatchResult
from .procedures import (
    MAIN_EPS,
    CoggingResult,
    FullSpanResult,
    HorizontalResult,
    VerticalResult,
    equilibrium_i_d,
)

_EPS_STYLE = {0.001: ("tab:blue", "o"), 0.01: ("tab:green", "s"), 0.05: ("tab:red", "^")}


def _style(eps: float, i: int) -> tuple[str, str]:
    return _EPS_STYLE.get(eps, (f"C{i + 3}", "d"))


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    atomic_write_bytes(path, fig)
    plt.close(fig)
    return path


def _L1_curve(C1: float, g_mm: np.ndarray) -> np.ndarray:
    return np.array([C1 * float(get_model().shape(g * 1e-3)[3]) for g in g_mm])


def _decorate(ax, xlabel: str, ylabel: str, title: str) -> None:
    """Axis labels (with units), title, light grid and a small legend."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)


def fig3_parabolas(va: HorizontalResult, path: Path, max_panels: int = 4) -> Path:
    """Seed Fig. 3: position under constant i_q at locked gaps with the fitted parabolas."""
    pick = np.unique(np.linspace(0, len(va.fits) - 1, min(max_panels, len(va.fits))).round().astype(int))
    fig, axes = plt.subplots(1, len(pick), figsize=(3.2 * len(pick), 3.2), squeeze=False)
    for ax, i in zip(axes[0], pick, strict=True):
        f = va.fits[i]
        ax.plot(f["t"], f["d"] * 1e3, ".", ms=2, color="0.4", label="encoder d")
        ax.plot(f["t"], f["d_fit"] * 1e3, "-", color="tab:red", label="parabola fit (eq. 5)")
        ax.set_title(f"g = {f['g'] * 1e3:.1f} mm")
        ax.set_xlabel("t [s] (from the start of constant i_q)")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("d [mm]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Fig. 3: parabolic fits to the horizontal position at locked gaps")
    return _save(fig, path)


def fig4_L1(va: HorizontalResult, path: Path, prior: Params) -> Path:
    """Seed Fig. 4: L1 by gap from parabola fits and from NPFISI at each eps."""
    g = np.array([r["g"] for r in va.rows]) * 1e3
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(g, [r["L1_fit"] for r in va.rows], "k*-", ms=9, label="parabola fit (eq. 5)")
    for i, e in enumerate(sorted(va.npfisi)):
        c, m = _style(e, i)
        ax.plot(g, [r["L1_npfisi"][e] for r in va.rows], m + "--", color=c, label=f"NPFISI on eq. (4), eps = {e:g}")
    gg = np.linspace(g.min(), g.max(), 60)
    ax.plot(gg, _L1_curve(prior.C1, gg), ":", color="0.5", label=f"prior model, C1 = {prior.C1:.4g}")
    _decorate(ax, "locked gap g [mm]", "L1 = C1 f1(g) [m/s^2/A]", "Fig. 4: estimates of L1 at fixed gaps")
    return _save(fig, path)


def fig5_equilibrium(vb: VerticalResult, path: Path) -> Path:
    """Seed Fig. 5: measured equilibrium i_d at d = 0 against eq. (8) with the V.B estimates."""
    g = np.array([q["g"] for q in vb.equilibrium]) * 1e3
    fig, ax = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    ax[0].plot(g, [q["i_d"] for q in vb.equilibrium], "ko", label="measured equilibrium i_d")
    ax[0].plot(g, [q["i_d_theory"] for q in vb.equilibrium], "r-", label=f"eq. (8), V.B estimates, eps = {MAIN_EPS:g}")
    ax[0].set_ylabel("i_d [A]")
    ax[0].legend(fontsize=8)
    ax[0].grid(alpha=0.3)
    ax[1].plot(g, [1e3 * (q["i_d"] - q["i_d_theory"]) for q in vb.equilibrium], "ko-")
    ax[1].axhline(0, color="0.5", lw=0.8)
    ax[1].set_ylabel("measured - eq. (8) [mA]")
    ax[1].set_xlabel("gap g [mm]")
    ax[1].grid(alpha=0.3)
    fig.suptitle("Fig. 5: measured and theoretical equilibrium currents, d = 0")
    return _save(fig, path)


def fig6_cogging(vc: CoggingResult, path: Path, batch: BatchResult | None = None) -> Path:
    """Seed Fig. 6: peak cogging force by gap (seed-style, gap by gap, fitted law, batch law)."""
    g = np.array([q["g"] for q in vc.per_gap])
    gg = np.linspace(min(g.min(), 0.0095) if len(g) else 0.0095, max(g.max(), 0.025) if len(g) else 0.025, 100)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(
        gg * 1e3,
        vc.xi_seed(gg),
        "--",
        color="tab:orange",
        label=f"seed-style: Mv (C2' - C2) f2(g), C2' = {vc.C2_peak:.5g}",
    )
    if len(g):
        ax.plot(g * 1e3, [q["xi"] for q in vc.per_gap], "ko", label="gap by gap: C2 at the peak vs at d = 0")
    if np.isfinite(vc.xi0):
        ax.plot(gg * 1e3, vc.xi_law(gg), "b-", label=f"fitted law: xi0 = {vc.xi0:.3g} N, ell = {vc.ell * 1e3:.3g} mm")
    if batch is not None and "xi0" in batch.values:
        ell = batch.values.get("ell", batch.params.ell)
        ax.plot(
            gg * 1e3,
            batch.values["xi0"] * np.exp(-(gg - 0.010) / ell),
            "g:",
            label=f"batch fit: xi0 = {batch.values['xi0']:.3g} N, ell = {ell * 1e3:.3g} mm",
        )
    ax.axhline(1.0, color="0.6", lw=0.8)
    _decorate(ax, "gap g [mm]", "peak cogging force xi(g) [N]", "Fig. 6: estimate of the peak cogging force")
    return _save(fig, path)


def fig7_equilibrium_cogging(vb: VerticalResult, vc: CoggingResult, path: Path) -> Path:
    """Seed Fig. 7: measured and theoretical equilibrium i_d at d = 0 and at the cogging peak."""
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    g0 = np.array([q["g"] for q in vb.equilibrium]) * 1e3
    g1 = np.array([q["g"] for q in vc.equilibrium]) * 1e3
    ax.plot(g0, [q["i_d"] for q in vb.equilibrium], "ko", label="measured, d = 0")
    ax.plot(g1, [q["i_d"] for q in vc.equilibrium], "bs", mfc="none", label=f"measured, d = {vc.d_peak * 1e3:.2f} mm")
    ax.plot(g0, [q["i_d_theory"] for q in vb.equilibrium], "k-", lw=1, label="model without cogging")
    if np.isfinite(vc.xi0):
        ax.plot(
            g1,
            [q["i_d_with_cogging"] for q in vc.equilibrium],
            "b--",
            lw=1,
            label="model with the fitted cogging, at the peak",
        )
    _decorate(
        ax, "gap g [mm]", "equilibrium i_d [A]", "Fig. 7: equilibrium currents with and without the horizontal offset"
    )
    return _save(fig, path)


def fig8_L1_full(vd: FullSpanResult, va: HorizontalResult | None, path: Path, batch: BatchResult | None = None) -> Path:
    """Seed Fig. 8: L1(g) of the full-span estimates against the fixed-gap estimates of V.A."""
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    gg = np.linspace(9.5, 28.0, 80)
    for i, e in enumerate(sorted(vd.npfisi)):
        c, _ = _style(e, i)
        ax.plot(
            gg,
            _L1_curve(vd.npfisi[e].final["C1"], gg),
            "-",
            color=c,
            lw=1,
            label=f"V.D NPFISI eps = {e:g}: C1 = {vd.npfisi[e].final['C1']:.4g}",
        )
    if batch is not None and "C1" in batch.values:
        ax.plot(gg, _L1_curve(batch.values["C1"], gg), "k--", lw=1.2, label=f"batch fit: C1 = {batch.values['C1']:.4g}")
    if va is not None:
        g = np.array([r["g"] for r in va.rows]) * 1e3
        ax.plot(g, [r["L1_fit"] for r in va.rows], "k*", ms=9, label="V.A parabola fits")
        if MAIN_EPS in va.npfisi:
            ax.plot(
                g, [r["L1_npfisi"][MAIN_EPS] for r in va.rows], "gs", mfc="none", label=f"V.A NPFISI eps = {MAIN_EPS:g}"
            )
    ax.set_xlabel("gap g [mm]")
    ax.set_ylabel("L1 = C1 f1(g) [m/s^2/A]")
    ax.set_title("Fig. 8: L1 from the full-span model and at fixed gaps")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)


def fig9_equilibrium_full(
    vd: FullSpanResult, vb: VerticalResult, prior: Params, path: Path, batch: BatchResult | None = None
) -> Path:
    """Seed Fig. 9: equilibrium i_d predicted by the full-span estimates against the measured ones (d = 0)."""
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    g = np.array([q["g"] for q in vb.equilibrium])
    ax.plot(g * 1e3, [q["i_d"] for q in vb.equilibrium], "ko", label="measured, d = 0")
    for i, e in enumerate(sorted(vd.npfisi)):
        c, _ = _style(e, i)
        p = prior.with_(**vd.npfisi[e].final).vector()
        ax.plot(g * 1e3, [equilibrium_i_d(gi, 0.0, p) for gi in g], "-", color=c, lw=1, label=f"V.D NPFISI eps = {e:g}")
    if batch is not None:
        p = batch.params.vector()
        ax.plot(g * 1e3, [equilibrium_i_d(gi, 0.0, p) for gi in g], "k--", lw=1.2, label="batch fit")
    _decorate(ax, "gap g [mm]", "equilibrium i_d [A]", "Fig. 9: predicted and measured equilibrium currents")
    return _save(fig, path)


def fig_npfisi_trajectories(results: dict[str, dict], path: Path) -> Path:
    """Parameter trajectories (relative to their final values) and min eig(Sigma), by procedure and eps."""
    items = [(name, e, r) for name, by_eps in results.items() for e, r in sorted(by_eps.items())]
    procs = list(results)
    fig, axes = plt.subplots(2, len(procs), figsize=(5.2 * len(procs), 6.4), squeeze=False)
    for j, name in enumerate(procs):
        ax, ax2 = axes[0, j], axes[1, j]
        for i, (nm, e, r) in enumerate(items):
            if nm != name:
                continue
            c, _ = _style(e, i)
            sl = slice(None, None, max(1, len(r.t) // 600))  # a few hundred points per line are enough
            for q, pn in enumerate(r.names):
                ls = ["-", "--", ":", "-."][q % 4]
                ref = r.theta[-1, q]
                ax.plot(r.t[sl], 100 * (r.theta[sl, q] / ref - 1), ls, color=c, lw=0.9, label=f"{pn}, eps = {e:g}")
            ax2.semilogy(r.t[sl], np.clip(r.sigma_min_eig[sl], 1e-12, None), color=c, lw=1, label=f"eps = {e:g}")
        ax.set_ylim(-5, 5)
        ax.set_ylabel("estimate / final - 1 [%]")
        ax.set_title(f"NPFISI {name}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
        ax2.set_xlabel("t [s] (runs chained)")
        ax2.set_ylabel("min eig(Sigma) [-]")
        ax2.grid(alpha=0.3)
        ax2.legend(fontsize=7)
    fig.suptitle("NPFISI trajectories (seed eq. 3) and the smallest eigenvalue of Sigma")
    return _save(fig, path)


def fig_batch_correlation(batch: BatchResult, path: Path) -> Path:
    """Correlation matrix of the batch estimates (how well the data separates the parameters)."""
    n = len(batch.names)
    fig, ax = plt.subplots(figsize=(1.0 * n + 2.5, 1.0 * n + 1.5))
    im = ax.imshow(batch.correlation, vmin=-1, vmax=1, cmap="RdBu_r")
    ax.set_xticks(range(n), batch.names)
    ax.set_yticks(range(n), batch.names)
    for i in range(n):
        for j in range(n):
            ax.text(j, i, f"{batch.correlation[i, j]:+.2f}", ha="center", va="center", fontsize=8)
    fig.colorbar(im, ax=ax, label="correlation [-]")
    ax.set_title("Batch fit: correlation of the estimates")
    return _save(fig, path)


def write_all(out: str | os.PathLike, *, prior: Params, va=None, vb=None, vc=None, vd=None, batch=None) -> list[Path]:
    """Write every figure the available results allow; return the paths."""
    out = Path(out)
    paths = []
    if va is not None:
        paths += [fig3_parabolas(va, out / "fig3_parabolas.png"), fig4_L1(va, out / "fig4_L1_fixed_gaps.png", prior)]
    if vb is not None:
        paths.append(fig5_equilibrium(vb, out / "fig5_equilibrium_d0.png"))
    if vc is not None:
        paths.append(fig6_cogging(vc, out / "fig6_cogging_peak.png", batch))
        paths.append(fig7_equilibrium_cogging(vb, vc, out / "fig7_equilibrium_cogging.png"))
    if vd is not None:
        paths.append(fig8_L1_full(vd, va, out / "fig8_L1_full_span.png", batch))
        if vb is not None:
            paths.append(fig9_equilibrium_full(vd, vb, prior, out / "fig9_equilibrium_full_span.png", batch))
    traj = {}
    if vb is not None:
        traj["V.B (C2..C4, d = 0)"] = vb.npfisi
    if vd is not None:
        traj["V.D (C1..C4, free runs)"] = vd.npfisi
    if traj:
        paths.append(fig_npfisi_trajectories(traj, out / "npfisi_trajectories.png"))
    if batch is not None and len(batch.names) > 1:
        paths.append(fig_batch_correlation(batch, out / "batch_correlation.png"))
    return paths
