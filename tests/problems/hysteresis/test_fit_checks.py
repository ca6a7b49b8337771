"""What `bwbench fit` states beyond the loss: units, parameters on a box edge, linear branches, the
energy dissipated per cycle, and the expected force error of an estimated velocity."""

import json
from pathlib import Path

import numpy as np
import pytest

from bwbench.cli import main
from bwbench.data.specimen import read_specimen
from bwbench.models.switched.parameters import UNITS
from bwbench.problems.hysteresis import fit_checks
from paper_problems import IdentifiableProblem

DATA = Path(__file__).resolve().parents[3] / "data" / "specimens"
SPECIMEN = DATA / "pom-mt24u01_0.01MPa_r1.csv"


def test_units_of_the_paper_parameters_follow_from_z_in_mm():
    # dz/dx = A − (β + γ·sign(z·dx))·|z|^n is dimensionless: A has no unit, β and γ carry mm^-n.
    assert UNITS["A+"] == "-" and UNITS["n-"] == "-" and UNITS["xi+"] == "-" and UNITS["alpha-"] == "-"
    assert UNITS["beta+"] == "mm^-n+" and UNITS["gamma-"] == "mm^-n-" and UNITS["wn+"] == "rad/s"
    problem = IdentifiableProblem(read_specimen(SPECIMEN))
    units = fit_checks.units(problem, ["m", "c+", "h-", "xy+", "rho", "beta-"])
    assert units == {
        "m": "N·s²/mm (1 N·s²/mm = 1 t = 1000 kg)",
        "c+": "N·s/mm",
        "h-": "N",
        "xy+": "mm",
        "rho": "-",
        "beta-": "mm^-n-",
    }


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _fit(capsys, *args):
    capsys.readouterr()
    status = main(["fit", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


def test_a_parameter_on_its_box_edge_is_warned_about_and_flagged(folder, capsys):
    # The truth has x_y₋ ≈ 1.4 mm: held at ≥ 4 mm, the fit makes up with η₋ and ends on its lower edge.
    (folder / "box.json").write_text(json.dumps({"xy-": [4.0, 10.0]}))
    status, out, err = _fit(
        capsys,
        SPECIMEN,
        "--optimizer",
        "cmaes",
        "--budget",
        "200",
        "--seed",
        "1",
        "--formulation",
        "identifiable",
        "--bounds",
        "box.json",
        "--out",
        "r.json",
    )
    assert status == 0
    result = json.loads((folder / "r.json").read_text())
    assert result["at_bound"] == {"eta-": "lower"}
    assert result["units"]["xy+"] == "mm" and result["units"]["beta-"] == "mm^-n-"
    assert result["units"]["m"].startswith("N·s²/mm")
    edge = [line for line in err.splitlines() if "edge of its search box" in line]
    # ... where widening it gains nothing (the cause is x_y₋'s bound): undetermined, not "widen"
    assert edge == []
    assert "  eta- on its lower edge is undetermined: a fit in a box widened to -5 lowers the loss by 0.00%" in out
    assert result["edges"]["eta-"]["kind"] == "undetermined"
    # the synthetic specimen's loop runs clockwise, as the paper's parameters make it: a note, no alarm
    assert "note: the fitted loop runs clockwise" in out and "generates energy" not in err
    assert result["energy_per_cycle_Nmm"] < 0
    assert "velocity_estimate" not in result  # the synthetic files log their velocity


def test_an_estimated_velocity_and_a_clockwise_loop_of_own_data_are_reported(folder, capsys):
    lines = SPECIMEN.read_text().splitlines()
    columns = lines[0].split(",")
    keep = [columns.index(c) for c in ("time_s", "displacement_mm", "force_N")]
    own = folder / "own.csv"  # no manifest beside it, no velocity column
    own.write_text("\n".join(",".join(np.array(line.split(","))[keep]) for line in lines) + "\n")
    status, out, err = _fit(capsys, own, "--optimizer", "random", "--budget", "40", "--out", "r.json")
    assert status == 0
    result = json.loads((folder / "r.json").read_text())
    estimate = result["velocity_estimate"]
    assert 5e-5 < estimate["velocity_error_mm_s"] < 1e-3  # 1 µm encoder noise at 1 Hz
    assert estimate["expected_force_error_N"] == pytest.approx(
        estimate["velocity_error_mm_s"] * estimate["sensitivity_N_s_per_mm"]
    )
    assert "velocity estimated from the displacement: expected error" in out
    assert f"warning: {own}: the fitted model generates energy" in err


def test_a_linear_branch_is_named_and_its_cap_is_not_an_edge_warning():
    problem = IdentifiableProblem(read_specimen(SPECIMEN))
    a = 0.5 * float(np.ptp(problem.specimen.x))
    names = problem.param_names
    theta = dict(zip(names, [50 * a, 2.0, 0.0, 0.1 * a, 2.0, 0.0, 0.01]))  # '+' at the cap, tiny ρ
    params = [theta[n] for n in names]
    assert fit_checks.linear_branches(problem, params) == {"+": True, "-": False}
    checks = fit_checks.check(problem, params, synthetic=True, at_bound={"xy+": "upper", "n-": "lower"})
    assert "xy+" in checks.explained and "xy+" not in checks.json["edges"]  # the cap: no edge to classify
    assert checks.json["edges"]["n-"]["kind"] == "undetermined"
    assert checks.json["linear_branches"] == {"+": True, "-": False}
    assert any(n.startswith("branch + is linear (no yield within the stroke)") for n in checks.notes)
    # the truth's '+' branch has x_y₊ = 5·a but starts where the '−' branch left w: it is not linear
    from bwbench.models.switched.identifiable import from_paper
    from bwbench.models.switched.parameters import truth_params

    assert fit_checks.linear_branches(problem, from_paper(truth_params(SPECIMEN))[0]) == {"+": False, "-": False}
