"""lsq-trf with the fit's early stop explores on a cheaper simulation (Spencer's model at a looser
integration tolerance) and polishes the best end on the model's own; studies never explore."""

from pathlib import Path

import numpy as np
import pytest

from bwbench import testing
from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting
from bwbench.engine.objective import Objective
from bwbench.models.spencer.model import EXPLORATION_PACE, EXPLORATION_TOLERANCE, MODEL
from bwbench.problems.hysteresis.formulations import make_problem

MR = Path(__file__).resolve().parents[2] / "data" / "mr_damper" / "mr_10mm_2Hz_1V.csv"


def _problem():
    return make_problem(read_specimen(MR), {"model": "spencer", "formulation": "identifiable"})


def test_the_searches_explore_on_a_cheaper_simulation_and_the_fit_is_the_models_own():
    problem = _problem()
    explored = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3})
    plain = fitting.run(problem, "lsq-trf", 4100, 1, {"stop_agree": 3, "explore": False})
    assert explored.extras["stop_reason"] == plain.extras["stop_reason"] == "restarts agree"
    spent = explored.extras["exploration"]
    assert explored.nfev == spent["evaluations"] + spent["polish"] and 1 <= spent["polish"] <= 60
    assert "exploration" not in plain.extras
    assert f"tolerance {EXPLORATION_TOLERANCE:g} per step" in explored.message
    assert f"polished on the model's own in {spent['polish']} evaluations" in explored.message
    # What is reported is the model's own loss at the reported parameters, not the cheaper simulation's.
    theta = np.array([[explored.params[name] for name in problem.param_names]])
    assert problem.loss_batch(theta)[0] == pytest.approx(explored.mse, rel=1e-12)
    # The same optimum as searching on the model's own simulation throughout.
    assert explored.mse == pytest.approx(plain.mse, rel=2e-3)


def test_the_budget_still_caps_an_exploring_fit_and_the_polish_keeps_its_share():
    capped = fitting.run(_problem(), "lsq-trf", 150, 1, {"stop_agree": 3})
    assert capped.nfev == 150 and np.isfinite(capped.mse)  # no agreement: the whole budget is spent
    assert capped.extras["stop_reason"] == "budget exhausted"
    assert capped.message.startswith("budget exhausted; the local searches ran on a cheaper simulation")
    spent = capped.extras["exploration"]
    assert spent["evaluations"] == 150 - 40 and spent["polish"] >= 1  # 40 kept back for the polish
    assert (
        f"in {spent['polish']} evaluations, and the {40 - spent['polish']} left in more local searches"
        in capped.message
    )


def test_a_study_spends_its_whole_budget_on_the_models_own_simulation():
    result = fitting.run(_problem(), "lsq-trf", 120, 1)  # no stop_agree: a study's run
    assert result.nfev == 120 and result.message == "budget exhausted" and "exploration" not in result.extras


def test_the_exploring_model_is_a_looser_copy_and_the_model_is_untouched():
    problem = _problem()
    cheaper = problem.exploration()
    assert cheaper.model.tolerance == EXPLORATION_TOLERANCE and MODEL.tolerance is None and problem.model is MODEL
    assert cheaper.model.pace == EXPLORATION_PACE == 10 and MODEL.pace is None  # every sample kept: 10 steps each
    theta = np.array([[0.02, 2.0, 0.3, 20.0, 0.09, 0.2]])  # near Spencer's damper (x_y mm, n, η, v_y mm/s, r₀, κ₀ 1/s)
    fine, coarse = problem.model.trajectories(theta, problem.signal), cheaper.model.trajectories(theta, problem.signal)
    gap = np.max(np.abs(fine - coarse)) / np.ptp(fine)
    assert 0.0 < gap < 1e-3  # ẏ moves by less than 0.1 % of its range
    assert cheaper.loss_batch(theta)[0] == pytest.approx(problem.loss_batch(theta)[0], rel=1e-2)


def test_an_objective_without_a_cheaper_problem_has_no_exploration_and_charges_count():
    objective = Objective(testing.SphereProblem(dim=3), 50)
    assert objective.exploration(10) is None
    explorer = Objective(_problem(), 30).exploration(10)
    assert explorer is not None and explorer.budget == 20
    parent = Objective(_problem(), 30)
    child = parent.exploration(10)
    child.batch(np.full((4, 6), 0.5))
    parent.charge(child)
    assert parent.nfev == 4 and parent.best_u is None  # counted here, its losses not recorded here


def test_samples_per_cycle_counts_each_reversal_once_through_the_velocitys_noise():
    from bwbench.problems.hysteresis.exploration import samples_per_cycle

    t = np.arange(3000) / 1000.0  # three cycles of a 1 Hz sine at 1 kHz
    v = np.cos(2 * np.pi * t) + np.random.default_rng(4).normal(0.0, 0.02, t.size)
    assert samples_per_cycle(v) == pytest.approx(1000.0, rel=0.01)


def test_an_oversampled_record_is_explored_on_every_kth_sample_and_fitted_on_all():
    from bwbench.problems.hysteresis.exploration import decimation

    slow = make_problem(
        read_specimen(MR.parent / "mr_25mm_0.5Hz_1V.csv"), {"model": "spencer", "formulation": "identifiable"}
    )
    assert decimation(slow) == 2  # 1,000 samples per cycle: 500 kept
    cheaper = slow.exploration()
    assert cheaper.n_data == 1501 and slow.n_data == 3001 and len(cheaper.signal.x) == 1501
    assert np.array_equal(cheaper.lower, slow.lower) and np.array_equal(cheaper.upper, slow.upper)  # one box
    assert decimation(_problem()) == 1  # 250 samples per cycle: every sample
    result = fitting.run(slow, "lsq-trf", 4100, 1, {"stop_agree": 3})
    assert result.extras["stop_reason"] == "restarts agree" and "every k-th sample (k = 2)" in result.message
    theta = np.array([[result.params[name] for name in slow.param_names]])
    assert slow.loss_batch(theta)[0] == pytest.approx(result.mse, rel=1e-12)  # the loss on all 3,001 samples
    plain = fitting.run(slow, "lsq-trf", 4100, 1, {"stop_agree": 3, "explore": False})
    assert result.mse == pytest.approx(plain.mse, rel=2e-3)


def test_a_joint_fit_explores_on_every_kth_sample_of_its_oversampled_files_on_its_own_box():
    from bwbench.problems.hysteresis.exploration import exploration_note
    from bwbench.problems.hysteresis.joint_problem import JointProblem

    parts = [
        make_problem(read_specimen(MR.parent / name), {"model": "spencer", "formulation": "identifiable"})
        for name in ("mr_25mm_0.5Hz_1V.csv", "mr_10mm_2Hz_1V.csv")
    ]
    joint = JointProblem(parts)
    cheaper = joint.exploration()
    assert cheaper.model.tolerance == EXPLORATION_TOLERANCE and joint.model.tolerance is None
    assert [p.n_data for p in cheaper.parts] == [1501, 751] and cheaper.n_data == 2252 and joint.n_data == 3752
    assert np.array_equal(cheaper.lower, joint.lower) and np.array_equal(cheaper.upper, joint.upper)
    assert "k = 2, 1" in exploration_note(cheaper)
    theta = np.array([[0.02, 2.0, 0.3, 20.0, 0.09, 0.2]])
    assert cheaper.residual_batch(theta).shape == (1, 2252) and joint.residual_batch(theta).shape == (1, 3752)
    assert cheaper.loss_batch(theta)[0] == pytest.approx(joint.loss_batch(theta)[0], rel=0.1)
    samples = JointProblem(parts, "samples").exploration()  # files weighed by their samples: all of them kept
    assert samples.n_data == 3752


def test_the_exploring_step_budget_stops_a_stiff_simulation_sooner_and_spares_the_optimums():
    from bwbench.models.spencer import kernel
    from bwbench.models.spencer.start import kernel_inputs

    problem = _problem()
    t, x, v, a = kernel_inputs(problem.sim_signal)  # the record after the pre-roll put before it
    intervals = len(x) - 1

    def run(theta, pace):  # (steps per interval tried, status) at the exploring tolerance, pre-roll included
        steps, status = kernel._run(
            kernel.with_reciprocals(theta),
            t,
            x,
            v,
            a,
            x[0],
            0.0,
            intervals,
            np.empty(0),
            0,
            0,
            pace * intervals,
            EXPLORATION_TOLERANCE,
            pace,
        )[2:]
        return steps / intervals, status

    near = np.array([0.02, 2.0, 0.3, 20.0, 0.09, 0.2])  # near Spencer's damper
    stiff = problem.from_unit(np.array([0.064, 0.752, 0.279, 0.681, 0.277, 0.841]))  # a random point of the box
    assert run(near, EXPLORATION_PACE) == run(near, kernel.STEPS_PER_SAMPLE) and run(near, 8)[0] < 2.5
    (fine, fine_status), (coarse, coarse_status) = run(stiff, kernel.STEPS_PER_SAMPLE), run(stiff, EXPLORATION_PACE)
    assert fine_status == coarse_status == kernel.STATUS_STEP_BUDGET
    # measured 8.56 and 4.06 steps per interval of the record with its pre-roll (1,000 intervals; 21.3 and 10.4
    # per interval of the record alone when the kernel pre-rolled internally, its budget counted over both)
    assert fine > 8 and coarse < 4.5 and fine > 2 * coarse  # it stops 2x sooner
    slow = make_problem(
        read_specimen(MR.parent / "mr_25mm_0.5Hz_1V.csv"), {"model": "spencer", "formulation": "identifiable"}
    )
    assert slow.exploration().model.pace == kernel.STEPS_PER_SAMPLE  # every 2nd sample: 16 per interval of 2
