"""Fits of measured-like records as an engineer reads them: physical limits as findings, checks that
can fail, the inertia rule on a ramped sine's steady part, a start from rest without a spike, and
the provenance and NRMSEs of the result JSON."""

import hashlib
import json
import re

import numpy as np
import pytest

from bwbench.cli import main
from bwbench.data.specimen import read_specimen
from bwbench.data.steady_part import steady_part
from bwbench.models import excitation, registry
from bwbench.models.start import starts_from_rest
from bwbench.problems.hysteresis import fit_checks
from bwbench.problems.hysteresis.inertia_rule import SINE_TOLERANCE, inertia_check, sine_test
from bwbench.problems.hysteresis.model_problem import IdentifiableProblem

SPENCER = registry.get("spencer")
# Spencer et al. (1997) at 1 V in N, mm, s: c0 c1 (N·s/mm), k0 k1 (N/mm), x0 (mm), α (N/mm), β γ (mm⁻²), A, n.
SPENCER_1V = np.array([2.45, 28.595, 4.69, 0.5, 143.0, 83.5, 3.63, 3.63, 301.0, 2.0])
RATE, FREQ, AMP = 500.0, 2.0, 10.0


def ramped_sine(steady_cycles=3, ramp=True):
    """t (s), x (mm), ẋ (mm/s) of a sine from rest, its amplitude ramped in over the first cycle and out
    over the last (raised cosine), ``steady_cycles`` between."""
    cycles = steady_cycles + 2
    t = np.arange(0.0, cycles / FREQ + 0.5 / RATE, 1.0 / RATE)
    T, w = 1.0 / FREQ, 2 * np.pi * FREQ
    env, denv = np.ones_like(t), np.zeros_like(t)
    if ramp:
        up, down = t < T, t > t[-1] - T
        env[up], denv[up] = 0.5 * (1 - np.cos(np.pi * t[up] / T)), 0.5 * np.pi / T * np.sin(np.pi * t[up] / T)
        s = t[-1] - t[down]
        env[down], denv[down] = 0.5 * (1 - np.cos(np.pi * s / T)), -0.5 * np.pi / T * np.sin(np.pi * s / T)
    return t, AMP * env * np.sin(w * t), AMP * (denv * np.sin(w * t) + env * w * np.cos(w * t))


def write(path, t, x, v, f):
    with open(path, "w") as fh:
        fh.write("time_s,displacement_mm,velocity_mm_s,force_N\n")
        for row in zip(t, x, v, f):
            fh.write(",".join(f"{value:.9g}" for value in row) + "\n")
    return path


def spencer_record(path, params=SPENCER_1V, noise_N=2.0, seed=0):
    """A ramped sine from rest with Spencer's force at ``params`` (direct), velocity recorded with 0.2 mm/s
    noise (so its first sample is not exactly 0) and ``noise_N`` of force noise."""
    rng = np.random.default_rng(seed)
    t, x, v = ramped_sine()
    v = v + rng.normal(0, 0.2, len(t))
    write(path, t, x, v, np.zeros_like(t))
    signal = excitation.of_specimen("measured", read_specimen(path))
    force = SPENCER.force_batch(np.asarray(params)[None, :], signal)[0]
    return read_specimen(write(path, t, x, v, force + rng.normal(0, noise_N, len(t))))


def true_theta(params):
    theta, _ = SPENCER.from_direct(params)
    return theta


def test_a_fit_that_would_need_a_negative_accumulator_stiffness_reports_it(tmp_path):
    params = SPENCER_1V.copy()
    params[3] = -2.0  # k1 (N/mm): a spring that pulls the rod further the further it goes
    spec = spencer_record(tmp_path / "k1.csv", params)
    problem = IdentifiableProblem(SPENCER, spec)
    assert problem.design.bounds["k1"] == (0.0, np.inf)
    checks = fit_checks.check(problem, true_theta(params))
    limit = checks.json["physical_limits"]["k1"]
    assert limit["value"] == 0.0 and limit["unbounded"] == pytest.approx(-2.0, abs=0.05)
    assert limit["rmse_unbounded_N"] < limit["rmse_N"]
    (finding,) = [f for f in checks.findings if f.startswith("k1 = 0")]
    assert "held on its physical limit" in finding and "cannot do physically" in finding
    # the same data with Spencer's own k1 = 0.5 N/mm: nothing to report
    clean = IdentifiableProblem(SPENCER, spencer_record(tmp_path / "ok.csv"))
    assert "physical_limits" not in fit_checks.check(clean, true_theta(SPENCER_1V)).json


def test_the_energy_check_fails_on_a_deliberately_bad_fit_and_passes_on_the_truth(tmp_path):
    problem = IdentifiableProblem(SPENCER, spencer_record(tmp_path / "s.csv"))
    good = fit_checks.check(problem, true_theta(SPENCER_1V))
    assert good.json["energy_check"]["passed"] and good.json["energy_check"]["worst_mismatch"] < 0.01
    bad_theta = true_theta(SPENCER_1V).copy()
    bad_theta[0] *= 30  # x_y: a yield 30 times rounder
    bad_theta[1], bad_theta[2] = 1.0, 0.9  # n, η
    bad = fit_checks.check(problem, bad_theta)
    assert not bad.json["energy_check"]["passed"] and bad.json["energy_check"]["worst_mismatch"] > 0.05
    assert any(f.startswith("energy check failed") for f in bad.findings)
    assert bad.json["residual_structure"]["model_error_dominates"]
    assert not good.json["residual_structure"]["model_error_dominates"]


def test_a_ramped_sine_is_a_sine_test_on_its_steady_part(tmp_path):
    t, x, v = ramped_sine()
    steady = steady_part(t, x)
    assert (steady.ramp_in_cycles, steady.ramp_out_cycles) == (1.0, 1.0)
    assert t[steady.start] == pytest.approx(0.5, abs=2 / RATE) and t[steady.stop - 1] == pytest.approx(
        2.0, abs=2 / RATE
    )
    # the whole record is not a sine within the tolerance, its steady part is
    from bwbench.models.excitation import fit_sine

    sine = fit_sine(t, x)
    assert np.sqrt(np.mean((sine.evaluate(t)[0] - x) ** 2)) > SINE_TOLERANCE * AMP
    a, judged = sine_test(t, x)
    assert judged is not None and judged.ramped
    assert np.allclose(a, -((2 * np.pi * FREQ) ** 2) * x, atol=1e-6 * AMP * (2 * np.pi * FREQ) ** 2)
    spec = spencer_record(tmp_path / "s.csv")
    check = inertia_check(excitation.of_specimen("measured", spec), spec.f, SPENCER.linear_layout())
    assert check.sine_segments == 1 and "judged on its steady part" in check.reason
    # a sine without ramps is a sine test on the whole record, and says nothing of ramps
    t2, x2, _ = ramped_sine(ramp=False)
    assert not steady_part(t2, x2).ramped and sine_test(t2, x2)[1] is None


def test_a_random_record_has_no_steady_part_and_no_ramps():
    rng = np.random.default_rng(3)
    t = np.arange(0, 8, 1 / RATE)
    x = np.cumsum(rng.normal(0, 1, len(t)))
    x = np.convolve(x - x.mean(), np.ones(50) / 50, mode="same")
    assert not steady_part(t, x).ramped


def test_data_check_flags_the_ramps(tmp_path, capsys):
    t, x, v = ramped_sine()
    path = write(tmp_path / "r.csv", t, x, v, 100 * np.sin(2 * np.pi * FREQ * t + 0.3) * (np.abs(x) + 1))
    assert main(["data", "check", str(path)]) == 0
    out = capsys.readouterr().out
    found = re.search(
        r"ramps: ramp-in 1 cycle \(([\d.]+) s\), ramp-out 1 cycle \(([\d.]+) s\); steady part "
        r"t = ([\d.]+) … ([\d.]+) s",
        out,
    )
    assert found is not None, out
    ramp_in, ramp_out, start, stop = map(float, found.groups())
    assert ramp_in == pytest.approx(0.5, abs=2 / RATE) and ramp_out == pytest.approx(0.5, abs=2 / RATE)
    assert start == pytest.approx(0.5, abs=2 / RATE) and stop == pytest.approx(2.0, abs=2 / RATE)


def test_a_record_that_starts_from_rest_starts_the_model_from_rest_without_a_spike(tmp_path):
    spec = spencer_record(tmp_path / "s.csv", noise_N=0.0)
    problem = IdentifiableProblem(SPENCER, spec)
    signal = problem.signal
    assert signal.v[0] != 0.0  # a recorded velocity: noise, not exactly 0
    assert starts_from_rest(signal.t, signal.x, signal.v)
    assert problem.start.resolved == "rest" and problem.start.describe().startswith("from rest")
    direct = SPENCER.force_batch(SPENCER_1V[None, :], problem.sim_signal)[0]
    # at rest the damper carries its accumulator preload −k1·x0 = −71.5 N and nothing else
    assert direct[0] == pytest.approx(-SPENCER_1V[3] * SPENCER_1V[4], abs=1.0)
    # the same record pre-rolled from its noisy first velocity (what the auto rule would do without the
    # rest test, and what "pre-roll" asks for) starts the model at its yield force: the spike the rest test removes
    theta, coef = SPENCER.from_direct(SPENCER_1V)
    pre = IdentifiableProblem(SPENCER, spec, initial_state="pre-roll")
    assert pre.start.resolved == "pre-roll"
    spiked = coef["c1"] * pre.record_trajectories(theta)[0] + coef["k1"] * signal.x + coef["f0"]
    assert abs(spiked[0] - direct[0]) > 100.0
    # after the first cycles the two agree: only the start differs
    assert np.max(np.abs(spiked - direct)[len(direct) // 2 :]) < 0.05 * np.max(np.abs(direct))


def test_a_record_cut_at_a_reversal_is_not_taken_as_at_rest():
    t = np.arange(0, 2, 1 / RATE)
    x = AMP * np.cos(2 * np.pi * FREQ * t)  # starts at the end of its stroke, ẋ = 0, loaded
    v = -AMP * 2 * np.pi * FREQ * np.sin(2 * np.pi * FREQ * t)
    assert not starts_from_rest(t, x, v)


def test_the_fit_json_records_its_inputs_nrmse_both_ways_and_the_command(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    spencer_record(tmp_path / "s.csv")
    args = ["fit", "s.csv", "--model", "spencer", "--optimizer", "random", "--budget", "8", "--out", "r.json"]
    monkeypatch.setattr("sys.argv", ["bwbench", *args])
    assert main(args) == 0
    out = capsys.readouterr().out
    result = json.loads((tmp_path / "r.json").read_text())
    data = (tmp_path / "s.csv").read_bytes()
    assert result["inputs"] == [
        {
            "role": "specimen",
            "path": str((tmp_path / "s.csv").resolve()),
            "size_bytes": len(data),
            "sha256": hashlib.sha256(data).hexdigest(),
        }
    ]
    assert result["command_line"] == "bwbench " + " ".join(args)
    assert result["bwbench_version"]
    f = read_specimen(tmp_path / "s.csv").f
    assert result["nrmse"] == pytest.approx(result["rmse_N"] / np.max(np.abs(f)))
    assert result["nrmse_max_F"] == pytest.approx(result["rmse_N"] / np.max(f))
    assert "literature" in result["nrmse_definitions"]["nrmse_max_F"]
    lines = out.splitlines()
    assert lines[0] == "fitting s.csv: spencer in the identifiable formulation (the model's default)"
    assert f"NRMSE {result['nrmse_max_F']:.4g} (RMSE/max F, the literature's" in lines[1]
    assert result["formulation_reason"] == "spencer in the identifiable formulation (the model's default)"
    assert result["initial_state"].startswith("from rest")
    assert set(result["plausibility"]) >= {"xy", "n", "eta", "vy", "r0", "kappa0", "c1", "k1"}


def test_kappa0_on_its_floor_is_a_physical_limit_not_a_box_edge(tmp_path):
    problem = IdentifiableProblem(SPENCER, spencer_record(tmp_path / "s.csv"))
    theta = true_theta(SPENCER_1V).copy()
    theta[5] = problem.lower[problem.param_names.index("kappa0")]
    checks = fit_checks.check(problem, theta, at_bound={"kappa0": "lower"})
    assert "kappa0" in checks.explained
    assert any(f.startswith("kappa0 on its lower limit") and "physical limit (k₀ ≥ 0)" in f for f in checks.findings)


def test_the_box_probe_says_so_and_its_time_is_in_the_result(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    spencer_record(tmp_path / "s.csv")
    (tmp_path / "box.json").write_text(json.dumps({"n": [1.5, 3.0]}))
    assert (
        main(
            [
                "fit",
                "s.csv",
                "--model",
                "spencer",
                "--optimizer",
                "random",
                "--budget",
                "8",
                "--bounds",
                "box.json",
                "--out",
                "r.json",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "probing the search box of --bounds box.json (32 corners, one evaluation each) …"
    result = json.loads((tmp_path / "r.json").read_text())
    assert out[1] == f"probing the search box: done in {result['box_probe_s']:.1f} s"
    assert result["box_probe_s"] > 0 and [i["role"] for i in result["inputs"]] == ["specimen", "bounds"]
    assert result["bounds"]["n"] == [1.5, 3.0]
