"""A study's answer, computed once: the ranking in the rule's order, the statistics, the verdict and
its words. ``bwbench report`` (the box and the paragraph), ``bwbench compare`` (the line it prints)
and the Python API (``Study.recommendation``, ``Study.ranking()``) all read a ``StudyDecision`` made
by ``decide_study``: none of them applies the rule on its own, so they cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from bwbench.analysis import comparisons, statistics
from bwbench.render.labels import variant_noun
from bwbench.report import time_noise
from bwbench.report.recommend import box, one_line, recommend
from bwbench.report.verdict import TARGET, Verdict


@dataclass(frozen=True, eq=False)
class StudyDecision:
    """``table``: the ranking table in the rule's order (``statistics.ranking_table``); ``tests``: the
    rank tests (``statistics.Comparison``); ``verdict``: the rule's decision; ``text``: the paragraph
    that applies it (markdown, provisional studies say so first); ``budget``: evaluations per run;
    ``provisional``: "" or "provisional: 16 of 36 runs"; ``noun``: what the variants are, or None."""

    table: pd.DataFrame
    tests: statistics.Comparison
    verdict: Verdict
    text: str
    budget: object
    provisional: str
    noun: str | None
    facts: dict

    @property
    def choice(self) -> str | None:
        return self.verdict.choice

    @property
    def best(self) -> str:
        """The recommended label, else the reference of the rule."""
        return str(self.verdict.choice or self.verdict.reference or self.verdict.order[0])

    @property
    def as_dict(self) -> dict:
        """The shape ``recommend.recommend`` returns (verdict, best, choice, order, text)."""
        return {
            "verdict": self.verdict,
            "best": self.best,
            "choice": self.choice,
            "order": self.verdict.order,
            "text": self.text,
        }

    def line(self) -> str:
        """The recommendation in one line, for the terminal (``bwbench compare``, ``bwbench report``)."""
        text = one_line(self.verdict, self.table.set_index("optimizer"), self.budget)
        return (f"{_capital(self.provisional)}: " if self.provisional else "") + text

    def box(self) -> list[str]:
        """The report's box: what to use, how reliable and fast, what is tied, what to avoid."""
        return box(self.verdict, self.table.set_index("optimizer"), self.budget, self.noun, self.facts)

    def ranking(self) -> pd.DataFrame:
        """The ranking table with each label's role in the verdict (``verdict`` column)."""
        return self.table.assign(verdict=[self.verdict.role(n) for n in self.table["optimizer"]])


def decide_study(study) -> StudyDecision:
    """The decision of a loaded study (``bwbench.store.reader.Study``) with its measured times: the one
    function every entry point calls."""
    table, _ = statistics.ranking_table(study.runs, study.traces, study.optimizers)
    tests = statistics.compare_backends(study.runs)
    success = statistics.success_by_specimen(study.runs, study.traces, TARGET)
    budget = study.settings.get("budget", "?")
    noun = variant_noun(study.settings)
    rec = recommend(
        table,
        success,
        comparisons.log_losses(study.ranking),
        tests,
        budget,
        study.problem_type.residual_unit,
        noun,
        times=time_noise.intervals(study.runs, study.traces),
    )
    table = table.set_index("optimizer").loc[rec["order"]].reset_index()  # the rule's order, everywhere
    provisional = study.provisional
    text = rec["text"]
    if provisional:
        text = (
            f"**{_capital(provisional)}**: the study is unfinished (still running, or stopped part-way), so "
            "this recommendation may change when it completes. " + text
        )
    verdict = rec["verdict"]
    shown_noun = noun if verdict.by_variant is not None and len(verdict.by_variant) else None
    return StudyDecision(table, tests, verdict, text, budget, provisional, shown_noun, label_facts(study))


def label_facts(study) -> dict:
    """Label -> {"model": …, "formulation": …} as its ranking runs recorded them (one value each)."""
    ranking = study.ranking
    facts: dict = {}
    for label, g in ranking.groupby("optimizer", sort=False):
        facts[label] = {
            key: str(g[key].dropna().iloc[0])
            for key in ("model", "formulation")
            if key in g and g[key].dropna().nunique() == 1
        }
    return facts


def _capital(text: str) -> str:
    return f"{text[0].upper()}{text[1:]}" if text else text
