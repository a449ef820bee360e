"""Exudyn (PyPI ``exudyn``, in daebench's environment) runs a daebench case: run as
``python exudyn_worker.py`` with the request on stdin (:mod:`common`).

Method ``ga``: Exudyn's implicit generalized-α (``SolveDynamic``, fixed step h, spectral
radius ρ∞ = the request's ``rho_inf``, default 0.74 as daebench's ``genalpha``; Exudyn's
step adaptation off, so a step Newton cannot take fails the run; modified Newton at Exudyn's
default tolerances, but for the hub–beam's absolute one, set above its axial forces'
round-off). Cases:

* the ``pendulum`` model: a mass point (``MassPoint2D``) held by a ``DistanceConstraint``
  (index 3, Cartesian, as daebench's model), gravity as a coordinate load;
* the ``hub-beam`` model (FE discretization, no gravity, contact or damping): the hub an
  ``ObjectRigidBody2D`` pinned at the origin and driven by the scene's torque, the beam
  ``discretization.n`` ANCF cable elements (``ObjectANCFCable2D``, geometrically exact
  Euler–Bernoulli) clamped to the hub by a ``GenericJoint``. daebench's model keeps the
  deflection's coupling to first order, so the two agree to O((w/L)²) relative, not better;
* the ``ball`` model with ``contact.law = penalty``: a ``Mass1D`` and a
  ``CoordinateSpringDamper`` to the ground whose user function is the scene's law,
  F = max(0, k δ + c δ̇) for δ = x_w − x > 0 (daebench.core.contact), the like-for-like
  compliant contact (Exudyn has no Newton impact law in its implicit integrators).

The coordinates are written at every step (internally stored sensors).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402  (the worker's own folder)

DEFAULT_RHO = 0.74


def _pendulum(exu, items, mbs, p):
    m, l, g = float(p["pendulum.mass"]), float(p["pendulum.length"]), float(p["gravity.g"])
    th, om = math.radians(float(p["start.theta_deg"])), float(p["start.omega"])
    n_g = mbs.AddNode(items.NodePointGround(referenceCoordinates=[0, 0, 0]))
    n = mbs.AddNode(items.NodePoint2D(referenceCoordinates=[l * math.sin(th), -l * math.cos(th)],
                                      initialVelocities=[l * om * math.cos(th), l * om * math.sin(th)]))
    mbs.AddObject(items.MassPoint2D(physicsMass=m, nodeNumber=n))
    mbs.AddObject(items.DistanceConstraint(markerNumbers=[mbs.AddMarker(items.MarkerNodePosition(nodeNumber=n_g)),
                                                          mbs.AddMarker(items.MarkerNodePosition(nodeNumber=n))],
                                           distance=l))
    mbs.AddLoad(items.LoadCoordinate(markerNumber=mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=n, coordinate=1)),
                                     load=-m * g))
    pos = mbs.AddSensor(items.SensorNode(nodeNumber=n, outputVariableType=exu.OutputVariableType.Position,
                                         storeInternal=True))

    def rows():
        d = mbs.GetSensorStoredData(pos)
        return [(t, math.degrees(math.atan2(x, -y)), x, y) for t, x, y, _ in d]
    return ["t", "theta_deg", "x", "y"], rows, None, None


def _ball(exu, items, mbs, p):
    if p["contact.law"] != "penalty" or not p.get("effects.contact", True):
        raise common.Refused("Exudyn's generalized-α has no Newton impact law: run the ball on the compliant law "
                             "both codes share (--set contact.law=penalty)")
    if float(p["spring.stiffness"]):
        raise common.Refused("the Exudyn adapter runs the ball without its spring (spring.stiffness = 0)")
    m, g, wall = float(p["ball.mass"]), float(p["gravity.g"]), float(p["contact.wall"])
    k, c = float(p["contact.penalty_stiffness"]), float(p["contact.penalty_damping"])
    n = mbs.AddNode(items.Node1D(referenceCoordinates=[0.0], initialCoordinates=[float(p["start.x"])],
                                 initialVelocities=[float(p["start.v"])]))
    mbs.AddObject(items.Mass1D(physicsMass=m, nodeNumber=n))
    n_g = mbs.AddNode(items.NodePointGround(referenceCoordinates=[wall, 0, 0]))
    mc = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=n, coordinate=0))
    mg = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=n_g, coordinate=0))

    def force(mbs_, t, item, u, u_t, *_):
        # u = x − x_w (the gap), the spring force acts against u; the law pushes the gap open only
        return min(0.0, k * u + c * u_t) if u < 0.0 else 0.0

    mbs.AddObject(items.CoordinateSpringDamper(markerNumbers=[mg, mc], stiffness=0.0, damping=0.0,
                                               springForceUserFunction=force))
    mbs.AddLoad(items.LoadCoordinate(markerNumber=mc, load=-m * g))
    sx = mbs.AddSensor(items.SensorNode(nodeNumber=n, outputVariableType=exu.OutputVariableType.Coordinates,
                                        storeInternal=True))
    sv = mbs.AddSensor(items.SensorNode(nodeNumber=n, outputVariableType=exu.OutputVariableType.Coordinates_t,
                                        storeInternal=True))

    def rows():
        x, v = mbs.GetSensorStoredData(sx), mbs.GetSensorStoredData(sv)
        return [(a[0], a[1], b[1], a[1] - wall) for a, b in zip(x, v)]

    def impacts(rs):   # a penetration episode starts where the gap closes
        return [(rs[i][0], 0) for i in range(1, len(rs)) if rs[i][3] < 0.0 <= rs[i - 1][3]]
    return ["t", "x", "v", "gap"], rows, impacts, None


def _hub_beam(exu, items, mbs, p):
    """The hub (``ObjectRigidBody2D``, pinned at the origin, the scene's drive torque) and
    the beam as ``discretization.n`` ANCF cable elements (``Cable2D``: Euler–Bernoulli,
    geometrically exact, so axial stretch and foreshortening are in it), its first node
    clamped to the hub at radius a by a ``GenericJoint`` (both positions and the rotation)."""
    wanted = {"effects.axial": True, "effects.foreshortening": True, "effects.damping": False,
              "effects.contact": False, "effects.gravity": False, "start.omega": 0.0}
    if p["discretization.kind"] != "fem":
        raise common.Refused(f"the Exudyn adapter builds the beam of discretization.n finite elements: "
                             f"discretization.kind = 'fem' only (the scene has {p['discretization.kind']!r})")
    for key, value in wanted.items():
        if p[key] != value:
            raise common.Refused(f"the Exudyn adapter runs the hub-beam model with {key} = {value} only (its "
                                 f"geometrically exact cable has stretch and foreshortening built in; the scene "
                                 f"has {p[key]!r})")
    L, S, inertia = float(p["beam.length"]), float(p["beam.area"]), float(p["beam.inertia"])
    rho, E, a = float(p["beam.density"]), float(p["beam.modulus"]), float(p["hub.radius"])
    tau0, period = float(p["torque.tau0"]) if p["effects.torque"] else 0.0, float(p["torque.period"])
    th = math.radians(float(p["start.theta_deg"]))
    c, s = math.cos(th), math.sin(th)
    hub = mbs.AddNode(items.NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, th]))
    o_hub = mbs.AddObject(items.ObjectRigidBody2D(mass=1.0, inertia=float(p["hub.inertia"]),
                                                  nodeNumber=hub))
    ground = mbs.AddNode(items.NodePointGround(referenceCoordinates=[0, 0, 0]))
    for k in (0, 1):    # the hinge: the hub's centre held at the origin
        mbs.AddObject(items.CoordinateConstraint(markerNumbers=[
            mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0)),
            mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=hub, coordinate=k))]))
    m_hub = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=o_hub, localPosition=[a, 0.0, 0.0]))

    def drive(mbs_, t, load):
        return [0.0, 0.0, tau0 * math.sin(2.0 * math.pi * t / period) if t <= period else 0.0]

    mbs.AddLoad(items.LoadTorqueVector(markerNumber=mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=o_hub)),
                                       loadVector=[0, 0, 0], loadVectorUserFunction=drive))
    n_el = int(p["discretization.n"])
    nodes = [mbs.AddNode(items.NodePoint2DSlope1(referenceCoordinates=[(a + k * L / n_el) * c, (a + k * L / n_el) * s,
                                                                       c, s])) for k in range(n_el + 1)]
    for k in range(n_el):
        mbs.AddObject(items.ObjectANCFCable2D(nodeNumbers=[nodes[k], nodes[k + 1]], physicsLength=L / n_el,
                                              physicsMassPerLength=rho * S, physicsBendingStiffness=E * inertia,
                                              physicsAxialStiffness=E * S))
    mbs.AddObject(items.GenericJoint(markerNumbers=[m_hub, mbs.AddMarker(items.MarkerNodeRigid(nodeNumber=nodes[0]))],
                                     constrainedAxes=[1, 1, 0, 0, 0, 1]))
    sq = mbs.AddSensor(items.SensorNode(nodeNumber=hub, outputVariableType=exu.OutputVariableType.Coordinates,
                                        storeInternal=True))
    sv = mbs.AddSensor(items.SensorNode(nodeNumber=hub, outputVariableType=exu.OutputVariableType.Coordinates_t,
                                        storeInternal=True))
    tip = mbs.AddSensor(items.SensorNode(nodeNumber=nodes[-1], outputVariableType=exu.OutputVariableType.Position,
                                         storeInternal=True))

    def rows():
        out = []
        for q, v, r in zip(mbs.GetSensorStoredData(sq), mbs.GetSensorStoredData(sv), mbs.GetSensorStoredData(tip)):
            phi = th + q[3]       # the node's coordinates are displacements from its reference
            x, y = r[1], r[2]
            out.append((q[0], math.degrees(phi), v[3], x, y, -math.sin(phi) * x + math.cos(phi) * y))
        return out
    # the axial forces' round-off, ε·EA·(a + L)/ℓ (measured 1.7× that: 6e-8 N here), is far above
    # Exudyn's default 1e-10: Newton stalls there; 100× it bounds the deflection's error by
    # ≈ tol·ℓ³/EI (3e-9 m on hub-beam)
    floor = 2.220446049250313e-16 * E * S * (a + L) / (L / n_el)
    return ["t", "theta_deg", "omega", "tip_x", "tip_y", "tip_w2"], rows, None, 100.0 * floor


MODELS = {"pendulum": _pendulum, "ball": _ball, "hub-beam": _hub_beam}


def run(req: dict) -> None:
    import exudyn as exu
    from exudyn import itemInterface as items

    sheet = req["sheet"]
    if sheet["model"] not in MODELS:
        raise common.Refused(f"the Exudyn adapter runs the models {', '.join(MODELS)}; case '{sheet['case']}' is "
                             f"model '{sheet['model']}'")
    p = common.values(sheet)
    t_end, h = float(sheet["time"]["t_end"]), float(req["h"])
    n = common.steps_of(t_end, h)
    rho = float(req.get("rho_inf", DEFAULT_RHO))
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    columns, rows, impacts, newton_abs = MODELS[sheet["model"]](exu, items, mbs, p)
    mbs.Assemble()
    sim = exu.SimulationSettings()
    sim.timeIntegration.numberOfSteps = n
    sim.timeIntegration.endTime = t_end
    sim.timeIntegration.generalizedAlpha.spectralRadius = rho
    sim.timeIntegration.newton.useModifiedNewton = True
    if newton_abs is not None:
        sim.timeIntegration.newton.absoluteTolerance = newton_abs
    sim.timeIntegration.adaptiveStep = False     # the fixed step asked for: a step Newton cannot take fails the run
    sim.timeIntegration.verboseMode = 0
    sim.solutionSettings.writeSolutionToFile = False
    sim.solutionSettings.sensorsWritePeriod = h
    sim.displayComputationTime = False
    sim.displayStatistics = False
    _, cpu = common.timed(lambda: exu.SolveDynamic(mbs, sim))
    rs = rows()
    common.write(req, columns, rs, impacts(rs) if impacts else None,
                 {"cost_s": repr(cpu), "steps": n, "code": f"Exudyn {exu.__version__}",
                  "method": f"generalized-α (ρ∞ = {rho:g}, modified Newton, h = {h!r} s)",
                  "cost": "CPU time of SolveDynamic in the peer's process (time.process_time)", "h": repr(h)})


if __name__ == "__main__":
    common.main(run)
