"""The decision rule behind the report's recommendation, as data (``decide``); its words are
``bwbench.report.recommend``.

The rule combines the two views of a benchmark:

- fixed target: does a run get within 1 % of the best known loss of its specimen (``TARGET``), and
  how long does it take (ERT, COCO's expected running time, in evaluations);
- fixed budget: the final loss, compared as a Hodges–Lehmann ratio on log losses with specimens as
  blocks (``bwbench.analysis.comparisons``).

Steps (each threshold a constant here, each stated in the report before the verdict):

1. The baseline is found by backend: every label of random search, in whichever variant, is
   compared and described, never recommended. The other labels are the candidates.
2. Order: success rate at ``TARGET`` (higher first), then the mean rank of the median final loss
   over specimens (losses within ``statistics.TIE`` share a rank), then ERT in evaluations at
   ``TARGET`` and at ``FALLBACK_TARGET``, then the name. Every key is set by the seeds, none by the
   machine. The first candidate is the reference.
3. A candidate is *as good as* the reference only when both views agree: its final losses are at
   most ``PRACTICAL`` above the reference's (Hodges–Lehmann ratio ≤ 1.10) AND on every specimen its
   success rate is at most ``SUCCESS_MARGIN`` below the reference's. Final losses as low but a
   larger success deficit somewhere: *less reliable*. Final losses higher: *behind*.
4. Among the reference and its equals, measured time decides only where it is beyond its noise
   (``bwbench.report.time_noise``): a label is dropped when another's expected time to the target
   (ERT × measured seconds per evaluation; the 10 % target when none of them reaches 1 %) is
   lower by more than both its bootstrap interval and the machine's load allow. The labels left
   are *tied on time*; the recommended one is the first by ERT in evaluations (fewest), then the
   order of step 2 (``tie_key``). The same seeds give the same recommendation at any load.
5. *Avoid*: a candidate whose final losses are significantly (Holm) and practically (> ``PRACTICAL``)
   worse than the baseline's of its own variant (random search on the same model and formulation:
   a backend is never called worse than random search on another model). A candidate whose variant
   has no baseline run is not judged against one.
6. Variants (formulations; models alike): the effect of the variant on each backend's final loss
   against the recommended label's variant, before the recommendation.

Holm's correction runs within each family of comparisons the rule uses: candidates against the
reference, candidates against the baseline, and each backend's variants.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from bwbench.analysis import comparisons, statistics
from bwbench.render.labels import is_baseline, split_label
from bwbench.report.time_noise import clearly_faster

ALPHA = statistics.ALPHA
TARGET = 0.01  # the verdict's target: within 1 % of the best known loss of the specimen
FALLBACK_TARGET = 0.10  # the tie-break's target when none of the tied labels reaches TARGET
PRACTICAL = 0.10  # final losses at most 10 % higher (Hodges–Lehmann ratio ≤ 1.10): practically equal
SUCCESS_MARGIN = 0.10  # success rate at most 10 percentage points lower, on every specimen


@dataclass
class Verdict:
    """What the rule decided. Lists hold labels in the rule's order; ``vs_reference``,
    ``vs_baseline`` and ``by_variant`` are ``comparisons.family`` frames."""

    order: list  # every label: candidates and baselines by the key of step 2
    candidates: list
    baselines: list
    reference: str | None
    choice: str | None
    equal: list = field(default_factory=list)
    less_reliable: list = field(default_factory=list)
    behind: list = field(default_factory=list)
    avoid: list = field(default_factory=list)
    deficit: dict = field(default_factory=dict)  # label -> (worst specimen, success deficit there)
    tie_target: float = TARGET
    tied: list = field(default_factory=list)  # peers tied with the choice on time (within the noise)
    slower: list = field(default_factory=list)  # peers slower than another beyond the noise
    time_bounds: dict = field(default_factory=dict)  # label -> (low, high) expected time at tie_target, s
    reference_variant: str | None = None
    vs_reference: pd.DataFrame = None
    vs_baseline: pd.DataFrame = None
    by_variant: pd.DataFrame = None

    @property
    def peers(self) -> list:
        """The reference and its equals, in order."""
        return [n for n in self.order if n == self.reference or n in self.equal]

    def role(self, label: str) -> str:
        if label == self.choice:
            return "recommended"
        if label in self.tied:
            return "tied on time"
        if label in self.slower:
            return "as good, slower"
        for name, group in (
            ("as good", self.equal),
            ("avoid", self.avoid),
            ("less reliable", self.less_reliable),
            ("behind", self.behind),
        ):
            if label in group:
                return name
        if label == self.reference:
            return "as good"
        return "baseline" if label in self.baselines else ""


def own_baseline(label: str, baselines) -> str | None:
    """The baseline label of ``label``'s own variant (model and formulation), or None when that
    variant ran no baseline."""
    variant = split_label(label)[1]
    return next((b for b in baselines if split_label(b)[1] == variant), None)


def sort_key(table: pd.DataFrame):
    """The order of step 2 as a key over the ranking table's rows (by label)."""
    rows = table.set_index("optimizer")

    def key(label):
        r = rows.loc[label]
        rank = r["mean_rank"] if np.isfinite(r["mean_rank"]) else math.inf
        return (-float(r[f"success_{TARGET:.0%}"]), rank, _ert(r, TARGET), _ert(r, FALLBACK_TARGET), label)

    return key


def _ert(row, tau) -> float:
    value = float(row.get(f"ert_{tau:.0%}", math.nan))
    return value if np.isfinite(value) else math.inf


def worst_deficit(success: pd.DataFrame, label: str, reference: str) -> tuple[str | None, float]:
    """(specimen, deficit): where ``label``'s success rate falls furthest below ``reference``'s."""
    if label not in success or reference not in success:
        return None, math.nan
    gap = (success[reference] - success[label]).dropna()
    if not len(gap):
        return None, math.nan
    specimen = gap.idxmax()
    return specimen, float(gap[specimen])


def decide(
    table: pd.DataFrame, success: pd.DataFrame, values: pd.DataFrame, times: pd.DataFrame | None = None
) -> Verdict:
    """Apply the rule. ``table``: ``statistics.ranking_table``; ``success``: its labels' success
    rates at ``TARGET`` per specimen (``statistics.success_by_specimen``); ``values``: log10 final
    losses per run (``comparisons.log_losses`` of the ranking runs); ``times``: the expected times'
    intervals (``time_noise.intervals``; None: no time is beyond its noise, every peer is tied)."""
    order = sorted(table["optimizer"], key=sort_key(table))
    candidates = [n for n in order if not is_baseline(n)]
    baselines = [n for n in order if is_baseline(n)]
    verdict = Verdict(order, candidates, baselines, candidates[0] if candidates else None, None)
    if not candidates:
        return verdict
    ref = verdict.reference
    verdict.vs_reference = comparisons.family(
        values, [(c, ref) for c in candidates[1:]], "against the reference", ALPHA
    )
    verdict.vs_baseline = comparisons.family(
        values,
        [(c, base) for c in candidates if (base := own_baseline(c, baselines)) is not None],
        f"against {baselines[0]}" if len(baselines) == 1 else "against random search of the same variant",
        ALPHA,
    )
    against_ref = verdict.vs_reference.set_index("a")
    against_base = verdict.vs_baseline.set_index("a")
    for label in candidates:
        if ref is not None and label != ref:
            verdict.deficit[label] = worst_deficit(success, label, ref)
        if label in against_base.index:
            row = against_base.loc[label]
            if row["significant"] and row["ratio"] > 1 + PRACTICAL:
                verdict.avoid.append(label)
                continue
        if label == ref:
            continue
        ratio = against_ref.loc[label, "ratio"]
        deficit = verdict.deficit[label][1]
        if ratio <= 1 + PRACTICAL and not deficit > SUCCESS_MARGIN + 1e-12:
            verdict.equal.append(label)
        elif ratio <= 1 + PRACTICAL:
            verdict.less_reliable.append(label)
        else:
            verdict.behind.append(label)
    peers = [n for n in verdict.peers if n not in verdict.avoid] or [ref]
    rows = table.set_index("optimizer")
    reaches = any(np.isfinite(_ert(rows.loc[n], TARGET)) for n in peers)
    verdict.tie_target = tau = TARGET if reaches else FALLBACK_TARGET
    bounds = {}
    if times is not None and len(times):
        at = times[np.isclose(times["tau"], tau)].set_index("optimizer")
        bounds = {n: (float(at.loc[n, "low"]), float(at.loc[n, "high"])) for n in peers if n in at.index}
    verdict.time_bounds = bounds
    unknown = (math.nan, math.nan)
    # A peer stays in only if no other peer is faster beyond the noise.
    kept = [
        n
        for n in peers
        if not any(clearly_faster(bounds.get(m, unknown), bounds.get(n, unknown)) for m in peers if m != n)
    ]
    verdict.choice = min(kept, key=tie_key(rows, order, tau))
    verdict.tied = [n for n in sorted(kept, key=tie_key(rows, order, tau)) if n != verdict.choice]
    verdict.slower = [n for n in peers if n not in kept]
    verdict.reference_variant = split_label(verdict.choice)[1]
    verdict.by_variant = variant_effects(values, candidates + baselines, verdict.reference_variant)
    return verdict


def tie_key(rows: pd.DataFrame, order: list, tau: float):
    """The deterministic key among labels tied on time: ERT in evaluations at ``tau`` (fewest
    first), then the order of step 2 (success, mean rank, ERT, name)."""
    return lambda n: (_ert(rows.loc[n], tau), order.index(n))


def variant_effects(values: pd.DataFrame, labels, reference_variant: str | None) -> pd.DataFrame:
    """Each backend run in ``reference_variant`` and in another variant: that variant's label (a)
    against the reference variant's (b), Holm over all of these; columns of ``comparisons.family``
    plus ``backend`` and ``variant``. Empty when the labels carry no variants."""
    if reference_variant is None:
        return comparisons.family(values, [], "variants", ALPHA).assign(backend=[], variant=[])
    by_backend: dict = {}
    for label in labels:
        backend, variant = split_label(label)
        by_backend.setdefault(backend, {})[variant] = label
    pairs = [
        (variants[v], variants[reference_variant])
        for variants in by_backend.values()
        if reference_variant in variants
        for v in variants
        if v != reference_variant
    ]
    frame = comparisons.family(values, pairs, "variants", ALPHA)
    frame["backend"] = [split_label(a)[0] for a in frame["a"]]
    frame["variant"] = [split_label(a)[1] for a in frame["a"]]
    return frame
