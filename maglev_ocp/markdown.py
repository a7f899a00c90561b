"""Markdown tables: one writer, so every table the suite writes is well-formed.

A table is well-formed when its header, its separator and every row have the
same number of cells; :func:`md_table` checks that and escapes ``|`` inside
cells, and :func:`parse_md_tables` reads the tables of a Markdown text back
(the tests parse every ``.md`` the main job writes with it).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def _cell(v: object) -> str:
    """One cell: text with ``|`` escaped and line breaks as spaces."""
    return str(v).replace("|", "\\|").replace("\n", " ").strip()


def md_table(header: Sequence[object], rows: Iterable[Sequence[object]], align: Sequence[str] | None = None) -> str:
    """A Markdown table (no trailing newline).

    Parameters
    ----------
    header : sequence
        Column titles (units in brackets, e.g. ``"error [µm]"``).
    rows : iterable of sequences
        The rows; each must have as many cells as ``header``.
    align : sequence of str, optional
        Per column ``"l"``, ``"r"``, ``"c"`` or ``""`` (default: none).

    Raises
    ------
    ValueError
        A row whose cell count differs from the header's (a bug in the caller).
    """
    n = len(header)
    if n == 0:
        raise ValueError("a Markdown table needs at least one column")
    marks = {"": "---", "l": ":---", "r": "---:", "c": ":---:"}
    seps = [marks[a] for a in (align or [""] * n)]
    if len(seps) != n:
        raise ValueError(f"align has {len(seps)} entries for {n} columns")
    lines = ["| " + " | ".join(_cell(h) for h in header) + " |", "|" + "|".join(seps) + "|"]
    for i, row in enumerate(rows):
        cells = list(row)
        if len(cells) != n:
            raise ValueError(f"Markdown table row {i + 1} has {len(cells)} cells, the header {n}")
        lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    return "\n".join(lines)


def split_row(line: str) -> list[str]:
    """Cells of one table line (``| a | b |`` -> ``["a", "b"]``); an escaped ``\\|`` stays in its cell."""
    s = line.strip()
    if s.startswith("|"):
        s = s[1:]
    if s.endswith("|") and not s.endswith("\\|"):
        s = s[:-1]
    cells, cur, i = [], "", 0
    while i < len(s):
        if s[i] == "\\" and i + 1 < len(s) and s[i + 1] == "|":
            cur += "\\|"
            i += 2
            continue
        if s[i] == "|":
            cells.append(cur.strip())
            cur = ""
        else:
            cur += s[i]
        i += 1
    cells.append(cur.strip())
    return cells


def _is_separator(line: str) -> bool:
    cells = split_row(line)
    return bool(cells) and all(c and set(c) <= set(":-") and "-" in c for c in cells)


def parse_md_tables(text: str) -> list[list[list[str]]]:
    """Every table of a Markdown text as ``[header, separator, *rows]`` lists of cells.

    A table starts at a ``|`` line followed by a separator line; it runs over
    the consecutive ``|`` lines after it (fenced code blocks are skipped).
    """
    tables, lines, i, fenced = [], text.splitlines(), 0, False
    while i < len(lines):
        line = lines[i]
        if line.strip().startswith("```"):
            fenced = not fenced
        if (
            not fenced
            and line.strip().startswith("|")
            and i + 1 < len(lines)
            and lines[i + 1].strip().startswith("|")
            and _is_separator(lines[i + 1])
        ):
            block = [split_row(line), split_row(lines[i + 1])]
            i += 2
            while i < len(lines) and lines[i].strip().startswith("|"):
                block.append(split_row(lines[i]))
                i += 1
            tables.append(block)
            continue
        i += 1
    return tables


def malformed_tables(text: str) -> list[str]:
    """One description per table whose header, separator and rows differ in cell count (empty: all well-formed)."""
    out = []
    for t, block in enumerate(parse_md_tables(text)):
        n = len(block[0])
        for j, row in enumerate(block[1:], start=1):
            if len(row) != n:
                what = "separator" if j == 1 else f"row {j - 1}"
                out.append(f"table {t + 1} ({' | '.join(block[0])[:60]}): {what} has {len(row)} cells, header {n}")
    return out


__all__ = ["malformed_tables", "md_table", "parse_md_tables", "split_row"]
