"""A good fit that ended on an edge of the box (a search stopped by its box, e.g. another formulation's)
is said to lie there, not called a mode the nested sampler missed."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine.box import box_from_unit
from bwbench.problems.hysteresis.formulations import make_problem
from bwbench.problems.hysteresis.report.nested_section import _on_box_edge

SPECIMEN = Path(__file__).resolve().parents[4] / "data" / "specimens" / "pom-mt24u01_0.05MPa_r1.csv"


@pytest.fixture(scope="module")
def problem():
    return make_problem(read_specimen(SPECIMEN), {"model": "switched-bouc-wen", "formulation": "identifiable"})


def at(problem, u):
    return box_from_unit(np.asarray(u, dtype=float)[None, :], problem.lower, problem.upper, problem.log_scaled)[0]


def unit(problem, theta):
    return problem.to_unit(theta[None, :])[0]


def test_a_fit_inside_the_box_is_on_no_edge(problem):
    assert _on_box_edge(problem, unit(problem, at(problem, [0.7, 0.3, 0.8, 0.5, 0.57, 0.3, 0.5]))) == ""


def test_a_fit_at_the_upper_edge_of_n_is_named_with_its_edge(problem):
    # the paper formulation's lsq-trf fits of this specimen, moved to the identifiable box: n₊ at u = 0.9997
    text = _on_box_edge(problem, unit(problem, at(problem, [0.79, 0.9997, 0.67, 0.51, 0.59, 0.33, 0.52])))
    assert text.startswith("n₊") and text.endswith("at its upper edge") and text.count("edge") == 1


def test_a_fit_beyond_the_lower_edge_counts_too(problem):
    theta = at(problem, [0.7, 0.3, 0.8, 0.5, 0.57, 0.3, 0.5])
    theta[2] = problem.lower[2] - 0.5  # η₊ below its box
    text = _on_box_edge(problem, unit(problem, theta))
    assert text.endswith("at its lower edge") and text.count("edge") == 1
