"""Parameters as laws of the control (``bwbench.problems.hysteresis.control``): the laws, the exact
Jacobian through them, and a damper simulated with known laws giving them back."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from bwbench.errors import UserError
from bwbench.models.spencer.model import MODEL
from bwbench.problems.hysteresis.control import generator as controlled
from bwbench.problems.hysteresis.control import laws
from bwbench.problems.hysteresis.control.lag import filtered
from bwbench.problems.hysteresis.control.problem import build

TESTS = [
    controlled.Test("a0", 20, 1.0, 0.0),
    controlled.Test("a1", 20, 1.0, 1.0),
    controlled.Test("a2", 10, 2.0, 2.25),
    controlled.Test("b1", 15, 1.5, 0.5),
]
TRUTH = controlled.SPENCER_LAWS.params


@pytest.fixture(scope="module")
def specimens():
    return controlled.simulate(controlled.SPENCER_LAWS, TESTS, noise_N=2.0, seed=1)


def test_the_laws_are_their_values_at_the_nodes():
    u = np.array([0.0, 0.5, 1.0, 2.0])
    lin = laws.law_of("linear")
    np.testing.assert_allclose(lin.value(np.array([1.0, 3.0]), u, lin.nodes(0, 2)), [1, 1.5, 2, 3])
    quad = laws.law_of("quadratic")
    np.testing.assert_allclose(quad.value(np.array([0.0, 1.0, 4.0]), u, quad.nodes(0, 2)), u**2)
    assert quad.monomials([0.0, 1.0, 4.0], quad.nodes(0, 2)) == {
        "formula": "θ(u) = a0 + a1·u + a2·u²",
        "a0": 0.0,
        "a1": 0.0,
        "a2": 1.0,
    }
    exp = laws.law_of("exponential")
    np.testing.assert_allclose(exp.value(np.array([1.0, np.e**2]), u, exp.nodes(0, 2)), np.exp(u))
    assert exp.monomials([1.0, np.e**2], exp.nodes(0, 2))["b"] == pytest.approx(1.0)
    mine = laws.CallableLaw(lambda u, a, b: a / (1 + b * u), {"a": (1, 10), "b": (0, 5)})
    np.testing.assert_allclose(mine.jacobian(np.array([2.0, 1.0]), u, None)[:, 1], -2 * u / (1 + u) ** 2, rtol=1e-6)


def test_the_law_flag_is_parsed_and_bad_laws_refused(specimens):
    assert laws.parse("vy=linear, c1=quadratic") == {"vy": "linear", "c1": "quadratic"}
    with pytest.raises(UserError, match="unknown law 'cubic' for vy"):
        laws.parse("vy=cubic")
    with pytest.raises(UserError, match="has no parameter 'alpha'; its parameters are xy, n, eta, vy, r0, kappa0, c1"):
        build(specimens, {"model": "spencer"}, {"alpha": "linear"})
    with pytest.raises(UserError, match="c1 is solved by least squares, so its law must be linear"):
        build(specimens, {"model": "spencer"}, {"c1": "exponential"})
    with pytest.raises(UserError, match="an exponential law keeps its parameter positive, and eta's box reaches -50"):
        build(specimens, {"model": "spencer"}, {"eta": "exponential"})
    with pytest.raises(UserError, match=r"a quadratic law needs 3 control levels, the files have 2 \(0, 1 V\)"):
        build(specimens[:2], {"model": "spencer"}, {"vy": "quadratic"})


def test_the_exact_jacobian_through_the_laws_matches_differences(specimens):
    problem = build(specimens, {"model": "spencer"}, {"vy": "linear", "c1": "linear", "r0": "quadratic"})
    tight = copy.copy(MODEL)  # a tight integration: differences of an adaptive step's force are smooth enough
    tight.tolerance, tight.pace = 1e-9, 2000
    problem.model = tight
    assert problem.param_names == ("xy", "n", "eta", "vy@0V", "vy@2.25V", "r0@0V", "r0@1.125V", "r0@2.25V", "kappa0")
    # the sensitivities are those of the model's equations on its own steps: within 1e-3–1e-2 of the force's derivative (η: 1 %)
    c = np.array([0.05, 2.0, 0.3, 20.0, 40.0, 0.1, 0.12, 0.14, 0.2])
    r, J = problem.residual_jacobian(c)
    np.testing.assert_allclose(r, problem.residual_batch(c[None, :])[0], atol=1e-9)
    for j in range(len(c)):
        h = 1e-5 * abs(c[j])
        up, down = c.copy(), c.copy()
        up[j] += h
        down[j] -= h
        diff = (problem.residual_batch(up[None, :])[0] - problem.residual_batch(down[None, :])[0]) / (2 * h)
        assert np.linalg.norm(J[:, j] - diff) <= 1e-2 * np.linalg.norm(diff), problem.param_names[j]


def test_the_exact_jacobian_under_a_switching_filtered_control_matches_differences():
    """Per-interval sensitivities to the law coefficients (``spencer_varying``), the filter's rate by a difference."""
    records = [
        controlled.Test("s", 20, 1.0, 2.25, switch_hz=3.0, cycles=1.0),
        controlled.Test("a1", 20, 1.0, 1.0, cycles=1.0),
    ]
    problem = build(
        controlled.simulate(controlled.SPENCER_LAWS, records, 2.0, seed=2),
        {"model": "spencer"},
        {"vy": "linear", "c1": "linear"},
        control_filter=True,
    )
    tight = copy.copy(MODEL)
    tight.tolerance, tight.pace = 1e-9, 2000
    problem.model = tight
    assert problem.param_names[-1] == "eta_u" and problem.jacobian_cost == 2 * 3 + 1
    c = np.array([0.05, 2.0, 0.3, 20.0, 40.0, 0.1, 0.2, 80.0])
    r, J = problem.residual_jacobian(c)
    np.testing.assert_allclose(r, problem.residual_batch(c[None, :])[0], atol=1e-9)
    for j in range(len(c)):
        h = 1e-5 * abs(c[j])
        up, down = c.copy(), c.copy()
        up[j] += h
        down[j] -= h
        diff = (problem.residual_batch(up[None, :])[0] - problem.residual_batch(down[None, :])[0]) / (2 * h)
        assert np.linalg.norm(J[:, j] - diff) <= 2e-2 * np.linalg.norm(diff), problem.param_names[j]


def _within(problem, params, sigmas=3.5):
    off = {}
    for row in problem.law_table(params):
        if row["name"] in TRUTH:
            off[row["name"]] = (row["value"] - TRUTH[row["name"]]) / row["stderr"]
    assert all(abs(v) <= sigmas for v in off.values()), off
    return off


def test_constant_levels_give_the_laws_back_within_their_intervals(specimens):
    from bwbench.problems.hysteresis.fit_result import run_fit

    problem = build(specimens, {"model": "spencer"}, {"vy": "linear", "c1": "linear"})
    fit = run_fit(problem, "lsq-trf", 1500, 0, stop="agreed")
    assert fit.result.mse == pytest.approx(4.0, rel=0.15)  # the 2 N noise
    off = _within(problem, fit.result.params)
    assert set(off) == set(TRUTH)


def test_a_switching_control_gives_the_laws_back(specimens):
    """One record under a command switching 0/2.25 V six times a second, with one at 1 V: the kernel
    sees per-interval parameters; the least squares from the truth's neighbourhood stays at it."""
    from scipy.optimize import least_squares

    switching = controlled.simulate(
        controlled.SPENCER_LAWS, [controlled.Test("s", 20, 1.0, 2.25, switch_hz=3.0)], noise_N=2.0, seed=2
    )
    problem = build([switching[0], specimens[1]], {"model": "spencer"}, {"vy": "linear", "c1": "linear"})
    assert problem.varying and problem.jacobian_cost == 2 * (1 + 2)  # the state's sensitivities and two blocks
    c0 = np.array([TRUTH[n] for n in problem.param_names]) * 1.1
    c0[problem.param_names.index("eta")] = 0.05
    found = least_squares(
        lambda u: problem.residual_batch(problem.from_unit(u)[None, :])[0], problem.to_unit(c0), x_scale="jac"
    )
    params = problem.parameters(problem.from_unit(found.x))
    _within(problem, params)


def test_the_filter_is_the_exact_lag_of_a_held_command():
    t = np.arange(0, 0.1, 0.001)
    v = np.where(t >= 0.02, 2.0, 0.0)
    u, mean = filtered(v, np.diff(t), 100.0)
    after = t >= 0.02
    np.testing.assert_allclose(u[after], 2.0 * (1 - np.exp(-100.0 * (t[after] - 0.02))), atol=1e-12)
    assert np.all((mean >= np.minimum(u[:-1], u[1:]) - 1e-12) & (mean <= np.maximum(u[:-1], u[1:]) + 1e-12))


def test_auto_takes_the_smallest_law_the_points_need_beyond_their_errors():
    from bwbench.problems.hysteresis.control.auto import choose

    u = [0.0, 0.25, 0.5, 0.75, 1.0]
    flat = choose("k1", u, [0.50, 0.52, 0.49, 0.51, 0.50], [0.02] * 5)
    assert flat.law == "constant" and "constant χ² 1.3 on 4 dof" in flat.reason
    line = choose("c1", u, [30.0, 52.6, 75.1, 97.4, 120.2], [0.3] * 5, "N·s/mm", "current_A")
    assert line.law == "linear" and line.chi2["constant"][0] > 1e4
    assert choose("alpha", u, [10, 30, 60, 100, 150], [0.5] * 5).law == "quadratic"
    grows = 3.63 * np.exp(0.8 * np.array(u))
    assert choose("gamma", u, grows, 0.003 * grows).law == "exponential"
    assert choose("n", u, [2.0, 1.9, np.nan, 2.1, 2.0], [0.1] * 5).law == "constant"


def test_the_result_json_predicts_the_fitted_files_and_a_level_no_file_had(specimens, tmp_path):
    import json

    from bwbench.problems.hysteresis.control.fitted import model_of_result
    from bwbench.problems.hysteresis.fit_result import run_fit

    problem = build(specimens, {"model": "spencer"}, {"vy": "linear", "c1": "linear"})
    fit = run_fit(problem, "lsq-trf", 600, 0, stop="agreed")
    fit.write_json(tmp_path / "fit.json")
    data = json.loads((tmp_path / "fit.json").read_text())
    assert data["control"]["laws"]["c1"]["coefficients"] == ["c1@0V", "c1@2.25V"]
    model = model_of_result(data)
    for row, spec in zip(fit.files, specimens):
        assert model.predict(spec).nrmse == pytest.approx(row["nrmse"], rel=1e-9)
    unseen = controlled.simulate(controlled.SPENCER_LAWS, [controlled.Test("u", 15, 1.5, 1.75)], 2.0, seed=9)[0]
    assert model.predict(unseen).rmse_N < 2.5  # the 2 N noise: the laws carry the fit to 1.75 V
    assert model.at(1.75).params["vy"] == pytest.approx(3.2 + (38.0 - 3.2) * 1.75 / 2.25, rel=0.01)


def test_leave_one_level_out_predicts_a_held_out_level_better_than_the_nearest_constants(specimens):
    from bwbench.problems.hysteresis.control.levels import compare_levels

    comparison = compare_levels(
        specimens, {"model": "spencer"}, {"vy": "linear", "c1": "linear"}, budget=600, left_out=[1.0]
    )
    rows = {r["level"]: r for r in comparison.rows}
    assert set(rows) == {0.0, 0.5, 1.0, 2.25} and rows[0.0]["left_out"] is None
    held = rows[1.0]
    assert held["left_out"] < 0.1 * held["nearest"]  # the laws carry v_y and c1 to 1 V; 0.5 V's constants do not
    assert held["left_out"] < 1.1 * held["laws"]
    assert "| a1 | 1 |" in comparison.table() and "the laws better on 1 of 1 files" in comparison.summary()


def test_the_command_line_fits_laws_and_predicts_a_level_from_a_flag(specimens, tmp_path, capsys, monkeypatch):
    import json

    from bwbench.cli import main

    paths = controlled.write(specimens, tmp_path / "data")
    monkeypatch.chdir(tmp_path)
    out = ["--out", "fit.json", "--laws-figure", "laws.png"]
    assert (
        main(
            [
                "fit",
                *paths,
                "--model",
                "spencer",
                "--control",
                "voltage_V",
                "--law",
                "vy=linear",
                "--budget",
                "60",
                *out,
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "laws of voltage_V (vy linear):" in printed and "vy@2.25V = " in printed and "mm/s" in printed
    result = json.loads((tmp_path / "fit.json").read_text())
    assert result["control"]["laws"]["vy"]["nodes"] == [0.0, 2.25] and (tmp_path / "laws.png").stat().st_size > 10_000
    bare = tmp_path / "bare.csv"  # the 0.5 V test without its column: the level from the flag
    bare.write_text(
        "\n".join(",".join(line.split(",")[:4]) for line in (tmp_path / "data" / "b1.csv").read_text().splitlines())
    )
    assert main(["predict", "--fit", "fit.json", str(bare), "--control", "voltage_V=0.5"]) == 0
    assert "bare: RMSE" in capsys.readouterr().out
    assert main(["simulate", "--params", "fit.json", "--specimen", paths[1], "--out", "sim.csv"]) == 0
    assert (tmp_path / "sim.csv").read_text().startswith("time_s,displacement_mm,velocity_mm_s,voltage_V,force_model_N")
    assert main(["predict", "--fit", "fit.json", str(bare)]) == 2
    assert "no column voltage_V and no voltage_V level for this file" in capsys.readouterr().err
