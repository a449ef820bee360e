"""One rule for the names of an entry-point group, for integrators and models alike: each
name is provided once. daebench's own entry point keeps its name; among plugins the first
found keeps it; every other claim is refused, and the refusal says who keeps the name and
how to fix it (the registries list the refusals: `daebench list`)."""

from __future__ import annotations

from typing import Any, Callable, Iterable

BUILTIN = "daebench"   # the distribution whose entry points are the built-ins


def distribution(ep: Any) -> str:
    """The name of the distribution that declares entry point ``ep`` ("?" when unknown)."""
    return ep.dist.name if getattr(ep, "dist", None) is not None else "?"


def one_per_name(eps: Iterable[Any], kind: str, provider: Callable[[Any], str],
                 fix: str) -> tuple[dict[str, Any], list[str]]:
    """The entry points ``eps`` of one group, one per name (``{name: entry point}``, in the
    order found), and the refusals of the claims on a taken name: "``kind`` 'name' of
    ``provider(dropped)`` is refused: ``provider(kept)`` provides that name (…; ``fix``)"."""
    kept: dict[str, Any] = {}
    refused: list[str] = []
    for ep in eps:
        old = kept.get(ep.name)
        if old is not None:
            keep_old = distribution(old) == BUILTIN or distribution(ep) != BUILTIN
            keep, drop = (old, ep) if keep_old else (ep, old)
            refused.append(f"{kind} '{ep.name}' of {provider(drop)} is refused: {provider(keep)} provides that name "
                           f"(a plugin may not shadow a built-in or another plugin; {fix})")
            if keep_old:
                continue
            del kept[ep.name]
        kept[ep.name] = ep
    return kept, refused
