"""``predict --refit-offset``: a record from another test set-up, whose load cell reads another zero,
predicted with the constant force re-solved on it (and said), every other coefficient as stored.
Records from an independent solve_ivp reference, commands run from another folder."""

import json
import os
import re

import numpy as np
import pandas as pd
import pytest

from bwbench.cli import main
from reference_mr import classic_force, random_motion

CLASSIC = [1.0, 1.5, 0.2, 0.5, 0.5, 2.0, 10.0]  # A, n, α, β, γ, ξ, ωn


def record(x_of, v_of, a_of, t, offset, seed):
    f = classic_force(CLASSIC, t, x_of, v_of, a_of) + offset + np.random.default_rng(seed).normal(0, 2.0, len(t))
    return pd.DataFrame({"time_s": t, "displacement_mm": x_of(t), "velocity_mm_s": v_of(t), "force_N": f})


@pytest.fixture
def elsewhere(tmp_path):
    before = os.getcwd()
    os.chdir(tmp_path)
    yield tmp_path
    os.chdir(before)


def test_the_constant_force_is_re_solved_on_the_new_record_and_said(elsewhere, capsys):
    w = 2 * np.pi * 0.2
    t = np.arange(0.0, 15.0, 0.02) + 0.0037
    record(
        lambda s: 10 * np.sin(w * s), lambda s: 10 * w * np.cos(w * s), lambda s: -10 * w * w * np.sin(w * s), t, 0.0, 1
    ).to_csv("sine.csv", index=False)
    x_of, v_of, a_of = random_motion(seed=3, amplitude=8.0, f_max=0.3)
    t = np.arange(0.0, 30.0, 0.02)
    record(x_of, v_of, a_of, t, -1500.0, 2).to_csv("quake.csv", index=False)  # another rig: −1.5 kN of zero
    assert main(["fit", "sine.csv", "--model", "bouc-wen", "--budget", "300", "--out", "fit.json"]) == 0
    capsys.readouterr()
    assert main(["predict", "--fit", "fit.json", "quake.csv", "--out", "as_stored.json"]) == 0
    as_stored = json.loads(open("as_stored.json").read())["predictions"][0]
    assert as_stored["rmse_N"] > 1400 and "refitted_offset_N" not in as_stored
    capsys.readouterr()
    assert main(["predict", "--fit", "fit.json", "quake.csv", "--refit-offset", "--out", "rezeroed.json"]) == 0
    out = capsys.readouterr().out
    rezeroed = json.loads(open("rezeroed.json").read())
    row = rezeroed["predictions"][0]
    assert row["refitted_offset_N"] == pytest.approx(-1500.0, abs=10.0) and row["rmse_N"] < 10.0
    said = re.search(r"constant force re-solved on this record: (-\d+(?:\.\d+)?) N", out)
    assert said is not None and float(said[1]) == pytest.approx(row["refitted_offset_N"], abs=0.5), out
    assert "every coefficient as stored but the constant force, re-solved on each file (--refit-offset)" in out
    assert rezeroed["coefficients"].endswith("but the constant force, re-solved on each file")
