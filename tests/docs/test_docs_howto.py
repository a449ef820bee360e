"""docs/howto/write-an-integrator.md runs as written: its Python blocks, top to bottom, as
one script (a file, so that its compiled functions cache as a user's would); the Problem
methods and compiled functions its tables list exist."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "howto" / "write-an-integrator.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_pages_code_runs(tmp_path):
    blocks = python_blocks(PAGE.read_text())
    assert len(blocks) >= 7
    script = tmp_path / "howto.py"
    script.write_text("\n\n".join(blocks))
    env = dict(os.environ, PYTHONPATH=str(ROOT), DAEBENCH_RESULTS=str(tmp_path / "results"))
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, env=env,
                         timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-5000:]
    assert "PASS  order     measured 2.00, declared 2" in out.stdout
    assert "FAIL" not in out.stdout


@pytest.mark.parametrize("table, owner", [("p", "daebench.core.problem:Problem"),
                                          ("phase", "daebench.core.phase"), ("linalg", "daebench.core.linalg"),
                                          ("control", "daebench.stepping.control")])
def test_every_function_the_page_lists_exists(table, owner):
    import importlib

    module, _, cls = owner.partition(":")
    obj = importlib.import_module(module)
    obj = getattr(obj, cls) if cls else obj
    names = set(re.findall(rf"`{table}\.(\w+)[(`]", PAGE.read_text()))
    assert names, table
    missing = sorted(n for n in names if not hasattr(obj, n) and not (cls and n in ("n", "m", "n_contacts")))
    assert missing == []
