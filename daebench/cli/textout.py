"""Plain-text tables and summaries that never break a number or cut a column.

A table that fits the width is printed as aligned columns; one that does not is printed
as one record per row, ``name value`` pairs wrapped between pairs (never inside one).
The width is the terminal's, or ``COLUMNS``, or 80 when output goes to a pipe.
"""

from __future__ import annotations

import io
import math
import os
import re
import shutil
import sys
import textwrap
from typing import Any, Sequence

from rich import box
from rich.console import Console
from rich.table import Table

GAP = "  "
MIN_LAST = 24   # a prose last column narrower than this: record layout instead


def width() -> int:
    """Columns available: $COLUMNS, the terminal's, or 80 (a pipe)."""
    env = os.environ.get("COLUMNS", "")
    if env.isdigit() and int(env) > 0:
        return int(env)
    if sys.stdout.isatty():
        return shutil.get_terminal_size((80, 24)).columns
    return 80


def fmt(v: Any, digits: int = 3) -> str:
    """A cell: floats with ``digits`` significant digits, NaN as '-', others as str."""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.{digits}g}"
    if v is None:
        return "-"
    return str(v)


def table_lines(columns: Sequence[str], rows: Sequence[Sequence[Any]], max_width: int | None = None,
                title: str = "") -> list[str]:
    """Lines of a table that fits ``max_width`` (default :func:`width`)."""
    w = max_width or width()
    cells = [[fmt(v) for v in r] for r in rows]
    widths = [max([len(c)] + [len(r[i]) for r in cells]) for i, c in enumerate(columns)]
    out = [title] if title else []
    lead = sum(widths[:-1]) + len(GAP) * (len(widths) - 1)
    if lead + widths[-1] <= w or (w - lead >= MIN_LAST and all(" " in r[-1] or len(r[-1]) <= w - lead
                                                                for r in cells)):
        # columns; a last column of prose too wide for the line wraps between words
        last = min(widths[-1], w - lead)
        widths[-1] = last
        out.append(GAP.join(c.ljust(widths[i]) for i, c in enumerate(columns)).rstrip())
        out.append(GAP.join("-" * widths[i] for i in range(len(columns))))
        for r in cells:
            tail = textwrap.wrap(r[-1], last, break_long_words=False, break_on_hyphens=False) or [""]
            out.append(GAP.join([r[i].ljust(widths[i]) for i in range(len(columns) - 1)] + [tail[0]]).rstrip())
            out += [" " * lead + t for t in tail[1:]]
        return out
    for r in cells:  # record layout: "name value" pairs, wrapped between pairs (prose between words)
        tokens: list[str] = []
        for c, v in zip(columns, r):
            pair = f"{c} {v}"
            tokens += textwrap.wrap(pair, w - 3, break_long_words=False, break_on_hyphens=False) \
                if len(pair) > w - 3 else [pair]
        line = ""
        for tok in tokens:
            if line and len(line) + len(GAP) + len(tok) > w:
                out.append(line)
                line = "   " + tok
            else:
                line = f"{line}{GAP}{tok}" if line else tok
        out.append(line)
    return out


def kv_lines(pairs: Sequence[tuple[str, str]], max_width: int | None = None) -> list[str]:
    """'label: value' lines, one per pair; a value that does not fit after its label goes
    on indented lines of its own, wrapped between words (a number is never split)."""
    w = max_width or width()
    out = []
    for k, v in pairs:
        line = f"{k}: {v}"
        if len(line) <= w:
            out.append(line)
        else:
            out.append(f"{k}:")
            out += textwrap.wrap(str(v), w, initial_indent="    ", subsequent_indent="    ",
                                 break_long_words=False, break_on_hyphens=False)
    return out


def rich_lines(columns: Sequence[str], rows: Sequence[Sequence[Any]], prose: dict[str, int] | None = None,
               max_width: int | None = None) -> list[str]:
    """A table drawn by rich as plain text (the same on a terminal and in a pipe): one
    line per row, a header of several lines where a column's name has ``\\n``. Cells never
    wrap except in the ``prose`` columns ({column: its narrowest width}), which wrap
    between words; every other column is as wide as its widest cell, so a number is never
    split or cut, and a row that does not fit the width (:func:`width`) runs on rather
    than breaking."""
    prose = dict(prose or {})
    cells = [[_short_exp(fmt(v)) for v in r] for r in rows]
    t = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, padding=0, expand=bool(prose))
    fixed = 0
    last = list(prose)[-1] if prose else None
    for i, c in enumerate(columns):
        numeric = any(isinstance(r[i], (int, float)) and not isinstance(r[i], bool) for r in rows)
        if c == last:      # the last prose column takes what the line has left
            t.add_column(c, justify="left", min_width=prose[c], ratio=1, overflow="fold")
            fixed += prose[c]
        elif c in prose:
            t.add_column(c, justify="left", width=prose[c], overflow="fold")
            fixed += prose[c]
        else:
            w = max([len(x) for x in c.split("\n")] + [len(r[i]) for r in cells])
            t.add_column(c, justify="right" if numeric else "left", no_wrap=True, min_width=w, overflow="ignore")
            fixed += w
    for r in cells:
        t.add_row(*r)
    need = fixed + len(columns) - 1        # one space between columns
    natural = Console(width=10_000, file=io.StringIO(), color_system=None).measure(t).maximum
    w = max(max_width or width(), need) if prose else max(need, natural)
    buf = io.StringIO()
    Console(file=buf, width=w, color_system=None, highlight=False, emoji=False, markup=False,
            soft_wrap=False).print(t)
    return [ln.rstrip() for ln in buf.getvalue().splitlines()]


def _short_exp(text: str) -> str:
    """'1.1e-05' → '1.1e-5' (a narrower cell, the same number)."""
    return re.sub(r"e([+-])0(\d)", r"e\1\2", text)
