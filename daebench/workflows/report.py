"""One self-contained HTML page of a survey (or of any set of scored tables): the
recommendation first, then the tables (sortable: click a header), every figure embedded
as a base64 PNG, the reference's trusted span where the rows carry it, and the
provenance footer (versions, machine, scene hashes).

No external file, script or font: the page is one file that opens anywhere. Loaded with
``?selftest`` in its URL the page checks itself and writes the result as JSON into
``<pre id="selftest">`` (what a headless browser's ``--dump-dom`` returns): the number of
figures and those of zero size, the errors raised on the page, and — with
``&table=I&col=J`` — table I's column J before and after a click on its header.
"""

from __future__ import annotations

import base64
import html
import math
from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import check_name
from daebench.harness.analysis import evidence, plots, profiles
from daebench.harness.files import (DamagedFile, OutputError, atomic_write, ensure_writable_dir, read_json, results_dir,
                                    under_root)
from daebench.harness.running import provenance
from daebench.workflows.compare import marked, measures_present
from daebench.workflows.score import is_external
from daebench.harness.scoring import glossary
from daebench.workflows import survey
from daebench.workflows.survey import CaseResult, scene_hashes

#: columns the reference's trusted span may be recorded in (added by the reference's own check)
TRUST_COLUMNS = ("trust_t", "trust_impacts")

_CSS = """
body{font-family:system-ui,sans-serif;max-width:1360px;margin:1.5em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
p.rec{background:#f3f7ff;border-left:4px solid #36c;padding:.5em .8em}
div.answer{display:flex;gap:1.5em;align-items:flex-start}div.answer>div{flex:1 1 0}
div.answer>div:last-child{flex:1.4 1 0}div.answer li{margin:.3em 0}p.note{font-size:.85em;color:#555}
details{margin:.5em 0}summary{cursor:pointer;color:#36c}
table{border-collapse:collapse;font-size:.82em;margin:.5em 0}
th,td{border:1px solid #ddd;padding:2px 6px;text-align:right}
th{background:#eee;cursor:pointer;user-select:none}th.asc::after{content:" \\25B2"}th.desc::after{content:" \\25BC"}
td.s,th.s{text-align:left}figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}
footer{margin-top:2em;font-size:.75em;color:#666;border-top:1px solid #ccc;padding-top:.5em}
"""

_JS = r"""
(function(){
var errs=[];window.addEventListener('error',function(e){errs.push(String(e.message||e));});
var ce=console.error;console.error=function(){errs.push(Array.prototype.join.call(arguments,' '));ce.apply(console,arguments);};
function key(td){var t=td.getAttribute('data-v');if(t===null)t=td.textContent.trim();
  var x=parseFloat(t);return (t!==''&&!isNaN(x)&&isFinite(Number(t)))?[0,x]:(t===''||t==='-'?[2,0]:[1,t.toLowerCase()]);}
function cmp(a,b){if(a[0]!==b[0])return a[0]-b[0];return a[1]<b[1]?-1:(a[1]>b[1]?1:0);}
function sortBy(th){var table=th.closest('table'),tb=table.tBodies[0],i=th.cellIndex;
  var asc=!th.classList.contains('asc');
  Array.prototype.forEach.call(th.parentNode.children,function(h){h.classList.remove('asc','desc');});
  th.classList.add(asc?'asc':'desc');
  var rows=Array.prototype.slice.call(tb.rows);
  rows.sort(function(r1,r2){var c=cmp(key(r1.cells[i]),key(r2.cells[i]));return asc?c:-c;});
  rows.forEach(function(r){tb.appendChild(r);});}
document.querySelectorAll('table.sortable th').forEach(function(th){th.addEventListener('click',function(){sortBy(th);});});
function selftest(){var q=new URLSearchParams(location.search);if(!q.has('selftest'))return;
  var imgs=document.querySelectorAll('img'),zero=0;
  imgs.forEach(function(im){var r=im.getBoundingClientRect();if(!(im.naturalWidth>0&&r.width>0&&r.height>0))zero++;});
  var out={figures:imgs.length,zero_size:zero,tables:document.querySelectorAll('table.sortable').length};
  var a=document.querySelector('div.answer');if(a){var fi=a.querySelector('img'),li=a.querySelector('li,p');
    out.answer={text_top:li?li.getBoundingClientRect().top:null,figure_top:fi?fi.getBoundingClientRect().top:null,
      figure_height:fi?fi.getBoundingClientRect().height:0,viewport:[innerWidth,innerHeight]};}
  if(q.has('table')){var t=document.querySelectorAll('table.sortable')[+q.get('table')],j=+(q.get('col')||0);
    var col=function(){return Array.prototype.map.call(t.tBodies[0].rows,function(r){return r.cells[j].textContent.trim();});};
    out.before=col();t.tHead.rows[0].cells[j].click();out.after=col();
    out.header=t.tHead.rows[0].cells[j].textContent.trim();}
  out.errors=errs;document.getElementById('selftest').textContent=JSON.stringify(out);}
if(document.readyState==='complete')selftest();else window.addEventListener('load',selftest);
})();
"""


def _cell(v: Any) -> str:
    if isinstance(v, bool):
        return html.escape(str(v))
    if isinstance(v, float):
        return "-" if math.isnan(v) else ("∞" if math.isinf(v) else f"{v:.4g}")
    if v is None:
        return "-"
    return html.escape(str(v))


#: headers of the verdict table's and the page's own columns (the scored columns' come from the glossary)
HEADERS = {"label": "setting", "qualified": "qualifies", "reach_cpu_s": "CPU time to reach [s]",
           "reach_steps": "steps to reach", "reach_kind": "cost is", "at": "at", "order": "observed order",
           "declared": "declared order", "regime": "outside the asymptotic regime", "limit": "stability limit",
           "best_err": "smallest error", "missing": "what is missing", "rho_1": "ρ(1)", "rho_4": "ρ(4)",
           "rho_inf": "ρ(∞)"}


def header(column: str, model: str | None = None) -> str:
    """A column's header for people: the glossary's short name and unit, else the page's
    own words, else the name."""
    if column in HEADERS:
        return HEADERS[column]
    m = glossary.describe(column, model)
    if m.words == column:
        return column
    return f"{m.short} [{m.unit}]" if m.unit else m.short


def table_html(df: pd.DataFrame, columns: Sequence[str] | None = None, caption: str = "",
               model: str | None = None) -> str:
    """A sortable HTML table (numbers right-aligned, text left; each cell's sort key in
    ``data-v`` where the shown text is rounded); headers in words (:func:`header`, the
    column's name as its tooltip), measures named in words."""
    cols = [c for c in (columns or list(df.columns)) if c in df.columns]
    if "measure" in cols:
        df = df.assign(measure=df["measure"].map(lambda m: glossary.display(str(m), model)))
    text = {c: not pd.api.types.is_numeric_dtype(df[c]) or pd.api.types.is_bool_dtype(df[c]) for c in cols}
    head = "".join(f'<th class="{"s" if text[c] else "n"}" title="{html.escape(str(c))}">'
                   f'{html.escape(header(str(c), model))}</th>' for c in cols)
    body = []
    for _, r in df[cols].iterrows():
        cells = []
        for c in cols:
            v = r[c]
            dv = f' data-v="{float(v)!r}"' if isinstance(v, float) and math.isfinite(v) else ""
            cells.append(f'<td class="{"s" if text[c] else "n"}"{dv}>{_cell(v)}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<table class="sortable">{cap}<thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def figure_html(path: str | Path, caption: str = "") -> str:
    """A PNG embedded as base64, with its caption."""
    data = base64.b64encode(Path(path).read_bytes()).decode()
    alt = html.escape(caption or Path(path).stem)
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{alt}">'
            f'<figcaption>{html.escape(caption)}</figcaption></figure>')


def trusted_span(table: pd.DataFrame) -> pd.DataFrame:
    """Per case, the reference's trusted span as the rows record it (the columns of
    :data:`TRUST_COLUMNS` that exist; empty when none does)."""
    cols = [c for c in TRUST_COLUMNS if c in table.columns]
    if not cols or not len(table):
        return pd.DataFrame()
    return table.groupby("case", sort=False)[cols].first().reset_index()


def page(title: str, lead: str, sections: Sequence[tuple[str, str]], prov: dict[str, Any]) -> str:
    """The whole page: title, ``lead`` (the answer: html), then ``sections`` ((heading,
    html) in order), the provenance footer, the inline script."""
    secs = "".join(f"<h2>{html.escape(h)}</h2>{body}" for h, body in sections)
    scenes = ", ".join(f"{html.escape(s['name'])}#{html.escape(s['hash'])}" for s in prov.get("scenes", []))
    foot = (f"<footer>provenance: {html.escape(provenance.footer_text(prov))}"
            + (f"<br>scene hashes: {scenes}" if scenes else "") + "</footer>")
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>"
            f"{lead}{secs}{foot}<pre id=\"selftest\"></pre>"
            f"<script>{_JS}</script></body></html>")


def paragraphs_html(paragraphs: Sequence[str]) -> str:
    """Recommendation paragraphs, or why there is none."""
    return "".join(f'<p class="rec">{html.escape(p)}</p>' for p in paragraphs) or \
        "<p>No setting qualified for a target (or nothing was scored).</p>"


#: the verdict table's columns on the page (``compact``: without the texts of what is missing)
VERDICT_COLUMNS = ("case", "label", "measure", "target", "qualified", "reach_cpu_s", "reach_steps", "reach_kind", "at",
                   "order", "declared", "regime", "limit", "best_err", "missing")
COMPACT_VERDICT = ("case", "label", "measure", "target", "qualified", "reach_cpu_s", "reach_kind", "order", "regime",
                   "best_err")
RUN_COLUMNS = ("label", "h", "tol", "status", "cpu_s", "wall_s", "steps", "digest", "message")
#: ``compact``: the columns kept (no digests; a message only where a run did not complete)
COMPACT_RUNS = ("label", "h", "tol", "status", "cpu_s", "steps", "message")
COMPACT_WIDTH = 900       # px: the profile figure's width in a compact page
COMPACT_COLORS = 128      # palette of that PNG (32 merged the setting colours of the legend)


def small_png(src: Path, dst: Path, width: int = COMPACT_WIDTH) -> Path:
    """``src`` scaled down to ``width`` pixels (never up) as a :data:`COMPACT_COLORS`-colour
    palette PNG (a line plot loses nothing visible)."""
    from PIL import Image  # lazy: Pillow, only for a compact page's small figure

    with Image.open(src) as im:
        im = im.convert("RGB")
        if im.width > width:
            im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        im.quantize(colors=COMPACT_COLORS).save(dst, optimize=True)
    return dst


def runs_with_orders(table: pd.DataFrame, measure: str | None) -> pd.DataFrame:
    """A case's runs with the observed order on ``measure`` and the asymptotic flag
    (:func:`daebench.harness.analysis.evidence.observed_orders`); a message only where the
    run did not complete (the reason of an error row)."""
    out = table.copy()
    if measure:
        o = evidence.observed_orders(out, measure)
        out["order"], out["regime"] = o["order"], o["regime"]
    if "message" in out:
        done = out["status"].astype(str) == "completed"
        out["message"] = out["message"].where(~done, "").fillna("").astype(str).str.split("\n").str[0].str[:160]
    return out


def _case_section(r: Any, para: str, figs: Path, prov: dict[str, Any], compact: bool, verdicts: pd.DataFrame) -> str:
    """One case: its conclusion in words, its work–precision figure, its tables collapsed."""
    model = survey.model_of(r.case)
    body = f'<p class="rec">{html.escape(para)}</p>' if para else "<p>No target was set for this case.</p>"
    if r.measures and len(r.table) and not compact:
        files = plots.work_precision(r.table, evidence.COST, r.measures, "label", figs / f"wp-{r.case}", prov,
                                     title=f"{r.case}: work–precision")[1]
        body += "".join(figure_html(p, f"{r.case}: work–precision (CPU time)") for p in files
                        if Path(p).suffix == ".png")
    if len(r.table):
        runs = runs_with_orders(r.table, r.measures[0] if r.measures else None)
        cols = [*(COMPACT_RUNS if compact else RUN_COLUMNS), *r.measures, "order", "regime"]
        what = glossary.display(r.measures[0], model) if r.measures else ""
        body += (f"<details><summary>{len(r.table)} runs (observed order and asymptotic regime on "
                 f"{html.escape(what)})</summary>"
                 + table_html(runs, cols, model=model) + "</details>")
    mine = verdicts[verdicts["case"] == r.case] if len(verdicts) else verdicts
    if len(mine):
        body += ("<details><summary>every setting's verdict per target</summary>"
                 + table_html(mine, COMPACT_VERDICT if compact else VERDICT_COLUMNS, model=model) + "</details>")
    return body


def write_survey_report(res: Any, path: Path | None = None, compact: bool = False) -> Path:
    """The page of a survey (:class:`daebench.workflows.survey.SurveyResult`), the answer
    first: the library-wide conclusion per accuracy band (from the performance profiles)
    beside the profile figure, the work–precision small multiples of every case; then one
    section per case (its conclusion in words, its figure, its tables collapsed); the
    reference's trusted span, the integrators not applicable, provenance. Written to
    ``<survey>/report.html``.

    ``compact``: a page small enough to keep under version control: the figures as small
    palette PNGs, no work–precision figure per case section, the tables without digests
    (:data:`COMPACT_RUNS`, :data:`COMPACT_VERDICT`; the survey's CSV files have every column)."""
    f = Path(res.folder)
    figs = f / "figures"
    out = Path(path) if path is not None else f / "report.html"
    # both places proved writable before any figure is drawn; the page is one regular file
    if out.exists() and not out.is_file() or out.is_symlink():
        raise OutputError(f"--out {out} exists and is not a regular file; give the path of an .html file to write")
    ensure_writable_dir(out.parent, "the report's folder (--out)")
    ensure_writable_dir(figs, "the survey's figure folder")
    prov = provenance.collect(scene_hashes(res.table))
    concl = profiles.conclusions(res.profile) if len(res.profile) else []
    answer = ("<ul>" + "".join(f"<li>{html.escape(c)}</li>" for c in concl) + "</ul>" if concl else
              "<p>No setting qualified for any target: see each case below for what is missing.</p>")
    answer += ("<p class=\"note\">A setting qualifies for a target when its run and every finer run of it reach "
               "the target, none failed, and the errors fall with the step (positive observed order); cost = CPU "
               "time, the minimum of the timed repeats.</p>")
    prof_png = f / f"{survey.PROFILE_FIGURE}.png"
    fig = ""
    if prof_png.exists():
        shown = small_png(prof_png, figs / "profile-small.png") if compact else prof_png
        fig = figure_html(shown, "performance profiles: fraction of cases on which a setting qualifies within τ × "
                                 "the cheapest CPU time (log τ axis)")
    lead = f'<div class="answer"><div><h2>The answer</h2>{answer}</div><div>{fig}</div></div>'
    sections: list[tuple[str, str]] = []
    multiples = {r.case: (r.table, r.measures[0]) for r in res.cases if r.measures and len(r.table)}
    if multiples:
        sm = plots.small_multiples(multiples, evidence.COST, stem=figs / "wp-cases", prov=prov,
                                   title="work–precision per case: error against CPU time, one panel per case")[1]
        png = next(p for p in sm if Path(p).suffix == ".png")
        shown = small_png(png, figs / "wp-cases-small.png", width=1200) if compact else png
        sections.append(("Work–precision per case", figure_html(shown, "each case's headline error against CPU "
                                                                       "time, log–log; one colour per setting")))
    for r in res.cases:
        sections.append((r.case, _case_section(r, res.paragraphs.get(r.case, ""), figs, prov, compact, res.reach)))
    if len(res.profile):
        sections.append(("Performance profiles (CPU time)", "<details><summary>the profile table</summary>" + table_html(
            res.profile, caption="ρ(1): fraction of cases where the setting is the cheapest qualified; ρ(4): within "
                                 "4× the cheapest; ρ(∞): qualifies at all") + "</details>"))
    ts = trusted_span(res.table)
    sections.append(("The reference's trusted span",
                     table_html(ts) if len(ts) else "<p>These rows do not record the reference's trusted span.</p>"))
    refused = [(r.case, k, v) for r in res.cases for k, v in r.refused.items()]
    if refused:
        sections.append(("Not applicable", table_html(pd.DataFrame(refused, columns=["case", "integrator", "why"]))))
    text = page(f"daebench survey {res.name}", lead, sections, prov)
    atomic_write(out, lambda p: Path(p).write_text(text, encoding="utf-8"), "the report page",
                 f"the survey's own files in {f} are untouched")
    return out


def write_compare_report(res: Any, scene: Any, path: Path) -> Path:
    """The page of one `daebench compare` (:class:`daebench.workflows.compare.CompareResult`):
    the recommendation, the work–precision figure, every run with the protocol's measures
    and observed orders, the reference and its trusted span, the integrators not
    applicable, provenance."""
    measures = measures_present(res.table, res.protocol.measures)
    sections: list[tuple[str, str]] = [("The protocol", f"<p>{html.escape(res.heading(scene.name))}</p>"
                                                        f"<p>{html.escape(res.protocol.why)}</p>")]
    figs = [figure_html(p, f"{scene.name}: work–precision") for p in res.files if Path(p).suffix == ".png"]
    if figs:
        sections.append(("Work–precision", "".join(figs)))
    own = res.table[~is_external(res.table)]
    runs = runs_with_orders(marked(res.table), measures[0] if measures else None)
    cols = [c for c in (*RUN_COLUMNS, *measures, "order", "regime") if c in runs.columns]
    sections.append(("Every run", table_html(runs, cols, model=scene.model,
                                             caption="rows marked [external] are other codes' trajectories, "
                                                     "scored by the same pipeline" if len(own) < len(res.table)
                                             else "")))
    if len(own) < len(res.table):
        sections.append(("Other codes", "<p>" + html.escape(
            "Trajectories from other codes (daebench score, compare --include), scored against the same truth "
            "over the same trusted span by the same measures; their cost is what their files state (wall_s), "
            "and they take no part in the recommendation.") + "</p>"
            + table_html(res.table[is_external(res.table)], ("label", "settings", "wall_s", "steps", "against",
                                                              *measures), model=scene.model)))
    ref = res.reference
    ts = trusted_span(res.table)
    span = table_html(ts) if len(ts) else "<p>These rows do not record the reference's trusted span.</p>"
    sections.append(("The reference and its trusted span",
                     (f"<p>{html.escape(ref.describe())}</p>" if ref is not None else "<p>no reference</p>") + span))
    if res.not_applicable:
        sections.append(("Not applicable", table_html(pd.DataFrame(sorted(res.not_applicable.items()),
                                                                   columns=["integrator", "why"]))))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    lead = "<h2>Recommendation</h2>" + paragraphs_html(list(res.paragraphs.values()))
    text = page(f"daebench compare {scene.name}", lead, sections, provenance.collect([scene]))
    atomic_write(out, lambda p: Path(p).write_text(text, encoding="utf-8"), "the report page",
                 "the table and figure are written")
    return out


def load_survey(name: str, folder: Path | None = None) -> Any:
    """A written survey (:class:`daebench.workflows.survey.SurveyResult`) back from
    results/survey/<name>/, for `daebench report NAME`.

    Raises
    ------
    ParamError
        When there is no such survey.
    """
    f = Path(folder) if folder is not None else under_root(results_dir() / "survey", check_name(name, "survey name"),
                                                            what="survey")
    side = f / "survey.json"
    if not side.exists():
        raise ParamError(f"no survey '{name}' in {f.parent} (run `daebench survey --name {name}` first)")

    def damaged(why: str) -> ParamError:
        return ParamError(f"the survey folder {f} is damaged ({why}); run the survey again "
                          f"(`daebench survey --name {name} --overwrite`)")

    try:
        meta = read_json(side, "survey.json")
        tab = pd.read_parquet(f / "table.parquet") if (f / "table.parquet").exists() else pd.DataFrame()
        if not len(tab) and any(int(c.get("runs", 0)) for c in meta["cases"]):
            raise DamagedFile("table.parquet is missing or empty, and survey.json lists runs")
        cases = [CaseResult(str(c["case"]), tab[tab["case"] == c["case"]] if len(tab) else tab,
                            dict(c["not_applicable"]), list(c["measures"]), float(c["wall_s"]), int(c["rounds_run"]),
                            int(c["rounds"]), str(c["note"]), c["repeat_check"])
                 for c in meta["cases"]]
        wall = float(meta["wall_s"])
        targets = (meta.get("options") or {}).get("targets") or None
    except DamagedFile as exc:
        raise damaged(str(exc)) from None
    except Exception as exc:  # a missing key, a wrong type; pyarrow raises several types for a truncated file
        raise damaged(f"{type(exc).__name__}: {str(exc)[:120]}") from None
    # the verdicts, profiles and recommendations by today's rules, from the runs as stored
    res = survey.score(cases, targets)
    return replace(res, name=name, folder=f, wall_s=wall)
