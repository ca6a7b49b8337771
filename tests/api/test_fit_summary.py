"""FitResult.summary(), .correlation(), .report(): standard errors from the Jacobian at the optimum (the
solved coefficients through the variable-projection covariance), checked against the spread of fits to
noise re-draws of a toy where the linearisation holds."""

import math
import warnings

import numpy as np
import pandas as pd
import pytest

import bwbench
from api_toy import TRUTH, toy_frame

FIT = {"model": "bouc-wen", "budget": 200, "seed": 0, "fix_mass": 0.0}


def quiet_fit(data, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bwbench.FitWarning)
        return bwbench.fit(data, **{**FIT, **kw})


@pytest.fixture(scope="module")
def toy_fit():
    return quiet_fit(toy_frame(0))


def test_standard_errors_match_the_spread_of_fits_to_noise_redraws():
    fits = [quiet_fit(toy_frame(100 + k)) for k in range(30)]
    values = pd.DataFrame([f.summary()["value"] for f in fits])
    errors = pd.DataFrame([f.summary()["stderr"] for f in fits])
    checked = ["xy", "n", "eta", "k", "c", "f", "h", "alpha", "wn", "xi"]  # searched, solved, derived
    ratio = values[checked].std() / errors[checked].mean()
    assert ratio.between(0.65, 1.5).all(), ratio
    assert ratio.median() == pytest.approx(1.0, abs=0.1)
    # The fits scatter around the truth by about their error: no bias the errors hide.
    free = ["xy", "n", "eta", "c", "k", "h", "f"]
    z = (values[free].mean() - pd.Series(TRUTH)[free]) / (errors[free].mean() / math.sqrt(len(fits)))
    assert (z.abs() < 4).all(), z


def test_the_solved_coefficients_inherit_the_uncertainty_of_the_searched_ones(toy_fit):
    # At θ fixed, the linear fit alone gives h's conditional error s·√((XᵀX)⁻¹); the variable-projection
    # error is larger, as h trades off against x_y (the spread test above shows the larger one is right).
    problem, unc = toy_fit.problem, toy_fit.uncertainty
    theta = np.array([toy_fit.params[n] for n in problem.param_names])
    R = problem.solve(theta[None, :]).R[0]
    conditional = np.sqrt(unc.s2 * np.diag(np.linalg.inv(R.T @ R)))
    h = problem.design.free_names.index("h")
    assert toy_fit.summary().loc["h", "stderr"] > 1.4 * conditional[h]  # 0.31 N against 0.18 N (spread: 0.30 N)


def test_summary_has_every_parameter_with_its_unit_role_and_edge(toy_fit):
    s = toy_fit.summary()
    assert list(s.columns) == ["value", "stderr", "unit", "role", "at_edge", "lower", "upper"]
    assert s.loc[["xy", "n", "eta"], "role"].eq("searched").all()
    assert s.loc[["k", "c", "f", "h"], "role"].eq("solved").all()
    assert s.loc["m", "role"] == "held" and math.isnan(s.loc["m", "stderr"])  # fix_mass=0: no error
    assert s.loc[["alpha", "wn", "xi"], "role"].eq("derived").all()
    assert s.loc["xy", "unit"] == "mm" and s.loc["h", "unit"] == "N" and s.loc["c", "unit"] == "N·s/mm"
    free = s[s["role"].isin(["searched", "solved"])]
    assert np.isfinite(free["stderr"]).all() and (free["stderr"] > 0).all()
    assert not s["at_edge"].any()
    assert s.loc["c", "lower"] == 0.0  # the linear solve's bound on the viscous coefficient


def test_a_parameter_held_on_its_box_edge_is_flagged():
    fit = quiet_fit(toy_frame(0), bounds={"n": (1.7, 3.0)})  # the truth (1.5) lies outside
    s = fit.summary()
    assert s.loc["n", "at_edge"] and s.loc["n", "value"] == pytest.approx(1.7, rel=1e-3)
    assert not s.loc["xy", "at_edge"]


def test_correlation_is_the_covariance_normalised(toy_fit):
    c = toy_fit.correlation()
    assert list(c.index) == list(c.columns) == ["xy", "n", "eta", "k", "c", "f", "h"]
    assert np.allclose(c.values, c.values.T) and np.allclose(np.diag(c.values), 1.0)
    cov = toy_fit.uncertainty.cov
    assert c.loc["xy", "eta"] == pytest.approx(cov[0, 2] / math.sqrt(cov[0, 0] * cov[2, 2]))
    assert c.loc["xy", "eta"] < -0.8  # a larger yield displacement is traded against a lower unloading ratio


def test_report_reads_like_lmfit_fit_report(toy_fit):
    text = toy_fit.report()
    n, p = 400, 7
    chi2 = toy_fit.mse * n
    assert "[[Fit Statistics]]" in text and "[[Variables]]" in text and "[[Correlations]]" in text
    assert f"# data points      = {n}" in text and f"# variables        = {p} (3 searched, 4 solved)" in text
    assert f"chi-square         = {chi2:.6g} N²" in text
    aic = n * math.log(chi2 / n) + 2 * p
    assert f"Akaike info crit   = {aic:.6g}" in text
    se = toy_fit.summary().loc["xy", "stderr"]
    assert "xy:" in text and f"+/- {se:.6g} mm" in text
    assert "m:     0 N·s²/mm (1 N·s²/mm = 1 t = 1000 kg) (held)" in text
    assert "[[Findings]]" in text and "m fixed at 0 by the caller" in text


def test_exact_symmetries_of_the_paper_formulation_are_not_determined():
    # The switched model's own 14 parameters have exact invariances (a scale of z traded against A, β,
    # γ, α, ωn, ξ): no finite error along them; the identifiable formulation removes them.
    path = "data/specimens/pom-mt24u01_0.01MPa_r1.csv"
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / path
    paper = quiet_fit(path, model=None, fix_mass="auto", optimizer="cmaes", budget=150)
    s = paper.summary()
    assert s.loc["A+", "stderr"] == math.inf and s.loc["alpha-", "stderr"] == math.inf
    assert "not determined by the data" in paper.report() and "formulation='identifiable'" in paper.report()
