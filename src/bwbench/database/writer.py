"""The study database (SQLite): created, checked against the configuration, one transaction per run.

Schema (the report reads it; names are a contract):

- ``study(key, value)``: ``name``, ``config_json``, ``config_hash``, ``created_utc``, ``bwbench_version``,
  ``planned_runs`` (how many runs the study has: the report calls a study with fewer provisional;
  written on every open, so databases from before the key get it when resumed), and where the data
  of the latest run were (where ``bwbench report`` looks first; not part of the configuration):
  ``data_paths`` (JSON, specimen name -> file) or ``data_dir`` (a folder); ``machine``; ``backends``
  (JSON, backend -> family and whether it evaluates populations: the report reads the database,
  never the optimiser registry). Read by ``bwbench.database.reader``.
- ``runs``: one row per finished run: a run that succeeded, or one that failed deterministically
  (status "error"; ``bwbench.study.failures``). A row of an older version whose error was the
  environment's (``OSError: ...``) is not finished: it is run again and replaced.
  Keyed by (kind, specimen, optimizer, replicate); no wall
  time, so rows are identical whoever ran them and when. Columns for any problem: ``problem``,
  ``model``, ``formulation`` and ``variant`` (the label's bracket, NULL when the study has one
  variant), ``params_json`` (every parameter by name: no model's names are columns) and
  ``metrics_json`` (the problem's own metrics of the best point, e.g. the benchmark's test e_RMS;
  null where not finite; NULL for a run that raised), ``meta_json`` (what the problem knows of the
  specimen, e.g. the paper's material, underpressure and repeat from a manifest). ``state``,
  ``excitation``, ``rmse_N`` are filled by the problems that have such values
  (``ProblemType.record_columns``) and NULL otherwise. Older layouts (no generic columns; the switched
  model's 14 parameters, or material, underpressure and repeat, as columns) still read: the reader
  knows them in one place (``bwbench.database.legacy``); a resumed study gains the new columns.
- ``timings``: wall time (s), worker (``host:pid``) and finish time (UTC) of each run.
- ``traces``: the best-so-far improvements (evaluation count, loss) of each run.
- ``chains``: MCMC chains (float64, unit coordinates, shape (steps, walkers, dim)) of the posterior
  runs (ranking runs keep none, whatever their backend returns).

Every fault of the file (read-only, not a database, a directory, a full disk, ...) is a
``UserError`` of one line naming the file (``database_fault``).
"""

from __future__ import annotations

import json
import os
import sqlite3
import sys
from datetime import datetime, timezone
from pathlib import Path

from bwbench.data.input_files import not_regular
from bwbench.data.strict_json import dumps
from bwbench.database.reader import is_transient_text
from bwbench.database.timing import machine_description
from bwbench.errors import UserError
from bwbench.version import __version__

# any problem's: a problem's own facts about a specimen (the paper's material, underpressure, repeat)
# live in meta_json, not in columns of every study's schema
GENERIC_COLUMNS = ("problem", "params_json", "metrics_json", "model", "formulation", "variant", "meta_json")
RUN_COLUMNS = (
    "kind",
    "specimen",
    "optimizer",
    "replicate",
    "seed_entropy",
    "status",
    "error",
    "budget",
    "nfev",
    "mse",
    "f_err",
    "rmse_N",
    "success",
    "message",
    "state",
    "excitation",
    "options_json",
    *GENERIC_COLUMNS,
)
_KEY_SQL = "kind TEXT, specimen TEXT, optimizer TEXT, replicate INTEGER"
_PK_SQL = "PRIMARY KEY (kind, specimen, optimizer, replicate)"
# A nested-sampling posterior's per-run ln Z, errors and evaluations (JSON); a table of its own so a
# database made before it gains it on resume (``_add_generic_columns``).
EVIDENCE_SQL = f"CREATE TABLE IF NOT EXISTS evidence ({_KEY_SQL}, evidence_json TEXT, {_PK_SQL})"
SCHEMA = f"""
CREATE TABLE IF NOT EXISTS study (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS runs (
    {_KEY_SQL}, seed_entropy TEXT, status TEXT, error TEXT, budget INTEGER, nfev INTEGER,
    mse REAL, f_err REAL, rmse_N REAL, success INTEGER, message TEXT, state TEXT, excitation TEXT,
    options_json TEXT, problem TEXT, params_json TEXT, metrics_json TEXT, model TEXT, formulation TEXT,
    variant TEXT, meta_json TEXT, {_PK_SQL});
CREATE TABLE IF NOT EXISTS timings ({_KEY_SQL}, wall_s REAL, worker TEXT, finished_utc TEXT, {_PK_SQL});
CREATE TABLE IF NOT EXISTS traces ({_KEY_SQL}, nfev INTEGER, mse REAL);
CREATE INDEX IF NOT EXISTS traces_key ON traces (kind, specimen, optimizer, replicate);
CREATE TABLE IF NOT EXISTS chains (
    {_KEY_SQL}, steps INTEGER, walkers INTEGER, dim INTEGER, chain BLOB, log_prob BLOB,
    acceptance_fraction REAL, autocorr_json TEXT, {_PK_SQL});
{EVIDENCE_SQL}
"""


def utc_now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def prepare_database_path(path) -> Path:
    """Check that the study database ``path`` can be created or written, creating its folder; return it.

    Raises ``UserError`` (one line naming the file) for a directory, a folder that cannot be created
    or written, or a read-only database file.
    """
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a directory, not a study database; pass --db with a file name")
    kind = not_regular(os.stat(path).st_mode) if path.exists() else None
    if kind:  # SQLite would block on a FIFO forever
        raise UserError(f"{path}: is {kind}, not a study database; pass --db with a file name")
    folder = path.parent
    blocking = next((p for p in [folder, *folder.parents] if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise UserError(f"{path}: cannot create its folder: {blocking} is a file")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(f"{path}: cannot create its folder {folder}: {err.strerror or err}") from None
    # SQLite writes a journal next to the database on every commit: the folder must be writable too.
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(
            f"{path}: the folder {folder} is not writable (SQLite keeps its journal next to "
            "the database); pass --db with a writable path"
        )
    if path.exists() and not os.access(path, os.R_OK):
        raise UserError(f"{path}: cannot read the study database (permission denied)")
    if path.exists() and not os.access(path, os.W_OK):
        raise UserError(f"{path}: the study database is read-only; make it writable or pass another --db")
    return path


def database_fault(path, err: sqlite3.Error) -> str:
    """One line naming the file ``path`` and what is wrong with it, for a SQLite error."""
    path = Path(path)
    text = str(err)
    code = getattr(err, "sqlite_errorcode", None)  # Python 3.11+; the text otherwise
    primary = code & 0xFF if isinstance(code, int) else None

    def means(number, words):
        return primary == number or (primary is None and words in text)

    if means(13, "is full"):  # SQLITE_FULL
        return f"{path}: the disk is full ({text})"
    if means(8, "readonly"):  # SQLITE_READONLY
        where = path if path.exists() and not os.access(path, os.W_OK) else path.parent
        return f"{path}: cannot write: {where} is read-only ({text})"
    if means(26, "not a database"):  # SQLITE_NOTADB
        return f"{path}: not a SQLite database ({text}); choose another --db"
    if means(14, "unable to open"):  # SQLITE_CANTOPEN
        if path.is_dir():
            return f"{path}: is a directory, not a study database"
        return f"{path}: cannot open the database file ({text})"
    if means(5, "locked") or means(6, "locked"):  # SQLITE_BUSY, SQLITE_LOCKED
        return f"{path}: another program holds a lock on the database ({text}); close it and try again"
    if means(11, "malformed"):  # SQLITE_CORRUPT
        return f"{path}: the database is damaged ({text})"
    if means(10, "I/O error"):  # SQLITE_IOERR
        return f"{path}: input/output error ({text})"
    return f"{path}: {text}"


def open_database(path, config, planned_runs: int | None = None, backends: str = "{}") -> sqlite3.Connection:
    """Create the study database, or reopen it after checking it holds this very configuration
    (``config``: a ``bwbench.study.config.StudyConfig``, read for its JSON, hash and backends).

    ``planned_runs``: how many runs the study has (stored for the report); ``backends``: JSON of what
    each backend is (family, batched), for the report, which never reads the registry. Writes on every open, so
    a database that cannot be written fails here, before any run starts. Raises ``UserError`` (one
    line naming the file) if it is not a study database, was made by another configuration, or
    cannot be written.
    """
    path = prepare_database_path(path)
    conn = None
    try:
        conn = sqlite3.connect(path, timeout=60, isolation_level=None)  # transactions are explicit
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
            conn.executemany(
                "INSERT INTO study (key, value) VALUES (?, ?)",
                [
                    ("name", config.name),
                    ("config_json", config.canonical_json()),
                    ("config_hash", config.config_hash),
                    ("created_utc", utc_now()),
                    ("bwbench_version", __version__),
                ],
            )
        if planned_runs is not None:
            conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('planned_runs', ?)", (str(planned_runs),))
        conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('machine', ?)", (machine_description(),))
        # What each backend is, for the report, which reads the database and never the registry.
        conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('backends', ?)", (backends,))
        location = config.setup.data_location  # where the data are now: for the report, not the identity
        if isinstance(location, dict):
            conn.execute(
                "INSERT OR REPLACE INTO study (key, value) VALUES ('data_paths', ?)", (dumps(location, canonical=True),)
            )
        elif location:
            conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('data_dir', ?)", (location,))
        conn.execute("COMMIT")
    except sqlite3.Error as err:
        if conn is not None:
            conn.close()
        raise UserError(database_fault(path, err)) from None
    except BaseException:
        if conn is not None:
            conn.close()
        raise
    return conn


def _add_generic_columns(conn) -> None:
    """Give a database from before the generic columns existed those columns (NULL in old rows)."""
    present = {r[1] for r in conn.execute("PRAGMA table_info(runs)")}
    for column in GENERIC_COLUMNS:
        if column not in present:
            conn.execute(f"ALTER TABLE runs ADD COLUMN {column} TEXT")
    conn.execute(EVIDENCE_SQL)


def _check_same_study(conn, path, config) -> None:
    """The configuration must be the stored one, or extend it (more seeds, backends or specimens, the
    same settings for what both have): then the stored one is replaced and only the new runs run."""
    stored = dict(conn.execute("SELECT key, value FROM study"))
    if stored.get("config_hash") == config.config_hash:
        if stored.get("bwbench_version") != __version__:
            print(
                f"note: {path} was started with bwbench {stored.get('bwbench_version')}, this is {__version__}",
                file=sys.stderr,
            )
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
    conn.executemany(
        "INSERT OR REPLACE INTO study (key, value) VALUES (?, ?)",
        [("config_json", config.canonical_json()), ("config_hash", config.config_hash)],
    )
    print(
        f"note: {config.path} extends the study in {path}: its finished runs are kept, only the new ones run",
        file=sys.stderr,
    )


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
        out += [
            f"specimen {s}: its data changed (SHA-256 differs)"
            for s in old_specimens
            if s in new_specimens and old_specimens[s] != new_specimens[s]
        ]
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
    """Keys of the finished runs: those that succeeded or failed deterministically."""
    return {
        tuple(r[:4])
        for r in conn.execute("SELECT kind, specimen, optimizer, replicate, status, error FROM runs")
        if not _retryable(r[4], r[5])
    }


def failed_runs(conn) -> list:
    """[(key, error)] of the runs recorded as deterministic errors, by key."""
    rows = conn.execute(
        "SELECT kind, specimen, optimizer, replicate, error FROM runs WHERE status = 'error' "
        "ORDER BY kind, specimen, optimizer, replicate"
    )
    return [(tuple(r[:4]), r[4]) for r in rows if not _retryable("error", r[4])]


def _retryable(status, error) -> bool:
    # An error row of an older version that was the environment's fault: not a finished run.
    return status == "error" and is_transient_text(error)


def record_run(conn, outcome: dict) -> bool:
    """Write one finished run in one transaction; False (and nothing written) if already there.

    A retryable row of the same key (``finished_keys``) is replaced. Raises ``sqlite3.Error`` (the
    database unchanged) if the write fails, e.g. on a full disk.
    """
    key = outcome["key"]
    placeholders = ", ".join("?" * len(RUN_COLUMNS))
    columns = ", ".join(f'"{c}"' for c in RUN_COLUMNS)
    where = "kind = ? AND specimen = ? AND optimizer = ? AND replicate = ?"
    conn.execute("BEGIN IMMEDIATE")
    try:
        old = conn.execute(f"SELECT status, error FROM runs WHERE {where}", key).fetchone()
        if old is not None:
            if not _retryable(*old):
                conn.execute("ROLLBACK")
                return False
            for table in ("runs", "timings", "traces", "chains", "evidence"):
                conn.execute(f"DELETE FROM {table} WHERE {where}", key)
        conn.execute(f"INSERT INTO runs ({columns}) VALUES ({placeholders})", [outcome["row"][c] for c in RUN_COLUMNS])
        t = outcome["timing"]
        conn.execute(
            "INSERT OR REPLACE INTO timings VALUES (?, ?, ?, ?, ?, ?, ?)",
            (*key, t["wall_s"], t["worker"], t["finished_utc"]),
        )
        conn.executemany(
            "INSERT INTO traces VALUES (?, ?, ?, ?, ?, ?)", [(*key, int(n), float(m)) for n, m in outcome["trace"]]
        )
        c = outcome["chain"]
        if c is not None:
            conn.execute(
                "INSERT OR REPLACE INTO chains VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    *key,
                    c["steps"],
                    c["walkers"],
                    c["dim"],
                    c["chain"],
                    c["log_prob"],
                    c["acceptance_fraction"],
                    c["autocorr_json"],
                ),
            )
            if c.get("evidence_json"):
                conn.execute("INSERT OR REPLACE INTO evidence VALUES (?, ?, ?, ?, ?)", (*key, c["evidence_json"]))
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            try:
                conn.execute("ROLLBACK")
            except sqlite3.Error:  # e.g. SQLite already rolled back on a full disk: the first error says more
                pass
        raise
    return True


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
            a, b = dumps(old[key], canonical=True), dumps(new[key], canonical=True)
            out.append(f"{label}: {a} -> {b}" if len(a) + len(b) <= 80 else f"{label} changed")
    return out
