"""The per-call path of the identifiable formulation: a batch is the same numbers whatever its size and
however many threads run it (small batches run in the caller's thread, large ones on numba's)."""

from pathlib import Path

import numba
import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.problems.hysteresis.formulations import make_problem

DATA = Path(__file__).resolve().parents[3] / "data"
CASES = [
    ("switched-bouc-wen", DATA / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("spencer", DATA / "mr_damper" / "mr_10mm_2Hz_1V.csv"),
    ("bouc-wen", DATA / "specimens" / "pc-abs-c12hf_0.01MPa_r1.csv"),
]


@pytest.fixture
def two_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:  # type: ignore[attr-defined]
        pytest.skip("numba has one thread here")
    previous = numba.get_num_threads()
    numba.set_num_threads(2)
    yield
    numba.set_num_threads(previous)


@pytest.mark.parametrize("model, path", CASES, ids=[c[0] for c in CASES])
def test_one_point_per_call_equals_the_batch_on_two_threads(model, path, two_threads):
    problem = make_problem(read_specimen(path), {"model": model, "formulation": "identifiable"})
    U = np.random.default_rng(3).random((12, problem.dim))  # 12 rows: the parallel path on 2 threads
    batched = Objective(problem, 12).batch(U)
    one = Objective(problem, 12)
    single = np.array([one(u) for u in U])
    assert np.isfinite(batched).sum() >= 6  # mostly real losses, not all blow-ups
    np.testing.assert_array_equal(single, batched)
    numba.set_num_threads(1)
    np.testing.assert_array_equal(Objective(problem, 12).batch(U), batched)
