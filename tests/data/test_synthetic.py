"""The committed synthetic dataset: reproducible, faithful to its truth, labelled synthetic."""

import filecmp
import json
from pathlib import Path

import numpy as np
import pytest

from bwbench.data import manifest as manifest_mod
from bwbench.data import synthetic
from bwbench.cli import main
from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
from bwbench.data.specimen import read_specimen

DATA = Path(__file__).resolve().parents[2] / "data" / "specimens"


def test_generate_reproduces_the_committed_files_byte_for_byte(tmp_path):
    assert main(["data", "generate", "--out", str(tmp_path)]) == 0
    committed = sorted(p.name for p in DATA.iterdir())
    assert sorted(p.name for p in tmp_path.iterdir()) == committed
    assert len(committed) == 46  # 45 specimens + manifest
    match, mismatch, errors = filecmp.cmpfiles(DATA, tmp_path, committed, shallow=False)
    assert mismatch == [] and errors == []


def test_dataset_layout_and_labels():
    manifest = manifest_mod.read_manifest(DATA)
    assert len(manifest) == 45
    assert set(manifest.material) == {"POM MT24u01", "POM C9021", "PC/ABS C12HF"}
    assert sorted(set(manifest.underpressure_MPa)) == [0.01, 0.03, 0.05, 0.07, 0.09]
    assert set(manifest.repeat) == {1, 2, 3}
    assert manifest.synthetic.all()
    document = json.loads((DATA / manifest_mod.MANIFEST).read_text())
    assert "synthetic" in document["note"]
    spec = read_specimen(DATA / manifest.file[0])
    assert 1900 <= spec.n_samples <= 2100
    assert spec.x.max() == pytest.approx(10.0, abs=0.5) and spec.x.min() == pytest.approx(-10.0, abs=0.5)


def test_repeats_differ_by_at_most_7_percent_in_peak_force():
    manifest = manifest_mod.read_manifest(DATA)
    peaks = []
    for _, row in manifest.iterrows():
        peaks.append(np.max(np.abs(read_specimen(DATA / row.file).f)))
    manifest["peak"] = peaks
    spread = manifest.groupby(["material", "underpressure_MPa"]).peak.agg(lambda p: p.max() / p.min() - 1)
    assert spread.max() <= 0.07
    assert spread.min() > 0.0  # repeats are not copies


def test_truth_parameters_fit_their_specimen_to_near_the_noise_floor():
    # Load-cell noise is 1 N (1 N² MSE); the measured-excitation differentiator adds a few N² at
    # the reversals. The sine approximation of the paper is two to four orders worse.
    manifest = manifest_mod.read_manifest(DATA)
    measured, sine = [], []
    for file in manifest.file[::4]:
        spec = read_specimen(DATA / file)
        truth = manifest_mod.truth_params(DATA / file)
        measured.append(SwitchedBoucWenProblem(spec).loss_batch(truth[None])[0])
        sine.append(SwitchedBoucWenProblem(spec, excitation="sine").loss_batch(truth[None])[0])
    assert np.median(measured) < 20.0 and max(measured) < 100.0
    assert min(measured) > 0.5  # noise is really there
    assert np.median(sine) > 100 * np.median(measured)


def test_triangular_motion_is_continuous_and_at_constant_speed_between_reversals():
    s = synthetic.Settings()
    t = np.arange(0, 1920, 0.05)
    x, v, a, duration = synthetic.triangular_motion(t, s)
    assert duration == pytest.approx(1920.0)
    assert np.max(np.abs(np.diff(x))) <= 5.0 / 60.0 * 0.05 + 1e-12
    np.testing.assert_allclose(np.gradient(x, t)[100:-100], v[100:-100], atol=2e-4)
    constant = np.abs(a) == 0
    np.testing.assert_allclose(np.abs(v[constant & (t > 10) & (t < 1900)]), 5.0 / 60.0)
