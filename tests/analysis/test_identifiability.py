"""Local identifiability on toy models with known invariances."""

import numpy as np
import pytest
from scipy.linalg import subspace_angles

from bwbench.analysis import identifiability

T = np.linspace(0.0, 3.0, 60)


def one_invariance(u):
    """y depends on a and b only through a·b: one exact invariance, direction (a, −b, 0)."""
    a, b, c = u
    return a * b * np.exp(-c * T)


def two_invariances(u):
    """a·b and c·d only: two exact invariances, (a, −b, 0, 0, 0) and (0, 0, c, −d, 0)."""
    a, b, c, d, e = u
    return a * b * np.exp(-c * d * T) + e * np.sin(T)


def residual_of(model, u_true, noise=0.0, seed=0):
    y = model(u_true) + np.random.default_rng(seed).normal(0.0, noise, T.size)
    return lambda u: model(u) - y


def test_one_invariance_gives_one_zero_singular_value_along_the_product():
    u = np.array([0.3, 0.6, 0.5])
    sens = identifiability.sensitivity(residual_of(one_invariance, u), u, ["a", "b", "c"])
    assert np.sum(sens.ratios < 1e-6) == 1
    assert sens.ratios[1] > 1e-3
    # d(a·b) = b·da + a·db = 0 along (a, −b): with a ≠ b this differs from (1/a, −1/b).
    expected = np.array([u[0], -u[1], 0.0]) / np.hypot(u[0], u[1])
    weakest = sens.directions[-1]
    angle = np.arccos(min(1.0, abs(weakest @ expected)))
    assert angle < 1e-4
    (w,) = sens.weakest(1)
    assert w["ratio"] < 1e-6
    assert w["weights"]["b"] > 0  # sign fixed: the largest weight (|b| = 0.89) is positive
    assert w["text"] == "0.89·b − 0.45·a"


def test_two_invariances_give_two_zero_singular_values_spanning_both():
    u = np.array([0.3, 0.6, 0.5, 0.8, 0.4])
    sens = identifiability.sensitivity(residual_of(two_invariances, u), u, list("abcde"))
    assert np.sum(sens.ratios < 1e-6) == 2
    assert sens.ratios[2] > 1e-3
    known = np.array([[u[0], -u[1], 0, 0, 0], [0, 0, u[2], -u[3], 0]]).T
    angles = subspace_angles(sens.directions[-2:].T, known)
    assert np.max(angles) < 1e-4


def test_noise_decides_what_is_undetermined_and_the_free_ranges():
    u = np.array([0.3, 0.6, 0.5])
    sens = identifiability.sensitivity(residual_of(one_invariance, u, noise=0.01), u, ["a", "b", "c"])
    assert sens.undetermined().tolist() == [False, False, True]
    free = sens.free_ranges()
    # The path (a·(1 + t), b·(1 − t), c) stays in the unit box for t in [−2/3, 1] (b ≤ 1 and b ≥ 0
    # bind), so a can go from 0.1 to 0.6 without changing the model.
    assert free[0] == pytest.approx([0.3 - 0.3 * 2 / 3, 0.3 + 0.3 * 1.0], abs=1e-6)
    assert free[2] == pytest.approx([0.5, 0.5], abs=1e-9)
    assert sens.poorly_determined() == ["a", "b"]
    assert sens.standard_errors()[2] < 0.05


def test_profile_is_flat_along_an_invariance_and_curved_otherwise():
    u = np.array([0.3, 0.6, 0.5])
    y = one_invariance(u)

    def loss_batch(U):
        return np.array([np.mean((one_invariance(v) - y) ** 2) for v in U])

    flat = identifiability.profile(loss_batch, u, 0, [0.2, 0.3, 0.5, 0.8], maxiter=50)
    assert flat["loss"].max() < 1e-8  # b compensates for every a on the grid
    curved = identifiability.profile(loss_batch, u, 2, [0.1, 0.5, 0.9], maxiter=50)
    assert curved.set_index("unit")["loss"][0.5] < 1e-8
    assert curved.set_index("unit")["loss"][0.1] > 1e-3


def test_describe_direction():
    labels = ["ωn₋", "α₋", "ξ₋"]
    assert identifiability.describe_direction([0.71, -0.70, 0.02], labels) == "0.71·ωn₋ − 0.70·α₋"
    assert identifiability.describe_direction([-0.9, 0.3, 0.3], labels) == "−0.90·ωn₋ + 0.30·α₋ + 0.30·ξ₋"


def test_posterior_correlation_and_strongest_pairs():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(5000, 3))
    x[:, 2] = -x[:, 0] + 0.1 * rng.normal(size=5000)
    corr = identifiability.posterior_correlation(x, ["p", "q", "r"])
    (a, b, r), *_ = identifiability.strongest_pairs(corr, 2)
    assert (a, b) == ("p", "r") and r < -0.99


def test_an_exact_invariance_stays_zero_along_a_path_and_a_flat_spot_does_not():
    # y(a, b, c) = a·b·exp(−T) + 20(c − ½)²·sin(T): a·b is an exact (curved) invariance everywhere; at c = ½
    # the c direction is flat (zero derivative) at the point only.
    def flat_at_zero(u):
        a, b, c = u
        return a * b * np.exp(-T) + 20 * (c - 0.5) ** 2 * np.sin(T)

    u = np.array([0.4, 0.6, 0.5])
    sens = identifiability.sensitivity(flat_at_zero, u, ["a", "b", "c"])
    assert sens.ratios[-2] < identifiability.ZERO_RATIO and sens.ratios[-1] < identifiability.ZERO_RATIO
    scale = float(np.linalg.norm(flat_at_zero(u)))
    product = identifiability.follow_invariance(flat_at_zero, u, np.array([0.4, -0.6, 0.0]) / 0.72, scale)
    assert product["exact"] and product["length"] == pytest.approx(0.1) and product["change"] < 1e-9
    flat = identifiability.follow_invariance(flat_at_zero, u, np.array([0.0, 0.0, 1.0]), scale)
    assert not flat["exact"] and flat["change"] > 1e-4
