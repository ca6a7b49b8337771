"""``bwbench report``: the study report that says which optimiser to use, and why.

Writes ``report.md`` and one self-contained ``report.html`` (figures as base64 data URIs, inline
CSS, no scripts, no external links or fonts: it opens from a file with no network), plus every
figure and the CSV behind it, into the output folder.

The recommendation is generated from the numbers by a rule stated in the report
(``RULE``): best = lowest mean Friedman rank; as good within noise = not significantly different
from the best (Holm-corrected pairwise Wilcoxon, α = 0.05); short at this budget = never within
10 % of the best known MSE; avoid = significantly worse than random search.
"""

from __future__ import annotations

import argparse
import base64
import html
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from bwbench.report import figures
from bwbench.analysis import identifiability
from bwbench.study import results as results_db
from bwbench.analysis import statistics
from bwbench.data import synthetic
from bwbench.errors import UserError
from bwbench.models.switched_bouc_wen import PARAM_NAMES
from bwbench.data.parameters import LABELS, LOWER, UPPER
from bwbench.study.config import BENCHMARK_PROBLEM

ALPHA = statistics.ALPHA
BASELINE = "random"  # the backend "significantly worse than" disqualifies
RULE = (
    "best = the backend with the lowest mean Friedman rank (ranks of the median final MSE across seeds, "
    "per specimen; ties broken by the lower median RMSE); **as good within noise** = not significantly "
    "different from the best by a pairwise Wilcoxon signed-rank test on the paired (specimen, seed) "
    f"log10 final MSEs after Holm correction at α = {ALPHA:g}; **short at this budget** = success rate 0 "
    "at the 10 % tolerance (it may get there with more evaluations); **avoid** = significantly worse than "
    f"random search ('{BASELINE}', when it is in the study) by the same test. Every other backend is "
    "reported as significantly worse than the best. Random search is the baseline, not a candidate."
)


# ------------------------------------------------------------------------------------ formatting

def _g(x, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return f"{x:.{digits}g}"


def _unit_of(setting: str) -> str:
    """Unit of a generator setting, from its name's suffix (amplitude_mm, speed_mm_per_min, ...)."""
    for suffix, unit in (("_mm_per_min", "mm/min"), ("_mm", "mm"), ("_hz", "Hz"), ("_s", "s"), ("_n", "N")):
        if setting.lower().endswith(suffix):
            return unit
    return ""


def _join(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _evals(x) -> str:
    """An evaluation count (ERT): whole numbers with thousands separators, ∞ for never."""
    if x is None or np.isnan(x):
        return "–"
    return "∞" if np.isinf(x) else f"{x:,.0f}"


def _pct(x) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{x:.0%}"


def _p(x) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.2g}" if x >= 1e-3 else f"{x:.1e}"


def _spread(values) -> str:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return "–"
    if values.size == 1:
        return _g(values[0])
    return f"{_g(np.median(values))} [{_g(values.min(), 3)}, {_g(values.max(), 3)}]"


# ------------------------------------------------------------------------------- recommendation

def recommend(table: pd.DataFrame, wilcoxon: pd.DataFrame, friedman: statistics.Friedman, budget) -> dict:
    """Apply ``RULE`` to the ranking ``table`` (sorted by mean rank) and the pairwise tests.

    Returns ``best``, ``tied`` [(name, p_holm)], ``worse`` [(name, p_holm)], ``short`` [name],
    ``avoid`` [(name, reason)] and the generated ``text`` (markdown).
    """
    best = table.iloc[0]
    b = best["optimizer"]
    names = list(table["optimizer"])
    success10 = dict(zip(table["optimizer"], table["success_10%"]))
    tied, worse, short, avoid = [], [], [], []
    for name in names[1:]:
        row = statistics.compare(wilcoxon, b, name)
        p = row["p_holm"] if row else np.nan
        significant = bool(row and row["significant"])
        if name == BASELINE:
            continue
        vs = statistics.compare(wilcoxon, name, BASELINE) if BASELINE in names else None
        if vs and vs["significant"] and vs["median_diff"] > 0:
            avoid.append((name, f"is significantly worse than random search (Holm p = {_p(vs['p_holm'])})"))
        elif success10[name] == 0:
            short.append((name, p, significant))
        elif significant:
            worse.append((name, p))
        else:
            tied.append((name, p))
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    text = (f"For this problem at a budget of {budget_text} evaluations use **{b}**: it has the lowest mean "
            f"Friedman rank ({best['mean_rank']:.2f} over {friedman.n_blocks} specimen(s)), a median RMSE of "
            f"{_g(best['median_rmse_N'], 3)} N, and {_pct(best['success_10%'])} of its runs came within 10 % of the "
            f"best known MSE (ERT {_evals(best['ert_10%'])} evaluations).")
    if success10[b] == 0:
        text += f" Even {b} never came within 10 % of the best known fit: consider a larger budget."
    if tied:
        text += " " + "; ".join(f"**{n}** is as good within noise (Holm-corrected Wilcoxon p = {_p(p)})"
                                for n, p in tied) + "."
    else:
        text += f" No other backend is statistically indistinguishable from {b}."
    if "median_wall_s" in table and table["median_wall_s"].notna().any():
        # Same evaluations, not the same time: between equals, the faster one is the better buy.
        wall = dict(zip(table["optimizer"], table["median_wall_s"]))
        text += " Median wall time per run on one core: " + ", ".join(
            f"{n} {_g(wall[n], 2)} s" for n in [b] + [n for n, _ in tied]) + "."
    if worse:
        text += " " + "; ".join(f"{n} is significantly worse than {b} (p = {_p(p)})" for n, p in worse) + "."
    if short:
        text += (f" Short at this budget (no run came within 10 % of the best known MSE): "
                 f"{_join([n for n, _, _ in short])}.")
        not_sig = [f"{n} (p = {_p(p)})" for n, p, sig in short if not sig]
        if not_sig:
            text += f" Of these, {_join(not_sig)} are not significantly different from {b} in final MSE."
    for name, reason in avoid:
        text += f" Avoid **{name}**: it {reason}."
    if BASELINE in names and BASELINE != b:
        row = table[table["optimizer"] == BASELINE].iloc[0]
        text += f" Random search, the baseline, ends at a median RMSE of {_g(row['median_rmse_N'], 3)} N."
    if not np.isfinite(friedman.pvalue):
        text += f" Caution: {friedman.note}; the ranking rests on the pairwise tests alone."
    elif friedman.pvalue >= ALPHA:
        text += (f" Caution: the Friedman test over specimens does not detect a difference between the backends "
                 f"(p = {_p(friedman.pvalue)}, {friedman.n_blocks} specimens): the order of the mean ranks may be "
                 f"chance; more specimens would settle it.")
    return {"best": b, "tied": tied, "worse": worse, "short": [n for n, _, _ in short], "avoid": avoid,
            "text": text}


# -------------------------------------------------------------------------------------- content

class Document:
    """Report content as blocks, rendered to markdown and to self-contained HTML."""

    def __init__(self, out_dir: Path):
        self.out_dir = out_dir
        self.blocks: list[tuple] = []

    def h(self, level: int, text: str):
        self.blocks.append(("h", level, text))

    def p(self, text: str):
        self.blocks.append(("p", text))

    def banner(self, text: str):
        self.blocks.append(("banner", text))

    def bullets(self, items):
        self.blocks.append(("ul", list(items)))

    def table(self, frame: pd.DataFrame, caption: str = ""):
        self.blocks.append(("table", frame.astype(str), caption))

    def figure(self, png: Path, caption: str):
        self.blocks.append(("img", Path(png), caption))

    def pre(self, text: str):
        self.blocks.append(("pre", text))

    # markdown ---------------------------------------------------------------------------------
    def markdown(self) -> str:
        out = []
        for block in self.blocks:
            kind = block[0]
            if kind == "h":
                out.append("#" * block[1] + " " + block[2])
            elif kind == "p":
                out.append(block[1])
            elif kind == "banner":
                out.append(f"> **{block[1]}**")
            elif kind == "ul":
                out.append("\n".join(f"- {item}" for item in block[1]))
            elif kind == "table":
                frame, caption = block[1], block[2]
                cells = lambda row: "| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |"  # noqa: E731
                lines = [cells(frame.columns), "|" + "|".join("---" for _ in frame.columns) + "|"]
                lines += [cells(row) for row in frame.itertuples(index=False)]
                out.append((f"*{caption}*\n\n" if caption else "") + "\n".join(lines))
            elif kind == "img":
                png, caption = block[1], block[2]
                out.append(f"![{caption}]({png.name})\n\n*{caption}* (data: `{png.with_suffix('.csv').name}`)")
            elif kind == "pre":
                out.append("```\n" + block[1] + "\n```")
        return "\n\n".join(out) + "\n"

    # html -------------------------------------------------------------------------------------
    @staticmethod
    def _inline(text: str) -> str:
        text = html.escape(text)
        text = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", text)
        return re.sub(r"`(.+?)`", r"<code>\1</code>", text)

    def html(self, title: str) -> str:
        body = []
        for block in self.blocks:
            kind = block[0]
            if kind == "h":
                body.append(f"<h{block[1]}>{self._inline(block[2])}</h{block[1]}>")
            elif kind == "p":
                body.append(f"<p>{self._inline(block[1])}</p>")
            elif kind == "banner":
                body.append(f'<div class="banner">{self._inline(block[1])}</div>')
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{self._inline(i)}</li>" for i in block[1]) + "</ul>")
            elif kind == "table":
                frame, caption = block[1], block[2]
                head = "".join(f"<th>{self._inline(str(c))}</th>" for c in frame.columns)
                rows = "".join("<tr>" + "".join(f"<td>{self._inline(str(c))}</td>" for c in row) + "</tr>"
                               for row in frame.itertuples(index=False))
                cap = f"<caption>{self._inline(caption)}</caption>" if caption else ""
                body.append(f'<div class="scroll"><table>{cap}<thead><tr>{head}</tr></thead>'
                            f"<tbody>{rows}</tbody></table></div>")
            elif kind == "img":
                png, caption = block[1], block[2]
                data = base64.b64encode(png.read_bytes()).decode("ascii")
                csv_name = html.escape(png.with_suffix(".csv").name)
                body.append(f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
                            f"<figcaption>{self._inline(caption)} (data: <code>{csv_name}</code>)</figcaption>"
                            "</figure>")
            elif kind == "pre":
                body.append(f"<pre>{html.escape(block[1])}</pre>")
        head = (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
                f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n")
        return head + "<body>\n" + "\n".join(body) + "\n</body>\n</html>\n"


_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; max-width: 1500px;
       margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; padding-bottom: .15em; margin-top: 2em; }
.banner { background: #fff3cd; border: 2px solid #d39e00; padding: .6em 1em; font-weight: bold; margin: 1em 0; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: .88em; }
caption { caption-side: top; text-align: left; font-style: italic; padding-bottom: .3em; }
th, td { border: 1px solid #ccc; padding: .25em .55em; text-align: right; white-space: nowrap; }
th { background: #f0f0f0; }
td:first-child, th:first-child { text-align: left; }
tbody tr:nth-child(even) { background: #fafafa; }
.scroll { overflow-x: auto; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: .9em; color: #444; }
code, pre { font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: .9em; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; }
"""


# ---------------------------------------------------------------------------------- the sections

def _truth_mse(study, specimen):
    truth = synthetic.truth_params(study.specimen_path(specimen))
    if truth is None:
        return None
    problem = figures._problem(study, specimen)
    return float(problem.loss_batch(truth[None, :])[0])


def _best_runs(study) -> pd.DataFrame:
    ok = study.runs[(study.runs["status"] == "ok") & np.isfinite(study.runs["mse"])]
    return ok.loc[ok.groupby("specimen")["mse"].idxmin()].set_index("specimen")


def _featured_specimens(study, k: int = 3) -> list[str]:
    posterior = [c.specimen for c in study.chains if c.kind == "posterior"]
    return list(dict.fromkeys(posterior + study.specimens))[:k]


def backends_table(study) -> pd.DataFrame:
    """One row per ranking backend: its family and the options it ran with."""
    try:
        from bwbench.optimize import registry

        backends = registry.available()
    except Exception:  # the report must not depend on every plug-in importing
        backends = {}
    rows = []
    for name in study.optimizers:
        options = study.config.get("optimizers", {}).get(name, {})
        family = getattr(backends.get(name), "family", "–")
        rows.append({"backend": name, "family": family,
                     "options": ", ".join(f"{k}={json.dumps(v)}" for k, v in options.items()) or "defaults"})
    return pd.DataFrame(rows)


def _section_setup(doc, study, synthetic_data: bool):
    s = study.settings
    doc.h(2, "What was compared")
    doc.p(f"Study **{study.name}** (database `{study.path.name}`, bwbench {study.meta.get('bwbench_version', '?')}, "
          f"created {study.meta.get('created_utc', '?')}). Every backend had the same budget of "
          f"**{s.get('budget', '?')} evaluations** per run (one evaluation = one simulation of one parameter vector), "
          f"{s.get('seeds', '?')} seeds per (specimen, backend), study seed {s.get('seed', '?')}; model state "
          f"convention **{s.get('state', '?')}**, excitation **{s.get('excitation', '?')}**.")
    doc.table(backends_table(study), "Backends and their options (as run)")
    post = study.config.get("posterior")
    if post:
        doc.p(f"Posterior sampling (not part of the ranking): {post.get('optimizer')} on "
              f"{', '.join(post.get('specimens', []))}, budget {post.get('budget')} evaluations, "
              f"{post.get('seeds')} seed(s), options {json.dumps(post.get('options', {}))}.")

    doc.h(2, "Data")
    manifest = study.manifest()
    if synthetic_data and manifest:
        doc.banner("SYNTHETIC DATA: every specimen in this study was generated by bwbench from the paper's "
                   "identified parameters (Tables 6–8); the paper's raw force–displacement curves are not public. "
                   "Conclusions are about this synthetic benchmark, not about the real VPP specimens.")
        settings = manifest.get("settings", {})
        doc.p(f"Generator: {manifest.get('generator', '?')}. Note: {manifest.get('note', '')}. Settings:")
        doc.table(pd.DataFrame([{"setting": k, "value": v, "unit": _unit_of(k)} for k, v in settings.items()]),
                  "Generation settings (manifest.json; noise values are 1σ)")
    elif not synthetic_data:
        doc.p("The specimens are not marked synthetic in their manifest: treated as measured data.")
    entries = {Path(e["file"]).stem: e for e in (manifest or {}).get("specimens", [])}
    rows = []
    for specimen in study.specimens:
        e = entries.get(specimen, {})
        truth_mse = _truth_mse(study, specimen)
        rows.append({"specimen": specimen, "material": e.get("material", "–"),
                     "underpressure (MPa)": e.get("underpressure_MPa", "–"), "repeat": e.get("repeat", "–"),
                     "peak force (N)": e.get("peak_force_N", "–"),
                     "MSE of the truth (N²)": _g(truth_mse) if truth_mse is not None else "–"})
    doc.table(pd.DataFrame(rows), "Specimens of the ranking (the truth's MSE is the noise floor a perfect fit reaches)")


def _section_ranking(doc, study, table, fr, wilcoxon, rec):
    budget = study.settings.get("budget", "?")
    doc.h(2, "Ranking")
    shown = pd.DataFrame({
        "backend": table["optimizer"], "runs": table["runs"], "errors": table["errors"],
        "median RMSE (N)": table["median_rmse_N"].map(lambda x: _g(x, 3)),
        "best RMSE (N)": table["best_rmse_N"].map(lambda x: _g(x, 3)),
        "success ≤1 %": table["success_1%"].map(_pct), "success ≤10 %": table["success_10%"].map(_pct),
        "ERT 1 % (evals)": table["ert_1%"].map(_evals),
        "ERT 10 % (evals)": table["ert_10%"].map(_evals),
        "mean Friedman rank": table["mean_rank"].map(lambda x: _g(x, 3)),
        "median wall time (s)": table["median_wall_s"].map(lambda x: _g(x, 2)),
    })
    doc.table(shown, f"Ranking runs at a budget of {budget} evaluations, best mean rank first")
    doc.p("Success at τ: the run's best MSE came within (1 + τ) × the best known MSE of its specimen (the lowest "
          "MSE of any run in this database, ranking or posterior). ERT (expected running time, COCO definition) = "
          "evaluations spent by all runs (evaluations to target for the successful ones, all their evaluations for "
          "the others) / number of successful runs, pooled over specimens; ∞ = no run succeeded. Wall time is "
          "per run on one core; it is not part of the ranking (the budget is), but equal evaluations do not "
          "cost equal time: the model needs more substeps in the stiff corners of the box (n < 1).")
    if np.isfinite(fr.pvalue):
        doc.p(f"Friedman test over {fr.n_blocks} specimens (blocks) and {len(table)} backends (treatments), value = "
              f"median final MSE across seeds: χ² = {fr.statistic:.3g}, **p = {_p(fr.pvalue)}**.")
    else:
        doc.p(f"{fr.note}.")
    rows = []
    for r in wilcoxon.itertuples():
        verdict = f"{r.better} better" if r.significant else "no significant difference"
        rows.append({"A": r.a, "B": r.b, "pairs": r.n_pairs, "A wins": r.wins_a, "B wins": r.wins_b,
                     "median log10(MSE A / MSE B)": _g(r.median_diff, 3), "p": _p(r.p),
                     "p (Holm)": _p(r.p_holm), "verdict (α = 0.05)": verdict})
    if rows:
        doc.table(pd.DataFrame(rows), "Pairwise Wilcoxon signed-rank tests, paired by (specimen, seed), Holm-corrected")
    doc.p("The Wilcoxon tests are on log10 of the final MSE (a ratio, so a specimen with larger forces does not "
          "dominate); a failed run counts as one decade worse than the worst finished run on its specimen. Holm's "
          "step-down correction is written out in `bwbench.statistics.holm` because scipy offers only FDR "
          "corrections and statsmodels is not a dependency.")
    doc.h(2, "Recommendation")
    doc.p(rec["text"])
    doc.p("Rule used: " + RULE)


def _section_tables(doc, study, best_backend):
    doc.h(2, "Identified parameters per specimen (the paper's Tables 6–8)")
    doc.p(f"For each specimen: the best run of any backend (F_err = −MSE, N², the paper's eq 6), the spread of the "
          f"best backend ({best_backend}) across its seeds as median [min, max], and, for synthetic specimens, the "
          f"truth with its own F_err.")
    ranking = study.ranking
    ok = ranking[(ranking["status"] == "ok") & np.isfinite(ranking["mse"])]
    best = ok.loc[ok.groupby("specimen")["mse"].idxmin()].set_index("specimen")
    for material, group in ranking.groupby("material", sort=False):
        specimens = (group.drop_duplicates("specimen").sort_values(["underpressure_MPa", "repeat"])["specimen"])
        for half, names in (("tension set (+)", PARAM_NAMES[:7]), ("compression set (−)", PARAM_NAMES[7:])):
            rows = []
            for specimen in specimens:
                first = group[group["specimen"] == specimen].iloc[0]
                label = f"{first['underpressure_MPa']:g} MPa r{int(first['repeat'])}"
                b = best.loc[specimen]
                rows.append({"specimen": label, "row": f"best: {b['optimizer']} seed {int(b['replicate'])}",
                             "F_err (N²)": _g(-b["mse"], 5), **{LABELS[n]: _g(b[n]) for n in names}})
                runs = ok[(ok["specimen"] == specimen) & (ok["optimizer"] == best_backend)]
                rows.append({"specimen": "", "row": f"{best_backend}: median [min, max], {len(runs)} seeds",
                             "F_err (N²)": _spread(-runs["mse"]), **{LABELS[n]: _spread(runs[n]) for n in names}})
                truth = synthetic.truth_params(study.specimen_path(specimen))
                if truth is not None:
                    truth_mse = _truth_mse(study, specimen)
                    rows.append({"specimen": "", "row": "truth (synthetic)", "F_err (N²)": _g(-truth_mse, 5),
                                 **{LABELS[n]: _g(truth[PARAM_NAMES.index(n)]) for n in names}})
            doc.table(pd.DataFrame(rows), f"{material}: {half}")


def _good_run_spread(study, specimen, tolerance=figures.SPREAD_TOLERANCE):
    """Per parameter, (max − min)/(Table 5 range) over the ranking runs within tolerance; None if < 2 runs."""
    best = statistics.best_known(study.runs)[specimen]
    ok = study.ranking[(study.ranking["specimen"] == specimen) & (study.ranking["status"] == "ok")]
    good = ok[ok["mse"] <= best * (1 + tolerance)]
    if len(good) < 2:
        return None, len(good)
    unit = (good[list(PARAM_NAMES)].to_numpy(dtype=float) - LOWER) / (UPPER - LOWER)
    return dict(zip(PARAM_NAMES, unit.max(axis=0) - unit.min(axis=0))), len(good)


def _section_identifiability(doc, study, specimens, profile_params, profile_grid, log):
    doc.h(2, "Identifiability: what the data cannot pin down")
    doc.p("At the best fit of each specimen: the Jacobian of the force residual (model − measured, N) with respect "
          "to the 14 parameters scaled to their Table 5 range, by central differences (step 1e-4 of the range); its "
          "singular values say how strongly the force responds along each direction of parameter space. A direction "
          "is *undetermined* when even a step across the whole range changes the residual sum of squares by less "
          "than the 95 % threshold for one parameter (1.96² × the noise variance); moving along the undetermined "
          "directions inside the box gives each parameter a *free range*. A parameter is *poorly determined* when its "
          f"free range or its linearised standard error exceeds {identifiability.POOR_SE:.0%} of its range. This is a "
          "local, linear analysis at one point; the profiles and the spread across seeds test it further.")
    best_runs = _best_runs(study)
    results = []
    for k, specimen in enumerate(specimens):
        run = best_runs.loc[specimen]
        params = run[list(PARAM_NAMES)].to_numpy(dtype=float)
        widest = profile_params if k == 0 else 0
        if widest:
            print(f"profiling {widest} parameter(s) on {specimen} ...", file=log, flush=True)
        try:
            result = identifiability.analyse(study.specimen_path(specimen), params,
                                             study.settings.get("state", "shared"),
                                             study.settings.get("excitation", "measured"),
                                             profile_widest=widest, grid=profile_grid)
        except UserError as err:
            doc.p(f"{specimen}: identifiability analysis not possible: {err}")
            continue
        results.append(result)
        doc.h(3, specimen)
        rel = result["relative_singular_values"]
        poor = result["poorly_determined"]
        well = [n for n in PARAM_NAMES if n not in poor]
        doc.p(f"Best fit: {run['optimizer']} ({run['kind']}, seed {int(run['replicate'])}), "
              f"RMSE {result['rmse_N']:.3g} N. "
              f"The singular values span {math.log10(rel[0] / max(rel[-1], 1e-300)):.1f} decades (condition number "
              f"{_g(result['condition_number'], 3)}); {result['numerically_zero']} are below 1e-6 of the largest and "
              f"{result['undetermined_directions']} directions are undetermined at the noise level "
              f"({result['noise_rmse_N']:.3g} N RMSE).")
        doc.bullets([f"σ/σmax = {w['ratio']:.1e}: {w['text']}" for w in result["weakest"]])
        spread, n_good = _good_run_spread(study, specimen)
        rows = []
        for n in PARAM_NAMES:
            lo, hi = result["free_range"][n]
            rows.append({"parameter": LABELS[n], "best fit": _g(result["params"][n]),
                         "free range": f"{_g(lo)} – {_g(hi)}",
                         "free (% of range)": f"{result['free_range_unit'][n]:.0%}",
                         "s.e. (% of range)": f"{min(result['standard_error_unit'][n], 9.99):.1%}",
                         f"spread of {n_good} good run{'s' if n_good != 1 else ''} (% of range)":
                             (f"{spread[n]:.0%}" if spread else "–"),
                         "poorly determined": "yes" if n in poor else ""})
        doc.table(pd.DataFrame(rows), f"{specimen}: local identifiability at the best fit")
        text = (f"The data cannot pin down {', '.join(LABELS[n] for n in poor)}" if poor else
                "Every parameter is determined to better than 10 % of its range")
        text += f"; well determined: {', '.join(LABELS[n] for n in well) or 'none'}."
        if spread:
            wide = [n for n in PARAM_NAMES if spread[n] > identifiability.POOR_SE]
            explained = [n for n in wide if n in poor]
            unexplained = [n for n in wide if n not in poor]
            text += (f" Across the {n_good} ranking runs within 10 % of the best known MSE, {len(wide)} parameters "
                     f"spread over more than {identifiability.POOR_SE:.0%} of their range; {len(explained)} of them "
                     "are flagged poorly determined")
            if unexplained:
                text += (f", while {_join([f'{LABELS[n]} ({spread[n]:.0%})' for n in unexplained])} "
                         f"{'is' if len(unexplained) == 1 else 'are'} determined locally yet "
                         f"scatter{'s' if len(unexplained) == 1 else ''}: there the good "
                         "runs sit in different minima, not along one flat valley")
            text += "."
            if wide and len(explained) >= len(wide) / 2:
                text += (" So most of the scatter across seeds is what the data allow: runs that fit equally well "
                         "land at different points along the undetermined combinations, so the scatter of these "
                         "parameters is no fault of the optimisers and cannot be read as a trend in the material.")
        else:
            text += (f" Only {n_good} ranking run(s) came within 10 % of the best known MSE, too few to compare the "
                     "spread across seeds with this analysis.")
        doc.p(text)
        if result["profiles"]:
            png = figures.profiles(result, doc.out_dir, synthetic.is_synthetic(study.specimen_path(specimen)))
            doc.figure(png, f"Profile likelihoods on {specimen}: each point re-optimises the other 13 parameters "
                            f"(scipy L-BFGS-B on log MSE, two starts, 15 iterations each)")
            doc.p(_profile_sentence(result))
    return results


def _profile_sentence(result: dict) -> str:
    """What the profiles say, in words: over the whole range, below the 95 % threshold (not identifiable
    at all), within 2 × the best MSE (practically equivalent fits), or neither."""
    values = [p["mse"] for points in result["profiles"].values() for p in points if p["mse"] is not None]
    floor = min([result["mse"], *values])
    threshold = floor + 1.96**2 * result["noise_rmse_N"] ** 2 / result["n_data"]
    parts = []
    for name, points in result["profiles"].items():
        worst = max((p["mse"] if p["mse"] is not None else math.inf) for p in points)
        if worst <= threshold:
            parts.append(f"{LABELS[name]}: below the 95 % threshold over its whole Table 5 range, so the data do not "
                         "identify it at all (the others compensate exactly)")
        elif worst <= 2 * floor:
            parts.append(f"{LABELS[name]}: statistically identifiable, but every value in its range fits within "
                         f"2 × the best MSE (worst {_g(worst, 3)} N² vs {_g(floor, 3)} N²): fits that look "
                         "equally good")
        else:
            parts.append(f"{LABELS[name]}: the profile rises to {_g(worst, 3)} N² (best {_g(floor, 3)} N²), so the "
                         "data constrain it away from its best value")
    return "Profiles — " + "; ".join(parts) + "."


def _section_posterior(doc, study, log):
    chains = [c for c in study.chains if c.kind == "posterior"]
    if not chains:
        return []
    from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs

    doc.h(2, "Posterior sampling (emcee)")
    diags = []
    for chain in chains:
        d = statistics.chain_diagnostics(chain.samples, chain.acceptance_fraction, chain.log_prob)
        diags.append((chain, d))
        png = figures.posterior(study, doc.out_dir, chain)
        burn = chain.steps // 2
        stuck = statistics.stuck_walkers(chain.samples, chain.log_prob, burn)
        corr = posterior_correlation(chain.physical(burn, ~stuck), list(PARAM_NAMES))
        pairs = strongest_pairs(corr, 4)
        doc.h(3, chain.specimen)
        doc.table(pd.DataFrame([{
            "steps": d["steps"], "walkers": d["walkers"], "acceptance fraction": f"{d['acceptance_fraction']:.2f}",
            "τ max (steps)": _g(d["tau_max"], 3), "τ median (steps)": _g(float(np.nanmedian(d["tau"])), 3),
            "effective samples (steps·walkers/τ)": _evals(d["ess"]), "50·τ (steps)": _evals(50 * d["tau_max"])}]),
            f"{chain.optimizer} chain diagnostics (emcee.autocorr.integrated_time on the whole chain)")
        if d["warnings"]:
            doc.banner("Warning: " + "; ".join(d["warnings"]) + ".")
        else:
            doc.p("No warning: the chain is longer than 50·τ and the acceptance fraction is in 0.2–0.5.")
        doc.p("Strongest posterior correlations (second half of the chain, stuck walkers left out): "
              + "; ".join(f"{LABELS[a]}–{LABELS[b]} r = {r:+.2f}" for a, b, r in pairs) + ".")
        doc.figure(png, f"{chain.specimen}: posterior marginals of the 14 parameters and the 4 most correlated pairs, "
                        "with each backend's best fit and the truth")
    return diags


def _section_limits(doc, study, fr, diags, synthetic_data):
    s = study.settings
    n_spec = len(study.specimens)
    items = []
    if synthetic_data:
        items.append("The data are synthetic, generated with the same model (shared state) that is fitted: there "
                     "is no model error, only noise. On real specimens the best MSE will be set by model error and "
                     "the differences between backends may shrink or change.")
    items.append(f"{n_spec} specimen(s) and {s.get('seeds', '?')} seeds per backend: the Friedman test has "
                 f"{n_spec} blocks{' and little power' if n_spec < 6 else ''}; the pairwise Wilcoxon tests pair seed r "
                 "of one backend with seed r of another on the same specimen (the seeds are independent, so the "
                 "pairing only removes the specimen effect).")
    items.append(f"One budget ({s.get('budget', '?')} evaluations): the ranking can change at another budget "
                 "(see the ECDF and convergence figures for how each backend would do with less).")
    items.append("The best known MSE is the best found in this database, not the global optimum; success rates and "
                 "ERT are relative to it." + (" The truth's MSE (table above) shows how far it is from the noise "
                                             "floor." if synthetic_data else ""))
    items.append(f"Model choices fixed for the whole study: state '{s.get('state', '?')}', excitation "
                 f"'{s.get('excitation', '?')}'.")
    items.append("Identifiability is analysed locally (linearised at the best fit); profiles use a small local "
                 "re-optimisation budget and can miss a better fit far away, so a profile is an upper bound.")
    for chain, d in diags:
        if d["warnings"]:
            items.append(f"The posterior chain on {chain.specimen} is too short for reliable summaries "
                         f"({d['steps']} steps, τ ≈ {_g(d['tau_max'], 3)}).")
    if np.isfinite(fr.pvalue) and fr.pvalue >= ALPHA:
        items.append(f"The Friedman test does not reject equal performance (p = {_p(fr.pvalue)}).")
    doc.h(2, "Limits of this study")
    doc.bullets(items)


# ----------------------------------------------------------------------------------- entry points

def build_report(db, out, *, data_dir=None, identifiability_specimens: int = 3, profile_params: int = 2,
                 profile_grid: int = 7, log=None) -> Path:
    """Write report.md, report.html, the figures and their CSVs into ``out``; return report.html's path.

    A ``bouc-wen-benchmark`` study gets the benchmark report (``bwbench.problems.noel_schoukens.report``).

    ``profile_params``: profile likelihoods of that many parameters (the widest free ranges) on the
    first featured specimen (0: none; they cost about a second per grid point).
    Raises ``UserError`` for a missing or non-study database, or one without ranking runs.
    """
    import sys

    log = sys.stderr if log is None else log
    study = results_db.load_study(db, data_dir)
    if study.ranking.empty:
        raise UserError(f"{db}: the study has no ranking runs yet: nothing to report")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if study.problem == BENCHMARK_PROBLEM:
        from bwbench.problems.noel_schoukens import report as benchmark_report

        return benchmark_report.build_report(study, out, log=log)
    synthetic_data = any(synthetic.is_synthetic(study.specimen_path(s)) for s in study.specimens)
    doc = Document(out)

    table, fr = statistics.ranking_table(study.runs, study.traces, study.optimizers)
    wilcoxon = statistics.pairwise_wilcoxon(study.ranking)
    rec = recommend(table, wilcoxon, fr, study.settings.get("budget", "?"))
    best_backend = rec["best"]
    featured = _featured_specimens(study, identifiability_specimens)

    doc.h(1, f"Optimiser comparison: {study.name}")
    if synthetic_data:
        doc.banner("SYNTHETIC DATA — generated from the paper's Tables 6–8, not measured.")
    doc.p("**Recommendation.** " + rec["text"])
    _section_setup(doc, study, synthetic_data)
    _section_ranking(doc, study, table, fr, wilcoxon, rec)
    table.to_csv(out / "ranking.csv", index=False)
    wilcoxon.to_csv(out / "wilcoxon.csv", index=False)

    print("figures ...", file=log, flush=True)
    doc.h(2, "Figures")
    doc.figure(figures.convergence(study, out, featured),
               "Convergence (the paper's Fig 16 for every backend): median and interquartile range over seeds")
    doc.figure(figures.runtime_ecdf(study, out),
               "Runtime ECDF: fraction of (specimen, seed, target) triples reached within x evaluations")
    doc.figure(figures.waterfall(study, out), "Waterfall: the final MSE of every ranking run, sorted per backend")
    doc.figure(figures.hysteresis_loops(study, out, featured[0]),
               f"Measured vs fitted loops on {featured[0]}, best run of each backend (the paper's Figs 20–21)")
    doc.figure(figures.parameter_spread(study, out, featured),
               "Parameters of every run within 10 % of the best known MSE, scaled to the Table 5 range")
    for material in study.ranking["material"].dropna().unique():
        doc.figure(figures.parameters_vs_underpressure(study, out, best_backend, material),
                   f"{material}: parameters against underpressure, {best_backend} (the paper's Figs 18–19)")
    _section_tables(doc, study, best_backend)
    print("identifiability ...", file=log, flush=True)
    _section_identifiability(doc, study, featured, profile_params, profile_grid, log)
    diags = _section_posterior(doc, study, log)
    _section_limits(doc, study, fr, diags, synthetic_data)

    (out / "report.md").write_text(doc.markdown(), encoding="utf-8")
    html_path = out / "report.html"
    html_path.write_text(doc.html(f"bwbench report: {study.name}"), encoding="utf-8")
    return html_path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", required=True, help="study database (SQLite, written by bwbench compare)")
    parser.add_argument("--out", required=True, help="output folder, e.g. reports/NAME")
    parser.add_argument("--data", help="folder with the specimen CSVs and manifest.json, or the Bouc-Wen benchmark "
                                       "folder (default: the study's)")
    parser.add_argument("--profiles", type=int, default=2,
                        help="profile likelihoods of this many parameters on the first specimen (default 2; 0 = none)")


def cli_main(args) -> int:
    """``bwbench report --db PATH --out reports/NAME``; prints the path of report.html."""
    if args.profiles < 0:
        raise UserError(f"--profiles must be 0 or more, got {args.profiles}")
    path = build_report(args.db, args.out, data_dir=getattr(args, "data", None),
                        profile_params=getattr(args, "profiles", 2))
    print(path)
    return 0
