"""The one Markdown table writer: every table in a report the package writes comes from here.

The delimiter row is built from the header, and every body row must have as many cells, so a
table always renders (GitHub-flavoured Markdown drops a table whose delimiter row has another
cell count than its header). ``|`` inside a cell is escaped.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["table", "parse_tables"]


def _cell(x: object) -> str:
    return str(x).replace("\n", " ").replace("|", "\\|").strip()


def table(header: Sequence[str], rows: Sequence[Sequence[object]], align: str = "") -> list[str]:
    """A Markdown table as lines: header, delimiter, one line per row.

    Parameters
    ----------
    header : sequence of str
        The column titles.
    rows : sequence of sequences
        One sequence of cells (``str()`` of each) per row, each as long as ``header``.
    align : str, default ``''``
        One letter per column: ``l`` (left), ``r`` (right), ``c`` (centre); a shorter string
        leaves the remaining columns left-aligned except the first, and an empty one aligns
        the first column left and the others right (numbers).

    Raises
    ------
    ValueError
        A row or ``align`` with more or fewer cells than ``header``.
    """
    n = len(header)
    if not align:
        align = "l" + "r" * (n - 1)
    if len(align) > n:
        raise ValueError(f"align {align!r} has {len(align)} columns for {n} header cells")
    align = align + "l" * (n - len(align))
    marks = {"l": "---", "r": "---:", "c": ":---:"}
    out = ["| " + " | ".join(_cell(h) for h in header) + " |"]
    out.append("|" + "|".join(marks[a] for a in align) + "|")
    for i, row in enumerate(rows):
        if len(row) != n:
            raise ValueError(f"row {i} has {len(row)} cells for {n} header cells")
        out.append("| " + " | ".join(_cell(c) for c in row) + " |")
    return out


def _split(line: str) -> list[str]:
    """The cells of one table line (outer pipes stripped, ``\\|`` kept inside a cell)."""
    s = line.strip()
    s = s[1:] if s.startswith("|") else s
    s = s[:-1] if s.endswith("|") and not s.endswith("\\|") else s
    cells, cur, i = [], "", 0
    while i < len(s):
        if s[i] == "\\" and i + 1 < len(s) and s[i + 1] == "|":
            cur += "|"
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


def parse_tables(text: str) -> list[list[list[str]]]:
    """Every pipe table in ``text``: a list of tables, each a list of rows of cells (the
    header first, the delimiter row left out).

    Raises
    ------
    ValueError
        A table whose delimiter row or a body row has another number of cells than its
        header, or a header not followed by a delimiter row.
    """
    tables: list[list[list[str]]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if not lines[i].lstrip().startswith("|"):
            i += 1
            continue
        header = _split(lines[i])
        if i + 1 >= len(lines) or not lines[i + 1].lstrip().startswith("|"):
            raise ValueError(f"line {i + 1}: a table row without a delimiter row")
        delim = _split(lines[i + 1])
        if not all(c and set(c) <= set(":-") and "-" in c for c in delim):
            raise ValueError(f"line {i + 2}: not a delimiter row: {lines[i + 1]!r}")
        if len(delim) != len(header):
            raise ValueError(
                f"line {i + 2}: {len(delim)} delimiter cells for {len(header)} header cells"
            )
        rows = [header]
        j = i + 2
        while j < len(lines) and lines[j].lstrip().startswith("|"):
            row = _split(lines[j])
            if len(row) != len(header):
                raise ValueError(f"line {j + 1}: {len(row)} cells for {len(header)} header cells")
            rows.append(row)
            j += 1
        tables.append(rows)
        i = j
    return tables
