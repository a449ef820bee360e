"""daebench.core.bounded_file: a file read back is a regular file within its bound, or an
UnreadableFile saying why (never a read of a device, a folder or a huge file)."""

from __future__ import annotations

import os

import pytest

from daebench.core.bounded_file import UnreadableFile, read_bounded


def test_a_regular_file_within_its_bound_is_read_whole(tmp_path):
    p = tmp_path / "f.json"
    p.write_bytes(b"x" * 100)
    assert read_bounded(p, 100) == b"x" * 100        # exactly at the bound: read


def test_one_byte_over_the_bound_is_refused_before_reading(tmp_path):
    p = tmp_path / "f.json"
    p.write_bytes(b"x" * 101)
    with pytest.raises(UnreadableFile, match="is 101 bytes, more than .* \\(100 bytes\\)"):
        read_bounded(p, 100)


@pytest.mark.parametrize("make", ["folder", "fifo", "device", "missing"])
def test_what_is_not_a_regular_file_is_refused(tmp_path, make):
    p = tmp_path / "x"
    if make == "folder":
        p.mkdir()
    elif make == "fifo":
        os.mkfifo(p)            # a read would block forever
    elif make == "device":
        p = "/dev/zero"         # a read would never end
    with pytest.raises(UnreadableFile) as exc:
        read_bounded(p, 10_000)
    want = "cannot be read" if make == "missing" else "is not a regular file"
    assert want in str(exc.value) and str(p) not in str(exc.value)   # the caller names the file
    assert isinstance(exc.value, OSError)
