"""The paper's GA (Section 3.2): population 100, 100 evaluations per generation, 4,100 in all,
one-gene mutation and one-gene swap crossover at the stated probabilities, binary tournament."""

from __future__ import annotations

import numpy as np
import pytest

from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted
from bwbench.optimizers import paper_ga, random_search
from bwbench.optimizers.paper_ga import crossover, mutate, survivors, tournament
from fakes import SphereProblem

DIM = 14


def _pop(n=100, seed=0):
    return np.random.default_rng(seed).random((n, DIM))


def test_default_run_is_100_then_100_per_generation_4100_in_all():
    problem = SphereProblem()
    objective = Objective(problem, budget=10_000)
    out = paper_ga.minimize(objective, rng=np.random.default_rng(1))
    assert problem.call_sizes == [100] * 41
    assert objective.nfev == 4_100
    assert out["message"] == "40 generations done"


def test_budget_smaller_than_the_run_is_spent_exactly_and_propagates():
    objective = Objective(SphereProblem(), budget=250)
    with pytest.raises(BudgetExhausted):
        paper_ga.minimize(objective, rng=np.random.default_rng(1))
    assert objective.nfev == 250


def test_mutation_p1_changes_exactly_one_parameter_of_every_individual_within_range():
    pop = _pop()
    before = pop.copy()
    out = mutate(np.random.default_rng(2), pop, 1.0)
    np.testing.assert_array_equal(pop, before)  # a new array; the input is untouched
    changed = out != pop
    assert (changed.sum(axis=1) == 1).all()
    assert ((out[changed] >= 0.0) & (out[changed] <= 1.0)).all()


def test_mutation_p0_changes_nothing():
    pop = _pop()
    np.testing.assert_array_equal(mutate(np.random.default_rng(2), pop, 0.0), pop)


def test_mutation_and_crossover_p_half_hit_about_half():
    pop = _pop(n=10_000)
    mutated = (mutate(np.random.default_rng(3), pop, 0.5) != pop).any(axis=1).mean()
    crossed = (crossover(np.random.default_rng(3), pop, 0.5) != pop).any(axis=1).mean()
    assert 0.47 < mutated < 0.53
    assert 0.47 < crossed < 0.53


def test_crossover_p1_swaps_exactly_one_parameter_within_each_consecutive_pair():
    pop = _pop()
    before = pop.copy()
    out = crossover(np.random.default_rng(4), pop, 1.0)
    np.testing.assert_array_equal(pop, before)
    # No value is created or lost: every column keeps its multiset of values.
    np.testing.assert_array_equal(np.sort(out, axis=0), np.sort(pop, axis=0))
    for a in range(0, 100, 2):
        b = a + 1
        (cols_a,) = np.nonzero(out[a] != pop[a])
        (cols_b,) = np.nonzero(out[b] != pop[b])
        assert len(cols_a) == 1 and list(cols_b) == list(cols_a)
        c = cols_a[0]
        assert out[a, c] == pop[b, c] and out[b, c] == pop[a, c]


def test_crossover_of_equal_values_changes_nothing_and_odd_last_row_is_left_alone():
    pop = np.tile(_pop(n=1), (5, 1))  # identical rows: every swap is a no-op
    pop[4] = 0.5
    out = crossover(np.random.default_rng(5), pop, 1.0)
    np.testing.assert_array_equal(out, pop)


def test_crossover_p0_changes_nothing():
    pop = _pop()
    np.testing.assert_array_equal(crossover(np.random.default_rng(4), pop, 0.0), pop)


def test_tournament_keeps_the_better_of_each_pair():
    # Two individuals: every tournament is between them, so the better wins every time.
    pop2 = _pop(n=2)
    won = tournament(np.random.default_rng(6), pop2, np.array([5.0, 1.0]))
    np.testing.assert_array_equal(won, pop2[[1, 1]])
    # 100 individuals, loss = row index: the worst can never win (contestants are distinct),
    # every winner is a copy of a row, and selection lowers the mean loss.
    pop = _pop()
    loss = np.arange(100.0)
    won = tournament(np.random.default_rng(7), pop, loss)
    assert won.shape == pop.shape
    rows = [int(np.flatnonzero((pop == w).all(axis=1))[0]) for w in won]
    assert 99 not in rows
    assert np.mean(rows) < np.mean(loss) - 10  # expected mean of the winners: ≈ 33


def test_tournament_prefers_finite_over_blown_up():
    pop = _pop(n=2)
    won = tournament(np.random.default_rng(8), pop, np.array([np.inf, 3.0]))
    np.testing.assert_array_equal(won, pop[[1, 1]])


def test_survivors_keep_the_best_of_parents_and_offspring():
    pop, kids = _pop(n=4, seed=1), _pop(n=4, seed=2)
    new, new_loss = survivors(pop, np.array([4.0, 1.0, 6.0, 8.0]), kids, np.array([2.0, np.inf, 1.0, 7.0]))
    np.testing.assert_array_equal(new_loss, [1.0, 1.0, 2.0, 4.0])
    np.testing.assert_array_equal(new, np.vstack([pop[1], kids[2], kids[0], pop[0]]))  # ties: parents first


def _best(minimize, seed, budget=4_100):
    objective = Objective(SphereProblem(), budget=budget)
    try:
        minimize(objective, rng=np.random.default_rng(seed))
    except BudgetExhausted:
        pass
    return objective.best_mse


def test_ga_beats_random_search_on_a_sphere_at_equal_budget():
    for seed in (0, 1, 2):
        ga, rs = _best(paper_ga.minimize, seed), _best(random_search.minimize, seed)
        assert ga < 0.25 * rs, (seed, ga, rs)


def test_same_seed_same_run():
    assert _best(paper_ga.minimize, 11) == _best(paper_ga.minimize, 11)
