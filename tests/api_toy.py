"""A toy test for the Python API's tests and notebooks: the classic Bouc-Wen model (identifiable
formulation, known coefficients) driven by a two-tone displacement, force with Gaussian noise.
Not from bwbench's generators: a DataFrame built here, with the specimen file's column names."""

import numpy as np
import pandas as pd

TRUTH = {"xy": 2.0, "n": 1.5, "eta": 0.3, "m": 0.0, "c": 0.8, "k": 5.0, "h": 60.0, "f": 3.0}  # mm, -, -, N·s²/mm, ...
NOISE_N = 2.0


def toy_frame(seed: int, n: int = 400, noise: float = NOISE_N, dt: float = 0.005) -> pd.DataFrame:
    """time_s, displacement_mm (8 mm at 1 Hz + 3 mm at 2.3 Hz), velocity_mm_s (exact), force_N (the
    classic Bouc-Wen force of ``TRUTH`` + N(0, noise²) N)."""
    from bwbench.data.specimen_input import from_frame
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    t = np.arange(n) * dt
    x = 8.0 * np.sin(2 * np.pi * t) + 3.0 * np.sin(2 * np.pi * 2.3 * t)
    v = 16.0 * np.pi * np.cos(2 * np.pi * t) + 13.8 * np.pi * np.cos(2 * np.pi * 2.3 * t)
    frame = pd.DataFrame({"time_s": t, "displacement_mm": x, "force_N": np.zeros(n), "velocity_mm_s": v})
    model = FittedModel("bouc-wen", "identifiable", TRUTH)
    force = model.force(model.signal(from_frame(frame, "toy")))
    return frame.assign(force_N=force + noise * np.random.default_rng(seed).standard_normal(n))
