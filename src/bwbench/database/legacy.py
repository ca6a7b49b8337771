"""The layouts of study databases written by earlier versions, known here and nowhere else, so that
every database still reads:

- before the generic columns: no ``problem``, ``params_json``, ``metrics_json``, ``model``,
  ``formulation``, ``variant`` (a switched-model study of the paper's 14 parameters);
- the switched model's 14 parameters as columns of ``runs`` (``PARAMETER_COLUMNS``), later also in
  ``params_json`` (where a row has both, the column wins where it is not NULL);
- the paper's specimen facts as columns (``META_COLUMNS``: material, underpressure_MPa, repeat), now
  in ``meta_json``.
"""

from __future__ import annotations

import pandas as pd

# The switched model's parameters, columns of the runs table in the first databases.
PARAMETER_COLUMNS = (
    "A+", "n+", "alpha+", "beta+", "gamma+", "xi+", "wn+", "A-", "n-", "alpha-", "beta-", "gamma-", "xi-", "wn-",
)  # fmt: skip
META_COLUMNS = ("material", "underpressure_MPa", "repeat")
GENERIC = ("problem", "params_json", "metrics_json", "model", "formulation", "variant", "meta_json")


def upgrade(runs: pd.DataFrame, default_problem: str) -> pd.DataFrame:
    """``runs`` as read from any layout, with every column of the current one (NULL where an old
    layout had none) and the old problem's name for rows written before the key."""
    if "problem" not in runs:  # written before the generic columns: a switched-model study
        runs["problem"] = default_problem
    runs["problem"] = runs["problem"].fillna(default_problem)
    for column in GENERIC:
        if column not in runs:
            runs[column] = None
    return runs


def numeric_columns(runs: pd.DataFrame) -> list[str]:
    """The old layouts' numeric columns present in ``runs``."""
    return [c for c in (*PARAMETER_COLUMNS, "underpressure_MPa") if c in runs]


def fill_from_json(runs: pd.DataFrame, name: str, values) -> bool:
    """Fill an old layout's column ``name`` from a JSON column's ``values`` where it is NULL; False
    when ``name`` is no column of an old layout present in ``runs``."""
    if name in runs and name in (*PARAMETER_COLUMNS, *META_COLUMNS):
        runs[name] = runs[name].where(runs[name].notna(), values)
        return True
    return False
