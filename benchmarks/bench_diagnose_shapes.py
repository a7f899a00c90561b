"""CPU and wall time of ``diagnose`` on two datasets whose effect law is not a library member (issue 27).

Used to measure what the learned-shape members (:mod:`maglev_ocp.effects`, ``flexible`` library members) cost
per diagnosis: run it once on the code before them and once after, and compare. The two plants carry

* ``tustin_friction``: friction with an exponential (Tustin) Stribeck curve, ``F = -sign(v) (Fc + Fs
  exp(-|v| / v_s)) - b v`` on both axes (Armstrong-Helouvry, Dupont, Canudas de Wit, Automatica 30(7), 1994,
  eq. (4)); the library's Stribeck member has the Gaussian ``exp(-(v / v_s)^2)``;
* ``cogging_h4``: a tangential cogging force with harmonics 1, 2 and 4 of the slot pitch (periods t1, t1 / 2,
  t1 / 4) and a power-law gap decay ``(g_ref / g)^2`` (Zhu and Howe, IEEE Trans. Energy Conv. 15(4), 2000:
  cogging as a Fourier series of the slot pitch); the library's closed-form cogging has neither the 4th
  harmonic nor this decay;

both written here, as forces added to the simulated rig. Output: one JSON line per dataset (verdict, effects,
process and wall time).

Usage: ``python benchmarks/bench_diagnose_shapes.py OUT.json``
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

from maglev_ocp import constants as k
from maglev_ocp.diagnosis import DiagnoseSettings, diagnose
from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
from maglev_ocp.diagnosis.selftest import selftest_plant
from maglev_ocp.params import NOMINAL

BASE = NOMINAL.without_cogging()
SMALL = GeneratorSettings(n_runs=4, run_duration=7.0)


def tustin_friction(fc=(0.3, 0.4), fs=(0.3, 0.5), vs=2e-3, b=(2.0, 3.0), v_reg=2e-4):
    """Friction with an exponential Stribeck curve on both axes (forces [N] on g and d)."""

    def F(t: float, x: np.ndarray) -> np.ndarray:
        out = np.zeros(2)
        for j, v in enumerate((x[1], x[3])):
            out[j] = -(fc[j] + fs[j] * math.exp(-abs(v) / vs)) * math.tanh(v / v_reg) - b[j] * v
        return out

    return F


def cogging_h4(amp=(0.6, 0.3, 0.0, 0.25), g_ref=0.010):
    """Tangential cogging with harmonics 1, 2, 4 of the slot pitch and a (g_ref / g)^2 decay [N]."""

    def F(t: float, x: np.ndarray) -> np.ndarray:
        a = 2 * math.pi * x[2] / k.t1
        fx = sum(c * math.sin((j + 1) * a + 0.3 * j) for j, c in enumerate(amp)) * (g_ref / x[0]) ** 2
        return np.array([0.0, fx])

    return F


CASES = {"tustin_friction": tustin_friction, "cogging_h4": cogging_h4}


def main(out: str) -> None:
    """Generate each dataset, diagnose it alone and time it."""
    rows = []
    for i, (name, law) in enumerate(CASES.items()):
        cfg = selftest_plant("given", {})
        gen = generate_dataset(cfg, BASE, seed=41 + i, settings=SMALL, extra_force=law())
        c0, w0 = time.process_time(), time.perf_counter()
        d = diagnose(gen.dataset, params=BASE, settings=DiagnoseSettings(simulate=False))
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        row = {
            "dataset": name,
            "verdict": d.verdict.verdict,
            "effects": list(d.effects_found),
            "cpu_s": round(cpu, 1),
            "wall_s": round(wall, 1),
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
    with open(out, "w") as fh:
        json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
