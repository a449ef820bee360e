"""Meshes and finite-element matrices of planar elastic bodies (plane stress).

Assembly is scikit-fem's (Gustafsson & McBain 2020): the stiffness of small-strain
linear elasticity in plane stress, ``linear_elasticity`` with the plane-stress Lamé
parameters λ* = Eν/(1 − ν²), μ = E/(2(1 + ν)), times the thickness, on bilinear
quadrilaterals (``ElementQuad1``) or linear triangles (``ElementTriP1``); the mass is
scikit-fem's consistent mass ρ t ∫u·v, lumped by row sums (for these elements the
row sum, the HRZ and the nodal-area lumping coincide: a quadrilateral gives each of its
nodes a quarter of its mass, a triangle a third), which is the lumped-mass model of
the interactive-mode paper (docs/sources.md §D.1). The element matrices are kept as well: the
interactive-mode integrator assembles its local statics module from them.

Why scikit-fem: it is maintained, pure Python (NumPy/SciPy only, no compiler, no
system library), assembles any bilinear form on triangles and quadrilaterals and
returns element matrices (``Form.elemental``). SfePy and FEniCSx do the same with far
heavier installs (SfePy compiles extensions, FEniCSx needs PETSc/MPI), felupe targets
nonlinear solids; a body here is assembled once per scene, so scikit-fem's speed is
no concern (≈ 10 ms for 1 000 elements).

Meshes are generated from the scene's dimensions: graded tensor-product quadrilateral
grids for rectangles (:func:`rectangle`), and for a bar with a semicircular end
(:func:`rounded_bar`: the slider, the rod's hemispherical tip) a point set — a graded
grid in the straight part, concentric half rings in the cap whose radii are the grid's
ordinates, so that the two meet node to node — triangulated by Delaunay (the shape is
convex, so the triangulation of its points is the shape). Coordinates are in the
body's own frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import Delaunay
from skfem import Basis, BilinearForm, ElementQuad1, ElementTriP1, ElementVector, MeshQuad, MeshTri
from skfem.helpers import dot
from skfem.models.elasticity import linear_elasticity, plane_stress

GROWTH = 1.25      # largest ratio of neighbouring element sizes in a graded direction
SLIVER = 1e-6      # triangles below this fraction of the median area are joggle slivers


@dataclass
class Mesh2D:
    """Nodes ``p`` (N × 2, body frame, metres) and cells ``t`` (nel × 3 or 4)."""

    p: np.ndarray
    t: np.ndarray

    @property
    def quads(self) -> bool:
        return self.t.shape[1] == 4

    def area(self) -> float:
        x, y = self.p[self.t, 0], self.p[self.t, 1]
        a = 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1)
        return float(np.abs(a).sum())


@dataclass
class BodyMatrices:
    """What the kernels need of one body: lumped nodal masses, the stiffness (CSR over
    the body's 2N DOFs, node i ↔ DOFs 2i, 2i+1) and the element matrices."""

    mass: np.ndarray          # (N,) nodal masses [kg]
    K: "object"               # scipy.sparse CSR (2N × 2N) [N/m]
    elem_nodes: np.ndarray    # (nel, 4) node indices, −1 padded for triangles
    elem_K: np.ndarray        # (nel, 8, 8) element stiffness, DOFs (x, y) per element node


def graded(a: float, b: float, h_a: float, h_b: float | None = None) -> np.ndarray:
    """Points from a to b whose spacing grows geometrically (ratio ≤ GROWTH) from h_a at
    a up to h_b (default h_a: uniform), then stays at h_b; the last interval is
    stretched so that b is hit exactly."""
    h_b = h_a if h_b is None else h_b
    span = b - a
    if span <= 0.0:
        raise ValueError(f"empty interval [{a}, {b}]")
    steps, h = [], h_a
    while sum(steps) < span - 1e-12 * span:
        steps.append(h)
        h = min(h * GROWTH, h_b) if h_b > h_a else h_b
    total = sum(steps)
    if len(steps) > 1 and total - span > 0.5 * steps[-1]:
        steps.pop()
    steps = np.asarray(steps) * span / sum(steps)
    return a + np.concatenate([[0.0], np.cumsum(steps)])


def symmetric_graded(half: float, h_c: float, h_far: float) -> np.ndarray:
    """Points on [−half, half], finest (h_c) at 0 and growing to h_far at both ends."""
    right = graded(0.0, half, h_c, h_far)
    return np.concatenate([-right[:0:-1], right])


def rectangle(xs: np.ndarray, ys: np.ndarray) -> Mesh2D:
    """Tensor-product bilinear quadrilaterals on the grid xs × ys."""
    m = MeshQuad.init_tensor(np.asarray(xs, float), np.asarray(ys, float))
    return Mesh2D(m.p.T.copy(), m.t.T.copy())


def rounded_bar(length: float, width: float, h: float, h_tip: float | None = None,
                h_across: float | None = None) -> Mesh2D:
    """A bar [0, length − width/2] × [−width/2, width/2] closed by a semicircle of radius
    width/2 (total length ``length`` along x, tip at (length, 0)): linear triangles of
    size h along the bar, graded to h_tip towards the cap, whose arcs are divided at
    h_tip; ``h_across`` (default h_tip) spaces the grid across the width and the cap's
    rings."""
    R = 0.5 * width
    x_end = length - R
    if x_end <= 0.0:
        raise ValueError(f"a rounded bar needs length > width/2 (length {length}, width {width})")
    h_tip = h if h_tip is None else h_tip
    h_across = h_tip if h_across is None else h_across
    xs = x_end - graded(0.0, x_end, min(h_across, h), h)[::-1]   # fine at the cap
    xs[0] = 0.0
    ys = symmetric_graded(R, h_across, h_across)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = [np.column_stack([gx.ravel(), gy.ravel()])]
    for r in ys[ys > 1e-12 * R]:
        n_seg = 2 * max(1, int(math.ceil(0.5 * math.pi * r / h_tip)))   # even: a node on the axis
        phi = np.linspace(-0.5 * math.pi, 0.5 * math.pi, n_seg + 1)[1:-1]   # ends are grid points
        pts.append(np.column_stack([x_end + r * np.cos(phi), r * np.sin(phi)]))
    p = np.vstack(pts)
    tri = Delaunay(p, qhull_options="QJ")
    t = tri.simplices
    a = _areas(p, t)
    t = t[a > SLIVER * np.median(a)]
    used = np.unique(t)
    if used.size != p.shape[0]:
        raise ValueError(f"rounded_bar: {p.shape[0] - used.size} node(s) not in any triangle")
    return Mesh2D(p, _counter_clockwise(p, t))


def _areas(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    d1 = p[t[:, 1]] - p[t[:, 0]]
    d2 = p[t[:, 2]] - p[t[:, 0]]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def _counter_clockwise(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    d1 = p[t[:, 1]] - p[t[:, 0]]
    d2 = p[t[:, 2]] - p[t[:, 0]]
    cw = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] < 0.0
    t = t.copy()
    t[cw, 1], t[cw, 2] = t[cw, 2], t[cw, 1].copy()
    return t


def assemble(mesh: Mesh2D, E: float, nu: float, rho: float, thickness: float) -> BodyMatrices:
    """Plane-stress stiffness, lumped mass and element matrices of one body (scikit-fem)."""
    if mesh.quads:
        m, elem = MeshQuad(mesh.p.T, mesh.t.T), ElementQuad1()
    else:
        m, elem = MeshTri(mesh.p.T, mesh.t.T), ElementTriP1()
    basis = Basis(m, ElementVector(elem))
    if not np.allclose(m.p.T, mesh.p):
        raise ValueError("scikit-fem reordered the nodes")  # never seen; the DOF map below assumes not
    lam, mu = plane_stress(E, nu)
    form = linear_elasticity(lam * thickness, mu * thickness)
    K = form.assemble(basis).tocsr()

    @BilinearForm
    def mass_form(u, v, w):
        return rho * thickness * dot(u, v)

    masses = np.asarray(mass_form.assemble(basis).sum(axis=1)).ravel()
    ed = basis.element_dofs                       # (2 × nodes per element, nel)
    if not np.array_equal(ed[1::2], ed[0::2] + 1) or np.any(ed[0::2] % 2):
        raise ValueError("unexpected DOF layout from scikit-fem (expected x, y interleaved per node)")
    nodes = (ed[0::2] // 2).T
    nel, k = nodes.shape
    elem_nodes = np.full((nel, 4), -1, dtype=np.int64)
    elem_nodes[:, :k] = nodes
    elem_K = np.zeros((nel, 8, 8))
    elem_K[:, :2 * k, :2 * k] = form.elemental(basis).tolocal()
    return BodyMatrices(masses[0::2].copy(), K, elem_nodes, elem_K)


def smallest_element(md: Any) -> float:
    """The smallest element edge in the reference configuration (the local Newton
    tolerance's scale)."""
    en, X = md.elem_nodes, md.Xref.reshape(-1, 2)
    h = math.inf
    for k in range(en.shape[1]):
        a, b = en[:, k], en[:, (k + 1) % en.shape[1]]
        b = np.where(b < 0, en[:, 0], b)
        ok = a >= 0
        d = np.linalg.norm(X[a[ok]] - X[b[ok]], axis=1)
        d = d[d > 0.0]
        if d.size:
            h = min(h, float(d.min()))
    return h
