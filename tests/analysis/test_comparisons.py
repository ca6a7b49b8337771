"""Two labels compared with specimens as blocks: van Elteren / Mann–Whitney, Hodges–Lehmann, bounds of p."""

import numpy as np
import pandas as pd
import pytest
import scipy.special
import scipy.stats

from bwbench.analysis import comparisons, statistics


def _runs(table):
    """Run rows from {(specimen, label): [final losses]} (inf = a failed run)."""
    rows = []
    for (specimen, label), losses in table.items():
        for r, loss in enumerate(losses):
            rows.append(
                {
                    "kind": "ranking",
                    "specimen": specimen,
                    "optimizer": label,
                    "replicate": r,
                    "status": "ok" if np.isfinite(loss) else "error",
                    "mse": loss,
                }
            )
    return pd.DataFrame(rows)


def test_failed_runs_count_one_decade_above_the_worst_finished_run_of_their_specimen():
    values = comparisons.log_losses(
        _runs({("s", "a"): [1.0, 10.0], ("s", "b"): [100.0, np.inf], ("t", "a"): [np.inf], ("t", "b"): [np.inf]})
    )
    got = dict(zip(zip(values["specimen"], values["optimizer"], values["replicate"]), values["value"]))
    assert got[("s", "a", 0)] == 0.0 and got[("s", "b", 0)] == 2.0
    assert got[("s", "b", 1)] == 3.0  # worst finished on s: 100 → one decade above
    assert got[("t", "a", 0)] == got[("t", "b", 0)] == 1.0  # nothing finished on t: 0 + 1


def test_one_specimen_is_scipys_mann_whitney_and_its_exact_floor():
    a = {"s": np.array([1.0, 2.0, 3.0, 4.0, 5.0])}
    b = {"s": np.array([6.0, 7.0, 8.0, 9.0, 10.0])}
    statistic, p = comparisons.two_sample(a, b)
    expected = scipy.stats.mannwhitneyu(a["s"], b["s"], alternative="two-sided")
    assert (statistic, p) == (expected.statistic, expected.pvalue)
    assert p == pytest.approx(2 / 252) == comparisons.smallest_p(a, b)
    assert "unpaired Mann–Whitney U test" in comparisons.method_name(1)


def test_van_elteren_with_one_block_is_the_normal_mann_whitney_and_with_equal_blocks_adds_them():
    rng = np.random.default_rng(5)
    x, y = rng.normal(0, 1, 6), rng.normal(0.8, 1, 7)
    z, p = comparisons.van_elteren({"s": x}, {"s": y})
    normal = scipy.stats.mannwhitneyu(x, y, alternative="two-sided", method="asymptotic", use_continuity=False)
    assert p == pytest.approx(normal.pvalue, rel=1e-12) and z < 0
    # two identical blocks: the weighted sum doubles, its variance quadruples' half: z grows by √2
    z2, _ = comparisons.van_elteren({"s": x, "t": x}, {"s": y, "t": y})
    assert z2 == pytest.approx(np.sqrt(2) * z)
    assert "van Elteren" in comparisons.method_name(3)


def test_van_elteren_floor_is_every_run_of_a_below_every_run_of_b_in_every_block():
    a = {s: np.array([0.0, 1.0, 2.0, 3.0]) for s in "pqr"}
    b = {s: np.array([10.0, 11.0, 12.0, 13.0]) for s in "pqr"}
    assert comparisons.smallest_p(a, b) == pytest.approx(comparisons.two_sample(a, b)[1])
    # by hand: per block W − E = 10 − 18 = −8, weight 1/9, variance 4·4·9/12 = 12 → z = −(3·8/9)/√(3·12/81) = −4
    assert comparisons.two_sample(a, b)[0] == pytest.approx(-4.0)
    assert comparisons.smallest_p(a, b) == pytest.approx(2 * scipy.stats.norm.sf(4.0))


def test_identical_values_give_p_one_and_ties_are_corrected():
    a = {"s": np.array([1.0, 1.0]), "t": np.array([2.0, 3.0])}
    assert comparisons.two_sample({"s": a["s"]}, {"s": a["s"]}) == (0.0, 1.0)
    z, p = comparisons.van_elteren(a, {"s": np.array([1.0, 1.0]), "t": np.array([2.0, 5.0])})
    assert np.isfinite(p) and 0 < p <= 1  # the all-tied block carries nothing, the other decides


def test_hodges_lehmann_is_the_median_of_within_block_differences_only():
    a = {"s": np.array([1.0, 2.0, 3.0]), "t": np.array([100.0])}
    b = {"s": np.array([0.0]), "t": np.array([100.0, 101.0])}
    # within s: 1, 2, 3; within t: 0, −1 (never s against t): median of {−1, 0, 1, 2, 3} = 1
    assert comparisons.hodges_lehmann(a, b) == 1.0


def test_the_bootstrap_interval_is_fixed_by_the_names_and_covers_the_estimate():
    rng = np.random.default_rng(9)
    values = _runs(
        {
            (s, label): list(10 ** rng.normal(shift, 0.1, 4))
            for s in ("p", "q", "r")
            for label, shift in (("a", 0.0), ("b", 0.3))
        }
    )
    values = comparisons.log_losses(values)
    first = comparisons.compare(values, "a", "b")
    again = comparisons.compare(values.sample(frac=1.0, random_state=3), "a", "b")
    assert first == pytest.approx(again)  # same data, any row order: the same answer
    assert first["shift_low"] <= first["shift"] <= first["shift_high"] < 0
    assert first["ratio"] == pytest.approx(10 ** first["shift"]) and first["specimens"] == 3
    assert first["runs_a"] == first["runs_b"] == 12


def test_holm_runs_over_the_family_given_and_its_floor_is_size_times_smallest_p():
    values = comparisons.log_losses(
        _runs({("s", n): [float(k + 1)] * 2 + [float(k + 2)] * 2 for k, n in enumerate("abcd")})
    )
    family = comparisons.family(values, [("b", "a"), ("c", "a"), ("d", "a")], "against a", 0.05)
    assert list(family["family"]) == ["against a"] * 3
    assert family["p_holm"].to_numpy() == pytest.approx(comparisons.holm(family["p"]))
    assert comparisons.holm_floor(family) == pytest.approx(3 * 2 / scipy.special.comb(8, 4))  # 4 runs against 4


def test_ranks_tie_within_one_percent_not_by_round_off():
    logs = np.log10([1.0, 1.0 + 1e-8, 1.005, 1.3, 1.3])
    assert statistics.tied_ranks(logs).tolist() == [2.0, 2.0, 2.0, 4.5, 4.5]
    assert statistics.tied_ranks(np.log10([1.0, 1.02])).tolist() == [1.0, 2.0]
    table = pd.DataFrame(
        {"a": np.log10([1.0, 2.0]), "b": np.log10([1.0 + 7.6e-9, 2.0 * (1 + 1.9e-6)]), "c": np.log10([5.0, 9.0])},
        index=["s", "t"],
    )
    fr = statistics.friedman(table)
    assert fr.mean_ranks["a"] == fr.mean_ranks["b"] == 1.5 and fr.mean_ranks["c"] == 3.0
