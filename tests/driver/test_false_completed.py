"""No false "completed": runs that break the divergence or the penetration rule end
diverged with the reason."""

from __future__ import annotations

import pytest

from _cli import cli


def _over_the_rule(history) -> str:
    """'' when every row of a history passes the divergence rule, else its reason."""
    import numpy as np

    from daebench.driver.history import divergence

    works = {c[2:]: history[c].to_numpy() for c in history.columns if c.startswith("W_")}
    last = {k: float(np.nan_to_num(w[-1])) for k, w in works.items()}
    E = history["E"].to_numpy()
    scale = max(abs(float(x)) for c, x in history.iloc[0].items() if c.startswith("E_")) or 1.0
    return divergence(E, history["energy_residual"].to_numpy(), last, float(E[0]), scale,
                      float(history["D_impacts"].iloc[-1]))[1]


@pytest.mark.parametrize("integrator", ["moreau", "hht", "newmark", "genalpha"])
def test_no_stiff_spring_wall_run_completes_over_the_divergence_rule(integrator):
    """spring-wall at stiffness 1e4 … 1e10 × h 1e-2, 1e-3 (32 runs over the four integrators):
    Moreau said 'completed' at 534–865× the start energy where the others said diverged."""
    from daebench.harness.running.runner import run_scene
    from daebench.models.scenes import load_scene

    for k in (1e4, 1e6, 1e8, 1e10):
        for h in (1e-2, 1e-3):
            sc = load_scene("spring-wall", {"t_end": 0.5, "spring.stiffness": k})
            _, r = run_scene(sc, integrator, {"h": h}, write=False)
            assert r.status in ("completed", "diverged"), (k, h, r.status, r.message)
            if r.status == "completed":
                assert _over_the_rule(r.history) == "", (integrator, k, h, r.energy_residual)
            else:
                assert r.message, (k, h)


def test_the_moreau_spring_wall_command_ends_diverged_with_the_reason(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(["run", "spring-wall", "-i", "moreau", "--opt", "h=1e-2", "--set", "t_end=0.5",
             "--set", "spring.stiffness=1e8"])
    assert r.exit_code == 1 and "diverged" in r.output and "inside its rigid obstacle" in r.output, r.output


def test_hht_at_extreme_values_is_not_completed():
    """ball.mass 1e-9, stiffness 1e12, start 1e6 m at 1e6 m/s: residual 1.4e35 J, 779 km through
    the wall, 'completed'."""
    import daebench

    r = daebench.run("spring-wall", "hht", overrides=["ball.mass=1e-9", "spring.stiffness=1e12", "start.x=1e6",
                                                      "start.v=1e6"], write=False).record
    assert r.status == "diverged" and "energy" in r.message


def test_a_capturing_step_through_a_rigid_obstacle_is_diverged(monkeypatch):
    """The penetration rule: a capturing run whose gap falls below −PENETRATION × the scene's
    length scale (the size of its start, here 1 m) is diverged with the reason; made strict, it
    catches the O(h v) penetration every Moreau step has."""
    import daebench
    from daebench.driver import history
    from daebench.models import build_system
    from daebench.models.scenes import load_scene

    assert build_system(load_scene("ball")).length_scale() == pytest.approx(1.0)
    ok = daebench.run("ball", "moreau", settings={"h": 1e-3}, overrides={"t_end": 1.0}, write=False).record
    assert ok.status == "completed"
    monkeypatch.setattr(history, "PENETRATION", 1e-9)
    r = daebench.run("ball", "moreau", settings={"h": 1e-3}, overrides={"t_end": 1.0}, write=False).record
    assert r.status == "diverged" and "inside its rigid obstacle, deeper than 1e-09 × the scene's length scale 1 m" \
        in r.message, r.message
    bad, why = history.penetration([[0.1, -0.6], [0.2, 0.0]], 1.0)
    assert bad.tolist() == [True, False] and why.startswith("contact 1 is 0.6 m inside")
