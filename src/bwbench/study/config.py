"""Study configurations (TOML): which problem and specimens, which backends, how many seeds, one budget.

Generic format (``studies/quick.toml`` is a worked example)::

    [study]
    name = "quick"            # default database: reports/<name>/study.sqlite
    seed = 20261121           # study seed (non-negative integer)
    budget = 4100             # evaluations, identical for every backend
    seeds = 5                 # replicates per (specimen, backend)
    problem = "hysteresis"    # the default (any hysteresis model; formerly "switched-bouc-wen"); see `bwbench.problems`
    plugins = ["my_model.py"] # optional: models, problems or backends loaded from files (relative to this TOML)
    # ... the problem's own keys (e.g. state, excitation, data)

    [specimens]               # the problem's own table: which data sets
    [optimizers]              # every backend with its options (empty table = defaults)
    random = {}
    pso = { n_particles = 40 }

    [validation]              # optional (hysteresis problem): held-out tests, never fitted
    files = ["held_out/*.csv"]  # every ranking run's fit predicts them; the report ranks by that error too

    [posterior]               # optional: the posterior, kept out of the ranking
    specimens = ["pom-mt24u01_0.01MPa_r1"]   # names (file stems); may be omitted with one specimen
    optimizer = "nested"      # the default: nested sampling, every mode and ln Z ("emcee" also works)
    budget = 6000000          # the default: a cap on evaluations (runs stop once they agree); optional
    seeds = 1                 # the default
    options = {}              # on top of POSTERIOR_OPTIONS (what converges without options)

    # several samplers on the same specimens and budget, compared in the report:
    # optimizer = ["nested", "emcee"]
    # options = { emcee = { n_walkers = 32 } }   # then one table per sampler (omitted: its defaults)

A study comparing models samples each model's posterior (the last formulation listed for it), so
the report can weigh the models by their evidence.

The problem's keys and tables are read by its ``ProblemType.configure``
(``bwbench.problems.hysteresis.study``, ``bwbench.problems.noel_schoukens.study``). Every mistake
raises ``UserError`` naming the file and the key, e.g.
``studies/x.toml: [study] budget must be a positive integer``.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

import bwbench.limits as limits
import bwbench.problems as problems
from bwbench.data.input_files import read_text
from bwbench.errors import UserError
from bwbench.problems.base import ProblemSetup, integer
from bwbench.study.config_checks import bounded, canonical_json, check_backend, resolve_backend_options
from bwbench.study.posterior_config import PosteriorConfig, posterior_table, posterior_variants

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

GENERIC_STUDY_KEYS = ("name", "seed", "budget", "seeds", "problem", "plugins")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


@dataclass(frozen=True)
class StudyConfig:
    """A validated, resolved study: specimens listed, options merged with the backends' defaults."""

    path: str  # the configuration file, as the user named it ("--specimens" for a study without one)
    root: Path  # what relative paths are relative to: the TOML's folder (or the current one)
    name: str
    seed: int
    budget: int
    seeds: int
    problem: str
    setup: ProblemSetup
    optimizers: dict  # name -> resolved options, in file order
    posterior: PosteriorConfig | None
    validation: tuple = ()  # of SpecimenEntry: held-out tests each fit predicts (the report's held-out error)

    @property
    def specimens(self) -> tuple:
        return self.setup.specimens

    @property
    def settings(self) -> dict:
        """The problem's settings, as every worker gets them."""
        return self.setup.settings

    @property
    def default_db(self) -> Path:
        """Next to the TOML (or in the current folder), never inside the installed package."""
        return self.root / f"{self.name}.sqlite"

    def to_json_dict(self) -> dict:
        """What defines the study's results (not where files are): compared on resume."""
        posterior = None
        if self.posterior is not None:
            p = self.posterior
            several = len(p.backends) > 1  # one sampler: stored as before, so stored studies keep their hash
            posterior = {
                "specimens": [s.name for s in p.specimens],
                "optimizer": [b for b, _ in p.backends] if several else p.optimizer,
                "budget": p.budget,
                "seeds": p.seeds,
                "options": dict(p.backends) if several else p.options,
            }
            digests = {s.name: s.meta["sha256"] for s in p.specimens if "sha256" in s.meta}
            if digests:  # the data the posterior reads are part of the identity too
                posterior["sha256"] = digests
        study = {
            "name": self.name,
            "seed": self.seed,
            "budget": self.budget,
            "seeds": self.seeds,
            **self.setup.study_json,
        }
        out = {
            "study": study,
            "specimens": self.setup.specimens_json,
            "optimizers": self.optimizers,
            "posterior": posterior,
        }
        if self.validation:  # absent without held-out files: stored studies keep their hash
            out["validation"] = {e.name: e.meta.get("sha256") for e in self.validation}
        return out

    def canonical_json(self) -> str:
        return canonical_json(self.to_json_dict())

    @property
    def config_hash(self) -> str:
        return hashlib.sha256(self.canonical_json().encode("utf-8")).hexdigest()


def read_toml(path) -> dict:
    where = str(path)
    text = read_text(path)  # a regular file of bounded size, or one line naming it (a FIFO would block)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise UserError(f"{where}: invalid TOML: {err}") from None


def load_study_config(path, data=None) -> StudyConfig:
    """Read, validate and resolve a study TOML; raise ``UserError`` naming the file and key.

    Relative paths in it resolve against its own folder. ``data``: the command line's ``--data``
    (relative to the current directory), replacing the problem's data location.
    """
    where = str(path)
    document = read_toml(path)

    def fail(message):
        raise UserError(f"{where}: {message}")

    if not isinstance(document.get("study"), dict):
        fail("missing table [study]")
    study = document["study"]
    given = study.get("plugins", [])
    if not isinstance(given, list) or not all(isinstance(p, str) for p in given):
        fail('[study] plugins must be a list of Python files, e.g. plugins = ["my_model.py"]')
    import bwbench.plugins as plugins  # before any name is looked up: a file may give the model or backend

    plugins.load_files([Path(path).resolve().parent / p for p in given], f"{where}: [study] plugins:")
    problem_name = study.get("problem", problems.DEFAULT)
    if isinstance(problem_name, str):
        problem_name = problems.current_name(problem_name)
    if not isinstance(problem_name, str) or problem_name not in problems.names():
        fail(f"[study] problem must be one of {', '.join(repr(n) for n in problems.names())}, got {problem_name!r}")
    problem_type = problems.get(problem_name)
    for key, why in problem_type.not_applicable.items():
        if key in study or key in document:
            what = f"[{key}]" if key in document else f"[study] {key}"
            fail(f"{what} does not apply to problem {problem_name!r} ({why}): remove it")
    known_tables = ("study", "optimizers", "posterior", *problem_type.tables)
    unknown = [t for t in document if t not in known_tables]
    if unknown:
        fail(f"unknown table [{unknown[0]}] (expected {', '.join(f'[{t}]' for t in known_tables)})")
    if not isinstance(document.get("optimizers"), dict):
        fail("missing table [optimizers]")
    known_keys = (*GENERIC_STUDY_KEYS, *problem_type.study_keys)
    unknown = [k for k in study if k not in known_keys]
    if unknown:
        fail(f"[study] unknown key {unknown[0]!r} (known: {', '.join(known_keys)})")
    for key in ("name", "seed", "budget", "seeds"):
        if key not in study:
            fail(f"[study] {key} is required")

    name = study["name"]
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        fail("[study] name must be a non-empty string of letters, digits, '.', '_' or '-' (it names a folder)")
    seed = integer(fail, "[study] seed", study["seed"], minimum=0, what="a non-negative integer")
    budget = bounded(fail, "[study] budget", integer(fail, "[study] budget", study["budget"]), "BWBENCH_MAX_BUDGET")
    seeds = bounded(fail, "[study] seeds", integer(fail, "[study] seeds", study["seeds"]), "BWBENCH_MAX_SEEDS")
    root = Path(path).resolve().parent

    optimizers_table = document["optimizers"]
    if not optimizers_table:
        fail("[optimizers] names no backend")
    for backend in optimizers_table:
        check_backend(fail, "[optimizers]", backend)
    optimizers = {
        backend: resolve_backend_options(fail, f"[optimizers] {backend}", backend, options)
        for backend, options in optimizers_table.items()
    }

    setup = problem_type.configure(fail, study, document, root, data)
    posterior = None
    if "posterior" in document:
        posterior = posterior_table(fail, document["posterior"], setup)
    validation = ()
    if "validation" in document:
        validation = held_out(fail, problem_type, document["validation"], root, setup)
        setup = with_locations(setup, validation)
    return check_plan_size(
        fail,
        StudyConfig(
            path=where,
            root=root,
            name=name,
            seed=seed,
            budget=budget,
            seeds=seeds,
            problem=problem_name,
            setup=setup,
            optimizers=optimizers,
            posterior=posterior,
            validation=validation,
        ),
    )


def held_out(fail, problem_type, table, base_dir, setup, label: str = "[validation] files") -> tuple:
    """The held-out specimens of a ``[validation]`` table (``files = [...]``, relative to ``base_dir``) or
    of ``--validate``: read and checked now; none may be a training specimen."""
    if label.startswith("[validation]"):
        if not isinstance(table, dict) or set(table) != {"files"}:
            fail('[validation] must be a table with one key, files = ["held_out/*.csv", ...]')
        table = table["files"]
    entries = problem_type.held_out_entries(fail, table, base_dir, label)
    training = {e.name for e in setup.specimens}
    for entry in entries:
        if entry.name in training:
            fail(f"{label}: {entry.name} is also a training specimen: a held-out test must not be fitted")
    return tuple(entries)


def with_locations(setup, validation):
    """``setup`` with the held-out files' paths in its data location (where the report finds them)."""
    import dataclasses

    location = dict(setup.data_location) if isinstance(setup.data_location, dict) else {}
    return dataclasses.replace(
        setup, data_location={**location, **{e.name: str(Path(e.path).resolve()) for e in validation}}
    )


def planned_runs(config: StudyConfig) -> int:
    """How many runs ``config`` has, counted without listing them."""
    variants = max(1, len(config.setup.variants))
    runs = config.seeds * len(config.specimens) * len(config.optimizers) * variants
    if config.posterior is not None:
        p = config.posterior
        runs += p.seeds * len(p.specimens) * len(p.backends) * len(posterior_variants(config.setup))
    return runs


def check_plan_size(fail, config: StudyConfig) -> StudyConfig:
    """``config``, or ``fail`` when it has more runs than ``BWBENCH_MAX_RUNS``: checked before the runs
    are listed, which for a mistyped seed count would take minutes and gigabytes."""
    variants = max(1, len(config.setup.variants))
    shape = (
        f" ({config.seeds:,} seeds × {len(config.specimens)} specimens × {len(config.optimizers)} backends"
        + (f" × {variants} formulations" if variants > 1 else "")
        + (" + posterior" if config.posterior else "")
        + ")"
    )
    try:
        limits.check("the study's number of runs", planned_runs(config), "BWBENCH_MAX_RUNS", shape)
    except UserError as err:
        fail(str(err))
    return config


def config_from_arguments(
    specimens,
    optimizers: str,
    seeds: int,
    budget: int,
    *,
    name: str = "study",
    seed: int = 0,
    state: str | None = None,
    excitation: str = "measured",
    bounds_file=None,
    formulation: str | None = None,
    model: str | None = None,
    fix_mass="auto",
    offsets: str = "branch",
    validate=None,
    initial_state="auto",
    warmup_s=0.0,
) -> StudyConfig:
    """A study over the files ``specimens`` (paths or globs, relative to the current folder) with no
    TOML and no manifest: ``bwbench compare --specimens ...``. ``model`` and ``formulation``: a name
    or comma-separated names (None: the switched model, and each model's own formulation);
    ``bounds_file``: a JSON search box, read by the problem type (it knows the parameter names);
    ``fix_mass``/``offsets``: the identifiable formulation's (read by the problem type); ``validate``:
    held-out files (paths or globs) every fit predicts; ``initial_state``/``warmup_s``: how every model
    starts each record (``bwbench.models.start``)."""

    def fail(message):
        raise UserError(message)

    if not _NAME.fullmatch(name):
        fail("--name must be letters, digits, '.', '_' or '-' (it names the database)")
    bounded(fail, "--seeds", integer(fail, "--seeds", seeds), "BWBENCH_MAX_SEEDS")
    bounded(fail, "--budget", integer(fail, "--budget", budget), "BWBENCH_MAX_BUDGET")
    integer(fail, "--seed", seed, minimum=0, what="a non-negative integer")
    names = [o.strip() for o in optimizers.split(",") if o.strip()]
    if not names:
        fail("--optimizers names no backend (e.g. --optimizers cmaes,random)")
    if len(set(names)) != len(names):
        fail("--optimizers names a backend twice")
    for backend in names:
        check_backend(fail, "--optimizers", backend)
    resolved = {backend: resolve_backend_options(fail, f"--optimizers {backend}", backend, {}) for backend in names}
    root = Path.cwd()
    problem_type = problems.get(problems.DEFAULT)
    setup = problem_type.setup_from_files(
        fail,
        list(specimens),
        root,
        state=state,
        excitation=excitation,
        bounds_file=bounds_file,
        formulation=formulation,
        model=model,
        fix_mass=fix_mass,
        offsets=offsets,
        initial_state=initial_state,
        warmup_s=warmup_s,
    )
    validation = ()
    if validate:
        validation = held_out(fail, problem_type, list(validate), root, setup, "--validate")
        setup = with_locations(setup, validation)
    return check_plan_size(
        fail,
        StudyConfig(
            path="--specimens",
            root=root,
            name=name,
            seed=seed,
            budget=budget,
            seeds=seeds,
            problem=problems.DEFAULT,
            setup=setup,
            optimizers=resolved,
            posterior=None,
            validation=validation,
        ),
    )
