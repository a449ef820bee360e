"""The model probe: a model's physics at a few states, recorded with every reference so
that a reference computed with another model is refused.

A changed scene has another hash (:mod:`daebench.harness.references.reference` keys its files on
it). A changed model with an unchanged scene — a formula or a constant in the code — is
what the probe catches: a reference's sidecar records, under ``model_probe``, the model's
energy terms, observables, mass matrix, applied force, gaps and bilateral constraints at
its initial state and at two states moved from it (:func:`probe`); a reference is refused
when today's model gives other values (beyond :data:`PROBE_RTOL` of each quantity's
largest entry: the round-off of a reordered sum passes, a physics change does not).
Changes to the solver or the driver are not probed (tests/harness/test_refship.py recomputes the
shipped reference and compares).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from daebench.core.observables import STATE_PREFIXES

PROBE_RTOL = 1e-9   # probe values agree to this fraction of each quantity's largest |entry|
PROBE_MOVES = (1, 2)  # the probe states: the start, and the start moved by 1× and 2× PROBE_STEP
PROBE_STEP = 0.01   # relative move of each coordinate and velocity (see _moved)


def _moved(x: np.ndarray, k: int, floor: float) -> np.ndarray:
    """x moved by k·PROBE_STEP of each |x_i| (alternating signs); a zero entry by
    k·PROBE_STEP·max(1e-3·max|x|, floor)."""
    a = np.abs(x)
    size = np.where(a > 0, a, max(1e-3 * float(np.max(a, initial=0.0)), floor))
    sign = np.where(np.arange(x.size) % 2 == 0, 1.0, -1.0)
    return x + k * PROBE_STEP * sign * size


def probe(system: Any) -> dict[str, list[float]]:
    """The model's physics at a few states: {quantity: values}, at the initial state and
    at it moved by PROBE_MOVES (energy terms and observables by name; M, Q row-major;
    gaps; bilateral constraints)."""
    q0, v0 = (np.asarray(x, float) for x in system.initial_state())
    out: dict[str, list[float]] = {}
    for k in (0,) + PROBE_MOVES:
        q, v = (q0, v0) if k == 0 else (_moved(q0, k, 1e-3), _moved(v0, k, 1e-2))
        t = 0.1 * k
        for name, vals in (("E", system.energy(q, v)), ("obs", system.observables(t, q, v))):
            for key in sorted(k for k in vals if not k.startswith(STATE_PREFIXES)):   # the probe's own input
                out.setdefault(f"{name}.{key}", []).append(float(vals[key]))
        out.setdefault("M", []).extend(np.asarray(system.mass(q), float).ravel().tolist())
        out.setdefault("Q", []).extend(np.asarray(system.applied_force(t, q, v), float).ravel().tolist())
        if system.n_contacts:
            out.setdefault("gap", []).extend(np.asarray(system.gap(q), float).ravel().tolist())
        if system.n_bilateral:
            out.setdefault("C", []).extend(np.asarray(system.constraint(t, q), float).ravel().tolist())
    return out


def differences(recorded: dict[str, list[float]], now: dict[str, list[float]]) -> list[str]:
    """What differs between a recorded probe and today's (empty: the same model)."""
    diff = [f"{k} {'appeared' if k in now else 'vanished'}" for k in sorted(set(recorded) ^ set(now))]
    for k in sorted(set(recorded) & set(now)):
        a, b = np.asarray(recorded[k], float), np.asarray(now[k], float)
        if a.shape != b.shape:
            diff.append(f"{k}: {a.size} values, now {b.size}")
            continue
        scale = float(np.nanmax(np.abs(b), initial=0.0))
        bad = ~((np.abs(a - b) <= PROBE_RTOL * scale) | (np.isnan(a) & np.isnan(b)))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            diff.append(f"{k}[{i}] was {a[i]:.12g}, is {b[i]:.12g}")
    return diff


def record(system: Any) -> dict[str, list[float]] | None:
    """:func:`probe` for a reference's sidecar; None (no probe: the reference is then not
    probe-checked, and not shippable) when the model cannot be evaluated at the moved
    states (it raises there)."""
    try:
        return probe(system)
    except (ArithmeticError, ValueError, NotImplementedError, np.linalg.LinAlgError):
        return None
