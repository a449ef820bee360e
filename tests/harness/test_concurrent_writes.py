"""Writers of one file in one process: threads that write the same target at once each
use a temporary file of their own, so every writer succeeds and the file that stays is one
writer's whole file; a write that does fail names what went missing (the folder, or the
temporary file), not a generic fault of the folder."""

from __future__ import annotations

import threading
from pathlib import Path

import pandas as pd
import pytest

import daebench
from daebench.harness.files import OutputWriteError, atomic_write

THREADS = 4


def _in_threads(fn, n: int = THREADS) -> list[BaseException]:
    errors: list[BaseException] = []

    def go(i: int) -> None:
        try:
            fn(i)
        except BaseException as exc:   # collected: the test asserts on them
            errors.append(exc)

    ts = [threading.Thread(target=go, args=(i,)) for i in range(n)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(timeout=120)
    return errors


def test_threads_writing_one_file_at_once_all_succeed(tmp_path):
    """Every writer is inside its write at the same moment (a barrier), so a temporary name
    shared by the process's threads is moved away under the others' feet."""
    target = tmp_path / "t.csv"
    barrier = threading.Barrier(THREADS, timeout=30)

    def write(i: int) -> None:
        def body(p: Path) -> None:
            p.write_text(f"writer,{i}\n" * 1000)
            barrier.wait()
        atomic_write(target, body, "the table")

    assert _in_threads(write) == []
    text = target.read_text()
    assert text in {f"writer,{i}\n" * 1000 for i in range(THREADS)}   # one writer's whole file
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]            # no temporary file left


def test_a_writer_that_raises_leaves_no_temporary_file(tmp_path):
    def body(p: Path) -> None:
        p.write_text("half")
        raise ValueError("the writer's own failure")

    with pytest.raises(ValueError, match="own failure"):
        atomic_write(tmp_path / "t.csv", body, "the table")
    assert list(tmp_path.iterdir()) == []


def test_a_removed_folder_is_named_as_the_cause(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()

    def body(p: Path) -> None:
        p.unlink()
        folder.rmdir()
        p.write_text("x")     # the folder is gone: No such file or directory

    with pytest.raises(OutputWriteError, match=r"the folder .*out no longer exists") as e:
        atomic_write(folder / "t.csv", body, "the table")
    assert "Leave the folder and its files alone" in str(e.value) and "Mend that" not in str(e.value)


def test_a_temporary_file_removed_by_someone_else_is_named_as_the_cause(tmp_path):
    def body(p: Path) -> None:
        p.write_text("x")
        p.unlink()            # another process cleaning the folder

    with pytest.raises(OutputWriteError, match=r"its temporary file \.t\.csv\.\w+\.tmp was removed"):
        atomic_write(tmp_path / "t.csv", body, "the table")


def test_four_threads_running_one_target_with_write_all_succeed(tmp_path):
    """The API's own writer: four threads, one run each of the same scene and settings, one
    output folder. Every run writes its history; the file left is a whole history equal to
    the one a single run writes."""
    kw = dict(overrides={"t_end": 0.2}, settings={"h": 1e-3}, write=True)
    alone = daebench.run("pendulum", "hht", out_dir=tmp_path / "alone", **kw)
    out = tmp_path / "shared"
    results: list = [None] * THREADS

    def run(i: int) -> None:
        results[i] = daebench.run("pendulum", "hht", out_dir=out, **kw)

    assert _in_threads(run) == []
    files = sorted(p.name for p in out.iterdir())
    assert files == sorted(p.name for p in (tmp_path / "alone").iterdir())   # no temporary file left
    for name in files:
        if name.endswith(".csv"):
            pd.testing.assert_frame_equal(pd.read_csv(out / name), pd.read_csv(tmp_path / "alone" / name),
                                          check_exact=True)
    assert all(r.status == alone.status == "completed" for r in results)
