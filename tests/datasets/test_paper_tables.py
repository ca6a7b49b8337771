"""The paper's tables in data/paper/ (see its README.md): they load, and they agree with each other."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

PAPER = Path(__file__).resolve().parents[2] / "data" / "paper"
NAMES = "A+ n+ alpha+ beta+ gamma+ xi+ wn+ A- n- alpha- beta- gamma- xi- wn-".split()
MATERIALS = {6: "POM MT24u01", 7: "POM C9021", 8: "PC/ABS C12HF"}
PRESSURES = [0.01, 0.03, 0.05, 0.07, 0.09]


@pytest.fixture(scope="module")
def bounds():
    return pd.read_csv(PAPER / "table5_bounds.csv")


@pytest.fixture(scope="module")
def identified():
    return pd.read_csv(PAPER / "identified_parameters.csv")


def test_bounds_table5(bounds):
    assert list(bounds.columns) == ["parameter", "lower", "upper", "unit"]
    assert list(bounds.parameter) == NAMES
    assert (bounds.lower < bounds.upper).all()
    b = bounds.set_index("parameter")
    assert (b.loc["xi-", "lower"], b.loc["xi-", "upper"]) == (-575.0, -23.0)
    assert (b.loc["xi+", "lower"], b.loc["xi+", "upper"]) == (20.0, 500.0)
    assert (b.loc["A+", "lower"], b.loc["A+", "upper"]) == (0.001, 0.025)
    assert (b.loc["alpha-", "lower"], b.loc["alpha-", "upper"]) == (0.0055, 0.1375)
    assert (b.loc["wn-", "lower"], b.loc["wn-", "upper"]) == (1.8, 45.0)
    assert dict(b.unit) == {n: ("rad/s" if n.startswith("wn") else "-") for n in NAMES}
    # Every printed range spans a factor 25 exactly: a check on the transcription.
    ratio = np.maximum(b.upper / b.lower, b.lower / b.upper)
    np.testing.assert_allclose(ratio, 25.0, rtol=1e-12)


def test_identified_tables_6_to_8(identified):
    assert list(identified.columns) == ["material", "table", "underpressure_MPa", "F_err_N2"] + NAMES
    assert len(identified) == 15
    for table, material in MATERIALS.items():
        rows = identified[identified.table == table]
        assert list(rows.material) == [material] * 5
        assert list(rows.underpressure_MPa) == PRESSURES
    assert identified[NAMES + ["F_err_N2"]].notna().all().all()
    assert (identified.F_err_N2 < 0).all()  # eq 6 is a negative mean squared error
    row = identified.set_index(["table", "underpressure_MPa"])
    assert row.loc[(6, 0.07), "alpha+"] == 1.481  # docs/design.md#parameters: α may exceed 1
    assert row.loc[(6, 0.01), "F_err_N2"] == -833.793
    assert row.loc[(7, 0.07), "n+"] == 10.057
    assert row.loc[(8, 0.09), "F_err_N2"] == -5495.133
    assert row.loc[(8, 0.01), "xi-"] == -54.433
    assert row.loc[(8, 0.09), "wn-"] == 23.795


def test_identified_parameters_against_table5_bounds(bounds, identified):
    b = bounds.set_index("parameter")
    outside = [
        (MATERIALS[r.table], r.underpressure_MPa, name)
        for _, r in identified.iterrows()
        for name in NAMES
        if not b.loc[name, "lower"] <= r[name] <= b.loc[name, "upper"]
    ]
    assert outside == []  # the GA drew start values and mutations from Table 5, so none can leave it
    on_bound = [
        (MATERIALS[r.table], r.underpressure_MPa, name)
        for _, r in identified.iterrows()
        for name in NAMES
        if r[name] in (b.loc[name, "lower"], b.loc[name, "upper"])
    ]
    assert on_bound == [("POM C9021", 0.05, "A+")]  # A+ = 0.025, the upper bound


def test_material_properties_table1():
    m = pd.read_csv(PAPER / "material_properties.csv", keep_default_na=False)
    assert list(m.columns) == [
        "material",
        "young_modulus_MPa",
        "yield_stress_MPa",
        "strain_at_break_percent",
        "strain_at_break_note",
    ]
    m = m.set_index("material")
    assert list(m.index) == ["PC/ABS C12HF", "POM C9021", "POM MT24u01"]
    assert list(m.young_modulus_MPa) == [2360, 2500, 2900]
    assert list(m.yield_stress_MPa) == [55, 48, 65]
    assert list(m.strain_at_break_percent) == [50, 16, 17]
    assert list(m.strain_at_break_note) == [">50", "", ""]


def test_mechanical_properties_tables_2_to_4():
    m = pd.read_csv(PAPER / "mechanical_properties.csv")
    assert list(m.columns) == [
        "material",
        "table",
        "underpressure_MPa",
        "yield_stress_0.2pct_MPa",
        "stress_5pct_MPa",
        "absorbed_energy",
    ]
    assert len(m) == 15
    assert m.dtypes["stress_5pct_MPa"] == np.float64  # the printed '0.0.108' typos are gone
    for table, material in {2: "PC/ABS C12HF", 3: "POM C9021", 4: "POM MT24u01"}.items():
        rows = m[m.table == table]
        assert list(rows.material) == [material] * 5
        assert list(rows.underpressure_MPa) == PRESSURES
        # more underpressure, stiffer packing: every property grows with it
        for col in ("yield_stress_0.2pct_MPa", "stress_5pct_MPa", "absorbed_energy"):
            assert (np.diff(rows[col]) > 0).all(), (table, col)
    # stress at 5 % strain lies above the 0.2 % yield stress, within 0.1-0.35 MPa
    assert (m.stress_5pct_MPa > m["yield_stress_0.2pct_MPa"]).all()
    assert m.stress_5pct_MPa.between(0.1, 0.35).all()
    assert list(m[m.table == 2].stress_5pct_MPa) == [0.108, 0.132, 0.187, 0.227, 0.262]
    assert list(m[m.table == 3].stress_5pct_MPa) == [0.11, 0.15, 0.2, 0.26, 0.32]
    assert list(m[m.table == 4].stress_5pct_MPa) == [0.109, 0.133, 0.165, 0.203, 0.247]


def test_code_bounds_are_the_transcribed_table5():
    from bwbench.models.switched.parameters import LOWER, UPPER

    bounds = pd.read_csv(Path(__file__).resolve().parents[2] / "data" / "paper" / "table5_bounds.csv")
    np.testing.assert_array_equal(bounds.lower.to_numpy(), LOWER)
    np.testing.assert_array_equal(bounds.upper.to_numpy(), UPPER)
