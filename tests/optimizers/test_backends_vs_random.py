"""At the paper's budget of 4,100, every backend beats uniform random search on a real specimen.

Slow (11 backends x 5 seeds of 4,100 evaluations, ~100 s on 2 cores): run with
`.venv/bin/python -m pytest -m slow`. The default run covers the same behaviour on a cheap
problem (tests/optimizers/test_library_backends.py, test_paper_ga.py, test_firefly.py) and the quick study
shows it on 3 specimens (reports/quick/report.html).
"""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting, registry
from paper_problems import SwitchedBoucWenProblem

SPECIMEN = Path(__file__).resolve().parents[2] / "data" / "specimens" / "pom-mt24u01_0.05MPa_r1.csv"
SEEDS = range(5)


@pytest.fixture(scope="module")
def problem():
    return SwitchedBoucWenProblem(read_specimen(SPECIMEN))


@pytest.fixture(scope="module")
def random_median(problem):
    return np.median([fitting.run(problem, "random", 4100, seed).mse for seed in SEEDS])


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in sorted(registry.available()) if n != "random"])
def test_median_mse_below_random_search(problem, random_median, name):
    median = np.median([fitting.run(problem, name, 4100, seed).mse for seed in SEEDS])
    assert median < random_median, f"{name}: median MSE {median:.4g} N², random {random_median:.4g} N²"
