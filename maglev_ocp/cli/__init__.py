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
import os
import pkgutil
import sys
from collections.abc import Sequence

from ..errors import UserError

EPILOG = """examples:
  maglev model --gaps 10 15 20 25 --json
  maglev simulate --duration 2 --out data/hover
  maglev <command> --help       (every command explains itself, with an example)
"""


class _Formatter(argparse.RawDescriptionHelpFormatter):
    pass


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every discovered subcommand."""
    parser = argparse.ArgumentParser(
        prog="maglev",
        description=(
            "maglev-ocp: model, simulate, identify, control and diagnose the 2-DOF PMLSM magnetic levitation stage."
        ),
        epilog=EPILOG,
        formatter_class=_Formatter,
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    pkg_dir = os.path.dirname(__file__)
    for info in sorted(pkgutil.iter_modules([pkg_dir]), key=lambda i: i.name):
        if info.name.startswith("cmd_"):
            mod = importlib.import_module(f"{__name__}.{info.name}")
            mod.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``maglev`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    try:
        return int(args.handler(args) or 0)
    except UserError as err:
        print(f"maglev {args.command}: error: {err}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print(f"maglev {args.command}: interrupted", file=sys.stderr)
        return 130


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
