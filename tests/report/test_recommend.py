"""The decision rule on stored run tables (no optimisation): both views must agree for "as good",
the tie-break is the expected time to the target only beyond its noise, random search is the baseline by backend, ranks
tie within tolerance, the power statement names the test run, and a clear case gets its clear answer."""

import numpy as np
import pandas as pd
import pytest

from bwbench.analysis import comparisons, statistics
from bwbench.report import time_noise
from bwbench.report.recommend import recommend, rule
from bwbench.report.verdict import PRACTICAL, SUCCESS_MARGIN, TARGET

BUDGET = 1000
BASE = {"s1": 4.0, "s2": 9.0, "s3": 7.0}  # best known MSE (N²) of each specimen


def tables(labels: dict, specimens=tuple(BASE), seeds: int = 4):
    """Run and trace tables of a study. ``labels``: {label: (s_per_eval, outcome)} where
    ``outcome(specimen, seed)`` is (final loss / best known, evaluations at which it got there). Each
    trace starts 1000× above the best known at evaluation 1."""
    runs, traces = [], []
    for label, (s_per_eval, outcome) in labels.items():
        for specimen in specimens:
            for seed in range(seeds):
                factor, evals = outcome(specimen, seed)
                final = BASE[specimen] * factor
                key = {"kind": "ranking", "specimen": specimen, "optimizer": label, "replicate": seed}
                runs.append(
                    {
                        **key,
                        "status": "ok" if np.isfinite(final) else "error",
                        "mse": final,
                        "nfev": float(BUDGET),
                        "wall_s": s_per_eval * BUDGET,
                    }
                )
                traces += [{**key, "nfev": 1, "mse": BASE[specimen] * 1000.0}]
                if np.isfinite(final):
                    traces += [{**key, "nfev": int(evals), "mse": final}]
    return pd.DataFrame(runs), pd.DataFrame(traces)


def decide(runs, traces, noun=None):
    table, _ = statistics.ranking_table(runs, traces)
    success = statistics.success_by_specimen(runs, traces, TARGET)
    tests = statistics.compare_backends(runs)
    return recommend(
        table, success, comparisons.log_losses(runs), tests, BUDGET, "N", noun, times=time_noise.intervals(runs, traces)
    )


def always(factor=1.0, evals=300):
    return lambda specimen, seed: (factor, evals)


def test_equal_median_but_lower_success_rate_is_not_as_good():
    # b ends at the best known on 3 of 4 seeds of every specimen (same median as a), 50 % above on one
    runs, traces = tables({"a": (1e-3, always()), "b": (1e-4, lambda s, seed: (1.5 if seed == 3 else 1.0, 200))})
    rec = decide(runs, traces)
    v = rec["verdict"]
    assert v.vs_reference.set_index("a").loc["b", "ratio"] == pytest.approx(1.0)  # final losses: practically equal
    assert v.deficit["b"][1] == pytest.approx(0.25) and v.deficit["b"][1] > SUCCESS_MARGIN
    assert v.equal == [] and v.less_reliable == ["b"] and rec["choice"] == "a"
    assert "b (9 of 12 runs on target; 25 points below the reference" in rec["text"]
    # b is faster per target, but a backend that misses on some specimens is never an equal
    assert "No other backend is as good by the rule" in rec["text"]


def test_a_label_faster_far_beyond_the_noise_wins_on_time_not_on_fewer_evaluations():
    # a: 300 evaluations × 2 ms = 0.6 s; b: 900 evaluations × 0.1 ms = 0.09 s; both always on target:
    # 6.7× apart, far more than the ±15 % machine load (1.35×) and the runs' spread (none here) allow
    labels = {"a": (2e-3, always(1.0, 300)), "b": (1e-4, always(1.0, 900))}
    rec = decide(*tables(labels))
    v = rec["verdict"]
    assert set(v.peers) == {"a", "b"} and rec["choice"] == "b"
    assert v.slower == ["a"] and v.tied == [] and v.role("a") == "as good, slower"
    assert "a 0.6 s [0.6 s, 0.6 s] is slower beyond the noise than **b** (90 ms [90 ms, 90 ms])" in rec["text"]
    table = statistics.ranking_table(*tables(labels))[0].set_index("optimizer")
    assert table.loc["a", "time_1%"] == pytest.approx(0.6) and table.loc["b", "time_1%"] == pytest.approx(0.09)
    # the same data in another order: the same answer, word for word
    runs, traces = tables(dict(reversed(list(labels.items()))))
    again = decide(runs.sample(frac=1.0, random_state=1), traces.sample(frac=1.0, random_state=2))
    assert again["choice"] == "b" and again["text"] == rec["text"]


def test_random_search_in_any_formulation_is_the_baseline_and_avoid_reads_formulation_labels():
    labels = {
        "random [identifiable]": (1e-4, always(1.0, 900)),  # even when it fits best
        "lsq-trf [identifiable]": (1e-3, always(1.0, 300)),
        "ga [paper]": (1e-4, always(300.0, 900)),
        "random [paper]": (1e-4, lambda s, seed: (30.0 + seed, 900)),
    }
    rec = decide(*tables(labels), noun="formulation")
    v = rec["verdict"]
    assert v.baselines == ["random [identifiable]", "random [paper]"]
    assert "random [identifiable]" not in v.candidates and rec["choice"] == "lsq-trf [identifiable]"
    assert v.avoid == ["ga [paper]"]  # significantly worse than random [paper], its own formulation's
    assert "Avoid **ga [paper]** (" in rec["text"] and "random [paper]'s final losses" in rec["text"]
    assert "Random search is the baseline, never a candidate: random [identifiable] ends" in rec["text"]


def test_final_losses_within_tolerance_share_a_rank_and_success_decides_the_order():
    # a and b end 1e-8 apart (a lower); b reaches the target on every run, a misses one
    labels = {
        "a": (1e-4, lambda s, seed: (1.0 if (s, seed) != ("s1", 0) else 2.0, 300)),
        "b": (1e-4, always(1.0 + 1e-8, 300)),
        "c": (1e-4, always(3.0, 300)),
    }
    table, fr = statistics.ranking_table(*tables(labels))
    ranks = table.set_index("optimizer")["mean_rank"]
    assert ranks["a"] == ranks["b"] == 1.5 and ranks["c"] == 3.0
    assert decide(*tables(labels))["order"][:2] == ["b", "a"]  # not ordered by round-off: by success


def test_the_power_statement_names_the_test_actually_run():
    one = decide(*tables({"a": (1e-4, always()), "b": (1e-4, always(1.3))}, specimens=("s1",), seeds=5))
    assert "Power: every comparison uses the unpaired Mann–Whitney U test" in one["text"]
    assert "1 specimen × up to 5 seeds" in one["text"] and "smallest p it can give is 0.0079" in one["text"]
    blocks = decide(*tables({"a": (1e-4, always()), "b": (1e-4, always(1.3))}))
    assert "Power: every comparison uses van Elteren's stratified Wilcoxon–Mann–Whitney test" in blocks["text"]
    assert any(
        "van Elteren" in item
        for item in rule(statistics.compare_backends(tables({"a": (1e-4, always())})[0]).test_name)
    )


def test_a_held_out_study_with_a_clear_answer_gets_it():
    """lsq-trf reaches the best fit within a few hundred evaluations on every seed; cmaes misses it on
    some seeds; random search is the baseline; the paper formulation is far worse for every backend."""

    def cmaes(s, seed):
        return (1.0, 1500) if seed % 3 else (1.8, 4000)

    labels = {
        "lsq-trf [identifiable]": (2e-3, always(1.0, 300)),
        "cmaes [identifiable]": (1e-3, cmaes),
        "random [identifiable]": (5e-4, always(1.4, 900)),
        "lsq-trf [paper]": (1e-3, always(50.0, 600)),
        "cmaes [paper]": (1e-3, always(60.0, 900)),
        "random [paper]": (5e-4, always(5000.0, 900)),
    }
    runs, traces = tables(labels, seeds=6)
    rec = decide(runs, traces, noun="formulation")
    v = rec["verdict"]
    assert rec["choice"] == "lsq-trf [identifiable]" == v.order[0]
    assert v.less_reliable == ["cmaes [identifiable]"] and not v.equal
    randoms = {"random [identifiable]", "random [paper]"}
    assert set(v.baselines) == randoms
    for group in (v.candidates, v.equal, v.less_reliable, v.behind, v.avoid):
        assert not randoms & set(group)
    text = rec["text"]
    assert text.startswith(
        "In the identifiable formulation, 3 of 3 backends end at lower final losses than in the paper formulation"
    )
    assert "**Use lsq-trf in the identifiable formulation** (lsq-trf [identifiable])" in text
    assert text.index("In the identifiable formulation") < text.index("**Use lsq-trf")  # the formulation first
    assert "Random search is the baseline, never a candidate" in text
    before = text[: text.index("Random search is the baseline")]
    assert "**random" not in before  # never recommended, never "as good", "less reliable" or "behind" …
    for sentence in before.split(". "):
        if "random [" in sentence:  # … only the yardstick of "avoid"
            assert sentence.startswith("Avoid") and "× random [identifiable]'s final losses" in sentence


def test_the_rule_is_stated_with_its_thresholds():
    text = " ".join(rule("TEST", "formulation"))
    assert f"at most {PRACTICAL:.0%} higher" in text and f"{SUCCESS_MARGIN * 100:.0f} percentage points" in text
    assert "ERT × measured seconds per evaluation" in text and "Random search" in text
    assert "Formulations first" in text and "TEST on log10 final losses" in text


def test_the_formulation_is_told_from_the_side_most_backends_favour_even_when_the_pair_sits_in_the_other():
    """lsq-trf is as good in both formulations and faster in the paper's, so the pair is lsq-trf [paper];
    every other backend ends lower in the identifiable formulation, and the text says it that way round."""
    labels = {
        "lsq-trf [identifiable]": (2e-3, always(1.0, 600)),
        "lsq-trf [paper]": (1e-3, always(1.0, 300)),
        "cmaes [identifiable]": (1e-3, always(1.0, 1500)),
        "cmaes [paper]": (1e-3, always(60.0, 900)),
        "random [identifiable]": (5e-4, always(1.4, 900)),
        "random [paper]": (5e-4, always(5000.0, 900)),
    }
    rec = decide(*tables(labels, seeds=6), noun="formulation")
    assert rec["choice"] == "lsq-trf [paper]"
    text = rec["text"]
    assert text.startswith(
        "In the identifiable formulation, 2 of 3 backends end at lower final losses than in "
        "the paper formulation (paper over identifiable: Hodges–Lehmann ratio "
    )
    assert "**Use lsq-trf in the paper formulation**" in text


def test_avoid_compares_a_backend_only_with_random_search_on_its_own_model():
    # Two models: on the easy one random search ends at the best known; on the hard one cmaes ends at
    # 3x and random at 20x. cmaes [hard] beats random [hard]: it must not be called worse than random
    # search because random [easy] ends lower on another model.
    runs, traces = tables(
        {
            "lsq [easy]": (1e-4, always(1.0, 100)),
            "random [easy]": (1e-4, always(1.0, 900)),
            "cmaes [hard]": (1e-4, lambda s, seed: (3.0 + 0.1 * seed, 900)),
            "random [hard]": (1e-4, lambda s, seed: (20.0 + seed, 900)),
        }
    )
    rec = decide(runs, traces, noun="model")
    v = rec["verdict"]
    assert "cmaes [hard]" not in v.avoid
    pairs = dict(zip(v.vs_baseline["a"], v.vs_baseline["b"]))
    assert pairs == {"lsq [easy]": "random [easy]", "cmaes [hard]": "random [hard]"}
    assert float(v.vs_baseline.set_index("a").loc["cmaes [hard]", "ratio"]) < 1  # better than its own baseline
    assert "worse than random search" not in rec["text"].split("Random search is the baseline")[0]


def test_a_backend_worse_than_random_search_on_its_own_model_is_avoided():
    runs, traces = tables(
        {
            "lsq [m]": (1e-4, always(1.0, 100)),
            "cmaes [m]": (1e-4, lambda s, seed: (9.0 + seed, 900)),
            "random [m]": (1e-4, lambda s, seed: (1.5 + 0.01 * seed, 900)),
        },
        seeds=6,
    )
    rec = decide(runs, traces, noun="model")
    assert rec["verdict"].avoid == ["cmaes [m]"]
    assert "**cmaes [m]**" in rec["text"] and "random [m]'s final losses" in rec["text"]


def test_the_box_states_a_formulation_effect_with_its_size():
    # every backend ends 0.1 % lower in the identifiable formulation on every run: significant, and
    # practically nothing; the box must say both
    from bwbench.report.recommend import box

    labels = {
        "lsq-trf [paper]": (1e-4, always(1.001, 100)),
        "lsq-trf [identifiable]": (1e-3, always(1.0, 300)),
        "cmaes [paper]": (1e-4, lambda s, seed: (1.001 * (1 + 0.01 * seed), 900)),
        "cmaes [identifiable]": (1e-3, lambda s, seed: (1 + 0.01 * seed, 900)),
        "random [paper]": (1e-4, always(50.05, 900)),
        "random [identifiable]": (1e-4, always(50.0, 900)),
    }
    runs, traces = tables(labels, seeds=6)
    rec = decide(runs, traces, noun="formulation")
    table, _ = statistics.ranking_table(runs, traces)
    items = box(rec["verdict"], table.set_index("optimizer"), BUDGET, "formulation")
    effect = next(i for i in items if i.startswith("**Formulation**"))
    assert "3 of 3 backends end at lower final losses" in effect
    assert "a median 0.1% lower" in effect and "practically equal (within the rule's 10%)" in effect
