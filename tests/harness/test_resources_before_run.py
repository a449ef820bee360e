"""Resources stated and enforced before the run: a scene too large for the machine is refused."""

from __future__ import annotations

from _cli import cli


def test_a_scene_too_large_for_the_machine_is_refused_before_the_run(tmp_path, monkeypatch):
    """rod-wall with 2000 × 50 elements asked numpy for 310 GiB after 13 s ('a bug in integrator
    hht'); at 2000 × 8 it would take 9.7 GiB of a 24 GiB machine without a word."""
    from daebench.harness.running import checks

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    monkeypatch.setattr(checks, "machine_memory", lambda: 24 << 30)
    r = cli(["run", "rod-wall", "-i", "hht", "--set", "rod.elements=2000", "--set", "rod.elements_across=8"])
    assert r.exit_code == 2 and "GiB" in r.output and "of this machine's 24 GiB" in r.output, r.output
    assert "coarser mesh" in r.output
    assert not (tmp_path / "runs").exists() or not list((tmp_path / "runs").iterdir())
    r = cli(["bench", "rod-wall", "-i", "hht", "--steps", "1e-6", "--set", "rod.elements=2000",
             "--set", "rod.elements_across=8", "--reference", "none", "--name", "big"])
    assert r.exit_code == 2 and "GiB" in r.output, r.output
