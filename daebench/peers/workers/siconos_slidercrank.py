"""The slider-crank with a clearance (daebench's ``slider-crank`` model, case
``slider-crank-clearance``) in Siconos' plugin formulation: a ``LagrangianDS`` in the reduced
coordinates q = (θ1, θ2, θ3) whose mass matrix, gyroscopic-plus-gravity force and its two
Jacobians are compiled C functions, and one ``LagrangianScleronomousR`` per slider corner
(gap h(q) and its gradient, compiled too), as Siconos' own slider-crank example sets the
system up. The functions here are written from daebench's model docstring (M, Q, g, g_q) and
compiled once per source (:mod:`siconos_plugins`); the scene's values reach them through the
system's ``z`` vector.

Siconos' convention M q̈ + F_gyr(q, q̇) = p, so F_gyr = −Q (gravity included).
"""

from __future__ import annotations

import math
from pathlib import Path

#: z = (l1, l2, m1, m2, m3, J1, J2, J3, a, b, c, g)
SOURCE = r"""
#include <math.h>
#define L1 z[0]
#define L2 z[1]
#define M1 z[2]
#define M2 z[3]
#define M3 z[4]
#define J1 z[5]
#define J2 z[6]
#define J3 z[7]
#define A z[8]
#define B z[9]
#define C z[10]
#define G z[11]
#define KC ((0.5 * M2 + M3) * L1 * L2)
#define FA (0.5 * M1 + M2 + M3)
#define FB (0.5 * M2 + M3)

extern "C" void mass(unsigned int n, double* q, double* m, unsigned int nz, double* z) {
  for (int i = 0; i < 9; i++) m[i] = 0.0;
  m[0] = J1 + (0.25 * M1 + M2 + M3) * L1 * L1;
  m[1] = m[3] = KC * cos(q[1] - q[0]);
  m[4] = J2 + (0.25 * M2 + M3) * L2 * L2;
  m[8] = J3;
}

extern "C" void FGyr(unsigned int n, double* q, double* v, double* f, unsigned int nz, double* z) {
  double s12 = sin(q[0] - q[1]);
  f[0] = KC * s12 * v[1] * v[1] + FA * G * L1 * cos(q[0]);
  f[1] = -KC * s12 * v[0] * v[0] + FB * G * L2 * cos(q[1]);
  f[2] = 0.0;
}

extern "C" void jacobianFGyrq(unsigned int n, double* q, double* v, double* j, unsigned int nz, double* z) {
  double c12 = cos(q[0] - q[1]);
  for (int i = 0; i < 9; i++) j[i] = 0.0;
  j[0] = KC * c12 * v[1] * v[1] - FA * G * L1 * sin(q[0]);
  j[3] = -KC * c12 * v[1] * v[1];
  j[1] = -KC * c12 * v[0] * v[0];
  j[4] = KC * c12 * v[0] * v[0] - FB * G * L2 * sin(q[1]);
}

extern "C" void jacobianFGyrqDot(unsigned int n, double* q, double* v, double* j, unsigned int nz, double* z) {
  double s12 = sin(q[0] - q[1]);
  for (int i = 0; i < 9; i++) j[i] = 0.0;
  j[3] = 2.0 * KC * s12 * v[1];
  j[1] = -2.0 * KC * s12 * v[0];
}

/* corner k: body-frame (p, r) = (-a,+b), (+a,+b), (-a,-b), (+a,-b); side s = +1, +1, -1, -1 */
static void corner(int k, double* z, double* p, double* r, double* s) {
  *p = (k == 0 || k == 2) ? -A : A;
  *r = (k < 2) ? B : -B;
  *s = (k < 2) ? 1.0 : -1.0;
}

static void gap(int k, double* q, double* y, double* z) {
  double p, r, s;
  corner(k, z, &p, &r, &s);
  double yc = L1 * sin(q[0]) + L2 * sin(q[1]) + p * sin(q[2]) + r * cos(q[2]);
  y[0] = (B + C) - s * yc;
}

static void grad(int k, double* q, double* j, double* z) {
  double p, r, s;
  corner(k, z, &p, &r, &s);
  j[0] = -s * L1 * cos(q[0]);
  j[1] = -s * L2 * cos(q[1]);
  j[2] = -s * (p * cos(q[2]) - r * sin(q[2]));
}

#define CORNER(k) \
  extern "C" void g##k(unsigned int n, double* q, unsigned int ny, double* y, unsigned int nz, double* z) { gap(k, q, y, z); } \
  extern "C" void W##k(unsigned int n, double* q, unsigned int ny, double* j, unsigned int nz, double* z) { grad(k, q, j, z); }
CORNER(0)
CORNER(1)
CORNER(2)
CORNER(3)
"""


def plugin() -> Path:
    """The compiled plugin (:func:`siconos_plugins.compiled`), its path without ``.so``."""
    import siconos_plugins

    return siconos_plugins.compiled(SOURCE, "SliderCrankPlugin")


def build(sk, np, sheet: dict, p: dict, t_end: float):
    """(nsds, ds, interactions): the case as Siconos' plugin formulation sets it up, from the
    sheet's start in the model's coordinates."""
    if p.get("contact.friction", 0.0):
        import common
        raise common.Refused("the Siconos slider-crank runs frictionless (contact.friction = 0): the friction "
                             "variant needs NewtonImpactFrictionNSL relations with tangent rows, not built here")
    stem = str(plugin())
    coords = sheet["initial_state"]["coordinates"]
    q0, v0 = [float(c["q0"]) for c in coords], [float(c["v0"]) for c in coords]
    l1, l2 = float(p["crank.length"]), float(p["rod.length"])
    ds = sk.LagrangianDS(np.array(q0), np.array(v0))
    z = np.array([l1, l2, p["crank.mass"], p["rod.mass"], p["slider.mass"], p["crank.inertia"], p["rod.inertia"],
                  p["slider.inertia"], p["slider.half_length"], p["slider.half_width"], p["clearance.c"],
                  p["gravity.g"]], float)
    ds.setzPtr(z)
    ds.setComputeMassFunction(stem, "mass")
    ds.setComputeFGyrFunction(stem, "FGyr")
    ds.setComputeJacobianFGyrqFunction(stem, "jacobianFGyrq")
    ds.setComputeJacobianFGyrqDotFunction(stem, "jacobianFGyrqDot")
    nsds = sk.NonSmoothDynamicalSystem(0.0, t_end)
    nsds.insertDynamicalSystem(ds)
    inters = []
    for k in range(4):
        rel = sk.LagrangianScleronomousR(f"{stem}:g{k}", f"{stem}:W{k}")
        inter = sk.Interaction(sk.NewtonImpactNSL(float(p["contact.restitution"])), rel)
        nsds.link(inter, ds)
        inters.append(inter)
    return nsds, ds, inters


def observables(q, v, p: dict) -> tuple[float, ...]:
    """theta, omega, rod, psi, x, y, vx, vy, psidot, gap as daebench's model defines them."""
    l1, l2 = float(p["crank.length"]), float(p["rod.length"])
    a, b, c = float(p["slider.half_length"]), float(p["slider.half_width"]), float(p["clearance.c"])
    s1, c1, s2, c2 = math.sin(q[0]), math.cos(q[0]), math.sin(q[1]), math.cos(q[1])
    y3 = l1 * s1 + l2 * s2
    gaps = [(b + c) - s * (y3 + pp * math.sin(q[2]) + r * math.cos(q[2]))
            for pp, r, s in ((-a, b, 1.0), (a, b, 1.0), (-a, -b, -1.0), (a, -b, -1.0))]
    return (q[0], v[0], q[1], q[2], l1 * c1 + l2 * c2, y3, -l1 * s1 * v[0] - l2 * s2 * v[1],
            l1 * c1 * v[0] + l2 * c2 * v[1], v[2], min(gaps))


COLUMNS = ["t", "theta", "omega", "rod", "psi", "x", "y", "vx", "vy", "psidot", "gap"]
