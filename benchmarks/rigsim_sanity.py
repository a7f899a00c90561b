"""One dataset per family of one of rigsim's law sets: does it keep the stage off its stops, and how big is it?

For each (effect, family) of the law set ``--laws`` (:mod:`maglev_ocp.rigsim.laws_v4` or ``laws_v5``) the first
scenario drawn by ``rigsim.draw(seed, laws=LAWS)`` (seeds from ``--first`` on) that contains it gives the law's
parameters; the law alone is then simulated on the default rig (6 runs x 10 s, the rig's own FL-PID controller),
with the dataset's seed. Reported per family: the truth's peak size, the readings' range, the samples within 50 µm of
a stop, and the tracking RMS (reading minus reference after the first second), beside the RMS of the same
seed's rig without the effect (same constants, excitation and noise: the difference is the effect's).

With ``--sweep N`` it instead generates the ``N`` scenarios ``draw(seed, laws=LAWS)`` for seeds from ``--first``
on, as the blind self-check draws them (none, single, pairs, triples, out of library), on the default rig.

``python benchmarks/rigsim_sanity.py --laws v4 --first 5000 --out results/rigsim/v4_sanity.md``
``python benchmarks/rigsim_sanity.py --laws v4 --first 7000 --sweep 40 --out results/rigsim/v4_sweep.md``
``python benchmarks/rigsim_sanity.py --laws v5 --first 5000 --out results/rigsim/v5_sanity.md``
``python benchmarks/rigsim_sanity.py --laws v5 --first 7000 --sweep 40 --out results/rigsim/v5_sweep.md``
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws_v4 import V4_LAWS
from maglev_ocp.rigsim.laws_v5 import V5_LAWS

#: The law sets this check knows, with their classes by effect.
SETS = {"v4": V4_LAWS, "v5": V5_LAWS}

STOP_MARGIN = 5e-5  #: a reading within this of a stop counts as a stop hit [m]


def pick(first: int, laws: str = "v4") -> list[tuple[str, str, int, dict]]:
    """``(effect, family, seed, spec)`` for every family of ``laws``: the first drawn scenario that has it."""
    want = {(n, f) for n, c in SETS[laws].items() for f in c.families}
    out = [("none", "-", first, {})]
    s = first
    while want and s < first + 5000:
        for name, spec in draw(s, laws=laws)["effects"].items():
            if (name, spec["family"]) in want:
                want.discard((name, spec["family"]))
                out.append((name, spec["family"], s, spec))
        s += 1
    return out


def measure(folder: Path) -> dict:
    """Reading ranges, stop hits and tracking RMS of a written dataset."""
    gs, ds, eg, ed = [], [], [], []
    for p in sorted(folder.glob("run_*.csv")):
        head = p.read_text().splitlines()[0].split(",")
        a = np.loadtxt(p, delimiter=",", skiprows=1)
        col = {n: a[:, i] for i, n in enumerate(head)}
        gs.append(col["g"])
        ds.append(col["d"])
        eg.append((col["g"] - col["g_ref"])[1000:])
        ed.append((col["d"] - col["d_ref"])[1000:])
    g, d = np.concatenate(gs), np.concatenate(ds)
    hits = int(np.sum((g < k.g_stop[0] + STOP_MARGIN) | (g > k.g_stop[1] - STOP_MARGIN)))
    hits += int(np.sum((d < k.d_stop[0] + STOP_MARGIN) | (d > k.d_stop[1] - STOP_MARGIN)))
    return {
        "g_min_mm": 1e3 * float(g.min()),
        "g_max_mm": 1e3 * float(g.max()),
        "d_min_mm": 1e3 * float(d.min()),
        "d_max_mm": 1e3 * float(d.max()),
        "stop_hits": hits,
        "rms_g_um": 1e6 * float(np.sqrt(np.mean(np.concatenate(eg) ** 2))),
        "rms_d_um": 1e6 * float(np.sqrt(np.mean(np.concatenate(ed) ** 2))),
        "max_err_g_um": 1e6 * float(np.max(np.abs(np.concatenate(eg)))),
        "max_err_d_um": 1e6 * float(np.max(np.abs(np.concatenate(ed)))),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--laws", choices=tuple(SETS), default="v4", help="law set (default v4)")
    ap.add_argument("--first", type=int, default=5000, help="first draw seed searched (default 5000)")
    ap.add_argument("--out", type=Path, help="write the table (markdown) and a .json beside it")
    ap.add_argument("--sweep", type=int, default=0, metavar="N", help="N drawn scenarios instead of one per family")
    args = ap.parse_args()
    if args.sweep:
        sweep(args.first, args.sweep, args.out, args.laws)
        return
    rows = []
    for name, fam, seed, spec in tqdm(pick(args.first, args.laws), desc="families"):
        eff = {} if name == "none" else {name: spec}
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            f = generate(Path(tmp) / "ds", eff, seed=seed, settings=RigSettings())
            truth = json.loads((f / "truth.json").read_text())
            m = measure(f)
        with tempfile.TemporaryDirectory() as tmp:
            base = measure(generate(Path(tmp) / "ds", {}, seed=seed, settings=RigSettings()))
        m.update(base_rms_g_um=base["rms_g_um"], base_rms_d_um=base["rms_d_um"])
        e = truth["effects"].get(name, {})
        size = {a: b for a, b in e.items() if a.startswith(("peak_", "effective_delay"))}
        rows.append({"effect": name, "family": fam, "seed": seed, "size": size, **m, "s": time.perf_counter() - t0})
        print(json.dumps(rows[-1]), flush=True)
    lines = [
        "| effect | family | seed | peak size | g range [mm] | d range [mm] | stop hits | RMS g / d [µm] | "
        "without it [µm] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        sz = ", ".join(f"{a} {b:.3g}" for a, b in r["size"].items() if not a.endswith(("_g_n", "_d_n")))
        lines.append(
            f"| {r['effect']} | {r['family']} | {r['seed']} | {sz or '-'} | {r['g_min_mm']:.2f}-{r['g_max_mm']:.2f} | "
            f"{r['d_min_mm']:.1f}-{r['d_max_mm']:.1f} | {r['stop_hits']} | {r['rms_g_um']:.1f} / {r['rms_d_um']:.1f} | "
            f"{r['base_rms_g_um']:.1f} / {r['base_rms_d_um']:.1f} |"
        )
    print("\n".join(lines))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")
        args.out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")


def sweep(first: int, n: int, out: Path | None, laws: str = "v4") -> None:
    """Generate ``n`` drawn scenarios of the law set ``laws`` and tabulate stop hits, ranges and tracking."""
    rows = []
    for seed in tqdm(range(first, first + n), desc="scenarios"):
        sc = draw(seed, laws=laws)
        with tempfile.TemporaryDirectory() as tmp:
            f = generate(Path(tmp) / "ds", sc["effects"], seed=seed, settings=RigSettings())
            m = measure(f)
        eff = ", ".join(f"{a} ({b['family']})" for a, b in sc["effects"].items()) or "-"
        rows.append({"seed": seed, "kind": sc["kind"], "effects": eff, **m})
        print(json.dumps(rows[-1]), flush=True)
    lines = [
        "| seed | kind | effects | g range [mm] | d range [mm] | stop hits | RMS g / d [µm] |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['seed']} | {r['kind']} | {r['effects']} | {r['g_min_mm']:.2f}-{r['g_max_mm']:.2f} | "
            f"{r['d_min_mm']:.1f}-{r['d_max_mm']:.1f} | {r['stop_hits']} | {r['rms_g_um']:.1f} / {r['rms_d_um']:.1f} |"
        )
    print("\n".join(lines))
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text("\n".join(lines) + "\n")
        out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
