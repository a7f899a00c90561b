"""User-facing errors: bad input gets one line and exit code 2, never a traceback."""

from __future__ import annotations


class UserError(Exception):
    """An error caused by the user's input (file, key, value), not by a bug.

    The CLI prints ``str(err)`` on one line and exits with code 2.
    """

    exit_code: int = 2


class ConfigError(UserError):
    """A YAML settings file that does not parse or does not validate."""


class DataError(UserError):
    """A rig-log dataset that does not satisfy ``RIG_LOG.md``."""
