"""The data of one phase (:class:`PhaseData`): what the compiled phase functions read."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class PhaseData(NamedTuple):
    model: tuple            # the model's kernel data (a registered NamedTuple)
    nb: int                 # bilateral constraints (rows 0 … nb − 1)
    active: np.ndarray      # int64: closed contacts, constraint rows nb, nb + 1, …
    law: np.ndarray | None  # float64[5]: kind, K, exponent, c, v_ε (friction regularisation velocity); None: no continuous law
    engaged: np.ndarray     # float64 per contact: 1 = its continuous force acts in this phase
    chi: np.ndarray         # float64 per contact: hysteresis factor of the current episode
    gq: np.ndarray          # float64[n] scratch: one gap-Jacobian row
    work: np.ndarray        # float64[5n] scratch: contact-force differences, tangent rows
    friction: tuple         # coulomb.FrictionData: stick rows and slipping contacts (coulomb.NONE: none)
    lumped: np.ndarray | None  # float64[n]: a lumped model's constant diagonal mass (its kernel's M may have no rows); None: none
