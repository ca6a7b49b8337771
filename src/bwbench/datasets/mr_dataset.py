"""The synthetic MR-damper dataset: sine tests of Spencer et al. (1997)'s damper, with a manifest.

A second shipped dataset beside the paper's synthetic VPP specimens, for comparing models on the
kind of data the field fits Spencer's model to: a damper that bwbench's switched model did not make.
Six tests (``TESTS``: amplitude, frequency, current-equivalent voltage), recorded as a servo-hydraulic
machine records them — displacement, the velocity channel and the load cell — at 500 Hz for three
cycles after a warm-up cycle, scaled to a 1.2 kN peak, with 0.5 % force noise, a +8 N load-cell
offset, 1 µm encoder noise and 0.05 mm/s velocity-channel noise (``bwbench.datasets.mr_damper``).

The manifest marks every file synthetic, names its source and model (``"model": "spencer"``) and
gives its truth in that model's direct parameters in mm, s, N (the load-cell offset folded into x₀:
F = c₁·ẏ + k₁·(x − x₀) with k₁·x₀ reduced by the offset). ``generate`` is deterministic: the same
bytes on every run (``bwbench data generate --mr-damper``).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from bwbench.data.manifest import MANIFEST
from bwbench.data.output_paths import write_text
from bwbench.datasets import mr_damper, shipped

DATASET_DIR = shipped.MR_DAMPER
SOURCE = "Spencer et al. (1997)'s phenomenological MR-damper model"
NOTE = f"synthetic data generated from {SOURCE} (not measured)"
SEED = 1997
TESTS = (  # amplitude (mm), frequency (Hz), voltage (V)
    (25.0, 0.5, 1.0),
    (25.0, 1.0, 0.0),
    (25.0, 1.0, 2.25),
    (10.0, 2.0, 1.0),
    (5.0, 5.0, 2.25),
    (10.0, 5.0, 0.0),
)


@dataclasses.dataclass(frozen=True)
class Settings:
    rate_hz: float = 500.0
    cycles: int = 3
    peak_force_N: float = 1200.0
    force_noise_frac: float = 0.005
    force_offset_N: float = 8.0
    displacement_noise_mm: float = 0.001
    velocity_noise_mm_s: float = 0.05
    seed: int = SEED


def truth(test: mr_damper.SineTest, voltage: float, settings: Settings) -> dict:
    """The direct parameters (mm, s, N) of the recorded force of ``test``: Spencer's damper at
    ``voltage`` scaled by the test's force factor, with the load-cell offset folded into x₀."""
    p, c, s = mr_damper.SPENCER_1997, mr_damper._coefficients(voltage, mr_damper.SPENCER_1997), test.scale
    k1 = p["k1"] / mr_damper.MM_PER_CM * s  # N/cm → N/mm, then the scale
    x0 = p["x0"] * mr_damper.MM_PER_CM - settings.force_offset_N / k1
    return {
        "c0": c["c0"] / mr_damper.MM_PER_CM * s,
        "c1": c["c1"] / mr_damper.MM_PER_CM * s,
        "k0": p["k0"] / mr_damper.MM_PER_CM * s,
        "k1": k1,
        "x0": x0,
        "alpha": c["alpha"] / mr_damper.MM_PER_CM * s,
        "beta": p["beta"] / mr_damper.MM_PER_CM ** p["n"],
        "gamma": p["gamma"] / mr_damper.MM_PER_CM ** p["n"],
        "A": p["A"],
        "n": p["n"],
    }


def file_names() -> list[str]:
    """The names of the files ``generate`` writes (tests, then the manifest), without writing any."""
    return [f"mr_{amplitude:g}mm_{frequency:g}Hz_{voltage:g}V.csv" for amplitude, frequency, voltage in TESTS] + [
        MANIFEST
    ]


def generate(out_dir=DATASET_DIR, settings: Settings = Settings()) -> list[Path]:
    """Write the tests and their manifest into ``out_dir``; returns the paths written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    children = np.random.SeedSequence(settings.seed).spawn(len(TESTS))
    entries, written = [], []
    for (amplitude, frequency, voltage), child in zip(TESTS, children):
        test = mr_damper.sine_test(
            amplitude_mm=amplitude,
            frequency_hz=frequency,
            voltage=voltage,
            rate_hz=settings.rate_hz,
            cycles=settings.cycles,
            peak_force_N=settings.peak_force_N,
            force_noise_frac=settings.force_noise_frac,
            displacement_noise_mm=settings.displacement_noise_mm,
            force_offset_N=settings.force_offset_N,
            rng=np.random.default_rng(child),
            velocity_noise_mm_s=settings.velocity_noise_mm_s,
        )
        name = f"mr_{amplitude:g}mm_{frequency:g}Hz_{voltage:g}V.csv"
        path = out_dir / name
        write_text(path, mr_damper.render(test, velocity=True))
        written.append(path)
        entries.append(
            {
                "file": name,
                "synthetic": True,
                "model": "spencer",
                "amplitude_mm": amplitude,
                "frequency_Hz": frequency,
                "voltage_V": voltage,
                "force_scale": round(test.scale, 6),
                "noise_force_N": round(settings.force_noise_frac * settings.peak_force_N, 6),
                "truth": {k: float(f"{v:.10g}") for k, v in truth(test, voltage, settings).items()},
            }
        )
    document = {
        "note": NOTE,
        "source": SOURCE,
        "generator": "bwbench data generate --mr-damper (src/bwbench/datasets/mr_dataset.py)",
        "settings": {
            **dataclasses.asdict(settings),
            "noise_force_N": settings.force_noise_frac * settings.peak_force_N,
        },  # 1σ of the scaled force
        "units": {
            "time": "s",
            "displacement": "mm",
            "velocity": "mm/s",
            "force": "N",
            "truth": "Spencer's direct parameters: c0, c1 N·s/mm; k0, k1, alpha N/mm; x0 mm; beta, gamma mm^-n",
        },
        "specimens": entries,
    }
    write_text(out_dir / MANIFEST, json.dumps(document, indent=1) + "\n")
    written.append(out_dir / MANIFEST)
    return written
