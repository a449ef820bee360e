"""Reading a file of another code: CSV or Parquet, bounded before anything is allocated.

A Parquet file's row and column counts come from its footer (metadata), a CSV file's from
its header line and one pass counting lines; a file over :data:`MAX_BYTES`, more than
:data:`MAX_COLUMNS` columns or more than :data:`MAX_CELLS` values is refused before it is
parsed. A CSV file is UTF-8 (a byte-order mark is allowed) or UTF-16 with its byte-order
mark; its columns are separated by commas — a header separated by ';' or tabs is refused
with the fix, and a column named twice is named as such (pandas would rename the second
'x.1').
"""

from __future__ import annotations

import codecs
import csv
import os
import stat
from collections import Counter
from pathlib import Path
from typing import Any

import pandas as pd

from daebench.harness.scoring.external.records import ExternalDataError, clip

#: the largest file read [bytes]; a larger one is refused before it is opened
MAX_BYTES = 512 * 2 ** 20
#: the most columns and values (rows × columns) read; more is refused before parsing
MAX_COLUMNS = 2000
MAX_CELLS = 50_000_000
#: file suffixes read, and the format each names
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
PARQUET_MAGIC = b"PAR1"
_BOMS = ((codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))

#: read CSV numbers exactly: pandas 3 does by default (and deprecates the option), pandas 2 when asked
_EXACT_CSV = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


def _format_of(path: Path, what: str) -> tuple[str, str]:
    """('csv' or 'parquet', the text encoding of a CSV file) from the file's suffix and first
    bytes; refused otherwise."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ExternalDataError(f"{what} '{path}' cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ExternalDataError(f"{what} '{path}' is not a regular file; give a .csv or .parquet file")
    if st.st_size > MAX_BYTES:
        raise ExternalDataError(f"{what} '{path}' is {st.st_size / 2 ** 20:.0f} MiB, more than the "
                                f"{MAX_BYTES / 2 ** 20:.0f} MiB read; write fewer output times (the case's "
                                f"output.dt is enough) or only the observables scored")
    fmt = SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise ExternalDataError(f"{what} '{path}' is neither CSV nor Parquet (suffix {clip(path.suffix)}); write a "
                                f".csv or .parquet file, e.g. pandas' df.to_csv(path, index=False)")
    with open(path, "rb") as fh:
        head = fh.read(4096)
    is_parquet = head.startswith(PARQUET_MAGIC)
    if fmt == "parquet" and not is_parquet:
        raise ExternalDataError(f"{what} '{path}' is named {path.suffix} but is not a Parquet file")
    encoding = next((enc for bom, enc in _BOMS if head.startswith(bom)), "utf-8")
    if fmt == "csv" and (is_parquet or (encoding == "utf-8" and b"\x00" in head)):
        utf16 = not is_parquet and head[1:2] == b"\x00" or head[:1] == b"\x00"
        raise ExternalDataError(f"{what} '{path}' is named .csv but is not a text file"
                                + (" (it is a Parquet file: name it .parquet)" if is_parquet else
                                   " (it looks like UTF-16 text without a byte-order mark: save it as UTF-8)"
                                   if utf16 else ""))
    return fmt, encoding


def csv_metadata(lines: list[str]) -> dict[str, str]:
    """``# key: value`` lines at the top of a CSV file (other comment lines are skipped)."""
    meta: dict[str, str] = {}
    for line in lines:
        if not line.startswith("#"):
            break
        key, sep, value = line[1:].partition(":")
        if sep and key.strip():
            meta[key.strip()] = value.strip()
    return meta


def _header(lines: list[str], path: Path, what: str) -> list[str]:
    """The column names of a CSV file (its first line that is not a comment), checked: commas
    as separators, at most :data:`MAX_COLUMNS`, none named twice."""
    line = next((ln for ln in lines if ln.strip() and not ln.startswith("#")), None)
    if line is None:
        raise ExternalDataError(f"{what} '{path}' holds no header line (the column names, e.g. t,theta_deg)")
    names = [c.strip() for c in next(csv.reader([line]))]
    if len(names) == 1:
        for sep, name in ((";", "semicolons"), ("\t", "tabs")):
            if sep in line:
                raise ExternalDataError(f"{what} '{path}': its columns are separated by {name} (header "
                                        f"{clip(line.strip())}); write them separated by commas, with '.' as the "
                                        f"decimal point (pandas: df.to_csv(path, index=False))")
    if len(names) > MAX_COLUMNS:
        raise ExternalDataError(f"{what} '{path}' has {len(names)} columns, more than the {MAX_COLUMNS} read; write "
                                f"t and the case's observables only (`daebench show CASE`)")
    twice = [c for c, n in Counter(names).items() if n > 1]
    if twice:
        raise ExternalDataError(f"{what} '{path}' has the column {clip(twice[0])} twice; keep one")
    return names


def _check_cells(rows: int, columns: int, path: Path, what: str) -> None:
    if columns > MAX_COLUMNS:
        raise ExternalDataError(f"{what} '{path}' has {columns} columns, more than the {MAX_COLUMNS} read; write "
                                f"t and the case's observables only (`daebench show CASE`)")
    if rows * columns > MAX_CELLS:
        raise ExternalDataError(f"{what} '{path}' holds {rows} rows × {columns} columns, more than the "
                                f"{MAX_CELLS:.0e} values read; write the case's output times only (its output.dt)")


def _lines_count(path: Path) -> int:
    """An upper bound of the lines of a file, by one pass over its bytes (no text is kept)."""
    n = 0
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 22):
            n += chunk.count(b"\n")
    return n + 1


def _read_csv(path: Path, encoding: str, what: str) -> tuple[pd.DataFrame, dict[str, Any]]:
    head: list[str] = []
    try:
        with open(path, encoding=encoding, newline="") as fh:
            for line in fh:   # the comment lines and the header only
                head.append(line.rstrip("\r\n"))
                if line.strip() and not line.startswith("#"):
                    break
    except UnicodeDecodeError as exc:
        raise ExternalDataError(f"{what} '{path}' is not {encoding.upper()} text ({exc.reason} at byte {exc.start}); "
                                f"save it as UTF-8") from None
    names = _header(head, path, what)
    _check_cells(_lines_count(path) - len(head), len(names), path, what)
    df = pd.read_csv(path, comment="#", skipinitialspace=True, encoding=encoding, **_EXACT_CSV)
    return df, csv_metadata(head)


def _read_parquet(path: Path, what: str) -> tuple[pd.DataFrame, dict[str, Any]]:
    import pyarrow.parquet as pq  # lazy: only a Parquet file needs it

    pf = pq.ParquetFile(path)
    _check_cells(int(pf.metadata.num_rows), int(pf.metadata.num_columns), path, what)
    names = list(pf.schema_arrow.names)
    twice = [c for c, n in Counter(names).items() if n > 1]
    if twice:
        raise ExternalDataError(f"{what} '{path}' has the column {clip(twice[0])} twice; keep one")
    raw = pf.schema_arrow.metadata or {}
    meta = {k.decode(errors="replace"): v.decode(errors="replace") for k, v in raw.items()
            if not k.startswith(b"pandas") and not k.startswith(b"ARROW")}
    return pf.read().to_pandas(), meta


def read_table(data: str | os.PathLike | pd.DataFrame, what: str = "the data file"
               ) -> tuple[pd.DataFrame, dict[str, Any], str]:
    """(table, metadata, source) of a path to a CSV or Parquet file, or of a DataFrame
    (metadata: its ``attrs``). CSV numbers are read exactly (round trip); every bound of the
    module docstring is checked before the values are parsed.

    Raises
    ------
    ExternalDataError
        Not a regular file, not CSV/Parquet, over a bound, unreadable.
    """
    if isinstance(data, pd.DataFrame):
        _check_cells(len(data), len(data.columns), Path("DataFrame"), what)
        return data.copy(), dict(data.attrs), "DataFrame"
    if not isinstance(data, (str, os.PathLike)) or not str(data).strip():
        raise ExternalDataError(f"{what} must be a path to a .csv or .parquet file or a pandas DataFrame; "
                                f"got {clip(data)}")
    path = Path(data)
    fmt, encoding = _format_of(path, what)
    try:
        df, meta = _read_csv(path, encoding, what) if fmt == "csv" else _read_parquet(path, what)
    except ExternalDataError:
        raise
    except (ValueError, OSError, pd.errors.ParserError) as exc:
        raise ExternalDataError(f"{what} '{path}' cannot be read as {fmt.upper()}: {clip(str(exc), 300)}") from None
    except Exception as exc:  # pyarrow's own errors for a damaged file
        raise ExternalDataError(f"{what} '{path}' cannot be read as {fmt.upper()}: "
                                f"{type(exc).__name__}: {clip(str(exc), 300)}") from None
    return df, meta, str(path)
