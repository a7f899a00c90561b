"""The end effect's signature on rigsim datasets: where it shows, where it should not (issue 27).

When the end effect is a verdict's only effect, the claim guard (:mod:`maglev_ocp.diagnosis.stages.claims`) tests
its signature (:func:`maglev_ocp.diagnosis.signatures.evidence`) on the held-out residual of the calibrated
baseline. This script makes that input as the diagnosis does (split, baseline, noise model) for one rigsim
dataset per law and seed, and reports the signature's figures per channel: the explained share of the residual
(of what its uniform counterparts leave, :attr:`~maglev_ocp.diagnosis.signatures.Signature.beyond`) against the
circular-shift null's 99 % quantile, its rms over the noise floor, and whether it shows. The laws: every
end-effect family of rigsim's four law sets (it should show), and effects that are no end effect, among them
the out-of-library cable (a spring with a cubic term and a drag) and encoder errors, which are smooth functions
of d too (it should not; those others are named beside it in a diagnosis only when the selection finds them,
and test (b) of the claim guard is not run here). Each law with its family's default parameters, the rig's
default settings with 10 % constant mismatch.

``python -m benchmarks.end_signature --out results/benchmarks/end_signature_s15.md``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from tqdm import tqdm

from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import evidence
from maglev_ocp.diagnosis.stages.baseline import calibrate_baseline
from maglev_ocp.diagnosis.stages.localization import localize_gap, noise_stage
from maglev_ocp.diagnosis.stages.split import split_dataset
from maglev_ocp.output import atomic_write_text
from maglev_ocp.riglog import read_dataset
from maglev_ocp.rigsim import RigSettings, generate

#: End-effect families of rigsim's law sets (``laws``, ``laws_new``, ``laws_v3``, ``laws_v4``).
END_FAMILIES: tuple[str, ...] = (
    "cosine", "quadratic", "asymmetric", "entry_exp", "fringe", "roters", "pole_strip", "winding_iron",
    "energy_overhang",
)  # fmt: skip
#: Effects that are no end effect: ``label -> (effect, family)``.
OTHERS: dict[str, tuple[str, str] | None] = {
    "cable spring": ("cable", "spring"),
    "encoder scale": ("encoder_error", "scale"),
    "encoder nonlinear": ("encoder_error", "nonlinear"),
    "saturation exp": ("saturation", "exp"),
    "cogging power": ("cogging", "power"),
    "friction stribeck": ("friction", "stribeck"),
    "commutation drift": ("commutation_offset", "drift"),
    "none": None,
}


def cases() -> list[tuple[str, dict, bool]]:
    """``(label, effects spec for rigsim.generate, is an end effect)`` for every law of the module docstring."""
    out = [(f"end_effect {f}", {"end_effect": {"family": f}}, True) for f in END_FAMILIES]
    out += [(lab, {e[0]: {"family": e[1]}} if e else {}, False) for lab, e in OTHERS.items()]
    return out


def measure(data: Path) -> dict:
    """The end effect's signature on the baseline's held-out residual of the dataset in ``data``."""
    st = DiagnoseSettings()
    ds = read_dataset(data)
    q = float(ds.encoder_resolution or 1e-5)
    split = split_dataset(ds, st)
    base = calibrate_baseline(split, None, st, q)
    loc = localize_gap(split, base, st, np.random.default_rng(np.random.SeedSequence(st.seed)))
    noise, _ = noise_stage(split, base, loc, q, st.seed, drift_z=st.z_min, drift_min_floor=st.drift_min_floor)
    floors = {ch: float(nc.floor) for ch, nc in noise.checks.items()}
    ev = evidence("end_effect", base.b_test, floors, n_null=st.signature_null, alpha=st.signature_alpha,
                  min_over_floor=st.signature_min_floor, seed=st.seed)  # fmt: skip
    return ev.to_dict()


def _cell(rec: dict | None) -> str:
    if not rec:
        return "-"
    mark = "**yes**" if rec["shows"] else "no"
    return f"{mark} {rec['explained']:.2f} / {rec['null_q']:.2f}, {rec['rms_explained_over_floor']:.1f}x"


def main(argv: list[str] | None = None) -> str:
    """Generate (or reuse) the datasets, measure, print and return the markdown table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="markdown file to write")
    ap.add_argument("--work", type=Path, default=Path("end_signature_work"), help="datasets go here")
    ap.add_argument("--seeds", type=int, nargs="+", default=[11, 12], help="rigsim seeds, one dataset each")
    ap.add_argument("--reuse", action="store_true", help="keep datasets already in WORK")
    a = ap.parse_args(argv)
    rows, shown = [], {True: [0, 0], False: [0, 0]}
    todo = [(c, s) for c in cases() for s in a.seeds]
    for (label, spec, is_end), seed in tqdm(todo, desc="end signature", unit="dataset"):
        data = a.work / f"{label.replace(' ', '_')}_s{seed}"
        if not (a.reuse and (data / "dataset.yaml").is_file()):
            generate(data, spec, seed, RigSettings(mismatch=0.1))
        ev = measure(data)
        pc = ev["per_channel"]
        shown[is_end][0] += int(ev["shows"])
        shown[is_end][1] += 1
        rows.append(f"| {label} | {seed} | {_cell(pc.get('vertical'))} | {_cell(pc.get('horizontal'))} | "
                    f"{'**yes**' if ev['shows'] else 'no'} |")  # fmt: skip
    lines = [
        "# The end effect's signature on the baseline's held-out residual of rigsim datasets",
        "",
        f"Command: `python -m benchmarks.end_signature --seeds {' '.join(map(str, a.seeds))}`. Per channel: shows, "
        "explained share / null 99 % quantile, rms explained over the noise floor.",
        "",
        f"- end-effect laws: the signature shows on **{shown[True][0]} of {shown[True][1]}** datasets",
        f"- other effects and none: it shows on **{shown[False][0]} of {shown[False][1]}** (without the other "
        "effect named beside it; the claim guard's test (b) not run)",
        "",
        "| law | seed | vertical | horizontal | shows |",
        "|---|---|---|---|---|",
        *rows,
        "",
    ]
    text = "\n".join(lines)
    print(text)
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(a.out, text)
    return text


if __name__ == "__main__":
    main()
