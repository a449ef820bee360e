"""A third-party integrator installed as a package shows up and runs with no change here."""

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


PLUGIN = Path(__file__).resolve().parents[1] / "plugin_pkg"
ROOT = str(Path(__file__).resolve().parents[2])   # this tree's daebench, whatever is installed


@pytest.fixture(scope="module")
def plugin_site(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(PLUGIN)]
    if importlib.util.find_spec("hatchling") is not None:
        cmd.insert(4, "--no-build-isolation")  # no download needed when the backend is here
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return target


def daebench(site, *args):
    env = dict(os.environ, COLUMNS="250", PYTHONPATH=os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "daebench.cli.app", *args], capture_output=True, text=True, env=env)


def test_plugin_listed_with_its_distribution_and_a_shadowing_one_refused(plugin_site, tmp_path):
    """Listed with its distribution; the example package registers 'hht' too: `list` says it
    is refused, naming both distributions, and `run -i hht` runs daebench's."""
    out = daebench(plugin_site, "list")
    assert out.returncode == 0, out.stderr
    line = next(ln for ln in out.stdout.splitlines() if "verlet" in ln)
    assert "daebench-verlet" in line or "daebench_verlet" in line
    text = " ".join(out.stdout.split())
    assert ("refused: integrator 'hht' of the installed distribution daebench-verlet (daebench_verlet:ShadowHHT) "
            "is refused: daebench's built-in (daebench.integrators.hht:HHT) provides that name") in text
    line = next(ln for ln in out.stdout.splitlines() if ln.split()[:1] == ["hht"])
    assert "daebench" in line and "daebench-verlet" not in line
    run = daebench(plugin_site, "run", "pendulum", "-i", "hht", "--opt", "h=1e-3", "--set", "t_end=0.01",
                   "--out", str(tmp_path), "--json")
    assert run.returncode == 0 and json.loads(run.stdout)["counters"]["newton_iterations"] > 0   # the built-in


def test_plugin_runs_and_is_second_order(plugin_site, tmp_path):
    """The plugin runs the pendulum through the CLI; its error against the exact solution
    falls 4× when h halves (it is a 2nd-order method)."""
    errs = []
    for h in (2e-3, 1e-3):
        out = daebench(plugin_site, "run", "pendulum", "--integrator", "verlet", "--opt", f"h={h}",
                       "--out", str(tmp_path), "--json")
        assert out.returncode == 0, out.stderr
        rec = json.loads(out.stdout)
        assert rec["integrator"] == "verlet" and rec["status"] == "completed"
        theta = rec["observables"]["theta_deg"]
        errs.append(abs(np.radians(theta) - exact_theta_end()))
    assert 3.0 < errs[0] / errs[1] < 5.0


def exact_theta_end():
    from daebench.models import build_system
    from daebench.models.scenes import load_scene

    sc = load_scene("pendulum")
    return float(np.squeeze(build_system(sc).exact_theta(sc.t_end)))


def test_unknown_integrator_refused_with_suggestion(plugin_site):
    out = daebench(plugin_site, "run", "pendulum", "--integrator", "verlett")
    assert out.returncode == 2
    assert "unknown integrator 'verlett'" in out.stderr and "did you mean 'verlet'" in out.stderr


def test_registry_is_cached_per_sys_path_and_sees_a_plugin_added_to_it(plugin_site, monkeypatch):
    """In-process: the entry-point scan is kept while sys.path is unchanged, and a plugin
    directory added to sys.path is found without an explicit refresh."""
    from daebench.integrators import registry as integrator_registry

    calls = []
    real = integrator_registry.entry_points
    monkeypatch.setattr(integrator_registry, "entry_points", lambda **kw: calls.append(1) or real(**kw))
    first = integrator_registry.registry(refresh=True)
    assert integrator_registry.registry() == first and len(calls) == 1 and "verlet" not in first
    monkeypatch.syspath_prepend(str(plugin_site))
    with_plugin = integrator_registry.registry()
    assert len(calls) == 2 and "verlet" in with_plugin and with_plugin["verlet"].cls is not None
    assert integrator_registry.registry(refresh=True) == with_plugin and len(calls) == 3


def test_compiled_plugin_runs_like_the_python_one(plugin_site, tmp_path):
    """The second example plugin writes its step against the compiled interfaces
    (daebench_verlet.compiled): it is listed, runs through the CLI and gives the Python
    plugin's answer (same method) to round-off, with second-order error."""
    out = daebench(plugin_site, "list")
    assert out.returncode == 0 and "verlet-compiled" in out.stdout, out.stderr
    thetas = {}
    for name in ("verlet", "verlet-compiled"):
        for h in (2e-3, 1e-3):
            out = daebench(plugin_site, "run", "pendulum", "--integrator", name, "--opt", f"h={h}",
                           "--out", str(tmp_path), "--json")
            assert out.returncode == 0, out.stderr
            rec = json.loads(out.stdout)
            assert rec["status"] == "completed"
            thetas[name, h] = np.radians(rec["observables"]["theta_deg"])
    for h in (2e-3, 1e-3):
        assert abs(thetas["verlet", h] - thetas["verlet-compiled", h]) < 1e-11
    errs = [abs(thetas["verlet-compiled", h] - exact_theta_end()) for h in (2e-3, 1e-3)]
    assert 3.0 < errs[0] / errs[1] < 5.0


def test_daebench_still_runs_where_the_plugin_is_not_installed(plugin_site, tmp_path):
    """The plugin's compiled runs put its types into the cache index of daebench's loops;
    a process that cannot import the plugin must treat that index as a miss, not crash."""
    out = daebench(plugin_site, "run", "pendulum", "--integrator", "verlet-compiled", "--opt", "h=1e-3",
                   "--out", str(tmp_path), "--json")
    assert out.returncode == 0, out.stderr
    env = dict(os.environ, COLUMNS="250", PYTHONPATH=ROOT)
    p = subprocess.run([sys.executable, "-m", "daebench.cli.app", "run", "pendulum", "--integrator", "hht",
                        "--opt", "h=1e-3", "--out", str(tmp_path), "--json"], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr[-2000:]
    assert json.loads(p.stdout)["status"] == "completed"


PROBE = """
import daebench
from daebench.core import numba_cache
from numba.core import event
from daebench.stepping import control

with event.install_recorder("numba:compile") as rec:
    control.land(0.0, 1.0, 0.3)
print("STAMP", numba_cache.source_stamp(), "COMPILES", len(rec.buffer))
"""


def test_a_plugin_leaves_the_builtins_kernel_cache_alone(plugin_site, tmp_path):
    """Issue 24 item 10: a plugin's version was part of the stamp of every daebench kernel,
    so a process with a plugin installed (and the next one without) recompiled everything
    and overwrote the index. The stamp is now the same with and without the plugin, and a
    built-in kernel cached without it is a hit with it, and again without (numba's compile
    event fires on a miss only)."""
    cache = tmp_path / "cache"

    def probe(with_plugin: bool) -> tuple[str, int]:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(cache),
                   PYTHONPATH=os.pathsep.join([str(plugin_site), ROOT] if with_plugin else [ROOT]))
        out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=300)
        assert out.returncode == 0, out.stderr
        stamp, compiles = out.stdout.split("STAMP")[1].split("COMPILES")
        return stamp.strip(), int(compiles)

    stamp0, cold = probe(False)
    assert cold >= 1
    stamp1, n = probe(True)
    assert stamp1 == stamp0 and n == 0
    assert probe(False) == (stamp0, 0)


EDIT_PROBE = """
import daebench
from numba.core import event

with event.install_recorder("numba:compile") as rec:
    r = daebench.run("pendulum", "verlet-compiled", h=1e-3, overrides={"t_end": 0.2})
mods = {getattr(getattr(ev.data["dispatcher"], "py_func", None), "__module__", "?") for _, ev in rec.buffer}
print("THETA", repr(float(r.observables["theta_deg"].iloc[-1])), "MODULES", ",".join(sorted(mods)))
"""


def test_an_edit_of_a_compiled_plugin_is_never_served_stale_and_recompiles_its_code_only(plugin_site, tmp_path):
    """A compiled plugin's code keys what is compiled of it, not its version: an edit of its
    step (version unchanged) changes the answer at once, and what is compiled again is the
    step's entry alone — no daebench function (the loop reaches the plugin's stepper as
    compiled values, daebench.stepping.method_handles)."""
    import shutil
    import time

    site = tmp_path / "site"
    shutil.copytree(plugin_site, site)

    def probe() -> tuple[float, set[str]]:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), ROOT]))
        out = subprocess.run([sys.executable, "-c", EDIT_PROBE], capture_output=True, text=True, env=env,
                             timeout=600)
        assert out.returncode == 0, out.stderr[-3000:]
        theta, mods = out.stdout.split("THETA")[1].split("MODULES")
        return float(theta), {m for m in mods.strip().split(",") if m}

    theta0, _ = probe()
    assert probe() == (theta0, set())                       # cached: nothing compiled
    src = site / "daebench_verlet" / "compiled.py"
    text = src.read_text()
    old = "new.v[i] = cur.v[i] + 0.5 * h * (cur.a[i] + new.a[i])"
    assert old in text
    factor = 1.001 + (time.time_ns() % 10**6) * 1e-12    # a wrong method on purpose, same version; an
    src.write_text(text.replace(old, f"{old} * {factor!r}"))  # edit never made before (code keys the cache)
    theta1, compiled = probe()
    assert abs(theta1 - theta0) > 1e-6                      # the edit runs
    assert compiled and not [m for m in compiled if m.startswith("daebench.")], compiled
    entries = [m for m in compiled if m.startswith("_daebench_method_")]
    assert entries and all("_step_" in m for m in entries), entries   # the step's entry alone
