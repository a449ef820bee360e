"""results/curated/survey-<name>-profiles.md from a survey's folder: the runs per case (from
its table and sidecar), its profile table (profiles.csv) and its recommendations
(recommendations.md, with their provenance line).

    daebench survey --quick --report
    python docs/results/_scripts/survey_profiles.py results/survey/<the quick survey's name> > results/curated/survey-quick-profiles.md
    daebench survey --cases <the 12 of docs/results/survey.md> --budget 150 --jobs 2 --name full --report
    python docs/results/_scripts/survey_profiles.py results/survey/full > results/curated/survey-full-profiles.md

Run the survey from a clean commit: the provenance line names the commit (a modified tree reads "+dirty").
"""

import json
import sys
from pathlib import Path

import pandas as pd

folder = Path(sys.argv[1])
side = json.loads((folder / "survey.json").read_text())
prof = pd.read_csv(folder / "profiles.csv")
table = pd.read_parquet(folder / "table.parquet")
rec = (folder / "recommendations.md").read_text().splitlines()
opts = side.get("options", {})
budget = opts.get("budget_s")
cases = [c["case"] for c in side["cases"]]
kind = "the quick protocol: t_end 0.5 s, " if opts.get("quick") else ""
per_case = f", budget {float(budget):g} s per case" if budget is not None else ", the quick protocol's default budget"
print(f"# Performance profiles, `daebench survey`{' --quick' if opts.get('quick') else ''} ({len(cases)} cases"
      f"{per_case})\n")
status = table.status.value_counts().to_dict()
print(f"Survey {side['name']} ({', '.join(cases)}; {kind}every applicable integrator at its protocol's steps and "
      f"their halvings, IDA over tolerances, while the budget allows): {side['wall_s']:.0f} s wall, "
      f"{len(table)} runs — " + ", ".join(f"{n} {s}" for s, n in sorted(status.items())) + ". Cost = CPU time. "
      "ρ(1): the fraction of the cases where the setting is the cheapest to reach the target; ρ(4): within 4× the "
      "cheapest; ρ(∞): reaches it at all.\n")
print("| case | runs | completed | diverged | rounds run | wall [s] | repeat digest |\n|---|---|---|---|---|---|---|")
for c in side["cases"]:
    rows = table[table.case == c["case"]]
    rep = c.get("repeat_check") or {}
    print(f"| {c['case']} | {len(rows)} | {(rows.status == 'completed').sum()} | {(rows.status == 'diverged').sum()} "
          f"| {c['rounds_run']}/{c['rounds']} | {c['wall_s']:.1f} | "
          f"{'equal' if rep.get('match') else 'differs' if rep else '—'} |")
print("\n| measure | target | setting | cases | ρ(1) | ρ(4) | ρ(∞) |\n|---|---|---|---|---|---|---|")
for r in prof.itertuples(index=False):
    print(f"| {r.measure} | {r.target:g} | {r.setting} | {r.cases} | {r.rho_1:.2g} | {r.rho_4:.2g} | {r.rho_inf:.2g} |")
print()
print("\n".join(line for line in rec if not line.startswith("# ")).strip())
