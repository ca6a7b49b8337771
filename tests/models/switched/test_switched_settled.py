"""The switched kernels' backward-Euler substeps on a piece settled on its loading attractor
(``switched_kernel.takes_implicit``): the relaxation onto z_s they take instead of up to 32 RK4 substeps,
against solve_ivp, on single pieces and on stiff rows of the identifiable box over a whole record."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bwbench.models.switched import kernel
from bwbench.models.switched import simulation as model
from reference import sine_excitation


def _exact_piece(z0, dx, A, n, beta, gamma):
    """z after a monotone displacement dx from z0, dz/dx = A − (β + γ·sign(z·ẋ))·|z|^n, by Radau at 1e-12."""
    direction = 1.0 if dx > 0 else -1.0

    def rhs(_, z):
        return [A - (beta + gamma * np.sign(z[0] * direction)) * abs(z[0]) ** n]

    sol = solve_ivp(rhs, (0.0, dx), [z0], method="Radau", rtol=1e-12, atol=1e-15 * abs(z0))
    assert sol.success
    return sol.y[0, -1]


@pytest.mark.parametrize("n", [0.5, 1.0, 2.0, 5.0])
@pytest.mark.parametrize("deviation", [-9e-3, -1e-3, 1e-3, 9e-3])  # within the band of 1e-2
@pytest.mark.parametrize("work", [8.5, 16.0, 31.0])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_a_settled_piece_relaxes_onto_its_attractor_as_the_ode_does(n, deviation, work, direction):
    A, beta, gamma = 40.0, 3.0e3, 1.0e3  # '+' of a stiff row: z_s = (A/(β + γ))^(1/n)
    z_s = math.pow(A / (beta + gamma), 1.0 / n)
    rate = n * A / z_s  # the attractor's relaxation rate per mm: the kernel's stiffness there
    dx = direction * work / rate  # work = stiffness · |dx| in (8, 32]: RK4's range before
    z0 = direction * z_s * (1.0 + deviation)
    assert kernel.takes_implicit(work, z0, direction, z_s)
    ours = kernel._advance_z(z0, dx, A, n, beta, gamma, z_s, rate)
    exact = _exact_piece(z0, dx, A, n, beta, gamma)
    # backward Euler leaves at most (1 + work/16)^-16 of the deviation: 1.5e-3 of 9e-3·z_s at work 8
    assert abs(ours - exact) <= 2e-5 * z_s
    # a piece off its attractor (a reversal's transition) keeps RK4
    assert not kernel.takes_implicit(work, -z0, direction, z_s) and not kernel.takes_implicit(
        work, 0.5 * z0, direction, z_s
    )


# Kernel rows H = (A, n, β, γ) per branch of the identifiable box (bench_objective's specimen box, seed 7)
# whose z the settled pieces moved most (2.8e-6–3.7e-6 of its range); solve_ivp's error stayed 1.2e-4–3.1e-4.
STIFF_ROWS = [
    [14.956034359414781, 4.1666828356441385, 1.882135557643083, 13.073898801771698]
    + [0.005616056399624557, 0.5642692276742859, 0.026392714418828234, 0.03421107576792797],
    [863.8077899164934, 2.563971144685041, 120.24661125143922, 743.5611786650542]
    + [2.4540318131455097, 0.733015674213632, -0.6816847050889159, 3.6129642838021234],
    [578.282943324799, 2.575304234231146, 457.1781106469063, 121.10483267789272]
    + [611.450520530869, 3.7899941989693673, 125.38953617119085, 209.74709391668478],
]


def _reference_z(H, t, amplitude, period):
    """z of the shared convention in time, DOP853-free: Radau at rtol 1e-10 between the sine's reversals."""
    w = 2 * np.pi / period
    _, v, _ = sine_excitation(t, amplitude, period)
    k = np.arange(0, int(np.ceil(2 * t[-1] / period)) + 2)
    reversals = (k + 0.5) * period / 2
    edges = np.concatenate([[t[0]], reversals[(reversals > t[0]) & (reversals < t[-1])], [t[-1]]])

    def rhs(tt, z, A, n, beta, gamma):
        xdot = amplitude * w * np.cos(w * tt)
        return [xdot * (A - (beta + gamma * np.sign(z[0] * xdot)) * abs(z[0]) ** n)]

    z, out = 0.0, np.empty_like(t)
    for lo, hi in zip(edges[:-1], edges[1:]):
        plus = np.cos(w * 0.5 * (lo + hi)) >= 0
        pars = tuple(H[:4]) if plus else tuple(H[4:])
        inside = (t >= lo) & (t <= hi) & ((v >= 0) == plus)
        sol = solve_ivp(rhs, (lo, hi), [z], method="Radau", rtol=1e-10, atol=1e-13, args=pars, dense_output=True)
        assert sol.success
        out[inside] = sol.sol(t[inside])[0]
        z = sol.y[0, -1]
    return out


@pytest.mark.parametrize("row", range(len(STIFF_ROWS)))
def test_stiff_rows_of_the_identifiable_box_stay_within_the_models_accuracy(row):
    H = np.array(STIFF_ROWS[row])
    t = np.arange(0.0, 1921.0)  # the model tests' grid: 1 Hz, 4 cycles of 480 s
    x, v, _ = sine_excitation(t, 10.0, 480.0)
    z = model.hysteretic_state_batch(H[None], t, x, v, "shared", kernel="scalar")[0]
    assert np.array_equal(z, model.hysteretic_state_batch(H[None], t, x, v, "shared")[0])  # lockstep: the same bits
    reference = _reference_z(H, t, 10.0, 480.0)
    assert np.max(np.abs(z - reference)) <= 1e-3 * np.ptp(reference)  # measured 1.2e-4–3.1e-4
