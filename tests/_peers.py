"""Skip markers for the tests that run real peer codes: skipped, with the install command,
where the peer is not installed."""

from __future__ import annotations

import subprocess

import pytest

import _apt
from daebench.peers import PEERS, PeerUnavailable
from daebench.peers.base import system_python


def available(name: str) -> bool:
    """Whether peer ``name`` finds the Python it runs in."""
    try:
        PEERS[name].python()
    except PeerUnavailable:
        return False
    return True


needs_siconos = pytest.mark.skipif(not available("siconos-mj"),
                                   reason="Siconos is not installed (apt-get install python3-siconos)")
needs_exudyn = pytest.mark.skipif(not available("exudyn-ga"),
                                  reason="Exudyn is not installed (pip install 'daebench[exudyn]')")


def ensure_siconos() -> None:
    """Siconos in the system Python, installed (Debian's python3-siconos) when the session
    may (:func:`_apt.ensure`): the documentation's peer how-to runs it. Asked anew each time
    (:func:`available` keeps the answer it had at collection)."""
    def present():
        exe = system_python()
        ok = exe is not None and subprocess.run([exe, "-c", "import siconos.kernel"], capture_output=True,
                                                timeout=120).returncode == 0
        return True if ok else None

    _apt.ensure("python3-siconos", present, "Siconos is not importable in the system Python",
                "Siconos, which docs/howto/run-a-peer.md runs")
