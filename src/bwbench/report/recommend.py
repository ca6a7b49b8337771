"""The recommendation in words: the rule (``rule``), stated before it is applied, and the paragraph
that applies it (``recommend``). The decision itself is ``bwbench.report.verdict``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bwbench.analysis import comparisons, statistics
from bwbench.report.format import evals_text, join, number, p_text, seconds_text
from bwbench.report.labels import split_label
from bwbench.report.verdict import (
    ALPHA,
    FALLBACK_TARGET,
    PRACTICAL,
    SUCCESS_MARGIN,
    TARGET,
    Verdict,
    decide,
)


def rule(test_name: str, noun: str | None = None) -> list[str]:
    """The decision rule as bullets, naming the test the design runs and, when the study compares
    variants side by side, what they are (``noun``: "formulation", "model", ...)."""
    items = [
        f"**Views.** Fixed budget: a run's *final loss* is its best loss when the budget is spent. Fixed target: a "
        f"run *succeeds* when it gets within {TARGET:.0%} of the best known loss of its specimen (the lowest of any "
        "run in this database); *ERT* (COCO's expected running time) = evaluations spent by all runs (to the "
        "target for the successful ones) / number of successful runs; *expected time to the target* = ERT × "
        "measured seconds per evaluation (all wall time of the label's runs / all their evaluations, one core).",
        "**Baseline.** Random search, in whichever "
        + (noun or "variant") + ", is the baseline: compared and described, never recommended.",
        f"**Order.** Candidates by success rate at the {TARGET:.0%} target (higher first), then by the mean rank "
        f"over specimens of their median final loss (losses within {statistics.TIE:.0%} of each other share a "
        "rank), then by expected time to the target. The first is the reference.",
        f"**As good as the reference** only when both views agree: final losses at most {PRACTICAL:.0%} higher "
        f"(Hodges–Lehmann ratio ≤ {1 + PRACTICAL:.2f}) **and** on every specimen a success rate at most "
        f"{SUCCESS_MARGIN * 100:.0f} percentage points lower. Final losses as low but a larger success deficit on "
        f"some specimen: *less reliable*. Final losses more than {PRACTICAL:.0%} higher: *behind*.",
        f"**Tie-break.** Among the reference and its equals, the lowest expected time to the {TARGET:.0%} target "
        f"is recommended (to the {FALLBACK_TARGET:.0%} target when none of them reaches {TARGET:.0%}).",
        f"**Avoid**: final losses significantly (Holm) and more than {PRACTICAL:.0%} worse than the best baseline's.",
        f"**Statistics.** Each comparison: {test_name} on log10 final losses (a failed run counts one decade "
        f"worse than the worst finished run on its specimen); effect size = Hodges–Lehmann ratio of final losses "
        f"with a {comparisons.LEVEL:.0%} bootstrap interval ({comparisons.BOOTSTRAP:,} resamples of the seeds within "
        f"each specimen, fixed seed); Holm's correction at α = {ALPHA:g} within each family of comparisons the "
        "rule uses (against the reference; against the baseline"
        + (f"; each backend's {noun}s" if noun else "") + "). Significance qualifies a verdict, it never makes one.",
    ]
    if noun:
        items.insert(1, f"**{noun.capitalize()}s first.** Each backend run in several {noun}s: its final losses in "
                        f"each {noun} against those in the recommended label's {noun}; then one (backend, {noun}) "
                        "pair is recommended.")
    return items


def ratio_text(row) -> str:
    """'1.02 [0.99, 1.05]': a Hodges–Lehmann ratio with its interval."""
    return f"{_ratio(row['ratio'])} [{_ratio(row['ratio_low'])}, {_ratio(row['ratio_high'])}]"


def _ratio(x) -> str:
    """A loss ratio: three decimals near 1 (1.004, 0.982), three figures further out, powers of ten far."""
    if not np.isfinite(x):
        return number(x)
    if 0.9 <= x <= 1.1:
        return f"{x:.3f}"
    return f"{x:.3g}" if 0.01 <= x < 1000 else f"{x:.1e}"


def _pair(label: str, noun: str | None) -> str:
    backend, variant = split_label(label)
    return f"**{backend}** in the **{variant}** {noun}" if variant and noun else f"**{label}**"


def _success(table, label, tau=TARGET) -> str:
    row = table.loc[label]
    runs = int(row["runs"])
    return f"{int(round(row[f'success_{tau:.0%}'] * runs))} of {runs} runs"


def variant_text(verdict: Verdict, noun: str) -> str:
    """'In the identifiable formulation 4 of 4 backends end lower than in the paper formulation …', told
    from the side where most backends end lower (the recommended pair may sit in the other one)."""
    frame = verdict.by_variant
    if frame is None or not len(frame):
        return ""
    ref = verdict.reference_variant
    parts = []
    for variant, g in frame.groupby("variant", sort=False):
        g = g.copy()
        winner, loser = ref, variant  # ratio: the loser's losses over the winner's
        if (g["ratio"] < 1).sum() > (g["ratio"] > 1).sum():
            winner, loser = variant, ref
            # the inverse ratio, its interval's ends swapped
            g["ratio"], g["ratio_low"], g["ratio_high"] = 1.0 / g["ratio"], 1.0 / g["ratio_high"], 1.0 / g["ratio_low"]
        better = g[g["ratio"] > 1]
        significant = better[better["significant"]]
        worse = g[g["ratio"] < 1]
        text = (f"In the {winner} {noun}, {len(better)} of {len(g)} backends end at lower final losses than in the "
                f"{loser} {noun} ({loser} over {winner}: Hodges–Lehmann ratio "
                + (f"{_ratio(better['ratio'].min())} to {_ratio(better['ratio'].max())}" if len(better) else "–")
                + f"), {len(significant)} of them significantly (Holm over the {len(g)} comparisons")
        quiet = better[~better["significant"]]
        if len(quiet):
            text += "; not significant: " + join([f"{b}, ratio {ratio_text(r)}, Holm p = {p_text(r['p_holm'])}"
                                                  for b, r in zip(quiet["backend"], quiet.to_dict("records"))])
        text += ")"
        if len(worse):
            text += "; " + join([f"{b} ends lower in the {loser} {noun} (ratio {ratio_text(r)}"
                                 f"{', significant' if r['significant'] else ''})"
                                 for b, r in zip(worse["backend"], worse.to_dict("records"))])
        parts.append(text + ".")
    return " ".join(parts)


def recommend(table: pd.DataFrame, success: pd.DataFrame, values: pd.DataFrame, tests, budget,
              unit: str = "N", noun: str | None = None) -> dict:
    """Apply the rule to a study: ``table`` (``statistics.ranking_table``), ``success`` (per specimen,
    at ``TARGET``), ``values`` (``comparisons.log_losses`` of the ranking runs), ``tests``
    (``statistics.Comparison``). Returns ``verdict``, ``best`` (the reference), ``choice``, ``order``
    and the paragraph ``text`` (markdown)."""
    verdict = decide(table, success, values)
    text = paragraph(verdict, table.set_index("optimizer"), tests, budget, noun)
    return {"verdict": verdict, "best": verdict.reference or verdict.order[0], "choice": verdict.choice,
            "order": verdict.order, "text": text}


def paragraph(verdict: Verdict, table, tests, budget, noun) -> str:
    """The recommendation paragraph: variants first, then the label to use and why, its equals and
    the tie-break, those less reliable, behind and to avoid, the baseline, and the design's power."""
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    noun = noun if verdict.by_variant is not None and len(verdict.by_variant) else None
    out = [variant_text(verdict, noun)] if noun else []
    if verdict.choice is None:
        out.append(f"Only the baseline ({join(verdict.baselines)}) ran: there is nothing to recommend.")
        return " ".join(out)
    choice, tau = verdict.choice, verdict.tie_target
    row = table.loc[choice]
    named = f"**Use {_pair(choice, noun).replace('**', '')}** ({choice})" if noun else f"**Use {choice}**"
    out.append(f"{named} at a budget of {budget_text} evaluations: it reached the {TARGET:.0%} target in "
               f"{_success(table, choice)}, with ERT {evals_text(row[f'ert_{TARGET:.0%}'])} evaluations × "
               f"{seconds_text(row['s_per_eval'])} per evaluation = "
               f"{seconds_text(row[f'time_{TARGET:.0%}'])} expected time to the target; its median final loss is "
               f"{_ratio(row['median_ratio'])} × the best known loss.")
    out.append(per_variant_text(verdict, table, noun))
    if choice in verdict.avoid:
        out.append(f"Even so, its final losses are significantly worse than random search's ({verdict.baselines[0]}): "
                   "no backend in this study beats the baseline.")
    peers = [n for n in verdict.peers if n not in verdict.avoid]
    ref_rows = verdict.vs_reference.set_index("a") if verdict.vs_reference is not None else pd.DataFrame()
    if len(peers) > 1:
        alike = [n for n in peers if n != verdict.reference]
        described = join([f"{n} (final losses {ratio_text(ref_rows.loc[n])}× the reference's, {_success(table, n)} on "
                          "target)" for n in alike])
        times = ", ".join(f"{n} {seconds_text(table.loc[n, f'time_{tau:.0%}'])}" for n in peers)
        out.append(f"By the rule, {described} {'is' if len(alike) == 1 else 'are'} as good as the reference "
                   f"{verdict.reference} ({_success(table, verdict.reference)} on target); the tie-break, the expected "
                   f"time to the {tau:.0%} target, picks **{choice}** ({times}).")
    else:
        out.append(f"No other backend is as good by the rule (final losses within {PRACTICAL:.0%} and success within "
                   f"{SUCCESS_MARGIN * 100:.0f} points on every specimen).")
    if verdict.less_reliable:
        out.append(f"Final losses within {PRACTICAL:.0%} of the reference's, but less reliable at reaching the "
                   f"target ({_success(table, verdict.reference)} for {verdict.reference}): "
                   + join([_deficit_text(verdict, table, n) for n in verdict.less_reliable]) + ".")
    if verdict.behind:
        items = [f"{n} ({_ratio(ref_rows.loc[n, 'ratio'])}×{'*' if ref_rows.loc[n, 'significant'] else ''})"
                 for n in verdict.behind]
        out.append(f"Behind (final losses more than {PRACTICAL:.0%} above the reference's; Hodges–Lehmann ratio, "
                   f"* = significant after Holm): {', '.join(items)}.")
    avoid = [n for n in verdict.avoid if n != choice]
    if avoid:
        base = verdict.vs_baseline.set_index("a")
        items = [f"**{n}** ({_ratio(base.loc[n, 'ratio'])}× {verdict.baselines[0]}'s final losses, Holm p = "
                 f"{p_text(base.loc[n, 'p_holm'])})" for n in avoid]
        out.append(f"Avoid {join(items)}: significantly worse than random search.")
    if verdict.baselines:
        out.append("Random search is the baseline, never a candidate: " + join(
            [f"{n} ends at a median {_ratio(table.loc[n, 'median_ratio'])} × the best known loss "
             f"({_success(table, n)} on target)" for n in verdict.baselines]) + ".")
    out.append(power_text(verdict, tests))
    return " ".join(t for t in out if t)


def per_variant_text(verdict: Verdict, table, noun) -> str:
    """When variants are compared: the backend to use in each of them (the first of its non-baseline
    labels in the rule's order), with its median final loss against the best known; "" otherwise."""
    if not noun:
        return ""
    first = {}
    for label in verdict.order:
        backend, variant = split_label(label)
        if variant is not None and label not in verdict.baselines and variant not in first:
            first[variant] = label
    if len(first) < 2:
        return ""
    items = [f"{split_label(label)[0]} in the {variant} {noun} (median final loss "
             f"{_ratio(table.loc[label, 'median_ratio'])} × the best known, {_success(table, label)} on target)"
             for variant, label in first.items()]
    return f"If the {noun} is given, the backend to use in each, by the same rule: {join(items)}."


def _deficit_text(verdict, table, label) -> str:
    specimen, gap = verdict.deficit.get(label, (None, math.nan))
    where = f"; {gap * 100:.0f} points below the reference on {specimen}" if specimen is not None else ""
    return f"{label} ({_success(table, label)} on target{where})"


def power_text(verdict: Verdict, tests) -> str:
    """What the test actually run can show at this size: its name, the design, the smallest p it
    can give and that p times Holm's factor for the comparisons against the reference (or, with
    no other candidate, against the baseline)."""
    families = [(verdict.vs_reference, "the reference"),
                (verdict.vs_baseline, verdict.baselines[0] if verdict.baselines else "the baseline")]
    frame, against = next(((f, name) for f, name in families if f is not None and len(f)), (None, ""))
    if frame is None:
        return f"Test: {tests.test_name}."
    smallest = float(frame["min_p"].min())
    floor = comparisons.holm_floor(frame)
    design = (f"{tests.n_specimens} specimen{'s' if tests.n_specimens != 1 else ''} × up to {tests.seeds} seeds "
              "per label")
    comparisons_ = "comparison" if len(frame) == 1 else f"{len(frame)} comparisons"
    text = (f"Power: every comparison uses {tests.test_name}; with {design} the smallest p it can give is "
            f"{p_text(smallest)}, and {p_text(floor)} after Holm's factor for the {comparisons_} against {against}")
    if floor >= ALPHA:
        return text + (f" ≥ α = {ALPHA:g}: no difference can be significant at this size, so the verdict rests on "
                       "the effect sizes and success rates; more seeds (or specimens) would be needed to test it.")
    return text + f" < α = {ALPHA:g}."
