"""results/curated/survey-quick-profiles.md from a quick survey's folder: its profile table
(profiles.csv) and its recommendations (recommendations.md, with their provenance line).

    daebench survey --quick --budget 120 --jobs 2 --name quick
    python docs/results/_scripts/survey_quick_profiles.py results/survey/quick > results/curated/survey-quick-profiles.md

Run it from a clean commit: the provenance line names the commit (a modified tree reads "+dirty").
"""

import json
import sys
from pathlib import Path

import pandas as pd

folder = Path(sys.argv[1])
side = json.loads((folder / "survey.json").read_text())
prof = pd.read_csv(folder / "profiles.csv")
rec = (folder / "recommendations.md").read_text().splitlines()
cases = ", ".join(c["case"] for c in side["cases"])
opts = side.get("options", {})
print(f"# Performance profiles, `daebench survey --quick --budget {float(opts['budget_s']):g}`\n")
print(f"Survey {side['name']} ({cases}; the quick protocol: t_end 0.5 s, every applicable integrator at its "
      f"default step and its halvings, IDA over tolerances, while the budget of {float(opts['budget_s']):g} s per "
      f"case allows), {side['wall_s']:.0f} s wall. Cost = CPU time. ρ(1): the fraction of the cases where the "
      f"setting is the cheapest to reach the target; ρ(4): within 4× the cheapest; ρ(∞): reaches it at all.\n")
print("| measure | target | setting | cases | ρ(1) | ρ(4) | ρ(∞) |\n|---|---|---|---|---|---|---|")
for r in prof.itertuples(index=False):
    print(f"| {r.measure} | {r.target:g} | {r.setting} | {r.cases} | {r.rho_1:.2g} | {r.rho_4:.2g} | {r.rho_inf:.2g} |")
print()
print("\n".join(line for line in rec if not line.startswith("# ")).strip())
