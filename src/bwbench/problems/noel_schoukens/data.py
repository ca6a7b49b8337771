"""The Noël–Schoukens benchmark's data files: ``time_s,force_N,displacement_m`` at 750 Hz.

The files are read from a folder the user gives (default: a ``shared/benchmarks/bouc-wen`` folder
beside the repository's folder); they are never copied into the project.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bwbench.errors import InputFileError
from bwbench.problems.noel_schoukens.force_driven_bouc_wen import SAMPLE_RATE_HZ

PERIOD_SAMPLES = 8192
TRAIN_PERIODS = 5
FILES = ("train_multisine.csv", "test_multisine.csv", "test_sinesweep.csv")
COLUMNS = ("time_s", "force_N", "displacement_m")
# Time stamps are printed with 8 decimals: allow that rounding, refuse any other sample rate.
_TIME_TOLERANCE_S = 2e-6


def default_data_dir() -> Path:
    """The ``shared/benchmarks/bouc-wen`` folder beside the repository's folder (beside the current
    folder for an installed bwbench)."""
    from bwbench.datasets.shipped import working_root

    return working_root().parent / "shared" / "benchmarks" / "bouc-wen"


# ---------------------------------------------------------------------------------------------
# Data files


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class BenchmarkRecord:
    """One benchmark file: time (s), force u (N) and displacement y (m), all the same length."""

    path: str
    name: str
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray

    @property
    def n_samples(self) -> int:
        return int(self.t.size)


def read_benchmark_csv(path) -> BenchmarkRecord:
    """Read a ``time_s,force_N,displacement_m`` file sampled at 750 Hz.

    Raises ``InputFileError(path, line, problem)`` for a missing or unreadable file (line None),
    a wrong header, a row that is not three finite numbers, time not increasing by 1/750 s.
    """
    path = str(path)
    try:
        with open(path, encoding="utf-8-sig") as fh:
            text = fh.read()
    except FileNotFoundError:
        raise InputFileError(path, None, "no such file") from None
    except IsADirectoryError:
        raise InputFileError(path, None, "is a directory, not a file") from None
    except UnicodeDecodeError:
        raise InputFileError(path, None, "not UTF-8 text") from None
    except OSError as err:
        raise InputFileError(path, None, f"cannot read file: {err.strerror or err}") from None
    lines = text.split("\n")
    header = [name.strip() for name in lines[0].strip().split(",")]
    if tuple(header) != COLUMNS:
        raise InputFileError(path, 1, f"header must be {','.join(COLUMNS)}, found {lines[0].strip()[:60]!r}")
    values: list = []
    for line_no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != len(COLUMNS):
            raise InputFileError(path, line_no, f"{len(cells)} cells on this row, expected {len(COLUMNS)}")
        try:
            row = [float(cell) for cell in cells]
        except ValueError:
            raise InputFileError(path, line_no, f"not a number in {line.strip()[:60]!r}") from None
        if not all(math.isfinite(v) for v in row):
            raise InputFileError(path, line_no, f"value is not finite in {line.strip()[:60]!r}")
        if values:
            dt = row[0] - values[-1][0]
            if abs(dt - 1.0 / SAMPLE_RATE_HZ) > _TIME_TOLERANCE_S:
                raise InputFileError(
                    path, line_no, f"time step {dt:.8g} s, expected 1/{SAMPLE_RATE_HZ:g} s (uniform 750 Hz)"
                )
        values.append(row)
    if len(values) < 2:
        raise InputFileError(path, None, "fewer than two data rows")
    data = np.array(values, dtype=np.float64)
    t, u, y = (np.ascontiguousarray(data[:, j]) for j in range(3))
    for arr in (t, u, y):
        arr.flags.writeable = False
    return BenchmarkRecord(path=path, name=Path(path).stem, t=t, u=u, y=y)


def one_period(record: BenchmarkRecord, n_periods: int) -> np.ndarray:
    """The input's period, after checking the file holds ``n_periods`` identical periods."""
    if record.n_samples != n_periods * PERIOD_SAMPLES:
        raise InputFileError(
            record.path,
            None,
            f"{record.n_samples} samples, expected {n_periods} period(s) of {PERIOD_SAMPLES} ({n_periods * PERIOD_SAMPLES})",
        )
    periods = record.u.reshape(n_periods, PERIOD_SAMPLES)
    worst = float(np.max(np.abs(periods - periods[0]))) if n_periods > 1 else 0.0
    if worst > 1e-9 * max(1.0, float(np.max(np.abs(periods[0])))):
        bad = int(np.argmax(np.max(np.abs(periods - periods[0]), axis=0) == worst))
        row = int(np.argmax(np.abs(periods[:, bad] - periods[0, bad]))) * PERIOD_SAMPLES + bad
        raise InputFileError(record.path, row + 2, f"force is not periodic with {PERIOD_SAMPLES} samples")
    return np.ascontiguousarray(periods[0])
