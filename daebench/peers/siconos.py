"""Siconos (the Debian package ``python3-siconos``, for the system Python): Moreau–Jean time
stepping (``siconos-mj``) and event-driven LSODAR (``siconos-ed``) on the ball model's cases
and Moreau–Jean on ``slider-crank-clearance`` in Siconos' plugin formulation (compiled C
functions: :mod:`daebench.peers.workers.siconos_slidercrank`);
:mod:`daebench.peers.workers.siconos_worker` says what each does and what Siconos' Python
layer does not give."""

from __future__ import annotations

from daebench.peers.base import Peer, system_python

INSTALL = "apt-get install python3-siconos"

SICONOS_MJ = Peer("siconos-mj", "Siconos", "mj", "siconos_worker.py", "siconos.kernel", INSTALL, system_python,
                  {"ball": (1e-3, 5e-4, 2.5e-4), "spring-wall": (1e-3, 5e-4, 2.5e-4),
                   "slider-crank-clearance": (4e-5, 2e-5, 1e-5, 5e-6)})
SICONOS_ED = Peer("siconos-ed", "Siconos", "ed", "siconos_worker.py", "siconos.kernel", INSTALL, system_python,
                  {"ball": (1e-2,), "spring-wall": (1e-2,)})
