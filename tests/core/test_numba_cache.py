"""The numba cache index across processes with and without a plugin: an entry naming a
class this process cannot import costs only that entry (independent truth: numba's own
``numba:compile`` event, which fires on a cache miss only)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

PLUGIN = """
from typing import NamedTuple


class PluginData(NamedTuple):
    a: float
"""

USER = """
from numba import njit


@njit(cache=True)
def f(x):
    return x.a + 1.0 if hasattr(x, "a") else x + 1.0
"""

PROBE = """
import sys
import daebench  # installs the tolerant index loader
from numba.core import event
import user_mod

with event.install_recorder("numba:compile") as rec:
    {calls}
print("COMPILES", len(rec.buffer))
"""


def _run(folder: Path, calls: str) -> int:
    code = textwrap.dedent(PROBE).format(calls=calls)
    out = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True,
                         env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(folder), "NUMBA_CACHE_DIR": str(folder / "cache")},
                         timeout=300)
    assert out.returncode == 0, out.stderr
    return int(out.stdout.split("COMPILES")[1])


def test_an_entry_of_a_missing_plugin_costs_only_itself(tmp_path):
    (tmp_path / "plugin_mod.py").write_text(PLUGIN)
    (tmp_path / "user_mod.py").write_text(USER)
    with_plugin = "import plugin_mod\n    user_mod.f(2.0)\n    user_mod.f(plugin_mod.PluginData(1.0))"
    assert _run(tmp_path, with_plugin) >= 2                 # both specializations compiled and cached
    assert _run(tmp_path, with_plugin) == 0                 # and both load from the cache
    (tmp_path / "plugin_mod.py").unlink()                   # a process where the plugin is not installed
    assert _run(tmp_path, "user_mod.f(2.0)") == 0           # the built-in entry is still a hit
    (tmp_path / "plugin_mod.py").write_text(PLUGIN)
    assert _run(tmp_path, with_plugin) == 0                 # and the plugin's entry was not thrown away


# ---- a damaged cache heals itself (issue 24, item 7) -------------------------------------------
HEAL_PROBE = """
import daebench
from numba.core import event
from daebench.stepping import control

with event.install_recorder("numba:compile") as rec:
    h, t = control.land(0.0, 1.0, 0.3)
print("RESULT", h, t, "COMPILES", len(rec.buffer))
"""


def _heal_run(cache: Path, extra_path: str = "") -> tuple[int, str]:
    """(compilations of daebench's land, stderr) in a fresh process on the private cache."""
    import os

    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=extra_path)
    out = subprocess.run([sys.executable, "-c", HEAL_PROBE], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    assert "RESULT 0.3 0.3" in out.stdout            # land's answer: a step of 0.3 from 0 ends at 0.3
    return int(out.stdout.split("COMPILES")[1]), out.stderr


def _flip(p: Path) -> None:
    b = bytearray(p.read_bytes())
    for i in range(len(b) // 2, len(b) // 2 + 8):
        b[i] ^= 0xFF
    p.write_bytes(bytes(b))


def _truncate(p: Path) -> None:
    p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 3])


def _empty(p: Path) -> None:
    p.write_bytes(b"")


def _random_index(p: Path) -> None:
    import os

    idx = p.with_name(p.name.rsplit(".", 2)[0] + ".nbi")       # control.land-59.py311.1.nbc → .nbi
    assert idx.exists()
    idx.write_bytes(os.urandom(300))


import pytest  # noqa: E402


@pytest.mark.parametrize("damage", [_flip, pytest.param(_truncate, marks=pytest.mark.slow),
                                    pytest.param(_empty, marks=pytest.mark.slow),
                                    pytest.param(_random_index, marks=pytest.mark.slow)])
def test_a_damaged_kernel_cache_is_reported_once_removed_and_recompiled(tmp_path, damage):
    """Flipped bytes, a truncated or empty data file, a random index: the next process says
    so once (naming the file), compiles the kernel again (numba's compile event: a miss)
    and gives the right answer; the process after it loads from the healed cache."""
    cache = tmp_path / "cache"
    cold = _heal_run(cache)[0]
    assert cold >= 1                                 # cold: compiled and saved
    assert _heal_run(cache)[0] == 0                  # warm
    data = [p for p in cache.rglob("*.nbc") if p.name.startswith("control.land-")]
    assert len(data) == 1, sorted(cache.rglob("*"))
    damage(data[0])
    compiles, err = _heal_run(cache)
    assert compiles == cold                          # compiled again, as on a cold cache
    assert err.count("was damaged") == 1 and "compiled again" in err and "land" in err, err
    compiles, err = _heal_run(cache)
    assert compiles == 0 and "damaged" not in err     # healed: a hit again
