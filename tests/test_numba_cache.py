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
