"""Physical size and closed-loop effect of each law family of the third set (``rigsim.laws_v3``).

For every family: one random draw of its parameters (``rigsim.draw.V3_DRAWS``, seeded), a dataset on
the independent rig with the default settings (6 runs x 10 s) and only that effect, and from its
``truth.json`` the peak force (or reading error) and the hover/tracking error RMS per axis, beside the
same rig without effects. Prints a markdown table (the one in ``docs/validation/rigsim-laws.md``).

Usage: ``python benchmarks/rigsim_v3_sizes.py [--seed 3] [--runs 6] [--duration 10]``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from tqdm import tqdm

from maglev_ocp.rigsim import RigSettings, generate
from maglev_ocp.rigsim.draw import V3_DRAWS
from maglev_ocp.rigsim.laws_v3 import V3_LAWS


def _row(name: str, family: str, truth: dict) -> str:
    e = truth["effects"].get(name, {})
    h = truth["hover_error_rms_m"]
    size = f"{e['peak_force_n']:.3g} N (g {e['peak_force_g_n']:.3g}, d {e['peak_force_d_n']:.3g})" if e else "-"
    if "peak_error_g_m" in e:
        size = f"reading error g {e['peak_error_g_m'] * 1e6:.1f} µm, d {e['peak_error_d_m'] * 1e6:.1f} µm"
    if "effective_delay_s" in e:
        size += f", delay {e['effective_delay_s'] * 1e3:.2f} ms"
    return f"| {name} | {family} | {size} | {h['g'] * 1e6:.1f} | {h['d'] * 1e6:.1f} |"


def main() -> None:
    """Generate one dataset per family and print the table."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--runs", type=int, default=6)
    ap.add_argument("--duration", type=float, default=10.0)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    settings = RigSettings(n_runs=a.runs, duration=a.duration)
    jobs = [(n, f) for n, c in V3_LAWS.items() for f in c.families]
    print("| effect | family | peak size | hover/tracking RMS g [µm] | d [µm] |\n|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        truth = json.loads((generate(Path(tmp) / "none", None, a.seed, settings) / "truth.json").read_text())
        print(_row("none", "-", truth), flush=True)
        for name, fam in tqdm(jobs, desc="families", leave=False):
            spec = V3_DRAWS[name](rng)
            while spec["family"] != fam:
                spec = V3_DRAWS[name](rng)
            folder = generate(Path(tmp) / f"{name}_{fam}", {name: spec}, a.seed, settings)
            print(_row(name, fam, json.loads((folder / "truth.json").read_text())), flush=True)


if __name__ == "__main__":
    main()
