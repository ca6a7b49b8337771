"""The study database (SQLite): created, checked against the configuration, one transaction per run.

Schema (the report reads it; names are a contract):

- ``study(key, value)``: ``name``, ``config_json``, ``config_hash``, ``created_utc``, ``bwbench_version``,
  and where the data of the latest run were (where ``bwbench report`` looks first; not part of the
  configuration): ``data_paths`` (JSON, specimen name -> file) or ``data_dir`` (a folder).
- ``runs``: one row per finished run, keyed by (kind, specimen, optimizer, replicate); no wall
  time, so rows are identical whoever ran them and when. Columns for any problem: ``problem``,
  ``params_json`` (the parameters by name) and ``metrics_json`` (the problem's own metrics of the
  best point, e.g. the benchmark's test e_RMS; null where not finite; NULL for a run that raised).
  The columns named after the switched model (its 14 parameters, ``state``, ``excitation``,
  ``material``, ``underpressure_MPa``, ``repeat``, ``rmse_N``) are filled by the problems that have
  such values (``ProblemType.record_columns``) and NULL otherwise. Databases written before the three
  generic columns existed get them (NULL) when a study is resumed.
- ``timings``: wall time (s), worker (``host:pid``) and finish time (UTC) of each run.
- ``traces``: the best-so-far improvements (evaluation count, loss) of each run.
- ``chains``: MCMC chains (float64, unit coordinates, shape (steps, walkers, dim)) of runs that
  return one (emcee).
"""

from __future__ import annotations

import json
import sqlite3
import sys
from datetime import datetime, timezone
from pathlib import Path

from bwbench import __version__
from bwbench.errors import UserError
from bwbench.models.switched_bouc_wen import PARAM_NAMES
from bwbench.study.config import StudyConfig, describe_differences

GENERIC_COLUMNS = ("problem", "params_json", "metrics_json")  # usable by any problem
RUN_COLUMNS = (
    "kind", "specimen", "optimizer", "replicate", "seed_entropy", "status", "error", "budget",
    "nfev", "mse", "f_err", "rmse_N", "success", "message", "state", "excitation", "material",
    "underpressure_MPa", "repeat", "options_json", *PARAM_NAMES, *GENERIC_COLUMNS,
)
_KEY_SQL = "kind TEXT, specimen TEXT, optimizer TEXT, replicate INTEGER"
_PK_SQL = "PRIMARY KEY (kind, specimen, optimizer, replicate)"
SCHEMA = f"""
CREATE TABLE IF NOT EXISTS study (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS runs (
    {_KEY_SQL}, seed_entropy TEXT, status TEXT, error TEXT, budget INTEGER, nfev INTEGER,
    mse REAL, f_err REAL, rmse_N REAL, success INTEGER, message TEXT, state TEXT, excitation TEXT,
    material TEXT, underpressure_MPa REAL, repeat INTEGER, options_json TEXT,
    {", ".join(f'"{name}" REAL' for name in PARAM_NAMES)},
    problem TEXT, params_json TEXT, metrics_json TEXT,
    {_PK_SQL});
CREATE TABLE IF NOT EXISTS timings ({_KEY_SQL}, wall_s REAL, worker TEXT, finished_utc TEXT, {_PK_SQL});
CREATE TABLE IF NOT EXISTS traces ({_KEY_SQL}, nfev INTEGER, mse REAL);
CREATE INDEX IF NOT EXISTS traces_key ON traces (kind, specimen, optimizer, replicate);
CREATE TABLE IF NOT EXISTS chains (
    {_KEY_SQL}, steps INTEGER, walkers INTEGER, dim INTEGER, chain BLOB, log_prob BLOB,
    acceptance_fraction REAL, autocorr_json TEXT, {_PK_SQL});
"""


def utc_now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def open_database(path, config: StudyConfig) -> sqlite3.Connection:
    """Create the study database, or reopen it after checking it holds this very configuration.

    Raises ``UserError`` if the file is not a study database or was made by another configuration.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    conn = sqlite3.connect(path, timeout=60, isolation_level=None)  # transactions are explicit
    try:
        # One write transaction for check-and-create: two studies started at once on one new file
        # cannot both create it with different configurations.
        conn.execute("BEGIN IMMEDIATE")
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if tables and "study" not in tables:
            raise UserError(f"{path}: not a bwbench study database (no 'study' table); choose another --db")
        if "study" in tables:
            _check_same_study(conn, path, config)
            _add_generic_columns(conn)
        else:
            for statement in SCHEMA.split(";"):
                if statement.strip():
                    conn.execute(statement)
            conn.executemany("INSERT INTO study (key, value) VALUES (?, ?)", [
                ("name", config.name), ("config_json", config.canonical_json()),
                ("config_hash", config.config_hash), ("created_utc", utc_now()),
                ("bwbench_version", __version__),
            ])
        location = config.setup.data_location  # where the data are now: for the report, not the identity
        if isinstance(location, dict):
            conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('data_paths', ?)",
                         (json.dumps(location, sort_keys=True),))
        elif location:
            conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('data_dir', ?)", (location,))
        conn.execute("COMMIT")
    except sqlite3.DatabaseError as err:
        conn.close()
        raise UserError(f"{path}: cannot use as a study database: {err}") from None
    except BaseException:
        conn.close()
        raise
    return conn


def _add_generic_columns(conn) -> None:
    """Give a database from before the generic columns existed those columns (NULL in old rows)."""
    present = {r[1] for r in conn.execute("PRAGMA table_info(runs)")}
    for column in GENERIC_COLUMNS:
        if column not in present:
            conn.execute(f"ALTER TABLE runs ADD COLUMN {column} TEXT")


def _check_same_study(conn, path, config: StudyConfig) -> None:
    """The configuration must be the stored one, or extend it (more seeds, backends or specimens, the
    same settings for what both have): then the stored one is replaced and only the new runs run."""
    stored = dict(conn.execute("SELECT key, value FROM study"))
    if stored.get("config_hash") == config.config_hash:
        if stored.get("bwbench_version") != __version__:
            print(f"note: {path} was started with bwbench {stored.get('bwbench_version')}, "
                  f"this is {__version__}", file=sys.stderr)
        return
    new = config.to_json_dict()
    try:
        old = json.loads(stored["config_json"])
        changes = extension_conflicts(old, new)
    except (KeyError, TypeError, ValueError, AttributeError):
        changes = ["the stored configuration is unreadable"]
    if changes:
        shown = "; ".join(changes[:4]) + (f"; and {len(changes) - 4} more" if len(changes) > 4 else "")
        raise UserError(
            f"{config.path} differs from the study in {path} ({shown}): pass --db with another path "
            f"to keep both, or delete {path} to start over"
        )
    conn.executemany("INSERT OR REPLACE INTO study (key, value) VALUES (?, ?)",
                     [("config_json", config.canonical_json()), ("config_hash", config.config_hash)])
    print(f"note: {config.path} extends the study in {path}: its finished runs are kept, only the new ones run",
          file=sys.stderr)


def extension_conflicts(old: dict, new: dict) -> list[str]:
    """Why ``new`` (a ``StudyConfig.to_json_dict()``) cannot continue the study ``old``: [] when it
    has the same settings and every specimen, backend and seed of ``old``, perhaps more.

    A configuration stored before specimens were identified by their bytes (``specimens`` held
    ``files`` and manifest ``filters``, ``[study] data`` a path) is compared by specimen names.
    """
    legacy = "files" in old.get("specimens", {})
    old_study, new_study = dict(old.get("study", {})), dict(new.get("study", {}))
    old_seeds, new_seeds = old_study.pop("seeds", None), new_study.pop("seeds", None)
    if legacy:
        old_study.pop("data", None)
    out = describe_differences(old_study, new_study, "study.")
    if new_seeds is None or old_seeds is None or new_seeds < old_seeds:
        out.append(f"study.seeds: {old_seeds} -> {new_seeds} (fewer seeds than already run)")
    old_specimens, new_specimens = old.get("specimens", {}), new.get("specimens", {})
    if legacy:
        missing = [s for s in old_specimens.get("files", []) if s not in new_specimens]
    else:
        missing = [s for s in old_specimens if s not in new_specimens]
        out += [f"specimen {s}: its data changed (SHA-256 differs)" for s in old_specimens
                if s in new_specimens and old_specimens[s] != new_specimens[s]]
    out += [f"specimen {s} removed" for s in missing]
    for name, options in old.get("optimizers", {}).items():
        if name not in new.get("optimizers", {}):
            out.append(f"optimizers.{name} removed")
        elif new["optimizers"][name] != options:
            out += describe_differences(options, new["optimizers"][name], f"optimizers.{name}.")
    old_posterior, new_posterior = old.get("posterior"), new.get("posterior")
    if old_posterior is not None and new_posterior is not None and "sha256" not in old_posterior:
        new_posterior = {k: v for k, v in new_posterior.items() if k != "sha256"}  # stored before data hashes
    if old_posterior is not None and old_posterior != new_posterior:
        out += describe_differences({"posterior": old_posterior}, {"posterior": new_posterior})
    return out


def finished_keys(conn) -> set:
    return {tuple(r) for r in conn.execute("SELECT kind, specimen, optimizer, replicate FROM runs")}


def record_run(conn, outcome: dict) -> bool:
    """Write one finished run in one transaction; False (and nothing written) if already there."""
    key = outcome["key"]
    placeholders = ", ".join("?" * len(RUN_COLUMNS))
    columns = ", ".join(f'"{c}"' for c in RUN_COLUMNS)
    conn.execute("BEGIN IMMEDIATE")
    try:
        cursor = conn.execute(f"INSERT OR IGNORE INTO runs ({columns}) VALUES ({placeholders})",
                              [outcome["row"][c] for c in RUN_COLUMNS])
        if cursor.rowcount == 0:
            conn.execute("ROLLBACK")
            return False
        t = outcome["timing"]
        conn.execute("INSERT OR REPLACE INTO timings VALUES (?, ?, ?, ?, ?, ?, ?)",
                     (*key, t["wall_s"], t["worker"], t["finished_utc"]))
        conn.executemany("INSERT INTO traces VALUES (?, ?, ?, ?, ?, ?)",
                         [(*key, int(n), float(m)) for n, m in outcome["trace"]])
        c = outcome["chain"]
        if c is not None:
            conn.execute("INSERT OR REPLACE INTO chains VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                         (*key, c["steps"], c["walkers"], c["dim"], c["chain"], c["log_prob"],
                          c["acceptance_fraction"], c["autocorr_json"]))
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    return True
