"""Re-diagnose one case of the pre-registered v3 blind check (``results/prereg/issue27_v3_result.json``).

These datasets are SEEN (the check ran at 24e8b4f): what this measures is training accuracy. The case's scenario is
re-drawn with :func:`maglev_ocp.rigsim.draw` from the seed and kind in the result file (same seed, same bytes), the
dataset generated and diagnosed with the self-check's settings, and the report written under ``OUT/report``.

Usage: ``python results/diagnosis/cogging_coenergy/rediagnose_case.py INDEX OUT``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from maglev_ocp.diagnosis import diagnose
from maglev_ocp.diagnosis.report import write_report
from maglev_ocp.diagnosis.selftest import SelftestSettings
from maglev_ocp.riglog import read_dataset
from maglev_ocp.rigsim import RigSettings, draw, generate

RESULT = Path(__file__).resolve().parents[2] / "prereg" / "issue27_v3_result.json"


def main(index: int, out: Path) -> None:
    """Re-draw, generate and diagnose case ``index``; print the verdict and the table, write the report."""
    cases = {c["index"]: c for c in json.loads(RESULT.read_text())["cases"]}
    tp = cases[index]["truth_params"]
    scen = draw(tp["seed"], tp["kind"], laws="v3")
    if scen["effects"].keys() != tp["effects"].keys():
        raise SystemExit(f"case {index}: the re-drawn scenario differs from the result file's")
    st = SelftestSettings()
    folder = out / "ds"
    if not (folder / "truth.json").exists():
        generate(folder, scen["effects"], tp["seed"], RigSettings(n_runs=st.generator.n_runs,
                                                                   duration=st.generator.run_duration))  # fmt: skip
    t0 = time.perf_counter()
    d = diagnose(read_dataset(folder), settings=st.diagnose.model_copy(update={"seed": int(tp["seed"] % (2**31))}))
    print("verdict", d.verdict.verdict, "found", d.effects_found, f"{time.perf_counter() - t0:.0f} s")
    print(d.table())
    write_report(d, out / "report")


if __name__ == "__main__":
    main(int(sys.argv[1]), Path(sys.argv[2]))
