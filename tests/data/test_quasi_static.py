"""Quasi-static tests: a file with displacement and force only (a digitised column test) read as a
sequence, the direction of motion with a dead band against digitising jitter, no viscous or inertia
term, the protocol named (cyclic with growing amplitude, not "ramp-in"); files written here by hand."""

import os
import warnings

import numpy as np
import pandas as pd
import pytest

import bwbench
from bwbench.cli import main
from bwbench.data.specimen import read_specimen
from bwbench.data.steady_part import steady_part
from bwbench.errors import UserError
from bwbench.models import protocol
from bwbench.models.excitation import of_specimen
from bwbench.problems.hysteresis.formulations import make_problem
from reference_bwbn import growing_cycles, reference_force

# k, α, c, β, γ, n, δν, δη, ζ_s, p, q, ψ, δψ, λ: a degrading, pinching column
COLUMN = np.array([100.0, 0.05, 0.0, 0.02, 0.02, 1.5, 2e-4, 1e-4, 0.9, 2e-3, 0.1, 3.0, 2e-4, 0.2])


def digitised_column(path, points=400, jitter=0.05, seed=7):
    """Points picked off a column's loops (2 cycles at each of 5, 10, 20, 30 mm... growing), uneven
    spacing, the displacement jittered by ``jitter`` mm and printed to 0.01 mm, no time column."""
    x_of, v_of, t = growing_cycles(period=20.0, rate=10.0)
    f = reference_force(COLUMN, t, x_of, v_of)
    rng = np.random.default_rng(seed)
    keep = np.sort(rng.choice(len(t), points, replace=False))
    x = x_of(t[keep]) + rng.normal(0, jitter, points)
    pd.DataFrame({"displacement_mm": np.round(x, 2), "force_N": np.round(f[keep], 1)}).to_csv(path, index=False)
    return x_of(t[keep]), f[keep]


@pytest.fixture
def elsewhere(tmp_path):
    before = os.getcwd()
    os.chdir(tmp_path)
    yield tmp_path
    os.chdir(before)


def test_a_file_without_time_is_read_as_a_sequence_and_its_protocol_named(elsewhere, capsys):
    digitised_column("column.csv")
    spec = read_specimen("column.csv")
    assert spec.quasi_static and np.array_equal(spec.t, np.arange(400.0))
    assert main(["data", "check", "column.csv"]) == 0
    out = capsys.readouterr().out
    assert "400 points, quasi-static (no time_s column" in out
    assert "protocol: cyclic with growing amplitude: 6 cycles" in out and "ramp" not in out
    # the same protocol with time is not a "ramp-in" either
    x_of, _, t = growing_cycles(period=20.0, rate=10.0)
    assert not steady_part(t, x_of(t)).ramped


def test_the_direction_of_motion_ignores_jitter_and_reverses_at_the_extremes(elsewhere):
    true_x, _ = digitised_column("column.csv", jitter=0.08)
    signal = of_specimen("measured", read_specimen("column.csv"))
    assert signal.rate_independent and np.all(signal.a == 0) and set(np.unique(signal.v)) == {-1.0, 0.0, 1.0}
    reversals = np.flatnonzero(signal.v == 0)
    assert len(reversals) == len(protocol.reversals(true_x, band=0.0)) == 12  # one per half-cycle, no more
    jittery = np.flatnonzero(np.diff(signal.x) * signal.v[:-1] < 0)
    assert len(jittery) >= 5  # the path does go back and forth by the jitter, the direction does not
    for k in reversals:  # each reversal sits on its extreme
        window = signal.x[max(k - 3, 0) : k + 4]
        assert signal.x[k] in (window.max(), window.min())


def test_models_run_on_the_path_with_no_viscous_or_inertia_term(elsewhere):
    digitised_column("column.csv")
    spec = read_specimen("column.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bwbench.FitWarning)
        fit = bwbench.fit(spec, model="bwbn", budget=400, seed=1)
        switched = bwbench.fit(spec, model="switched-bouc-wen", formulation="identifiable", budget=100, seed=1)
    assert fit.params["c"] == 0.0 and fit.params["m"] == 0.0
    assert switched.params["c+"] == switched.params["c-"] == 0.0
    assert fit.rmse_N < 0.02 * np.abs(spec.f).max()  # the jitter through the stiffness, and the rounding
    with pytest.raises(UserError, match="rate-dependent and needs time"):
        make_problem(spec, {"model": "spencer"})
    with pytest.raises(UserError, match="use --formulation identifiable"):
        make_problem(spec, {"model": "switched-bouc-wen", "formulation": "paper"})


def test_a_file_with_a_velocity_but_no_time_is_refused(elsewhere):
    pd.DataFrame({"displacement_mm": np.sin(np.arange(40.0)), "velocity_mm_s": 1.0, "force_N": 1.0}).to_csv(
        "v.csv", index=False
    )
    with pytest.raises(UserError, match="missing column 'time_s'"):
        read_specimen("v.csv")
