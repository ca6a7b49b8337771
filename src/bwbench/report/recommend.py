"""The recommendation: which backend to use, by a rule the report states (``rule``).

It weighs effect size, not only p: a difference that is significant but small (the median paired
ratio of final losses within ``PRACTICAL`` of 1) is reported as practically equal; and it states its
power: how many paired comparisons there are, the smallest p the design can reach after Holm's
correction, and "not enough runs to separate X and Y" when that smallest p cannot reach α. Ties are
described as ties, with the wall time per run as the tie-breaker, stated.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import statistics
from bwbench.report.format import evals_text, join, number, p_text, percent

ALPHA = statistics.ALPHA
BASELINE = "random"  # the baseline: reported, never recommended
PRACTICAL = 0.10  # final losses within 10 % of each other (median paired ratio): practically equal
CLOSE = 2.0  # median final RMSE within 2× the best's: close behind, not far behind


def rule(pairwise_name: str = "Wilcoxon signed-rank tests on the paired (specimen, seed) runs") -> str:
    """The recommendation rule in words, naming the pairwise test the design allows."""
    return (
        "best = the backend with the lowest mean Friedman rank (ranks of the median final loss across seeds, "
        f"per specimen; ties broken by the lower median RMSE). Each other backend is compared with it by pairwise "
        f"{pairwise_name} on log10 final losses, Holm-corrected at α = {ALPHA:g}, and by the effect size, the "
        f"median paired ratio of final losses: **practically equal** when that ratio is within {PRACTICAL * 100:.0f} % of 1 "
        "(whatever p says), **tied** when the test cannot tell them apart; among the best and its equals and ties, "
        "the faster one per run is the better buy (wall time breaks the tie). Of the rest, **close behind** = median "
        f"RMSE within {CLOSE:g}× the best's, **far behind** = more; **avoid** = significantly worse than random "
        f"search ('{BASELINE}', when it is in the study), the baseline that is never recommended."
    )


def power(pairwise: pd.DataFrame) -> dict:
    """What the design can show: comparisons, pairs per comparison, the smallest raw p of one test and the
    smallest Holm-corrected p (raw × number of comparisons), and whether that can reach α."""
    if pairwise is None or not len(pairwise):
        return {"comparisons": 0, "pairs": 0, "min_p": np.nan, "min_p_holm": np.nan, "can_reach": False}
    min_p = float(pairwise["min_p"].min())
    min_holm = min(1.0, min_p * len(pairwise))
    pairs = int(pairwise["n_a"].min()) if "n_a" in pairwise else 0
    return {"comparisons": len(pairwise), "pairs": pairs, "min_p": min_p, "min_p_holm": min_holm,
            "can_reach": min_holm < ALPHA}


def recommend(table: pd.DataFrame, pairwise: pd.DataFrame, omnibus, budget, n_specimens: int,
              omnibus_name: str = "Friedman test over specimens", unit: str = "N") -> dict:
    """Apply ``rule()`` to the ranking ``table`` (sorted by mean rank) and the pairwise tests.

    Returns ``best``, ``equal`` and ``tied`` [(name, p_holm, ratio)], ``close`` and ``far``
    [(name, p_holm, ratio)], ``avoid`` [(name, reason)], ``choice`` (the backend to use: the fastest
    of the best and its equals/ties), ``power`` and the generated ``text`` (markdown).
    """
    names = list(table["optimizer"])
    candidates = [n for n in names if n != BASELINE] or names
    b = candidates[0]
    row_of = table.set_index("optimizer")
    rmse = row_of["median_rmse_N"].astype(float)
    p_info = power(pairwise)
    groups = {"equal": [], "tied": [], "close": [], "far": []}
    avoid = []
    for name in candidates[1:]:
        row = statistics.compare(pairwise, b, name)
        p = float(row["p_holm"]) if row else np.nan
        ratio = 10 ** abs(float(row["median_diff"])) if row and np.isfinite(row["median_diff"]) else np.nan
        vs = statistics.compare(pairwise, name, BASELINE) if BASELINE in names else None
        if vs and vs["significant"] and vs["median_diff"] > 0 and 10 ** vs["median_diff"] > 1 + PRACTICAL:
            avoid.append((name, f"is significantly worse than random search (Holm p = {p_text(vs['p_holm'])})"))
        elif np.isfinite(ratio) and ratio <= 1 + PRACTICAL:
            groups["equal"].append((name, p, ratio))
        elif not (row and row["significant"]) and rmse[name] <= CLOSE * rmse[b]:
            groups["tied"].append((name, p, ratio))  # the tests cannot tell, and the effect is moderate
        elif rmse[name] <= CLOSE * rmse[b]:
            groups["close"].append((name, p, ratio))
        else:
            groups["far"].append((name, p, ratio))
    wall = row_of["median_wall_s"].astype(float) if "median_wall_s" in row_of else pd.Series(dtype=float)
    alike = {n for n, _, _ in groups["equal"]}
    peers = [b] + [n for n in names if n in alike]  # in ranking order
    choice = min(peers, key=lambda n: wall.get(n, np.inf)) if wall.notna().any() else b
    text = _text(table, b, choice, groups, avoid, p_info, omnibus, omnibus_name, budget, n_specimens, unit, wall)
    return {"best": b, "choice": choice, **groups, "avoid": avoid, "power": p_info, "text": text,
            "tied_names": peers[1:]}


def _text(table, b, choice, groups, avoid, p_info, omnibus, omnibus_name, budget, n_specimens, unit, wall) -> str:
    row_of = table.set_index("optimizer")
    best = row_of.loc[b]
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    alike = {n for n, _, _ in groups["equal"]}
    peers = [n for n in table["optimizer"] if n in alike]
    significant = {n for n, p, _ in groups["close"] + groups["far"] if np.isfinite(p) and p < ALPHA}

    def seconds(name):
        if name not in wall or not np.isfinite(wall[name]):
            return "–"
        return f"{wall[name]:,.0f} s" if wall[name] >= 100 else f"{number(wall[name], 2)} s"

    if peers:
        everyone = [b] + peers
        text = (f"For this problem at a budget of {budget_text} evaluations, {join([f'**{n}**' for n in everyone])} "
                f"are as good as each other here: use {'either' if len(everyone) == 2 else 'any of them'}; **{choice}** is "
                f"the fastest per run ({', '.join(f'{n} {seconds(n)}' for n in everyone)} median wall time on one "
                "core). ")
    else:
        text = f"For this problem at a budget of {budget_text} evaluations use **{b}**. "
    text += (f"{b} has the lowest mean rank ({best['mean_rank']:.2f} over {n_specimens} specimen(s)), a median RMSE of "
             f"{number(best['median_rmse_N'], 3)} {unit}, and {percent(best['success_10%'])} of its runs came within "
             f"10 % of the best known loss (ERT {evals_text(best['ert_10%'])} evaluations).")
    if row_of.loc[b, "success_10%"] == 0:
        text += f" Even {b} never came within 10 % of the best known fit: consider a larger budget."
    if len(groups["equal"]) <= 2:
        for name, p, ratio in groups["equal"]:
            text += (f" {name}'s final losses are within {PRACTICAL * 100:.0f} % of {b}'s (median ratio {ratio:.2f}, "
                     f"Holm p = {p_text(p)}): practically equal.")
    else:  # one sentence for many: a list of a dozen identical sentences hides the rest of the paragraph
        ratios = [r for _, _, r in groups["equal"]]
        ps = [p for _, p, _ in groups["equal"] if np.isfinite(p)]
        p_range = f"; Holm p {p_text(min(ps))} to {p_text(max(ps))}" if ps else ""
        text += (f" The final losses of the other {len(groups['equal'])} are within {PRACTICAL * 100:.0f} % of {b}'s "
                 f"(median paired ratios {min(ratios):.2f} to {max(ratios):.2f}{p_range}; each pair in the "
                 "pairwise matrix below): practically equal, whether or not the difference is significant.")
    tied = [f"{n} (Holm p = {p_text(p)}, median ratio {ratio:.2f})" for n, p, ratio in groups["tied"]]
    if tied and not p_info["can_reach"]:
        text += (f" Not enough runs to separate {b} from {join(tied)}: with {p_info['pairs']} pairs per comparison "
                 f"and {p_info['comparisons']} comparisons the smallest Holm-corrected p the design can reach is "
                 f"{p_text(p_info['min_p_holm'])} ≥ α = {ALPHA:g}.")
    elif tied:
        text += f" The tests cannot tell {b} from {join(tied)}."
    for label, key in (("Close behind (median RMSE within {close:g}× the best's)", "close"),
                       ("Far behind (median RMSE more than {close:g}× the best's)", "far")):
        if groups[key]:
            listing = ", ".join(f"{n} ({number(row_of.loc[n, 'median_rmse_N'], 3)} {unit}"
                                + ("" if n in significant else ", not significant at this size") + ")"
                                for n, _, _ in groups[key])
            text += f" {label.format(close=CLOSE)}: {listing}."
    for name, reason in avoid:
        text += f" Avoid **{name}**: it {reason}."
    if BASELINE in row_of.index and BASELINE != b:
        text += f" Random search, the baseline, ends at a median RMSE of {number(row_of.loc[BASELINE, 'median_rmse_N'], 3)} {unit}."
    if not p_info["can_reach"] and p_info["comparisons"]:
        text += (f" Power: {p_info['comparisons']} pairwise comparisons of {p_info['pairs']} paired runs each; the "
                 f"smallest p the design can reach after Holm's correction is {p_text(p_info['min_p_holm'])}, so no "
                 "difference can be significant at this size: the order rests on the effect sizes.")
    if not np.isfinite(omnibus.pvalue):
        text += f" Caution: {omnibus.note}; the ranking rests on the pairwise comparisons alone."
    elif omnibus.pvalue >= ALPHA:
        text += (f" Caution: the {omnibus_name} does not detect a difference between the backends "
                 f"(p = {p_text(omnibus.pvalue)}, {n_specimens} specimen(s)): the order of the mean ranks may be "
                 f"chance; more runs would settle it.")
    return text
