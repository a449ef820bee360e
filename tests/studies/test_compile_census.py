"""The compile census (daebench.studies.perf.compile_census): nested compiles are attributed to
their own function, and the own times add up to the outer compile's span; the census of what a
process holds (daebench.studies.perf.loaded_code) reads the same machine code from the kernel
cache as numba emitted when it compiled."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from daebench.harness.running.compile_events import recording
from daebench.studies.perf.compile_census import Census, Compiled, markdown


def _fresh_pair():
    # defined inside the test: new dispatchers, never cached, so they compile here
    @numba.njit(cache=False)
    def inner(x):
        return np.sin(x) * 2.0

    @numba.njit(cache=False)
    def outer(x):
        return inner(x) + 1.0

    return inner, outer


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing compiles with NUMBA_DISABLE_JIT")
def test_recording_attributes_nested_compiles():
    inner, outer = _fresh_pair()
    with recording() as rec:
        assert outer(0.5) == pytest.approx(2.0 * np.sin(0.5) + 1.0, abs=0.0, rel=1e-15)
    names = [f["name"].rsplit(".", 1)[-1] for f in rec["functions"]]
    assert "outer" in names and "inner" in names
    fo = next(f for f in rec["functions"] if f["name"].endswith(".outer"))
    fi = next(f for f in rec["functions"] if f["name"].endswith(".inner"))
    assert fo["signature"] == "float64" and fi["signature"] == "float64"
    # inner compiled while outer was typed: its span lies inside outer's, and is not outer's own
    assert fo["total_s"] >= fi["total_s"] > 0.0
    assert fo["own_s"] <= fo["total_s"] - fi["total_s"] + 1e-9
    # the own times of everything recorded add up to the outermost span (nothing counted twice)
    assert sum(f["own_s"] for f in rec["functions"]) == pytest.approx(fo["total_s"], rel=1e-9)
    assert 0.0 < rec["llvm_s"] <= fo["total_s"]
    # a second call compiles nothing
    with recording() as again:
        outer(0.25)
    assert again["functions"] == []


def test_markdown_groups_by_module():
    c = Census("daebench run x", "3", 10.0, 2.0, 3.0, 1.0, 0,
               [Compiled("a.b.f", "float64", 2.0, 2.5), Compiled("a.b.g", "int64", 0.5, 0.5),
                Compiled("a.c.h", "float64", 0.5, 0.5)])
    assert c.by_module() == [("a.b", 2, 2.5), ("a.c", 1, 0.5)]
    text = markdown(c)
    assert "compiling ≈ 8.0 s" in text and "| a.b | 2 | 2.50 |" in text


_PROBE = '''
import json, sys
import numpy as np
from numba import njit
import daebench  # noqa: F401 — installs daebench's cache locators, as in every daebench process
from daebench.studies.perf.loaded_code import loaded


@njit(cache=True)
def probe(x):
    return np.sin(x) * 2.0 + np.cos(x)


probe(0.5)
probe(np.arange(3.0))
print(json.dumps([r.__dict__ for r in loaded(("__main__",))]))
'''


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing compiles with NUMBA_DISABLE_JIT")
def test_loaded_code_reads_the_cache_as_numba_emitted_it(tmp_path):
    """A process that compiles counts the machine code of the object numba emitted; one that
    loads the same functions from the kernel cache reads it from the cache entries: the same
    specializations and the same bytes."""
    script = tmp_path / "probe_module.py"
    script.write_text(_PROBE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    runs = []
    for _ in range(2):   # compiled, then loaded from the cache
        p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
        assert p.returncode == 0, p.stderr[-2000:]
        runs.append(sorted((r["signature"], r["code_bytes"]) for r in json.loads(p.stdout.strip().splitlines()[-1])))
    compiled, cached = runs
    assert [s for s, _ in compiled] == ["array(float64, 1d, C)", "float64"]
    assert all(b > 0 for _, b in compiled)
    assert cached == compiled
