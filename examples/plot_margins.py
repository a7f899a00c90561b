"""
Loop margins of feedback linearization and the NMPC
===================================================

:mod:`maglev_ocp.analysis` (``maglev analyze``; method in :doc:`/analysis`)
settles a controller at a hover point on a noise-free plant, linearizes the
controller as the map (memory, reading) -> (memory, command) and the plant by
CasADi AD, breaks each axis' loop at its current (the other loop closed) and
computes the gain, phase, disk and delay margins with python-control.

Here at one hover point (g = 20 mm, d = 0) with the default profile's 2 kHz
amplifier lag, for both controllers: the margins table and the Bode plot of
the loop transfer function of the gap axis.
"""

# %%
import matplotlib.pyplot as plt
import numpy as np

from maglev_ocp.analysis import AnalysisPlant, analyze_point
from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings
from maglev_ocp.controllers.nmpc import NMPC, NMPCSettings
from maglev_ocp.params import NOMINAL

plant = AnalysisPlant(params=NOMINAL, lag_hz=2000.0, delay_samples=0)
factories = {
    "fl": lambda: FeedbackLinearization(FLSettings(), params=NOMINAL),
    "nmpc": lambda: NMPC(NMPCSettings(), params=NOMINAL),
}
points = {name: analyze_point(make, plant, 0.020, 0.0, name=name) for name, make in factories.items()}

# %%
# The margins, loop broken at the plant input
# -------------------------------------------
header = (
    f"{'ctrl':5s} {'axis':4s} {'GM+ [dB]':>9s} {'PM [deg]':>9s} {'DM [ms]':>8s} {'disk alpha':>10s} {'BW [Hz]':>8s}"
)
print(header)
print("-" * len(header))
for name, pt in points.items():
    for loop in pt.loops:
        if loop.at != "input":
            continue
        r = loop.row(plant.Ts)
        print(
            f"{name:5s} {loop.axis:4s} {r['gm_upper_db']:9.1f} {r['pm_deg']:9.1f} {r['delay_margin_ms']:8.2f} "
            f"{r['disk_alpha']:10.2f} {r['bandwidth_hz']:8.0f}"
        )

# %%
# Bode plot of the gap loop
# -------------------------
fig, (ax_mag, ax_ph) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
for name, pt in points.items():
    loop = next(lp for lp in pt.loops if lp.axis == "g" and lp.at == "input")
    f_hz = loop.omega / (2 * np.pi)
    ax_mag.semilogx(f_hz, 20 * np.log10(np.abs(loop.L)), label=name)
    ax_ph.semilogx(f_hz, np.degrees(np.unwrap(np.angle(loop.L))), label=name)
ax_mag.axhline(0, color="k", lw=0.5)
ax_ph.axhline(-180, color="k", lw=0.5)
ax_mag.set_ylabel("|L| [dB]")
ax_ph.set_ylabel("phase of L [deg]")
ax_ph.set_xlabel("frequency [Hz]")
ax_mag.legend(fontsize=8)
ax_mag.set_title("Gap loop broken at the current, g = 20 mm, d = 0")
fig.tight_layout()
