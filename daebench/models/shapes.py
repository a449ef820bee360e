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
A meshfree builder only has to add a third ``ShapeBasis``.

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
from typing import Callable, Protocol

import numpy as np

MAX_MODES = 12
MAX_ELEMENTS = 200
# Global modes: composite Gauss–Legendre on a fixed grid, independent of N, chosen so
# that mode-12 mass and stiffness integrals are exact to ~1e-14 (tests/test_shapes.py).
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


#: discretization.kind → builder (length, n, axial) -> ShapeBasis. "meshfree" comes later.
BUILDERS: dict[str, Callable[[float, int, bool], ShapeBasis]] = {
    "modes": modal_basis,
    "fem": fem_basis,
}


# ---------------------------------------------------------------------------
# meshfree: element-free Galerkin with interpolating generalized moving least squares
MAX_NODES = 60
MESHFREE_INFLUENCE = 2.5
MESHFREE_CELL_GAUSS = 4
MIN_INFLUENCE, MAX_INFLUENCE = 2.1, 6.0  # influence radius / nodal spacing
TRANSVERSE_ORDER = 3  # cubic basis for w2 (Hermite data: value and slope)
AXIAL_ORDER = 2       # quadratic basis for w1 (values only)


def cubic_spline_weight(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cubic-spline weight w(r) (support r ≤ 1) and dw/dr, d²w/dr² (C² at r = ½, 1)."""
    r = np.abs(r)
    inner, outer = r <= 0.5, (r > 0.5) & (r < 1.0)
    w = np.where(inner, 2 / 3 - 4 * r**2 + 4 * r**3, np.where(outer, 4 / 3 - 4 * r + 4 * r**2 - 4 / 3 * r**3, 0.0))
    dw = np.where(inner, -8 * r + 12 * r**2, np.where(outer, -4 + 8 * r - 4 * r**2, 0.0))
    ddw = np.where(inner, -8 + 24 * r, np.where(outer, 8 - 8 * r, 0.0))
    return w, dw, ddw


def _monomials(s: np.ndarray, order: int, scale: float) -> tuple[np.ndarray, ...]:
    """p = (1, s, …, s^order) at s = (x − c)/scale and its 1st–3rd x-derivatives (c fixed);
    each of shape s.shape + (order+1,)."""
    k = np.arange(order + 1)
    out = []
    for d in range(4):
        c = np.ones(order + 1)
        for j in range(d):
            c = c * (k - j)
        e = np.maximum(k - d, 0)
        out.append(c * s[..., None] ** e / scale**d)
    return tuple(out)


def gmls(x: np.ndarray, nodes: np.ndarray, radius: float, order: int, hermite: bool, slope_scale: float
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Generalized) moving least-squares shape functions and their first two derivatives.

    The local polynomial a·p fits, around each evaluation point x, the nodal data with
    the weights W_I(x) = w(|x − x_I|/radius): values d_I (always) and, with ``hermite``,
    slopes — the slope residual is scaled by ``slope_scale`` (the nodal spacing h) so
    that both kinds of data have the unit of length. With the data rows P (row p(x_I)
    and row h·p′(x_I) per node), A(x) = PᵀW(x)P, B(x) = PᵀW(x):

        φ(x) = p(x)ᵀ A⁻¹ B = γᵀB,   γ = A⁻¹p,
        γ′ = A⁻¹(p′ − A′γ),  γ″ = A⁻¹(p″ − 2A′γ′ − A″γ),
        φ′ = γ′ᵀB + γᵀB′,   φ″ = γ″ᵀB + 2γ′ᵀB′ + γᵀB″        (analytic, A′ = PᵀW′P, …).

    Conditioning: φ does not depend on which basis of the polynomial space is used, so
    at every evaluation point the monomials are centred there and scaled by h,
    s = (ξ − x)/h, held fixed while differentiating in x. (Monomials in x/L instead
    lose ~(L/h)⁶ in cond(A): a 1e-8 floor on the frequencies at 40 nodes.)

    Columns: per node (value, scaled slope) with ``hermite``, else one per node.
    Returns arrays (m, ncols) for φ, φ′, φ″.
    """
    x = np.asarray(x, dtype=float)
    h = slope_scale
    s_nodes = (nodes[None, :] - x[:, None]) / h                  # (m, n)
    pn, dpn, _, _ = _monomials(s_nodes, order, h)                # (m, n, k)
    if hermite:
        P = np.stack([pn, h * dpn], axis=2).reshape(x.size, -1, order + 1)  # (m, 2n, k)
        rep = 2
    else:
        P = pn
        rep = 1
    dx = x[:, None] - nodes[None, :]
    w, dw, ddw = cubic_spline_weight(dx / radius)
    sgn = np.sign(dx)
    W = np.repeat(w, rep, axis=1)                        # (m, ncols)
    W1 = np.repeat(dw * sgn / radius, rep, axis=1)       # dW/dx
    W2 = np.repeat(ddw / radius**2, rep, axis=1)         # d²W/dx²
    A = np.einsum("mck,mc,mcl->mkl", P, W, P)
    A1 = np.einsum("mck,mc,mcl->mkl", P, W1, P)
    A2 = np.einsum("mck,mc,mcl->mkl", P, W2, P)
    p, dp, ddp, _ = _monomials(np.zeros(x.size), order, h)   # at s = 0
    g = np.linalg.solve(A, p[..., None])[..., 0]
    g1 = np.linalg.solve(A, (dp - np.einsum("mkl,ml->mk", A1, g))[..., None])[..., 0]
    g2 = np.linalg.solve(A, (ddp - 2 * np.einsum("mkl,ml->mk", A1, g1)
                             - np.einsum("mkl,ml->mk", A2, g))[..., None])[..., 0]
    Pg, Pg1, Pg2 = (np.einsum("mck,mk->mc", P, gi) for gi in (g, g1, g2))
    phi = Pg * W
    dphi = Pg1 * W + Pg * W1
    ddphi = Pg2 * W + 2 * Pg1 * W1 + Pg * W2
    return phi, dphi, ddphi


@dataclass(frozen=True)
class MeshfreeBasis:
    """Element-free Galerkin shapes from *interpolating generalized moving least squares*.

    ``n_nodes`` equally spaced nodes x_I = I·h on [0, L] (the root node included),
    cubic-spline weight with influence radius ``influence``·h, Gauss quadrature with
    ``cell_gauss`` points on every background cell.

    Transverse field w2 (Hermite data). A *generalized* MLS (Atluri, Cho & Kim,
    Comput. Mech. 24 (1999) 334, "Analysis of thin beams ... with generalized moving
    least squares interpolations") fits the local cubic p = (1, s, s², s³) to the nodal
    deflections w_I *and* slopes θ_I (slope residual scaled by h):

        J(a) = Σ_I W_I(x) [(p(x_I)·a − w_I)² + h²(p′(x_I)·a − θ_I)²].

    Its shape functions reproduce cubics (values and slopes) but are not interpolating.
    The Kronecker-delta property for values *and* slopes is obtained by the
    transformation method (Chen, Wang, Hu & Chi, IJNME 2000; for interpolating MLS in
    structural problems see Garijo, Valencia & Gómez-Escalonilla, Acta Mech. 2015):
    with D the (2n × 2n) matrix of the GMLS shapes' nodal values and scaled slopes,
    D[(J, value), K] = φ_K(x_J), D[(J, slope), K] = h φ_K′(x_J), the interpolating shapes
    are Φ̂ = Φ D⁻¹ (derivatives Φ̂′ = Φ′D⁻¹, Φ̂″ = Φ″D⁻¹). Then w2(x_J) = w_J and
    w2′(x_J) = θ_J exactly, polynomial reproduction is kept (D maps the nodal data of a
    reproduced cubic to itself), and the clamped root w2(0) = w2′(0) = 0 is imposed by
    dropping the root's two columns. We chose this over singular weights
    (Lancaster–Šalkauskas), whose derivatives degrade near the nodes; the exact IGMLS
    variant of the Journal of Vibration Engineering 2017 paper was not available to us.
    The interpolating shapes are no longer compactly supported (D⁻¹ is dense), which
    costs nothing here: the hub–beam tables are dense anyway.

    Axial field w1: the same construction with values only and a quadratic basis
    (interpolating MLS); the root value is dropped (w1(0) = 0).

    Background cells: the node intervals, each split at the weight functions' knots
    x_I ± radius/2, x_I ± radius (where the shapes are only C²), so that every cell sees a
    smooth (rational) integrand; ``cell_gauss`` Gauss points per cell. With the default
    influence 2.5 the knots split each node interval into four cells. The two end cells
    are further graded toward the ends (boundary layer of the MLS shapes, see
    ``breakpoints``). Measured on the clamped-beam frequencies (tests/test_meshfree.py):
    with cells = node intervals, as usual in EFG, the quadrature error (integrand kinks
    inside cells) stalls the frequency error at ~1e-3; with these cells the frequencies
    converge at the h⁴ rate of cubic Hermite elements.

    Coordinates: A = (u₁ … u_{n−1}), B = (w₁, θ₁, …, w_{n−1}, θ_{n−1}) at nodes 1 … n−1,
    the same meaning and order as the finite elements' nodal coordinates.
    """

    length: float
    n_nodes: int
    axial: bool = True
    influence: float = MESHFREE_INFLUENCE
    cell_gauss: int = MESHFREE_CELL_GAUSS
    kind: str = "meshfree"

    @property
    def spacing(self) -> float:
        return self.length / (self.n_nodes - 1)

    @property
    def nodes(self) -> np.ndarray:
        return np.linspace(0.0, self.length, self.n_nodes)

    @property
    def radius(self) -> float:
        return self.influence * self.spacing

    @property
    def n_axial(self) -> int:
        return self.n_nodes - 1 if self.axial else 0

    @property
    def n_transverse(self) -> int:
        return 2 * (self.n_nodes - 1)

    @property
    def points_per_panel(self) -> int:
        return self.cell_gauss

    @property
    def breakpoints(self) -> np.ndarray:
        x, r, L = self.nodes, self.radius, self.length
        knots = np.concatenate([x, x - r, x + r, x - 0.5 * r, x + 0.5 * r])
        knots = np.unique(np.round(knots[(knots > 0.0) & (knots < L)] / L, 12)) * L
        bp = np.union1d(knots, [0.0, L])
        # drop slivers from rounding (cells shorter than 1e-9 h)
        keep = np.concatenate([[True], np.diff(bp) > 1e-9 * self.spacing])
        bp = bp[keep]
        bp[-1] = L
        # the end cells hold a boundary layer of the MLS shapes (Φ″ of the first node's
        # shape falls from ~5× its interior size within h/10 of the root, where few nodes
        # share the support): grade them toward the ends, 1/8, 1/4, 1/2 of the cell
        # (measured per-cell error of 4-point Gauss on ∫Φ″ᵀΦ″: 2.5e-2 → 1.2e-6)
        g = np.array([0.125, 0.25, 0.5])
        first, last = bp[1], bp[-2]
        return np.concatenate([[0.0], first * g, bp[1:-1], L - (L - last) * g[::-1], [L]])

    @property
    def axial_names(self) -> tuple[str, ...]:
        return tuple(f"u{i + 1}" for i in range(self.n_axial))

    @property
    def transverse_names(self) -> tuple[str, ...]:
        out: list[str] = []
        for i in range(1, self.n_nodes):
            out += [f"w{i}", f"dw{i}"]
        return tuple(out)

    def _raw(self, x: np.ndarray, hermite: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        order = TRANSVERSE_ORDER if hermite else AXIAL_ORDER
        return gmls(x, self.nodes, self.radius, order, hermite, self.spacing)

    def _transform(self, hermite: bool) -> np.ndarray:
        """D⁻¹ of the transformation method, slope columns rescaled from h·θ_I to θ_I:
        raw GMLS shapes @ T = interpolating shapes of every node (root included)."""
        phi, dphi, _ = self._raw(self.nodes, hermite)
        if hermite:
            h = self.spacing
            D = np.stack([phi, h * dphi], axis=1).reshape(2 * self.n_nodes, -1)
            T = np.linalg.inv(D)
            T[:, 1::2] *= h  # coordinate θ_I instead of h θ_I
            return T
        return np.linalg.inv(phi)

    def interpolating(self, x: np.ndarray, hermite: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Interpolating shapes of *all* nodes, root included (no boundary condition):
        (φ, φ′, φ″), columns (w₀, θ₀, w₁, θ₁, …) with ``hermite``, else (u₀, u₁, …)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        T = self._transform(hermite)
        return tuple(f @ T for f in self._raw(x, hermite))

    def evaluate(self, x: np.ndarray) -> ShapeValues:
        # clamped root: drop w₀, θ₀ (and u₀) — exact, by the Kronecker-delta property
        phy, dphy, ddphy = (f[:, 2:] for f in self.interpolating(x, True))
        if self.axial:
            phx, dphx = (f[:, 1:] for f in self.interpolating(x, False)[:2])
        else:
            phx = dphx = np.zeros((np.size(x), 0))
        return ShapeValues(phx, dphx, phy, dphy, ddphy)


def meshfree_basis(length: float, n: int, axial: bool = True, influence: float = MESHFREE_INFLUENCE,
                   cell_gauss: int = MESHFREE_CELL_GAUSS) -> MeshfreeBasis:
    """EFG/IGMLS basis on ``n`` nodes (root included); see :class:`MeshfreeBasis`."""
    if not 3 <= n <= MAX_NODES:
        raise ValueError(f"meshfree needs 3 ≤ n ≤ {MAX_NODES} nodes (root included), got {n}")
    # the quadratic axial fit needs three nodes inside the influence radius at the ends: > 2
    if not MIN_INFLUENCE <= influence <= MAX_INFLUENCE:
        raise ValueError(f"meshfree influence-domain factor must be in [{MIN_INFLUENCE}, {MAX_INFLUENCE}], "
                         f"got {influence}")
    if not 1 <= cell_gauss <= 16:
        raise ValueError(f"meshfree Gauss points per cell must be in [1, 16], got {cell_gauss}")
    return MeshfreeBasis(float(length), int(n), bool(axial), float(influence), int(cell_gauss))


BUILDERS["meshfree"] = meshfree_basis
#: extra scene keys ``discretization.<key>`` a builder takes as keyword arguments
BUILDER_OPTIONS: dict[str, tuple[str, ...]] = {"meshfree": ("influence", "cell_gauss")}
