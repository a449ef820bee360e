"""daebench.core.switches: an environment switch is off for 0, false, no and off in any case
and spacing, on otherwise and when unset — and the package reads DAEBENCH_COMPILED through it
(a fresh process with DAEBENCH_COMPILED=" Off " runs numba functions as plain Python)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from daebench.core.switches import switched_off


@pytest.mark.parametrize("value, off", [("0", True), ("false", True), (" No ", True), ("OFF", True),
                                        ("1", False), ("yes", False), ("", False), ("2", False)])
def test_values_that_turn_a_switch_off(monkeypatch, value, off):
    monkeypatch.setenv("DAEBENCH_TEST_SWITCH", value)
    assert switched_off("DAEBENCH_TEST_SWITCH") is off


def test_an_unset_switch_is_on(monkeypatch):
    monkeypatch.delenv("DAEBENCH_TEST_SWITCH", raising=False)
    assert not switched_off("DAEBENCH_TEST_SWITCH")


def test_the_package_reads_the_compiled_switch_through_it():
    code = "import daebench, numba; print(bool(numba.config.DISABLE_JIT))"
    for value, disabled in ((" Off ", "True"), ("1", "False")):
        out = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, DAEBENCH_COMPILED=value),
                             capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr[-1000:]
        assert out.stdout.strip().splitlines()[-1] == disabled
