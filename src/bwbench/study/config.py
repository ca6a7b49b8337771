"""Study configurations (TOML): which specimens, which backends, how many seeds, one budget.

Format (``studies/quick.toml`` is a worked example)::

    [study]
    name = "quick"            # default database: reports/<name>/study.sqlite
    seed = 20261121           # study seed (non-negative integer)
    budget = 4100             # evaluations, identical for every backend
    seeds = 5                 # replicates per (specimen, backend)
    state = "shared"          # or "split"
    excitation = "measured"   # or "sine"
    data = "data/specimens"   # folder with manifest.json
    problem = "switched-bouc-wen"   # the default; or "bouc-wen-benchmark" (see below)

    [specimens]               # manifest filters, each a value or a list; omitted key = all
    material = ["POM MT24u01"]
    underpressure_MPa = [0.01, 0.09]
    repeat = [1]

    [optimizers]              # every backend with its options (empty table = defaults)
    random = {}
    pso = { n_particles = 40 }

    [posterior]               # optional: long MCMC runs, kept out of the ranking
    specimens = ["pom-mt24u01_0.01MPa_r1"]   # file stems
    optimizer = "emcee"
    budget = 40000
    seeds = 1
    options = {}

Relative paths (``data``, and the default database) are relative to the repository root: the
parent of the ``studies/`` folder holding the configuration, or, for a configuration kept
anywhere else, the bwbench checkout itself. ``--data PATH`` on the command line (relative to the
current directory) replaces ``[study] data``.

Problems (``[study] problem``):

- ``"switched-bouc-wen"`` (default): the paper's 14-parameter switched model fitted to the
  specimens of ``data`` (a folder with manifest.json) selected by ``[specimens]``. ``state`` and
  ``excitation`` choose the model variant. ``data`` is part of the configuration hash as written
  (the folder defines the specimens). With ``problem`` absent the hash is the one of earlier
  versions: ``problem`` enters the canonical JSON only when it is not the default.
- ``"bouc-wen-benchmark"``: the Noël–Schoukens benchmark (``bwbench.problems.noel_schoukens.problem``), one
  "specimen", ``train_multisine``. ``data`` is the benchmark folder (default
  ``boucwen_benchmark.default_data_dir()``, i.e. ``../shared/benchmarks/bouc-wen`` beside the
  repository). ``[specimens]``, ``state`` and ``excitation`` do not apply to it and are refused
  (not ignored: a setting that silently does nothing would be read as part of the result).
  ``[posterior] specimens`` may be omitted (it can only be ``["train_multisine"]``). The hash
  holds the SHA-256 of the three benchmark files, not their folder: the same data moved
  elsewhere (or reached through ``--data``) resume the same study, changed data are refused.

Every mistake raises ``UserError`` naming the file and the key, e.g.
``studies/x.toml: [study] budget must be a positive integer``.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

from bwbench.models import switched_bouc_wen as model
from bwbench.optimize import registry
from bwbench.errors import UserError
from bwbench.data.synthetic import MANIFEST, REPO, load_manifest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

STUDY_KEYS = ("name", "seed", "budget", "seeds", "state", "excitation", "data", "problem")
DEFAULT_PROBLEM = "switched-bouc-wen"
BENCHMARK_PROBLEM = "bouc-wen-benchmark"
PROBLEMS = (DEFAULT_PROBLEM, BENCHMARK_PROBLEM)
BENCHMARK_SPECIMEN = "train_multisine"
BENCHMARK_FILES = ("train_multisine.csv", "test_multisine.csv", "test_sinesweep.csv")
# Keys that make no sense for the benchmark: refused there, with the reason.
_NOT_FOR_BENCHMARK = {
    "state": "it has a single hysteretic variable",
    "excitation": "its input is the measured force, not a displacement",
}
FILTER_KEYS = ("material", "table", "underpressure_MPa", "repeat")
POSTERIOR_KEYS = ("specimens", "optimizer", "budget", "seeds", "options")
EXCITATIONS = ("measured", "sine")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


@dataclass(frozen=True)
class SpecimenEntry:
    """One specimen of a study: its file stem (the ``specimen`` of every run) and manifest facts."""

    name: str
    path: str
    material: str
    underpressure_MPa: float
    repeat: int


@dataclass(frozen=True)
class PosteriorConfig:
    specimens: tuple  # of SpecimenEntry
    optimizer: str
    budget: int
    seeds: int
    options: dict  # the backend's defaults updated with the configured options


@dataclass(frozen=True)
class StudyConfig:
    """A validated, resolved study: specimens listed, options merged with the backends' defaults."""

    path: str  # the configuration file, as the user named it
    root: Path  # what relative paths are relative to
    name: str
    seed: int
    budget: int
    seeds: int
    state: str
    excitation: str
    data: str  # as written in the file
    filters: dict  # manifest column -> tuple of accepted values
    specimens: tuple  # of SpecimenEntry, manifest order
    optimizers: dict  # name -> resolved options, in file order
    posterior: PosteriorConfig | None
    problem: str = DEFAULT_PROBLEM
    data_dir: Path | None = None  # the resolved data folder (after --data)
    data_sha256: str | None = None  # bouc-wen-benchmark: digest of its three files

    @property
    def default_db(self) -> Path:
        return self.root / "reports" / self.name / "study.sqlite"

    def to_json_dict(self) -> dict:
        """What defines the study's results (not where files are): compared on resume."""
        posterior = None
        if self.posterior is not None:
            p = self.posterior
            posterior = {"specimens": [s.name for s in p.specimens], "optimizer": p.optimizer,
                         "budget": p.budget, "seeds": p.seeds, "options": p.options}
        if self.problem == BENCHMARK_PROBLEM:
            from bwbench.problems.noel_schoukens import problem as bm

            return {
                "study": {"name": self.name, "seed": self.seed, "budget": self.budget, "seeds": self.seeds,
                          "problem": self.problem, "data_sha256": self.data_sha256,
                          # the problem's fixed settings: a code change to them is a different study
                          "settings": {"train_period": bm.TRAIN_PERIODS, "steps_per_sample": bm.STEPS_PER_SAMPLE,
                                       "warmup_samples": bm.WARMUP_SAMPLES}},
                "specimens": {"files": [s.name for s in self.specimens]},
                "optimizers": self.optimizers,
                "posterior": posterior,
            }
        study = {"name": self.name, "seed": self.seed, "budget": self.budget, "seeds": self.seeds,
                 "state": self.state, "excitation": self.excitation, "data": self.data}
        if self.problem != DEFAULT_PROBLEM:  # absent for the default: old hashes stay valid
            study["problem"] = self.problem
        return {
            "study": study,
            "specimens": {"filters": {k: list(v) for k, v in self.filters.items()},
                          "files": [s.name for s in self.specimens]},
            "optimizers": self.optimizers,
            "posterior": posterior,
        }

    def canonical_json(self) -> str:
        return canonical_json(self.to_json_dict())

    @property
    def config_hash(self) -> str:
        return hashlib.sha256(self.canonical_json().encode("utf-8")).hexdigest()


def canonical_json(value) -> str:
    """Sorted keys, no spaces: equal configurations give equal text (and hash)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def repository_root(config_path) -> Path:
    folder = Path(config_path).resolve().parent
    return folder.parent if folder.name == "studies" else REPO


def load_study_config(path, data=None) -> StudyConfig:
    """Read, validate and resolve a study TOML; raise ``UserError`` naming the file and key.

    ``data``: the command line's ``--data`` (relative to the current directory), replacing the
    file's ``[study] data``.
    """
    where = str(path)
    try:
        with open(path, "rb") as fh:
            document = tomllib.load(fh)
    except FileNotFoundError:
        raise UserError(f"{where}: no such file") from None
    except IsADirectoryError:
        raise UserError(f"{where}: is a directory, not a study TOML") from None
    except tomllib.TOMLDecodeError as err:
        raise UserError(f"{where}: invalid TOML: {err}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise UserError(f"{where}: cannot read file: {err}") from None

    def fail(message):
        raise UserError(f"{where}: {message}")

    unknown = set(document) - {"study", "specimens", "optimizers", "posterior"}
    if unknown:
        fail(f"unknown table [{sorted(unknown)[0]}] (expected [study], [specimens], [optimizers], [posterior])")
    for table in ("study", "optimizers"):
        if not isinstance(document.get(table), dict):
            fail(f"missing table [{table}]")
    study = document["study"]
    _refuse_unknown(fail, "study", study, STUDY_KEYS)
    for key in ("name", "seed", "budget", "seeds"):
        if key not in study:
            fail(f"[study] {key} is required")

    name = study["name"]
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        fail("[study] name must be a non-empty string of letters, digits, '.', '_' or '-' (it names a folder)")
    seed = _integer(fail, "[study] seed", study["seed"], minimum=0, what="a non-negative integer")
    budget = _integer(fail, "[study] budget", study["budget"])
    seeds = _integer(fail, "[study] seeds", study["seeds"])
    problem = _choice(fail, "[study] problem", study.get("problem", DEFAULT_PROBLEM), PROBLEMS)
    root = repository_root(path)

    optimizers_table = document["optimizers"]
    if not optimizers_table:
        fail("[optimizers] names no backend")
    for name_ in optimizers_table:
        _check_backend(fail, "[optimizers]", name_)
    optimizers = {name_: _resolve_options(fail, f"[optimizers] {name_}", name_, options)
                  for name_, options in optimizers_table.items()}
    common = {"path": where, "root": root, "name": name, "seed": seed, "budget": budget, "seeds": seeds,
              "optimizers": optimizers, "problem": problem}
    if problem == BENCHMARK_PROBLEM:
        return _benchmark_config(fail, document, study, data, common)

    state = _choice(fail, "[study] state", study.get("state", "shared"), model.STATES)
    excitation = _choice(fail, "[study] excitation", study.get("excitation", "measured"), EXCITATIONS)
    if data is None:
        data = study.get("data", "data/specimens")
        if not isinstance(data, str) or not data:
            fail("[study] data must be a folder path (a string)")
        data_dir = Path(data) if Path(data).is_absolute() else root / data
    else:
        data_dir = Path(data).resolve()
        data = str(data_dir)
    manifest = _read_manifest(fail, data_dir)

    filters_table = document.get("specimens", {})
    if not isinstance(filters_table, dict):
        fail("[specimens] must be a table of manifest filters")
    _refuse_unknown(fail, "specimens", filters_table, FILTER_KEYS)
    filters = {key: _filter_values(fail, key, value) for key, value in filters_table.items()}
    selected = _select(fail, manifest, filters)

    posterior = None
    if "posterior" in document:
        posterior = _posterior(fail, document["posterior"], manifest, data_dir)

    return StudyConfig(
        **common, state=state, excitation=excitation, data=data, filters=filters,
        specimens=tuple(_entry(fail, row, data_dir) for row in selected), posterior=posterior,
        data_dir=data_dir,
    )


def _benchmark_config(fail, document, study, data, common) -> StudyConfig:
    """The ``bouc-wen-benchmark`` part of ``load_study_config``."""
    from bwbench.problems.noel_schoukens import problem as boucwen_benchmark

    for key, why in _NOT_FOR_BENCHMARK.items():
        if key in study:
            fail(f"[study] {key} does not apply to problem {BENCHMARK_PROBLEM!r} ({why}): remove it")
    if "specimens" in document:
        fail(f"[specimens] does not apply to problem {BENCHMARK_PROBLEM!r} (its one specimen is "
             f"{BENCHMARK_SPECIMEN}): remove the table")
    if data is not None:
        data_dir = Path(data).resolve()
        written = str(data)
    elif "data" in study:
        written = study["data"]
        if not isinstance(written, str) or not written:
            fail("[study] data must be a folder path (a string)")
        data_dir = Path(written) if Path(written).is_absolute() else common["root"] / written
    else:
        data_dir = boucwen_benchmark.default_data_dir()
        written = str(data_dir)
    missing = [f for f in BENCHMARK_FILES if not (data_dir / f).is_file()]
    if missing:
        fail(f"[study] data: the Bouc-Wen benchmark files are not in {data_dir} (missing {', '.join(missing)}); "
             "point to the folder with [study] data = \"PATH\" or --data PATH")
    entry = SpecimenEntry(name=BENCHMARK_SPECIMEN, path=str(data_dir), material=None, underpressure_MPa=None,
                          repeat=None)

    posterior = None
    if "posterior" in document:
        table = document["posterior"]
        if not isinstance(table, dict):
            fail("[posterior] must be a table")
        names = table.get("specimens", [BENCHMARK_SPECIMEN])
        if names != [BENCHMARK_SPECIMEN]:
            fail(f"[posterior] specimens: problem {BENCHMARK_PROBLEM!r} has one specimen, "
                 f"[\"{BENCHMARK_SPECIMEN}\"] (or omit the key)")
        manifest = [{"file": f"{BENCHMARK_SPECIMEN}.csv"}]
        posterior = _posterior(fail, {**table, "specimens": names}, manifest, data_dir, lambda *_: entry)

    return StudyConfig(
        **common, state=None, excitation=None, data=written, filters={}, specimens=(entry,),
        posterior=posterior, data_dir=data_dir, data_sha256=data_digest(data_dir, BENCHMARK_FILES),
    )


def data_digest(folder: Path, files) -> str:
    """SHA-256 over the named files' bytes, in order: what the data are, wherever they are."""
    digest = hashlib.sha256()
    for name in files:
        digest.update(name.encode("utf-8") + b"\0")
        digest.update((folder / name).read_bytes())
    return digest.hexdigest()


def _refuse_unknown(fail, table, values, known) -> None:
    unknown = [k for k in values if k not in known]
    if unknown:
        fail(f"[{table}] unknown key {unknown[0]!r} (known: {', '.join(known)})")


def _integer(fail, label, value, minimum=1, what="a positive integer") -> int:
    # bool is an int subclass: `budget = true` must not read as 1.
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        fail(f"{label} must be {what}")
    return int(value)


def _choice(fail, label, value, choices) -> str:
    if value not in choices:
        fail(f"{label} must be one of {', '.join(repr(c) for c in choices)}, got {value!r}")
    return value


def _read_manifest(fail, data_dir: Path) -> list[dict]:
    try:
        document = load_manifest(data_dir)
        if document is None:
            fail(f"[study] data: no {MANIFEST} in {data_dir}")
        return list(document["specimens"])
    except (OSError, ValueError, KeyError, TypeError) as err:
        fail(f"[study] data: cannot read {data_dir / MANIFEST}: {err}")


def _filter_values(fail, key, value) -> tuple:
    values = value if isinstance(value, list) else [value]
    if not values:
        fail(f"[specimens] {key} is an empty list: it would select nothing (omit the key for all)")
    numeric = key in ("table", "underpressure_MPa", "repeat")
    for v in values:
        ok = (isinstance(v, (int, float)) and not isinstance(v, bool)) if numeric else isinstance(v, str)
        if not ok:
            fail(f"[specimens] {key} must be {'numbers' if numeric else 'strings'}, got {v!r}")
    return tuple(values)


def _matches(key, manifest_value, wanted) -> bool:
    if key == "underpressure_MPa":
        return math.isclose(float(manifest_value), float(wanted), rel_tol=0.0, abs_tol=1e-9)
    return manifest_value == wanted


def _select(fail, manifest, filters) -> list[dict]:
    for key, values in filters.items():
        present = sorted({row[key] for row in manifest}, key=str)
        for wanted in values:
            if not any(_matches(key, row[key], wanted) for row in manifest):
                fail(f"[specimens] {key}: no specimen has {wanted!r} (the manifest has "
                     f"{', '.join(str(p) for p in present)})")
    selected = [row for row in manifest
                if all(any(_matches(k, row[k], w) for w in values) for k, values in filters.items())]
    if not selected:
        fail("[specimens] the filters together select no specimen")
    return selected


def _entry(fail, row, data_dir: Path) -> SpecimenEntry:
    if not (data_dir / row["file"]).is_file():
        fail(f"[study] data: {row['file']} is in {data_dir / MANIFEST} but not in the folder")
    return SpecimenEntry(
        name=Path(row["file"]).stem, path=str(data_dir / row["file"]), material=row["material"],
        underpressure_MPa=float(row["underpressure_MPa"]), repeat=int(row["repeat"]),
    )


def _check_backend(fail, label, optimizer) -> None:
    backends = registry.available()
    if optimizer not in backends:
        fail(f"{label}: unknown optimiser {optimizer!r}; available: {', '.join(backends)}")


def _resolve_options(fail, label, optimizer, options) -> dict:
    backends = registry.available()
    if not isinstance(options, dict):
        fail(f"{label} must be a table of options (use {{}} for the defaults)")
    defaults = backends[optimizer].defaults
    unknown = sorted(set(options) - set(defaults))
    if unknown:
        fail(f"{label}: unknown option {unknown[0]!r}; it takes {', '.join(defaults) or 'none'}")
    resolved = {**defaults, **options}
    try:  # options are stored as JSON with every run: only plain values will do
        return json.loads(canonical_json(resolved))
    except (TypeError, ValueError):
        fail(f"{label}: options must be plain numbers, strings, booleans or lists of them")


def _posterior(fail, table, manifest, data_dir, make_entry=None) -> PosteriorConfig:
    if not isinstance(table, dict):
        fail("[posterior] must be a table")
    _refuse_unknown(fail, "posterior", table, POSTERIOR_KEYS)
    for key in ("specimens", "budget"):
        if key not in table:
            fail(f"[posterior] {key} is required")
    names = table["specimens"]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        fail("[posterior] specimens must be a non-empty list of file stems")
    by_stem = {Path(row["file"]).stem: row for row in manifest}
    for stem in names:
        if stem not in by_stem:
            fail(f"[posterior] specimens: no specimen {stem!r} in the manifest")
    if len(set(names)) != len(names):
        fail("[posterior] specimens lists a specimen twice")
    optimizer = table.get("optimizer", "emcee")
    if not isinstance(optimizer, str):
        fail("[posterior] optimizer must be a backend name")
    _check_backend(fail, "[posterior] optimizer", optimizer)
    make_entry = make_entry or _entry
    return PosteriorConfig(
        specimens=tuple(make_entry(fail, by_stem[stem], data_dir) for stem in names),
        optimizer=optimizer,
        budget=_integer(fail, "[posterior] budget", table["budget"]),
        seeds=_integer(fail, "[posterior] seeds", table.get("seeds", 1)),
        options=_resolve_options(fail, "[posterior] options", optimizer, table.get("options", {})),
    )


def describe_differences(old: dict, new: dict, prefix: str = "") -> list[str]:
    """Human-readable differences between two ``to_json_dict()`` values, e.g. ``study.budget: 200 -> 300``."""
    out = []
    for key in sorted(set(old) | set(new), key=str):
        label = f"{prefix}{key}"
        if key not in old:
            out.append(f"{label} added")
        elif key not in new:
            out.append(f"{label} removed")
        elif isinstance(old[key], dict) and isinstance(new[key], dict):
            out.extend(describe_differences(old[key], new[key], label + "."))
        elif old[key] != new[key]:
            a, b = canonical_json(old[key]), canonical_json(new[key])
            out.append(f"{label}: {a} -> {b}" if len(a) + len(b) <= 80 else f"{label} changed")
    return out
