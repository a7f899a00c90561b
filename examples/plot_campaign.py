"""
A small robustness campaign
===========================

A campaign (:doc:`/campaigns`) runs one base scenario many times with what
varies drawn from one seed: the rig's true constants, random targets, the
controllers compared on the very same draws. ``maglev campaign FILE --out DIR``
runs it on a local Dask cluster (``--workers N``), a running scheduler, or in
this process (``--workers 1``, used here); finished runs are skipped when it is
run again.

Here: four rigs whose C1..C4 are drawn within ±10 % of the values the
controllers believe, one random target each, feedback linearization against
the seed's PID regulators.
"""

# %%
# The campaign file and its base scenario
# ---------------------------------------
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import yaml

from maglev_ocp.campaign import run_campaign

work = Path(tempfile.mkdtemp(prefix="maglev_campaign_"))
base = {
    "name": "robustness_base",
    "seed": 1,
    "controller": {"type": "fl"},
    "plant": {"profile": "default"},
    "targets": [{"g": 0.020, "d": 0.0, "hold": 0.2}],
}
campaign = {
    "name": "robustness_small",
    "base_scenario": "base.yaml",  # relative to the campaign file
    "n_runs": 4,
    "seed": 2026,
    "vary": {
        "plant": {n: {"dist": "uniform", "pct": 10} for n in ("C1", "C2", "C3", "C4")},
        "targets": {"n": 1, "hold": 0.2, "g": [0.016, 0.022], "d": [-0.02, 0.02]},
        "controllers": [{"type": "fl"}, {"type": "pid"}],
    },
    "save": {"log": False, "figures": False},
}
(work / "base.yaml").write_text(yaml.safe_dump(base, sort_keys=False))
(work / "campaign.yaml").write_text(yaml.safe_dump(campaign, sort_keys=False))
print((work / "campaign.yaml").read_text())

# %%
# Run it in this process
# ----------------------
result = run_campaign(work / "campaign.yaml", work / "out", workers=1, progress=False, figures=False)
print(result.summary)

# %%
# Each run's worst steady error, by controller
# --------------------------------------------
# The same four rigs for both controllers: the comparison is paired.
table = result.summary.table
fig, (ax_g, ax_d) = plt.subplots(1, 2, figsize=(8, 3.4), sharey=False)
for ctrl, marker in (("fl", "o"), ("pid", "s")):
    rows = table[table["controller"] == ctrl].sort_values("draw")
    c1 = rows["dev.plant.C1"].to_numpy(dtype=float)
    ax_g.plot(c1, 1e6 * rows["m.max_rms_error_g_m"].to_numpy(dtype=float), marker, label=ctrl)
    ax_d.plot(c1, 1e6 * rows["m.max_rms_error_d_m"].to_numpy(dtype=float), marker, label=ctrl)
for ax, axis in ((ax_g, "g"), (ax_d, "d")):
    ax.set_xlabel("rig's C1 off the believed value [%]")
    ax.set_ylabel(f"worst steady RMS error in {axis} [µm]")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
fig.suptitle("Four drawn rigs, two controllers")
fig.tight_layout()
print(table[["draw", "controller", "dev.plant.C1", "m.all_settled", "m.max_rms_error_d_m"]].to_string(index=False))
