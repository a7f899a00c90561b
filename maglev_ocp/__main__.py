"""``python -m maglev_ocp`` is the ``maglev`` command."""

import atexit
import os
import signal
import sys

from .cli import main

try:
    code = main()
except KeyboardInterrupt:  # an interrupt that reached past main's own handler (e.g. while it returned)
    code = 130
finally:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the work is done: a late interrupt must not kill the exit silently
if code == 130:
    # An interrupt that landed inside an import which runs code through the C API (PyRun_*) is remembered by
    # CPython as "unhandled" even though main caught it, and ``python -m`` then ends by re-raising SIGINT
    # (exit status -2) instead of returning 130 (seen when interrupted while the subcommands are imported).
    # So the interpreter's exit is done here: the exit handlers, the streams, then the status.
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # a closed pipe: nothing left to say
            pass
    os._exit(130)
sys.exit(code)
