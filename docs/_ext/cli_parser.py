"""The ``maglev`` parser for sphinx-argparse, its texts made safe to read as reStructuredText.

The command's descriptions and epilogs are preformatted for a terminal
(``RawDescriptionHelpFormatter``): they are shown as literal blocks, exactly as
``maglev COMMAND --help`` prints them. Help strings are plain text: the
characters reST would read as markup (``|x|`` substitutions, ``*`` emphasis,
backquotes, a trailing ``_``) are escaped. The grammar itself comes unchanged
from :func:`maglev_ocp.cli.build_parser`.
"""

from __future__ import annotations

import argparse
import re
import textwrap

from maglev_ocp.cli import build_parser as _build_parser


def _literal(text: str | None) -> str | None:
    """A preformatted text as a reST literal block (``None`` stays ``None``)."""
    if not text or not text.strip():
        return text
    return "::\n\n" + textwrap.indent(textwrap.dedent(text).strip("\n"), "    ") + "\n"


def _escape(text: str | None) -> str | None:
    """Plain text with reST's inline markup characters escaped."""
    if not text:
        return text
    text = text.replace("\\", "\\\\")
    for ch in "|*`":
        text = text.replace(ch, "\\" + ch)
    return re.sub(r"(\w)_(?=\W|$)", r"\1\\_", text)


def _clean(parser: argparse.ArgumentParser) -> None:
    """Make every text of ``parser`` and its subcommands safe (in place)."""
    parser.description = _literal(parser.description)
    parser.epilog = _literal(parser.epilog)
    for action in parser._actions:
        if action.help and action.help != argparse.SUPPRESS:
            action.help = _escape(action.help)
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = _escape(choice.help)
            for sub in action.choices.values():
                _clean(sub)


def build_parser() -> argparse.ArgumentParser:
    """:func:`maglev_ocp.cli.build_parser` with its texts made safe for reST."""
    parser = _build_parser()
    _clean(parser)
    return parser
