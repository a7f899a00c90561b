"""
Your own loop with the Python API
=================================

Every block of the suite, the plant simulator, the observers and the
controllers, has the same two methods (:mod:`maglev_ocp.blocks`): ``reset``
once, then ``step`` once per 1 ms control period. A loop on a real rig is the
same code with the rig's I/O in place of :class:`~maglev_ocp.plant.Plant`; no
runner, scenario file or command is needed.

Here: feedback linearization on the ``default`` rig profile (noise, 10 µm
encoders, current limits, stops, amplifier lag, a few % of parameter
mismatch), a smooth 20 mm move of the mover that we plan ourselves, and an
extra high-gain observer run beside the controller, fed the same readings and
the currents the controller commanded.
"""

# %%
# The blocks
# ----------
import matplotlib.pyplot as plt
import numpy as np

from maglev_ocp.blocks import Reference
from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings
from maglev_ocp.observers import HighGainObserver, ObserverSettings
from maglev_ocp.params import NOMINAL
from maglev_ocp.plant import Plant, PlantConfig

Ts = 1e-3  # control period [s]
plant = Plant(PlantConfig.from_profile("default"), params=NOMINAL, seed=11)
ctrl = FeedbackLinearization(FLSettings(), params=NOMINAL, Ts=Ts)
observer = HighGainObserver(NOMINAL, ObserverSettings(eps=0.01, disturbance=True), Ts)


# %%
# A reference we plan ourselves
# -----------------------------
# A cosine ramp of the position d from 0 to 20 mm in 60 ms, with its rates for
# the controller's feed-forward, while the gap holds 18 mm.
def reference(t: float, t0: float = 0.05, T: float = 0.06, stroke: float = 0.020, g: float = 0.018) -> Reference:
    """Set-point and rates at time ``t`` [s]: hold, cosine ramp of ``stroke`` [m] over ``T`` [s], hold."""
    s = np.clip((t - t0) / T, 0.0, 1.0)
    moving = 0.0 < s < 1.0
    w = np.pi / T
    d = stroke * (1 - np.cos(np.pi * s)) / 2
    d_dot = stroke * w * np.sin(np.pi * s) / 2 if moving else 0.0
    d_ddot = stroke * w**2 * np.cos(np.pi * s) / 2 if moving else 0.0
    return Reference(g=g, d=float(d), d_dot=float(d_dot), d_ddot=float(d_ddot))


# %%
# The loop
# --------
# ``plant.reset`` returns the first :class:`~maglev_ocp.blocks.Measurement`;
# each ``ctrl.step`` returns a :class:`~maglev_ocp.blocks.ControlOutput` whose
# ``u`` is held over the next period by ``plant.step``.
y = plant.reset(np.array([0.018, 0.0, 0.0, 0.0]))
ctrl.reset(y, reference(0.0))
observer.reset(y.y)
n = 300
stops = 0
log = {k: np.zeros(n) for k in ("t", "g", "d", "d_ref", "g_true", "d_true", "d_hat", "i_q", "i_d")}
for k in range(n):
    ref = reference(y.t)
    out = ctrl.step(y, ref)
    log["t"][k], (log["g"][k], log["d"][k]) = y.t, y.y
    log["g_true"][k], log["d_true"][k] = y.x_true[0], y.x_true[2]
    log["d_ref"][k] = ref.d
    log["i_q"][k], log["i_d"][k] = out.u
    y = plant.step(out.u)
    stops += y.info.get("stop") is not None
    log["d_hat"][k] = observer.step(y.y, out.u)[2]  # the reading after out.u was held for one period

err = 1e6 * (log["d_true"] - log["d_ref"])
print(f"largest |d error| during the move: {np.abs(err[(log['t'] > 0.05) & (log['t'] < 0.11)]).max():.1f} µm")
print(f"RMS d error over the last 100 ms: {np.sqrt(np.mean(err[-100:] ** 2)):.1f} µm")
print(f"stop hits: {stops}")

# %%
# What happened
# -------------
fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 6))
axes[0].plot(log["t"], 1e3 * log["d_ref"], "k--", lw=1, label="reference")
axes[0].plot(log["t"], 1e3 * log["d"], lw=1, label="encoder reading")
axes[0].plot(log["t"], 1e3 * log["d_hat"], lw=1, label="our observer's estimate")
axes[0].set_ylabel("position d [mm]")
axes[0].legend(fontsize=8)
axes[1].plot(log["t"], err, lw=1)
axes[1].axhline(100, color="r", lw=0.5)
axes[1].axhline(-100, color="r", lw=0.5)
axes[1].set_ylabel("d error, true state [µm]")
axes[2].plot(log["t"], log["i_q"], lw=1, label="i_q")
axes[2].plot(log["t"], log["i_d"], lw=1, label="i_d")
axes[2].set_ylabel("current [A]")
axes[2].set_xlabel("time t [s]")
axes[2].legend(fontsize=8)
axes[0].set_title("Feedback linearization in a hand-written loop")
fig.tight_layout()
