"""``python -m maglev_ocp`` is the ``maglev`` command."""

import signal
import sys

from .cli import main

code = main()
signal.signal(signal.SIGINT, signal.SIG_IGN)  # the work is done: a late interrupt must not kill the exit silently
sys.exit(code)
