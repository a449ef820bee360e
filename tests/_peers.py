"""Skip markers for the tests that run real peer codes: skipped, with the install command,
where the peer is not installed."""

from __future__ import annotations

import pytest

from daebench.peers import PEERS, PeerUnavailable


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
