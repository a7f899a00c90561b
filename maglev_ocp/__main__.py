"""``python -m maglev_ocp`` is the ``maglev`` command."""

import sys

from .cli import main

sys.exit(main())
