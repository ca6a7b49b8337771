"""``bwbench identifiability``: the switched model's 14 parameters at the truth of a synthetic specimen."""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from bwbench.data import manifest
from bwbench.errors import UserError
from bwbench.models.switched import parameters as switched_parameters
from bwbench.problems.hysteresis import identifiability

SPECIMEN = Path(__file__).resolve().parents[3] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"


def test_analyse_bouc_wen_at_the_truth_is_json_ready():
    result = identifiability.analyse(SPECIMEN, switched_parameters.truth_params(SPECIMEN))
    json.dumps(result, allow_nan=False)
    s = np.array(result["singular_values"])
    assert np.all(np.diff(s) <= 0) and len(s) == 14
    assert result["relative_singular_values"][0] == 1.0
    assert 1.0 < result["mse"] < 20.0  # the synthetic noise floor
    assert set(result["poorly_determined"]) <= set(result["names"])
    assert len(result["weakest"]) == 3 and all("·" in w["text"] for w in result["weakest"])
    text = identifiability.format_text(result)
    assert "condition number" in text and "weakest directions" in text


def _cli(args):
    from bwbench.commands import simulate as commands

    parser = argparse.ArgumentParser()
    commands.add_identifiability_arguments(parser)
    return commands.identifiability(parser.parse_args(args))


def test_cli_prints_text_and_json(tmp_path, capsys):
    params = tmp_path / "p.json"
    params.write_text(json.dumps(manifest.manifest_entry(SPECIMEN)["truth"]))
    assert _cli([str(SPECIMEN), "--params", str(params), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["specimen"] == SPECIMEN.stem and len(out["weakest"]) == 3
    assert _cli([str(SPECIMEN), "--params", str(params)]) == 0
    assert "singular values" in capsys.readouterr().out


def test_cli_refuses_parameters_outside_table5(tmp_path):
    truth = dict(manifest.manifest_entry(SPECIMEN)["truth"], **{"A+": 1.0})
    params = tmp_path / "p.json"
    params.write_text(json.dumps(truth))
    with pytest.raises(UserError, match="A\\+"):
        _cli([str(SPECIMEN), "--params", str(params)])


@pytest.mark.parametrize(
    "state, names", [("shared", ["z → s·z in both branches"]), ("split", ["z₊ → s·z₊", "z₋ → s·z₋"])]
)
def test_the_exact_symmetry_is_named_and_verified_along_its_orbit(state, names):
    result = identifiability.analyse(SPECIMEN, switched_parameters.truth_params(SPECIMEN), state)
    assert [s["name"] for s in result["symmetries"]] == names
    for s in result["symmetries"]:
        assert s["max_force_change_N"] < 1e-9 and s["in_null_space"] > 0.99
    # what the symmetry does not explain is followed over a path: some of it is only a flat spot here
    assert len(result["null_directions"]) == result["numerically_zero"] - len(names)
    assert any(not d["exact"] for d in result["null_directions"])
    assert all(d["length"] > 0 for d in result["null_directions"])


def test_the_identifiable_coordinates_have_no_symmetry(tmp_path):
    from bwbench.models.switched.identifiable import from_paper

    theta, _ = from_paper(switched_parameters.truth_params(SPECIMEN), "shared")
    result = identifiability.analyse(SPECIMEN, theta, "shared", formulation="identifiable")
    assert result["symmetries"] == [] and result["names"][-1] == "rho"
    assert result["numerically_zero"] <= 1 and not any(d["exact"] for d in result["null_directions"])
    assert "identifiable formulation" in identifiability.format_text(result)
