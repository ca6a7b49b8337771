"""The lockstep kernel against the scalar one (bit for bit, with and without its stiff rows handed to the scalar
kernel), and z against the force."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.models import excitation
from bwbench.models.switched import lockstep
from bwbench.models.switched import simulation as model
from bwbench.models.switched.kernel import HYSTERETIC_INDEX, STATES, symmetric_params
from bwbench.models.switched.parameters import LOWER, UPPER

SPECIMEN = Path(__file__).resolve().parents[3] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
TABLE6 = [0.005, 5.019, 1.009, 1.171, 3.600, 261.893, 3.589, 0.341, 2.825, 0.068, 0.014, 2.814, -151.740, 17.333]

# Outside or at the edge of Table 5, to provoke every path: n down to 0.2 with large A (stiff:
# many RK4 substeps, backward Euler), β+γ < 0 on loading (runaway in both conventions), β − γ
# far below zero on unloading, A = 0 (NaN attractor rate), α = 1 (z out of the force).
EXTREME = [
    [0.025, 0.43, 0.5, 0.1, 0.3, 100, 5, 5.0, 0.2, 0.1, 0.001, 0.2, -300, 30],
    [0.5, 0.3, 0.5, 0.1, 0.3, 100, 5, 1.25, 0.2, 0.1, 0.001, 5.0, -300, 30],
    [0.02, 2.0, 0.5, 0.1, -5.0, 100, 5, 1.0, 2.0, 0.1, 0.02, 1.0, -300, 30],
    [0.02, 2.0, 0.5, 0.5, 1.0, 100, 5, 1.0, 1.5, 0.1, 0.02, -3.0, -300, 30],
    [0.001, 10, 0.5, 2.5, 0.3, 100, 5, 1.25, 0.2, 0.1, 0.001, 0.2, -300, 30],
    [0.02, 3.0, 0.5, 8.0, 0.1, 100, 5, 1.0, 4.0, 0.1, 9.0, 0.1, -300, 30],
    [0.0, 2.0, 0.5, 0.5, 1.0, 100, 5, 1.0, 2.0, 0.1, 0.02, 1.0, -300, 30],
    [0.02, 2.0, 1.0, 0.5, 1.0, 100, 5, 1.0, 2.0, 0.1, 0.02, 1.0, -300, 30],
    # Inside Table 5, finite, with ~800 backward-Euler steps that find no bracket (shared z).
    [0.02081, 0.4764, 1.669, 2.411, 0.8862, 472.6, 2.343, 1.025, 4.350, 0.02902, 0.00921, 4.793, -142.1, 32.13],
    TABLE6,
]
BATCH_SIZES = (1, 3, 7, 13, 17, 30)  # none a multiple of lockstep.LANES; 17 and 33 span groups


@pytest.fixture(scope="module")
def specimen():
    s = read_specimen(SPECIMEN)
    return excitation.measured(s.t, s.x), s.f


@pytest.fixture(scope="module")
def population():
    # Seed 1 draws rows that blow up half-way (some right after a bracket-less backward-Euler
    # step) and stiff rows; draw 30 of seed 5 runs the RK4 fallback in both conventions and stays
    # finite. Shuffled with the extreme ones.
    rng = np.random.default_rng(1)
    fallback_both = LOWER + np.random.default_rng(5).random((200, 14))[30] * (UPPER - LOWER)
    P = np.vstack([LOWER + rng.random((60, 14)) * (UPPER - LOWER), EXTREME, fallback_both])
    return P[rng.permutation(len(P))]


def _batches(P):
    start = 0
    for size in BATCH_SIZES:
        yield P[start : start + size]
        start += size


# The lockstep kernel hands rows stiff enough for its groups to lose to the scalar kernel
# (``lockstep.SCALAR_WORK``); with that off, every row runs in lockstep, backward Euler included.
SCALAR_WORK = pytest.mark.parametrize("scalar_work", [lockstep.SCALAR_WORK, np.inf], ids=["dispatch", "all-lockstep"])


@SCALAR_WORK
@pytest.mark.parametrize("state", STATES)
def test_lockstep_mse_is_bit_identical_to_scalar(specimen, population, state, scalar_work, monkeypatch):
    monkeypatch.setattr(lockstep, "SCALAR_WORK", scalar_work)
    ex, f = specimen
    scalar = model.mse_batch(population, ex.t, ex.x, ex.v, ex.a, f, state, kernel="scalar")
    blown = np.isposinf(scalar)
    assert 0 < blown.sum() < len(scalar) / 2  # the population does exercise blow-ups
    start = 0
    for P in _batches(population):
        ours = model.mse_batch(P, ex.t, ex.x, ex.v, ex.a, f, state, kernel="lockstep")
        np.testing.assert_array_equal(ours, scalar[start : start + len(P)])
        start += len(P)
    assert start == len(population)
    # The whole population at once: several groups, in parallel when numba has threads.
    np.testing.assert_array_equal(model.mse_batch(population, ex.t, ex.x, ex.v, ex.a, f, state), scalar)


@SCALAR_WORK
@pytest.mark.parametrize("state", STATES)
def test_lockstep_z_is_bit_identical_to_scalar(specimen, population, state, scalar_work, monkeypatch):
    monkeypatch.setattr(lockstep, "SCALAR_WORK", scalar_work)
    ex, _ = specimen
    H = population[:, list(HYSTERETIC_INDEX)]
    scalar = model.hysteretic_state_batch(H, ex.t, ex.x, ex.v, state, kernel="scalar")
    assert scalar.shape == (len(H), len(ex.t))
    rows_inf = np.all(np.isposinf(scalar), axis=1)
    assert rows_inf.any() and np.all(np.isfinite(scalar[~rows_inf]))  # +inf rows, else finite
    start = 0
    for batch in _batches(H):
        ours = model.hysteretic_state_batch(batch, ex.t, ex.x, ex.v, state, kernel="lockstep")
        np.testing.assert_array_equal(ours, scalar[start : start + len(batch)])
        start += len(batch)


def test_grouping_does_not_change_results(specimen, population, monkeypatch):
    ex, f = specimen
    default = model.mse_batch(population, ex.t, ex.x, ex.v, ex.a, f)
    monkeypatch.setattr(lockstep, "LANES", 3)
    np.testing.assert_array_equal(model.mse_batch(population, ex.t, ex.x, ex.v, ex.a, f), default)


@pytest.mark.parametrize("state", STATES)
def test_force_is_linear_in_the_hysteretic_state(specimen, state):
    ex, _ = specimen
    for p in np.array([TABLE6, EXTREME[0], EXTREME[1], EXTREME[7], symmetric_params(0.3, 1.5, 0.2, 0.5, 1.5, 50, 10)]):
        z = model.hysteretic_state(p[list(HYSTERETIC_INDEX)], ex.t, ex.x, ex.v, state)
        force = model.simulate(p, ex.t, ex.x, ex.v, ex.a, state)
        assert np.all(np.isfinite(z)) and np.ptp(z) > 0
        branch = np.where(ex.v >= 0, 0, 7)
        A, n, alpha, beta, gamma, xi, wn = (p[branch + i] for i in range(7))
        expected = ex.a + 2.0 * xi * wn * ex.v + alpha * wn * wn * ex.x + (1.0 - alpha) * wn * wn * z
        np.testing.assert_array_equal(force, expected)


def test_runaway_gives_inf_z_and_force(specimen):
    ex, _ = specimen
    p = np.array(EXTREME[2])  # β₊ + γ₊ < 0: z runs away on the first loading
    for state in STATES:
        assert np.all(np.isposinf(model.hysteretic_state(p[list(HYSTERETIC_INDEX)], ex.t, ex.x, ex.v, state)))
        assert np.all(np.isposinf(model.simulate(p, ex.t, ex.x, ex.v, ex.a, state)))


def test_batched_z_equals_row_by_row(specimen, population):
    ex, _ = specimen
    H = population[:20, list(HYSTERETIC_INDEX)]
    Z = model.hysteretic_state_batch(H, ex.t, ex.x, ex.v, "split")
    for i, h in enumerate(H):
        np.testing.assert_array_equal(Z[i], model.hysteretic_state(h, ex.t, ex.x, ex.v, "split"))


def test_edge_sizes_and_bad_arguments(specimen):
    ex, f = specimen
    H = np.array(TABLE6)[list(HYSTERETIC_INDEX)]
    assert model.mse_batch(np.empty((0, 14)), ex.t, ex.x, ex.v, ex.a, f).shape == (0,)
    assert model.hysteretic_state_batch(np.empty((0, 8)), ex.t, ex.x, ex.v).shape == (0, len(ex.t))
    one = model.hysteretic_state_batch(np.tile(H, (2, 1)), ex.t[:1], ex.x[:1], ex.v[:1])
    np.testing.assert_array_equal(one, [[0.0], [0.0]])  # one sample: the initial z
    with pytest.raises(ValueError, match="kernel"):
        model.mse_batch(np.array([TABLE6]), ex.t, ex.x, ex.v, ex.a, f, kernel="simd")
    with pytest.raises(ValueError, match="shape"):
        model.hysteretic_state_batch(np.ones((2, 7)), ex.t, ex.x, ex.v)
    with pytest.raises(ValueError, match="at least one sample"):
        model.mse_batch(np.ones((2, 14)), [], [], [], [], [])


def test_stiff_rows_go_to_the_scalar_kernel(specimen, population, monkeypatch):
    """Rows whose attractor rate times the longest sample step exceeds ``SCALAR_WORK`` run in the
    scalar kernel, the others in lockstep: the population has both kinds."""
    ex, _ = specimen
    H = population[:, list(HYSTERETIC_INDEX)]
    work = lockstep._stiffness_key(H) * np.max(np.abs(np.diff(ex.x)))
    stiff = work > lockstep.SCALAR_WORK
    assert 0 < stiff.sum() < len(H)
    calls = []
    scalar = lockstep.kernel.hysteretic_batch_scalar
    monkeypatch.setattr(
        lockstep.kernel, "hysteretic_batch_scalar", lambda rows, *args: calls.append(len(rows)) or scalar(rows, *args)
    )
    monkeypatch.setattr(lockstep.numba, "get_num_threads", lambda: 1)  # the dispatch is on the one-thread path
    lockstep.run_hysteretic(np.ascontiguousarray(H), *(np.ascontiguousarray(a) for a in (ex.t, ex.x, ex.v)), False)
    assert calls == [int(stiff.sum())]
