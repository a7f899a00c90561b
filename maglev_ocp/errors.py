"""User-facing errors: bad input gets one line and exit code 2, never a traceback."""

from __future__ import annotations

import re

#: Longest message a :class:`UserError` carries (the rest is elided).
MAX_MESSAGE: int = 600


#: ``np.float64(0.048)`` -> ``0.048`` (the repr numpy 2 gives its scalars).
_NUMPY_SCALAR = re.compile(r"\bnp\.(?:float|int|uint|bool|complex|str)_?\d*\(([^()]*)\)")


def one_line(text: str, limit: int = MAX_MESSAGE) -> str:
    """Make ``text`` a single line of at most ``limit`` characters.

    Line breaks (which can come from the user's own data, e.g. a quoted CSV
    cell) are shown as ``\\n``, so an error always stays one line; numpy scalars
    show as plain numbers (``0.048``, not ``np.float64(0.048)``).
    """
    text = _NUMPY_SCALAR.sub(r"\1", text)
    text = text.replace("\r", "\\r").replace("\n", "\\n")
    return text if len(text) <= limit else text[: limit - 5] + " ..."


class UserError(Exception):
    """An error caused by the user's input (file, key, value), not by a bug.

    The CLI prints ``str(err)`` on one line and exits with code 2; the message
    is made one line (see :func:`one_line`) whatever the data put into it.
    """

    exit_code: int = 2

    def __init__(self, message: object = "") -> None:
        super().__init__(one_line(str(message)))


class ConfigError(UserError):
    """A YAML settings file that does not parse or does not validate."""


class DataError(UserError):
    """A rig-log dataset that does not satisfy ``RIG_LOG.md``."""
