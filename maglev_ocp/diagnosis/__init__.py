"""Sim-to-real gap diagnosis: where the model and the rig part, which effect causes it, how far it shrinks.

``maglev diagnose DATASET --out DIR`` runs :func:`diagnose` on a rig-log
dataset and writes :mod:`report` files; ``--selftest N`` runs the blind
self-check (:mod:`selftest`); ``--scenario`` the closed-loop view
(:mod:`closed_loop`).

Modules: :mod:`settings` (what a diagnosis is asked), :mod:`residuals`
(filtered equation-error residuals), :mod:`spectra` (the one Welch PSD),
:mod:`localize` (floor, binning, period scan, regions), :mod:`noise` (the noise
model, whiteness), :mod:`peaks` (spectral peaks with damping, the lag's
resonance guard), :mod:`library` (the candidate effects: parameters, bounds,
law families), :mod:`fit` (their bounded least-squares fit),
:mod:`attribution` (held-out scores), :mod:`verdict` (the verdict as effect
sets, its one text form), :mod:`stages` (one module per stage, each with its
own result), :mod:`diagnose` (the stages in order, timing, progress, the
:class:`Diagnosis` assembled), :mod:`consequence` (force, delay and closed-loop
consequence of an effect; the model as a plant file), :mod:`simulate_compare`
(short-window simulated trajectories), :mod:`result` (the :class:`Diagnosis`
type, its JSON and text summary), :mod:`report` (Markdown and figures),
:mod:`generate` (diagnosis datasets on the plant), :mod:`selftest`,
:mod:`closed_loop`. :mod:`candidates` re-exports :mod:`library` and :mod:`fit`
under their former name. The filter and the standard errors are the
identification toolkit's (:mod:`maglev_ocp.estimation.ident`), shared with the
calibration.
"""

from .diagnose import LIBRARY, diagnose
from .result import DiagnoseSettings, Diagnosis

__all__ = ["LIBRARY", "DiagnoseSettings", "Diagnosis", "diagnose"]
