"""Model evidence comparable between models: the per-θ likelihood it integrates is a density of the data
for every model and formulation (a change of the force's unit moves it by −L·log s, whatever the model's
number of linear coefficients), and a Bayes factor is ranked and worded per specimen."""

import numpy as np
import pandas as pd
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.problems.hysteresis.formulations import make_problem
from bwbench.problems.hysteresis.report.model_evidence import (
    direct_constant,
    log_likelihoods,
    log_mean_exp,
    shown,
    verdicts,
)
from robustness_helpers import REPO

SPECIMEN = REPO / "data" / "mr_damper" / "mr_10mm_2Hz_1V.csv"
SCALE = 1000.0  # N -> mN


@pytest.fixture(scope="module")
def specimens(tmp_path_factory):
    text = SPECIMEN.read_text().splitlines()
    rows = np.loadtxt(SPECIMEN, delimiter=",", skiprows=1)
    rows[:, 3] *= SCALE
    path = tmp_path_factory.mktemp("unit") / "scaled.csv"
    np.savetxt(path, rows, delimiter=",", header=text[0], comments="", fmt="%.10g")
    return read_specimen(SPECIMEN), read_specimen(path)


@pytest.mark.parametrize(
    "model, formulation",
    [("bouc-wen", "identifiable"), ("spencer", "identifiable"), ("switched-bouc-wen", "identifiable")],
)
def test_the_comparable_likelihood_is_a_density_of_the_data(specimens, model, formulation):
    settings = {"model": model, "formulation": formulation, "state": "shared", "excitation": "measured"}
    newton, milli = (make_problem(s, settings) for s in specimens)
    P = newton.from_unit(np.random.default_rng(3).uniform(0.3, 0.7, (6, newton.dim)))
    (s_n, c_n), (s_m, c_m) = log_likelihoods(newton, P), log_likelihoods(milli, P)
    ok = np.isfinite(c_n) & np.isfinite(c_m)
    assert ok.sum() >= 3
    L = newton.n_data
    assert c_m[ok] - c_n[ok] == pytest.approx(-L * np.log(SCALE), abs=1e-6 * L)
    # the sampler's own marginal is not: it moves by −(L − p_G)·log s, p_G differing between models
    assert np.all(np.abs((s_m - s_n)[ok] + L * np.log(SCALE)) > 1.0)


def test_the_direct_constant_is_jeffreys_sigma_integrated_out():
    """(A direct formulation's force does not scale with the data's unit: its constant is checked here.)"""
    from scipy.integrate import quad

    L, mse = 40, 2.5  # ∫ N(r; 0, σ²)^L · dσ/σ for residuals of mean square mse, against −(L/2)·log mse
    rss = L * mse
    expected = -0.5 * L * np.log(mse) + direct_constant(L)
    # the integrand divided by exp(expected), so that quad's absolute tolerance is meaningful
    ratio, _ = quad(
        lambda s: np.exp(-L * np.log(s) - 0.5 * L * np.log(2 * np.pi) - rss / (2 * s * s) - expected) / s,
        1e-2,
        100,
        limit=200,
        points=[np.sqrt(mse)],
    )
    assert ratio == pytest.approx(1.0, rel=1e-6)


def test_log_mean_exp_and_its_error():
    z, err = log_mean_exp(np.log([1.0, 2.0, 3.0, np.nan]))
    assert z == pytest.approx(np.log(2.0)) and err == pytest.approx(np.std([1, 2, 3], ddof=1) / np.sqrt(3) / 2)


def frame():
    rows = [
        ("switched-bouc-wen", -2600.0, 1.0, "mr", 12, 0.31, 0.64, 0.13),
        ("spencer", -2000.0, 1.5, "mr", 9, 0.05, 0.2, 0.13),
        ("bouc-wen", -2900.0, 0.8, "mr", 8, 0.5, 0.7, 0.13),
        ("switched-bouc-wen", -50.0, 0.5, "vpp", 12, 0.05, 0.1, 0.2),
        ("spencer", -51.0, 0.9, "vpp", 9, 0.06, 0.1, 0.2),
    ]
    out = pd.DataFrame(
        rows,
        columns=["model", "ln Z", "±", "specimen", "n", "outside", "residual near reversals", "samples near reversals"],
    )
    out["box shift"] = -out.pop("n") * np.log(2)
    out["converged"] = True
    out["best log-likelihood"] = [-2590.0, -1980.0, -2880.0, -45.0, -48.0]
    out["band draws"] = [200, 200, 2, 200, 200]  # bouc-wen's run on "mr" kept 2 draws
    out.insert(3, "ln B against the best", out["ln Z"] - out.groupby("specimen")["ln Z"].transform("max"))
    return out


def test_the_table_reads_model_ln_z_error_bayes_factor_specimen_first():
    table = shown(frame())
    assert list(table.columns[:5]) == ["model", "ln Z", "±", "ln B against the best", "specimen"]
    assert list(table["ln B against the best"]) == ["-600.00", "+0.00", "-900.00", "+0.00", "-1.00"]
    assert list(table["best log-likelihood (ln Z ≤)"])[:2] == ["-2590.0", "-1980.0"]
    assert list(table["outside the 95 % band"])[:3] == ["31.0 %", "5.0 %", "50.0 % (from 2 draws: no check)"]


def test_the_verdict_names_the_favoured_model_and_says_when_the_data_do_not_decide():
    mr, vpp = verdicts(frame())
    assert "favours **spencer** — ln B = 600.0 ± 1.8 over the next, switched-bouc-wen" in mr
    assert (
        "does not hang on the box" in mr and "64 % of its squared residual near reversals (13 % of the samples)" in mr
    )
    assert "; bouc-wen's measured force" not in mr  # its band rests on 2 draws: no check to report
    assert "Conclusive whatever the other runs' convergence" in mr  # −2000 − 2·1.5 > −2590, the next model's bound
    assert "favours **switched-bouc-wen**" in vpp and "the data do not decide between them" in vpp
    assert "Conclusive" not in vpp  # ln Z −50 is below spencer's best log-likelihood −48
