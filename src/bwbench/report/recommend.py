"""The recommendation in words: the rule (``rule``), stated before it is applied, and the paragraph
that applies it (``recommend``). The decision itself is ``bwbench.report.verdict``.
"""

from __future__ import annotations

import pandas as pd

from bwbench.analysis import comparisons, statistics
from bwbench.render.format import evals_text, join, p_text, seconds_text
from bwbench.render.labels import split_label
from bwbench.report import time_noise
from bwbench.report.recommend_clauses import (
    deficit_text,
    effect_sentence,
    per_variant_text,
    power_text,
    ratio_number,
    success_text,
    tie_text,
)
from bwbench.report.verdict import (
    ALPHA,
    FALLBACK_TARGET,
    PRACTICAL,
    SUCCESS_MARGIN,
    TARGET,
    Verdict,
    decide,
)


def _charge_text() -> str:
    """How the budget counts an exact Jacobian, with the built-in models' charges."""
    from bwbench.models import registry

    models = [registry.get(name) for name in registry.BUILTIN]
    listed = join([f"{m.sensitivity_cost} for the {m.title}" for m in models if m.sensitivity_cost])
    return (
        "An evaluation is one simulation of one parameter vector; an exact Jacobian (forward sensitivities "
        f"integrated with the model's state) is charged the plain evaluations it costs, rounded up: {listed}."
    )


def rule(test_name: str, noun: str | None = None) -> list[str]:
    """The decision rule as bullets, naming the test the design runs and, when the study compares
    variants side by side, what they are (``noun``: "formulation", "model", ...)."""
    items = [
        f"**Views.** Fixed budget: a run's *final loss* is its best loss when the budget is spent. Fixed target: a "
        f"run *succeeds* when it gets within {TARGET:.0%} of the best known loss of its specimen (the lowest of any "
        "run in this database); *ERT* (COCO's expected running time) = evaluations spent by all runs (to the "
        "target for the successful ones) / number of successful runs; *expected time to the target* = ERT × "
        "measured seconds per evaluation (all wall time of the label's runs / all their evaluations, one core). "
        + _charge_text(),
        "**Baseline.** Random search, in whichever "
        + (noun or "variant")
        + ", is the baseline: compared and described, never recommended.",
        f"**Order.** Candidates by success rate at the {TARGET:.0%} target (higher first), then by the mean rank "
        f"over specimens of their median final loss (losses within {statistics.TIE:.0%} of each other share a "
        "rank), then by ERT in evaluations, then by name: quantities the seeds set, not the machine. The first "
        "is the reference.",
        f"**As good as the reference** only when both views agree: final losses at most {PRACTICAL:.0%} higher "
        f"(Hodges–Lehmann ratio ≤ {1 + PRACTICAL:.2f}) **and** on every specimen a success rate at most "
        f"{SUCCESS_MARGIN * 100:.0f} percentage points lower. Final losses as low but a larger success deficit on "
        f"some specimen: *less reliable*. Final losses more than {PRACTICAL:.0%} higher: *behind*.",
        f"**Tie-break.** Among the reference and its equals, measured time counts only beyond its noise: a label "
        f"is dropped when another's expected time to the {TARGET:.0%} target (the {FALLBACK_TARGET:.0%} target when "
        f"none of them reaches {TARGET:.0%}) is lower even after the noise: the upper end of its "
        f"{time_noise.LEVEL:.0%} bootstrap interval (the label's runs resampled within each specimen, "
        f"{time_noise.RESAMPLES:,} resamples, fixed seed) × {time_noise.LOAD_FACTOR:.2f} (a machine's load moving "
        f"one label's times by ±{time_noise.LOAD:.0%} against another's) still below the other's lower end. The "
        "labels left are *tied on time*; of these the one with the fewest evaluations to the target (ERT) is "
        "recommended, then the order above. The same seeds give the same answer on any machine at any load.",
        f"**Avoid**: final losses significantly (Holm) and more than {PRACTICAL:.0%} worse than random search's on "
        "the same model and formulation (never against random search on another model).",
        f"**Statistics.** Each comparison: {test_name} on log10 final losses (a failed run counts one decade "
        f"worse than the worst finished run on its specimen); effect size = Hodges–Lehmann ratio of final losses "
        f"with a {comparisons.LEVEL:.0%} bootstrap interval ({comparisons.BOOTSTRAP:,} resamples of the seeds within "
        f"each specimen, fixed seed); Holm's correction at α = {ALPHA:g} within each family of comparisons the "
        "rule uses (against the reference; against the baseline"
        + (f"; each backend's {noun}s" if noun else "")
        + "). Significance qualifies a verdict, it never makes one.",
    ]
    if noun:
        items.insert(
            1,
            f"**{noun.capitalize()}s first.** Each backend run in several {noun}s: its final losses in "
            f"each {noun} against those in the recommended label's {noun}; then one (backend, {noun}) "
            "pair is recommended.",
        )
    return items


def ratio_text(row) -> str:
    """'1.02 [0.99, 1.05]': a Hodges–Lehmann ratio with its interval."""
    return f"{ratio_number(row['ratio'])} [{ratio_number(row['ratio_low'])}, {ratio_number(row['ratio_high'])}]"


def _pair(label: str, noun: str | None) -> str:
    backend, variant = split_label(label)
    return f"**{backend}** in the **{variant}** {noun}" if variant and noun else f"**{label}**"


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
        text = (
            f"In the {winner} {noun}, {len(better)} of {len(g)} backends end at lower final losses than in the "
            f"{loser} {noun} ({loser} over {winner}: Hodges–Lehmann ratio "
            + (
                ratio_number(better["ratio"].min())
                if len(better) == 1
                else f"{ratio_number(better['ratio'].min())} to {ratio_number(better['ratio'].max())}"
                if len(better)
                else "–"
            )
            + f"), {len(significant)} of them significantly (Holm over the {len(g)} comparisons"
        )
        quiet = better[~better["significant"]]
        if len(quiet):
            text += "; not significant: " + join(
                [
                    f"{b}, ratio {ratio_text(r)}, Holm p = {p_text(r['p_holm'])}"
                    for b, r in zip(quiet["backend"], quiet.to_dict("records"))
                ]
            )
        text += ")"
        if len(worse):
            text += "; " + join(
                [
                    f"{b} ends lower in the {loser} {noun} (ratio {ratio_text(r)}"
                    f"{', significant' if r['significant'] else ''})"
                    for b, r in zip(worse["backend"], worse.to_dict("records"))
                ]
            )
        parts.append(text + ".")
    return " ".join(parts)


def recommend(
    table: pd.DataFrame,
    success: pd.DataFrame,
    values: pd.DataFrame,
    tests,
    budget,
    unit: str = "N",
    noun: str | None = None,
    times: pd.DataFrame | None = None,
) -> dict:
    """Apply the rule to a study: ``table`` (``statistics.ranking_table``), ``success`` (per specimen,
    at ``TARGET``), ``values`` (``comparisons.log_losses`` of the ranking runs), ``tests``
    (``statistics.Comparison``), ``times`` (``time_noise.intervals``). Returns ``verdict``, ``best``
    (the reference), ``choice``, ``order`` and the paragraph ``text`` (markdown)."""
    verdict = decide(table, success, values, times)
    text = paragraph(verdict, table.set_index("optimizer"), tests, budget, noun)
    return {
        "verdict": verdict,
        "best": verdict.reference or verdict.order[0],
        "choice": verdict.choice,
        "order": verdict.order,
        "text": text,
    }


def paragraph(verdict: Verdict, table, tests, budget, noun) -> str:
    """The recommendation paragraph: variants first, then the label to use and why, its equals and
    the tie-break, those less reliable, behind and to avoid, the baseline, and the design's power."""
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    noun = noun if verdict.by_variant is not None and len(verdict.by_variant) else None
    out = [variant_text(verdict, noun)] if noun else []
    if verdict.choice is None:
        out.append(f"Only the baseline ({join(verdict.baselines)}) ran: there is nothing to recommend.")
        return " ".join(out)
    choice = verdict.choice
    row = table.loc[choice]
    named = f"**Use {_pair(choice, noun).replace('**', '')}** ({choice})" if noun else f"**Use {choice}**"
    out.append(
        f"{named} at a budget of {budget_text} evaluations: it reached the {TARGET:.0%} target in "
        f"{success_text(table, choice)}, with ERT {evals_text(row[f'ert_{TARGET:.0%}'])} evaluations × "
        f"{seconds_text(row['s_per_eval'])} per evaluation = "
        f"{seconds_text(row[f'time_{TARGET:.0%}'])} expected time to the target; its median final loss is "
        f"{ratio_number(row['median_ratio'])} × the best known loss."
    )
    out.append(per_variant_text(verdict, table, noun))
    if choice in verdict.avoid:
        base = verdict.vs_baseline.set_index("a").loc[choice, "b"]
        out.append(
            f"Even so, its final losses are significantly worse than random search's on the same variant "
            f"({base}): no backend in this study beats the baseline."
        )
    peers = [n for n in verdict.peers if n not in verdict.avoid]
    ref_rows = verdict.vs_reference.set_index("a") if verdict.vs_reference is not None else pd.DataFrame()
    if len(peers) > 1:
        alike = [n for n in peers if n != verdict.reference]
        described = join(
            [
                f"{n} (final losses {ratio_text(ref_rows.loc[n])}× the reference's, {success_text(table, n)} on target)"
                for n in alike
            ]
        )
        out.append(
            f"By the rule, {described} {'is' if len(alike) == 1 else 'are'} as good as the reference "
            f"{verdict.reference} ({success_text(table, verdict.reference)} on target)."
        )
        out.append(tie_text(verdict, table))
    else:
        out.append(
            f"No other backend is as good by the rule (final losses within {PRACTICAL:.0%} and success within "
            f"{SUCCESS_MARGIN * 100:.0f} points on every specimen)."
        )
    if verdict.less_reliable:
        out.append(
            f"Final losses within {PRACTICAL:.0%} of the reference's, but less reliable at reaching the "
            f"target ({success_text(table, verdict.reference)} for {verdict.reference}): "
            + join([deficit_text(verdict, table, n) for n in verdict.less_reliable])
            + "."
        )
    if verdict.behind:
        items = [
            f"{n} ({ratio_number(ref_rows.loc[n, 'ratio'])}×{'*' if ref_rows.loc[n, 'significant'] else ''})"
            for n in verdict.behind
        ]
        out.append(
            f"Behind (final losses more than {PRACTICAL:.0%} above the reference's; Hodges–Lehmann ratio, "
            f"* = significant after Holm): {', '.join(items)}."
        )
    avoid = [n for n in verdict.avoid if n != choice]
    if avoid:
        base = verdict.vs_baseline.set_index("a")
        items = [
            f"**{n}** ({ratio_number(base.loc[n, 'ratio'])}× {base.loc[n, 'b']}'s final losses, Holm p = "
            f"{p_text(base.loc[n, 'p_holm'])})"
            for n in avoid
        ]
        out.append(f"Avoid {join(items)}: significantly worse than random search on the same variant.")
    if verdict.baselines:
        out.append(
            "Random search is the baseline, never a candidate: "
            + join(
                [
                    f"{n} ends at a median {ratio_number(table.loc[n, 'median_ratio'])} × the best known loss "
                    f"({success_text(table, n)} on target)"
                    for n in verdict.baselines
                ]
            )
            + "."
        )
    out.append(power_text(verdict, tests))
    return " ".join(t for t in out if t)


def glance_items(verdict: Verdict, table, budget, noun: str | None, what: dict | None = None) -> list[str]:
    """The recommendation at a glance, as bullets: what to use (``what``: label -> {"model": …,
    "formulation": …} as the runs recorded them), how reliable and how fast, the tied alternatives,
    what to avoid, and the variants' effect in one sentence."""
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    if verdict.choice is None:
        return [f"**Nothing to recommend**: only the baseline ({join(verdict.baselines)}) ran."]
    choice, tau = verdict.choice, verdict.tie_target
    row = table.loc[choice]
    backend = split_label(choice)[0]
    facts = (what or {}).get(choice, {})
    context = [f"model {facts['model']}"] if facts.get("model") else []
    context += [f"{facts['formulation']} formulation"] if facts.get("formulation") else []
    items = [
        f"**Use {backend}**"
        + (f" ({', '.join(context)})" if context else "")
        + f" at **{budget_text} evaluations** per run (label `{choice}`)."
    ]
    items.append(
        f"**Reaches the target** (within {TARGET:.0%} of the best known loss) in {success_text(table, choice)}; "
        f"expected time {seconds_text(row[f'time_{TARGET:.0%}'])} ({evals_text(row[f'ert_{TARGET:.0%}'])} "
        f"evaluations × {seconds_text(row['s_per_eval'])} on the machine that ran it)."
    )
    if verdict.tied:
        items.append(
            "**Tied**: "
            + join([f"{n} ({evals_text(table.loc[n, f'ert_{tau:.0%}'])} evaluations)" for n in verdict.tied])
            + f": as good by the rule and as fast within the noise; {choice} needs the fewest evaluations."
        )
    else:
        others = [n for n in verdict.peers if n != choice and n not in verdict.avoid]
        items.append(
            "**Tied**: none"
            + (
                f"; as good but slower beyond the time noise: {join(others)}."
                if others
                else "; no other label is as good by the rule."
            )
        )
    avoid = [n for n in verdict.avoid if n != choice]
    parts = [
        f"**Avoid** {join(avoid)} (worse than random search on its own variant)."
        if avoid
        else "**Avoid**: no label is worse than random search."
    ]
    if verdict.behind:
        parts.append(f"Behind (final losses > {PRACTICAL:.0%} higher): {join(verdict.behind)}.")
    if verdict.less_reliable:
        parts.append(f"Less reliable: {join(verdict.less_reliable)}.")
    items.append(" ".join(parts))
    effect = effect_sentence(verdict, noun)
    if effect and noun:
        items.append(f"**{noun.capitalize()}**: {effect}")
    return items


def one_line(verdict: Verdict, table, budget) -> str:
    """The recommendation in one line, for the terminal."""
    if verdict.choice is None:
        return "Recommendation: none (only the baseline ran)."
    choice = verdict.choice
    budget_text = f"{budget:,}" if isinstance(budget, (int, float)) else str(budget)
    row = table.loc[choice]
    text = (
        f"Recommendation: use {choice} at {budget_text} evaluations ({success_text(table, choice)} within "
        f"{TARGET:.0%} of the best known loss, expected time {seconds_text(row[f'time_{TARGET:.0%}'])})"
    )
    if verdict.tied:
        text += f"; tied on time: {join(verdict.tied)} (broken by fewest evaluations to the target)"
    avoid = [n for n in verdict.avoid if n != choice]
    if avoid:
        text += f"; avoid {join(avoid)}"
    return text + "."
