"""The clauses of the recommendation's paragraph: the interval of a ratio, a tie and how it was broken,
the answer per formulation, the power of the tests and the size of an effect, each in words."""

from __future__ import annotations

import math

import numpy as np

from bwbench.analysis import comparisons
from bwbench.render.format import evals_text, join, number, p_text, seconds_text
from bwbench.render.labels import split_label
from bwbench.report import time_noise
from bwbench.report.verdict import ALPHA, PRACTICAL, TARGET, Verdict


def ratio_number(x) -> str:
    """A loss ratio: three decimals near 1 (1.004, 0.982), three figures further out, powers of ten far."""
    if not np.isfinite(x):
        return number(x)
    if 0.9 <= x <= 1.1:
        return f"{x:.3f}"
    return f"{x:.3g}" if 0.01 <= x < 1000 else f"{x:.1e}"


def success_text(table, label, tau=TARGET) -> str:
    row = table.loc[label]
    runs = int(row["runs"])
    return f"{int(round(row[f'success_{tau:.0%}'] * runs))} of {runs} runs"


def interval_text(verdict: Verdict, table, label: str) -> str:
    """'0.41 s [0.35, 0.47 s]': a label's expected time to the tie-break's target and its interval."""
    tau = verdict.tie_target
    low, high = verdict.time_bounds.get(label, (math.nan, math.nan))
    point = seconds_text(table.loc[label, f"time_{tau:.0%}"])
    return point + (f" [{seconds_text(low)}, {seconds_text(high)}]" if np.isfinite(low) or np.isfinite(high) else "")


def tie_text(verdict: Verdict, table) -> str:
    """How the tie-break went: which peers are slower beyond the noise, which are tied on time, and
    the deterministic key that broke the tie."""
    tau, choice = verdict.tie_target, verdict.choice
    if choice is None:
        return ""
    noise = (
        f"{time_noise.LEVEL:.0%} bootstrap interval over the runs, widened by the ±{time_noise.LOAD:.0%} a "
        "machine's load can move one label's times against another's"
    )
    parts = []
    if verdict.slower:
        parts.append(
            f"Expected time to the {tau:.0%} target ({noise}): "
            + join([f"{n} {interval_text(verdict, table, n)}" for n in verdict.slower])
            + f" {'is' if len(verdict.slower) == 1 else 'are'} slower beyond the noise than **{choice}** "
            f"({interval_text(verdict, table, choice)})."
        )
    if verdict.tied:
        group = [choice, *verdict.tied]
        erts = join([f"{n} {evals_text(table.loc[n, f'ert_{tau:.0%}'])}" for n in group])
        parts.append(
            f"{join(group)} are **tied** on time: their expected times to the {tau:.0%} target "
            + ("" if verdict.slower else f"({noise}) ")
            + "do not differ beyond the noise ("
            + ", ".join(f"{n} {interval_text(verdict, table, n)}" for n in group)
            + f"); the tie is broken by the deterministic key, ERT in evaluations (fewest first), then the "
            f"rule's order: **{choice}** (ERT {erts} evaluations)."
        )
    elif not verdict.slower:
        parts.append(f"**{choice}** is recommended.")
    return " ".join(parts)


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
    items = [
        f"{split_label(label)[0]} in the {variant} {noun} (median final loss "
        f"{ratio_number(table.loc[label, 'median_ratio'])} × the best known, {success_text(table, label)} on target)"
        for variant, label in first.items()
    ]
    return f"If the {noun} is given, the backend to use in each, by the same rule: {join(items)}."


def deficit_text(verdict, table, label) -> str:
    specimen, gap = verdict.deficit.get(label, (None, math.nan))
    where = f"; {gap * 100:.0f} points below the reference on {specimen}" if specimen is not None else ""
    return f"{label} ({success_text(table, label)} on target{where})"


def power_text(verdict: Verdict, tests) -> str:
    """What the test actually run can show at this size: its name, the design, the smallest p it
    can give and that p times Holm's factor for the comparisons against the reference (or, with
    no other candidate, against the baseline)."""
    families = [
        (verdict.vs_reference, "the reference"),
        (verdict.vs_baseline, "random search of the same variant"),
    ]
    frame, against = next(((f, name) for f, name in families if f is not None and len(f)), (None, ""))
    if frame is None:
        return f"Test: {tests.test_name}."
    smallest = float(frame["min_p"].min())
    floor = comparisons.holm_floor(frame)
    design = (
        f"{tests.n_specimens} specimen{'s' if tests.n_specimens != 1 else ''} × up to {tests.seeds} seeds per label"
    )
    comparisons_ = "comparison" if len(frame) == 1 else f"{len(frame)} comparisons"
    text = (
        f"Power: every comparison uses {tests.test_name}; with {design} the smallest p it can give is "
        f"{p_text(smallest)}, and {p_text(floor)} after Holm's factor for the {comparisons_} against {against}"
    )
    if floor >= ALPHA:
        return text + (
            f" ≥ α = {ALPHA:g}: no difference can be significant at this size, so the verdict rests on "
            "the effect sizes and success rates; more seeds (or specimens) would be needed to test it."
        )
    return text + f" < α = {ALPHA:g}."


def effect_sentence(verdict: Verdict, noun: str | None) -> str:
    """The effect of the variants in one sentence: for each other variant, the side where most
    backends end at lower final losses, how many do and how many significantly, and by how much (the
    median over backends of the Hodges–Lehmann ratio, said as "practically equal" within
    ``PRACTICAL``: a significant 0.1 % is no reason to change formulation) ('' without variants)."""
    frame = verdict.by_variant
    if not noun or frame is None or not len(frame):
        return ""
    ref, parts = verdict.reference_variant, []
    for variant, g in frame.groupby("variant", sort=False):
        lower_in_other = int((g["ratio"] < 1).sum())
        lower_in_ref = int((g["ratio"] > 1).sum())
        winner, count = (variant, lower_in_other) if lower_in_other > lower_in_ref else (ref, lower_in_ref)
        loser = ref if winner == variant else variant
        significant = int((g["significant"] & ((g["ratio"] < 1) if winner == variant else (g["ratio"] > 1))).sum())
        parts.append(
            f"in the {winner} {noun} {count} of {len(g)} backends end at lower final losses than in the "
            f"{loser} {noun} ({significant} significantly, Holm), {_effect_size(g['ratio'], winner == variant)}"
        )
    text = "; ".join(parts)
    return text[0].upper() + text[1:] + "."


def _effect_size(ratios, other_lower: bool) -> str:
    """How much lower the winning variant's final losses are: the median over backends of
    1 − ratio (or of 1 − 1/ratio), with "practically equal" below ``PRACTICAL``."""
    r = np.asarray(ratios, dtype=float)
    r = r[np.isfinite(r) & (r > 0)]
    if not len(r):
        return "by an unknown amount"
    lower = 1.0 - (r if other_lower else 1.0 / r)  # the winner's final loss below the loser's, per backend
    median = float(np.median(lower))
    size = f"{median:.1%}" if abs(median) >= 0.0005 else "less than 0.05%"
    span = f" ({float(lower.min()):.1%} to {float(lower.max()):.1%})" if len(lower) > 1 else ""
    if median < PRACTICAL:
        return f"a median {size} lower{span}: practically equal (within the rule's {PRACTICAL:.0%})"
    return f"a median {size} lower{span}"
