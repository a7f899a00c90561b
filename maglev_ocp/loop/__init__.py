"""The one closed loop of controller and plant, and what runs on it.

* :mod:`.core` - :class:`ClosedLoop`: ``reset``/``step`` of a controller and a plant, pluggable recorders;
* :mod:`.recorders` - what a run logs: the scenario trace (:class:`TraceRecorder`) and the rig-log
  columns (:class:`RigLogRecorder`);
* :mod:`.drive` - rig-log runs: :func:`run_closed_loop`, :func:`run_open_loop`;
* :mod:`.experiments` - the seed's calibration experiments on the plant simulator (PID regulators).

The scenario runner (:mod:`maglev_ocp.runner`), campaigns, the diagnosis datasets and its
closed-loop view all step their runs through :class:`ClosedLoop`.
"""

from .core import ClosedLoop, Recorder, StepRecord
from .drive import CurrentSequence, run_closed_loop, run_open_loop
from .recorders import TIMING_SUFFIX, RigLogRecorder, TraceRecorder

__all__ = [
    "TIMING_SUFFIX",
    "ClosedLoop",
    "CurrentSequence",
    "Recorder",
    "RigLogRecorder",
    "StepRecord",
    "TraceRecorder",
    "run_closed_loop",
    "run_open_loop",
]
