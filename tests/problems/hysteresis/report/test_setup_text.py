"""The report's first paragraph says which formulation and search box the study used."""

from types import SimpleNamespace

from bwbench.problems.hysteresis.report.sections import setup_text


def _text(paper_data=True, **settings):
    return setup_text(
        SimpleNamespace(
            study=SimpleNamespace(settings={"state": "shared", "excitation": "measured", **settings}),
            problem_type=SimpleNamespace(is_synthetic=lambda study: paper_data),
        )
    )


def test_a_study_says_which_box_it_searched():
    assert "formulation: the paper's 14 parameters in its Table 5 box" in _text()
    identifiable = _text(formulation="identifiable")
    assert "box scaled from each specimen's data" in identifiable and "Table 5" not in identifiable
    both = _text(formulation=["paper", "identifiable"], bounds={"n+": [1, 2]})
    assert "formulations compared side by side: the paper's" in both and "scaled from" in both
    assert both.endswith("bounds set by the study: n+.")


def test_a_users_data_hear_of_the_paper_formulation_but_not_of_its_table():
    text = _text(paper_data=False)
    assert "the paper's 14 parameters in the paper's search box" in text and "Table 5" not in text
