"""``python -m maglev_ocp`` is the ``maglev`` command."""

import signal
import sys

from .cli import main

try:
    code = main()
except KeyboardInterrupt:  # an interrupt that reached past main's own handler (e.g. while it returned)
    code = 130
finally:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the work is done: a late interrupt must not kill the exit silently
sys.exit(code)
