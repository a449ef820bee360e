"""Siconos (the Debian package ``python3-siconos``, for the system Python): Moreau–Jean time
stepping (``siconos-mj``) and event-driven LSODAR (``siconos-ed``) on the ball model's cases;
Moreau–Jean on ``slider-crank-clearance`` in Siconos' plugin formulation (compiled C
functions: :mod:`daebench.peers.workers.siconos_slidercrank`) and on the rigid2d model's
``block-incline`` with Coulomb friction (:mod:`daebench.peers.workers.siconos_rigid2d`);
:mod:`daebench.peers.workers.siconos_worker` says what each does and what Siconos' Python
layer does not give."""

from __future__ import annotations

from daebench.peers.base import Peer, system_python

INSTALL = "apt-get install python3-siconos"

#: block-incline's steps: h = 1/n with the stop t_s = 0.40248 s half a step before the grid
#: point after it (frac(n t_s) = 0.50 ± 0.01). Moreau–Jean restarts the slide back at that
#: grid point, so its error is a2 times that lag; at equal lags the observed order is the
#: method's (at 1e-3, 5e-4, 2.5e-4 the lag is 0.52 h, 0.03 h, 0.06 h and the order reads 5, 0)
BLOCK_INCLINE_STEPS = tuple(1.0 / n for n in (1005, 2051, 4066))

SICONOS_MJ = Peer("siconos-mj", "Siconos", "mj", "siconos_worker.py", "siconos.kernel", INSTALL, system_python,
                  {"ball": (1e-3, 5e-4, 2.5e-4), "spring-wall": (1e-3, 5e-4, 2.5e-4),
                   "slider-crank-clearance": (4e-5, 2e-5, 1e-5, 5e-6), "block-incline": BLOCK_INCLINE_STEPS})
SICONOS_ED = Peer("siconos-ed", "Siconos", "ed", "siconos_worker.py", "siconos.kernel", INSTALL, system_python,
                  {"ball": (1e-2,), "spring-wall": (1e-2,)})
