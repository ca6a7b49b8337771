"""The identifiable formulation: symmetry, maps, linear solve, inertia rule, bounds, marginal likelihood."""

import glob
from pathlib import Path

import numpy as np
import pytest
from scipy.special import logsumexp

from bwbench.data.specimen import read_specimen
from bwbench.models import excitation
from bwbench.models.switched import identifiable as fm
from bwbench.models.switched import parameters as switched_parameters
from bwbench.models.switched import simulation as model
from bwbench.models.switched.kernel import STATES
from bwbench.models.switched.model import LAYOUT
from bwbench.problems.hysteresis import marginal as mg
from bwbench.problems.hysteresis.linear import solve as ls
from paper_problems import IdentifiableModel

DATA = Path(__file__).resolve().parents[3] / "data" / "specimens"
SPECIMENS = ["pom-mt24u01_0.01MPa_r1", "pom-c9021_0.03MPa_r2", "pc-abs-c12hf_0.07MPa_r3"]


def load(name):
    """Measured excitation, measured force and truth parameters of a synthetic specimen."""
    sp = read_specimen(DATA / f"{name}.csv")
    return excitation.measured(sp.t, sp.x), sp.f, switched_parameters.truth_params(DATA / f"{name}.csv")


def paper_force(p, e, state):
    return model.simulate(p, e.t, e.x, e.v, e.a, state)


def gauge_transform(p, s_plus, s_minus, state):
    """Apply z → s·z to a paper vector (shared: s_minus is s_plus), keeping c = 2ξωn and k = αωn²."""
    q = np.array(p, dtype=float)
    for i, s in ((0, s_plus), (7, s_plus if state == "shared" else s_minus)):
        A, n, alpha, beta, gamma, xi, wn = q[i : i + 7]
        c, k, h = 2 * xi * wn, alpha * wn**2, (1 - alpha) * wn**2
        w2 = k + h / s
        assert w2 > 0
        q[i : i + 7] = [s * A, n, k / w2, beta * s ** (1 - n), gamma * s ** (1 - n), c / (2 * np.sqrt(w2)), np.sqrt(w2)]
    return q


@pytest.mark.parametrize("state", STATES)
def test_the_gauge_symmetry_leaves_the_paper_force_unchanged(state):
    e, _, p = load("pom-mt24u01_0.01MPa_r1")
    f0 = paper_force(p, e, state)
    rng = np.random.default_rng(7)
    for s_plus, s_minus in np.exp(rng.uniform(np.log(0.1), np.log(10.0), (4, 2))):
        q = gauge_transform(p, s_plus, s_minus, state)
        assert np.max(np.abs(q - p) / np.abs(p)) > 1e-3  # the parameters really moved
        f1 = paper_force(q, e, state)
        assert np.max(np.abs(f1 - f0)) <= 1e-9 * np.ptp(f0)


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("name", SPECIMENS)
def test_w_dynamics_integrate_z_over_the_gauge(name, state):
    """trajectories(θ) = z/z_s₊ (split: z_b/z_s_b) of the paper's own hysteretic parameters."""
    e, _, p = load(name)
    theta, _ = fm.from_paper(p, state)
    w = model.hysteretic_state_batch(fm.kernel_hysteretic(theta, state), e.t, e.x, e.v, state)[0]
    z = model.hysteretic_state(p[[0, 1, 3, 4, 7, 8, 10, 11]], e.t, e.x, e.v, state)
    z_s = [(p[i] / (p[i + 3] + p[i + 4])) ** (1 / p[i + 1]) for i in (0, 7)]
    scale = np.where(e.v >= 0, z_s[0], z_s[1]) if state == "split" else z_s[0]
    np.testing.assert_allclose(w * scale, z, rtol=0, atol=1e-9 * np.ptp(z))


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("name", SPECIMENS)
def test_paper_to_identifiable_to_paper_gives_the_same_force(name, state):
    e, _, p = load(name)
    theta, linear = fm.from_paper(p, state)
    assert len(theta) == (7 if state == "shared" else 6) and linear[0] == 1.0
    back = fm.to_paper(theta, linear, state)
    assert back.params is not None, back.reason
    f0, f1 = paper_force(p, e, state), paper_force(back.params, e, state)
    assert np.max(np.abs(f1 - f0)) <= 1e-9 * np.ptp(f0)
    theta2, linear2 = fm.from_paper(back.params, state)
    np.testing.assert_allclose(theta2, theta, rtol=1e-9)
    np.testing.assert_allclose(linear2, linear, rtol=1e-9, atol=0)


@pytest.mark.parametrize("state", STATES)
def test_identifiable_to_paper_to_identifiable_round_trips(state):
    e, f, _ = load("pom-mt24u01_0.01MPa_r1")
    bounds = fm.scaled_bounds(e.x, f, state)
    rng = np.random.default_rng(11)
    for _ in range(10):
        theta = bounds.from_unit(rng.uniform(size=len(bounds.names)))
        linear = np.zeros(9)
        linear[0] = 1.0
        for b in "+-":  # c of either sign, k and h > 0: ωn² > 0 for every gauge
            linear[[fm.LINEAR_NAMES.index(f"{n}{b}") for n in "ckh"]] = [
                rng.uniform(-5e3, 5e3),
                rng.uniform(1.0, 100.0),
                rng.uniform(10.0, 1e3),
            ]
        back = fm.to_paper(theta, linear, state)
        assert back.params is not None, back.reason
        theta2, linear2 = fm.from_paper(back.params, state)
        np.testing.assert_allclose(theta2, theta, rtol=1e-9)
        np.testing.assert_allclose(linear2, linear, rtol=1e-9)


def test_to_paper_says_why_it_cannot():
    _, _, p = load("pom-mt24u01_0.01MPa_r1")
    theta, linear = fm.from_paper(p)
    heavy = linear.copy()
    heavy[0] = 2.0
    offset = linear.copy()
    offset[fm.LINEAR_NAMES.index("f-")] = 3.0
    soft = linear.copy()
    soft[[fm.LINEAR_NAMES.index("k+"), fm.LINEAR_NAMES.index("h+")]] = [-1.0, -1.0]
    for lin, word in ((heavy, "m = 2"), (offset, "f-"), (soft, "ωn²")):
        out = fm.to_paper(theta, lin)
        assert out.params is None and word in out.reason


def test_the_gauge_rule_picks_the_table5_centre_among_equivalent_vectors():
    """The chosen gauge is no farther from Table 5's centre than the truth's own gauge or any other."""
    _, _, p = load("pom-mt24u01_0.01MPa_r1")
    theta, linear = fm.from_paper(p)
    chosen = fm.to_paper(theta, linear).params
    from bwbench.models.switched.parameters import LOWER, UPPER

    def dist(q):
        return np.sum(((q - LOWER) / (UPPER - LOWER) - 0.5) ** 2)

    others = [gauge_transform(p, s, s, "shared") for s in np.exp(np.linspace(-2, 2, 41))]
    assert dist(chosen) <= min(dist(q) for q in others + [p]) + 1e-12


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("fix_mass", [1.0, None], ids=["m_fixed_1", "m_free"])
def test_noise_free_identifiable_optimum_is_the_paper_optimum(state, fix_mass):
    e, _, p = load("pom-mt24u01_0.05MPa_r1")
    f = paper_force(p, e, state)  # noise-free data on the measured excitation: paper MSE = 0
    theta, linear = fm.from_paper(p, state)
    M = IdentifiableModel(e, f, state, fix_mass=fix_mass, offsets=True)
    sol = M.solve(theta[None])
    assert sol.mse[0] <= 1e-18 * np.ptp(f) ** 2  # RMS error ≤ 1e-9 of the force range
    scale = np.array([1.0, 1e3, 10.0, 100.0, 100.0, 1e3, 10.0, 100.0, 100.0])
    assert np.all(np.abs(sol.coef[0] - linear) <= 1e-7 * np.abs(linear) + 1e-9 * np.ptp(f) / scale)


def explicit_design(e, w, names):
    """The design matrix written out column by column from the model equation."""
    plus = e.v >= 0
    col = {"m": e.a}
    for b, mask in (("+", plus), ("-", ~plus)):
        col.update({f"c{b}": e.v * mask, f"k{b}": e.x * mask, f"h{b}": w * mask, f"f{b}": 1.0 * mask})
    return np.column_stack([col[n] for n in names])


@pytest.mark.parametrize("fix_mass", [1.0, None], ids=["m_fixed_1", "m_free"])
def test_batched_solve_equals_lstsq_on_the_written_out_design(fix_mass):
    e, f, _ = load("pc-abs-c12hf_0.07MPa_r3")
    f = f + 40.0 * e.a * 1e3  # a visible inertia term, so a free m is not at its bound
    M = IdentifiableModel(e, f, "shared", fix_mass=fix_mass, mass_min=None)
    rng = np.random.default_rng(3)
    theta = M.bounds.from_unit(rng.uniform(size=(12, 7)))
    theta[0] = M.bounds.from_unit(np.array([0.9, 0.9, 0.99, 0.1, 0.9, 0.99, 0.01]))  # runs away
    Z = M.trajectories(theta)
    finite = np.flatnonzero(np.isfinite(Z).all(axis=1))
    assert 0 not in finite and len(finite) >= 8
    sol = M.design.solve(Z, residual=True)
    assert np.all(sol.mse[np.isin(np.arange(len(Z)), finite, invert=True)] == np.inf)
    assert np.all(np.isnan(sol.coef[0])) and np.all(sol.residual[0] == np.inf)
    y = f - (0.0 if fix_mass is None else fix_mass * e.a)
    for i in finite:
        X = explicit_design(e, Z[i], sol.free_names)
        beta, *_ = np.linalg.lstsq(X, y, rcond=None)
        np.testing.assert_allclose(sol.coef_ls[i], beta, rtol=1e-6, atol=1e-9 * np.abs(beta).max())
        r = y - X @ beta
        np.testing.assert_allclose(sol.mse[i], np.mean(r**2), rtol=1e-9)
        np.testing.assert_allclose(sol.residual[i], -r, atol=1e-8 * np.abs(f).max())
        np.testing.assert_allclose(sol.logdet[i], np.linalg.slogdet(X.T @ X)[1], rtol=0, atol=1e-6)
    one = M.design.solve(Z[finite[-1] : finite[-1] + 1])
    assert one.mse[0] == pytest.approx(sol.mse[finite[-1]], rel=1e-12)


def test_a_negative_free_mass_is_held_at_its_bound():
    e, f, _ = load("pom-mt24u01_0.01MPa_r1")
    f = f - 5e4 * e.a  # pulls the least-squares mass far below 0
    theta = fm.from_paper(load("pom-mt24u01_0.01MPa_r1")[2])[0][None]
    free = IdentifiableModel(e, f, fix_mass=None, mass_min=None).solve(theta)
    bounded = IdentifiableModel(e, f, fix_mass=None, mass_min=0.0).solve(theta)
    at_zero = IdentifiableModel(e, f, fix_mass=0.0).solve(theta)
    assert free.coef[0, 0] < -1e4 and bounded.bound_active[0]
    assert bounded.coef[0, 0] == 0.0 and bounded.mse[0] == pytest.approx(at_zero.mse[0], rel=1e-12)
    assert bounded.mse[0] > free.mse[0]


def test_a_test_that_only_moves_one_way_drops_the_idle_branch():
    t = np.arange(200.0)
    x = 0.05 * t + 0.5 * np.sin(t / 30)  # ẋ > 0 throughout
    e = excitation.measured(t, x)
    w = np.tanh(x)
    f = 3.0 * e.x + 50.0 * w + 7.0 + np.random.default_rng(0).normal(0, 0.1, len(t))
    design = ls.LinearDesign(e, f, LAYOUT)
    sol = design.solve(w[None], residual=True)
    assert any("branch - has no samples" in note for note in design.notes)
    assert "h-" not in sol.free_names and np.all(np.isnan(sol.coef[0, 5:]))
    k, h, off = (sol.coef[0, fm.LINEAR_NAMES.index(n)] for n in ("k+", "h+", "f+"))
    assert (
        k == pytest.approx(3.0, rel=0.05) and h == pytest.approx(50.0, rel=0.01) and off == pytest.approx(7.0, abs=0.5)
    )
    assert np.sqrt(sol.mse[0]) < 0.12


@pytest.mark.parametrize("path", sorted(glob.glob(str(DATA / "*.csv"))), ids=lambda p: Path(p).stem)
def test_inertia_is_not_excited_by_the_quasi_static_specimens(path):
    sp = read_specimen(path)
    check = ls.inertia_check(excitation.measured(sp.t, sp.x), sp.f, LAYOUT)
    assert not check.excited and not check.fit and "not excited" in check.reason
    assert check.inertia_rms_N < 0.01 * check.noise_N


def fast_test(x_of_t):
    """A 1 kHz test driven by x(t) (mm), force from a paper truth plus 1 N noise."""
    t = np.arange(0.0, 2.0, 1e-3)
    e = excitation.measured(t, x_of_t(t))
    p = load("pom-mt24u01_0.05MPa_r1")[2]
    return e, paper_force(p, e, "shared") + np.random.default_rng(5).normal(0, 1.0, len(t))


def test_inertia_of_a_fast_sine_is_excited_but_confounded_with_stiffness():
    e, f = fast_test(lambda t: 25.0 * np.sin(2 * np.pi * 5.0 * t))
    check = ls.inertia_check(e, f, LAYOUT)
    assert check.excited and check.inertia_rms_N > 1e3 * check.noise_N
    # ẍ = −ω²x: m and k are one combination on a sine, so m stays fixed (at 0) and k absorbs it.
    assert not check.separable and "not separable" in check.reason and check.sine_segments == 1
    assert ls.LinearDesign(e, f, LAYOUT).mass == ls.M_UNFITTED == 0.0


def test_inertia_of_a_two_tone_test_is_fitted():
    e, f = fast_test(lambda t: 20.0 * np.sin(2 * np.pi * 5.0 * t) + 5.0 * np.sin(2 * np.pi * 13.0 * t + 0.3))
    check = ls.inertia_check(e, f, LAYOUT)
    assert check.excited and check.separable and check.fit
    design = ls.LinearDesign(e, f, LAYOUT)
    assert design.mass is None and "m" in design.free_names


def test_scaled_bounds_contain_every_synthetic_truth():
    for name in sorted(Path(p).stem for p in glob.glob(str(DATA / "*.csv"))):
        e, f, p = load(name)
        for state in STATES:
            b = fm.scaled_bounds(e.x, f, state)
            assert np.all(np.isfinite(b.lower)) and np.all(np.isfinite(b.upper)) and np.all(b.lower < b.upper)
            assert b.names == fm.hysteretic_names(state)
            u = b.to_unit(fm.from_paper(p, state)[0])
            assert np.all((u > 0) & (u < 1)), (name, state, u)
    assert b.amplitude_mm == pytest.approx(10.0, rel=0.02)  # ±10 mm, peaks rounded by the reversal blend
    U = np.random.default_rng(2).uniform(size=(5, 6))
    np.testing.assert_allclose(b.to_unit(b.from_unit(U)), U, atol=1e-12)
    assert b.log.tolist() == [True, True, False, True, True, False]


def small_case():
    """L = 30 samples, p = 3 free coefficients (c+, k+, h+): one branch, no offsets, m fixed."""
    t = np.arange(30) * 0.1
    x = np.sin(0.5 * t) + 0.3 * t
    e = excitation.Excitation("test", t, x, 0.5 * np.cos(0.5 * t) + 0.3, -0.25 * np.sin(0.5 * t))
    w = np.tanh(2 * x)
    f = 3 * e.v + 2 * x + 5 * w + np.random.default_rng(3).normal(0, 0.5, len(t))
    design = ls.LinearDesign(e, f, LAYOUT, fix_mass=0.0, offsets=False)
    sol = design.solve(w[None])
    X = np.column_stack([{"c+": e.v, "k+": x, "h+": w}[n] for n in sol.free_names])
    return f, X, sol


def test_marginal_likelihood_matches_numerical_integration():
    f, X, sol = small_case()
    L, p = X.shape
    assert p == 3 and sol.n_free == 3
    # Dense trapezoid grid over β: β = β̂ + B·u, B a square root of (XᵀX)⁻¹ computed independently.
    beta_hat = np.linalg.solve(X.T @ X, X.T @ f)
    B = np.linalg.cholesky(np.linalg.inv(X.T @ X))
    u = np.linspace(-8, 8, 65)
    U = np.stack(np.meshgrid(u, u, u, indexing="ij"), -1).reshape(-1, 3)
    S = np.sum((f[None, :] - (beta_hat + U @ B.T) @ X.T) ** 2, axis=1)
    log_cell = 3 * np.log(u[1] - u[0]) + np.log(abs(np.linalg.det(B)))
    sigma = 0.5
    numeric = logsumexp(-L / 2 * np.log(2 * np.pi * sigma**2) - S / (2 * sigma**2)) + log_cell
    assert abs(mg.log_marginal(sol, sigma)[0] - numeric) < 1e-6
    # σ too, under p(σ) = 1/σ: a trapezoid grid in log σ (dσ/σ = d log σ).
    log_s = np.linspace(np.log(0.1), np.log(3.0), 300)
    per_sigma = [logsumexp(-L * ls_ - L / 2 * np.log(2 * np.pi) - S / (2 * np.exp(2 * ls_))) for ls_ in log_s]
    numeric = logsumexp(per_sigma) + np.log(log_s[1] - log_s[0]) + log_cell
    assert abs(mg.log_marginal(sol)[0] - numeric) < 1e-6


def test_conditional_draws_have_the_posterior_mean_and_covariance():
    f, X, sol = small_case()
    L, p = X.shape
    draws = mg.draw_linear(sol.row(0), np.random.default_rng(0), 200_000)
    beta = draws["coef"][:, sol.free_index]
    k = (L - p) / 2
    mean_s2 = sol.rss_ls[0] / 2 / (k - 1)  # E[σ²] of Inv-Gamma(k, RSS/2)
    assert np.mean(draws["sigma"] ** 2) == pytest.approx(mean_s2, rel=0.01)
    cov = mean_s2 * np.linalg.inv(X.T @ X)
    sd = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(beta.mean(0), np.linalg.lstsq(X, f, rcond=None)[0], atol=0.01 * sd.max())
    np.testing.assert_allclose(np.cov(beta.T) / np.outer(sd, sd), cov / np.outer(sd, sd), atol=0.02)
    assert np.all(draws["coef"][:, 0] == 0.0) and np.all(np.isnan(draws["coef"][:, 5:]))


def test_residual_vector_is_model_minus_measured_and_finite_on_blow_up():
    e, f, p = load("pom-mt24u01_0.05MPa_r1")
    M = IdentifiableModel(e, f, "shared")
    theta = fm.from_paper(p)[0]
    r = M.residual(theta)
    sol = M.solve(theta[None])
    c = dict(zip(fm.LINEAR_NAMES, sol.coef[0]))
    w = M.trajectories(theta[None])[0]
    plus = e.v >= 0
    F = c["m"] * e.a + np.where(
        plus,
        c["c+"] * e.v + c["k+"] * e.x + c["h+"] * w + c["f+"],
        c["c-"] * e.v + c["k-"] * e.x + c["h-"] * w + c["f-"],
    )
    np.testing.assert_allclose(r, F - f, atol=1e-9 * np.ptp(f))
    assert np.mean(r**2) == pytest.approx(sol.mse[0], rel=1e-12)
    runaway = M.bounds.from_unit(np.array([0.9, 0.9, 0.99, 0.1, 0.9, 0.99, 0.01]))
    r_bad = M.residual(runaway)
    assert np.all(np.isfinite(r_bad)) and np.mean(r_bad**2) > np.mean(f**2)
    np.testing.assert_allclose(M.residual_unit(M.bounds.to_unit(theta)), r, rtol=0, atol=1e-6 * np.ptp(f))


def test_a_finite_but_huge_trajectory_is_a_blow_up_not_a_crash():
    # Found by lsq-trf on this specimen: w reaches 1.5e277 (finite), and the linear solve overflowed
    # into "array must not contain infs or NaNs" from scipy instead of a loss of +inf.
    from paper_problems import IdentifiableProblem

    problem = IdentifiableProblem(read_specimen(DATA / "pc-abs-c12hf_0.01MPa_r1.csv"))
    theta = np.array([0.50669315, 1.14039746, 0.88825619, 0.00194327, 0.99384954, 0.80172319, 0.23632528])
    assert np.all(np.isfinite(problem.model.trajectories(theta[None], problem.signal, problem.state)))
    assert problem.loss_batch(theta[None])[0] == np.inf
    assert np.all(problem.residual_batch(theta[None]) == np.inf)
    on_signal = IdentifiableModel(problem.signal, problem.specimen.f)
    assert np.all(on_signal.residual(theta) == on_signal.penalty)
    mse, log_marginal = problem.log_likelihood_batch(
        np.vstack([theta, problem.lower + 0.5 * (problem.upper - problem.lower)])
    )
    assert mse[0] == np.inf and log_marginal[0] == -np.inf and np.isfinite(mse[1])
