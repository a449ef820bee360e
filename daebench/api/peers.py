"""Peer codes run on a case and scored (`daebench peer`): Siconos and Exudyn build the exported
case in their own process (:mod:`daebench.peers`); each run's file is scored by
:func:`daebench.api.external.score`, as any other code's file is."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

from daebench import peers as _peers
from daebench.api.catalogue import SceneLike, load_scene
from daebench.api.external import score
from daebench.harness.analysis.evidence import fitted_order
from daebench.harness.files import jsonable
from daebench.workflows.export import case_sheet
from daebench.workflows.score import ScoreResult, Source

PeerFailed = _peers.PeerFailed
PeerUnavailable = _peers.PeerUnavailable


@dataclass(frozen=True)
class PeerResult:
    """A peer's runs on a case (:class:`daebench.peers.PeerRun`, one per step) and their scores."""

    peer: str
    runs: tuple[_peers.PeerRun, ...]
    scores: tuple[ScoreResult, ...]

    def rows(self) -> list[dict[str, Any]]:
        """One scored row per run."""
        return [s.row for s in self.scores]

    def orders(self, measure: str) -> tuple[list[float], float]:
        """The observed order of ``measure`` between each run and the next coarser one (NaN
        for the first), and the least-squares order over all runs (NaN for fewer than two)."""
        hs = [r.h for r in self.runs]
        es = [float(row.get(measure, math.nan)) for row in self.rows()]
        pairs = [math.nan] + [math.log(e0 / e1) / math.log(h0 / h1) if min(e0, e1) > 0 and h0 != h1 else math.nan
                              for h0, h1, e0, e1 in zip(hs, hs[1:], es, es[1:])]
        ok = [(h, e) for h, e in zip(hs, es) if math.isfinite(e) and e > 0]
        return pairs, fitted_order(*zip(*ok)) if len(ok) > 1 else math.nan

    def as_json(self) -> str:
        return json.dumps(jsonable([{**s.row, "file": str(r.file), "cpu_s_peer": r.cpu_s}
                                    for r, s in zip(self.runs, self.scores)]), default=str)


def peer_names() -> list[str]:
    """The peers `daebench peer --code` takes."""
    return list(_peers.PEERS)


def peer_sources(scene: SceneLike, codes: Sequence[str], steps: Sequence[float] | None = None, *,
                 overrides: Iterable[str] | dict[str, Any] | None = None,
                 out: str | Path | None = None) -> list[Source]:
    """Run each peer of ``codes`` on ``scene`` at ``steps`` [s] (default: each peer's own steps
    for the case) and give their files as :class:`Source` values (the impacts file, the cost
    and steps the peer's process measured), as :func:`daebench.compare` includes them.

    Raises
    ------
    daebench.peers.PeerUnavailable, daebench.peers.PeerRefused
        A peer that is not installed (the install command named) or that does not run the case;
        before any peer has run.
    """
    sc = load_scene(scene, overrides)
    chosen = [_peers.get_peer(c) for c in codes]
    plans = [(p, tuple(steps) if steps else p.steps_for(sc)) for p in chosen]
    for p, _ in plans:
        p.python()   # every peer found before any runs
    sheet = case_sheet(sc)
    out_runs = [r for p, hs in plans for r in _peers.run_peer(p, sc, hs, out, sheet)]
    return [_source(r) for r in out_runs]


def _source(r: _peers.PeerRun) -> Source:
    return Source(r.file, str(r.impacts) if r.impacts is not None else None, r.peer, r.cpu_s, r.steps)


def peer(scene: SceneLike, code: str, steps: Sequence[float] | None = None, *,
         overrides: Iterable[str] | dict[str, Any] | None = None, reference: str = "compute",
         progress: bool = False, out: str | Path | None = None, write: bool = True) -> PeerResult:
    """Run the peer ``code`` (``siconos-mj``, ``siconos-ed``, ``exudyn-ga``) on ``scene`` at each
    fixed step of ``steps`` [s] (default: the peer's own steps for the case), in the peer's own
    process, and score each file it writes with :func:`daebench.score`.

    Parameters
    ----------
    scene, overrides : the case, as for :func:`daebench.run`
    code : the peer (:func:`peer_names`)
    steps : fixed steps [s]; each must divide t_end
    reference, progress : as for :func:`daebench.score`
    out : folder of the peer's files (default results/peers/<case>-<hash8>); the scored rows go
        where :func:`daebench.score` writes them (``write``)

    Returns
    -------
    PeerResult

    Raises
    ------
    daebench.peers.PeerUnavailable
        The peer code is not installed: the message names the install command.
    daebench.peers.PeerRefused
        The peer does not run this case, law or step.
    """
    sc = load_scene(scene, overrides)
    p = _peers.get_peer(code)
    runs = _peers.run_peer(p, sc, tuple(steps) if steps else p.steps_for(sc), out)
    scores = [score(sc, r.file, impacts=str(r.impacts) if r.impacts is not None else None, label=r.peer,
                    cost_s=r.cpu_s, steps=r.steps, reference=reference, progress=progress, write=write)
              for r in runs]
    return PeerResult(p.name, tuple(runs), tuple(scores))
