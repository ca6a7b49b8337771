"""The recommendation: which backend to use, by a rule the report states (``RULE``)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import statistics
from bwbench.report.format import evals_text, join, number, p_text, percent

ALPHA = statistics.ALPHA
BASELINE = "random"  # the backend "significantly worse than" disqualifies


def rule(pairwise_name: str = "Wilcoxon signed-rank tests on the paired (specimen, seed) runs") -> str:
    """The recommendation rule in words, naming the pairwise test the design allows."""
    return (
        "best = the backend with the lowest mean Friedman rank (ranks of the median final loss across seeds, "
        "per specimen; ties broken by the lower median RMSE); **as good within noise** = not significantly "
        f"different from the best by pairwise {pairwise_name} on log10 final losses after Holm correction at "
        f"α = {ALPHA:g}; **short at this budget** = success rate 0 at the 10 % tolerance (it may get there with "
        f"more evaluations); **avoid** = significantly worse than random search ('{BASELINE}', when it is in the "
        "study) by the same test. Every other backend is reported as significantly worse than the best. Random "
        "search is the baseline, not a candidate."
    )


def recommend(table: pd.DataFrame, pairwise: pd.DataFrame, omnibus, budget, n_specimens: int,
              omnibus_name: str = "Friedman test over specimens", unit: str = "N") -> dict:
    """Apply ``rule()`` to the ranking ``table`` (sorted by mean rank) and the pairwise tests.

    Returns ``best``, ``tied`` [(name, p_holm)], ``worse`` [(name, p_holm)], ``short`` [name],
    ``avoid`` [(name, reason)] and the generated ``text`` (markdown).
    """
    best = table.iloc[0]
    b = best["optimizer"]
    names = list(table["optimizer"])
    success10 = dict(zip(table["optimizer"], table["success_10%"]))
    tied, worse, short, avoid = [], [], [], []
    for name in names[1:]:
        row = statistics.compare(pairwise, b, name)
        p = row["p_holm"] if row else np.nan
        significant = bool(row and row["significant"])
        if name == BASELINE:
            continue
        vs = statistics.compare(pairwise, name, BASELINE) if BASELINE in names else None
        if vs and vs["significant"] and vs["median_diff"] > 0:
            avoid.append((name, f"is significantly worse than random search (Holm p = {p_text(vs['p_holm'])})"))
        elif success10[name] == 0:
            short.append((name, p, significant))
        elif significant:
            worse.append((name, p))
        else:
            tied.append((name, p))
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    text = (f"For this problem at a budget of {budget_text} evaluations use **{b}**: it has the lowest mean "
            f"rank ({best['mean_rank']:.2f} over {n_specimens} specimen(s)), a median RMSE of "
            f"{number(best['median_rmse_N'], 3)} {unit}, and {percent(best['success_10%'])} of its runs came within 10 % of the "
            f"best known MSE (ERT {evals_text(best['ert_10%'])} evaluations).")
    if success10[b] == 0:
        text += f" Even {b} never came within 10 % of the best known fit: consider a larger budget."
    if tied:
        text += " " + "; ".join(f"**{n}** is as good within noise (Holm-corrected p = {p_text(p)})"
                                for n, p in tied) + "."
    else:
        text += f" No other backend is statistically indistinguishable from {b}."
    if "median_wall_s" in table and table["median_wall_s"].notna().any():
        # Same evaluations, not the same time: between equals, the faster one is the better buy.
        wall = dict(zip(table["optimizer"], table["median_wall_s"]))
        text += " Median wall time per run on one core: " + ", ".join(
            f"{n} {number(wall[n], 2)} s" for n in [b] + [n for n, _ in tied]) + "."
    if worse:
        text += " " + "; ".join(f"{n} is significantly worse than {b} (p = {p_text(p)})" for n, p in worse) + "."
    if short:
        text += (f" Short at this budget (no run came within 10 % of the best known MSE): "
                 f"{join([n for n, _, _ in short])}.")
        not_sig = [f"{n} (p = {p_text(p)})" for n, p, sig in short if not sig]
        if not_sig:
            text += f" Of these, {join(not_sig)} are not significantly different from {b} in final MSE."
    for name, reason in avoid:
        text += f" Avoid **{name}**: it {reason}."
    if BASELINE in names and BASELINE != b:
        row = table[table["optimizer"] == BASELINE].iloc[0]
        text += f" Random search, the baseline, ends at a median RMSE of {number(row['median_rmse_N'], 3)} {unit}."
    if not np.isfinite(omnibus.pvalue):
        text += f" Caution: {omnibus.note}; the ranking rests on the pairwise tests alone."
    elif omnibus.pvalue >= ALPHA:
        text += (f" Caution: the {omnibus_name} does not detect a difference between the backends "
                 f"(p = {p_text(omnibus.pvalue)}, {n_specimens} specimen(s)): the order of the mean ranks may be "
                 f"chance; more runs would settle it.")
    return {"best": b, "tied": tied, "worse": worse, "short": [n for n, _, _ in short], "avoid": avoid,
            "text": text}

