"""Where results go and how a file is written so that no reader sees half of it.

:func:`results_dir` is the one root of everything daebench writes (``$DAEBENCH_RESULTS``
or ./results). :func:`ensure_writable_dir` proves a folder writable before any work, so a
run never finishes only to fail when it writes; :func:`atomic_write` writes through a
temporary file and ``os.replace``, and a failure becomes :class:`OutputWriteError`, whose
message names the file, the cause and what was kept. :func:`jsonable` is the one rule
for values written as JSON.
"""

from __future__ import annotations

import errno
import json
import math
import os
import secrets
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from daebench.core.bounded_file import UnreadableFile, read_bounded
from daebench.core.params import ParamError


def results_dir() -> Path:
    """Where runs write: $DAEBENCH_RESULTS or ./results."""
    return Path(os.environ.get("DAEBENCH_RESULTS", "results"))


class OutputError(ParamError):
    """An output folder or file name that cannot be used, refused before any work; the
    message says what to change."""


class OutputWriteError(OutputError):
    """A result that was computed but could not be written (full disk, a folder removed
    or made read-only meanwhile); the message says what was kept and what to do. The
    command line exits 1 (the work ran; its input was fine). ``result``: what was computed
    (a run's :class:`~daebench.driver.simulate.RunResult`, a comparison's result), None when
    nothing was — the caller that catches the error still has the work."""

    result: Any = None


def ensure_writable_dir(path: str | Path, what: str = "output folder", longest_name: str = "") -> Path:
    """Create ``path`` if needed and prove it writable (a file is made and removed), so
    that a run never finishes only to fail when it writes. ``longest_name``: the longest
    file name that will be written there, checked against the file system's limit."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise OutputError(f"{what} must be a folder path (a string), e.g. results/runs; got {path!r}")
    p = Path(path)
    try:
        if p.exists() and not p.is_dir():
            raise OutputError(f"{what} '{p}' is a file, not a folder; give a folder (it is created if missing)")
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=p, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise OutputError(f"cannot write to {what} '{str(p)[:120]}{'…' if len(str(p)) > 120 else ''}': "
                         f"{describe_os_error(exc)}; choose a writable folder (--out, or the DAEBENCH_RESULTS "
                         f"environment variable)") from None
    if longest_name:
        check_name_fits(p, longest_name, what)
    return p


def check_name_fits(folder: Path, name: str, what: str = "output folder") -> None:
    """Refuse, before any work, a file name longer than ``folder``'s file system takes."""
    try:
        limit = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    n = len(os.fsencode(name))
    if n > limit:
        raise OutputError(f"the file name {name[:40]!r}… would be {n} bytes, more than the {limit} the file system "
                         f"of {what} '{folder}' takes; use a shorter scene name (--set name=short) or --name")


def describe_os_error(exc: BaseException) -> str:
    """'the disk is full (No space left on device)' and the like, for messages."""
    code = getattr(exc, "errno", None)
    text = getattr(exc, "strerror", None) or str(exc)
    if code in (errno.ENOSPC, errno.EDQUOT) or "disk is full" in str(exc) or "No space left" in str(exc):
        return f"the disk is full ({text})"
    if code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return f"it is not writable ({text})"
    if code == errno.ENAMETOOLONG:
        return f"the name is too long for the file system ({text})"
    return f"{type(exc).__name__}: {text}"


#: characters of a temporary file's name beyond ``.<name>.`` and ``.tmp`` (as many as a pid had: the
#: name-length checks that count ``.<name>.9999999.tmp`` hold)
TEMP_TAG_CHARS = 7
_TAG_ALPHABET = "0123456789abcdefghijklmnopqrstuvwxyz"


def temp_beside(path: Path) -> Path:
    """A new, empty temporary file beside ``path`` (``.<name>.<tag>.tmp``), created with
    ``O_EXCL``: unique per process, thread and call, so two writers of one target (threads
    of one process included) never share it.

    Raises
    ------
    OSError
        When the folder cannot take it.
    """
    for _ in range(100):
        tag = "".join(secrets.choice(_TAG_ALPHABET) for _ in range(TEMP_TAG_CHARS))
        tmp = path.with_name(f".{path.name}.{tag}.tmp")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name after 100 tries", str(path))


def atomic_write(path: Path, write: Callable[[Path], Any], what: str, kept: str = "") -> None:
    """Write ``path`` through a temporary file of its own beside it (:func:`temp_beside`;
    ``write(tmp)``, then ``os.replace``): a reader sees the old file or the new one, and of
    concurrent writers of one target the last one's whole file stays. A failure removes
    the temporary file and raises :class:`OutputWriteError` naming the file, the cause and
    ``kept`` (what is safe)."""
    tmp = None
    try:
        tmp = temp_beside(path)
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise write_error(exc, what, path, kept, tmp, folder=path.parent) from None
    except BaseException:   # a writer's own exception (or Ctrl-C): no temporary file is left behind
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise


def _missing(exc: BaseException, folder: Path, tmp: Path | None) -> str | None:
    """For a 'No such file or directory' while writing: what was missing, in words (the
    folder removed meanwhile, or the temporary file removed by someone else)."""
    if getattr(exc, "errno", None) != errno.ENOENT:
        return None
    if not folder.is_dir():
        return f"the folder {folder} no longer exists (removed while daebench wrote there)"
    if tmp is not None:
        return (f"its temporary file {tmp.name} was removed before it could be moved into place (by another "
                f"process cleaning {folder}?)")
    return None


def write_error(exc: BaseException, what: str, path: Path | str, kept: str = "",
                tmp: Path | None = None, folder: Path | None = None) -> OutputWriteError:
    """The :class:`OutputWriteError` of a failed write (the temporary file ``tmp`` removed),
    naming the cause: a full disk, a folder that is not writable or was removed meanwhile,
    a temporary file removed by someone else, else the system's own words. ``folder``:
    where it was written (default: ``path`` itself, a folder)."""
    missing = _missing(exc, Path(folder) if folder is not None else Path(path), tmp)
    if tmp is not None:
        try:
            os.unlink(tmp)
        except OSError:
            pass
    why = missing or describe_os_error(exc)
    fix = "Free space there" if why.startswith("the disk is full") else (
        "Make it writable" if why.startswith("it is not writable") else
        "Leave the folder and its files alone while daebench writes" if missing else "Mend that")
    return OutputWriteError(f"could not write {what} {path}: {why}. "
                            + (f"{kept[0].upper()}{kept[1:]}. " if kept else "")
                            + f"{fix} or choose another folder (--out, or DAEBENCH_RESULTS), "
                              "then run again; this is not a fault of the integrator")


def jsonable(x: Any) -> Any:
    """``x`` with numpy scalars as Python numbers and non-finite floats as None (JSON has no NaN)."""
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


class DamagedFile(ValueError):
    """A file daebench wrote earlier (a sidecar, a table) that cannot be read back as what it
    should be; the message says which file and what is wrong with it."""


#: the largest JSON file daebench reads back (sidecars and summaries are kilobytes to megabytes)
MAX_JSON_BYTES = 64 << 20


def read_json(path: str | Path, what: str = "the file", max_bytes: int = MAX_JSON_BYTES) -> Any:
    """The JSON value in ``path``, read safely: a regular file of at most ``max_bytes``
    (its size read with ``stat`` before a byte is read), UTF-8, and parsed with every way
    a hostile or damaged file breaks the parser (nesting thousands deep, an integer of
    thousands of digits, invalid text) turned into :class:`DamagedFile`.

    Raises
    ------
    DamagedFile
    """
    p = Path(path)
    try:
        data = read_bounded(p, max_bytes)
    except UnreadableFile as exc:
        raise DamagedFile(f"{what} {p} {exc}") from None
    return parse_json(data, f"{what} {p}")


def parse_json(data: str | bytes, what: str = "the JSON text") -> Any:
    """``json.loads`` with its hostile failures (deep nesting: RecursionError; huge
    numbers: ValueError, OverflowError; bad bytes) as :class:`DamagedFile`."""
    try:
        text = data.decode("utf-8") if isinstance(data, bytes) else data
        return json.loads(text)
    except UnicodeDecodeError:
        raise DamagedFile(f"{what} is not UTF-8 text") from None
    except RecursionError:
        raise DamagedFile(f"{what} is nested too deeply to be what daebench wrote") from None
    except (ValueError, OverflowError) as exc:  # JSONDecodeError is a ValueError; so is a 5000-digit number
        raise DamagedFile(f"{what} is not valid JSON ({type(exc).__name__}: {str(exc)[:120]})") from None


def under_root(root: str | Path, *names: str, what: str = "output file") -> Path:
    """The one rule for a path written under an output root: ``root/names[0]/…/names[-1]``
    where every name is a plain file name (no separator, no '..', not absolute, not
    empty), checked at the moment of writing so that a name changed after it was first
    validated cannot lead outside ``root``.

    Raises
    ------
    OutputError
    """
    base = Path(root)
    for n in names:
        s = str(n)
        if (not s or s in (".", "..") or "/" in s or "\\" in s or "\x00" in s
                or os.path.isabs(s) or s != os.path.basename(s)):
            raise OutputError(f"{what} name {s[:60]!r} is not a plain file name (a path, '..' or empty); names are "
                              f"written under the output folder {base} only: give a plain name, e.g. my-run")
    return base.joinpath(*map(str, names))
