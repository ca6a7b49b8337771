"""Which backend is better, and how sure are we: success rates, ERT, Friedman, Wilcoxon-Holm, MCMC.

Conventions used throughout:

- a run's *final MSE* (N²) is its best MSE; a run that raised or found nothing finite counts as
  +inf (worse than every finished run);
- the *best known* MSE of a specimen is the lowest final MSE of any run on it in the database,
  ranking and posterior runs alike;
- a run *reaches* tolerance τ when its best-so-far MSE gets to best_known·(1 + τ); its
  *evaluations to target* are the evaluation count at which its trace first gets there.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.special
import scipy.stats

TOLERANCES = (0.01, 0.10)  # success at 1 % and 10 % above the best known MSE
ALPHA = 0.05


def final_mse(runs: pd.DataFrame) -> pd.Series:
    """Final MSE of each run; +inf for runs that raised or have no finite MSE."""
    mse = runs["mse"].astype(float).where(runs["status"] == "ok", np.inf)
    return mse.where(np.isfinite(mse), np.inf)


def best_known(runs: pd.DataFrame) -> pd.Series:
    """Lowest final MSE (N²) per specimen over every run in ``runs``."""
    return final_mse(runs).groupby(runs["specimen"]).min()


def evaluations_to_target(nfev: np.ndarray, mse: np.ndarray, target: float) -> float:
    """First evaluation count at which a best-so-far trace is ≤ ``target``; inf if never."""
    hit = np.flatnonzero(np.asarray(mse) <= target)
    return float(np.asarray(nfev)[hit[0]]) if hit.size else np.inf


def runtimes(runs: pd.DataFrame, traces: pd.DataFrame, taus=TOLERANCES, best=None) -> pd.DataFrame:
    """One row per (run, τ): ``target`` MSE, ``evals`` to reach it (inf if not), ``nfev`` spent, ``reached``.

    ``best`` (per specimen) defaults to ``best_known(runs)``. A run without a trace counts as
    reaching the target at its last evaluation if its final MSE is on target.
    """
    best = best_known(runs) if best is None else best
    grouped = {key: g for key, g in traces.groupby(["kind", "specimen", "optimizer", "replicate"])}
    final = final_mse(runs)
    rows = []
    for (idx, run), mse_final in zip(runs.iterrows(), final):
        key = (run["kind"], run["specimen"], run["optimizer"], int(run["replicate"]))
        trace = grouped.get(key)
        nfev = float(run["nfev"]) if np.isfinite(run["nfev"]) else 0.0
        for tau in taus:
            target = float(best[run["specimen"]]) * (1.0 + tau)
            if trace is not None and len(trace):
                evals = evaluations_to_target(trace["nfev"].to_numpy(), trace["mse"].to_numpy(), target)
            else:
                evals = nfev if mse_final <= target else np.inf
            rows.append({"kind": key[0], "specimen": key[1], "optimizer": key[2], "replicate": key[3],
                         "tau": tau, "target_mse": target, "evals": evals, "nfev": nfev,
                         "reached": bool(np.isfinite(evals))})
    return pd.DataFrame(rows)


def ert(evals, nfev, reached) -> float:
    """Expected running time (COCO): evaluations spent by all runs / number of successful runs.

    A successful run contributes its evaluations to target, an unsuccessful one everything it
    spent. inf when no run succeeded.
    """
    evals, nfev, reached = (np.asarray(a) for a in (evals, nfev, reached))
    reached = reached.astype(bool)
    successes = int(reached.sum())
    if successes == 0:
        return np.inf
    return float(np.where(reached, evals, nfev).sum() / successes)


def success_and_ert(rt: pd.DataFrame, by=("optimizer", "tau")) -> pd.DataFrame:
    """Success rate and ERT (evaluations) for each group of a ``runtimes`` table."""
    rows = []
    for key, g in rt.groupby(list(by), sort=False):
        key = key if isinstance(key, tuple) else (key,)
        rows.append({**dict(zip(by, key)), "runs": len(g), "successes": int(g["reached"].sum()),
                     "success_rate": float(g["reached"].mean()),
                     "ert": ert(g["evals"], g["nfev"], g["reached"])})
    return pd.DataFrame(rows)


def median_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Blocks × treatments: median final MSE across seeds, one row per specimen, one column per backend."""
    frame = runs.assign(final=final_mse(runs).to_numpy())
    table = frame.pivot_table(index="specimen", columns="optimizer", values="final", aggfunc="median")
    return table.dropna(axis=0, how="any")  # a specimen missing a backend cannot be a Friedman block


@dataclass(frozen=True)
class Friedman:
    statistic: float
    pvalue: float  # nan when the test is not applicable (see note)
    mean_ranks: pd.Series  # per backend, 1 = best (lowest MSE)
    n_blocks: int
    note: str


def friedman(table: pd.DataFrame) -> Friedman:
    """Friedman test over specimens (rows = blocks) and backends (columns = treatments).

    Mean ranks are always given; the test needs at least 3 backends and 2 specimens.
    """
    ranks = table.rank(axis=1, method="average")
    mean_ranks = ranks.mean(axis=0).sort_values()
    k, n = table.shape[1], table.shape[0]
    if k < 3 or n < 2:
        return Friedman(np.nan, np.nan, mean_ranks, n,
                        f"Friedman test not applicable: needs ≥ 3 backends and ≥ 2 specimens (have {k} and {n})")
    # Infinite medians (a backend that failed every seed on a specimen) are ranked last, as they should be.
    finite = np.where(np.isfinite(table.to_numpy()), table.to_numpy(), np.finfo(float).max)
    stat, p = scipy.stats.friedmanchisquare(*finite.T)
    return Friedman(float(stat), float(p), mean_ranks, n, "")


def holm(pvalues) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (step-down, family-wise error control); NaN stays NaN.

    Written out because scipy's ``false_discovery_control`` only offers BH/BY (FDR, not FWER)
    and statsmodels is not a dependency.
    """
    p = np.asarray(pvalues, dtype=float)
    out = np.full(p.shape, np.nan)
    valid = np.flatnonzero(~np.isnan(p))
    m = valid.size
    order = valid[np.argsort(p[valid], kind="stable")]
    adjusted = np.maximum.accumulate((m - np.arange(m)) * p[order])
    out[order] = np.minimum(adjusted, 1.0)
    return out


def paired_log_mse(runs: pd.DataFrame) -> pd.DataFrame:
    """Rows (specimen, replicate), columns backends: log10 final MSE, failed runs one decade
    above the worst finished run on that specimen (rank-based tests only see them as worst)."""
    frame = runs.assign(final=final_mse(runs).to_numpy())
    table = frame.pivot_table(index=["specimen", "replicate"], columns="optimizer", values="final", aggfunc="first")
    logged = np.log10(table.where(np.isfinite(table)))
    worst = logged.max(axis=1).groupby(level="specimen").transform("max") + 1.0
    return logged.apply(lambda col: col.fillna(worst)).where(table.notna())


def pairwise_wilcoxon(runs: pd.DataFrame, alpha: float = ALPHA) -> pd.DataFrame:
    """Wilcoxon signed-rank test for every pair of backends on paired (specimen, seed) log10 MSE.

    Pairing: replicate r of one backend with replicate r of the other on the same specimen.
    Columns: a, b, n_pairs, median_diff (log10 MSE a − b; < 0: a better), wins_a, wins_b,
    statistic, p, p_holm (Holm over all pairs), significant (p_holm < alpha), better (a, b or "").
    """
    table = paired_log_mse(runs)
    rows = []
    for a, b in itertools.combinations(list(table.columns), 2):
        pair = table[[a, b]].dropna()
        d = (pair[a] - pair[b]).to_numpy()
        row = {"a": a, "b": b, "n_pairs": len(d), "median_diff": float(np.median(d)) if len(d) else np.nan,
               "wins_a": int((d < 0).sum()), "wins_b": int((d > 0).sum()), "statistic": np.nan, "p": np.nan}
        if len(d) and np.all(d == 0):
            row["p"] = 1.0  # identical results: no evidence of a difference
        elif len(d) >= 2:
            res = scipy.stats.wilcoxon(pair[a], pair[b])
            row["statistic"], row["p"] = float(res.statistic), float(res.pvalue)
        rows.append(row)
    out = pd.DataFrame(rows, columns=["a", "b", "n_pairs", "median_diff", "wins_a", "wins_b", "statistic", "p"])
    out["n_a"] = out["n_b"] = out["n_pairs"]
    # The exact two-sided signed-rank test cannot go below 2/2^n with n pairs.
    out["min_p"] = np.minimum(1.0, 2.0 / 2.0 ** out["n_pairs"].astype(float))
    out["p_holm"] = holm(out["p"].to_numpy()) if len(out) else []
    out["significant"] = out["p_holm"] < alpha
    out["better"] = np.where(~out["significant"], "", np.where(out["median_diff"] < 0, out["a"], out["b"]))
    return out


def compare(wilcoxon: pd.DataFrame, a: str, b: str) -> dict | None:
    """The row of ``pairwise_wilcoxon`` for the pair {a, b}, oriented so that 'a' is ``a``."""
    hit = wilcoxon[(wilcoxon["a"] == a) & (wilcoxon["b"] == b)]
    if len(hit):
        return hit.iloc[0].to_dict()
    hit = wilcoxon[(wilcoxon["a"] == b) & (wilcoxon["b"] == a)]
    if not len(hit):
        return None
    row = hit.iloc[0].to_dict()
    row.update(a=a, b=b, median_diff=-row["median_diff"], wins_a=row["wins_b"], wins_b=row["wins_a"])
    return row


def ranking_table(runs: pd.DataFrame, traces: pd.DataFrame, order=None) -> tuple[pd.DataFrame, Friedman]:
    """Per backend (ranking runs only; best known over all runs): runs, errors, median and best
    RMSE (N), success rate and ERT at each tolerance, mean Friedman rank. Sorted by mean rank."""
    best = best_known(runs)
    ranking = runs[runs["kind"] == "ranking"]
    rt = runtimes(ranking, traces, TOLERANCES, best)
    se = success_and_ert(rt)
    fr = friedman(median_table(ranking))
    final = final_mse(ranking)
    rows = []
    for optimizer in order or list(dict.fromkeys(ranking["optimizer"])):
        mask = ranking["optimizer"] == optimizer
        rmse = np.sqrt(final[mask])
        row = {"optimizer": optimizer, "runs": int(mask.sum()),
               "errors": int((ranking.loc[mask, "status"] != "ok").sum()),
               "median_rmse_N": float(np.median(rmse)), "best_rmse_N": float(np.min(rmse)),
               # Equal evaluations are not equal time: a backend that explores stiff corners of
               # the box (where the model needs many substeps) costs more per evaluation.
               "median_wall_s": float(ranking.loc[mask, "wall_s"].median()) if "wall_s" in ranking else np.nan}
        for tau in TOLERANCES:
            s = se[(se["optimizer"] == optimizer) & (se["tau"] == tau)].iloc[0]
            row[f"success_{tau:.0%}"] = s["success_rate"]
            row[f"ert_{tau:.0%}"] = s["ert"]
        row["mean_rank"] = float(fr.mean_ranks.get(optimizer, np.nan))
        rows.append(row)
    table = pd.DataFrame(rows).sort_values(["mean_rank", "median_rmse_N"], kind="stable").reset_index(drop=True)
    return table, fr


# ------------------------------------------------- one specimen: backends as independent samples

def log_final_mse(runs: pd.DataFrame) -> pd.Series:
    """log10 final MSE per run; failed runs one decade above the worst finished run (rank-based
    tests only see them as worst)."""
    logged = np.log10(final_mse(runs).astype(float))
    finite = logged[np.isfinite(logged)]
    worst = (finite.max() if len(finite) else 0.0) + 1.0
    return logged.where(np.isfinite(logged), worst)


@dataclass(frozen=True)
class KruskalWallis:
    statistic: float
    pvalue: float  # nan when not applicable (see note)
    n_groups: int
    note: str


def kruskal_wallis(runs: pd.DataFrame) -> KruskalWallis:
    """Kruskal–Wallis H test of "every backend's final MSE has the same distribution", the runs
    of each backend (its seeds) an independent sample: the omnibus test for one specimen, where
    there are no blocks for Friedman's test."""
    values = log_final_mse(runs)
    groups = [values[runs["optimizer"] == o].to_numpy() for o in dict.fromkeys(runs["optimizer"])]
    groups = [g for g in groups if len(g)]
    if len(groups) < 2 or sum(len(g) for g in groups) <= len(groups):
        return KruskalWallis(np.nan, np.nan, len(groups), "Kruskal–Wallis test not applicable: needs ≥ 2 backends "
                             "with more runs than backends")
    if np.ptp(np.concatenate(groups)) == 0:
        return KruskalWallis(0.0, 1.0, len(groups), "every run has the same final MSE")
    stat, p = scipy.stats.kruskal(*groups)
    return KruskalWallis(float(stat), float(p), len(groups), "")


def mann_whitney_vs(runs: pd.DataFrame, reference: str, alpha: float = ALPHA) -> pd.DataFrame:
    """Two-sided Mann–Whitney U test of each backend against ``reference`` on log10 final MSE,
    the seeds of each backend an independent sample; Holm-corrected over these comparisons.

    Columns: a (= reference), b, n_a, n_b, median_diff (log10 MSE a − b; < 0: a better),
    p_superiority (probability that a run of a beats a run of b, ties half), statistic (U of a),
    p, p_holm, significant (p_holm < alpha), better (a, b or ""), min_p (the smallest two-sided p
    the exact test can give with these sample sizes: with 5 seeds each, 2/252 ≈ 0.008).
    """
    values = log_final_mse(runs)
    a = values[runs["optimizer"] == reference].to_numpy()
    rows = []
    for other in dict.fromkeys(runs["optimizer"]):
        if other == reference:
            continue
        b = values[runs["optimizer"] == other].to_numpy()
        row = {"a": reference, "b": other, "n_a": len(a), "n_b": len(b), "median_diff": np.nan,
               "p_superiority": np.nan, "statistic": np.nan, "p": np.nan,
               "min_p": 2.0 / scipy.special.comb(len(a) + len(b), len(a)) if len(a) and len(b) else np.nan}
        if len(a) and len(b):
            row["median_diff"] = float(np.median(a) - np.median(b))
            row["p_superiority"] = float(np.mean((a[:, None] < b[None, :]) + 0.5 * (a[:, None] == b[None, :])))
            if np.ptp(np.concatenate([a, b])) == 0:
                row["p"] = 1.0  # identical results: no evidence of a difference
            else:
                res = scipy.stats.mannwhitneyu(a, b, alternative="two-sided")
                row["statistic"], row["p"] = float(res.statistic), float(res.pvalue)
        rows.append(row)
    columns = ["a", "b", "n_a", "n_b", "median_diff", "p_superiority", "statistic", "p", "min_p"]
    out = pd.DataFrame(rows, columns=columns)
    out["p_holm"] = holm(out["p"].to_numpy()) if len(out) else []
    out["significant"] = out["p_holm"] < alpha
    out["better"] = np.where(~out["significant"], "", np.where(out["median_diff"] < 0, out["a"], out["b"]))
    return out


def pairwise_mann_whitney(runs: pd.DataFrame, alpha: float = ALPHA) -> pd.DataFrame:
    """Two-sided Mann–Whitney U test for every pair of backends on log10 final MSE, the seeds of
    each backend an independent sample (one specimen: there is nothing to pair), Holm-corrected over
    all pairs. Columns as ``pairwise_wilcoxon`` (``wins_a`` = pairs of runs a beats), plus
    ``p_superiority`` (probability that a run of a beats a run of b, ties half)."""
    names = list(dict.fromkeys(runs["optimizer"]))
    frames = [mann_whitney_vs(runs[runs["optimizer"].isin([a, *names[i + 1:]])], a, alpha)
              for i, a in enumerate(names[:-1])]
    out = pd.concat(frames, ignore_index=True) if frames else mann_whitney_vs(runs.iloc[:0], "", alpha)
    values = log_final_mse(runs)
    wins = []
    for r in out.itertuples():
        a = values[runs["optimizer"] == r.a].to_numpy()
        b = values[runs["optimizer"] == r.b].to_numpy()
        wins.append((int((a[:, None] < b[None, :]).sum()), int((a[:, None] > b[None, :]).sum())))
    out["wins_a"] = [w[0] for w in wins]
    out["wins_b"] = [w[1] for w in wins]
    out["p_holm"] = holm(out["p"].to_numpy()) if len(out) else []
    out["significant"] = out["p_holm"] < alpha
    out["better"] = np.where(~out["significant"], "", np.where(out["median_diff"] < 0, out["a"], out["b"]))
    return out


@dataclass(frozen=True)
class Comparison:
    """The tests a study's design allows, and their results."""

    omnibus_name: str
    omnibus_design: str
    omnibus: object  # Friedman or KruskalWallis
    pairwise_name: str
    pairwise_note: str
    pairwise: pd.DataFrame
    power_note: str


def compare_backends(runs: pd.DataFrame) -> Comparison:
    """Friedman over specimens and paired Wilcoxon tests when there are ≥ 2 specimens; with one,
    Kruskal–Wallis and unpaired Mann–Whitney tests (the seeds of two backends share nothing, so they
    cannot be blocks)."""
    ranking = runs[runs["kind"] == "ranking"]
    n_specimens = ranking["specimen"].nunique()
    if n_specimens >= 2:
        fr = friedman(median_table(ranking))
        return Comparison(
            "Friedman test", f"{fr.n_blocks} specimens (blocks) and {ranking['optimizer'].nunique()} backends "
            "(treatments), value = median final loss across seeds", fr,
            "Wilcoxon signed-rank tests on the paired (specimen, seed) runs",
            "Pairing: seed r of one backend with seed r of another on the same specimen (the seeds are "
            "independent, so the pairing only removes the specimen effect).",
            pairwise_wilcoxon(ranking),
            f"the Friedman test has {n_specimens} blocks{' and little power' if n_specimens < 6 else ''}; the "
            "pairwise Wilcoxon tests pair seed r of one backend with seed r of another on the same specimen.")
    kw = kruskal_wallis(ranking)
    return Comparison(
        "Kruskal–Wallis test", f"{kw.n_groups} backends, the seeds of each an independent sample", kw,
        "Mann–Whitney U tests (the seeds of each backend an independent sample)",
        "With one specimen there are no blocks: seed r of one backend shares nothing with seed r of another.",
        pairwise_mann_whitney(ranking),
        "one specimen, so there is no Friedman test; backends are compared as independent samples of their "
        "seeds, which needs many seeds for power.")
