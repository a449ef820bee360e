"""Meshfree shape functions for the hub–beam: element-free Galerkin with interpolating
generalized moving least squares (IGMLS), a third :class:`~daebench.models.shapes.ShapeBasis`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from daebench.models.shapes import ShapeValues


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
    ``breakpoints``). Measured on the clamped-beam frequencies (tests/models/test_meshfree.py):
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

