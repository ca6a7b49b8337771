"""A parameter on its box edge, classified: a model limit (said, never widened, and a --bounds past it
refused), an undetermined (flat) direction, or a box too small (widened by the fit itself, said so).
Records from independent solve_ivp references, not from our generators."""

import warnings

import numpy as np
import pandas as pd
import pytest

import bwbench
from bwbench.data.specimen_input import from_frame
from bwbench.engine import fitting
from bwbench.errors import UserError
from bwbench.problems.hysteresis import edges
from bwbench.problems.hysteresis.formulations import make_problem
from reference_bwbn import growing_cycles, reference_force
from reference_mr import classic_force

# A, n, α, β, γ, ξ, ωn: x_y = z_s/A = 1 mm; k = α·ωn² = 20 N/mm, h = 80 N, c = 40 N·s/mm
CLASSIC = [1.0, 1.5, 0.2, 0.5, 0.5, 2.0, 10.0]


def classic_frame(noise=2.0, seed=4):
    """Three cycles of ±10 mm at 0.2 Hz, 50 Hz, the classic Bouc-Wen force from solve_ivp."""
    w = 2 * np.pi * 0.2
    t = np.arange(0.0, 15.0, 0.02) + 0.0037

    def x_of(s):
        return 10 * np.sin(w * s)

    def v_of(s):
        return 10 * w * np.cos(w * s)

    def a_of(s):
        return -10 * w * w * np.sin(w * s)

    f = classic_force(CLASSIC, t, x_of, v_of, a_of) + np.random.default_rng(seed).normal(0, noise, len(t))
    return pd.DataFrame({"time_s": t, "displacement_mm": x_of(t), "velocity_mm_s": v_of(t), "force_N": f})


def test_a_box_too_small_is_widened_by_the_fit_and_said_so():
    frame = classic_frame()
    problem = make_problem(from_frame(frame, "narrow"), {"model": "bouc-wen", "bounds": {"xy": (0.01, 0.2)}})
    best = fitting.run(problem, "lsq-trf", 300, 0)  # the best fit in the narrow box: x_y on its upper edge
    assert best.at_bound["xy"] == "upper"
    theta = np.array([best.params[n] for n in problem.param_names])
    (edge,) = edges.classify(problem, theta, {"xy": "upper"})
    assert edge.kind == edges.TOO_SMALL and edge.loss_change > 5 * edge.noise
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", bwbench.FitWarning)
        fit = bwbench.fit(frame, model="bouc-wen", bounds={"xy": (0.01, 0.2)}, budget=2000, seed=0)
    widened = [str(w.message) for w in caught if "box widened by the fit" in str(w.message)]
    assert widened and "xy to [0.01, 2]" in widened[0]
    assert fit.params["xy"] == pytest.approx(1.0, rel=0.05) and fit.rmse_N < 2.2
    assert not [w for w in caught if "widen it with --bounds" in str(w.message)]


def test_a_flat_direction_is_undetermined_not_a_box_to_widen():
    x_of, v_of, t = growing_cycles(period=20.0, rate=5.0)
    P = np.array([100.0, 0.05, 0.0, 0.02, 0.02, 1.5, 2e-4, 1e-4, 0.0, 2e-3, 0.1, 3.0, 2e-4, 0.2])  # no pinching
    f = reference_force(P, t, x_of, v_of) + np.random.default_rng(1).normal(0, 5, len(t))
    problem = make_problem(
        from_frame(pd.DataFrame({"time_s": t, "displacement_mm": x_of(t), "force_N": f}), "col"), {"model": "bwbn"}
    )
    theta = problem.from_unit(np.full(problem.dim, 0.5))
    names = list(problem.param_names)
    theta[names.index("zeta_s")] = 0.0  # no pinching: how soon it would set in does not matter
    theta[names.index("p_e")] = problem.upper[names.index("p_e")]
    (edge,) = edges.classify(problem, theta, {"p_e": "upper"})
    assert edge.kind == edges.UNDETERMINED and edge.loss_change < edge.noise
    assert "undetermined" in edge.text and "with --bounds" not in edge.text


def test_a_model_limit_is_said_never_widened_and_a_bounds_past_it_is_refused():
    spec = from_frame(classic_frame(), "limit")
    problem = make_problem(spec, {"model": "switched-bouc-wen", "formulation": "identifiable"})
    theta = problem.from_unit(np.full(problem.dim, 0.5))
    theta[list(problem.param_names).index("eta+")] = 1.0
    (edge,) = edges.classify(problem, theta, {"eta+": "upper"})
    assert edge.kind == edges.MODEL_LIMIT and "the model's limit" in edge.text
    with pytest.raises(UserError, match=r"--bounds: eta\+ upper 1.5 is past the model's limit 1"):
        make_problem(spec, {"model": "switched-bouc-wen", "formulation": "identifiable", "bounds": {"eta+": (-2, 1.5)}})
    make_problem(spec, {"model": "switched-bouc-wen", "formulation": "identifiable", "bounds": {"eta+": (-2, 0.5)}})
