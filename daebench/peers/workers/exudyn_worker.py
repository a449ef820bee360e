"""Exudyn (PyPI ``exudyn``, in daebench's environment) runs a daebench case: run as
``python exudyn_worker.py`` with the request on stdin (:mod:`common`).

Method ``ga``: Exudyn's implicit generalized-α (``SolveDynamic``, fixed step h, spectral
radius ρ∞ = the request's ``rho_inf``, default 0.74 as daebench's ``genalpha``; modified
Newton at Exudyn's default tolerances). Cases:

* the ``pendulum`` model: a mass point (``MassPoint2D``) held by a ``DistanceConstraint``
  (index 3, Cartesian, as daebench's model), gravity as a coordinate load;
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
    return ["t", "theta_deg", "x", "y"], rows, None


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
    return ["t", "x", "v", "gap"], rows, impacts


MODELS = {"pendulum": _pendulum, "ball": _ball}


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
    columns, rows, impacts = MODELS[sheet["model"]](exu, items, mbs, p)
    mbs.Assemble()
    sim = exu.SimulationSettings()
    sim.timeIntegration.numberOfSteps = n
    sim.timeIntegration.endTime = t_end
    sim.timeIntegration.generalizedAlpha.spectralRadius = rho
    sim.timeIntegration.newton.useModifiedNewton = True
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
