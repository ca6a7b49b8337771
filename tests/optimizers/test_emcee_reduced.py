"""A branch the data cannot tell from a linear one is sampled as linear (a reduced model), and the
sampler says so; a branch that yields within the stroke is sampled in full."""

from pathlib import Path

import numpy as np

from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting
from bwbench.problems.hysteresis.formulations import make_problem
from bwbench.study.posterior_config import POSTERIOR_OPTIONS
from bwbench.threads import limited

SPECIMENS = Path(__file__).resolve().parents[2] / "data" / "specimens"


def test_the_linear_tension_branch_is_held_and_the_compression_branch_sampled():
    # pom-mt24u01 0.05 MPa: truth x_y₊ = 39 mm on a ±10 mm stroke (linear), x_y₋ = 0.76 mm (yields)
    problem = make_problem(
        read_specimen(SPECIMENS / "pom-mt24u01_0.05MPa_r1.csv"),
        {"state": "shared", "excitation": "measured", "formulation": "identifiable"},
    )
    options = {**POSTERIOR_OPTIONS["emcee"], "start_fraction": 0.5, "stop": "budget"}
    with limited(1):  # as a study's worker runs it: numba's parallel loops wait for busy cores otherwise
        result = fitting.run(problem, "emcee", 30_000, seed=3, options=options)
    fixed = result.extras["fixed"]
    assert set(fixed) == {"n+", "eta+", "xy+"}, result.message
    assert fixed["n+"] == 10.75 and fixed["eta+"] == 0.0
    assert fixed["xy+"] == float(problem.from_unit([[1.0] * problem.dim])[0][0])  # the cap: never yields
    assert "branch +: with n₊ = 10.75, η₊ = 0" in result.message and "held there too" in result.message
    assert "branch -:" in result.message and "the data tell its shape; sampled in full" in result.message
    chain = result.extras["chain"]
    names = list(problem.param_names)
    for name in ("n+", "eta+", "xy+"):  # held: constant in the chain
        assert np.ptp(chain[:, :, names.index(name)]) == 0.0
    assert np.ptp(chain[:, :, names.index("xy-")]) > 0.0
