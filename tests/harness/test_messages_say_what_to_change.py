"""Messages that say what to change (stability options, unwritable folders)."""

from __future__ import annotations

import pytest

from _cli import cli


@pytest.mark.parametrize("args, fragment", [
    (["stability", "pendulum", "--n", "abc", "--n-key", "pendulum.mass"], "--n takes whole numbers"),
    (["stability", "pendulum", "-m", "hht:alpha"], "'alpha' is not name=value"),
])
def test_stability_options_say_what_they_take(tmp_path, monkeypatch, args, fragment):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(args)
    assert r.exit_code == 2 and fragment in r.output, r.output


def test_an_unwritable_folder_is_not_called_full():
    import errno

    from daebench.harness.files import write_error

    msg = str(write_error(PermissionError(errno.EACCES, "Permission denied"), "the table", "/x/t.csv"))
    assert "Free space" not in msg and "Make it writable" in msg
    msg = str(write_error(OSError(errno.ENOSPC, "No space left on device"), "the table", "/x/t.csv"))
    assert "Free space there" in msg
