"""The conformance run of one integrator (`daebench verify`)."""

from __future__ import annotations

from typing import Any, Callable, Sequence

from daebench.workflows import verify as _verify
from daebench.workflows.verify import Check, VerifyResult


def verify(integrator: str, settings: dict[str, Any] | None = None, *, properties: Sequence[str] | str | None = None,
           progress: Callable[[str], None] | None = None, run_cap: float = _verify.PROPERTY_CAP,
           **keywords: Any) -> VerifyResult:
    """Measure what ``integrator`` declares on cases with exact solutions, one
    :class:`~daebench.workflows.verify.Check` per property (``order``, ``drift``, ``energy``,
    ``contract``, ``contact``: :mod:`daebench.workflows.verify`), each 'pass', 'fail' or
    'n/a' with the numbers.

    Parameters
    ----------
    integrator : a registered name (a class registered with :func:`daebench.register` too)
    settings : its settings (also as keywords); the step of each case is the check's own
    properties : only these (default: all); a string is one name or comma-separated names
    progress : called with each property's name before it runs
    run_cap : wall-time cap of each property [s] (a plugin's run in a child process, killed
        beyond it); a property over its cap fails

    Returns
    -------
    VerifyResult
        ``.ok`` (no property failed), ``.checks``, ``.lines()`` (what `daebench verify` prints).

    Raises
    ------
    ParamError
        An unknown integrator, setting or property, before anything runs.
    """
    return _verify.verify(integrator, {**(settings or {}), **keywords}, properties, progress, run_cap)


__all__ = ["verify", "VerifyResult", "Check"]
