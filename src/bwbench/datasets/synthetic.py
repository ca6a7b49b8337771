"""The synthetic specimens: 3 materials × 5 underpressures × 3 repeats, from paper Tables 6–8.

The paper's raw curves are not public, so the dataset is generated, deterministically, from its
identified parameters. What is simulated is the test machine, not the model's sine:

- displacement: triangular, ±10 mm at a crosshead speed of 5 mm/min, 4 full cycles starting upward
  from 0 mm (1,920 s); the crosshead reverses (and starts and stops) with a smooth half-cosine
  velocity blend over ``reversal_s`` seconds instead of jumping between ±5 mm/min;
- the force is the switched model (shared state) driven by the exact displacement, velocity and
  acceleration on a 20× finer grid, then kept at the 1 Hz recording rate (1,921 samples);
- repeats: the elastic terms of each repeat are scaled by (1 + δ), δ uniform in ±3 % (ωn by
  √(1 + δ)), so peak forces of repeats differ by at most ~6 % — the paper reports ≤ 7 %;
- noise: load-cell noise N(0, 1 N) on the force, encoder noise N(0, 1 µm) on the displacement;
- the commanded crosshead velocity is logged beside them (``velocity_mm_s``, exact, printed to
  1e-8 mm/s), as a test machine logs it: with it the model sees the velocity the force was made
  with, so the truth's MSE is the force noise (0.92–1.07 σ² on the 45 specimens; with the former
  Savitzky–Golay estimate from the noisy displacement it was 2.6–46 σ²). The acceleration is not logged (machines
  rarely do): its inertia force is ≤ 0.033 N here, and bwbench's estimate of it from the logged
  velocity is off by 7·10⁻⁵ mm/s² rms.

Every draw comes from ``SeedSequence(SEED)`` spawned per specimen, and numbers are written with
fixed formats, so ``bwbench data generate`` reproduces the committed files byte for byte.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bwbench.data import strict_json
from bwbench.data.manifest import MANIFEST
from bwbench.data.output_paths import write_text
from bwbench.datasets import shipped
from bwbench.models.switched import simulation as model
from bwbench.models.switched.kernel import PARAM_NAMES

PAPER_PARAMETERS = shipped.PAPER_TABLES / "identified_parameters.csv"
SPECIMEN_DIR = shipped.SPECIMENS
SYNTHETIC_NOTE = "synthetic data generated from the paper's Tables 6–8 (raw curves not public)"


@dataclass(frozen=True)
class Settings:
    amplitude_mm: float = 10.0
    speed_mm_per_min: float = 5.0
    cycles: int = 4
    sample_rate_hz: float = 1.0
    reversal_s: float = 8.0
    fine_factor: int = 20
    repeat_spread: float = 0.03
    noise_force_n: float = 1.0
    noise_displacement_mm: float = 0.001
    start_delay_s: float = 0.5
    state: str = "shared"
    seed: int = 20181208  # the paper's online date


def triangular_motion(t, s: Settings):
    """Exact x (mm), ẋ (mm/s), ẍ (mm/s²) of the crosshead at times t (s), and the duration (s).

    Constant speed ±v between the peaks; each reversal (and the start from and stop to rest) is a
    half-cosine velocity blend over ``reversal_s``, so the acceleration is continuous, as a
    servo-driven crosshead's is. x is the exact integral of the velocity.
    """
    v0 = s.speed_mm_per_min / 60.0
    quarter = s.amplitude_mm / v0  # seconds from 0 mm to a peak at constant speed
    duration = 4 * quarter * s.cycles
    half = s.reversal_s / 2
    # Velocity blends (start time, v before, v after); constant velocity between them.
    blends = [(0.0, 0.0, v0)]
    sign = 1.0
    for k in range(2 * s.cycles):
        blends.append((quarter * (1 + 2 * k) - half, sign * v0, -sign * v0))
        sign = -sign
    blends.append((duration - 2 * half, sign * v0, 0.0))
    # The recording starts half a sample before the crosshead, so no sample falls exactly on a
    # reversal, where ẋ = 0 and the branch (and with it the force) would be a coin toss.
    t = np.asarray(t, dtype=float) - s.start_delay_s
    x = np.zeros_like(t)
    v = np.zeros_like(t)
    a = np.zeros_like(t)
    x_start = 0.0
    t_prev, v_prev = 0.0, 0.0
    for t0, va, vb in blends:
        tau = s.reversal_s if t0 > 0.0 and t0 < duration - 2 * half else 2 * half
        # Constant-velocity stretch before this blend.
        flat = (t >= t_prev) & (t < t0)
        x[flat] = x_start + v_prev * (t[flat] - t_prev)
        v[flat] = v_prev
        x_start += v_prev * (t0 - t_prev)
        mean, swing = 0.5 * (va + vb), 0.5 * (va - vb)
        w = np.pi / tau
        inside = (t >= t0) & (t <= t0 + tau)
        u = t[inside] - t0
        x[inside] = x_start + mean * u + swing / w * np.sin(w * u)
        v[inside] = mean + swing * np.cos(w * u)
        a[inside] = -swing * w * np.sin(w * u)
        x_start += mean * tau
        t_prev, v_prev = t0 + tau, vb
    return x, v, a, duration


def material_slug(material: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", material.lower()).strip("-")


def specimen_filename(material: str, underpressure: float, repeat: int) -> str:
    return f"{material_slug(material)}_{underpressure:.2f}MPa_r{repeat}.csv"


def read_paper_parameters(path=PAPER_PARAMETERS) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        row["params"] = np.array([float(row[name]) for name in PARAM_NAMES])
    return rows


def _render_specimen(t, x, v, f) -> str:
    out = io.StringIO()
    out.write("time_s,displacement_mm,velocity_mm_s,force_N\n")
    for ti, xi, vi, fi in zip(t, x, v, f):
        out.write(f"{ti:.1f},{xi:.5f},{vi:.8f},{fi:.4f}\n")
    return out.getvalue()


def file_names(paper=PAPER_PARAMETERS) -> list[str]:
    """The names of the files ``generate`` writes (specimens, then the manifest), without writing any."""
    rows = read_paper_parameters(paper)
    return [
        specimen_filename(row["material"], float(row["underpressure_MPa"]), repeat)
        for row in rows
        for repeat in (1, 2, 3)
    ] + [MANIFEST]


def generate(out_dir=SPECIMEN_DIR, settings: Settings = Settings(), paper=PAPER_PARAMETERS) -> list[Path]:
    """Write the 45 specimen CSVs and their manifest into ``out_dir``; returns the paths written."""
    s = settings
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = read_paper_parameters(paper)
    _, _, _, duration = triangular_motion(np.zeros(1), s)
    n_samples = int(round(duration * s.sample_rate_hz)) + 1  # the last half second is not recorded
    t_fine = np.arange((n_samples - 1) * s.fine_factor + 1) / (s.sample_rate_hz * s.fine_factor)
    x_f, v_f, a_f, _ = triangular_motion(t_fine, s)
    keep = slice(None, None, s.fine_factor)
    t = t_fine[keep]

    children = np.random.SeedSequence(s.seed).spawn(len(rows) * 3)
    manifest, written = [], []
    for i, row in enumerate(rows):
        for repeat in (1, 2, 3):
            rng = np.random.default_rng(children[3 * i + repeat - 1])
            delta = rng.uniform(-s.repeat_spread, s.repeat_spread)
            truth = row["params"].copy()
            truth[[6, 13]] *= np.sqrt(1.0 + delta)  # ωn±: elastic terms scale by (1 + δ)
            force = model.simulate(truth, t_fine, x_f, v_f, a_f, s.state)[keep]
            if not np.all(np.isfinite(force)):
                raise RuntimeError(f"truth parameters of {row['material']} {row['underpressure_MPa']} blow up")
            f_noisy = force + rng.normal(0.0, s.noise_force_n, force.shape)
            x_noisy = x_f[keep] + rng.normal(0.0, s.noise_displacement_mm, force.shape)
            underpressure = float(row["underpressure_MPa"])
            name = specimen_filename(row["material"], underpressure, repeat)
            path = out_dir / name
            write_text(path, _render_specimen(t, x_noisy, v_f[keep], f_noisy))
            written.append(path)
            manifest.append(
                {
                    "file": name,
                    "material": row["material"],
                    "table": int(row["table"]),
                    "underpressure_MPa": round(underpressure, 2),
                    "repeat": repeat,
                    "synthetic": True,
                    "state": s.state,
                    "force_scale": round(1.0 + delta, 6),
                    "peak_force_N": round(float(np.max(np.abs(force))), 4),
                    "truth": {name_: float(f"{value:.6g}") for name_, value in zip(PARAM_NAMES, truth)},
                }
            )
    document = {
        "note": SYNTHETIC_NOTE,
        "generator": "bwbench data generate (src/bwbench/datasets/synthetic.py)",
        "settings": dataclasses.asdict(s),
        "units": {
            "time": "s",
            "displacement": "mm",
            "velocity": "mm/s (commanded, exact)",
            "force": "N",
            "noise_force_N": "N (1 sigma)",
            "noise_displacement_mm": "mm (1 sigma)",
            "reversal_s": "s",
        },
        "specimens": manifest,
    }
    strict_json.write(out_dir / MANIFEST, document, indent=1)
    written.append(out_dir / MANIFEST)
    return written
