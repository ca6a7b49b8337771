"""The runs of a study: one ``Task`` per (kind, specimen, optimizer, replicate), and running one.

Every task has its own seed,
``SeedSequence(study seed, spawn_key=(crc32(kind), crc32(specimen), crc32(optimizer), replicate))``,
so a run's result depends neither on the number of workers nor on which other runs the study has.
A task names its problem type (``bwbench.problems``) and carries the problem's settings; the worker
asks that type to build the problem and to say what to store besides the loss.
"""

from __future__ import annotations

import math
import os
import socket
import time
import zlib
from dataclasses import dataclass

import numpy as np

import bwbench.problems as problems
from bwbench.database.writer import RUN_COLUMNS, utc_now
from bwbench.errors import UserError
from bwbench.problems.base import SpecimenEntry
from bwbench.study import failures
from bwbench.study.config import StudyConfig, canonical_json
from bwbench.study.posterior_config import posterior_variants


@dataclass(frozen=True)
class Task:
    """One run: everything a worker needs, picklable, no reference to the configuration file."""

    kind: str  # "ranking" or "posterior"
    optimizer: str  # the run's label: the backend, or "backend [variant]" when the problem has variants
    replicate: int  # 0-based
    entropy: int  # the study seed
    budget: int
    options: dict  # resolved (defaults merged)
    problem: str  # problem type name
    settings: dict  # the problem type's settings (of this variant)
    entry: SpecimenEntry
    backend: str = ""  # the registered backend ("" = optimizer)

    @property
    def backend_name(self) -> str:
        return self.backend or self.optimizer

    @property
    def specimen(self) -> str:
        return self.entry.name

    @property
    def key(self) -> tuple:
        return (self.kind, self.specimen, self.optimizer, self.replicate)


def task_seed(entropy: int, kind: str, specimen: str, optimizer: str, replicate: int) -> np.random.SeedSequence:
    """The seed of one run: a function of the study seed and the run's key only."""
    spawn_key = (
        zlib.crc32(kind.encode()),
        zlib.crc32(specimen.encode()),
        zlib.crc32(optimizer.encode()),
        int(replicate),
    )
    return np.random.SeedSequence(entropy=entropy, spawn_key=spawn_key)


def plan_tasks(config: StudyConfig) -> list[Task]:
    """Every run of the study: posterior runs first (the longest), then the ranking, replicate by
    replicate, so a study stopped early has every backend on the same specimens."""

    def task(kind, entry, backend, replicate, budget, options, variant=("", None)):
        label, settings = variant
        return Task(
            kind,
            run_label(backend, label),
            replicate,
            config.seed,
            budget,
            options,
            config.problem,
            settings or config.settings,
            entry,
            backend if label else "",
        )

    variants = config.setup.variants or (("", config.settings),)
    tasks = []
    p = config.posterior
    if p is not None:  # each model's last variant (the identifiable formulation, when both are), every sampler
        tasks += [
            task("posterior", entry, backend, r, p.budget, options, variant)
            for r in range(p.seeds)
            for entry in p.specimens
            for variant in posterior_variants(config.setup)
            for backend, options in p.backends
        ]
    tasks += [
        task("ranking", entry, optimizer, r, config.budget, options, variant)
        for r in range(config.seeds)
        for entry in config.specimens
        for variant in variants
        for optimizer, options in config.optimizers.items()
    ]
    return tasks


def run_label(backend: str, variant: str) -> str:
    """How a run's optimiser is named in the store and the report: "cmaes", or "cmaes [identifiable]"
    when the study compares variants of the problem side by side."""
    return f"{backend} [{variant}]" if variant else backend


def plugins_of(task: Task) -> list[tuple[str, str]]:
    """The plug-ins a worker loads by name to run ``task``: ("problem", its problem type), then
    ("model", name) for each model the problem fits (``ProblemType.models``)."""
    found = [("problem", task.problem)]
    try:
        found += [("model", name) for name in problems.get(task.problem).models(task.settings)]
    except UserError:  # the problem itself cannot be loaded here: missing_plugins says so
        pass
    return found


def missing_plugins(plugins) -> list[str]:
    """Load every plug-in of ``plugins`` ((kind, name) pairs, ``plugins_of``) in this process; one
    line for each that cannot be (not installed here, or failing to import), [] if all load."""
    from bwbench.models import registry as models

    loaders = {"problem": problems.get, "model": models.get}
    missing = []
    for kind, name in plugins:
        try:
            loaders[kind](name)
        except (UserError, ImportError) as err:
            missing.append(f"{kind} {name!r} ({err})")
    return missing


def refuse_plugins_only_here(tasks, where: str) -> None:
    """``UserError`` before any run if a task needs a problem or model registered in this process only
    (``bwbench.problems.register``, ``bwbench.models.registry.register``): ``where`` (other processes:
    spawned workers, a Dask cluster) would not find it, and every run would be lost. An installed
    plug-in (entry points ``bwbench.problems``/``bwbench.models``) or a built-in one loads anywhere."""
    from bwbench.models import registry as models

    only_here = {"problem": problems.only_in_this_process, "model": models.only_in_this_process}
    groups = {"problem": problems.ENTRY_POINT_GROUP, "model": models.ENTRY_POINT_GROUP}
    needed = dict.fromkeys(plugin for task in tasks for plugin in plugins_of(task))
    for kind, name in needed:
        if only_here[kind](name):
            raise UserError(
                f"{kind} {name!r} is registered in this process only (register()), so {where} cannot "
                f"load it: install it as a plug-in package (entry-point group {groups[kind]!r}; "
                "see examples/problem_plugin) or run the study in this process (--workers 1)"
            )


def run_task(task: Task, threads: int = 1) -> dict:
    """Run one task on ``threads`` threads (``bwbench.threads``); never raises for a failed run.

    Returns a plain dict: ``key``, ``row`` (the ``runs`` columns), ``timing``, ``trace``
    (list of (nfev, mse)) and ``chain`` (None, or the ``chains`` columns: posterior runs only).
    A run that raised has status "error" and a one-line message, unless the fault was the
    environment's (``bwbench.study.failures``): then the dict is ``{"key": ..., "lost": why}``, not a
    result, and the run is left for the next call.
    """
    from bwbench.engine import fitting
    from bwbench.threads import limited

    row = dict.fromkeys(RUN_COLUMNS)
    row.update(
        kind=task.kind,
        specimen=task.specimen,
        optimizer=task.optimizer,
        replicate=task.replicate,
        seed_entropy=str(task.entropy),
        budget=task.budget,
        options_json=canonical_json(task.options),
        success=0,
        problem=task.problem,
    )
    missing = missing_plugins(plugins_of(task))
    if missing:  # the study's process found them: this worker's environment lacks them
        return {
            "key": task.key,
            "lost": f"cannot load {missing[0]} on worker host {socket.gethostname()}: "
            "install the plug-in package where the workers run",
        }
    problem_type = problems.get(task.problem)
    _fill(row, problem_type.record_columns(task.settings, task.entry, None))
    row["meta_json"] = canonical_json(problem_type.specimen_meta(task.entry))
    trace, chain, transient = [], None, False
    # One thread per worker by default, numba's and BLAS/OpenMP's alike: the workers already fill the
    # cores, a BLAS-heavy backend's result must not depend on the thread count, and the wall time
    # recorded is then one core's.
    started = time.perf_counter()
    with limited(threads):
        try:
            problem = problem_type.make_problem(task.settings, task.entry)
            # The seed follows the backend, not the label: the variants of a run share its random stream.
            seed = task_seed(task.entropy, task.kind, task.specimen, task.backend_name, task.replicate)
            result = fitting.run(problem, task.backend_name, task.budget, seed, task.options)
            # Only posterior runs keep their chain: nothing reads a ranking run's, and at the paper's
            # budget it would be ~0.5 MB per emcee run, more than every other table together.
            chain = _chain_columns(result.extras) if task.kind == "posterior" else None
            # Made here: a problem's metric that JSON cannot hold is that run's error, not the study's.
            params_json = canonical_json({k: json_number(v) for k, v in result.params.items()})
            metrics_json = canonical_json(problem_type.run_metrics(problem, result))
            columns = problem_type.record_columns(task.settings, task.entry, result)
        except Exception as err:  # a deterministic failure is a result: record it, keep the study going
            transient = failures.is_transient(err)
            row.update(status="error", error=failures.one_line(err))
        else:
            _fill(row, columns)
            row.update(
                status="ok",
                nfev=result.nfev,
                mse=result.mse,
                f_err=result.f_err,
                success=int(result.success),
                message=result.message,
                params_json=params_json,
                metrics_json=metrics_json,
            )
            trace = list(zip(result.trace_nfev, result.trace_mse, strict=True))
        finally:
            wall = time.perf_counter() - started
    if transient:  # the environment's fault, not the run's: retry it later
        return {"key": task.key, "lost": row["error"]}
    timing = {"wall_s": wall, "worker": f"{socket.gethostname()}:{os.getpid()}", "finished_utc": utc_now()}
    return {"key": task.key, "row": row, "timing": timing, "trace": trace, "chain": chain}


def _fill(row: dict, columns: dict) -> None:
    # The store has a fixed set of columns: a problem's names without a column live in params_json.
    row.update({k: v for k, v in columns.items() if k in row and row[k] is None})


def json_number(x):
    x = float(x)
    return x if math.isfinite(x) else None  # JSON has no inf/NaN: null = not finite


# what a nested-sampling posterior says of each run, stored beside its draws (the verdict reads them)
EVIDENCE_KEYS = (
    "log_z",
    "log_z_err",
    "run_nfev",
    "run_complete",
    "live_points",
    "run_ess",
    "run_steps",
    "insertion",
    "profile",
)


def _chain_columns(extras: dict) -> dict | None:
    if extras.get("chain") is None:
        return None
    chain = np.ascontiguousarray(extras["chain"], dtype=np.float64)
    if chain.ndim != 3:
        raise ValueError(f"backend returned a chain of shape {chain.shape}, expected (steps, walkers, dim)")
    log_prob = extras.get("log_prob")
    acceptance = extras.get("acceptance_fraction")
    autocorr = extras.get("autocorr", extras.get("autocorr_time"))
    if autocorr is not None:
        autocorr = [float(a) if math.isfinite(a) else None for a in np.atleast_1d(np.asarray(autocorr, float))]
    steps, walkers, dim = chain.shape
    # a nested-sampling posterior: each run's ln Z with its error, evaluations and whether it ended by its
    # own rule (the chain holds each run's equal-weight draws side by side)
    evidence = {k: extras[k] for k in EVIDENCE_KEYS if k in extras}
    return {
        "evidence_json": canonical_json(evidence) if "log_z" in evidence else None,
        "steps": steps,
        "walkers": walkers,
        "dim": dim,
        "chain": chain.tobytes(),
        "log_prob": None if log_prob is None else np.ascontiguousarray(log_prob, dtype=np.float64).tobytes(),
        "acceptance_fraction": None if acceptance is None else float(np.mean(acceptance)),
        "autocorr_json": None if autocorr is None else canonical_json(autocorr),
    }
