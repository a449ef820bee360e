"""Siconos (Debian's python3-siconos, the system Python) runs a daebench case: run as
``/usr/bin/python3 siconos_worker.py`` with the request on stdin (:mod:`common`).

Methods: ``mj`` — Moreau–Jean time stepping (θ = 0.5, one LCP per step, Newton's impact law
at velocity level; impulses, no events located); ``ed`` — event-driven with LSODAR (rtol
1e-14, atol 1e-16: impact times to ~1e-14 s on the ball), the impact LCP at each event and the
smooth-acceleration LCP for the contact status. Cases: the ``ball`` model (the bouncing ball
and the spring–wall oscillator: one coordinate, a linear time-invariant Lagrangian system, the
wall a linear relation y = x − x_w), both methods; the ``slider-crank`` model
(``slider-crank-clearance``, frictionless) with ``mj`` in Siconos' plugin formulation
(:mod:`siconos_slidercrank`): one Newton–LCP loop per step, an impact per corner where its
impulse turns positive.

What the Python layer does not give: the Liu–Zhao–Brogliato multiple-impact law
(``MultipleImpactNSL`` is wrapped, its one-step solver ``OSNSMultipleImpact`` is not), so the
chains and the cradle are not run here.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402  (the worker's own folder: it runs outside daebench)

LSODAR_RTOL, LSODAR_ATOL = 1e-14, 1e-16
THETA = 0.5


def _version() -> str:
    """The module's own version, with the Debian package's where dpkg knows it."""
    import subprocess
    from importlib.metadata import PackageNotFoundError, version
    try:
        mod = version("siconos")
    except PackageNotFoundError:
        mod = "unknown"
    try:
        deb = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "python3-siconos"], capture_output=True,
                             text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        deb = ""
    return f"{mod} (Debian python3-siconos {deb})" if deb else mod


def _ball(sk, p: dict, t_end: float):
    """The ball model as a Siconos system: (nsds, ds, interaction, wall)."""
    if not p.get("effects.contact", True):
        raise common.Refused("the Siconos adapter runs the ball with its wall (effects.contact = true)")
    if p["contact.law"] not in ("constraint", "complementarity"):
        raise common.Refused(f"Siconos resolves contact by Newton's impact law; contact.law = "
                             f"'{p['contact.law']}' is a compliant law: run it with contact.law = constraint")
    m, g, k, xr, wall = (float(p[key]) for key in ("ball.mass", "gravity.g", "spring.stiffness", "spring.rest",
                                                    "contact.wall"))
    ds = sk.LagrangianLinearTIDS([float(p["start.x"])], [float(p["start.v"])], np.array([[m]]))
    if k:
        ds.setKPtr(np.array([[k]]))
    ds.setFExtPtr(np.array([-m * g + k * xr]))
    rel = sk.LagrangianLinearTIR(np.array([[1.0]]), np.array([-wall]))
    inter = sk.Interaction(sk.NewtonImpactNSL(float(p["contact.restitution"])), rel)
    nsds = sk.NonSmoothDynamicalSystem(0.0, t_end)
    nsds.insertDynamicalSystem(ds)
    nsds.link(inter, ds)
    return nsds, ds, inter, wall


def moreau_jean(sk, nsds, ds, inter, wall, h: float, n: int):
    osi = sk.MoreauJeanOSI(THETA)
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, h), osi, sk.LCP())
    rows = [(0.0, ds.q()[0], ds.velocity()[0], ds.q()[0] - wall)]
    impacts = []

    def loop():
        was = False
        while sim.hasNextEvent():
            sim.computeOneStep()
            t = sim.nextTime()
            x, v = ds.q()[0], ds.velocity()[0]
            rows.append((t, x, v, x - wall))
            on = inter.lambda_(1)[0] > 0.0    # an impulse in this step: a contact episode
            if on and not was:
                impacts.append((t, 0))
            was = on
            sim.nextStep()
    _, cpu = common.timed(loop)
    return rows, impacts, cpu, len(rows) - 1, f"Moreau–Jean (θ = {THETA}, LCP per step, h = {h!r} s)"


def event_driven(sk, nsds, ds, inter, wall, h: float, n: int):
    osi = sk.LsodarOSI()
    osi.setTol(1, LSODAR_RTOL, LSODAR_ATOL)
    sim = sk.EventDriven(nsds, sk.TimeDiscretisation(0.0, h))
    sim.insertIntegrator(osi)
    sim.insertNonSmoothProblem(sk.LCP(), sk.SICONOS_OSNSP_ED_IMPACT)
    sim.insertNonSmoothProblem(sk.LCP(), sk.SICONOS_OSNSP_ED_SMOOTH_ACC)
    events = sim.eventsManager()
    rows = [(0.0, ds.q()[0], ds.velocity()[0], ds.q()[0] - wall)]
    impacts = []
    count = [0]

    def loop():
        while sim.hasNextEvent():
            sim.advanceToEvent()
            nonsmooth = events.nextEvent().getType() == 2     # NS_EVENT: an impact
            sim.processEvents()
            count[0] += 1
            t = sim.startingTime()
            x = ds.q()[0]
            if nonsmooth:   # the two sides of the jump at the same t, as an exact reference holds them
                rows.append((t, x, ds.velocityMemory().getSiconosVector(1)[0], x - wall))
                impacts.append((t, 0))
            rows.append((t, x, ds.velocity()[0], x - wall))
    _, cpu = common.timed(loop)
    return rows, impacts, cpu, count[0], (f"event-driven, LSODAR (rtol {LSODAR_RTOL:g}, atol {LSODAR_ATOL:g}), "
                                          f"impact and smooth-acceleration LCPs, output every {h!r} s")


def slider_crank(sk, sheet: dict, p: dict, t_end: float, h: float, method: str):
    """Moreau–Jean on the slider-crank in Siconos' plugin formulation (:mod:`siconos_slidercrank`)."""
    import siconos_slidercrank as sc

    if method != "mj":
        raise common.Refused("the slider-crank's corners chatter (accumulating impacts): Siconos' event-driven "
                             "scheme does not pass them; run it with siconos-mj")
    nsds, ds, inters = sc.build(sk, np, sheet, p, t_end)
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, h), sk.MoreauJeanOSI(THETA), sk.LCP())
    sim.setNewtonTolerance(1e-10)
    sim.setNewtonMaxIteration(20)
    rows = [(0.0, *sc.observables(ds.q(), ds.velocity(), p))]
    impacts = []

    def loop():
        was = [False] * len(inters)
        while sim.hasNextEvent():
            sim.computeOneStep()
            t = sim.nextTime()
            rows.append((t, *sc.observables(ds.q(), ds.velocity(), p)))
            for k, inter in enumerate(inters):
                on = inter.lambda_(1)[0] > 0.0
                if on and not was[k]:
                    impacts.append((t, k))
                was[k] = on
            sim.nextStep()
    _, cpu = common.timed(loop)
    return sc.COLUMNS, rows, impacts, cpu, len(rows) - 1, (f"Moreau–Jean (θ = {THETA}, LCP per step, Newton "
                                                            f"tolerance 1e-10, h = {h!r} s), plugin formulation")


def run(req: dict) -> None:
    import siconos.kernel as sk

    sheet = req["sheet"]
    p = common.values(sheet)
    t_end, h = float(sheet["time"]["t_end"]), float(req["h"])
    n = common.steps_of(t_end, h)
    if sheet["model"] == "slider-crank":
        columns, rows, impacts, cpu, steps, words = slider_crank(sk, sheet, p, t_end, h, req["method"])
        common.write(req, columns, rows, impacts,
                     {"cost_s": repr(cpu), "steps": steps, "code": f"Siconos {_version()}", "method": words,
                      "cost": "CPU time of the simulation loop in the peer's process (time.process_time)",
                      "h": repr(h)})
        return
    if sheet["model"] != "ball":
        raise common.Refused(f"the Siconos adapter runs the ball model's cases (ball, spring-wall) and "
                             f"slider-crank-clearance; case '{sheet['case']}' is model '{sheet['model']}'")
    scheme = {"mj": moreau_jean, "ed": event_driven}[req["method"]]
    rows, impacts, cpu, steps, words = scheme(sk, *_ball(sk, p, t_end), h, n)
    common.write(req, ["t", "x", "v", "gap"], rows, impacts,
                 {"cost_s": repr(cpu), "steps": steps, "code": f"Siconos {_version()}", "method": words,
                  "cost": "CPU time of the simulation loop in the peer's process (time.process_time)",
                  "h": repr(h)})


if __name__ == "__main__":
    common.main(run)
