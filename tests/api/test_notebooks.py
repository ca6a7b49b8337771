"""The example notebooks (examples/notebooks/) run top to bottom, each in a fresh kernel in a folder of
its own, at the small budgets they are written with: a notebook that no longer runs fails here."""

import shutil
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "examples" / "notebooks").glob("*.ipynb"))


def execute(notebook: Path, folder: Path):
    """The executed notebook (nbclient, a python3 kernel, ``folder`` as its working directory)."""
    import nbformat
    from nbclient import NotebookClient

    shutil.copy(notebook, folder / notebook.name)
    book = nbformat.read(folder / notebook.name, as_version=4)
    NotebookClient(book, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(folder)}}).execute()
    return book


def outputs(book, kind: str) -> list:
    return [
        o
        for cell in book.cells
        if cell.cell_type == "code"
        for o in cell.get("outputs", [])
        if kind in o.get("data", {}) or o.get("output_type") == kind
    ]


def test_there_are_the_five_notebooks():
    assert [n.stem for n in NOTEBOOKS] == [
        "01_first_fit",
        "02_your_own_data",
        "03_compare",
        "04_predict",
        "05_posterior",
    ]


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[n.stem for n in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(notebook, tmp_path):
    book = execute(notebook, tmp_path)  # a cell that raises fails the test (CellExecutionError)
    assert not outputs(book, "error")
    figures = outputs(book, "image/png")
    html = outputs(book, "text/html")
    if notebook.stem in ("01_first_fit", "04_predict", "05_posterior"):
        assert figures, "the figure shows inline"
    if notebook.stem == "01_first_fit":
        assert any("<b>FitResult</b>" in o["data"]["text/html"] for o in html)
        assert (tmp_path / "fit.json").is_file()
    if notebook.stem == "02_your_own_data":
        warned = [o for o in outputs(book, "stream") if o.get("name") == "stderr" and "FitNote" in o["text"]]
        assert warned and "UserError: DataFrame 'data', row 10: force_N is nan" in "".join(
            o.get("text", "") for o in outputs(book, "stream")
        )
    if notebook.stem == "03_compare":
        assert (tmp_path / "report" / "report.html").is_file()
