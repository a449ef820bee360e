"""The pendulum case run by Exudyn's generalized-α, written as a file `daebench score` reads.

The set-up comes from `daebench export pendulum` (every parameter with its unit, the
initial state, the output times), not from daebench's model code: this is what any other
code would do. Run it as a script to write one CSV file per step size and score each:

    python docs/examples/exudyn_pendulum.py [FOLDER]
    daebench score pendulum FOLDER/exudyn-genalpha-h0.001.csv
    daebench compare pendulum --include FOLDER/exudyn-genalpha-h0.001.csv --include …

Exudyn (pip install exudyn) is imported only by :func:`simulate`.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import daebench


def case_values(sheet: dict) -> dict:
    """{scene key: value} of an exported case sheet."""
    return {p["key"]: p["value"] for p in sheet["parameters"]}


def simulate(sheet: dict, h: float, rho_inf: float = 0.9) -> tuple[pd.DataFrame, dict]:
    """The case of ``sheet`` (the pendulum's export) run by Exudyn's generalized-α at the fixed
    step ``h`` with spectral radius ``rho_inf``: (the trajectory at the case's output times as
    the case names its observables, with the energy terms; the metadata: label, cost, steps,
    code)."""
    import exudyn as exu  # Exudyn is needed only here
    from exudyn.itemInterface import (DistanceConstraint, LoadCoordinate, MarkerNodeCoordinate,
                                      MarkerNodePosition, MassPoint2D, NodePoint2D, NodePointGround, SensorNode)

    v = case_values(sheet)
    m, length, g = v["pendulum.mass"], v["pendulum.length"], v["gravity.g"]
    th0, om0 = math.radians(v["start.theta_deg"]), v["start.omega"]
    t_end, dt = v["t_end"], v["output.dt"]
    mbs = exu.SystemContainer().AddSystem()
    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    bob = mbs.AddNode(NodePoint2D(referenceCoordinates=[length * math.sin(th0), -length * math.cos(th0)],
                                  initialVelocities=[length * om0 * math.cos(th0), length * om0 * math.sin(th0)]))
    mbs.AddObject(MassPoint2D(mass=m, nodeNumber=bob))
    rod = [mbs.AddMarker(MarkerNodePosition(nodeNumber=k)) for k in (ground, bob)]
    mbs.AddObject(DistanceConstraint(markerNumbers=rod, distance=length))
    mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=bob, coordinate=1)),
                               load=-m * g))
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=bob, storeInternal=True, writeToFile=False, outputVariableType=o))
               for o in (exu.OutputVariableType.Position, exu.OutputVariableType.Velocity)]
    mbs.Assemble()
    sim = exu.SimulationSettings()
    steps = int(round(t_end / h))
    sim.timeIntegration.numberOfSteps = steps
    sim.timeIntegration.endTime = t_end
    sim.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    sim.timeIntegration.verboseMode = 0
    sim.solution.file.write = False
    sim.solution.sensors.writePeriod = dt
    sim.show.computationTime = False
    sim.show.statistics = False
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, sim)
    cost = time.perf_counter() - t0
    p, w = (np.asarray(mbs.GetSensorStoredData(s)) for s in sensors)
    t, x, y = p[:, 0], p[:, 1], p[:, 2]
    df = pd.DataFrame({"t": t, "theta_deg": np.degrees(np.arctan2(x, -y)), "x": x, "y": y,
                       "E_kinetic": 0.5 * m * (w[:, 1] ** 2 + w[:, 2] ** 2), "E_gravity": m * g * y})
    meta = {"label": "exudyn-genalpha", "cost_s": cost, "steps": steps,
            "code": f"Exudyn {exu.__version__}", "method": f"generalized-alpha, rho_inf {rho_inf:g}, h {h:g} s"}
    return df, meta


def write_csv(df: pd.DataFrame, meta: dict, path: str | Path) -> Path:
    """The trajectory as CSV, its metadata as '# key: value' lines above the header."""
    path = Path(path)
    with open(path, "w", encoding="utf-8") as fh:
        for k, val in meta.items():
            fh.write(f"# {k}: {val}\n")
        df.to_csv(fh, index=False)
    return path


def main(folder: str = "exudyn-pendulum", steps: tuple[float, ...] = (1e-3, 5e-4, 2.5e-4)) -> list[Path]:
    """One file per step h ≤ the case's output.dt (1 ms), so that each is scored at its own rows
    (a coarser file is scored on the case's output times, interpolated: docs/score-external.md)."""
    sheet = daebench.export_case("pendulum", write=False).sheet
    Path(folder).mkdir(parents=True, exist_ok=True)
    files = []
    for h in steps:
        df, meta = simulate(sheet, h)
        files.append(write_csv(df, meta, Path(folder) / f"{meta['label']}-h{h:g}.csv"))
        r = daebench.score("pendulum", files[-1], write=False).row
        print(f"{meta['label']} h {h:g} s: err_theta_max {r['err_theta_max']:.3e} deg, "
              f"err_pos_max {r['err_pos_max']:.3e} m, energy residual {r['energy_resid_max']:.3e} J, {meta['cost_s'] * 1e3:.2f} ms")
    return files


if __name__ == "__main__":
    main(*sys.argv[1:2])
