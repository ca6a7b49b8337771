"""Long and broadband records: the fit figure's whole record, zoom window and force–velocity plane;
periodic-motion checks skipped on an irregular record (and said so); an NRMSE for a force that is never
positive; many files named by a count and the first few. Records written here, not by our generators."""

import numpy as np
import pandas as pd
import pytest
from scipy.signal import butter, sosfiltfilt

from bwbench.data.specimen_input import from_frame
from bwbench.models.protocol import protocol
from bwbench.problems.hysteresis import fit_checks
from bwbench.problems.hysteresis.fit_result import nrmse_text
from bwbench.problems.hysteresis.fitted_model import Prediction
from bwbench.problems.hysteresis.formulations import make_problem
from bwbench.problems.hysteresis.report import prediction_figures, record_fit_figure
from bwbench.render.format import files_text


def broadband(seconds=20.0, rate=500.0, offset=-1500.0, seed=11):
    """A band-limited random motion (0.5–8 Hz, ±10 mm) and a friction-like force that never goes positive."""
    n = int(seconds * rate)
    sos = butter(4, [0.5, 8.0], btype="band", fs=rate, output="sos")
    x = sosfiltfilt(sos, np.random.default_rng(seed).normal(size=n))
    x *= 10 / np.abs(x).max()
    t = np.arange(n) / rate
    v = np.gradient(x, t)
    f = offset + 400 * np.tanh(v / 20) + 5 * x + np.random.default_rng(seed + 1).normal(0, 5, n)
    return pd.DataFrame({"time_s": t, "displacement_mm": x, "velocity_mm_s": v, "force_N": f})


@pytest.fixture(scope="module")
def problem():
    return make_problem(from_frame(broadband(), "broadband"), {"model": "bouc-wen"})


def middle(problem):
    return problem.from_unit(np.full(problem.dim, 0.5))


def test_the_fit_figure_of_a_long_record_shows_it_whole_with_a_zoom_and_the_force_velocity_plane(problem, monkeypatch):
    drawn = {}
    monkeypatch.setattr(record_fit_figure, "write_png", lambda fig, path, synthetic: drawn.setdefault("fig", fig))
    params = middle(problem)
    result = type("R", (), {"params": dict(zip(problem.param_names, params)), "optimizer": "lsq-trf", "seed": 0})()
    result.nfev, result.rmse_N = 1, 10.0
    record_fit_figure.plot_fit(problem, result, "unused.png")
    titles = [ax.get_title(loc="left") for ax in drawn["fig"].axes]
    assert titles[0].startswith("loops of the whole record (") and titles[1] == "force–velocity plane"
    assert titles[2] == "force, whole record (shaded: the zoom below)"
    assert titles[3].startswith("zoom: ") and titles[3].endswith(" s (13 reversals)")
    assert titles[4].startswith("residual, whole record: RMSE ") and titles[4].endswith("(RMSE/max|F|)")
    suptitle = drawn["fig"].get_suptitle()
    assert "inf" not in suptitle and "the force is never positive, so RMSE/max F is undefined" in suptitle


def test_periodic_checks_are_skipped_on_an_irregular_record_and_say_so(problem):
    assert protocol(problem.signal.x).kind == "irregular"
    checks = fit_checks.check(problem, middle(problem))
    assert checks.json["periodic_checks"].startswith("skipped: irregular (random, broadband")
    assert "energy_check" not in checks.json and "reversal_error_share" not in str(checks.notes + checks.findings)
    assert any(n.startswith("periodic-motion checks skipped (energy per cycle") for n in checks.notes)
    assert not any(n.startswith("energy dissipated per cycle") for n in checks.notes)


def test_nrmse_is_defined_for_any_sign_of_force():
    assert nrmse_text(0.01, float("inf")) == (
        "NRMSE 0.01 (RMSE/max|F|; the force is never positive, so RMSE/max F is undefined)"
    )
    assert nrmse_text(0.01, 0.02) == "NRMSE 0.02 (RMSE/max F, the literature's; 0.01 RMSE/max|F|)"


def test_many_files_are_named_by_a_count_and_the_first_few_and_figures_say_which_they_show():
    names = [f"test_{k:02d}.csv" for k in range(46)]
    assert files_text(names) == "46 files (test_00.csv, test_01.csv, test_02.csv and 43 more)"
    assert files_text(names[:2]) == "test_00.csv + test_01.csv"
    frame = broadband(seconds=2.0)
    rows = []
    for k in range(46):
        force = frame.force_N.values
        rows.append(Prediction(f"test_{k:02d}", frame.time_s.values, frame.displacement_mm.values, force, force))
    fig = prediction_figures.draw_predictions(rows, "joint fit of 46 tests: a model", what="fitted")
    suptitle = fig.get_suptitle()
    assert "shown: the first 8 of 46 tests, one per row (test_00 … test_07)" in suptitle
    width = fig.get_figwidth() * 9.5
    assert all(len(line) <= width for line in suptitle.splitlines())  # wrapped: inside the image
