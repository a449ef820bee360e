"""Reading a file that may be hostile or damaged: a regular file only, its size read with
``stat`` before a byte is read, never more than a bound read. One rule for every file
daebench reads back or is given (scene files, sidecars, summaries); each caller says in its
own error type which file it was and how to fix it."""

from __future__ import annotations

import os
import stat
from pathlib import Path


class UnreadableFile(OSError):
    """The file is not a regular file, is larger than its bound, or cannot be read; the
    message is the reason, without the path (the caller names the file)."""


def read_bounded(path: str | Path, max_bytes: int) -> bytes:
    """The bytes of ``path``, a regular file of at most ``max_bytes``.

    Raises
    ------
    UnreadableFile
        a device, pipe, socket or folder; more than ``max_bytes`` bytes; an OS error.
    """
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise UnreadableFile("is not a regular file (a device, pipe, socket or folder)")
        if st.st_size > max_bytes:
            raise UnreadableFile(f"is {st.st_size} bytes, more than such a file can plausibly be ({max_bytes} bytes)")
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except UnreadableFile:
        raise
    except OSError as exc:
        raise UnreadableFile(f"cannot be read: {exc.strerror or exc}") from None
    if len(data) > max_bytes:  # grew between stat and read
        raise UnreadableFile(f"is more than such a file can plausibly be ({max_bytes} bytes)")
    return data
