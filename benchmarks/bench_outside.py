"""Gaps outside the library (issue 27 item 2): the session-time drift test and saturation's core, measured.

For each dataset of the independent rig (:mod:`maglev_ocp.rigsim`), the diagnosis's stages up to the noise
model's evidence (split, calibrated baseline, localization, noise) and then, on the baseline's held-out
residual, saturation's signature with its core at a fixed state (:func:`maglev_ocp.diagnosis.signatures.evidence`).
Per dataset one JSON line: the drift test per channel (held-out z, rms over the floor, significant, where),
saturation's evidence (signature and core per channel), and the time of the new pieces (median and p99 over
``--repeat`` calls: :func:`~maglev_ocp.diagnosis.outside.time_drift` on both channels,
:func:`~maglev_ocp.diagnosis.outside.model_stiffness`, :func:`~maglev_ocp.diagnosis.signatures.core_evidence`).

The cases are ``SEED:KIND:LAWS`` (:func:`maglev_ocp.rigsim.draw`); by default the seen v3 out-of-library cases
of the pre-registered check (results/prereg/issue27_v3_result.md: ``gap_sensor_drift`` 2574597895, 777214111,
807276515, ``steel_preload`` 905183607), three v3 saturation singles (984250072, 3270844379, 2142759224) and
the ``none`` datasets the drift test's false alarms were counted on (27001..27008).

Usage: ``python benchmarks/bench_outside.py OUT.jsonl [SEED:KIND:LAWS ...] [--repeat N]``
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from maglev_ocp.constants import encoder_resolution
from maglev_ocp.diagnosis.outside import model_stiffness, time_drift
from maglev_ocp.diagnosis.residuals import CHANNELS
from maglev_ocp.diagnosis.result import DiagnoseSettings
from maglev_ocp.diagnosis.signatures import SIGNATURES, core_evidence, evidence
from maglev_ocp.diagnosis.stages.baseline import calibrate_baseline
from maglev_ocp.diagnosis.stages.localization import localize_gap, noise_stage
from maglev_ocp.diagnosis.stages.split import split_dataset
from maglev_ocp.riglog import read_dataset
from maglev_ocp.rigsim import RigSettings, draw, generate

DEFAULT = [
    "2574597895:out_of_library:v3",
    "777214111:out_of_library:v3",
    "807276515:out_of_library:v3",
    "905183607:out_of_library:v3",
    "984250072:single:v3",
    "3270844379:single:v3",
    "2142759224:single:v3",
    *(f"{s}:none:{'old' if s % 2 else 'new'}" for s in range(27001, 27009)),
]


def _timed(fn, repeat: int) -> dict[str, float]:
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return {"median_s": float(np.median(ts)), "p99_s": float(np.quantile(ts, 0.99))}


def case(spec: str, repeat: int) -> dict:
    """One dataset: generated, staged, tested; its JSON record."""
    seed_s, kind, laws = spec.split(":")
    seed = int(seed_s)
    scen = draw(seed, kind, laws=laws)
    with tempfile.TemporaryDirectory(prefix="bench_outside_") as tmp:
        ds = read_dataset(generate(Path(tmp) / "ds", scen["effects"], seed, RigSettings(n_runs=6, duration=10.0)))
    st = DiagnoseSettings(seed=seed % 2**31)
    split = split_dataset(ds, st)
    q = float(ds.encoder_resolution or 0.0) or encoder_resolution
    base = calibrate_baseline(split, None, st, q)
    loc = localize_gap(split, base, st, np.random.default_rng(st.seed))
    noise, loc = noise_stage(split, base, loc, q, st.seed, drift_z=st.z_min, drift_min_floor=st.drift_min_floor)
    floors = {ch: float(nc.floor) for ch, nc in noise.checks.items()}
    ev = evidence("saturation", base.b_test, floors, seed=st.seed)
    fl = [floors.get(ch, float(base.fvec[c])) for c, ch in enumerate(CHANNELS)]
    return {
        "case": spec,
        "effects": {n: e.get("family") for n, e in scen["effects"].items()},
        "evidence": list(loc.evidence),
        "drifts": [{k: v for k, v in d.to_dict().items() if k not in ("mass", "stiffness")} for d in loc.drifts],
        "saturation": ev.to_dict(),
        "timing": {
            "time_drift": _timed(lambda: [time_drift(base.b_train, base.b_test, c, fl[c]) for c in (0, 1)], repeat),
            "model_stiffness": _timed(lambda: model_stiffness(base.spec, base.p, split.test), repeat),
            "core_evidence": _timed(lambda: core_evidence(SIGNATURES["saturation"], base.b_test, floors), repeat),
        },
    }


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    repeat = 5
    if "--repeat" in argv:
        i = argv.index("--repeat")
        repeat = int(argv[i + 1])
        argv = argv[:i] + argv[i + 2 :]
    out, specs = Path(argv[0]), argv[1:] or DEFAULT
    with out.open("w") as fh:
        for spec in specs:
            rec = case(spec, repeat)
            fh.write(json.dumps(rec, default=float) + "\n")
            fh.flush()
            d = {x["channel"]: f"z {x['z']:.1f}{'*' if x['significant'] else ''}" for x in rec["drifts"]}
            print(spec, rec["effects"], "drift", d, "saturation shows", rec["saturation"]["shows"], flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
