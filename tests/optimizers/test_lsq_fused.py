"""lsq-trf's fused evaluations (a fit with its early stop): every point trf asks for is simulated with
its sensitivities, and the Jacobian trf then asks for at an accepted point is the one already there."""

from pathlib import Path

import numpy as np

from bwbench import testing
from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting
from bwbench.engine.objective import Objective
from bwbench.optimizers import lsq_trf
from bwbench.problems.hysteresis.formulations import make_problem

MR = Path(__file__).resolve().parents[2] / "data" / "mr_damper" / "mr_10mm_2Hz_1V.csv"


def _counting(monkeypatch):
    """Calls of Objective.residuals (plain simulations) and .residual_jacobian (with sensitivities)."""
    calls = {"residuals": 0, "residual_jacobian": 0}
    for name in calls:
        original = getattr(Objective, name)

        def counted(self, *args, _original=original, _name=name, **kwargs):
            calls[_name] += 1
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(Objective, name, counted)
    return calls


def test_a_fit_simulates_each_point_once_with_its_sensitivities_to_the_same_optimum(monkeypatch):
    problem = make_problem(read_specimen(MR), {"model": "spencer", "formulation": "identifiable"})
    calls = _counting(monkeypatch)
    fused = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3})
    fused_calls = dict(calls)
    calls.update(residuals=0, residual_jacobian=0)
    separate = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3, "fused": False})
    assert fused.extras["stop_reason"] == separate.extras["stop_reason"] == "restarts agree"
    assert fused.mse <= 1.0001 * separate.mse  # measured: the same MSE, 37.8007 N²
    # Without it: a plain simulation at every point (151) and sensitivities again at each accepted one
    # (110). With it: sensitivities at each point (151), a plain one only where they could not be had.
    assert calls["residuals"] > calls["residual_jacobian"] > 0.5 * calls["residuals"]
    assert fused_calls["residual_jacobian"] > 20 * fused_calls["residuals"]
    assert fused.nfev < separate.nfev  # 307 against 371: a point costs 2, not 1 + 2 where it is accepted


def test_a_study_keeps_the_plain_residual_and_the_separate_jacobian(monkeypatch):
    problem = make_problem(read_specimen(MR), {"model": "spencer", "formulation": "identifiable"})
    calls = _counting(monkeypatch)
    study = fitting.run(problem, "lsq-trf", 300, 1)  # no stop_agree: the whole budget, as a study
    assert study.nfev == 300
    assert calls["residuals"] > calls["residual_jacobian"] > 0


def test_fused_needs_exact_jacobians():
    sphere = Objective(testing.SphereProblem(dim=3), 100)  # residuals, no exact Jacobian
    residuals = lsq_trf.Residuals(sphere, diff_step=1e-5, exact=True, fused=True)
    assert not residuals.fused
    u = np.full(3, 0.3)
    r = residuals.start(u)
    assert r is not None and np.array_equal(residuals.fun(u), r) and sphere.nfev == 1
    assert residuals.jac(u).shape == (len(r), 3) and sphere.nfev == 4  # differences: 3 more points


def test_a_simulation_that_does_not_finish_is_not_run_again_without_its_sensitivities(monkeypatch):
    problem = make_problem(read_specimen(MR), {"model": "spencer", "formulation": "identifiable"})
    # x_y at the box's floor, η far below −1: the relative velocity hovers about 0 and the branch flips
    # with the velocity's noise: over the step budget (a stiff corner of the box).
    stiff = problem.to_unit(np.array([problem.lower[0], 2.0, problem.lower[2], 20.0, 0.09, 0.2]))
    objective = Objective(problem, 100)
    r, J = objective.residual_jacobian(stiff)
    assert J is None and np.all(np.isinf(r)) and objective.nfev == problem.jacobian_cost  # charged, as tried
    assert not np.isfinite(problem.loss_batch(problem.from_unit(stiff)[None, :])[0])  # nor the plain one
    calls = _counting(monkeypatch)
    residuals = lsq_trf.Residuals(Objective(problem, 100), diff_step=1e-5, exact=True, fused=True)
    residuals.penalty(50.0)
    assert np.allclose(residuals.fun(stiff), np.sqrt(residuals.penalty.value))  # above every finite cost
    assert calls == {"residuals": 0, "residual_jacobian": 1}
    assert residuals.start(stiff) is None  # a start there is redrawn


def test_the_polish_starts_from_the_best_distinct_ends():
    best = (10.0, np.full(3, 0.5), None)
    near = (10.05, np.full(3, 0.51), None)  # the same place: one optimum
    other = (10.1, np.array([0.2, 0.5, 0.5]), None)  # another optimum within 2 × the agreement's MSE tolerance
    far = (10.3, np.array([0.9, 0.1, 0.5]), None)  # 3 % worse: not a candidate
    starts = lsq_trf._distinct_ends([far, other, near, (np.inf, None, None), best], 0.01)
    assert [list(u) for u in starts] == [list(best[1]), list(other[1])]
    assert len(lsq_trf._distinct_ends([(10.0 + i * 1e-3, np.full(3, 0.1 * i), None) for i in range(6)], 0.01)) == 3
