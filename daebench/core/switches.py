"""daebench's on/off environment switches (``DAEBENCH_COMPILED``, ``DAEBENCH_STACK_CHUNKS``):
one reading of them. Imports nothing but the standard library, so that the package can read a
switch before numpy or numba loads."""

from __future__ import annotations

import os

_OFF = ("0", "false", "no", "off")


def switched_off(name: str) -> bool:
    """Whether the environment turns ``name`` off (0, false, no or off; unset: on)."""
    return os.environ.get(name, "1").strip().lower() in _OFF
