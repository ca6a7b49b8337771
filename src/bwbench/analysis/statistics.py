"""Both views of a benchmark per label: success rates and ERT (fixed target), final losses and their
ranks with ties within ``TIE`` (fixed budget), the cost of an evaluation, and the omnibus tests
(Friedman over specimens, Kruskal–Wallis on one). Two labels are compared in
``bwbench.analysis.comparisons``.

Conventions used throughout:

- a run's *final MSE* (N²) is its best MSE; a run that raised or found nothing finite counts as
  +inf (worse than every finished run);
- the *best known* MSE of a specimen is the lowest final MSE of any run on it in the database,
  ranking and posterior runs alike;
- a run *reaches* tolerance τ when its best-so-far MSE gets to best_known·(1 + τ); its
  *evaluations to target* are the evaluation count at which its trace first gets there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.stats

from bwbench.analysis.comparisons import log_losses, method_name

TOLERANCES = (0.01, 0.10)  # success at 1 % and 10 % above the best known MSE
ALPHA = 0.05
TIE = 0.01  # final losses within 1 % of each other share a rank (the precision of the 1 % target)


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
    reaching the target at its last evaluation if its final MSE is on target. Every τ of a run is
    read from its trace at once (the best-so-far is non-increasing), so ~50 targets cost little.
    """
    best = best_known(runs) if best is None else best
    taus = np.asarray(list(taus), dtype=float)
    grouped = {key: g for key, g in traces.groupby(["kind", "specimen", "optimizer", "replicate"])}
    final = final_mse(runs).to_numpy()
    frames = []
    for k, run in enumerate(runs[["kind", "specimen", "optimizer", "replicate", "nfev"]].itertuples(index=False)):
        key = (run.kind, run.specimen, run.optimizer, int(run.replicate))
        trace = grouped.get(key)
        nfev = float(run.nfev) if np.isfinite(run.nfev) else 0.0
        targets = float(best[run.specimen]) * (1.0 + taus)
        if trace is not None and len(trace):
            mse = np.minimum.accumulate(trace["mse"].to_numpy(dtype=float))
            hit = np.searchsorted(-mse, -targets, side="left")  # first index with mse ≤ target
            counts = trace["nfev"].to_numpy(dtype=float)
            evals = np.where(hit < mse.size, counts[np.minimum(hit, mse.size - 1)], np.inf)
        else:
            evals = np.where(final[k] <= targets, nfev, np.inf)
        frames.append(
            pd.DataFrame(
                {
                    "kind": key[0],
                    "specimen": key[1],
                    "optimizer": key[2],
                    "replicate": key[3],
                    "tau": taus,
                    "target_mse": targets,
                    "evals": evals,
                    "nfev": nfev,
                    "reached": np.isfinite(evals),
                }
            )
        )
    columns = ["kind", "specimen", "optimizer", "replicate", "tau", "target_mse", "evals", "nfev", "reached"]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=columns)


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
        rows.append(
            {
                **dict(zip(by, key)),
                "runs": len(g),
                "successes": int(g["reached"].sum()),
                "success_rate": float(g["reached"].mean()),
                "ert": ert(g["evals"], g["nfev"], g["reached"]),
            }
        )
    return pd.DataFrame(rows)


def median_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Blocks × treatments: per specimen (rows) and label (columns) the median across seeds of the
    log10 final loss (a failed run one decade above the worst finished run on its specimen,
    ``comparisons.log_losses``). Specimens missing a label are left out (they cannot be a block)."""
    values = log_losses(runs)
    table = values.pivot_table(index="specimen", columns="optimizer", values="value", aggfunc="median")
    return table.dropna(axis=0, how="any")


def tied_ranks(values, tolerance: float = math.log10(1 + TIE)) -> np.ndarray:
    """Ranks (1 = lowest) in which values within ``tolerance`` of each other share a rank: sorted
    values are grouped greedily from the lowest (a group holds every value within ``tolerance`` of
    its first), and each group gets the average of the ranks it spans. Round-off cannot order two
    backends that end at the same loss. On log10 losses the default tolerance is ``TIE`` (1 %)."""
    values = np.asarray(values, dtype=float)
    order = np.argsort(values, kind="stable")
    ranks = np.empty(values.size)
    start = 0
    while start < values.size:
        end = start + 1
        first = values[order[start]]
        while end < values.size and (values[order[end]] - first <= tolerance or values[order[end]] == first):
            end += 1
        ranks[order[start:end]] = (start + 1 + end) / 2.0
        start = end
    return ranks


@dataclass(frozen=True)
class Friedman:
    statistic: float
    pvalue: float  # nan when the test is not applicable (see note)
    mean_ranks: pd.Series  # per backend, 1 = best (lowest MSE)
    n_blocks: int
    note: str


def friedman(table: pd.DataFrame) -> Friedman:
    """Friedman test over specimens (rows = blocks) and labels (columns = treatments) of a
    ``median_table``, on ranks that tie within ``TIE`` (``tied_ranks``), with scipy's tie correction.

    Mean ranks are always given; the test needs at least 3 labels and 2 specimens.
    """
    ranks = pd.DataFrame([tied_ranks(row) for row in table.to_numpy()], index=table.index, columns=table.columns)
    mean_ranks = ranks.mean(axis=0).sort_values(kind="stable")
    k, n = table.shape[1], table.shape[0]
    if k < 3 or n < 2:
        return Friedman(
            np.nan,
            np.nan,
            mean_ranks,
            n,
            f"Friedman test not applicable: needs ≥ 3 backends and ≥ 2 specimens (have {k} and {n})",
        )
    if np.all(ranks.to_numpy() == ranks.to_numpy()[:, :1]):
        return Friedman(0.0, 1.0, mean_ranks, n, "every backend ties on every specimen")
    stat, p = scipy.stats.friedmanchisquare(*ranks.to_numpy().T)
    return Friedman(float(stat), float(p), mean_ranks, n, "")


def ranking_table(runs: pd.DataFrame, traces: pd.DataFrame, order=None) -> tuple[pd.DataFrame, Friedman]:
    """Per label (ranking runs only; best known over all runs): runs, errors; the fixed-budget view
    (median and best RMSE, ``median_ratio`` = median final loss / best known of its specimen, mean
    rank of its median final loss over specimens with ties within ``TIE``); the fixed-target view
    (success rate and ERT at each tolerance); the cost of an evaluation (``s_per_eval``: total
    wall time / total evaluations of its runs, one core) and the expected time to each target
    (``time_1%`` = ERT × s_per_eval, s). Sorted by mean rank, then median ratio."""
    best = best_known(runs)
    ranking = runs[runs["kind"] == "ranking"]
    rt = runtimes(ranking, traces, TOLERANCES, best)
    se = success_and_ert(rt)
    fr = friedman(median_table(ranking))
    final = final_mse(ranking)
    ratio = final / ranking["specimen"].map(best).astype(float)
    rows = []
    for optimizer in order or list(dict.fromkeys(ranking["optimizer"])):
        mask = ranking["optimizer"] == optimizer
        rmse = np.sqrt(final[mask])
        # Equal evaluations are not equal time: a backend that explores stiff corners of the box
        # (where the model needs many substeps) costs more per evaluation.
        wall = ranking.loc[mask, "wall_s"].astype(float) if "wall_s" in ranking else pd.Series(dtype=float)
        nfev = ranking.loc[mask, "nfev"].astype(float)
        timed = wall.notna() & nfev.gt(0)
        row = {
            "optimizer": optimizer,
            "runs": int(mask.sum()),
            "errors": int((ranking.loc[mask, "status"] != "ok").sum()),
            "median_rmse_N": float(np.median(rmse)),
            "best_rmse_N": float(np.min(rmse)),
            "median_ratio": float(np.median(ratio[mask])),
            "median_wall_s": float(wall.median()) if len(wall) else np.nan,
            "s_per_eval": float(wall[timed].sum() / nfev[timed].sum()) if timed.any() else np.nan,
        }
        for tau in TOLERANCES:
            s = se[(se["optimizer"] == optimizer) & (se["tau"] == tau)].iloc[0]
            row[f"success_{tau:.0%}"] = s["success_rate"]
            row[f"ert_{tau:.0%}"] = s["ert"]
            row[f"time_{tau:.0%}"] = s["ert"] * row["s_per_eval"] if s["success_rate"] > 0 else np.inf
        row["mean_rank"] = float(fr.mean_ranks.get(optimizer, np.nan))
        rows.append(row)
    table = pd.DataFrame(rows).sort_values(["mean_rank", "median_ratio"], kind="stable").reset_index(drop=True)
    return table, fr


def success_by_specimen(runs: pd.DataFrame, traces: pd.DataFrame, tau: float) -> pd.DataFrame:
    """Success rate at ``tau`` of each label (columns) on each specimen (rows), ranking runs only,
    best known over every run."""
    ranking = runs[runs["kind"] == "ranking"]
    rt = runtimes(ranking, traces, (tau,), best_known(runs))
    return rt.pivot_table(index="specimen", columns="optimizer", values="reached", aggfunc="mean")


# ------------------------------------------------- one specimen: labels as independent samples


@dataclass(frozen=True)
class KruskalWallis:
    statistic: float
    pvalue: float  # nan when not applicable (see note)
    n_groups: int
    note: str


def kruskal_wallis(runs: pd.DataFrame) -> KruskalWallis:
    """Kruskal–Wallis H test of "every label's final loss has the same distribution", the runs of
    each label (its seeds) an independent sample: the omnibus test for one specimen, where there
    are no blocks for Friedman's test."""
    values = log_losses(runs)
    groups = [g["value"].to_numpy() for _, g in values.groupby("optimizer", sort=False)]
    groups = [g for g in groups if len(g)]
    if len(groups) < 2 or sum(len(g) for g in groups) <= len(groups):
        return KruskalWallis(
            np.nan,
            np.nan,
            len(groups),
            "Kruskal–Wallis test not applicable: needs ≥ 2 backends with more runs than backends",
        )
    if np.ptp(np.concatenate(groups)) == 0:
        return KruskalWallis(0.0, 1.0, len(groups), "every run has the same final MSE")
    stat, p = scipy.stats.kruskal(*groups)
    return KruskalWallis(float(stat), float(p), len(groups), "")


@dataclass(frozen=True)
class Comparison:
    """The omnibus test a study's design allows, and the name of the two-sample test the
    recommendation runs (``bwbench.analysis.comparisons``)."""

    omnibus_name: str
    omnibus_design: str
    omnibus: object  # Friedman or KruskalWallis
    test_name: str
    n_specimens: int
    seeds: int  # the most runs of one label on one specimen


def compare_backends(runs: pd.DataFrame) -> Comparison:
    """Friedman over specimens (blocks) when there are ≥ 2 specimens, Kruskal–Wallis with one (the
    seeds of two labels share nothing, so they cannot be blocks); the name of the two-sample test."""
    ranking = runs[runs["kind"] == "ranking"]
    n_specimens = int(ranking["specimen"].nunique())
    seeds = int(ranking.groupby(["specimen", "optimizer"]).size().max()) if len(ranking) else 0
    if n_specimens >= 2:
        fr = friedman(median_table(ranking))
        return Comparison(
            "Friedman test",
            f"{fr.n_blocks} specimens (blocks) and {ranking['optimizer'].nunique()} labels "
            f"(treatments), value = median log10 final loss across seeds, losses within {TIE:.0%} sharing a rank",
            fr,
            method_name(n_specimens),
            n_specimens,
            seeds,
        )
    kw = kruskal_wallis(ranking)
    return Comparison(
        "Kruskal–Wallis test",
        f"{kw.n_groups} labels, the seeds of each an independent sample",
        kw,
        method_name(n_specimens),
        n_specimens,
        seeds,
    )
