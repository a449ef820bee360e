"""beam-impact (e = 0): the first impact against the number N of assumed modes — its time,
the tip's approach speed, the impulse, the energy lost and the tip's effective mass
m_eff = P / |ġ⁻| (Newton's law with e = 0 at one contact: P = m_eff |ġ⁻|, loss = ½ P |ġ⁻|) —
the numbers behind the flexible-beams page's statement that the modal beam's impact loss
is a property of its discretization, with no limit in N; then the same on the beam
discretized by finite elements (``discretization.kind = fem``, n elements), whose
first impact shows the same: a time that converges, a loss that halves with the mesh.

    python docs/results/_scripts/beam_impact_loss_vs_n.py
"""

import daebench

RHO_A_L = 2.7667e3 * 3.14e-4 * 1.0   # the rod's mass [kg] (cases/beam-impact.toml)


def print_row(kind: str, n: int, imp: dict) -> None:
    vn, P, loss = imp["vn_minus"], imp["impulse"], imp["energy_loss"]
    print(f"{kind[0]}{n:<3d} {imp['t']:.7f}  {vn:+.4f}  {P:.5f}  {loss:.4f}    {0.5 * P * abs(vn):.4f}      "
          f"{P / abs(vn):.4f}      {RHO_A_L / (P / abs(vn)):.1f}", flush=True)


print("   N  t1 [s]      ġ⁻ [m/s]  P [N s]   loss [J]  ½P|ġ⁻| [J]  m_eff [kg]  m/m_eff")
for kind, sizes in (("modes", (3, 5, 7, 9)), ("fem", (2, 4, 8, 16))):
    for n in sizes:
        out = daebench.run("beam-impact", "ida", write=False, rtol=1e-8,
                           overrides=[f"discretization.kind={kind}", f"discretization.n={n}", "t_end=0.3705"])
        print_row(kind, n, out.record.impacts[0])
