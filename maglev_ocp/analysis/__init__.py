"""Loop analysis: margins of the linearized closed loops over the operating envelope (``maglev analyze``).

* :mod:`.plant_model` - the plant the analysis closes the loop on: shared model, amplifier lag,
  computation delay (whole samples plus a fraction); its discrete linearization;
* :mod:`.controller_map` - any controller as the map ``(memory, reading) -> (memory, command)``:
  steady state, Jacobians by finite differences of its public ``step`` (or CasADi AD of its step
  Function), the part of the memory that takes part in the loop;
* :mod:`.margins` - broken loops per axis and their gain, phase, disk and delay margins, ``|S|``/``|T|``
  peaks and bandwidth (python-control);
* :mod:`.delay_check` - the delay margin found by simulating the nonlinear loop with an added delay;
* :mod:`.report` - the grid of operating points, tables and figures.
"""

from .controller_map import (
    LinearController,
    MemoryAccess,
    StepRecorder,
    linearize_controller,
    linearize_recorded,
    minimal_part,
    settle,
)
from .delay_check import simulated_delay_margin
from .margins import LoopMargins, broken_loop, loop_margins
from .plant_model import AnalysisPlant, DelayedPlantSim
from .report import analyze_grid, analyze_point, delay_cross_check, write_report

__all__ = [
    "AnalysisPlant",
    "DelayedPlantSim",
    "LinearController",
    "LoopMargins",
    "MemoryAccess",
    "StepRecorder",
    "analyze_grid",
    "analyze_point",
    "broken_loop",
    "delay_cross_check",
    "linearize_controller",
    "linearize_recorded",
    "loop_margins",
    "minimal_part",
    "settle",
    "simulated_delay_margin",
    "write_report",
]
