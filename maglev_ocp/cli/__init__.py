"""The ``maglev`` command line.

Each subcommand lives in its own module ``maglev_ocp/cli/cmd_<name>.py`` that
defines ``register(subparsers)``; modules are discovered here, so adding a
subcommand never touches this file. A subcommand's handler returns an exit
code. A :class:`~maglev_ocp.errors.UserError` anywhere becomes one line on
stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import pkgutil
import signal
import sys
import threading
import warnings
from collections.abc import Sequence

from ..errors import UserError, one_line

EPILOG = """examples:
  maglev model --gaps 10 15 20 25 --json
  maglev simulate --duration 2 --out data/hover
  maglev <command> --help       (every command explains itself, with an example)
"""


class _Formatter(argparse.RawDescriptionHelpFormatter):
    pass


class OneLineParser(argparse.ArgumentParser):
    """Argument parser whose usage errors are one line (``maglev run: error: ... (see maglev run --help)``)."""

    def error(self, message: str):  # type: ignore[override]
        """Print one line and exit 2 (argparse would print the whole usage first)."""
        _say(one_line(f"{self.prog}: error: {message} (see {self.prog} --help)"))
        raise SystemExit(2)


def add_quiet(p: argparse.ArgumentParser) -> None:
    """The progress flag every command shares: ``--quiet`` (``--no-progress`` kept as a hidden alias)."""
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--no-progress", dest="quiet", action="store_true", help=argparse.SUPPRESS)


def parse_list(flag: str, values: Sequence[str] | None) -> list[str]:
    """A list flag the one way every command takes it: comma-separated (``--controllers fl,nmpc``).

    Space-separated values are accepted too (``--controllers fl nmpc``); an
    empty item is a one-line :class:`UserError`.
    """
    items = [x.strip() for v in (values or []) for x in str(v).split(",")]
    if any(not x for x in items):
        raise UserError(f"{flag}: empty item in {','.join(values or [])!r}; give a comma-separated list, e.g. a,b")
    return items


def _version() -> str:
    """The installed package's version (``maglev --version``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("maglev-ocp")
    except PackageNotFoundError:  # pragma: no cover - run from a source tree without install
        return "unknown (not installed)"


_SHOWN: set[str] = set()


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings from the library as one line on stderr (``maglev: warning: ...``), not Python's two lines;
    each text once per process (a file loaded twice warns once)."""
    text = one_line(f"maglev: warning: {message}")
    if text not in _SHOWN:
        _SHOWN.add(text)
        _say(text)


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every discovered subcommand."""
    parser = OneLineParser(
        prog="maglev",
        description=(
            "maglev-ocp: model, simulate, identify, control and diagnose the 2-DOF PMLSM magnetic levitation stage."
        ),
        epilog=EPILOG,
        formatter_class=_Formatter,
    )
    parser.add_argument("--version", action="version", version=f"maglev {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    pkg_dir = os.path.dirname(__file__)
    for info in sorted(pkgutil.iter_modules([pkg_dir]), key=lambda i: i.name):
        if info.name.startswith("cmd_"):
            mod = importlib.import_module(f"{__name__}.{info.name}")
            mod.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``maglev`` console script.

    Every failure ends here as one line on stderr: bad input (a
    :class:`~maglev_ocp.errors.UserError`, an unreadable or unwritable path, a
    file nested too deeply, a resource limit) exits 2, an interrupt (SIGINT)
    exits 130, and anything unforeseen exits 1 with ``internal error`` (set
    ``MAGLEV_DEBUG=1`` to see its traceback). Never a traceback otherwise.
    """
    command = "maglev"
    interrupts: list[int] = []
    previous = _catch_sigint(interrupts)
    shown = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        parser = build_parser()
        old = _old_form(list(sys.argv[1:] if argv is None else argv))
        if old:
            command = "maglev diagnose"
            raise UserError(old)
        args = parser.parse_args(argv)
        if not getattr(args, "handler", None):
            parser.print_help()
            return 2
        command = f"maglev {args.command}" + (f" {args.mode}" if getattr(args, "mode", None) else "")
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        _say(f"{command}: interrupted")
        return 130
    except BaseException as err:
        if isinstance(err, SystemExit) or os.environ.get("MAGLEV_DEBUG"):
            raise
        if interrupts:  # a library turned the KeyboardInterrupt into another error (seen in matplotlib)
            _say(f"{command}: interrupted")
            return 130
        text, code = describe_failure(err)
        _say(f"{command}: {text}")
        return code
    finally:
        warnings.showwarning = shown
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _old_form(argv: list[str]) -> str | None:
    """A command line of a form that changed (``maglev diagnose --selftest N``): what to write instead."""
    from .cmd_diagnose import old_form_error

    return old_form_error(argv)


def _catch_sigint(interrupts: list[int]):
    """Note every SIGINT in ``interrupts`` (then raise KeyboardInterrupt as usual); returns the previous handler.

    Only in the main thread and only where SIGINT has Python's default handler;
    ``None`` where nothing was installed.
    """
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.default_int_handler:
        return None

    def _handler(signum, frame):
        interrupts.append(signum)
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, _handler)
    return previous


def describe_failure(err: BaseException) -> tuple[str, int]:
    """One-line text and exit code of a failure (see :func:`main`)."""
    if isinstance(err, UserError):
        return f"error: {err}", err.exit_code
    if isinstance(err, RecursionError):
        return "error: input nested too deeply (recursion limit)", 2
    if isinstance(err, MemoryError):
        return "error: out of memory (input too large)", 2
    if isinstance(err, BrokenPipeError):
        return "error: output pipe closed", 2
    if isinstance(err, OSError):
        where = f"{err.filename}: " if err.filename else ""
        return one_line(f"error: {where}{err.strerror or err}"), 2
    if isinstance(err, (ValueError, OverflowError)):
        return one_line(f"error: {err or type(err).__name__}"), 2
    return one_line(f"internal error: {type(err).__name__}: {err} (MAGLEV_DEBUG=1 shows the traceback)"), 1


def _say(line: str) -> None:
    """Print one line on stderr, whatever state stdout/stderr are in."""
    try:
        sys.stdout.flush()
    except Exception:
        pass
    try:
        print(line, file=sys.stderr, flush=True)
    except Exception:
        pass


def check_range(flag: str, v: float, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> None:
    """A command-line number must be finite and in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``); one-line UserError."""
    u = f" {unit}" if unit else ""
    if math.isnan(v):
        raise UserError(f"{flag}: NaN is not allowed; give a number in {lo:g}..{hi:g}{u}")
    if not (math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi):
        raise UserError(f"{flag}: {v:g}{u} is outside {'(' if lo_open else ''}{lo:g}..{hi:g}{u}")


#: Bounds of the counts the commands take (every count and duration a user gives is bounded).
MAX_SEED: int = 2**63 - 1
MAX_WORKERS: int = 256
MAX_WARMUP_STEPS: int = 10_000
MAX_SELFTEST_DATASETS: int = 1000
MAX_CAMPAIGN_LIMIT: int = 1_000_000


def check_count(flag: str, v: int, lo: int, hi: int) -> None:
    """A whole-number flag must be in ``lo..hi``; one-line UserError otherwise."""
    if not lo <= v <= hi:
        raise UserError(f"{flag}: {v} is outside {lo}..{hi}")


def load_model_params(path: str | os.PathLike):
    """A parameter file the model can run on: its keys validated, and a real, finite hover current
    (seed eq. (8)) at every gap of the envelope (one-line error naming the keys otherwise)."""
    from ..params import load_params
    from ..plant.config import check_hover_envelope

    params = load_params(path)
    check_hover_envelope(params, str(path))
    return params


def add_command(sub, name: str, help: str, description: str, example: str) -> argparse.ArgumentParser:
    """Add a subcommand whose ``--help`` shows what it does and an example."""
    return sub.add_parser(
        name,
        help=help,
        description=description,
        epilog=f"example:\n  {example}",
        formatter_class=_Formatter,
    )


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
