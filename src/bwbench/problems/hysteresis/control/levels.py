"""Per-test constants against one model with laws, on control levels the fit did not see.

``compare_levels`` answers the two questions a lab asks of a controllable damper's tests:

- in sample: how close does one model with laws come to each file, against each file fitted alone
  with its own constants (the per-test fits a lab makes today)?
- leave one level out: for each control level, the model with laws is fitted to the files of the
  other levels and predicts the files at the held-out level, nothing refitted; beside it, the
  per-test approach's best guess at an unseen level: the constants fitted jointly to the files of
  the nearest other level.

NRMSE = RMSE / max|F measured| throughout.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class LevelComparison:
    """The rows (one per file: specimen, level, and the NRMSEs of the module docstring) and the settings."""

    control: str
    laws: dict
    rows: list = field(default_factory=list)

    def table(self) -> str:
        """A Markdown table of the rows."""
        head = (
            f"| file | {self.control} | each file alone (in sample) | one model with laws (in sample) | "
            "laws, level left out (predicted) | nearest level's constants (predicted) |"
        )
        lines = [head, "|---|---|---|---|---|---|"]
        for r in self.rows:
            cells = [r["specimen"], f"{r['level']:g}"] + [
                "—" if r.get(k) is None else f"{r[k]:.4f}" for k in ("alone", "laws", "left_out", "nearest")
            ]
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines)

    def summary(self) -> str:
        """One paragraph: medians and how often the laws' prediction beats the nearest level's constants."""

        def med(key):
            vals = [r[key] for r in self.rows if r.get(key) is not None]
            return float(np.median(vals)) if vals else float("nan")

        both = [r for r in self.rows if r.get("left_out") is not None and r.get("nearest") is not None]
        wins = sum(r["left_out"] <= r["nearest"] for r in both)
        return (
            f"median NRMSE: each file alone {med('alone'):.4f}, one model with laws {med('laws'):.4f} in sample; "
            f"on left-out levels the laws predict at {med('left_out'):.4f}, the nearest level's constants at "
            f"{med('nearest'):.4f} (the laws better on {wins} of {len(both)} files)"
        )

    def to_dict(self) -> dict:
        return {
            "control": self.control,
            "laws": dict(self.laws),
            "rows": list(self.rows),
            "nrmse": "RMSE / max|F measured|",
        }


def _nrmse(prediction) -> float | None:
    value = float(prediction.nrmse)
    return value if np.isfinite(value) else None


def compare_levels(
    specimens,
    settings: dict,
    laws: dict,
    *,
    optimizer: str = "lsq-trf",
    budget: int = 4100,
    seed: int = 0,
    left_out=None,
    progress=None,
) -> LevelComparison:
    """See the module docstring. ``left_out``: the levels to leave out (default: every level whose
    removal leaves the laws enough levels); ``progress``: called with a line before each fit."""
    from bwbench.problems.hysteresis.control.fitted import of_problem
    from bwbench.problems.hysteresis.control.problem import build
    from bwbench.problems.hysteresis.fit_result import run_fit

    say = progress or (lambda line: None)
    groups: dict = {}
    for s in specimens:
        groups.setdefault(float(np.asarray(s.control)[0]), []).append(s)
    levels = sorted(groups)
    full = build(specimens, settings, laws)
    needed = max([law.n for law in full.laws.values()] + [1])
    out = LevelComparison(full.control_name, {n: law.name for n, law in full.laws.items()})
    say(f"one model with laws, all {len(levels)} levels")
    fit = run_fit(full, optimizer, budget, seed, stop="agreed")
    in_sample = {row["specimen"]: row["nrmse"] for row in fit.files}
    alone, per_level = {}, {}
    for level in levels:
        say(f"each file alone at {level:g} {full.control_unit}")
        for s in groups[level]:
            one = run_fit(build([s], settings, {}), optimizer, budget, seed, stop="agreed")
            alone[s.name] = one.files[0]["nrmse"]
        say(f"the files at {level:g} {full.control_unit} jointly (constants)")
        joint = build(groups[level], settings, {})
        per_level[level] = of_problem(joint, run_fit(joint, optimizer, budget, seed, stop="agreed").result.params)
    chosen = [lv for lv in (left_out if left_out is not None else levels) if len(levels) - 1 >= needed]
    predicted, nearest = {}, {}
    for level in chosen:
        train = [s for lv in levels if lv != level for s in groups[lv]]
        say(f"laws without {level:g} {full.control_unit}: fit to {len(train)} files")
        problem = build(train, settings, laws)
        model = of_problem(problem, run_fit(problem, optimizer, budget, seed, stop="agreed").result.params)
        near = min((lv for lv in levels if lv != level), key=lambda lv: abs(lv - level))
        for s in groups[level]:
            predicted[s.name] = _nrmse(model.predict(s))
            nearest[s.name] = _nrmse(per_level[near].at(level).predict(s))
    for level in levels:
        for s in groups[level]:
            out.rows.append(
                {
                    "specimen": s.name,
                    "level": level,
                    "alone": alone.get(s.name),
                    "laws": in_sample.get(s.name),
                    "left_out": predicted.get(s.name),
                    "nearest": nearest.get(s.name),
                }
            )
    return out
