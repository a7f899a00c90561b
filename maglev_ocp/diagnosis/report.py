"""Writing a diagnosis: ``report.json``, ``report.md`` and figures (PNG, Agg backend).

The result type and the JSON content are :mod:`.result`'s; this module adds the
Markdown report and the figures.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import yaml
from tqdm import tqdm

from ..output import atomic_write_bytes, atomic_write_text, plain_data
from ..params import model_file_instruction
from ..signals import label
from .result import Diagnosis, report_json, summary_table
from .shape_report import shape_figure, shape_sizes


# --------------------------------------------------------------------------- figures
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _empty(plt, text: str):
    """A small figure that says why there is nothing to draw (never an empty figure)."""
    fig, ax = plt.subplots(figsize=(6, 2))
    ax.text(0.5, 0.5, text, ha="center", va="center", wrap=True)
    ax.axis("off")
    return fig


def fig_maps(d: Diagnosis):
    """Residual maps over gap x position, baseline and final model, per channel."""
    plt = _plt()
    chans = list(d.views_before)
    if not chans:
        return _empty(plt, "no channel has enough residual samples for a map")
    fig, ax = plt.subplots(len(chans), 2, figsize=(11, 4 * len(chans)), squeeze=False)
    for i, ch in enumerate(chans):
        vals = [d.views_before[ch].map_gd, d.views_after.get(ch, d.views_before[ch]).map_gd]
        lim = np.nanmax([np.nanmax(np.abs(v.mean)) if np.isfinite(v.mean).any() else 0 for v in vals]) or 1.0
        for j, (bs, title) in enumerate(zip(vals, ("baseline", d.final_model), strict=True)):
            eg, ed = bs.edges
            a = ax[i, j]
            im = a.pcolormesh(ed * 1e3, eg * 1e3, bs.mean, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="flat")
            sig = np.abs(np.nan_to_num(bs.z)) > 4
            for gi, di in zip(*np.nonzero(sig), strict=True):
                a.plot((ed[di] + ed[di + 1]) / 2 * 1e3, (eg[gi] + eg[gi + 1]) / 2 * 1e3, "k.", ms=3)
            a.set_xlabel("position d [mm]")
            a.set_ylabel("gap g [mm]")
            a.set_title(f"{ch} residual, {title} (dots: |mean| > 4 floors)")
            fig.colorbar(im, ax=a, label="mean residual [m/s^2]")
    fig.tight_layout()
    return fig


def fig_spectra(d: Diagnosis):
    """Residual spectra per channel: wide-band PSD of the baseline and the final model against the noise model,
    the residual filter's band, the peaks with their frequency and damping; the filtered spectra if any.

    Never empty: a channel without a run long enough for a spectrum says so in its panel.
    """
    plt = _plt()
    chans = [ch for ch in ("vertical", "horizontal") if ch in d.views_before or (d.noise and ch in d.noise.checks)]
    chans = chans or ["vertical", "horizontal"]
    fig, ax = plt.subplots(1, len(chans), figsize=(6.5 * len(chans), 4.2), squeeze=False)
    fc = d.settings.fc_hz if d.settings is not None else None
    for i, ch in enumerate(chans):
        a = ax[0, i]
        drawn = False
        nc = d.noise.checks.get(ch) if d.noise is not None else None
        if nc is not None:
            sp = nc.spectrum
            a.loglog(sp.f[1:], sp.psd[1:], lw=0.8, label="baseline (wide band)")
            after = d.noise.checks_after.get(ch)
            a.loglog(sp.f[1:], nc.model.psd(sp.f[1:]), "k--", lw=1.0, label="noise model (baseline residual)")
            if after is not None and d.final_model != "baseline":
                a.loglog(after.spectrum.f[1:], after.spectrum.psd[1:], lw=0.8, alpha=0.8, label=d.final_model)
                a.loglog(
                    sp.f[1:], after.model.psd(sp.f[1:]), "--", color="tab:orange", lw=1.0, label="noise model (final)"
                )
            for pk in nc.peaks:
                a.axvspan(*pk.band_hz, color="tab:red", alpha=0.2)
                zeta = f"ζ {pk.damping:.3f}" if pk.resolved else f"ζ < {pk.damping:.3f}"
                a.annotate(
                    f"{pk.freq_hz:.1f} Hz, {zeta}",
                    (pk.freq_hz, float(np.max(sp.psd[(sp.f >= pk.band_hz[0]) & (sp.f <= pk.band_hz[1])], initial=0))),
                    fontsize=7,
                    color="tab:red",
                )
            drawn = True
        v = d.views_before.get(ch)
        if v is not None and v.spectrum is not None:
            a.loglog(v.spectrum.f[1:], v.spectrum.psd[1:], lw=0.8, alpha=0.7, label="baseline (filtered)")
            for pk in v.spectrum.peaks:
                a.axvspan(*pk["band_hz"], color="tab:orange", alpha=0.2)
            drawn = True
        if fc is not None and drawn:
            a.axvline(fc, color="0.5", lw=0.8, ls=":", label=f"filter cut-off {fc:g} Hz")
        if not drawn:
            a.text(
                0.5,
                0.5,
                "no run is long enough for a spectrum\n(the residual filter and a Welch segment need a few s)",
                ha="center",
                va="center",
                transform=a.transAxes,
            )
            a.set_xticks([])
            a.set_yticks([])
        else:
            a.legend(fontsize=7)
            a.grid(True, which="both", alpha=0.3)
        a.set_xlabel("frequency [Hz]")
        a.set_ylabel("PSD [(m/s^2)^2/Hz]")
        a.set_title(f"{ch} residual spectrum")
    fig.tight_layout()
    return fig


def fig_periods(d: Diagnosis):
    """Least-squares period scan in d, per channel."""
    plt = _plt()
    from .localize import KNOWN_PERIODS

    chans = [ch for ch, v in d.views_before.items() if v.period is not None]
    if not chans:
        return _empty(plt, "no period scan: the runs do not travel far enough in d (or are too short)")
    fig, ax = plt.subplots(1, len(chans), figsize=(6 * len(chans), 4), squeeze=False)
    for i, ch in enumerate(chans):
        a = ax[0, i]
        for v, lab in ((d.views_before[ch], "baseline"), (d.views_after.get(ch), d.final_model)):
            if v is None or v.period is None:
                continue
            a.semilogx(v.period.periods * 1e3, v.period.explained, label=lab)
        ps = d.views_before[ch].period
        a.axhline(ps.threshold, color="k", ls=":", label="noise threshold")
        for name, P in KNOWN_PERIODS.items():
            a.axvline(P * 1e3, color="gray", lw=0.6, alpha=0.6)
            a.text(P * 1e3, a.get_ylim()[1] * 0.95, name, rotation=90, fontsize=7, va="top")
        a.set_xlabel("period in d [mm]")
        a.set_ylabel("explained variance fraction [-]")
        a.set_title(f"{ch}: period scan")
        a.legend(fontsize=8)
    fig.tight_layout()
    return fig


def fig_bins(d: Diagnosis):
    """Residual binned over velocities, currents and current rates, before and after."""
    plt = _plt()
    feats = ("g", "d", "g_dot", "d_dot", "i_q", "i_d", "di_q", "di_d")
    chans = list(d.views_before)
    if not chans:
        return _empty(plt, "no channel has enough residual samples to bin")
    fig, ax = plt.subplots(len(chans), len(feats), figsize=(2.6 * len(feats), 3 * len(chans)), squeeze=False)
    for i, ch in enumerate(chans):
        for j, fn in enumerate(feats):
            a = ax[i, j]
            for v, lab, col in (
                (d.views_before[ch], "baseline", "tab:blue"),
                (d.views_after.get(ch), d.final_model, "tab:orange"),
            ):
                if v is None:
                    continue
                bs = v.bins[fn]
                c = (bs.edges[0][:-1] + bs.edges[0][1:]) / 2
                a.errorbar(c, bs.mean, yerr=2 * bs.se, fmt=".-", color=col, ms=3, lw=0.8, label=lab)
            a.axhline(0, color="k", lw=0.5)
            a.set_xlabel(label(fn) if fn in ("g", "d", "g_dot", "d_dot", "i_q", "i_d") else f"{fn} [A/s]", fontsize=8)
            if j == 0:
                a.set_ylabel(f"{ch} residual [m/s^2]", fontsize=8)
            a.tick_params(labelsize=7)
    ax[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def fig_overlay(d: Diagnosis):
    """Measured readings vs simulated windows of the baseline and the augmented model (held-out run)."""
    plt = _plt()
    tr = d.trajectories
    if tr is None or not tr.measured:
        fig, ax = plt.subplots(figsize=(6, 2))
        ax.text(0.5, 0.5, "no trajectory comparison", ha="center")
        ax.axis("off")
        return fig
    nw = len(tr.measured)
    fig, ax = plt.subplots(2, nw, figsize=(3.2 * nw, 5.5), squeeze=False)
    styles = {"baseline": "tab:blue", "augmented": "tab:orange"}
    for j, (t, y) in enumerate(tr.measured):
        for row, (col, idx, lab) in enumerate(((0, 0, "gap g [mm]"), (1, 2, "position d [mm]"))):
            a = ax[row, j]
            a.plot(t, y[:, col] * 1e3, "k.", ms=3, label="encoder")
            for model, blocks in tr.examples.items():
                tt, X = blocks[j]
                a.plot(tt, X[idx] * 1e3, color=styles.get(model), lw=1.2, label=model)
            a.set_xlabel("time t [s]", fontsize=8)
            if j == 0:
                a.set_ylabel(lab)
            a.tick_params(labelsize=7)
    ax[0, 0].legend(fontsize=7)
    fig.suptitle(
        f"held-out run: encoder readings and {tr.horizon * 1e3:.0f} ms simulations from the measured state "
        "(windows where the baseline errs most)",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def fig_candidates(d: Diagnosis):
    """Held-out reduction of every candidate (filled: significant)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(d.scores) + 1.5))
    names = [s.name for s in d.scores][::-1]
    red = [s.reduction for s in d.scores][::-1]
    cols = ["tab:green" if s.selected else ("tab:blue" if s.significant else "lightgray") for s in d.scores][::-1]
    ax.barh(names, red, color=cols)
    ax.set_xlabel("held-out residual reduction 1 - after/before [-]")
    ax.set_title(f"candidates (green: verdict '{d.verdict.verdict}', blue: significant)")
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def fig_shapes(d: Diagnosis):
    """Fitted shape of each effect found vs its variable (:mod:`.shape_report`)."""
    plt = _plt()
    return shape_figure(d, plt) or _empty(plt, "no effect with a shape was found")


FIGURES = {
    "residual_maps.png": (fig_maps, "Residual over gap x position (bin means; dots exceed 4 floors)"),
    "spectra.png": (
        fig_spectra,
        "Residual spectra (Welch): wide band against the noise model, peaks with frequency and damping shaded",
    ),
    "period_scan.png": (fig_periods, "Least-squares period scan in d"),
    "binned.png": (fig_bins, "Residual binned over states, currents and current rates (+-2 floors)"),
    "overlay.png": (fig_overlay, "Measured vs simulated short windows on a held-out run"),
    "candidates.png": (fig_candidates, "Held-out reduction per candidate"),
    "shapes.png": (fig_shapes, "Fitted shapes of the effects found vs their variable"),
}


def report_markdown(d: Diagnosis, figures: list[str]) -> str:
    """The content of ``report.md``."""
    j = report_json(d)
    md = [f"# Sim-to-real gap diagnosis\n\n**Verdict: `{d.verdict.verdict}`**\n"]
    md += [f"- {r}" for r in d.verdict.reasons]
    md += [f"\n**Warning:** {w}" for w in d.warnings]
    md.append(
        f"\nBaseline ({d.baseline_mode}): "
        + ", ".join(f"{n} = {getattr(d.baseline_params, n):.5g}" for n in ("C1", "C2", "C3", "C4", "xi0"))
    )
    if d.constants_moved:
        md.append(
            "\nConstants of the final model (± standard error; from the calibration): "
            + ", ".join(
                f"{n} = {v['final']:.5g} ± {v['stderr']:.2g} ({v['change_pct']:+.1f} %)"
                for n, v in d.constants_moved.items()
            )
        )
    rr = d.baseline_calibration.get("resolved_refit") or {}
    if rr.get("reason"):
        md.append(
            f"\nResolved refit: {rr['reason']}"
            + (
                f" (C1 {rr['all_samples_fit']['C1']:.5g} over all samples)"
                if rr.get("adopted") and "C1" in rr.get("all_samples_fit", {})
                else ""
            )
        )
    md.append(f"\nTraining runs: {', '.join(d.train)}; held-out runs: {', '.join(d.test)}.\n")
    md.append("## Noise floor (from the data)\n")
    md.append("| channel | held-out rms [m/s²] | floor [m/s²] | quantization only [m/s²] | map gain | z | gap |")
    md.append("|---|---|---|---|---|---|---|")
    for ch, f in d.floors.items():
        md.append(
            f"| {ch} | {f.rms:.4g} | {f.floor:.3g} | {f.quantization:.2g} | {f.gain:.1%} | {f.z:.1f} | "
            f"{'yes' if f.significant else 'no'} |"
        )
    md += _noise_markdown(d)
    md.append("\n## Candidates (held-out runs, best first)\n")
    md.append("| effect | rms before | rms after | reduction | gap closed | z | ΔBIC | selected |")
    md.append("|---|---|---|---|---|---|---|---|")
    for s in d.scores:
        md.append(
            f"| {s.name} | {s.heldout_rms_before:.4g} | {s.heldout_rms_after:.4g} | {s.reduction:.1%} | "
            f"{s.closes:.0%} | {s.z:.1f} | {s.delta_bic:.0f} | {'**yes**' if s.selected else ''} |"
        )
    md += [
        f"\nFitted `{s.name}` (± standard error): {s.fitted_text(' = ', ' ± ')}. {s.note}."
        for s in d.scores
        if s.selected
    ]
    if d.regions or d.remaining_regions:
        md.append("\n## Regions\n")
        md.append("| model | channel | g [mm] | d [mm] | band [Hz] | excess / floor | z |")
        md.append("|---|---|---|---|---|---|---|")
        for lab, regs in (("baseline", d.regions), (d.final_model, d.remaining_regions)):
            for r in regs:
                band = f"{r.freq_band_hz[0]:.2f}..{r.freq_band_hz[1]:.2f}" if r.freq_band_hz else "-"
                md.append(
                    f"| {lab} | {r.channel} | {r.g_range_m[0] * 1e3:.1f}..{r.g_range_m[1] * 1e3:.1f} | "
                    f"{r.d_range_m[0] * 1e3:.0f}..{r.d_range_m[1] * 1e3:.0f} | {band} | "
                    f"{r.excess_over_floor:.2f} | {r.z:.1f} |"
                )
    md.append("\n## Localization\n")
    for ch, v in j["localization"].items():
        ps = v["period_scan"]
        pk = v["spectral_peaks"]
        md.append(
            f"- {ch}: "
            + (
                f"period scan best {ps['best_period_m'] * 1e3:.2f} mm "
                f"({'significant' if ps['significant'] else 'not significant'}"
                + (f", = {ps['matches']}" if ps["matches"] else "")
                + ")"
                if ps
                else "no scan"
            )
            + ("; spectral lines " + ", ".join(f"{p['peak_hz']:.2f} Hz" for p in pk[:3]) if pk else "")
        )
    if d.trajectories is not None:
        md.append(f"\n## Simulated trajectories ({d.trajectories.horizon * 1e3:.0f} ms windows, held-out runs)\n")
        md.append("| model | rms g [mm] | rms d [mm] |")
        md.append("|---|---|---|")
        for lab, e in d.trajectories.rms.items():
            md.append(
                f"| {lab} | " + " | ".join(f"{e[a] * 1e3:.4f}" if e[a] is not None else "-" for a in ("g", "d")) + " |"
            )
    md += _consequence_markdown(d)
    md.append("\n## Figures\n")
    sizes = shape_sizes(d)
    if sizes:
        md += ["\n## Physical size of the effects found\n", *sizes, ""]
    for f in figures:
        md.append(f"### {FIGURES[f][1]}\n\n![{f}]({f})\n")
    md.append(f"\nDiagnosis time: {d.timing.get('total_s', float('nan')):.1f} s.\n")
    stages = [(k_[:-2], v) for k_, v in d.timing.items() if k_.endswith("_s") and k_ not in ("total_s", "cpu_s")]
    if stages:
        md.append("Time per stage: " + ", ".join(f"{n} {v:.1f} s" for n, v in stages) + ".\n")
    return "\n".join(md)


def _noise_markdown(d: Diagnosis) -> list[str]:
    """Noise-model section: model floor, whiteness, peaks, what stays unexplained, the lag guard."""
    if d.noise is None or not d.noise.checks:
        return []
    md = ["\n## Noise model (floor from quantization, encoder and acceleration noise through the filter)\n"]
    md.append(
        "| channel | model floor [m/s²] | quantization [m/s²] | accel. noise [m/s²] | residual rms [m/s²] | "
        "rms / floor | white (flatness / null) |"
    )
    md.append("|---|---|---|---|---|---|---|")
    for ch, c in d.noise.checks.items():
        md.append(
            f"| {ch} | {c.floor:.3g} | {c.quantization:.2g} | {c.model.to_dict()['accel_noise_m_s2']:.2g} | "
            f"{c.rms:.3g} | {c.excess_ratio:.2f} | {'yes' if c.whiteness.white else 'no'} "
            f"({c.whiteness.flatness:.2f} / {c.whiteness.flatness_null:.2f}) |"
        )
    if d.noise.peaks:
        md.append("\nSpectral peaks beyond the noise model (training and held-out runs):\n")
        md += [f"- {p.describe()}" for p in d.noise.peaks]
    if d.noise.unexplained:
        md.append("\n**Unexplained** (left by the final model):\n")
        md += [f"- {u['what']}" for u in d.noise.unexplained]
    if d.noise.coverage:
        md.append("\nWhat the verdict's model closes per channel (held-out, above the model floor):\n")
        md.append("| channel | before / floor | after / floor | gap closed | accounted for |")
        md.append("|---|---|---|---|---|")
        md += [
            f"| {r['channel']} | {r['before_over_floor']:.1f} | {r['after_over_floor']:.1f} | {r['closes']:.0%} | "
            f"{'**no**' if r['short'] else 'yes'} |"
            for r in d.noise.coverage
        ]
    if d.noise.partial:
        md.append(
            f"\n`{d.noise.partial['model']}` explains part of the gap only; the verdict is **unexplained** "
            "(the library does not account for the channels marked **no**)."
        )
    md += _claims_md(d.noise.claims)
    for n, g in d.noise.guards.items():
        if g.peaks_hz:
            md.append(
                f"\nResonance guard `{n}`: {g.fraction_in_peaks:.0%} of its improvement in the peaks, "
                f"{g.peak_left:.0%} of the peaks' power left, {g.outside_reduction:.0%} of the residual outside "
                "them removed: "
                + (
                    "**absorbs a resonance, not counted**"
                    if g.absorbs_resonance
                    else "the lag's model of the peaks (a closed-loop mode of the lag)"
                    if g.explains_peaks
                    else "not a resonance"
                )
            )
    return md


def _consequence_markdown(d: Diagnosis) -> list[str]:
    """Size-and-consequence section of the effects found."""
    c = d.consequences
    if c is None:
        return []
    if not c.sizes:  # no effect found: the model file still is the refit baseline, loaded the one way
        return [
            f"\nThe refit model is written as a model file, `model.yaml` (the baseline as `baseline.yaml`). "
            f"{model_file_instruction('model.yaml')}."
        ]
    md = ["\n## Size and closed-loop consequence of the effects found\n"]
    md.append(
        "| effect | peak force g / d [N] | % of weight | delay [µs] | FL max error [µm] | NMPC max error [µm] | |"
    )
    md.append("|---|---|---|---|---|---|---|")
    for s in c.sizes:
        cl = s.closed_loop

        def err(ctrl: str, cl=cl) -> str:
            v = cl.get(ctrl)
            return f"{v['without_max_m'] * 1e6:.1f} → {v['with_max_m'] * 1e6:.1f}" if v else "-"

        md.append(
            f"| {s.name} | {s.peak_force_n['g']:.3g} / {s.peak_force_n['d']:.3g} | {s.peak_force_pct_weight:.2g} | "
            f"{f'{s.delay_us:.0f}' if s.delay_us is not None else '-'} | {err('fl')} | {err('nmpc')} | "
            + ("matters" if s.matters else "negligible for 0.1 mm" if s.matters is False else "not simulated")
            + " |"
        )
    md.append(
        f"\nThe augmented model is written as a model file, `model.yaml` (constants and fitted effects; the "
        f"baseline as `baseline.yaml`). {model_file_instruction('model.yaml')}. "
        "The same file is a plant file: `plant: {file: model.yaml}` simulates the model as a rig."
    )
    if c.dropped:
        md.append(f"Fitted terms a plant file cannot carry: {', '.join(c.dropped)}.")
    return md


def write_model_files(d: Diagnosis, out_dir: str | os.PathLike) -> list[Path]:
    """Write ``model.yaml`` (augmented model) and ``baseline.yaml``: model files, which are plant files too
    (see :mod:`.consequence` and :mod:`maglev_ocp.controllers.model_file`), with the one load instruction."""
    out = Path(out_dir)
    written = []
    if d.consequences is None:
        return written
    c = d.consequences
    head = (
        "# {what} of a gap diagnosis (maglev diagnose): a model file, constants in mismatch.overrides and\n"
        "# every library effect with its fitted law or off. {instruction}.\n"
        "# It is a plant file too: plant: {{file: {name}}} simulates the model as a rig.\n"
    )
    for name, data, what in (
        ("model.yaml", c.model_file, f"Augmented model ({c.label})"),
        ("baseline.yaml", c.baseline_file, "Baseline model"),
    ):
        text = head.format(what=what, name=name, instruction=model_file_instruction(name))
        if data.get("trusted") is False:  # said where a reader of the file looks first, and in the file's keys
            text = "# UNTRUSTED: " + "; ".join(data.get("untrusted_because", [])) + "\n" + text
        atomic_write_text(out / name, text + yaml.safe_dump(plain_data(data), sort_keys=False))
        written.append(out / name)
    return written


def write_report(d: Diagnosis, out_dir: str | os.PathLike, figures: bool = True, progress: bool = False) -> Path:
    """Write ``report.json``, the figures (``progress``: a bar over them) and ``report.md`` into ``out_dir``."""
    plt = _plt()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if figures:
        for name, (fn, _) in tqdm(FIGURES.items(), desc="figures", disable=not progress, leave=False):
            fig = fn(d)
            atomic_write_bytes(out / name, fig)
            plt.close(fig)
            written.append(name)
    write_model_files(d, out)
    atomic_write_text(out / "report.json", json.dumps(report_json(d), indent=2))
    atomic_write_text(out / "report.md", report_markdown(d, written))
    return out


def _claims_md(claims: dict) -> list[str]:
    """The no-false-claim guard's table: per effect, its signature's evidence and its own gain."""
    if not claims or not claims.get("effects"):
        return []
    md = ["\nNo effect claimed that is not there (signature in the residual without it; what it explains against "
          "what the verdict's model leaves above the floor; gain over the others at full freedom, held-out):\n",
          "| effect | signature shows (explained / null, rms / floor) | explains / leaves [m/s²] | own gain z "
          "(region / all) | kept |", "|---|---|---|---|---|"]  # fmt: skip
    for e, rec in claims["effects"].items():
        sig = rec["signature"]
        parts = ", ".join(
            f"{ch} {c['explained']:.2f}/{c['null_q']:.2f}, {c['rms_explained_over_floor']:.1f}x"
            for ch, c in sig["per_channel"].items()
        )
        g = rec.get("own_gain") or {}
        zg = f"{g['z_region']:.1f} / {g['z_all']:.1f}" if g.get("z_region") is not None else "-"
        lo = (rec.get("leftover") or {}).get("per_channel") or {}
        left = ", ".join(f"{ch} {c['explained_m_s2']:.3g} / {c['leftover_m_s2']:.3g}" for ch, c in lo.items()) or "-"
        md.append(f"| {e} | {'yes' if sig['shows'] else '**no**'} ({parts}) | {left} | {zg} | "
                  f"{'yes' if rec['kept'] else '**no**'} |")  # fmt: skip
    if claims.get("gap"):
        md.append("\nGap the effects found leave, that no library signature has (**partly explained**):\n")
        md += [f"- {g['what']}" for g in claims["gap"]]
    return md


__all__ = ["FIGURES", "report_json", "report_markdown", "summary_table", "write_model_files", "write_report"]
