"""What keys a plugin's compiled code (daebench.core.code_digest, daebench.core.numba_cache):
its code and what it reaches, never its version, line numbers or daebench's unrelated files."""

import importlib
import sys
import textwrap

import pytest

from daebench.core import code_digest, numba_cache

PKG = {
    "__init__.py": "",
    "helpers.py": "SCALE = 2.0\n\ndef scaled(x):\n    return SCALE * x\n",
    "step.py": textwrap.dedent("""\
        from daebench.core import phase          # builds on daebench: a plugin function
        from myplug import helpers

        def step(x):
            return helpers.scaled(x) + 1.0

        def other(x):
            return x
        """),
}


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    root = tmp_path / "myplug"
    root.mkdir()
    for name, text in PKG.items():
        (root / name).write_text(text)
    monkeypatch.syspath_prepend(str(tmp_path))

    def load():
        for m in [m for m in sys.modules if m == "myplug" or m.startswith("myplug.")]:
            del sys.modules[m]
        importlib.invalidate_caches()
        return importlib.import_module("myplug.step")

    yield root, load
    for m in [m for m in sys.modules if m == "myplug" or m.startswith("myplug.")]:
        del sys.modules[m]


def test_the_digest_follows_the_code_and_what_it_reaches(plugin):
    root, load = plugin
    d0 = code_digest.functions_digest([load().step])
    assert code_digest.functions_digest([load().step]) == d0                 # loading again: same code
    (root / "step.py").write_text("\n\n" + PKG["step.py"])                   # moved two lines down
    assert code_digest.functions_digest([load().step]) == d0
    (root / "helpers.py").write_text(PKG["helpers.py"].replace("2.0", "3.0"))  # a constant it reads, elsewhere
    d1 = code_digest.functions_digest([load().step])
    assert d1 != d0
    (root / "step.py").write_text(PKG["step.py"].replace("+ 1.0", "+ 1.5"))   # its own code
    assert code_digest.functions_digest([load().step]) not in (d0, d1)


def test_a_plugin_function_is_one_that_builds_on_daebench(plugin):
    _, load = plugin
    mod = load()
    assert code_digest.is_plugin_function(mod.step)
    assert not code_digest.is_plugin_function(importlib.import_module("myplug.helpers").scaled)
    from daebench.core import phase

    assert not code_digest.is_plugin_function(phase.law_force.py_func)        # daebench's own: its stamp


def test_a_plugin_functions_stamp_covers_its_package_and_daebench(plugin):
    """numba stamps a cached function with its own file only; a plugin's stamp also holds
    daebench's stamp and every file of its package, so a helper's edit recompiles it."""
    root, load = plugin
    mod = load()
    loc = numba_cache.PluginInTreeLocator.from_function(mod.step, mod.__file__)
    assert loc is not None and numba_cache.InTreeLocator.from_function(mod.step, mod.__file__) is None
    s0 = loc.get_source_stamp()
    assert numba_cache.source_stamp() in s0
    (root / "helpers.py").write_text(PKG["helpers.py"].replace("2.0", "4.0"))
    assert loc.get_source_stamp() != s0
