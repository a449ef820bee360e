"""Finite differences shared by the model tests (fixed absolute step, so tolerances
measured with it stay meaningful)."""

import numpy as np


def fd(fun, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences with a fixed absolute step (columns = ∂fun/∂x_j)."""
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        cols.append((np.asarray(fun(x + e)) - np.asarray(fun(x - e))) / (2 * h))
    return np.array(cols).T
