"""Peer codes run on daebench's cases: an adapter builds the exported case
(:func:`daebench.workflows.export.case_sheet`) in another code, runs it in that code's own
process and interpreter, and writes the file `daebench score` reads — the case's observables
at every step, the impacts beside it (``<file>-impacts.csv``) and the CPU time of the peer's
run, measured in the peer's process. One module per code (:mod:`.siconos`, :mod:`.exudyn`),
each optional and found at run time: a peer that is not installed is a
:class:`~daebench.peers.base.PeerUnavailable` refusal naming its install command. The
workers (:mod:`daebench.peers.workers`) run outside daebench and import none of it.

May import: :mod:`daebench.workflows` and the layers below it.
"""

from daebench.peers.base import Peer, PeerFailed, PeerRefused, PeerRun, PeerUnavailable, run_peer
from daebench.peers.exudyn import EXUDYN_GA
from daebench.peers.siconos import SICONOS_ED, SICONOS_MJ

#: every peer by the name `daebench peer --code` takes
PEERS: dict[str, Peer] = {p.name: p for p in (SICONOS_MJ, SICONOS_ED, EXUDYN_GA)}


def get_peer(name: str) -> Peer:
    """The peer called ``name``; a :class:`PeerRefused` naming the choices otherwise."""
    if name not in PEERS:
        raise PeerRefused(f"unknown peer '{name}'; choose one of {', '.join(PEERS)}")
    return PEERS[name]


__all__ = ["PEERS", "Peer", "PeerRun", "PeerRefused", "PeerFailed", "PeerUnavailable", "get_peer", "run_peer"]
