"""``bwbench report`` for a Bouc-Wen benchmark study (``problem = "bouc-wen-benchmark"``).

Same output as the switched-model report (``report.md``, one self-contained ``report.html``,
every figure with its CSV) and the same statistics where they apply: success rates and ERT
against the best known training MSE, backends ranked by their median final training MSE across
seeds. There is one specimen (``train_multisine``), so there are no blocks for a Friedman test:
the seeds are not blocks (seed r of one backend and seed r of another share nothing), so the
runs of each backend are compared as independent samples: Kruskal–Wallis over all backends,
then a two-sided Mann–Whitney U test of each backend against the best, Holm-corrected.

What the benchmark adds: the test e_RMS (m) of every run (computed by the runner, never seen by
the optimisers) next to the figures published with the benchmark, the identified parameters
next to the truth through the identifiable products βγ and βδ, and the identifiability of the
8 parameters on the training residual (the exact β–γ–δ scaling invariance).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from bwbench.problems.noel_schoukens import figures as benchmark_figures
from bwbench.report import figures
from bwbench.analysis import identifiability
from bwbench.analysis import statistics
from bwbench.problems.noel_schoukens import problem as bm
from bwbench.errors import InputFileError, UserError
from bwbench.report.build import Document, _evals, _g, _join, _p, _pct, backends_table
from bwbench.study.config import BENCHMARK_FILES, data_digest

SOURCE = ("J.P. Noël and M. Schoukens, “Hysteretic benchmark with a dynamic nonlinearity”, Workshop on Nonlinear "
          "System Identification Benchmarks, Brussels, 2016; data and description at www.nonlinearbenchmark.org")
TIE_TOLERANCE = 0.01  # medians of training MSE within 1 %: a tie in practice
TARGET_M = 1e-5  # e_RMS target on test_multisine (m): below every published black-box figure but one
# The README's figures on test_multisine (m): (model, kind, e_RMS).
PUBLISHED = (
    ("true parameters, RK4 at 15 kHz (benchmark README)", "reference", 2e-7),
    ("dynoNet", "black-box", 4.5e-5),
    ("NFIR", "black-box", 1.6e-4),
    ("PNLSS, 34 parameters", "black-box", 5.4e-5),
    ("PNLSS, 217 parameters", "black-box", 1.2e-5),
)
# Finite-difference step (unit coordinates) of the identifiability Jacobian. Not the switched
# model's 1e-4: the residual is only piecewise smooth in the parameters (the |ẏ| and |z| kinks move
# across the fixed RK4 stages), and at 1e-4 the difference quotients of single coordinates mix
# slopes across kinks, which leaves σ_min/σ_max ≈ 6e-4 at the truth along the exact invariance.
# At 1e-7 (1e-8 gives the same) it is 1e-10 there, and the other seven singular values do not
# change (the second smallest is 3.3e-3 of the largest at both steps).
JACOBIAN_STEP = 1e-7
NAMES = bm.PARAM_NAMES
LABELS = benchmark_figures.LABELS
UNITS = benchmark_figures.UNITS


def _head(name: str) -> str:
    unit = UNITS[name]
    return LABELS[name] if unit == "–" else f"{LABELS[name]} ({unit})"


def _e(x) -> str:
    """A length in metres, scientific: 1.23e-05."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return "∞" if math.isinf(x) else f"{x:.2e}"


def _spread4(values) -> str:
    """median [min, max], all to 4 significant digits."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return "–"
    return f"{_g(float(np.median(values)))} [{_g(float(values.min()))}, {_g(float(values.max()))}]"


def _e_spread(values) -> str:
    values = np.asarray(values, dtype=float)
    values = values[~np.isnan(values)]
    if values.size == 0:
        return "–"
    return f"{_e(np.median(values))} [{_e(values.min())}, {_e(values.max())}]"


# ------------------------------------------------------------------------------------ the numbers

def load_problem(study) -> bm.BoucWenBenchmarkProblem:
    """The benchmark problem on the study's data folder; ``UserError`` if the files are missing or
    are not the ones the study ran on (their SHA-256 is part of the configuration)."""
    folder = Path(study.data_dir)
    missing = [f for f in BENCHMARK_FILES if not (folder / f).is_file()]
    if missing:
        raise UserError(f"the Bouc-Wen benchmark files are not in {folder} (missing {', '.join(missing)}); "
                        "point to the folder with --data PATH")
    expected = study.settings.get("data_sha256")
    if expected and data_digest(folder, BENCHMARK_FILES) != expected:
        raise UserError(f"the benchmark files in {folder} are not the ones this study ran on (SHA-256 differs); "
                        "point to the right folder with --data PATH")
    try:
        return bm.BoucWenBenchmarkProblem(folder)
    except InputFileError as err:
        raise UserError(str(err)) from None


def _finished(runs: pd.DataFrame) -> pd.DataFrame:
    return runs[(runs["status"] == "ok") & np.isfinite(runs["mse"])]


def practical_ties(table: pd.DataFrame) -> list[str]:
    """Backends whose median final training MSE is within ``TIE_TOLERANCE`` of the best's (the
    ranking table's first row): an order among them is not worth reporting as a difference."""
    rmse = table["median_rmse_N"].to_numpy(dtype=float)  # sqrt of the median MSE, in m here
    best = rmse[0] ** 2
    return [o for o, r in zip(table["optimizer"], rmse) if np.isfinite(r) and r**2 <= best * (1 + TIE_TOLERANCE)]


def backend_results(study, order) -> pd.DataFrame:
    """Per backend: its best run (lowest training MSE: chosen without looking at the test files),
    that run's test e_RMS, the e_RMS of every seed, and how many seeds reached ``TARGET_M``."""
    rows = []
    ranking = study.ranking
    for optimizer in order:
        runs = ranking[ranking["optimizer"] == optimizer]
        ok = _finished(runs)
        multisine = runs["test_multisine_erms_m"].to_numpy(dtype=float)
        sweep = runs["test_sinesweep_erms_m"].to_numpy(dtype=float)
        # a failed run or a blown-up test simulation is a miss, not a missing value
        multisine = np.where(np.isnan(multisine), np.inf, multisine)
        sweep = np.where(np.isnan(sweep), np.inf, sweep)
        best = ok.loc[ok["mse"].idxmin()] if len(ok) else None
        rows.append({
            "optimizer": optimizer, "runs": len(runs),
            "best_replicate": -1 if best is None else int(best["replicate"]),  # -1: no finished run
            "best_train_rmse_m": math.nan if best is None else math.sqrt(best["mse"]),
            "best_multisine_m": math.nan if best is None else _metric(best, "test_multisine_erms_m"),
            "best_sweep_m": math.nan if best is None else _metric(best, "test_sinesweep_erms_m"),
            "median_multisine_m": float(np.median(multisine)), "min_multisine_m": float(np.min(multisine)),
            "max_multisine_m": float(np.max(multisine)),
            "median_sweep_m": float(np.median(sweep)), "min_sweep_m": float(np.min(sweep)),
            "max_sweep_m": float(np.max(sweep)),
            "seeds_below_target": int(np.sum(multisine < TARGET_M)),
        })
    return pd.DataFrame(rows)


def _metric(run, name) -> float:
    x = float(run[name])
    return math.inf if math.isnan(x) else x


def truth_figures(problem) -> dict:
    """The true parameters through this simulator: training RMSE and both test e_RMS (m)."""
    return {"train_rmse_m": float(np.sqrt(problem.loss_batch(bm.TRUE_PARAMS[None, :])[0])),
            **{which: problem.test_error(bm.TRUE_PARAMS, which) for which in bm.TEST_SETS}}


def invariance_tangent(problem, params) -> np.ndarray:
    """Unit vector, in the problem's unit coordinates, along (β·s, γ/s, δ/s) at s = 1."""
    def scaled(s):
        p = np.array(params, dtype=float)
        p[4] *= s
        p[5] /= s
        p[6] /= s
        return problem.to_unit(p)

    eps = 1e-6
    tangent = (scaled(1 + eps) - scaled(1 - eps)) / (2 * eps)
    return tangent / np.linalg.norm(tangent)


def analyse_identifiability(problem, params) -> dict:
    """Jacobian/SVD of the training residual (m) w.r.t. the 8 unit-scaled parameters at ``params``
    (``identifiability.sensitivity``), and the relative standard errors of the 7 identifiable
    quantities m, c, k, α, βγ, βδ, ν (the same analysis with β held at its fitted value)."""
    u = np.clip(problem.to_unit(params), 0.0, 1.0)
    params = problem.from_unit(u)

    def residual(v):
        return problem.simulate(problem.from_unit(v)) - problem.y_period

    sens = identifiability.sensitivity(residual, u, NAMES, [LABELS[n] for n in NAMES], step=JACOBIAN_STEP,
                                       bounds=None)
    tangent = invariance_tangent(problem, params)
    weakest = sens.weakest(3)
    cosine = float(abs(sens.directions[-1] @ tangent))

    # θ = relative change of (m, c, k, α, βγ, βδ, ν); β stays at its fitted value.
    reduced = ("m", "c", "k", "alpha", "beta_gamma", "beta_delta", "nu")
    base = np.array([params[0], params[1], params[2], params[3], params[4] * params[5], params[4] * params[6],
                     params[7]])

    def reduced_residual(x):
        q = base * (1.0 + np.asarray(x))
        p = np.array([q[0], q[1], q[2], q[3], params[4], q[4] / params[4], q[5] / params[4], q[6]])
        return problem.simulate(p) - problem.y_period

    sens7 = identifiability.sensitivity(reduced_residual, np.zeros(7), reduced, step=JACOBIAN_STEP, bounds=None)
    free = sens.free_ranges()
    return {
        "sensitivity": sens, "weakest": weakest, "cosine": cosine, "tangent": tangent,
        "undetermined": int(sens.undetermined().sum()), "poorly_determined": sens.poorly_determined(),
        "free_range_unit": {n: float(hi - lo) for n, (lo, hi) in zip(NAMES, free)},
        "standard_error_unit": dict(zip(NAMES, map(float, sens.standard_errors()))),
        "reduced": reduced, "reduced_values": base, "reduced_relative_se": sens7.standard_errors(),
        "reduced_ratios": sens7.ratios, "noise_rmse_m": math.sqrt(sens.noise_variance),
    }


# ------------------------------------------------------------------------------------- sections

def _budget(study) -> str:
    budget = study.settings.get("budget", "?")
    return f"{budget:,}" if isinstance(budget, int) else str(budget)


def _section_results(doc, study, results, truth, best_backend, ties):
    budget = _budget(study)
    doc.h(2, "Benchmark results: simulation error on the test files")
    rows = []
    for r in results.itertuples():
        rows.append({
            "model": f"Bouc-Wen, identified by {r.optimizer}", "kind": "grey-box, 8 parameters",
            "test_multisine e_RMS (m), best run": _e(r.best_multisine_m),
            "test_multisine, median [min, max] over seeds": f"{_e(r.median_multisine_m)} [{_e(r.min_multisine_m)}, "
                                                             f"{_e(r.max_multisine_m)}]",
            "test_sinesweep e_RMS (m), best run": _e(r.best_sweep_m),
            "test_sinesweep, median [min, max] over seeds": f"{_e(r.median_sweep_m)} [{_e(r.min_sweep_m)}, "
                                                            f"{_e(r.max_sweep_m)}]",
            f"seeds < {TARGET_M:g} m": f"{r.seeds_below_target}/{r.runs}"})
    rows.append({"model": "true parameters, this simulator (RK4 at 2.25 kHz)", "kind": "reference",
                 "test_multisine e_RMS (m), best run": _e(truth["test_multisine"]),
                 "test_sinesweep e_RMS (m), best run": _e(truth["test_sinesweep"])})
    for model, kind, value in PUBLISHED:
        rows.append({"model": model, "kind": kind, "test_multisine e_RMS (m), best run": _e(value)})
    table = pd.DataFrame(rows).fillna("–")
    doc.table(table, f"e_RMS = sqrt(mean((y_model − y_test)²)), simulation error, in metres. Backends at a budget of "
                     f"{budget} evaluations, best training MSE first; each backend's best run is its run with the "
                     "lowest training MSE. Published figures (black-box models and the README's reference) from the "
                     "benchmark's README; none is published for test_sinesweep.")
    counts = _join([f"{r.optimizer} {r.seeds_below_target}/{r.runs}" for r in results.itertuples()])
    doc.p(f"Seeds whose final fit reached e_RMS < {TARGET_M:g} m on test_multisine within the budget of {budget} "
          f"evaluations: {counts}.")
    best = results.set_index("optimizer").loc[best_backend]
    black_box = min(v for _, kind, v in PUBLISHED if kind == "black-box")
    beats = best["best_multisine_m"] < black_box
    text = (f"The best backend, **{best_backend}** (lowest median final training MSE), has a best run (seed "
            f"{int(best['best_replicate'])}) with e_RMS = **{_e(best['best_multisine_m'])} m** on test_multisine"
            f"{' (below the 1e-05 m target)' if best['best_multisine_m'] < TARGET_M else ' (NOT below the 1e-05 m target)'}"
            f" and {_e(best['best_sweep_m'])} m on test_sinesweep. ")
    if beats:
        text += (f"It beats every published black-box figure: the best of them, PNLSS with 217 parameters, has "
                 f"{_e(black_box)} m ({black_box / best['best_multisine_m']:.0f}× larger).")
    else:
        text += f"It does not beat every published black-box figure (the best, PNLSS with 217 parameters: {_e(black_box)} m)."
    if len(ties) > 1:
        below = results.set_index("optimizer")["seeds_below_target"]
        runs = results.set_index("optimizer")["runs"]
        text += (f" By median training MSE, {_join([f'**{o}**' for o in ties])} are tied in practice (medians within "
                 f"{TIE_TOLERANCE:.0%} of each other's): among them the seed counts above "
                 f"({_join([f'{o} {below[o]}/{runs[o]}' for o in ties])}) say which is the more reliable.")
    doc.p(text)
    doc.p(f"For scale: the test output has a standard deviation of 6.7e-04 m; the true parameters leave "
          f"{_e(truth['test_multisine'])} m on test_multisine through this simulator (RK4 at 2.25 kHz without the "
          f"data's decimation filter; the README's RK4 at 15 kHz gives 2e-07 m) and {_e(truth['test_sinesweep'])} m "
          "on test_sinesweep, a floor set by how that file was made (see `bwbench.problems.noel_schoukens.problem`). A grey-box "
          "fit that knows the model structure is expected to beat black-box models, which must learn it: the "
          "published figures say what the data allow, they are not a like-for-like ranking of methods.")


def _section_ranking(doc, study, table, kw, mw, results):
    budget = _budget(study)
    doc.h(2, "Ranking (training MSE)")
    below = results.set_index("optimizer")["seeds_below_target"]
    shown = pd.DataFrame({
        "backend": table["optimizer"], "runs": table["runs"], "errors": table["errors"],
        "median train RMSE (m)": table["median_rmse_N"].map(_e), "best train RMSE (m)": table["best_rmse_N"].map(_e),
        "success ≤1 %": table["success_1%"].map(_pct), "success ≤10 %": table["success_10%"].map(_pct),
        "ERT 1 % (evals)": table["ert_1%"].map(_evals), "ERT 10 % (evals)": table["ert_10%"].map(_evals),
        f"seeds test < {TARGET_M:g} m": [f"{below[o]}" for o in table["optimizer"]],
        "rank": table["mean_rank"].map(lambda x: _g(x, 3)),
    })
    doc.table(shown, f"Ranking runs at a budget of {budget} evaluations, ranked by the median final training MSE "
                     "across seeds (rank 1 = lowest)")
    doc.p("Training MSE: one period (the fifth, steady state) of train_multisine, noise included, so a perfect fit "
          "has a training RMSE near the noise (7.4e-06 m). Success at τ: the run's best MSE came within (1 + τ) × "
          "the best known MSE (the lowest of any run in this database). ERT (COCO) = evaluations spent by all runs "
          "/ number of successful runs; ∞ = no run succeeded.")
    doc.p("Statistics. There is one specimen, so there is no Friedman test: its blocks would have to be the seeds, "
          "and seed r of one backend shares nothing with seed r of another (independent random streams). The seeds "
          "of each backend are therefore treated as an independent sample of its final log10 training MSE (a failed "
          "run counts as one decade worse than the worst finished run): Kruskal–Wallis over all backends, then a "
          "two-sided Mann–Whitney U test of each backend against the best, Holm-corrected over these comparisons.")
    if np.isfinite(kw.pvalue):
        doc.p(f"Kruskal–Wallis over {kw.n_groups} backends: H = {kw.statistic:.3g}, **p = {_p(kw.pvalue)}** "
              f"({'the backends differ' if kw.pvalue < statistics.ALPHA else 'no difference detected'} at α = "
              f"{statistics.ALPHA:g}).")
    else:
        doc.p(f"{kw.note}.")
    if len(mw):
        rows = [{"A (best)": r.a, "B": r.b, "runs A/B": f"{r.n_a}/{r.n_b}",
                 "median log10(MSE A / MSE B)": _g(r.median_diff, 3), "P(A run beats B run)": f"{r.p_superiority:.2f}",
                 "p": _p(r.p), "p (Holm)": _p(r.p_holm),
                 "verdict (α = 0.05)": f"{r.better} better" if r.significant else "no significant difference"}
                for r in mw.itertuples()]
        doc.table(pd.DataFrame(rows), "Mann–Whitney U tests against the best backend, Holm-corrected")
        floor = float(mw["min_p"].min())
        holm_floor = floor * len(mw)
        if holm_floor >= statistics.ALPHA:
            doc.p(f"With these numbers of seeds the smallest two-sided p the exact test can give is {_p(floor)}, "
                  f"and Holm multiplies the smallest p by {len(mw)}: no comparison can be significant at α = "
                  f"{statistics.ALPHA:g} however different the backends are. The order below the best rests on the "
                  "medians, the probabilities of superiority and the seed counts, not on significance; more seeds "
                  "would be needed to test it.")


def _section_parameters(doc, study, results, problem, truth):
    doc.h(2, "Identified parameters")
    doc.p("**β, γ and δ are not separately identifiable.** β enters the model only through the products βγ and βδ: "
          "(β·s, γ/s, δ/s) gives exactly the same output for every s > 0. A fit's β, γ and δ may lie anywhere along "
          "that curve and are not wrong for differing from the truth; compare βγ and βδ (and m, c, k, α, ν), which "
          "the data do determine.")
    names = [*NAMES, "beta_gamma", "beta_delta"]

    def row(label, params, train_rmse, multisine):
        combos = bm.identifiable_combinations(params)
        values = {**dict(zip(NAMES, params)), **combos}
        return {"": label, **{_head(n): _g(float(values[n])) for n in names},
                "train RMSE (m)": _e(train_rmse), "test_multisine e_RMS (m)": _e(multisine)}

    rows = [row("truth", bm.TRUE_PARAMS, truth["train_rmse_m"], truth["test_multisine"])]
    ranking = study.ranking
    for r in results.itertuples():
        if r.best_replicate < 0:
            continue
        run = ranking[(ranking["optimizer"] == r.optimizer) & (ranking["replicate"] == r.best_replicate)].iloc[0]
        rows.append(row(f"{r.optimizer} best (seed {r.best_replicate})", run[list(NAMES)].to_numpy(dtype=float),
                        r.best_train_rmse_m, r.best_multisine_m))
    best = results.iloc[0]
    if best["best_replicate"] >= 0:
        run = ranking[(ranking["optimizer"] == best["optimizer"]) & (ranking["replicate"] == best["best_replicate"])]
        params = run.iloc[0][list(NAMES)].to_numpy(dtype=float)
        fit = {**dict(zip(NAMES, params)), **bm.identifiable_combinations(params)}
        true = {**dict(zip(NAMES, bm.TRUE_PARAMS)), **bm.identifiable_combinations(bm.TRUE_PARAMS)}
        rows.append({"": f"{best['optimizer']} best − truth (% of truth; β, γ, δ alone mean nothing)",
                     **{_head(n): f"{100 * (fit[n] / true[n] - 1):+.2g} %" for n in names}})
        ok = _finished(ranking[ranking["optimizer"] == best["optimizer"]])
        products = np.array([[c["beta_gamma"], c["beta_delta"]] for c in
                             map(bm.identifiable_combinations, ok[list(NAMES)].to_numpy(dtype=float))])
        spread = {**{n: ok[n] for n in NAMES}, "beta_gamma": products[:, 0], "beta_delta": products[:, 1]}
        rows.append({"": f"{best['optimizer']}: median [min, max], {len(ok)} seeds",
                     **{_head(n): _spread4(spread[n]) for n in names},
                     "train RMSE (m)": _e_spread(np.sqrt(ok["mse"])),
                     "test_multisine e_RMS (m)": _e_spread(ok["test_multisine_erms_m"])})
    doc.table(pd.DataFrame(rows).fillna(""), "The true parameters (benchmark README) and each backend's best run; "
                                             "βγ and βδ are the identifiable products")


def _section_identifiability(doc, analysis, label):
    sens = analysis["sensitivity"]
    ratios = sens.ratios
    weakest = analysis["weakest"]
    doc.h(2, "Identifiability: what the data cannot pin down")
    doc.p(f"At the best fit ({label}): the Jacobian of the training residual (model − measured displacement over the "
          "compared period, m) with respect to the 8 parameters scaled to the search box (log10-scaled for m, c, k, "
          f"α, β, γ), by central differences of step {JACOBIAN_STEP:g} of the box (the generic "
          "`identifiability.sensitivity`), and its singular values. A tiny singular value is a direction of parameter "
          "space the output does not see.")
    doc.table(pd.DataFrame([{"k": k + 1, "σ (m per unit range)": f"{s:.3g}", "σ/σmax": f"{r:.1e}",
                             "direction (right-singular vector)": identifiability.describe_direction(
                                 sens.directions[k], sens.labels)}
                            for k, (s, r) in enumerate(zip(sens.singular_values, ratios))]),
              "Singular values of the training-residual Jacobian, largest first")
    w = weakest[0]
    zero = w["ratio"] < identifiability.ZERO_RATIO
    found = zero and analysis["cosine"] > 0.99
    if found:
        doc.p(f"**Finding.** The smallest singular value is σ/σmax = {w['ratio']:.1e}, numerically zero (below "
              f"{identifiability.ZERO_RATIO:g}); its direction, {w['text']} (unit coordinates), is the tangent of the "
              f"exact scaling invariance (β·s, γ/s, δ/s) at this point (|cos| = {analysis['cosine']:.6f}). So the data "
              f"determine β, γ and δ only through βγ and βδ. The next weakest direction has σ/σmax = {ratios[-2]:.1e} "
              f"({weakest[1]['text']}), {ratios[-2] / max(w['ratio'], 1e-300):.0e} times larger.")
    else:
        doc.p(f"**Finding.** The analysis did not resolve the exact β–γ–δ scaling invariance here: the smallest "
              f"singular value is σ/σmax = {w['ratio']:.1e} along {w['text']}, at |cos| = {analysis['cosine']:.3f} "
              "with the invariance's tangent. The invariance holds all the same (it is exact in the model).")
    poor = analysis["poorly_determined"]
    if found and analysis["undetermined"] == 1:
        doc.p(f"At the noise level of this fit ({_e(analysis['noise_rmse_m'])} m RMS) it is the only undetermined "
              "direction (a step across the whole box along it changes the residual less than the noise): every "
              "other combination of the parameters is determined. Moving along it inside the box leaves "
              f"{_join([LABELS[n] for n in poor])} free over "
              + _join([f"{analysis['free_range_unit'][n]:.0%}" for n in poor])
              + " of their ranges (linearised), so the generic analysis flags exactly "
              + ("these" if len(poor) > 1 else "this") + " as poorly determined.")
    elif poor:
        doc.p(f"{analysis['undetermined']} direction(s) undetermined at the noise level of this fit "
              f"({_e(analysis['noise_rmse_m'])} m RMS; a step across the whole box along them changes the residual "
              f"less than the noise); moving along them inside the box leaves {_join([LABELS[n] for n in poor])} free "
              "over " + _join([f"{analysis['free_range_unit'][n]:.0%}" for n in poor])
              + " of their ranges (linearised), so the generic analysis flags them poorly determined.")
    rows = [{"quantity": _head(n), "best fit": _g(float(v)), "relative standard error": f"{se:.1e}"}
            for n, v, se in zip(analysis["reduced"], analysis["reduced_values"], analysis["reduced_relative_se"])]
    doc.table(pd.DataFrame(rows), "The 7 identifiable quantities: linearised standard errors from the noise "
                                  "(relative to the value; same Jacobian analysis with β held fixed)")
    smallest = analysis["reduced_ratios"][-1]
    doc.p(f"In these 7 coordinates the smallest singular value is {smallest:.1e} of the largest"
          + (": no invariance is left once β, γ, δ are replaced by βγ and βδ." if smallest >= identifiability.ZERO_RATIO
             else ", numerically zero: another invariance remains.")
          + " The standard errors are local and assume white noise; the measured noise is band-limited, so they "
            "are optimistic.")


def _section_posterior(doc, study):
    chains = [c for c in study.chains if c.kind == "posterior"]
    if not chains:
        return
    from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs

    doc.h(2, "Posterior sampling")
    for chain in chains:
        d = statistics.chain_diagnostics(chain.samples, chain.acceptance_fraction, chain.log_prob)
        burn = chain.steps // 2
        stuck = statistics.stuck_walkers(chain.samples, chain.log_prob, burn)
        samples = chain.physical(burn, ~stuck, from_unit=bm.from_unit)
        pairs = strongest_pairs(posterior_correlation(samples, list(NAMES)), 4)
        doc.table(pd.DataFrame([{
            "backend": chain.optimizer, "steps": d["steps"], "walkers": d["walkers"],
            "acceptance fraction": f"{d['acceptance_fraction']:.2f}", "τ max (steps)": _g(d["tau_max"], 3),
            "50·τ (steps)": _evals(50 * d["tau_max"])}]), "Chain diagnostics (emcee.autocorr.integrated_time)")
        if d["warnings"]:
            doc.banner("Warning: " + "; ".join(d["warnings"]) + ".")
        doc.p("Strongest posterior correlations (second half, stuck walkers left out): "
              + "; ".join(f"{LABELS[a]}–{LABELS[b]} r = {r:+.2f}" for a, b, r in pairs) + ".")


def _section_limits(doc, study, kw):
    seeds = study.settings.get("seeds", "?")
    items = [
        f"One data set and {seeds} seeds per backend: differences between backends below the best are described, "
        "not tested with power (see the ranking section).",
        f"One budget ({_budget(study)} evaluations): the order can change at another budget (see "
        "the convergence and ECDF figures).",
        "The optimisers see one steady-state period of train_multisine only; the test files are used after the run, "
        "to score its best point, and never to choose between runs (a backend's best run is the one with the "
        "lowest training MSE).",
        "The model structure is the true one, so the fit has no model error; the published black-box models have "
        "to learn the structure.",
        "The simulator (RK4 at 2.25 kHz, no decimation filter) leaves 5e-07 m on test_multisine at the true "
        "parameters, and the sine sweep carries a 2.6e-06 m floor from how the file was made: differences between "
        "fits below these levels are not meaningful.",
        "Identifiability is analysed locally, at the best fit.",
    ]
    if np.isfinite(kw.pvalue) and kw.pvalue >= statistics.ALPHA:
        items.append(f"The Kruskal–Wallis test does not reject equal performance (p = {_p(kw.pvalue)}).")
    doc.h(2, "Limits of this study")
    doc.bullets(items)


def _with_times(table: pd.DataFrame, ranking: pd.DataFrame) -> pd.DataFrame:
    """Add the median wall time per run and the evaluations spent (median) of each backend."""
    if "wall_s" not in ranking:
        return table
    grouped = ranking.groupby("optimizer")
    wall = grouped["wall_s"].median()
    nfev = grouped["nfev"].median()
    return table.assign(**{"median wall time per run (s)": table["backend"].map(lambda o: _g(wall.get(o), 3)),
                           "median evaluations": table["backend"].map(lambda o: _evals(nfev.get(o)))})


# ----------------------------------------------------------------------------------- entry point

def build_report(study, out: Path, log) -> Path:
    """Write the benchmark report of a loaded ``results_db.Study`` into ``out``; return report.html's path."""
    problem = load_problem(study)
    if not len(_finished(study.ranking)):
        raise UserError(f"{study.path}: no ranking run finished (every one raised or found nothing finite): "
                        "nothing to report")
    for metric in ("test_multisine_erms_m", "test_sinesweep_erms_m"):
        if metric not in study.runs:  # no run has metrics (e.g. every finished run blew up on the tests)
            study.runs[metric] = np.nan
    doc = Document(out)
    table, _ = statistics.ranking_table(study.runs, study.traces, study.optimizers)
    order = list(table["optimizer"])
    best_backend = order[0]
    ranking = study.ranking
    kw = statistics.kruskal_wallis(ranking)
    mw = statistics.mann_whitney_vs(ranking, best_backend)
    results = backend_results(study, order)
    truth = truth_figures(problem)
    s = study.settings

    doc.h(1, f"Optimiser comparison on the Bouc-Wen benchmark: {study.name}")
    doc.p(f"Data: the public Bouc-Wen benchmark of nonlinear system identification — {SOURCE}. The files were read "
          f"from `{study.data_dir}` (SHA-256 of the three files recorded with the study).")
    _section_results(doc, study, results, truth, best_backend, practical_ties(table))

    doc.h(2, "What was compared")
    doc.p(f"Study **{study.name}** (database `{study.path.name}`, bwbench {study.meta.get('bwbench_version', '?')}, "
          f"created {study.meta.get('created_utc', '?')}). Problem: fit the 8 parameters (m, c, k, α, β, γ, δ, ν) of "
          "the force-driven Bouc-Wen model to the displacement of one steady-state period of train_multisine "
          "(8,192 samples; loss = MSE in m²). Every backend had the same budget of "
          f"**{_budget(study)} evaluations** per run (one evaluation = one simulation of one parameter vector), "
          f"{s.get('seeds', '?')} seeds, study seed {s.get('seed', '?')}. Search box: every positive parameter a "
          "decade either side of the truth, log-scaled; δ in [−3, 3] and ν in [0.5, 3], linear.")
    doc.table(_with_times(backends_table(study), ranking), "Backends and their options (as run), with the wall "
                                                           "time of their runs (one core each)")

    _section_ranking(doc, study, table, kw, mw, results)
    table.to_csv(out / "ranking.csv", index=False)
    results.to_csv(out / "benchmark_results.csv", index=False)
    mw.to_csv(out / "mann_whitney.csv", index=False)
    _section_parameters(doc, study, results, problem, truth)

    best = results.iloc[0]
    run = ranking[(ranking["optimizer"] == best["optimizer"]) & (ranking["replicate"] == best["best_replicate"])]
    params = run.iloc[0][list(NAMES)].to_numpy(dtype=float)
    label = f"{best['optimizer']}, seed {int(best['best_replicate'])}"
    print("identifiability ...", file=log, flush=True)
    try:
        analysis = analyse_identifiability(problem, params)
    except ValueError:
        doc.p("Identifiability analysis not possible: the model is not finite next to the best fit.")
    else:
        _section_identifiability(doc, analysis, label)

    print("figures ...", file=log, flush=True)
    doc.h(2, "Figures")
    floor = (truth["train_rmse_m"] ** 2, f"true parameters: {truth['train_rmse_m'] ** 2:.2g} m² (noise)")
    doc.figure(figures.convergence(study, out, floors={study.specimens[0]: floor}),
               "Convergence: median and interquartile range over seeds of the best-so-far training MSE")
    doc.figure(figures.runtime_ecdf(study, out),
               "Runtime ECDF: fraction of (seed, target) pairs reached within x evaluations")
    doc.figure(figures.waterfall(study, out), "Waterfall: the final training MSE of every ranking run, sorted per "
                                              "backend")
    doc.figure(benchmark_figures.test_fit(study, out, problem, params, label),
               f"The best fit ({label}) against the test_multisine output, and the error of the fit and of the true "
               "parameters")
    doc.figure(benchmark_figures.parameter_spread(study, out),
               "Identified parameters of the runs within 10 % of the best training MSE, scaled to the search box, "
               "with the truth (×): β, γ, δ scatter along their invariance while βγ and βδ stay on the truth")
    _section_posterior(doc, study)
    _section_limits(doc, study, kw)

    (out / "report.md").write_text(doc.markdown(), encoding="utf-8")
    html_path = out / "report.html"
    html_path.write_text(doc.html(f"bwbench report: {study.name} (Bouc-Wen benchmark)"), encoding="utf-8")
    return html_path
