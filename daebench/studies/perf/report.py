"""`daebench perf` results as markdown (results/perf/perf.md)."""

from __future__ import annotations

import math
from typing import Any

from daebench.harness.running import provenance
from daebench.studies.perf import structure as perf_structure


def _f(x, fmt=".3g"):
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)


def _pair(p: dict[str, Any]) -> str:
    """A pendulum pair's ratio (studies.perf_peers._pendulum_pair): median of the rounds, range, µs."""
    lo, hi = p.get("ratio_range", (math.nan, math.nan))
    return (f"{_f(p['ratio_ours_over_exudyn'])} (median of {p.get('rounds', 1)} interleaved rounds, "
            f"range {_f(lo)}–{_f(hi)}; slope between T/4 and T: {_f(p['ours_us_per_step'])} vs "
            f"{_f(p['exudyn_us_per_step'])} µs; whole runs {_f(p.get('whole_run_ratio', math.nan))}")


def markdown(r: dict[str, Any]) -> str:
    L = ["# daebench perf", ""]
    L.append(f"compile / cache load (first calls in the process): "
             + ", ".join(f"{k} {_f(v)} s" for k, v in r["compile_s"].items()))
    L.append(f"load average before: {', '.join(f'{x:.2f}' for x in r['load_before'])}")
    L += ["", "## The four figures", ""]
    t = r.get("table1")
    if t:
        L.append(f"1. Table 1 grid (24 runs, jobs={t['jobs']}): {_f(t['total_wall_s'])} s wall "
                 f"→ {_f(t['speedup_vs_published'], '.0f')}× the published 47 500 s (target < 120 s: "
                 f"{'met' if t['met'] else 'NOT met'})")
    else:
        L.append("1. Table 1 grid: skipped")
    sc = r["scaling"]
    L.append(f"2. hht per-step cost N = {sc['rows'][0]['N']} → {sc['rows'][-1]['N']}: exponent "
             f"{_f(sc['exponent'])}, growth / N² = {_f(sc['growth_over_N2'])} ({'met' if sc['met'] else 'NOT met'})")
    ex = r["exudyn"]
    if ex.get("available"):
        p, b = ex["pendulum"], ex["beam"]
        L.append(f"3. vs Exudyn {ex['version']} generalized-α: pendulum hht per step ours/Exudyn = "
                 f"{_pair(p)}, {_f(p.get('newton_per_step', math.nan))} Newton iterations/step); flexible beam, wall at equal "
                 f"tip-angle error vs {b['exudyn_model']}: "
                 + "; ".join(f"{b['models'][k]} = {_f(b[k]['ratio_ours_over_exudyn'])} (at {_f(b[k]['target_err'])} rad)"
                             for k in b["models"])
                 + "; per step at equal h, FEM vs ANCF: "
                 + ", ".join(f"{_f(x['fem_over_exudyn_per_step'])} (h {x['h']:g})" for x in b["rows"]))
        g = ex.get("genalpha")
        if g:
            L.append(f"   genalpha vs Exudyn generalized-α, pendulum, ρ∞ = {_f(g['rho_inf'])}, h = {g['h']:g} s, "
                     f"T = {g['T']:g} s: per step ours/Exudyn = {_pair(g)}); |θ(T) − exact| "
                     f"ours {_f(g['ours_theta_err'])} rad, Exudyn {_f(g['exudyn_theta_err'])} rad "
                     f"(ratio {_f(g['error_ratio_ours_over_exudyn'])})")
    else:
        L.append(f"3. Exudyn: {ex.get('note')}")
    pl = r.get("plugin") or {}
    if pl.get("available"):
        L.append(f"   plugin on the compiled interfaces (tests/plugin_pkg, verlet-compiled), pendulum h = {pl['h']:g} s: "
                 + ", ".join(f"{k} {_f(v['us_per_step'])} µs/step" for k, v in pl["rows"].items())
                 + f"; plugin/hht = {_f(pl['plugin_over_hht'])}, plugin/genalpha = {_f(pl['plugin_over_genalpha'])} "
                 f"(target ≤ 2), plain-Python twin {_f(pl['python_over_compiled_plugin'])}× slower")
    cap = r.get("capture")
    if cap:
        L.append("   event-capturing vs event-driven, beam-impact N = 5, h = 1e-4 s: "
                 + ", ".join(f"{x['label']} {_f(x['steps_per_s'], '.0f')} steps/s" for x in cap))
    fr = r.get("friction")
    if fr:
        L.append("   Coulomb friction against the same case with μ = 0, h = 1e-4 s (µs/step, friction/frictionless): "
                 + "; ".join(f"{x['case']} {x['integrator']}{' + ' + x['law'] if x.get('law') in ('hertz', 'penalty') else ''} "
                             f"{_f(x['us_per_step'])} ({_f(x['friction_over_frictionless'])}×)"
                             for x in fr if x["mu"] > 0))
    cold = r.get("coldstart")
    if cold:
        L.append("   first run with an empty kernel cache: "
                 + "; ".join(f"`{c['command']}` {_f(c['cold_s'])} s (warm {_f(c['warm_s'])} s, first output "
                             f"{_f(c['first_output_s'])} s, longest silence {_f(c['longest_silence_s'])} s)" for c in cold))
    a = r["adaptive"]
    if a.get("best"):
        b = a["best"]
        L.append(f"4. {b['integrator']} rtol {b['rtol']:g}: {b['steps']} steps for max θ error "
                 f"{_f(b['theta_err_max_rad'])} rad ≤ 1e-6 = {_f(a.get('steps_fraction'))} of the protocol's "
                 f"{a['paper_protocol_steps']} steps (target < 0.01: {'met' if a.get('met') else 'NOT met'})")
    else:
        L.append(f"4. adaptive: no run reached 1e-6 rad ({a.get('note', '')})")
    bd = a.get("bound") or {}
    if bd.get("available"):
        top = max(bd["windows"], key=lambda x: x["omega_top_100x"], default=None)
        L.append(f"   lower bound for Runge–Kutta, multistep and Newmark-type steppers (aliasing, see below): "
                 f"≥ {bd['steps_lower_bound']:.0f} steps = "
                 f"{_f(bd.get('fraction_of_protocol'))} of the protocol; counting only tones 100× above the "
                 f"target: ≥ {bd['steps_lower_bound_100x']:.0f} = {_f(bd.get('fraction_of_protocol_100x'))}"
                 + (f" (θ carries a {_f(top['amplitude_top_100x'])} rad tone at ω = "
                    f"{top['omega_top_100x']:.0f} rad/s)" if top and top["omega_top_100x"] > 0 else "")
                 + f" — target < 0.01 {'attainable' if bd.get('target_attainable') else 'NOT attainable'}")
    L += ["", "## Steps per second, beam-impact N = 5, protocol h = 1e-4 s / 1e-6 s in contact", "",
          "| integrator | status | t_final | steps | wall [s] | steps/s |", "|---|---|---|---|---|---|"]
    for x in r["step_rates"]:
        L.append(f"| {x['integrator']} | {x['status']} | {_f(x['t_final'])} | {x['steps']} | {_f(x['wall_s'])} | "
                 f"{_f(x['steps_per_s'], '.0f')} |")
    if r.get("floor"):
        L += ["", "## Per step beyond the model's own physics (`daebench perf --section model-floor`)", "",
              "Whole `run_scene` calls (set-up, events, history table included); the median of the runs and "
              "their range. The model kernel's time per call × the force evaluations per step is a floor under "
              "any integrator's step; 1 / floor bounds steps/s.", "",
              "| case | integrator | steps/s (median) | range | µs/step | force evaluations/step | kernel µs/call "
              "| kernel share | bound steps/s |", "|---|---|---|---|---|---|---|---|---|"]
        for x in r["floor"]:
            lo, hi = x.get("steps_per_s_range", (math.nan, math.nan))
            L.append(f"| {x['case']} | {x['integrator']} | {_f(x['steps_per_s'], '.0f')} | {_f(lo, '.0f')}–{_f(hi, '.0f')} "
                     f"({x.get('repeats', 1)} runs) | {_f(x['us_per_step'])} | "
                     f"{_f(x['residual_evals_per_step'])} | {_f(x['kernel_us_per_call'])} | "
                     f"{_f(100 * x['kernel_share'], '.0f')} % | {_f(x['bound_steps_per_s'], '.0f')} |")
    if t:
        L += ["", "## Table 1 runs", "", "| N | setting | status | wall [s] | steps | t_final |", "|---|---|---|---|---|---|"]
        for x in t["runs"]:
            L.append(f"| {x['N']} | {x['setting']} | {x['status']} | {_f(x['wall_s'])} | {x['steps']} | "
                     f"{_f(x['t_final'])} |")
    L += ["", "## Scaling", "", "| N | n | steps | µs/step |", "|---|---|---|---|"]
    for x in sc["rows"]:
        L.append(f"| {x['N']} | {x['n']} | {x['steps']} | {_f(x['us_per_step'])} |")
    if ex.get("available"):
        L += ["", "## Flexible beam work–precision (tip angle at T vs each model's own reference)", "",
              "| h | modes wall [s] | modes err | FEM wall [s] | FEM err | Exudyn ANCF wall [s] | Exudyn err |",
              "|---|---|---|---|---|---|---|"]
        for x in ex["beam"]["rows"]:
            L.append(f"| {x['h']:g} | {_f(x['modes_wall_s'])} | {_f(x['modes_err'])} | {_f(x['fem_wall_s'])} | "
                     f"{_f(x['fem_err'])} | {_f(x['exudyn_wall_s'])} | {_f(x['exudyn_err'])} |")
    if a.get("rows"):
        L += ["", "## Adaptive runs (max θ error over the run vs the IDA reference)", "",
              "| integrator | rtol | status | steps | wall [s] | θ err [rad] |", "|---|---|---|---|---|---|"]
        for x in a["rows"]:
            L.append(f"| {x['integrator']} | {x['rtol']:g} | {x['status']} | {x['steps']} | {_f(x['wall_s'])} | "
                     f"{_f(x['theta_err_max_rad'])} |")
    if bd.get("available"):
        sr = bd["spectrum_run"]
        L += ["", "## Resolution bound (target 4): tones of θ above 1e-6 rad in free flight", "",
              f"Spectrum of θ about its slow trend per free-flight window ({sr['integrator']} α = {sr['alpha']:g}, "
              f"h = {sr['h']:g} s, sampled every {sr['output_dt']:g} s). A stepper with h > π/ω cannot follow a "
              f"tone at ω, so each window needs ≥ ω_top T / π steps.", "",
              "| window [s] | highest tone > 1e-6 rad: ω [rad/s], amplitude [rad] | steps ≥ "
              "| highest tone > 1e-4 rad: ω, amplitude | steps ≥ | largest amplitude [rad] |",
              "|---|---|---|---|---|---|"]
        for x in bd["windows"]:
            L.append(f"| {x['t0']:.4f}–{x['t1']:.4f} | {x['omega_top']:.0f}, {_f(x['amplitude_top'])} | "
                     f"{x['steps_min']:.0f} | {x['omega_top_100x']:.0f}, {_f(x['amplitude_top_100x'])} | "
                     f"{x['steps_min_100x']:.0f} | {_f(x['amplitude_max'])} |")
    L += perf_structure.markdown(r.get("fe_banded"), r.get("ida_backends"))
    L.append(provenance.markdown_footer(r["provenance"]))
    return "\n".join(L) + "\n"
