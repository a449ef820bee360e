"""Planar elastic bodies on floating frames in node-to-segment contact — the model behind
the cases ``rod-wall``, ``rod-plate`` and ``slider-slot`` (seed 001, docs/sources.md §A–D).

A scene's layout module (:mod:`.rodwall`, :mod:`.rodplate`, :mod:`.sliderslot`) builds
its bodies (:class:`Body`: mesh from the scene's dimensions, material, thickness,
floating-frame nodes, initial placement and velocity), its master surfaces
(:class:`Surface`: polylines of body nodes or fixed points) and its contact points
(slave node → master surface), and :class:`PlanarBodies` assembles them once
(scikit-fem, :mod:`._planar_mesh`) into the compiled kernels of
:mod:`._planar_kernels` (physics, coordinates and conventions are documented there).

Contact treatments, selected per scene by ``contact.law``:

* ``constraint`` — ACM: each closed contact point is a constraint g = 0 of the
  index-3 DAE, with the Newton impact map (restitution e, default 0: the contact
  node's normal velocity is zeroed) at closing, through the event-driven driver;
* ``penalty`` — PFM: F = ε_N δ (+ c δ̇) per contact point, a continuous law;
* ``complementarity`` — the contacts are left to an integrator that resolves them
  itself: ``imm`` (the interactive-mode method, :mod:`daebench.integrators.imm`) or ``lcp``.

The candidate contact points are a fixed list per scene (each slave node paired with
the one master surface it can reach; the layouts say why that suffices).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import ModuleType
from typing import Callable

import numpy as np

from daebench.core.contact import ContactLaw, contact_schema
from daebench.core.linalg import Sparsity, band_order
from daebench.models import _planar_imm, _planar_kernels as pk
from daebench.models._planar_mesh import Mesh2D, assemble
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.core.system import KernelSystem

CONTACT = contact_schema(("constraint", "penalty", "complementarity"), penalty_stiffness=1e7)

CONTACT_SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        *CONTACT.params,
        Param("imm.radius", float, 0.0, "radius of the interactive-mode local region; 0: the layout's "
              "Hertz estimate of the contact radius (flat contact: the contact node's own elements)",
              low=0.0, high=1.0, unit="m"),
    )
}


check_contact = CONTACT.check  # the cross-key checks of the contact keys


@dataclass
class Body:
    """One flexible body: mesh in its own frame, plane-stress material, the two nodes of
    its floating frame (origin, axis), and its rigid placement and velocity at t = 0."""

    name: str
    mesh: Mesh2D
    E: float
    nu: float
    rho: float
    thickness: float
    frame: tuple[int, int]
    origin: tuple[float, float] = (0.0, 0.0)   # initial position of frame node a [m]
    angle: float = 0.0                          # initial rotation of the frame [rad]
    velocity: tuple[float, float] = (0.0, 0.0)  # uniform initial velocity [m/s]


@dataclass
class Surface:
    """A master polyline: each point is (body name, node) or a fixed (x, y); the body
    lies on the left of the traversal (outward normal to the right)."""

    points: list[tuple[str, int] | tuple[float, float]]


@dataclass
class Layout:
    bodies: list[Body]
    surfaces: list[Surface]
    contacts: list[tuple[str, int, int]]        # (slave body, slave node, surface index)
    observe: Callable[["PlanarBodies", np.ndarray, np.ndarray], dict[str, float]]
    imm_radius: float = 0.0                     # the layout's Hertz estimate [m]
    notes: dict[str, float] = field(default_factory=dict)
    #: mass added to nodes beyond their elements' lumped mass: (body, node, kg) — where a layout moves
    #: the inertia of massless contact nodes it condensed (mass redistribution, see :mod:`.rodwall`)
    added_mass: list[tuple[str, int, float]] = field(default_factory=list)
    #: the layout's own contact law, replacing the one the scene's contact keys name (None: the scene's)
    contact_law: ContactLaw | None = None


class PlanarBodies(KernelSystem):
    """Planar bodies, assembled once from a :class:`Layout` (module docstring)."""

    n_bilateral = 0
    power_free = True   # no damping, no drive: contact-law dissipation is the driver's

    def __init__(self, layout: Layout, scene: Scene):
        self.layout = layout
        self.bodies = layout.bodies
        offsets, start = {}, 0
        for b in self.bodies:
            offsets[b.name] = start
            start += b.mesh.p.shape[0]
        self.offsets = offsets
        N = start
        self.n = n = 2 * N
        mats = [assemble(b.mesh, b.E, b.nu, b.rho, b.thickness) for b in self.bodies]
        self.matrices = mats
        mass = np.concatenate([np.repeat(m.mass, 2) for m in mats])
        for bn, i, dm in layout.added_mass:
            mass[2 * (offsets[bn] + int(i)) + np.arange(2)] += dm
        Xref = np.zeros(n)
        body_nodes = np.zeros(len(self.bodies) + 1, np.int64)
        frame = np.zeros((len(self.bodies), 2), np.int64)
        theta_ref = np.zeros(len(self.bodies))
        rows, cols, vals = [], [], []
        elem_nodes, elem_K, elem_body = [], [], []
        for k, (b, m) in enumerate(zip(self.bodies, mats)):
            o = offsets[b.name]
            body_nodes[k + 1] = o + b.mesh.p.shape[0]
            a, c = b.frame
            rel = b.mesh.p - b.mesh.p[a]
            Xref[2 * o:2 * (o + rel.shape[0])] = rel.ravel()
            frame[k] = (o + a, o + c)
            theta_ref[k] = math.atan2(rel[c, 1], rel[c, 0])
            coo = m.K.tocoo()
            rows.append(coo.row + 2 * o)
            cols.append(coo.col + 2 * o)
            vals.append(coo.data)
            en = m.elem_nodes.copy()
            en[en >= 0] += o
            elem_nodes.append(en)
            elem_K.append(m.elem_K)
            elem_body.append(np.full(en.shape[0], k, np.int64))
        import scipy.sparse as sp
        K = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
        K.sum_duplicates()
        K.sort_indices()
        self.K = K
        elem_nodes = np.vstack(elem_nodes)
        node_body = np.repeat(np.arange(len(self.bodies)), np.diff(body_nodes)).astype(np.int64)
        ne_ptr, ne = _node_elements(elem_nodes, N)
        pts_node, pts_xy, surf_ptr = [], [], [0]
        for s in layout.surfaces:
            for p in s.points:
                if isinstance(p[0], str):
                    pts_node.append(offsets[p[0]] + int(p[1]))
                    pts_xy.append((0.0, 0.0))
                else:
                    pts_node.append(-1)
                    pts_xy.append((float(p[0]), float(p[1])))
            surf_ptr.append(len(pts_node))
        self.slaves = np.array([offsets[bn] + int(i) for bn, i, _ in layout.contacts], np.int64)
        surface = np.array([int(j) for _, _, j in layout.contacts], np.int64)
        self.n_contacts = len(self.slaves)
        self.data = pk.PlanarData(
            mass, Xref, body_nodes, frame, theta_ref, K.indptr.astype(np.int64), K.indices.astype(np.int64),
            K.data.copy(), np.zeros(n), np.zeros(self.n_contacts), self.slaves, surface,
            np.array(surf_ptr, np.int64), np.array(pts_node, np.int64), np.array(pts_xy, float).reshape(-1, 2),
            elem_nodes, np.concatenate(elem_K), np.concatenate(elem_body), node_body, ne_ptr, ne,
            np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
        law = scene["contact.law"]
        self.contact_model = law
        self.contact_restitution = float(scene["contact.restitution"])
        self.contact_law = layout.contact_law or CONTACT.law(scene, self.n_contacts)
        self.imm_radius = float(scene["imm.radius"]) or float(layout.imm_radius)
        self.coordinate_names = tuple(f"{c}{i}" for i in range(N) for c in "xy")
        self._sparsity: Sparsity | None = None

    # -- what integrators may ask ---------------------------------------------------------
    def local_statics_module(self) -> ModuleType:
        """The local statics module of the interactive-mode method (``imm``): the contact
        region's FE statics around each contact, written on this model's kernels."""
        return _planar_imm

    @property
    def lumped_mass(self) -> np.ndarray:
        """The constant diagonal of M; the mass_force kernel accepts an M with no rows
        (force only) — what :mod:`daebench.integrators.central` relies on."""
        return self.data.mass

    def sparsity(self) -> Sparsity:
        """The structure of the iteration matrices (:class:`daebench.core.linalg.Sparsity`):
        the stiffness couples nodes of an element only, so in the mesh's numbering (or its
        reverse Cuthill–McKee order) the DOFs form a band; the floating frames' DOFs couple
        with their whole body (θ depends on them) and form the border. M is diagonal and
        constant."""
        if self._sparsity is None:
            K = self.K.tocoo()
            nr, nc = K.row // 2, K.col // 2          # node blocks: all 2 × 2 components couple
            rows = np.concatenate([2 * nr + a for a in (0, 1) for _ in (0, 1)])
            cols = np.concatenate([2 * nc + b for _ in (0, 1) for b in (0, 1)])
            border = np.array([2 * node + c for node in self.data.frame.ravel() for c in (0, 1)], np.int64)
            order, bw = band_order(self.n, border, rows, cols)
            self._sparsity = Sparsity(order, self.n - np.unique(border).size, bw, bw, 0, True)
        return self._sparsity

    def node(self, body: str, i: int) -> int:
        """Global node number of node i of a body."""
        return self.offsets[body] + int(i)

    # -- bookkeeping ----------------------------------------------------------------------
    def strain_energy(self, q: np.ndarray) -> float:
        return float(pk.elastic_force(self.data, np.ascontiguousarray(q, float), np.empty(self.n)))

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"kinetic": 0.5 * float(np.sum(self.data.mass * v * v)), "elastic": self.strain_energy(q),
                "contact": self.contact_potential(q)}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        out = dict(self.layout.observe(self, q, v))
        if self.n_contacts:
            out["gap_min"] = float(np.min(self.gap(q)))
        out["F_imm"] = float(np.sum(self.data.lam))
        return out

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        q = np.zeros(self.n)
        v = np.zeros(self.n)
        for b in self.bodies:
            o = self.offsets[b.name]
            rel = b.mesh.p - b.mesh.p[b.frame[0]]
            c, s = math.cos(b.angle), math.sin(b.angle)
            x = b.origin[0] + c * rel[:, 0] - s * rel[:, 1]
            y = b.origin[1] + s * rel[:, 0] + c * rel[:, 1]
            q[2 * o:2 * (o + rel.shape[0])] = np.column_stack([x, y]).ravel()
            v[2 * o:2 * (o + rel.shape[0])] = np.tile(b.velocity, rel.shape[0])
        self.data.fc[:] = 0.0
        self.data.lam[:] = 0.0
        return q, v

    # -- helpers for layouts' observables ---------------------------------------------------
    def xy(self, q: np.ndarray, body: str, i: int) -> tuple[float, float]:
        k = self.node(body, i)
        return float(q[2 * k]), float(q[2 * k + 1])

    def body_momentum_velocity(self, v: np.ndarray, body: str) -> tuple[float, float]:
        """Centre-of-mass velocity of a body."""
        k = [b.name for b in self.bodies].index(body)
        lo, hi = 2 * self.data.body_nodes[k], 2 * self.data.body_nodes[k + 1]
        m = self.data.mass[lo:hi]
        return float(np.sum(m[0::2] * v[lo:hi:2]) / np.sum(m[0::2])), \
            float(np.sum(m[1::2] * v[lo + 1:hi:2]) / np.sum(m[1::2]))

    def body_angle(self, q: np.ndarray, body: str) -> float:
        k = [b.name for b in self.bodies].index(body)
        return float(pk.frame_angle(self.data, k, np.ascontiguousarray(q, float))[0])


def _node_elements(elem_nodes: np.ndarray, N: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR of node → elements containing it."""
    pairs = [(int(nd), e) for e, row in enumerate(elem_nodes) for nd in row if nd >= 0]
    pairs.sort()
    ptr = np.zeros(N + 1, np.int64)
    for nd, _ in pairs:
        ptr[nd + 1] += 1
    return np.cumsum(ptr).astype(np.int64), np.array([e for _, e in pairs], np.int64)


def hertz_line_halfwidth(force: float, thickness: float, radius: float, E1: float, nu1: float,
                         E2: float = math.inf, nu2: float = 0.0) -> float:
    """Half-width b of the contact of a cylinder (radius R, length = thickness) on a flat
    under force F (Johnson 1985, §4.2): b = √(4 F R / (π t E*)), 1/E* = Σ (1 − ν²)/E."""
    inv = (1.0 - nu1 ** 2) / E1 + (0.0 if math.isinf(E2) else (1.0 - nu2 ** 2) / E2)
    return math.sqrt(4.0 * force * radius * inv / (math.pi * thickness))
