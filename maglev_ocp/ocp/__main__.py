"""``python -m maglev_ocp.ocp``: minimum-time bounds of the 100 mm traverse."""

import sys

from .min_time import main

sys.exit(main())
