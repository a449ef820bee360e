"""Exudyn (PyPI ``exudyn``, daebench's extra ``exudyn``, in daebench's own environment):
generalized-α (``exudyn-ga``) on the pendulum, on the ball with the penalty law and on the
flexible hub–beam as ANCF cable elements (:mod:`daebench.peers.workers.exudyn_worker`)."""

from __future__ import annotations

from daebench.peers.base import Peer, this_python

EXUDYN_GA = Peer("exudyn-ga", "Exudyn", "ga", "exudyn_worker.py", "exudyn", "pip install 'daebench[exudyn]'",
                 this_python, {"pendulum": (1e-2, 5e-3, 2.5e-3, 1.25e-3), "ball": (1e-4, 5e-5, 2.5e-5),
                                  "hub-beam": (1e-2, 5e-3, 2.5e-3)})
