"""The report's first paragraph says which formulation and search box the study used."""
from types import SimpleNamespace

from bwbench.problems.switched_vpp.report import setup_text


def _text(**settings):
    return setup_text(SimpleNamespace(study=SimpleNamespace(settings={"state": "shared", "excitation": "measured",
                                                                      **settings})))


def test_a_study_says_which_box_it_searched():
    assert "formulation: the paper's 14 parameters in its Table 5 box" in _text()
    identifiable = _text(formulation="identifiable")
    assert "box scaled from each specimen's data" in identifiable and "Table 5" not in identifiable
    both = _text(formulation=["paper", "identifiable"], bounds={"n+": [1, 2]})
    assert "formulations compared side by side: the paper's" in both and "scaled from" in both
    assert both.endswith("bounds set by the study: n+.")
