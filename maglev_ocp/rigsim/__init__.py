"""An independent rig generator: the maglev stage simulated again from the physics.

A plant simulator written apart from the suite (it imports none of the
suite's model, effects, plant, controllers, observers or estimation code; an
import-linter contract in ``pyproject.toml`` enforces it) that writes datasets
in the ``maglev-rig-log/1`` format, so that the gap diagnosis and calibration
can be checked on a rig they were not built from.

* :mod:`.physics` - nominal shape functions, seed eq. (2) and the cogging of eq. (9), from MODEL.md;
* :mod:`.laws` - effects as law families (library effects and ones outside the library);
* :mod:`.laws_new`, :mod:`.laws_v3`, :mod:`.laws_v4`, :mod:`.laws_v5`, :mod:`.laws_v6`, :mod:`.laws_v7`,
  :mod:`.laws_v8`, :mod:`.laws_v9`, :mod:`.laws_v10`, :mod:`.laws_v11`, :mod:`.laws_v12`, :mod:`.laws_v13`,
  :mod:`.laws_v14`, :mod:`.laws_v15`, :mod:`.laws_v16`, :mod:`.laws_v17`, :mod:`.laws_v18` - a second to eighteenth set
  of families from the literature (issue 27; :mod:`.draw_v4` ... :mod:`.draw_v18` draw the fourth to eighteenth);
* :mod:`.control` - the generator's own feedback-linearizing PID controller;
* :mod:`.sim` - the rig (amplifier, encoders, noise, stops) and the closed loop (Dormand-Prince 5);
* :mod:`.excite` - min-jerk moves at varied speeds plus dither over the gap band and the stroke;
* :mod:`.generate` - :func:`generate` writes a dataset and its ``truth.json``;
* :mod:`.draw` - :func:`draw` picks a random scenario for a blind self-check.

Command line: ``python -m maglev_ocp.rigsim --out DIR --seed N [--effects a,b] [--draw]``.
"""

from __future__ import annotations

from .draw import draw
from .generate import expected_verdict, generate
from .laws import LAWS, LIBRARY_EFFECTS, OUT_OF_LIBRARY
from .laws_new import ALL_EFFECTS, ALL_LIBRARY, ALL_OUT_OF_LIBRARY, NEW_LAWS
from .laws_v3 import EFFECTS_V3, V3_LAWS
from .laws_v4 import EFFECTS_V4, V4_LAWS
from .laws_v5 import EFFECTS_V5, V5_LAWS
from .laws_v6 import EFFECTS_V6, V6_LAWS
from .laws_v7 import EFFECTS_V7, V7_LAWS
from .laws_v8 import EFFECTS_V8, V8_LAWS
from .laws_v9 import EFFECTS_V9, V9_LAWS
from .laws_v10 import EFFECTS_V10, V10_LAWS
from .laws_v11 import EFFECTS_V11, V11_LAWS
from .laws_v12 import EFFECTS_V12, V12_LAWS
from .laws_v13 import EFFECTS_V13, V13_LAWS
from .laws_v14 import EFFECTS_V14, V14_LAWS
from .laws_v15 import EFFECTS_V15, V15_LAWS
from .laws_v16 import EFFECTS_V16, V16_LAWS
from .laws_v17 import EFFECTS_V17, V17_LAWS
from .laws_v18 import EFFECTS_V18, V18_LAWS, make_law
from .physics import NOMINAL, Constants
from .sim import RigSettings

__all__ = [
    "ALL_EFFECTS",
    "ALL_LIBRARY",
    "ALL_OUT_OF_LIBRARY",
    "EFFECTS_V3",
    "EFFECTS_V4",
    "EFFECTS_V5",
    "EFFECTS_V6",
    "EFFECTS_V7",
    "EFFECTS_V8",
    "EFFECTS_V9",
    "EFFECTS_V10",
    "EFFECTS_V11",
    "EFFECTS_V12",
    "EFFECTS_V13",
    "EFFECTS_V14",
    "EFFECTS_V15",
    "EFFECTS_V16",
    "EFFECTS_V17",
    "EFFECTS_V18",
    "LAWS",
    "LIBRARY_EFFECTS",
    "NEW_LAWS",
    "NOMINAL",
    "OUT_OF_LIBRARY",
    "V3_LAWS",
    "V4_LAWS",
    "V5_LAWS",
    "V6_LAWS",
    "V7_LAWS",
    "V8_LAWS",
    "V9_LAWS",
    "V10_LAWS",
    "V11_LAWS",
    "V12_LAWS",
    "V13_LAWS",
    "V14_LAWS",
    "V15_LAWS",
    "V16_LAWS",
    "V17_LAWS",
    "V18_LAWS",
    "Constants",
    "RigSettings",
    "draw",
    "expected_verdict",
    "generate",
    "make_law",
]
