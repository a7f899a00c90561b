"""Sim-to-real gap diagnosis: where the model and the rig part, which effect causes it, how far it shrinks.

``maglev diagnose DATASET --out DIR`` runs :func:`diagnose` on a rig-log
dataset and writes :mod:`report` files; ``--selftest N`` runs the blind
self-check (:mod:`selftest`); ``--scenario`` the closed-loop view
(:mod:`closed_loop`).

Modules: :mod:`residuals` (filtered equation-error residuals), :mod:`localize`
(floor, binning, spectrum, period scan, regions), :mod:`noise` (noise-model
floor, whiteness, spectral peaks with damping, the lag's resonance guard),
:mod:`consequence` (force, delay and closed-loop consequence of an effect; the
model as a plant file), :mod:`candidates` (library
effects fitted as CasADi NLPs), :mod:`attribution` (held-out scores, verdict),
:mod:`simulate_compare` (short-window simulated trajectories), :mod:`diagnose`
(the pipeline, stage by stage), :mod:`result` (the :class:`Diagnosis` type, its
JSON and text summary), :mod:`report` (Markdown and figures), :mod:`generate`
(diagnosis datasets on the plant), :mod:`selftest`, :mod:`closed_loop`. The
filter and the standard errors are the identification toolkit's
(:mod:`maglev_ocp.estimation.ident`), shared with the calibration.
"""

from .diagnose import LIBRARY, diagnose
from .result import DiagnoseSettings, Diagnosis

__all__ = ["LIBRARY", "DiagnoseSettings", "Diagnosis", "diagnose"]
