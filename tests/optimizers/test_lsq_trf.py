"""lsq-trf: the contract, the batched Jacobian, blow-ups, and a real fit at the noise floor."""

from pathlib import Path

import numpy as np
import pytest

from bwbench import testing
from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting, registry
from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted
from bwbench.models.switched.parameters import truth_params
from bwbench.optimizers import lsq_trf
from paper_problems import IdentifiableProblem, SwitchedBoucWenProblem

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN = ROOT / "data" / "specimens" / "pom-mt24u01_0.05MPa_r1.csv"
# lsq-trf at 1,500 evaluations on that specimen's identifiable problem reached MSE/truth 0.9153 with
# seeds 0-5 alike (first within 5 % after 58, 932, 501, 361, 49, 25 evaluations); seed 5 is the
# quickest. The identifiable fit goes below the truth's MSE: it also fits m and two offsets.
SEED, RATIO = 5, 0.99243


def test_registered_as_a_batched_least_squares_backend():
    backend = registry.get("lsq-trf")
    assert backend.family == "least-squares" and backend.batched
    assert backend.defaults["x_scale"] == "jac" and backend.defaults["max_nfev_per_start"] is None


def test_keeps_the_contract():
    testing.check_backend("lsq-trf")


@pytest.mark.parametrize("budget", [2, 15, 16, 17, 333])
def test_exact_budget_at_budgets_that_cut_a_jacobian(budget):
    # one start costs 1 evaluation, each Jacobian 14: these budgets end inside or at a Jacobian
    problem = testing.counting_problem()
    result = fitting.run(problem, "lsq-trf", budget, seed=3)
    assert result.nfev == problem.evaluated == budget and result.message == "budget exhausted"


def test_same_seed_same_run_with_non_default_options():
    options = {"x_scale": "unit", "diff_step": 1e-4, "stall_iters": 0, "max_nfev_per_start": 5}
    testing.check_same_seed("lsq-trf", options=options)
    testing.check_exact_budget("lsq-trf", budgets=(57, 600), options=options)


def test_a_jacobian_is_one_batch_of_d_points_after_one_point():
    problem = testing.SphereProblem()  # no blow-ups: no retried columns
    fitting.run(problem, "lsq-trf", 200, seed=1)
    # start, Jacobian, then (step, Jacobian)*; the last call is cut at the budget
    assert problem.call_sizes[:2] == [1, 14] and sum(problem.call_sizes) == 200
    assert set(problem.call_sizes[:-1]) == {1, 14} and problem.call_sizes.count(14) >= 5


def test_jacobian_is_exact_on_the_sphere_and_steps_inward_at_the_upper_bound():
    problem = testing.SphereProblem(dim=3, centre=0.5, n_data=4)
    residuals = lsq_trf.Residuals(Objective(problem, 100), diff_step=1e-5)
    for u in (np.array([0.2, 0.5, 0.7]), np.array([0.2, 1.0, 1.0 - 1e-7])):
        J = residuals.jac(u)
        expected = np.vstack([2.0 * np.eye(3), np.zeros((1, 3))])  # √n_data = 2
        np.testing.assert_allclose(J, expected, atol=1e-6)
    assert problem.call_sizes == [1, 3, 1, 3]  # each point (not remembered here), then its d neighbours


def test_a_blown_up_neighbour_is_differenced_from_the_other_side():
    problem = testing.SphereProblem(dim=3, centre=0.5, n_data=4, blow_up=lambda P: P[:, 0] > 0.3)
    objective = Objective(problem, 100)
    residuals = lsq_trf.Residuals(objective, diff_step=1e-3)
    J = residuals.jac(np.array([0.3, 0.5, 0.5]))  # u₀ + h blows up, u₀ − h does not
    np.testing.assert_allclose(J[:3], 2.0 * np.eye(3), atol=1e-9)
    assert problem.call_sizes == [1, 3, 1]  # the point, the Jacobian batch, the retried column
    # both sides blown up: a zero column, and the trial point itself gets the finite penalty
    squeezed = testing.SphereProblem(dim=2, centre=0.5, n_data=2, blow_up=lambda P: np.abs(P[:, 0] - 0.5) > 1e-4)
    residuals = lsq_trf.Residuals(Objective(squeezed, 100), diff_step=1e-3)
    J = residuals.jac(np.array([0.5, 0.2]))
    np.testing.assert_array_equal(J[:, 0], 0.0)
    penalised = residuals.fun(np.array([0.9, 0.2]))
    worst = np.mean(residuals.fun(np.array([0.5, 0.2])) ** 2)  # the worst finite mean square seen
    np.testing.assert_allclose(penalised, np.sqrt(10 * worst))


def test_blown_up_starts_are_redrawn_and_a_hostile_box_is_survived():
    # +inf on 99 % of the box: most starts and most trial steps blow up
    problem = testing.SphereProblem(dim=4, centre=0.05, blow_up=lambda P: (P[:, 0] > 0.1) | (P[:, 1] > 0.1))
    result = fitting.run(problem, "lsq-trf", 800, seed=4)
    assert result.nfev == 800 and problem.blew_up > 100
    assert result.mse < 1e-8  # it still finds the centre


def test_a_problem_with_only_a_loss_falls_back_to_the_square_root_of_the_loss():
    problem = testing.LossOnlySphereProblem(blow_up=lambda P: P[:, 0] > 0.9)
    result = fitting.run(problem, "lsq-trf", 600, seed=3)
    assert result.nfev == problem.evaluated == 600
    assert result.mse < 1e-6


def test_budget_exhausted_propagates_out_of_least_squares():
    objective = Objective(testing.counting_problem(), 40)
    with pytest.raises(BudgetExhausted):
        lsq_trf.minimize(objective, rng=np.random.default_rng(0), **registry.get("lsq-trf").defaults)
    assert objective.nfev == 40


def test_bad_options_are_refused():
    from bwbench.engine import registry

    for bad in ({"x_scale": "auto"}, {"diff_step": 0.0}, {"stall_iters": -1}):
        with pytest.raises(ValueError):
            registry.resolve_options("lsq-trf", bad)


def test_reaches_the_noise_floor_on_the_identifiable_problem():
    """The truth MSE (noise floor) is 1.011 N² here (1 N force noise); lsq-trf gets within 5 % of it
    (0.8 % below: what the ~16 fitted numbers absorb of 1,921 noisy samples, p/n)."""
    specimen = read_specimen(SPECIMEN)
    floor = SwitchedBoucWenProblem(specimen).loss_batch(truth_params(SPECIMEN)[None, :])[0]
    assert floor == pytest.approx(1.0107, abs=1e-3)  # N²: the generating parameters' MSE
    result = fitting.run(IdentifiableProblem(specimen), "lsq-trf", 1500, seed=SEED)
    assert result.nfev == 1500
    assert result.mse <= 1.05 * floor
    assert result.mse / floor == pytest.approx(RATIO, abs=2e-3)


def test_stops_early_once_the_local_searches_agree_on_one_optimum_and_says_so():
    problem = testing.SphereProblem(dim=4)
    early = fitting.run(problem, "lsq-trf", 5000, 2, {"stop_agree": 3})
    # One optimum, found by every search: it stops after the ninth (lsq_agreement.MIN_SEARCHES).
    assert early.nfev < 2000 and early.extras["stop_reason"] == "restarts agree"
    assert early.extras["local_searches"] == 9 and "9 of 9 independent local searches" in early.message
    exact = fitting.run(testing.SphereProblem(dim=4), "lsq-trf", 5000, 2)  # a study's rule: the whole budget
    assert exact.nfev == 5000 and exact.message == "budget exhausted"
    assert early.mse <= 1e-12 and exact.mse <= 1e-12
    # The budget still caps: a budget that ends before the last search ends stops there.
    capped = fitting.run(testing.SphereProblem(dim=4), "lsq-trf", early.nfev - 1, 2, {"stop_agree": 3})
    assert capped.nfev == early.nfev - 1 and capped.message == "budget exhausted"


def test_a_search_that_reaches_an_earlier_searchs_optimum_stops_there_at_the_same_result():
    """Spencer's model on an MR-damper generator test: with ``stop_on_arrival`` (the default with
    ``stop_agree``) the searches after the first that find the optimum stop on reaching it; the fit
    ends at the same optimum (MSE within the agreement's 1 %) on fewer evaluations (373 against 447 with the exploring searches; 372 against 474 without),
    and says so. (Not on every file: where the optimum is a flat valley a search that stopped on arrival
    may lie too far from a later, slightly better end to agree with it, and more searches run.)"""
    from bwbench.problems.hysteresis.formulations import make_problem

    mr = Path(__file__).resolve().parents[2] / "data" / "mr_damper" / "mr_10mm_2Hz_1V.csv"
    problem = make_problem(read_specimen(mr), {"model": "spencer", "formulation": "identifiable"})
    arriving = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3})
    full = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3, "stop_on_arrival": False})
    assert arriving.extras["stop_reason"] == full.extras["stop_reason"] == "restarts agree"
    assert arriving.extras["arrivals"] >= 2 and full.extras["arrivals"] == 0
    assert "stopped on reaching an optimum an earlier one ended at" in arriving.message
    assert arriving.mse <= 1.01 * full.mse
    assert arriving.nfev < 0.9 * full.nfev


def test_searches_agree_only_on_one_optimum_found_often_enough():
    """Starts where the hysteresis does nothing end at the same MSE (that of a linear fit) at different
    points: not an optimum to stop at. Ends within 2 % of the box and 1 % of the MSE are one optimum;
    stopping also needs nine searches (a basin attracting 30 % of starts missed with probability < 5 %)."""
    rng = np.random.default_rng(0)
    plateau = [(7474.16, rng.random(6)) for _ in range(9)]
    assert lsq_trf.agreed_searches(plateau, 3, 1e-2) == 0
    centre = rng.random(6)
    same = [(34.51 + 0.01 * i, centre + 0.002 * i) for i in range(3)]
    assert lsq_trf.agreed_searches(same, 3, 1e-2) == 0  # 3 of 3: too few searches to say
    assert lsq_trf.agreed_searches(same + plateau[:5], 3, 1e-2) == 0  # 8 searches
    assert lsq_trf.agreed_searches(same + plateau[:6], 3, 1e-2) == 3  # 9: stop
    assert lsq_trf.agreed_searches(same[:2] + plateau, 3, 1e-2) == 0  # the best found twice only
    assert lsq_trf.agreed_searches(same + plateau, 0, 1e-2) == 0  # 0: never stop early
    worse = [(34.51 * 1.02, centre)] * 2 + [(34.51, centre)] + plateau  # MSE 2 % apart: not one optimum
    assert lsq_trf.agreed_searches(worse, 3, 1e-2) == 0


class _FlatValleyProblem(testing.SphereProblem):
    """A decay exp(−3(θ₀ + θ₁ + θ₂)t) plus a slope θ₃t, 60 noisy samples: the data determine θ₀ + θ₁ + θ₂
    only, so every local search ends somewhere else on one plane of equally good fits."""

    def __init__(self):
        super().__init__(dim=4, n_data=60)
        self.t = np.linspace(0.0, 1.0, self.n_data)
        noise = 0.01 * np.random.default_rng(0).standard_normal(self.n_data)
        self.data = self.model(np.array([[0.1, 0.2, 0.3, 0.5]]))[0] + noise

    def model(self, P):
        return np.exp(-3.0 * P[:, :3].sum(axis=1, keepdims=True) * self.t) + P[:, 3:] * self.t

    def residual_batch(self, P):
        P = np.atleast_2d(P)
        self.evaluated += len(P)
        self.call_sizes.append(len(P))
        return self.model(P) - self.data

    def loss_batch(self, P):
        return np.mean(self.residual_batch(P) ** 2, axis=1)


def test_searches_that_end_along_a_direction_the_data_do_not_determine_agree_by_their_fitted_curves():
    for seed in (0, 1):
        by_fit = fitting.run(_FlatValleyProblem(), "lsq-trf", 2000, seed, {"stop_agree": 3})
        by_place = fitting.run(_FlatValleyProblem(), "lsq-trf", 2000, seed, {"stop_agree": 3, "agree_same_fit": False})
        # The ends lie up to ~0.5 apart on the plane: by their parameters three of them rarely agree.
        assert by_place.nfev == 2000 and by_place.message == "budget exhausted"
        # By their fitted curves every search ended at the one optimum: the 18th stops the fit
        # (lsq_agreement.VALLEY_SEARCHES; the searches after the first stop on arriving at its fitted curve).
        assert by_fit.extras["stop_reason"] == "restarts agree" and by_fit.extras["local_searches"] == 18
        assert by_fit.extras["arrivals"] == 17 and by_fit.nfev < 500  # 447 and 462 (seeds 0, 1)
        assert by_fit.mse <= 1.0001 * by_place.mse and by_fit.mse == pytest.approx(7.778e-5, rel=1e-3)  # noise 0.01
        assert "fitted curves within 0.05 of the residual RMS" in by_fit.extras["agreement"]
        assert "fitted curves within 0.05" in by_fit.message and by_fit.extras["agreed_by_fit"] >= 1


class _TwoOptimaProblem(testing.SphereProblem):
    """Two optima at θ₀ ≈ 0.25 and ≈ 0.75 whose MSE differ by 0.5 %, with a barrier between them (+34 % at
    the midpoint), and different fits: residual vectors at right angles."""

    def __init__(self):
        super().__init__(dim=2, n_data=3)

    def residual_batch(self, P):
        P = np.atleast_2d(P)
        self.evaluated += len(P)
        self.call_sizes.append(len(P))
        a, b = P[:, 0], P[:, 1]
        size = 1.0 + 40.0 * (a - 0.25) ** 2 * (a - 0.75) ** 2 + 0.005 * a
        return np.column_stack([size * np.cos(np.pi * a), size * np.sin(np.pi * a), 3.0 * (b - 0.4)])

    def loss_batch(self, P):
        return np.mean(self.residual_batch(P) ** 2, axis=1)


def test_two_separate_optima_of_equal_mse_do_not_agree():
    from scipy.optimize import least_squares

    problem = _TwoOptimaProblem()
    ends = []
    for u0 in ([0.2, 0.1], [0.8, 0.9]):
        found = least_squares(lambda u: problem.residual_batch(u)[0], u0, bounds=(0.0, 1.0), xtol=1e-12)
        ends.append((float(np.mean(found.fun**2)), found.x, found.fun))
    best, other = ends
    assert other[0] / best[0] == pytest.approx(1.005, abs=1e-4)  # within agree_rtol's 1 %
    assert problem.loss_batch((best[1] + other[1]) / 2)[0] / best[0] == pytest.approx(1.339, abs=1e-3)  # a barrier
    assert not lsq_trf.same_optimum(other, best, 1.01 * best[0])
    assert lsq_trf.agreed_searches([best] + [other] * 8, 3, 1e-2) == 0  # the other optimum found 8 times: no stop
    assert lsq_trf.agreed_searches([best] * 3 + [other] * 6, 3, 1e-2) == 3
    # The same fitted curve, 0.3 away along a direction the data do not determine, agrees, once 18
    # searches ran (a valley or a plateau of one fit attracts starts broadly: more evidence is asked).
    valley = (best[0] * 1.001, best[1] + 0.3, best[2] * (1 + 1e-3))
    assert lsq_trf.same_optimum(valley, best, 1.01 * best[0]) == "fit"
    assert lsq_trf.agreed_searches([best] * 2 + [valley] + [other] * 6, 3, 1e-2) == 0
    assert lsq_trf.agreed_searches([best] * 2 + [valley] + [other] * 15, 3, 1e-2) == 3
    # Fits stop at the lower optimum, whichever the starts found first.
    for seed in range(3):
        result = fitting.run(_TwoOptimaProblem(), "lsq-trf", 3000, seed, {"stop_agree": 3})
        assert result.extras["stop_reason"] == "restarts agree"
        assert result.mse == pytest.approx(best[0], rel=1e-5)
