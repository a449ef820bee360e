"""The planar rigid body on an inclined ground (daebench's ``rigid2d`` model: cases
``block-incline``, ``rocking-block``, ``falling-rod``) in Siconos, with Coulomb friction.

The body is a ``LagrangianLinearTIDS`` in the model's coordinates q = (x, y, θ) of the
ground's frame (x up the slope, y normal to it), M = diag(m, m, J), gravity rotated into
that frame as the constant external force F = (−m g sin φ, −m g cos φ, 0). Each contact
point (p, r) of the body (a box's four corners, bottom two first; a rod's two ends) is one
``LagrangianScleronomousR`` with a normal and a tangential row, compiled C functions
(:mod:`siconos_plugins`) written from the model's docstring::

    h(q)   = (y + p sin θ + r cos θ,  x + p cos θ − r sin θ)     gap; the point's x
    ∇h(q)  = [[0, 1, p cos θ − r sin θ], [1, 0, −(p sin θ + r cos θ)]]

so ∇h q̇ = (U_N, U_T) are the model's normal and slip velocities; the points reach the C
functions through the system's ``z`` vector (p0, r0, p1, r1, …). Each relation carries
``NewtonImpactFrictionNSL(e, 0, μ, 2)`` (Newton's impact law in the normal row, Coulomb's
cone in 2-D); Moreau–Jean then solves one ``FrictionContact(2)`` per Newton iteration.
"""

from __future__ import annotations

import math

import siconos_plugins

SOURCE = r"""
#include <math.h>
/* z = (p0, r0, p1, r1, ...): the contact points in the body frame */
static void h(int k, double* q, double* y, double* z) {
  double p = z[2 * k], r = z[2 * k + 1], s = sin(q[2]), c = cos(q[2]);
  y[0] = q[1] + p * s + r * c;
  y[1] = q[0] + p * c - r * s;
}

/* the 2 x 3 Jacobian, column-major as Siconos stores its dense matrices */
static void G(int k, double* q, double* j, double* z) {
  double p = z[2 * k], r = z[2 * k + 1], s = sin(q[2]), c = cos(q[2]);
  j[0] = 0.0; j[1] = 1.0;
  j[2] = 1.0; j[3] = 0.0;
  j[4] = p * c - r * s; j[5] = -(p * s + r * c);
}

#define POINT(k) \
  extern "C" void h##k(unsigned int n, double* q, unsigned int ny, double* y, unsigned int nz, double* z) { h(k, q, y, z); } \
  extern "C" void G##k(unsigned int n, double* q, unsigned int ny, double* j, unsigned int nz, double* z) { G(k, q, j, z); }
POINT(0)
POINT(1)
POINT(2)
POINT(3)
"""

COLUMNS = ["t", "x", "y", "theta", "vx", "vy", "omega", "gap"]


def points(p: dict) -> list[tuple[float, float]]:
    """The body-frame contact points (p, r) as the model places them."""
    b, c = 0.5 * float(p["body.width"]), 0.5 * float(p["body.height"])
    if p["body.shape"] == "rod":
        return [(0.0, -c), (0.0, c)]
    return [(-b, -c), (b, -c), (b, c), (-b, c)]


def build(sk, np, sheet: dict, p: dict, t_end: float):
    """(nsds, ds, interactions): the case in Siconos, from the sheet's start in the model's
    coordinates."""
    import common

    if not p.get("effects.contact", True):
        raise common.Refused("the Siconos rigid2d adapter runs the body on its ground (effects.contact = true)")
    if p["contact.law"] not in ("constraint", "complementarity"):
        raise common.Refused(f"Siconos resolves contact by Newton's impact law with Coulomb friction; contact.law = "
                             f"'{p['contact.law']}' is a compliant law: run it with contact.law = constraint")
    m, g, phi = float(p["body.mass"]), float(p["gravity.g"]), math.radians(float(p["ground.incline"]))
    width = 0.0 if p["body.shape"] == "rod" else float(p["body.width"])
    J = m * (width ** 2 + float(p["body.height"]) ** 2) / 12.0
    coords = sheet["initial_state"]["coordinates"]
    q0, v0 = [float(c["q0"]) for c in coords], [float(c["v0"]) for c in coords]
    ds = sk.LagrangianLinearTIDS(q0, v0, np.diag([m, m, J]))
    ds.setFExtPtr(np.array([-m * g * math.sin(phi), -m * g * math.cos(phi), 0.0]))
    pts = points(p)
    ds.setzPtr(np.array([x for pt in pts for x in pt], float))
    stem = str(siconos_plugins.compiled(SOURCE, "Rigid2dPlugin"))
    e, mu = float(p["contact.restitution"]), float(p["contact.friction"])
    nsds = sk.NonSmoothDynamicalSystem(0.0, t_end)
    nsds.insertDynamicalSystem(ds)
    inters = []
    for k in range(len(pts)):
        rel = sk.LagrangianScleronomousR(f"{stem}:h{k}", f"{stem}:G{k}")
        inter = sk.Interaction(sk.NewtonImpactFrictionNSL(e, 0.0, mu, 2), rel)
        nsds.link(inter, ds)
        inters.append(inter)
    return nsds, ds, inters


def observables(q, v, p: dict) -> tuple[float, ...]:
    """x, y, theta, vx, vy, omega, gap (the lowest point's) as daebench's model defines them."""
    s, c = math.sin(q[2]), math.cos(q[2])
    gap = min(q[1] + pp * s + r * c for pp, r in points(p))
    return (q[0], q[1], q[2], v[0], v[1], v[2], gap)

