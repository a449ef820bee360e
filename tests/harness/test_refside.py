"""A reference's check runs in forked processes (daebench.harness.references.side_runs) give the same
reference, to the last bit, as the three runs one after the other in one process."""

import pandas as pd
import pytest

from daebench.harness.references import reference as references, side_runs as refside
from daebench.models.scenes import load_scene


def test_forked_check_runs_equal_the_serial_ones(tmp_path, monkeypatch):
    scene = load_scene("pendulum", ["t_end=0.3"])
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "serial"))
    serial = references.compute_reference(scene, parallel=False)
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "forked"))
    forked = references.compute_reference(scene)
    pd.testing.assert_frame_equal(serial.history, forked.history, check_exact=True)
    for key in ("accuracy", "agreement", "impacts", "counters"):
        assert serial.meta[key] == forked.meta[key], key
    assert forked.meta["accuracy"]["trust_t"] == 0.3


def test_a_side_run_that_raises_raises_in_the_caller():
    def bad():
        raise ValueError("the check run's own error")

    with refside.SideRuns({"check": bad}) as runs:
        runs.start()
        with pytest.raises(ValueError, match="the check run's own error"):
            runs.results()


def test_a_side_run_whose_process_dies_is_reported():
    import os

    with refside.SideRuns({"perturbed": lambda: os._exit(3)}) as runs:
        with pytest.raises(RuntimeError, match="perturbed run ended without a result .*exited with code 3"):
            runs.results()


def test_every_run_the_caller_makes_shows_its_progress(tmp_path, monkeypatch):
    """The reference run and each check run made in the calling process report progress under
    their own label (one after the other here: all of them)."""
    from contextlib import contextmanager

    shown = []

    @contextmanager
    def progress(label, t_end):
        shown.append(label)
        yield lambda t: None

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    references.compute_reference(load_scene("pendulum", ["t_end=0.3"]), parallel=False, progress=progress)
    assert shown[0].startswith("reference of pendulum: ida rtol")
    assert [s.split(" run of ")[0] for s in shown[1:]] == ["check", "perturbed-start", "conditioning 1e-08",
                                                         "conditioning 1e-06", "conditioning 0.0001"]
