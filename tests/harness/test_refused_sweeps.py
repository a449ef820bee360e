"""A refused sweep leaves nothing behind; a reference that fails to compute in a bench exits 1."""

from __future__ import annotations

import pytest

from _cli import cli


B3 = ["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.05", "--reference", "none",
      "--repeats", "1"]


@pytest.mark.parametrize("bad", [["-j", "0"], ["--repeats", "0"], ["--run-cap", "-1"]])
def test_a_refused_sweep_leaves_no_store_and_the_corrected_command_runs(tmp_path, monkeypatch, bad):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    args = [a for a in B3 if a not in ("--repeats", "1")] if bad[0] == "--repeats" else B3
    r = cli(args + bad + ["--name", "x"])
    assert r.exit_code == 2, r.output
    assert not list((tmp_path / "bench").glob("*")) if (tmp_path / "bench").exists() else True
    r = cli(B3 + ["--name", "x"])
    assert r.exit_code == 0, r.output


def test_a_sweep_refused_for_its_reference_leaves_no_store(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    args = ["bench", "beam-impact", "-i", "hht", "--steps", "1e-4", "--set", "t_end=0.01", "--reference", "require"]
    for extra in (["--name", "y"], []):  # named, and with a unique name (no orphan store either)
        r = cli(args + extra)
        assert r.exit_code == 2 and "no reference" in r.output, r.output
        assert sorted(p.name for p in (tmp_path / "bench").glob("*")) == []


def test_a_reference_that_fails_to_compute_in_a_bench_exits_1(tmp_path, monkeypatch):
    """It exited 2 ('input refused') though the input was fine."""
    from daebench.harness.references import reference as references

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))

    def fails(scene, **kw):
        raise RuntimeError("reference run of 'beam-impact' failed: step size too small")

    monkeypatch.setattr(references, "compute_reference", fails)
    r = cli(["bench", "beam-impact", "-i", "hht", "--steps", "1e-4", "--set", "t_end=0.01", "--reference", "compute",
             "--name", "z"])
    assert r.exit_code == 1 and "could not be computed" in r.output, r.output
    assert sorted(p.name for p in (tmp_path / "bench").glob("*")) == []
