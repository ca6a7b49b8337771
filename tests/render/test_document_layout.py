"""The HTML reads on a phone and on paper: a viewport, scrolling tables with the label column fixed,
long tables collapsed with their CSV beside the report, the answer in a box, *emphasis* rendered."""

import pandas as pd

from bwbench.render.document import COLLAPSE_ROWS, Document


def test_long_tables_collapse_with_their_csv_and_the_page_has_a_viewport(tmp_path):
    doc = Document(tmp_path)
    doc.h(1, "Optimiser comparison: x")
    doc.h(2, "Recommendation")
    doc.box(["**Use cmaes** at 4,100 evaluations", "a *final loss* is the best loss; 1.87×* is a significance star"])
    long = pd.DataFrame({"parameter": [f"p{i}" for i in range(COLLAPSE_ROWS + 5)], "value": range(COLLAPSE_ROWS + 5)})
    doc.table(long, "POM MT24u01: tension set (+)")
    doc.table(long.head(3), "short")
    html = doc.html("x")
    assert '<meta name="viewport" content="width=device-width, initial-scale=1">' in html
    assert '<div class="answer"><ul><li><strong>Use cmaes</strong>' in html
    assert "a <em>final loss</em> is the best loss; 1.87×* is" in html  # the star of 1.87×* stays a star
    csv = tmp_path / "table_pom-mt24u01-tension-set.csv"
    assert pd.read_csv(csv)["value"].tolist() == list(range(COLLAPSE_ROWS + 5))
    assert (
        '<details><summary>POM MT24u01: tension set (+) (35 rows; data: <a href="table_pom-mt24u01-tension-set.csv">'
    ) in html
    assert html.count("<details>") == 1  # the short table stays open
    assert "position: sticky" in html and ".scroll { overflow-x: auto" in html
    md = doc.markdown()
    assert md.split("\n## ")[1].startswith("Recommendation\n\n- **Use cmaes**")
    assert "<details><summary>POM MT24u01: tension set (+) (35 rows; data: table_pom-mt24u01-tension-set.csv)" in md
