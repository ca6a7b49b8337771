"""Tests of a controllable damper simulated with known laws of its control: what a fit with laws must give back.

``simulate(truth, tests)`` runs a ``ControlledModel`` (a model, its parameters and their laws of the
control) on each test's motion and control (a constant level, or a command that switches), adds
Gaussian force noise and returns ``Specimen`` objects carrying the control; ``write`` saves them as
CSV files with the control column. The velocity is recorded (the exact one), as an MR-damper rig
records it, so the fit sees the signal the force was made with.

``SPENCER_LAWS`` is a damper in the family the identifiable formulation of Spencer's model fits with
laws: the yield velocity v_y and the series damping c₁ linear in the voltage, the rest constant, of
the size of Spencer et al. (1997)'s prototype (z_s = 6.44 mm, c₁ ≈ 28 N·s/mm, α·z_s/c₁ = 3–38 mm/s
over 0–2.25 V).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bwbench.data.specimen import Specimen
from bwbench.problems.hysteresis.control.fitted import ControlledModel

CONTROL = "voltage_V"
SPENCER_LAWS = ControlledModel(
    "spencer",
    "identifiable",
    {
        "xy": 0.0214,
        "n": 2.0,
        "eta": 0.0,
        "vy@0V": 3.2,
        "vy@2.25V": 38.0,
        "r0": 0.08,
        "kappa0": 0.17,
        "c1@0V": 28.3,
        "c1@2.25V": 35.0,
        "k1": 0.5,
        "f0": -70.0,
    },
    {
        "name": CONTROL,
        "unit": "V",
        "laws": {
            "vy": {"law": "linear", "coefficients": ["vy@0V", "vy@2.25V"], "nodes": [0.0, 2.25]},
            "c1": {"law": "linear", "coefficients": ["c1@0V", "c1@2.25V"], "nodes": [0.0, 2.25]},
        },
    },
)


@dataclass(frozen=True)
class Test:
    """One test: a sine of ``amplitude_mm`` at ``frequency_hz`` for ``cycles`` cycles (starting in motion:
    the model pre-rolls a cycle), sampled at ``rate_hz``; the control at ``level`` or, with
    ``switch_hz``, a command switching between 0 and ``level`` at that rate."""

    name: str
    amplitude_mm: float
    frequency_hz: float
    level: float
    cycles: float = 2.0
    rate_hz: float = 200.0
    switch_hz: float | None = None


def motion(test: Test):
    t = np.arange(int(round(test.cycles * test.rate_hz / test.frequency_hz)) + 1) / test.rate_hz
    w = 2 * np.pi * test.frequency_hz
    x = test.amplitude_mm * np.sin(w * t)
    v = test.amplitude_mm * w * np.cos(w * t)
    if test.switch_hz is None:
        u = np.full(len(t), float(test.level))
    else:
        u = np.where(np.floor(t * 2 * test.switch_hz) % 2 == 1, float(test.level), 0.0)
    return t, x, v, u


def simulate(truth: ControlledModel, tests, noise_N: float = 2.0, seed: int = 0) -> list[Specimen]:
    """The specimens of ``tests`` under ``truth`` with Gaussian force noise of ``noise_N`` (N)."""
    rng = np.random.default_rng(seed)
    out = []
    for test in tests:
        t, x, v, u = motion(test)
        t, x, v, u = (np.round(a, 6) for a in (t, x, v, u))
        record = dict(
            path=f"{test.name}.csv", name=test.name, t=t, x=x, v=v, control=u, control_name=truth.control_name
        )
        force = truth.predict(Specimen(f=np.zeros(len(t)), **record)).force_N
        out.append(Specimen(f=np.round(force + noise_N * rng.standard_normal(len(t)), 4), **record))
    return out


def write(specimens, folder) -> list[str]:
    """Each specimen as ``<name>.csv`` in ``folder`` with its control column; the paths."""
    from pathlib import Path

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for s in specimens:
        path = folder / f"{s.name}.csv"
        rows = [f"time_s,displacement_mm,force_N,velocity_mm_s,{s.control_name}"]
        rows += [f"{a:.6g},{b:.6f},{c:.4f},{d:.6f},{e:g}" for a, b, c, d, e in zip(s.t, s.x, s.f, s.v, s.control)]
        path.write_text("\n".join(rows) + "\n")
        paths.append(str(path))
    return paths
