"""Shape-function bases and the tables the hub–beam kernels read.

A discretization of the beam supplies only shape functions: axial ``Φx`` (for the
stretch ``w1 = Φx·A``) and transverse ``Φy`` (for the deflection ``w2 = Φy·B``),
both satisfying the clamped root conditions. Everything else (quadrature, the
foreshortening integrals ``H(x) = ∫₀ˣ Φy′ᵀΦy′ dξ``, the tables at the tip and the
contact point) is built from them here, once per scene, by :func:`tabulate`.

Builder interface
-----------------
A builder is a function ``(length, n, axial) -> ShapeBasis`` registered in
:data:`BUILDERS` under the scene's ``discretization.kind``. A :class:`ShapeBasis`
exposes

* ``n_axial``, ``n_transverse`` — number of axial and transverse coordinates;
* ``breakpoints`` — increasing panel edges from 0 to L; the shapes must be smooth
  (C∞) inside every panel (element edges for finite elements, background cells for
  meshfree, a uniform grid for global modes), so Gauss rules on panels are accurate;
* ``points_per_panel`` — Gauss–Legendre points per panel;
* ``evaluate(x) -> ShapeValues`` — Φx, Φx′, Φy, Φy′, Φy″ at arbitrary points;
* ``axial_names``, ``transverse_names`` — coordinate names.

:func:`tabulate` turns a basis into :class:`ShapeTables`: values and weights at
the quadrature points, the same (plus ``H``) at a few extra material points.
The meshfree builder (:mod:`daebench.models.meshfree`) adds a third ``ShapeBasis``.

Cantilever modes in a cancellation-free form
--------------------------------------------
The clamped–free mode ``φ = cosh βx − cos βx − σ(sinh βx − sin βx)`` with
``σ = (cosh βL + cos βL)/(sinh βL + sin βL)`` cancels catastrophically for large
βL (cosh βL ≈ 1e13 at mode 10). Splitting ``cosh − σ sinh`` into exponentials,

    φ(x) = c₁ e^{β(x−L)} + ½(1+σ) e^{−βx} − cos βx + σ sin βx,
    c₁ = ½(1−σ) e^{βL} = (sin βL − cos βL − e^{−βL}) / (1 − e^{−2βL} + 2 e^{−βL} sin βL),

every term is O(1) and ``1 − σ = 2 e^{−βL} c₁`` is computed without subtracting
nearly equal numbers. Normalization: ``∫₀ᴸ Φy_i Φy_j dx = L δ_ij`` (dimensionless
shapes, unit mean square; the tip value is ±2, B in metres). The roots βL of
``cos βL cosh βL = −1`` are solved as ``cos z + sech z = 0`` by Newton's method,
which is well conditioned for every mode.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

MAX_MODES = 12
MAX_ELEMENTS = 500
# Global modes: composite Gauss–Legendre on a fixed grid, independent of N, chosen so
# that mode-12 mass and stiffness integrals are exact to ~1e-14 (tests/models/test_shapes.py).
MODE_PANELS = 5
MODE_POINTS_PER_PANEL = 16
# Hermite cubics: integrands are polynomials of degree ≤ 10 per element (with the
# foreshortening terms), so 6 Gauss points per element integrate them exactly.
FEM_POINTS_PER_ELEMENT = 6


@dataclass(frozen=True)
class ShapeValues:
    """Shape functions and derivatives at m points: axial (m, nA), transverse (m, nB)."""

    phx: np.ndarray
    dphx: np.ndarray
    phy: np.ndarray
    dphy: np.ndarray
    ddphy: np.ndarray


class ShapeBasis(Protocol):
    kind: str
    length: float
    n_axial: int
    n_transverse: int
    breakpoints: np.ndarray
    points_per_panel: int
    axial_names: tuple[str, ...]
    transverse_names: tuple[str, ...]

    def evaluate(self, x: np.ndarray) -> ShapeValues: ...


@dataclass(frozen=True)
class ShapeTables:
    """Everything the kernels need about the shapes, computed once per scene.

    ``x``, ``w``: quadrature points and weights on [0, L]; ``at``: shape values there;
    ``H``: foreshortening matrices at the quadrature points (nq, nB, nB) or ``None``;
    ``points``: extra material points (tip, contact point), ``at_points`` and
    ``H_points`` the same there.
    """

    basis: ShapeBasis
    x: np.ndarray
    w: np.ndarray
    at: ShapeValues
    H: np.ndarray | None
    points: np.ndarray
    at_points: ShapeValues
    H_points: np.ndarray | None


# ---------------------------------------------------------------------------
# quadrature
def gauss_on(a: float | np.ndarray, b: float | np.ndarray, ng: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre points and weights mapped to [a, b] (broadcast over arrays of a, b:
    result shape (..., ng))."""
    xi, wi = np.polynomial.legendre.leggauss(ng)
    a = np.asarray(a, dtype=float)[..., None]
    b = np.asarray(b, dtype=float)[..., None]
    half = 0.5 * (b - a)
    return a + half * (xi + 1.0), half * wi


def composite_gauss(breakpoints: np.ndarray, ng: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre rule with ``ng`` points on each panel."""
    x, w = gauss_on(breakpoints[:-1], breakpoints[1:], ng)
    return x.ravel(), w.ravel()


def foreshortening_matrices(basis: ShapeBasis, x: np.ndarray) -> np.ndarray:
    """H(x) = ∫₀ˣ Φy′ᵀ Φy′ dξ for every x (nested Gauss: full panels below x, then
    the partial panel [edge, x] with its own mapped Gauss rule). Shape (m, nB, nB)."""
    x = np.asarray(x, dtype=float)
    bp = basis.breakpoints
    ng = basis.points_per_panel
    nB = basis.n_transverse
    # H at the panel edges, cumulative
    xp, wp = gauss_on(bp[:-1], bp[1:], ng)
    d = basis.evaluate(xp.ravel()).dphy.reshape(len(bp) - 1, ng, nB)
    panel = np.einsum("pk,pki,pkj->pij", wp, d, d)
    Hc = np.concatenate([np.zeros((1, nB, nB)), np.cumsum(panel, axis=0)])
    j = np.clip(np.searchsorted(bp, x, side="right") - 1, 0, len(bp) - 2)
    xs, ws = gauss_on(bp[j], x, ng)
    d = basis.evaluate(xs.ravel()).dphy.reshape(x.size, ng, nB)
    H = Hc[j] + np.einsum("mk,mki,mkj->mij", ws, d, d)
    return 0.5 * (H + H.transpose(0, 2, 1))


def tabulate(basis: ShapeBasis, points: np.ndarray, foreshortening: bool = True) -> ShapeTables:
    """Quadrature tables of a basis, and the same at the extra material ``points``."""
    x, w = composite_gauss(basis.breakpoints, basis.points_per_panel)
    points = np.asarray(points, dtype=float)
    return ShapeTables(
        basis=basis,
        x=x,
        w=w,
        at=basis.evaluate(x),
        H=foreshortening_matrices(basis, x) if foreshortening else None,
        points=points,
        at_points=basis.evaluate(points),
        H_points=foreshortening_matrices(basis, points) if foreshortening else None,
    )


# ---------------------------------------------------------------------------
# assumed modes
def cantilever_roots(n: int) -> np.ndarray:
    """The first n roots z = βL of cos z cosh z = −1, to machine precision.

    Solved as f(z) = cos z + sech z = 0 (bounded terms, well conditioned) by Newton
    from (2i − 1)π/2, where the root lies within e^{−z}.
    """
    z = (2.0 * np.arange(1, n + 1) - 1.0) * np.pi / 2.0
    z[0] = 1.875  # the first root is farther from π/2
    for _ in range(50):
        sech = 1.0 / np.cosh(z)
        f = np.cos(z) + sech
        df = -np.sin(z) - sech * np.tanh(z)
        dz = f / df
        z = z - dz
        if np.all(np.abs(dz) <= 4e-16 * z):
            break
    return z


@dataclass(frozen=True)
class ModalBasis:
    """Clamped–free bending modes (Φy, ∫Φy_iΦy_j = L δ_ij) and clamped–free axial
    modes sin((2i − 1)πx/2L) (Φx, unscaled)."""

    length: float
    n_modes: int
    axial: bool = True
    kind: str = "modes"
    points_per_panel: int = MODE_POINTS_PER_PANEL

    @property
    def n_axial(self) -> int:
        return self.n_modes if self.axial else 0

    @property
    def n_transverse(self) -> int:
        return self.n_modes

    @property
    def breakpoints(self) -> np.ndarray:
        return np.linspace(0.0, self.length, MODE_PANELS + 1)

    @property
    def roots(self) -> np.ndarray:
        """βᵢL."""
        return cantilever_roots(self.n_modes)

    @property
    def axial_names(self) -> tuple[str, ...]:
        return tuple(f"A{i + 1}" for i in range(self.n_axial))

    @property
    def transverse_names(self) -> tuple[str, ...]:
        return tuple(f"B{i + 1}" for i in range(self.n_transverse))

    def evaluate(self, x: np.ndarray) -> ShapeValues:
        L = self.length
        x = np.atleast_1d(np.asarray(x, dtype=float))[:, None]
        z = self.roots[None, :]
        beta = z / L
        emz = np.exp(-z)
        c1 = (np.sin(z) - np.cos(z) - emz) / (1.0 - emz * emz + 2.0 * emz * np.sin(z))
        one_minus_sigma = 2.0 * emz * c1
        sigma = 1.0 - one_minus_sigma
        half_one_plus_sigma = 1.0 - 0.5 * one_minus_sigma
        bx = beta * x
        e_plus = c1 * np.exp(beta * (x - L))       # ½(1−σ) e^{βx}, bounded
        e_minus = half_one_plus_sigma * np.exp(-bx)  # ½(1+σ) e^{−βx}
        c, s = np.cos(bx), np.sin(bx)
        phy = e_plus + e_minus - c + sigma * s
        dphy = beta * (e_plus - e_minus + s + sigma * c)
        ddphy = beta**2 * (e_plus + e_minus + c - sigma * s)
        m = x.shape[0]
        if self.axial:
            k = (2.0 * np.arange(1, self.n_modes + 1) - 1.0) * np.pi / (2.0 * L)
            phx = np.sin(k * x)
            dphx = k * np.cos(k * x)
        else:
            phx = np.zeros((m, 0))
            dphx = np.zeros((m, 0))
        return ShapeValues(phx, dphx, phy, dphy, ddphy)


def modal_basis(length: float, n: int, axial: bool = True) -> ModalBasis:
    if not 1 <= n <= MAX_MODES:
        raise ValueError(f"assumed modes need 1 ≤ N ≤ {MAX_MODES}, got {n}")
    return ModalBasis(float(length), int(n), bool(axial))


# ---------------------------------------------------------------------------
# finite elements
@dataclass(frozen=True)
class FEMBasis:
    """Uniform mesh of ``n_elements`` elements: Hermite cubics for w2 (nodal w and
    w′; the root node is clamped), linear elements for w1 (nodal u; root fixed).
    Coordinates: A = (u₁ … u_ne), B = (w₁, w₁′, …, w_ne, w_ne′) at nodes 1 … ne."""

    length: float
    n_elements: int
    axial: bool = True
    kind: str = "fem"
    points_per_panel: int = FEM_POINTS_PER_ELEMENT

    @property
    def n_axial(self) -> int:
        return self.n_elements if self.axial else 0

    @property
    def n_transverse(self) -> int:
        return 2 * self.n_elements

    @property
    def breakpoints(self) -> np.ndarray:
        return np.linspace(0.0, self.length, self.n_elements + 1)

    @property
    def axial_names(self) -> tuple[str, ...]:
        return tuple(f"u{i + 1}" for i in range(self.n_axial))

    @property
    def transverse_names(self) -> tuple[str, ...]:
        out: list[str] = []
        for i in range(self.n_elements):
            out += [f"w{i + 1}", f"dw{i + 1}"]
        return tuple(out)

    def evaluate(self, x: np.ndarray) -> ShapeValues:
        x = np.atleast_1d(np.asarray(x, dtype=float))
        ne = self.n_elements
        h = self.length / ne
        m = x.size
        e = np.clip(np.floor(x / h).astype(int), 0, ne - 1)
        xi = x / h - e
        r = np.arange(m)
        # Hermite cubics on the element, in the order (w_left, w'_left, w_right, w'_right)
        N = np.stack([1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3),
                      3 * xi**2 - 2 * xi**3, h * (-xi**2 + xi**3)], axis=1)
        dN = np.stack([-6 * xi + 6 * xi**2, h * (1 - 4 * xi + 3 * xi**2),
                       6 * xi - 6 * xi**2, h * (-2 * xi + 3 * xi**2)], axis=1) / h
        ddN = np.stack([-6 + 12 * xi, h * (-4 + 6 * xi), 6 - 12 * xi, h * (-2 + 6 * xi)], axis=1) / h**2
        nB = 2 * ne
        phy, dphy, ddphy = (np.zeros((m, nB)) for _ in range(3))
        for loc in range(4):
            # global index of local dof: left node e has dofs 2(e−1), 2(e−1)+1; node 0 is clamped
            g = 2 * (e - 1) + loc
            ok = g >= 0
            phy[r[ok], g[ok]] = N[ok, loc]
            dphy[r[ok], g[ok]] = dN[ok, loc]
            ddphy[r[ok], g[ok]] = ddN[ok, loc]
        nA = self.n_axial
        phx, dphx = np.zeros((m, nA)), np.zeros((m, nA))
        if self.axial:
            for loc, (val, der) in enumerate(((1 - xi, -np.ones(m) / h), (xi, np.ones(m) / h))):
                g = e - 1 + loc
                ok = g >= 0
                phx[r[ok], g[ok]] = val[ok]
                dphx[r[ok], g[ok]] = der[ok]
        return ShapeValues(phx, dphx, phy, dphy, ddphy)


def fem_basis(length: float, n: int, axial: bool = True) -> FEMBasis:
    if not 1 <= n <= MAX_ELEMENTS:
        raise ValueError(f"finite elements need 1 ≤ n ≤ {MAX_ELEMENTS}, got {n}")
    return FEMBasis(float(length), int(n), bool(axial))
