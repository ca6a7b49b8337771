"""The Noël–Schoukens benchmark as a study problem (``problem = "bouc-wen-benchmark"``).

One "specimen", ``train_multisine``. ``[study] data`` is the benchmark folder (default
``data.default_data_dir()``, a ``shared/benchmarks/bouc-wen`` folder beside the repository's);
``--data PATH`` overrides it. ``[specimens]``, ``state`` and ``excitation`` do not apply and are
refused. The study's identity holds the SHA-256 of the three benchmark files, not their folder:
the same data moved elsewhere (or reached through ``--data``) resume the same study, changed data
are refused. Every run's best point is scored on ``test_multisine`` and ``test_sinesweep`` (e_RMS,
m) by the runner; the optimisers never see the test files.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from bwbench.data.identity import files_sha256
from bwbench.problems.base import ProblemSetup, ProblemType, SpecimenEntry
from bwbench.problems.noel_schoukens import data as bench_data
from bwbench.problems.noel_schoukens.force_driven_bouc_wen import STEPS_PER_SAMPLE, WARMUP_SAMPLES
from bwbench.problems.noel_schoukens.problem import TARGET_ERMS_M, TEST_SETS

SPECIMEN = "train_multisine"


def metric(runs, name: str) -> np.ndarray:
    """One metric of ``metrics_json`` per run (NaN where absent or not finite)."""

    def value(text):
        if not isinstance(text, str):
            return np.nan
        try:
            x = json.loads(text).get(name)
            return np.nan if x is None else float(x)
        except (ValueError, TypeError, AttributeError):  # a hand-edited cell (load_study names it)
            return np.nan

    return np.array([value(t) for t in runs["metrics_json"]], dtype=float)


def _json_number(x):
    x = float(x)
    return x if math.isfinite(x) else None  # JSON has no inf/NaN: null = not finite


class NoelSchoukens(ProblemType):
    name = "bouc-wen-benchmark"
    description = "the Noël–Schoukens Bouc-Wen benchmark: 8 parameters, force in, displacement out (loss: MSE in m²)"
    loss_unit = "m²"
    residual_unit = "m"
    study_keys = ("data",)
    tables = ()
    not_applicable = {
        "state": "it has a single hysteretic variable",
        "excitation": "its input is the measured force, not a displacement",
        "specimens": f"its one specimen is {SPECIMEN}",
    }

    def configure(self, fail, study, document, base_dir, data_override=None) -> ProblemSetup:
        if data_override is not None:
            data_dir = Path(data_override).resolve()
        elif "data" in study:
            written = study["data"]
            if not isinstance(written, str) or not written:
                fail("[study] data must be a folder path (a string)")
            data_dir = Path(written) if Path(written).is_absolute() else base_dir / written
        else:
            data_dir = bench_data.default_data_dir()
        missing = [f for f in bench_data.FILES if not (data_dir / f).is_file()]
        if missing:
            fail(
                f"[study] data: the Bouc-Wen benchmark files are not in {data_dir} (missing {', '.join(missing)}); "
                'point to the folder with [study] data = "PATH" or --data PATH'
            )
        entry = SpecimenEntry(name=SPECIMEN, path=str(data_dir))
        digest = files_sha256([data_dir / f for f in bench_data.FILES])
        return ProblemSetup(
            settings={},
            # the problem's fixed settings: a code change to them is a different study
            study_json={
                "problem": self.name,
                "data_sha256": digest,
                "settings": {
                    "train_period": bench_data.TRAIN_PERIODS,
                    "steps_per_sample": STEPS_PER_SAMPLE,
                    "warmup_samples": WARMUP_SAMPLES,
                },
            },
            specimens_json={"files": [SPECIMEN]},
            specimens=(entry,),
            available={SPECIMEN: entry},
            data_location=str(data_dir.resolve()),
        )

    def make_problem(self, settings, entry):
        from bwbench.problems.noel_schoukens.problem import BoucWenBenchmarkProblem

        return BoucWenBenchmarkProblem(entry.path)

    def run_metrics(self, problem, result) -> dict:
        """The e_RMS (m) of the best point on ``test_multisine`` and ``test_sinesweep`` and the training
        RMSE (m); the test files are used here only, never by the optimiser."""
        params = np.array([result.params[name] for name in problem.param_names])
        metrics = {"train_rmse_m": _json_number(math.sqrt(result.mse) if math.isfinite(result.mse) else math.inf)}
        for which in TEST_SETS:
            error = problem.test_error(params, which) if np.all(np.isfinite(params)) else math.inf
            metrics[f"{which}_erms_m"] = _json_number(error)
        return metrics

    def summary_columns(self, runs) -> dict:
        test = metric(runs, "test_multisine_erms_m")
        return {
            "median test e_RMS (m)": "-" if not np.isfinite(test).any() else f"{np.nanmedian(test):.2e}",
            f"test < {TARGET_ERMS_M:g} m": f"{int((test < TARGET_ERMS_M).sum())}/{len(runs)}",
        }

    def is_synthetic(self, study) -> str:
        """The benchmark's data are a simulated Bouc-Wen system with noise, published as a benchmark:
        the mark on every figure and the banner say so."""
        from bwbench.problems.noel_schoukens.benchmark_figures import DATA_MARK

        return DATA_MARK

    def data_dir(self, study, override=None) -> Path:
        if override is not None:
            return Path(override)
        recorded = study.meta.get("data_dir")
        return Path(recorded) if recorded and Path(recorded).is_dir() else bench_data.default_data_dir()

    def noise_floor(self, study, specimen):
        from bwbench.problems.noel_schoukens.analysis import load_problem
        from bwbench.problems.noel_schoukens.problem import TRUE_PARAMS

        return float(load_problem(study).loss_batch(TRUE_PARAMS[None, :])[0])

    def setup_text(self, report) -> str:
        from bwbench.problems.noel_schoukens import report as sections

        return sections.setup_text(report)

    def report_intro(self, report) -> None:
        from bwbench.problems.noel_schoukens import report as sections

        sections.report_intro(report)

    def ranking_columns(self, report, table) -> dict:
        from bwbench.problems.noel_schoukens import report as sections

        return sections.ranking_columns(report, table)

    def report_sections(self, report) -> None:
        from bwbench.problems.noel_schoukens import report as sections

        sections.add_sections(report)

    def limits(self, report) -> list[str]:
        from bwbench.problems.noel_schoukens import report as sections

        return sections.limits(report)


PROBLEM_TYPE = NoelSchoukens()
