"""What a problem is, for the optimisers, the study runner, the store and the report.

Two objects, one per level:

``Problem`` (a protocol: any object with these members will do) is one fit of one model to one
data set — what ``Objective`` wraps and a backend minimises through it:

- ``param_names`` (tuple of str), ``lower``/``upper`` (physical bounds, arrays of length d),
  ``dim`` (= d), ``n_data`` (number of residuals the loss averages over);
- ``from_unit(U)`` / ``to_unit(P)``: unit coordinates u ∈ [0, 1]^d ↔ physical units, shape (..., d);
- ``loss_batch(P) -> (m,)``: the loss (a mean squared error, in ``ProblemType.loss_unit``) of each row
  of P (physical units, shape (m, d)); +inf where the model blows up, never NaN, never an exception;
- ``info`` (dict of scalars recorded with every result, e.g. specimen, state);
- ``parameters(P_row) -> dict``: the parameters of a best point to store, by name (default: the
  d coordinates; a problem may add derived ones, e.g. the same fit in another parametrisation).

``ProblemType`` (subclass it, one per module under ``problems/``) is everything a study and a report
need to know about a kind of problem, so that the runner, the store and the report never ask which
problem they are running:

- ``configure``: read the problem's own keys of a study TOML (``[study]`` keys it owns and its data
  tables) into a ``ProblemSetup``: the settings a worker needs to build each ``Problem``, the
  specimens, and what of them is part of the study's identity (a hash of the data the loss reads);
- ``make_problem(settings, entry)``: build the ``Problem`` of one specimen in a worker;
- ``run_metrics`` / ``record_columns``: what to store with a finished run besides the loss;
- ``setup_text``, ``report_intro``, ``ranking_columns``, ``report_sections``, ``noise_floor``,
  ``limits``: the report's problem-specific parts.

A new problem is one module (or sub-package) that subclasses ``ProblemType``: in another package,
an instance named by an entry point of the group ``bwbench.problems`` (every process of a study
loads it; ``examples/problem_plugin/``), or ``bwbench.problems.register`` from code for this
process only; nothing else changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, NoReturn, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Problem(Protocol):
    param_names: tuple
    lower: np.ndarray
    upper: np.ndarray
    info: dict

    @property
    def dim(self) -> int: ...

    @property
    def n_data(self) -> int: ...

    def from_unit(self, U) -> np.ndarray: ...

    def to_unit(self, P) -> np.ndarray: ...

    def loss_batch(self, P) -> np.ndarray: ...


@dataclass(frozen=True)
class SpecimenEntry:
    """One data set of a study: its name (the ``specimen`` of every run), where it is, and facts
    about it (e.g. material, underpressure_MPa, repeat) that the report may group by."""

    name: str
    path: str
    meta: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ProblemSetup:
    """What ``ProblemType.configure`` read from a study TOML.

    ``settings``: JSON-able, handed to ``make_problem`` in every worker. ``study_json`` and
    ``specimens_json``: the problem's part of the study's identity (its ``[study]`` keys and its
    ``[specimens]`` table as resolved), compared when a study is resumed. ``specimens``: the
    ranking specimens in order; ``available``: every specimen a ``[posterior]`` may name, by name.
    ``data_location``: where the data are now, a folder or {specimen name: file} (recorded for the
    report; not part of the identity).
    """

    settings: dict
    study_json: dict
    specimens_json: dict
    specimens: tuple
    available: dict
    data_location: str | dict | None = None
    # Variants of the problem compared side by side, (label, settings) each; () = one, ``settings``.
    # Every backend runs on every variant; a run is labelled "backend [label]".
    variants: tuple = ()


class ProblemType:
    """Base class of a problem plug-in; override what differs (see the module docstring)."""

    name = "problem"
    description = ""
    loss_unit = "N²"  # unit of the loss (a mean squared residual)
    residual_unit = "N"  # unit of its square root
    study_keys: tuple = ()  # the [study] keys this problem reads, besides the generic ones
    tables: tuple = ("specimens",)  # top-level TOML tables this problem reads
    # Generic keys and tables that make no sense for this problem, with the reason: refused, not
    # ignored (a setting that silently does nothing would be read as part of the result).
    not_applicable: dict = {}

    def configure(self, fail, study: dict, document: dict, base_dir: Path, data_override=None) -> ProblemSetup:
        raise NotImplementedError

    def setup_from_files(self, fail, files, base_dir: Path, **settings) -> ProblemSetup:
        """A setup over the data files ``files`` (paths or globs) with no TOML: ``compare --specimens``;
        ``settings`` are the command's own flags (model, formulation, state, excitation, bounds_file)."""
        fail(f"problem {self.name!r} does not read specimen files given on the command line")
        raise NotImplementedError  # not reached: ``fail`` raises

    def make_problem(self, settings: dict, entry: SpecimenEntry):
        raise NotImplementedError

    def models(self, settings: dict) -> tuple:
        """The ``bwbench.models`` models (by name) that ``make_problem`` fits with these settings: every
        study worker loads them before a run. By default the one named by ``settings["model"]``, the
        convention of the model-based problems; a problem whose settings use that key otherwise says ()."""
        model = settings.get("model")
        return (model,) if isinstance(model, str) else ()

    def run_metrics(self, problem, result) -> dict:
        """Problem-specific numbers of a run's best point, stored as ``metrics_json`` (None = not finite)."""
        return {}

    def record_columns(self, settings: dict, entry: SpecimenEntry, result=None) -> dict:
        """Values for the store's fixed ``runs`` columns that this problem fills (e.g. state, model, and
        with a finished ``result`` its RMSE); the store ignores names it
        has no column for. Called with ``result=None`` for what is known before the run."""
        return {}

    def specimen_meta(self, entry: SpecimenEntry) -> dict:
        """What this problem knows of a run's specimen beyond its data (e.g. a manifest's material),
        stored with the run (``meta_json``) and read back as columns of the runs table."""
        return {}

    def summary_columns(self, runs) -> dict:
        """Extra columns (name -> text) of ``bwbench compare``'s summary for one backend's ranking runs."""
        return {}

    def data_dir(self, study, override=None) -> Path | None:
        """Where the report finds the study's data files (``override``: the user's ``--data``)."""
        return Path(override) if override else None

    def noise_floor(self, study, specimen: str) -> float | None:
        """The loss a perfect fit reaches on ``specimen`` (e.g. the truth's MSE), if known."""
        return None

    def is_synthetic(self, study) -> bool | str:
        """True, or a text naming the data's source, when the study's data are synthetic (a false value
        for measured data): reports mark every figure and banner with it."""
        return False

    def setup_text(self, report) -> str:
        """A sentence for the report's "What was compared" (model variant, data, search box)."""
        return ""

    def report_intro(self, report) -> None:
        """Sections right after "What was compared" (e.g. the data; a benchmark's headline result)."""

    def ranking_columns(self, report, table) -> dict:
        """Extra columns (name -> values in ``table``'s order) for the report's ranking table."""
        return {}

    def report_sections(self, report) -> None:
        """Add this problem's sections and figures to ``report`` (a ``bwbench.report.build.Report``),
        after the ranking and the run figures."""

    def limits(self, report) -> list[str]:
        """Problem-specific items for the report's "Limits of this study" list."""
        return []


# Checks for ``configure`` implementations: ``fail`` raises a UserError naming the file.
Fail = Callable[[str], NoReturn]


def integer(fail, label, value, minimum=1, what="a positive integer") -> int:
    # bool is an int subclass: `budget = true` must not read as 1.
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        fail(f"{label} must be {what}")
    return int(value)


def choice(fail, label, value, choices) -> str:
    if value not in choices:
        fail(f"{label} must be one of {', '.join(repr(c) for c in choices)}, got {value!r}")
    return value
