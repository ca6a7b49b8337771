"""bwbench.fit's inputs (paths, several paths, a Specimen, a DataFrame), its notes as FitWarning, its
bad input as UserError, the plots (backend and rcParams untouched) and the short reprs."""

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import bwbench
from api_toy import toy_frame

REPO = Path(__file__).resolve().parents[2]
SPECIMEN = REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
FIT = {"model": "bouc-wen", "budget": 40, "seed": 0}


def quiet_fit(*data, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bwbench.FitWarning)
        return bwbench.fit(*data, **{**FIT, **kw})


def test_a_dataframe_a_specimen_and_its_file_give_the_same_fit(tmp_path):
    frame = toy_frame(1)
    frame.to_csv(tmp_path / "toy.csv", index=False, float_format="%.17g")
    from_file = quiet_fit(tmp_path / "toy.csv")
    from_frame = quiet_fit(frame, name="toy")
    from bwbench.data.specimen import read_specimen

    from_specimen = quiet_fit(read_specimen(tmp_path / "toy.csv"))
    assert from_frame.mse == from_file.mse == from_specimen.mse
    assert from_frame.params == pytest.approx(from_file.params, rel=1e-12)
    assert from_frame.table()["specimen"].tolist() == ["toy"]
    assert quiet_fit(frame).table()["specimen"].tolist() == ["data"]  # no name: "data"


def test_several_paths_or_a_list_of_them_is_one_joint_fit(tmp_path):
    for k in (1, 2):
        toy_frame(k).to_csv(tmp_path / f"t{k}.csv", index=False)
    joint = quiet_fit(tmp_path / "t1.csv", tmp_path / "t2.csv")
    listed = quiet_fit([tmp_path / "t1.csv", tmp_path / "t2.csv"])
    assert joint.table()["specimen"].tolist() == ["t1", "t2"] and listed.mse == joint.mse
    s = joint.summary()
    assert np.isfinite(s.loc[["xy", "h"], "stderr"]).all()  # one parameter set for both files
    assert len(joint.plot().axes) == 8  # a row of four panels per file


def test_the_fit_notes_are_warnings_of_their_own_category():
    with pytest.warns(bwbench.FitWarning) as caught:  # the truth's n = 1.5: a box too small, no budget left
        fit = bwbench.fit(toy_frame(0), **FIT, bounds={"n": (3.0, 5.0)})
    texts = [str(w.message) for w in caught]
    assert any(t.startswith("n = 3 ended on the lower edge of its search box [3, 5]") for t in texts)
    assert any("linear solve:" in t for t in texts)
    assert all(w.filename == __file__ for w in caught)  # pointing at the user's line
    assert set(texts) <= set(fit.notes)
    with warnings.catch_warnings():
        warnings.simplefilter("error", bwbench.FitWarning)  # a script can stop at the first
        with pytest.raises(bwbench.FitWarning):
            bwbench.fit(toy_frame(0), **FIT, bounds={"n": (3.0, 5.0)})


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"budget": 0}, "budget must be a positive number of evaluations, got 0"),
        ({"budget": 2.5}, "budget must be a positive number of evaluations, got 2.5"),
        ({"budget": 10**12}, "budget 1,000,000,000,000 is above the limit"),
        ({"seed": -1}, "seed must be a non-negative integer, got -1"),
        ({"optimizer": "nope"}, "unknown optimiser 'nope'"),
        ({"options": {"population": -3}, "optimizer": "paper-ga"}, "population"),
        ({"excitation": "square"}, "--excitation must be one of 'measured', 'sine'"),
        ({"weighting": "some"}, "weighting must be one of 'equal', 'samples'"),
        ({"state": "split"}, "state does not apply to model 'bouc-wen'"),
        ({"fix_mass": -1}, "--fix-mass must be 'auto', 'fit' or a mass ≥ 0"),
        ({"formulation": "paper", "fix_mass": 1.0}, "--fix-mass applies to the identifiable formulation"),
        ({"threads": 0}, "--threads must be 1 to"),
        ({"bounds": {"nope": (0, 1)}}, "nope"),
    ],
)
def test_bad_arguments_are_user_errors_with_the_cli_message(kwargs, message):
    with pytest.raises(bwbench.UserError, match=message.replace("(", r"\(").replace(")", r"\)")):
        bwbench.fit(toy_frame(0), **{**FIT, **kwargs})


def test_bad_data_is_a_user_error_naming_the_row(tmp_path):
    frame = toy_frame(0)
    with pytest.raises(bwbench.UserError, match="no column force_N"):
        bwbench.fit(frame.drop(columns="force_N"), **FIT)
    bad = frame.copy()
    bad.loc[7, "force_N"] = np.nan
    with pytest.raises(bwbench.UserError, match="DataFrame 'data', row 7: force_N is nan"):
        bwbench.fit(bad, **FIT)
    uneven = frame.copy()
    uneven.loc[50:, "time_s"] += 0.001
    with pytest.raises(bwbench.UserError, match="row 50: time step"):
        bwbench.fit(uneven, **FIT)
    with pytest.raises(bwbench.UserError, match="a Specimen or a pandas DataFrame, got ndarray"):
        bwbench.fit(frame.to_numpy(), **FIT)
    with pytest.raises(bwbench.UserError, match="at least one test"):
        bwbench.fit(**FIT)
    toy_frame(0).to_csv(tmp_path / "a.csv", index=False)
    with pytest.raises(bwbench.UserError, match="named twice"):
        bwbench.fit(tmp_path / "a.csv", str(tmp_path / "a.csv"), **FIT)


def test_plots_leave_the_backend_rcparams_and_pyplot_alone(tmp_path):
    # In a fresh process: the figure is drawn and saved, matplotlib's state is what it was.
    script = f"""
import sys, warnings, matplotlib
sys.path.insert(0, {str(REPO / "tests")!r})
from api_toy import toy_frame
import bwbench
warnings.simplefilter("ignore")
before = matplotlib.rcParams.copy()  # dict(rcParams) would resolve the backend itself
fit = bwbench.fit(toy_frame(0), model="bouc-wen", budget=40)
fig = fit.plot()
fig.savefig({str(tmp_path / "fit.png")!r})
p = fit.predict(toy_frame(3))
p.plot().savefig({str(tmp_path / "prediction.png")!r})
print(len(fig.axes), [a.get_xlabel() for a in fig.axes], "matplotlib.pyplot" in sys.modules,
      matplotlib.rcParams.copy() == before, matplotlib.rcParams._get_backend_or_none())
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[0] == (
        "4 ['displacement (mm)', 'velocity (mm/s)', 'time (s)', 'time (s)'] False True None"
    )
    assert (tmp_path / "fit.png").stat().st_size > 10_000 and (tmp_path / "prediction.png").is_file()


def test_plot_draws_into_given_axes():
    from matplotlib.figure import Figure

    fit = quiet_fit(toy_frame(0))
    fig = Figure()
    ax = fig.subplots()
    assert fit.plot(ax=ax) is fig and ax.get_xlabel() == "displacement (mm)"
    line = ax.get_lines()[1]  # the model's
    assert np.allclose(line.get_ydata(), fit.model.predict(toy_frame(0)).force_N)
    four = Figure().subplots(2, 2)
    fit.plot(ax=four)
    assert four[1, 1].get_ylabel() == "residual (N)"


def test_reprs_are_short_and_html_is_a_table():
    fit = quiet_fit(toy_frame(0))
    p = fit.predict(toy_frame(2))
    for obj in (fit, fit.model, p):
        assert len(repr(obj)) < 200, repr(obj)
        assert obj._repr_html_().startswith("<div>") and "<table>" in obj._repr_html_()
    assert repr(fit).startswith("<FitResult bouc-wen identifiable by lsq-trf, 40 evaluations: data RMSE")
    assert f"RMSE {p.rmse_N:.4g} N" in repr(p)
    assert "xy" in fit.model._repr_html_()


def test_prediction_of_a_dataframe_matches_its_file(tmp_path):
    fit = quiet_fit(toy_frame(0))
    toy_frame(5).to_csv(tmp_path / "held_out.csv", index=False, float_format="%.17g")
    a, b = fit.predict(toy_frame(5)), fit.predict(tmp_path / "held_out.csv")
    assert a.rmse_N == pytest.approx(b.rmse_N, rel=1e-9) and a.rmse_N < 2.5  # noise 2 N
    assert np.allclose(a.velocity_mm_s, toy_frame(5)["velocity_mm_s"])  # the recorded velocity drove it
