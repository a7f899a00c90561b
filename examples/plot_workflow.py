"""
The workflow end to end: rig logs to C code
===========================================

The path of a control engineer bringing up a stage, on a simulated rig:

1. **rig logs**: closed-loop runs of a rig that has an effect the model of
   :doc:`/model` does not have (here an *end effect*: thrust lost where the
   mover's magnets overhang the stator's ends);
2. **calibrate** the model's constants on them;
3. **diagnose** the gap between the model and the logs: which effect, how big;
   the diagnosis writes a *model file* (``model.yaml``);
4. load that model file into **feedback linearization** and the **NMPC** with the
   one key ``controller: {model: FILE}`` and run the **closed loop** on the rig;
5. **generate C** of the controller and, where a C compiler is found, run the
   generated harness over the closed-loop log.

Every step below is the Python API behind a ``maglev`` command (``maglev
diagnose generate``, ``maglev calibrate``, ``maglev diagnose run``, ``maglev run``,
``maglev codegen``; see :doc:`/cli`). The datasets are small so the example
runs in well under a minute; on your rig, record more and longer runs (the
defaults: 6 runs of 10 s).
"""

# %%
# 1. Rig logs from a rig with an effect
# -------------------------------------
# The plant simulator of the library with the default profile's noise, 10 µm
# encoders, current limits and stops, the nominal constants, and one effect
# switched on. :func:`~maglev_ocp.diagnosis.generate.generate_dataset` runs the
# seed's PID loops over excitation references covering the gap range and the
# stroke, and returns a rig-log dataset (:doc:`/formats`). Four runs of 6 s:
# an end effect is claimed only where its signature shows at each end of the
# stroke on the held-out runs (:doc:`/diagnosis`), and on three runs of 4 s the
# one held-out run holds too few samples at the ends for that test.
import shutil
import subprocess
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import yaml

from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
from maglev_ocp.diagnosis.selftest import selftest_plant
from maglev_ocp.params import NOMINAL

work = Path(tempfile.mkdtemp(prefix="maglev_workflow_"))
rig = selftest_plant("given", {"end_effect": {"enabled": True}})
generated = generate_dataset(
    rig, NOMINAL, seed=np.random.SeedSequence(3), settings=GeneratorSettings(n_runs=4, run_duration=6.0)
)
generated.save(work / "rig_logs")
dataset = generated.dataset
print(dataset.table())

fig, (ax_g, ax_d) = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5))
for run in dataset.runs:
    col = run.columns
    ax_g.plot(col["t"], 1e3 * col["g"], lw=0.8, label=run.file)
    ax_d.plot(col["t"], 1e3 * col["d"], lw=0.8)
ax_g.set_ylabel("air gap g [mm]")
ax_d.set_ylabel("position d [mm]")
ax_d.set_xlabel("time t [s]")
ax_g.legend(fontsize=7, loc="upper right")
ax_g.set_title("Rig logs: closed-loop excitation runs")
fig.tight_layout()

# %%
# 2. Calibrate
# ------------
# :func:`~maglev_ocp.estimation.calibrate.calibrate` runs the seed's procedures
# that the runs allow (here the free runs of section V.D) and the batch fit of
# C1..C4, xi0 and ell with standard errors (``maglev calibrate DATASET --out DIR``).
# Its warning is the point of the next step: the residuals stay correlated, an
# effect outside the model shapes the data.
from maglev_ocp.estimation.calibrate import calibrate

cal = calibrate(work / "rig_logs", eps_list=(0.01,), progress=False)
cal.save(work / "calibration", figures=False)
print(cal.table())
# A calibration that cannot identify a constant says so (``maglev calibrate`` then refuses to write
# unless ``--force``, which marks the file ``trusted: false``).
print("trust problems:", cal.trust_problems() or "none")

# %%
# 3. Diagnose
# -----------
# :func:`~maglev_ocp.diagnosis.diagnose` calibrates a baseline on the training
# runs, localizes where the residual exceeds the noise floor, fits the effect
# library's candidates and scores them on held-out runs (``maglev diagnose run
# DATASET --out DIR``; the method is in :doc:`/diagnosis`). To keep the example
# short it tries three candidates; leave ``candidates`` unset on a rig (all of
# the library's effects are tried).
from maglev_ocp.diagnosis import diagnose
from maglev_ocp.diagnosis.report import write_report
from maglev_ocp.diagnosis.result import DiagnoseSettings

settings = DiagnoseSettings(candidates=["friction", "end_effect", "saturation"], max_effects=2, consequence=False)
diagnosis = diagnose(dataset, settings=settings)
write_report(diagnosis, work / "diagnosis", figures=False)
print("verdict:", diagnosis.verdict.verdict)
print("\n".join(diagnosis.verdict.reasons))
model_file = work / "diagnosis" / "model.yaml"
print(model_file.read_text())

# %%
# 4. The diagnosed model in FL and NMPC, closed loop on the rig
# -------------------------------------------------------------
# The one key ``controller: {model: FILE}`` loads a model file (constants and
# fitted effects; :doc:`/formats`) into either controller. The rig is the plant
# of step 1, written as a plant file. The scenario is written to the work
# folder and loaded from there; relative paths in a scenario resolve from the
# scenario file's folder (here the paths are absolute, so they read the same
# from anywhere). Two moves to the ends of the stroke, where the end effect
# acts, first with the nominal model (blind), then with the diagnosed one.
from maglev_ocp.runner import run_scenario
from maglev_ocp.scenario import load_scenario

(work / "rig.yaml").write_text(yaml.safe_dump(rig.to_dict(), sort_keys=False))


def scenario(ctype: str, model: Path | None) -> Path:
    """Write a scenario YAML for controller ``ctype`` with an optional model file; return its path."""
    controller = {"type": ctype, **({"model": str(model)} if model else {})}
    data = {
        "name": f"ends_{ctype}_{'diagnosed' if model else 'blind'}",
        "seed": 7,
        "controller": controller,
        "plant": {"file": str(work / "rig.yaml")},
        "start": {"g": 0.018, "d": 0.0, "hover": 0.1},
        "targets": [{"g": 0.016, "d": 0.045, "hold": 0.25}, {"g": 0.020, "d": -0.045, "hold": 0.25}],
    }
    path = work / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


results = {}
for ctype in ("fl", "nmpc"):
    for model in (None, model_file):
        sc = load_scenario(scenario(ctype, model))
        res = run_scenario(sc, out_dir=work / "runs" / sc.name, progress=False, figures=False)
        results[sc.name] = res
        m = res.metrics
        print(
            f"{sc.name:22s} settled {sum(t.settled for t in m.targets)}/{len(m.targets)}  "
            f"worst steady RMS g {1e6 * m.max_rms_error_g_m:5.1f} µm, d {1e6 * m.max_rms_error_d_m:5.1f} µm"
        )

fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5))
for name, res in results.items():
    c = res.columns
    err_d = 1e6 * (c["d_true"] - c["d_ref"]) if "d_true" in c else 1e6 * (c["d"] - c["d_ref"])
    err_g = 1e6 * (c["g_true"] - c["g_ref"]) if "g_true" in c else 1e6 * (c["g"] - c["g_ref"])
    axes[0].plot(c["t"], err_g, lw=0.8, label=name)
    axes[1].plot(c["t"], err_d, lw=0.8)
axes[0].set_ylabel("g error [µm]")
axes[1].set_ylabel("d error [µm]")
axes[1].set_xlabel("time t [s]")
for ax in axes:
    ax.set_ylim(-150, 150)
axes[0].legend(fontsize=7, ncol=2)
axes[0].set_title("Tracking error against the plan: blind vs diagnosed model")
fig.tight_layout()

# %%
# 5. C code of the controller, and its harness
# --------------------------------------------
# :func:`~maglev_ocp.codegen.generate_controllers` writes self-contained C99 of
# the NMPC step designed on the diagnosed model (``maglev codegen --scenario
# FILE --out DIR``): the header, a harness ``main.c`` that runs the controller
# over a rig-log CSV, a Makefile and a CMakeLists.txt. The model file's effects
# are baked into the step. With a C compiler on the machine, the same scenario
# runs again with ``backend: c`` (the generated code, compiled and called from
# the loop) and its currents are compared with the Python backend's; the
# harness built from the same sources then replays the closed-loop log and
# reports the step's time (``--repeat``). A replay of the NMPC in its default
# *preview* mode differs from the log where the reference accelerates (the log
# stores each period's mean reference acceleration; see :doc:`/codegen`).
from maglev_ocp.codegen import generate_controllers
from maglev_ocp.codegen.build import build_cached, find_compiler

nmpc_scenario = load_scenario(work / "ends_nmpc_diagnosed.yaml")
sources = generate_controllers(
    ("nmpc",),
    params=nmpc_scenario.controller_model_params(),
    nmpc_settings=nmpc_scenario.controller.settings,
    shaping=nmpc_scenario.reference.shaping,
)
sources.save(work / "controller_c")
print(sorted(p.name for p in (work / "controller_c").iterdir()))

if find_compiler() and shutil.which("make"):
    data = yaml.safe_load((work / "ends_nmpc_diagnosed.yaml").read_text())
    data["name"] = "ends_nmpc_diagnosed_c"
    data["controller"]["backend"] = "c"
    (work / "ends_nmpc_diagnosed_c.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    res_c = run_scenario(load_scenario(work / "ends_nmpc_diagnosed_c.yaml"), progress=False, figures=False)
    py, cc = results["ends_nmpc_diagnosed"].columns, res_c.columns
    diff = max(np.abs(py[k] - cc[k]).max() for k in ("i_q", "i_d"))
    print(f"backend c vs python, same scenario and seed: max |current difference| {diff:.1e} A")

    built = build_cached(sources, progress=False)
    log_csv = work / "runs" / "ends_nmpc_diagnosed" / "log.csv"
    replay = subprocess.run(
        [str(built.harness), "nmpc", str(log_csv), "-o", str(work / "harness_currents.csv"), "--repeat", "3"],
        capture_output=True,
        text=True,
        check=True,
    )
    print("harness:", replay.stderr.strip())

    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(py["t"], py["i_q"], lw=2.0, label="NMPC, Python backend")
    ax.plot(cc["t"], cc["i_q"], lw=0.8, ls="--", label="NMPC, generated C (backend: c)")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("thrust current i_q [A]")
    ax.legend(fontsize=8)
    ax.set_title("The generated C commands the same currents")
    fig.tight_layout()
else:
    print("no C compiler or make on this machine: the C sources are written, not built")

# %%
# Files written
# -------------
# Everything above is in one folder: the rig logs, ``calibration/model.yaml``,
# ``diagnosis/report.md`` with ``model.yaml``, each run's ``log.csv`` and
# ``metrics.json``, and the C sources.
print(work)
print(sorted(str(p.relative_to(work)) for p in work.iterdir()))
