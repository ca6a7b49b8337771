"""The Noël–Schoukens Bouc-Wen benchmark (2016): a second problem whose answer is known.

Fit the 8 parameters of the force-driven Bouc-Wen system (``bwbench.problems.noel_schoukens.force_driven_bouc_wen``)
to the measured displacement, with the true parameters ``TRUE_PARAMS`` (m = 2 kg, c = 10 N·s/m,
k = α = 5·10⁴ N/m, β = 10³ m⁻¹, γ = 0.8, δ = −1.1, ν = 1) known. Data: ``data.py``.

Loss
    MSE (m²) between the simulated periodic steady state and ONE period of ``train_multisine.csv``
    (default: period 5, the last; period 1 holds the start-up transient from rest). The measured
    y carries band-limited noise of 7.4·10⁻⁶ m RMS, so at the truth the loss is ≈ 5.5·10⁻¹¹ m².
    ``test_error`` gives the benchmark's e_RMS (m) on ``test_multisine`` (steady state) and on
    ``test_sinesweep`` (153,000 samples, from rest).

    Every positive parameter spans a factor of 10 each side of the truth and is log-scaled
    (unit coordinate ↦ log10 linearly, ``from_unit``/``to_unit``): m ∈ [0.2, 20] kg,
    c ∈ [1, 100] N·s/m, k ∈ [5e3, 5e5] N/m, α ∈ [5e3, 5e5] N/m, β ∈ [1e2, 1e4] m⁻¹,
    γ ∈ [0.08, 8]. Physically: with m and k+α a decade apart the first resonance
    √((k+α)/m)/2π ranges over 2.5–250 Hz, i.e. across and beyond the 5–150 Hz band of the
    excitation. δ is linear in [−3, 3] (sign free: the truth −1.1 is inside) and ν linear in
    [0.5, 3] (the truth 1 inside). For ν far above 3, |z|^ν with z ~ 30–50 N (z ≈ α·y) grows
    beyond 10⁵ and the z equation becomes so stiff (rate β·γ·ν·|ẏ|·|z|^(ν−1)) that it runs away
    or overflows; below 0.5, |z|^ν is sharply non-Lipschitz at z = 0. At the truth
    β(γ+δ) = −300 < 0, so the usual constraint β(γ+δ) > 0 is NOT imposed: it would exclude the
    truth. About 29 % of uniform points in the box give +inf: true runaways (β(γ+δ) < 0 with
    ν > 1 makes |z| blow up in finite time) and sets too stiff for 64 substeps (mostly ν ≳ 2.5,
    small m). Simulated at 18 kHz, the latter have RMS residuals ≥ 4.7e-4 m, 60× the noise: no
    optimum hides there.

Identifiability
    β appears only in the products β·γ and β·δ, so (β·s, γ/s, δ/s) gives exactly the same
    output for every s > 0: β, γ and δ are not separately identifiable, only βγ and βδ are.
    ``identifiable_combinations`` reports them. A fit's β, γ, δ should be compared with the
    truth through these products, never one by one.

Parameter sets whose state becomes non-finite (runaway, or a fixed step too long for a very
stiff set) get loss +inf: never NaN, never an exception.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bwbench.engine.box import box_from_unit, box_to_unit
from bwbench.problems.noel_schoukens.data import (
    PERIOD_SAMPLES,
    TRAIN_PERIODS,
    default_data_dir,
    one_period,
    read_benchmark_csv,
)
from bwbench.problems.noel_schoukens.force_driven_bouc_wen import (
    PARAM_NAMES,
    SAMPLE_RATE_HZ,
    STEPS_PER_SAMPLE,
    WARMUP_SAMPLES,
    mse_batch,
    simulate,
    upsample_from_rest,
    upsample_periodic,
)

TRUE_PARAMS = np.array([2.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1, 1.0])
LOWER = np.array([0.2, 1.0, 5e3, 5e3, 1e2, 0.08, -3.0, 0.5])
UPPER = np.array([20.0, 100.0, 5e5, 5e5, 1e4, 8.0, 3.0, 3.0])
LOG_SCALED = np.array([True, True, True, True, True, True, False, False])
NOISE_RMS_M = 7.4e-6  # the README's residual of the truth on train_multisine
TEST_SETS = ("test_multisine", "test_sinesweep")
TARGET_ERMS_M = 1e-5  # below the best published black-box e_RMS on test_multisine (1.2e-5 m)
_PERIODIC = {"train_multisine": True, "test_multisine": True, "test_sinesweep": False}


def from_unit(U) -> np.ndarray:
    """Unit coordinates of the benchmark's search box → physical units (log10-linear where log-scaled)."""
    return box_from_unit(U, LOWER, UPPER, LOG_SCALED)


def to_unit(P) -> np.ndarray:
    """Physical units → unit coordinates of the benchmark's search box (NaN for a non-positive log value)."""
    return box_to_unit(P, LOWER, UPPER, LOG_SCALED)


# ---------------------------------------------------------------------------------------------
# The problem


@dataclass
class BoucWenBenchmarkProblem:
    """Fit the 8 Bouc-Wen parameters to one period of ``train_multisine`` (loss: MSE in m²).

    ``data_dir`` holds the benchmark's CSV files (default ``default_data_dir()``); files are read
    when the problem is made (InputFileError if one is missing or malformed), the test files
    only when ``test_error`` first needs them. ``train_period`` (1–5) is the compared period.
    """

    data_dir: Path = None  # type: ignore[assignment]  # None: the default folder, set in __post_init__
    train_period: int = TRAIN_PERIODS
    steps_per_sample: int = STEPS_PER_SAMPLE
    warmup_samples: int = WARMUP_SAMPLES
    param_names: tuple = PARAM_NAMES
    lower: np.ndarray = field(default_factory=lambda: LOWER.copy())
    upper: np.ndarray = field(default_factory=lambda: UPPER.copy())
    log_scaled: np.ndarray = field(default_factory=lambda: LOG_SCALED.copy())

    def __post_init__(self):
        self.data_dir = Path(self.data_dir) if self.data_dir is not None else default_data_dir()
        if not 1 <= int(self.train_period) <= TRAIN_PERIODS:
            raise ValueError(f"train_period must be 1..{TRAIN_PERIODS}, got {self.train_period}")
        if np.any(self.log_scaled & (self.lower <= 0)):
            raise ValueError("log-scaled parameters need a positive lower bound")
        self.train = read_benchmark_csv(self.data_dir / "train_multisine.csv")
        u_period = one_period(self.train, TRAIN_PERIODS)
        start = (int(self.train_period) - 1) * PERIOD_SAMPLES
        self.y_period = np.ascontiguousarray(self.train.y[start : start + PERIOD_SAMPLES])
        self.input = upsample_periodic(u_period, self.steps_per_sample, self.warmup_samples)
        self._tests: dict = {}

    @property
    def name(self) -> str:
        return "train_multisine"

    @property
    def dim(self) -> int:
        return len(self.param_names)

    @property
    def n_data(self) -> int:
        """Number of displacement samples the loss averages over (one period)."""
        return int(self.y_period.size)

    @property
    def info(self) -> dict:
        return {
            "problem": "bouc-wen-benchmark",
            "specimen": "train_multisine",
            "train_period": int(self.train_period),
            "integration_rate_hz": SAMPLE_RATE_HZ * self.steps_per_sample,
            "warmup_samples": int(self.warmup_samples),
        }

    def from_unit(self, U) -> np.ndarray:
        """Unit coordinates → physical units; log-scaled parameters map linearly in log10."""
        return box_from_unit(U, self.lower, self.upper, self.log_scaled)

    def to_unit(self, P) -> np.ndarray:
        """Physical units → unit coordinates (NaN for a non-positive log-scaled value)."""
        return box_to_unit(P, self.lower, self.upper, self.log_scaled)

    def simulate(self, params) -> np.ndarray:
        """Steady-state y (m) over the compared training period; +inf everywhere on blow-up."""
        return simulate(params, self.input)

    def loss_batch(self, P) -> np.ndarray:
        """MSE (m²) of each row of P (physical units, shape (m, 8)); +inf where it blows up."""
        return mse_batch(P, self.input, self.y_period)

    def residual_batch(self, P) -> np.ndarray:
        """Model − measured displacement (m) over the compared period, shape (m, 8192); +inf rows on blow-up."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        R = np.stack([simulate(p, self.input) for p in P]) - self.y_period
        return np.where(np.all(np.isfinite(R), axis=1)[:, None], R, np.inf)

    def simulate_test(self, params, which: str = "test_multisine") -> np.ndarray:
        """Model y (m) on a test file's sample times: steady state (multisine) or from rest (sweep)."""
        record, inp = self._test(which)
        return simulate(params, inp)

    def test_error(self, params, which: str = "test_multisine") -> float:
        """The benchmark's e_RMS = sqrt(mean((y_model − y_test)²)) in m; inf on blow-up."""
        record, inp = self._test(which)
        y_model = simulate(params, inp)
        with np.errstate(all="ignore"):
            e = float(np.sqrt(np.mean((y_model - record.y) ** 2)))
        return e if math.isfinite(e) else math.inf

    def _test(self, which: str):
        if which not in TEST_SETS:
            raise ValueError(f"which must be one of {TEST_SETS}, got {which!r}")
        if which not in self._tests:
            record = read_benchmark_csv(self.data_dir / f"{which}.csv")
            if _PERIODIC[which]:
                inp = upsample_periodic(one_period(record, 1), self.steps_per_sample, self.warmup_samples)
            else:
                inp = upsample_from_rest(record.u, self.steps_per_sample)
            self._tests[which] = (record, inp)
        return self._tests[which]
