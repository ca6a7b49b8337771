"""Read a study database (written by ``bwbench.database.writer``) into tidy pandas tables and numpy chains.

The schema is the runner's contract: tables ``study``, ``runs``, ``timings``, ``traces`` and
``chains``. Reading never writes: the file is opened read-only, so a report can be made while
the study is still running (``Study.provisional`` says how far it is). Databases from before the
generic ``runs`` columns (``problem``, ``params_json``, ``metrics_json``) read as switched-model
studies with those columns filled in.
"""

from __future__ import annotations

import builtins
import dataclasses
import json
import sqlite3
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

import bwbench.problems as problems
from bwbench.data.input_files import not_regular
from bwbench.data.manifest import load_manifest
from bwbench.database import legacy
from bwbench.database.plan import planned_from_config
from bwbench.errors import UserError

REQUIRED_TABLES = ("study", "runs", "traces")
# Faults of the environment, not of a run (``bwbench.study.failures``): a stored error of these types
# ("OSError: ...", written by versions that recorded them) is not a finished run.
TRANSIENT = (OSError, MemoryError, ImportError)
TRANSIENT_NAMES = frozenset(
    name for name, value in vars(builtins).items() if isinstance(value, type) and issubclass(value, TRANSIENT)
)


@dataclass(frozen=True, eq=False)
class Chain:
    """One MCMC run: ``samples`` of shape (steps, walkers, 14) in unit coordinates."""

    kind: str
    specimen: str
    optimizer: str
    replicate: int
    samples: np.ndarray
    log_prob: np.ndarray | None  # (steps, walkers)
    acceptance_fraction: float | None
    autocorr: list | None  # the runner's per-dimension estimate (None entries = not finite)
    # a nested-sampling posterior: {"log_z": [per run], "log_z_err", "run_nfev", "run_complete", "live_points"};
    # its samples are then (draws, runs, d), each run's equal-weight draws
    evidence: dict | None = None

    @property
    def steps(self) -> int:
        return int(self.samples.shape[0])

    @property
    def walkers(self) -> int:
        return int(self.samples.shape[1])

    def physical(self, from_unit, burn: int = 0, walkers=None) -> np.ndarray:
        """Samples after ``burn`` steps, flattened to (n, d), in physical units by ``from_unit`` (the
        problem's mapping from unit coordinates); ``walkers``: an optional boolean mask of the walkers
        to keep."""
        kept = self.samples[burn:] if walkers is None else self.samples[burn:, np.asarray(walkers, bool)]
        return from_unit(kept.reshape(-1, self.samples.shape[2]))


@dataclass(frozen=True, eq=False)
class Study:
    """Everything a study database holds. ``runs`` has one row per run (timings joined in);
    ``traces`` one row per best-so-far improvement (nfev, mse in N²)."""

    path: Path
    meta: dict  # name, config_hash, created_utc, bwbench_version
    config: dict  # the parsed config_json
    runs: pd.DataFrame
    traces: pd.DataFrame
    chains: tuple  # of Chain
    data_dir: Path
    paths: dict = dataclasses.field(default_factory=dict)  # specimen -> file, where the runner last found it
    # specimen -> file the runner recorded, even if gone: a missing file is named as the study used it
    recorded: dict = dataclasses.field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.meta.get("name") or self.config.get("study", {}).get("name", self.path.stem)

    @property
    def settings(self) -> dict:
        """The config's [study] table: name, seed, budget, seeds, state, excitation, data."""
        return self.config.get("study", {})

    @property
    def backends(self) -> dict:
        """{backend: {"family": ..., "batched": ...}} as the runner recorded them (``backends`` in the
        study table); {} for a database from before the key."""
        try:
            return dict(json.loads(self.meta.get("backends") or "{}"))
        except (TypeError, ValueError):
            return {}

    @property
    def problem(self) -> str:
        """The problem type's name (the hysteresis problem also for databases older than the key; a former
        name is read as the current one)."""
        return problems.current_name(self.settings.get("problem", problems.DEFAULT))

    @property
    def problem_type(self):
        return problems.get(self.problem)

    @property
    def loss_unit(self) -> str:
        """Unit of the loss, e.g. N² (force residual) or m² (a displacement residual)."""
        return self.problem_type.loss_unit

    @property
    def planned_runs(self) -> int | None:
        """How many runs the study has: as the runner recorded it (``planned_runs``), else counted from
        the stored configuration (seeds × specimens × backends + posterior runs); None if neither can."""
        try:
            return int(self.meta["planned_runs"])
        except (KeyError, TypeError, ValueError):
            return planned_from_config(self.config)

    @property
    def finished_runs(self) -> int:
        """Runs the runner counts as finished: every row but an old version's transient errors."""
        return int(
            sum(
                not (status == "error" and is_transient_text(error))
                for status, error in zip(self.runs["status"], self.runs["error"], strict=True)
            )
        )

    @property
    def provisional(self) -> str | None:
        """``"provisional: 16 of 36 runs"`` while the study is unfinished; None when it is finished
        or its size is unknown."""
        planned = self.planned_runs
        done = self.finished_runs
        if planned is None or done >= planned:
            return None
        return f"provisional: {done} of {planned} runs"

    @property
    def ranking(self) -> pd.DataFrame:
        return self.runs[self.runs["kind"] == "ranking"]

    @property
    def optimizers(self) -> list[str]:
        """Ranking backends in the stored configuration's order (the runner stores it as canonical
        JSON, i.e. alphabetically), then any others found in the runs."""
        configured = list(self.config.get("optimizers", {}))
        found = list(dict.fromkeys(self.ranking["optimizer"]))
        return [o for o in configured if o in found] + [o for o in found if o not in configured]

    @property
    def specimens(self) -> list[str]:
        return list(dict.fromkeys(self.ranking["specimen"])) or list(dict.fromkeys(self.runs["specimen"]))

    def specimen_path(self, specimen: str) -> Path:
        if specimen in self.paths:
            return Path(self.paths[specimen])
        guess = self.data_dir / f"{specimen}.csv"
        if not guess.is_file() and specimen in self.recorded:  # deleted: name the file the study ran on
            return Path(self.recorded[specimen])
        return guess

    def manifest(self) -> dict | None:
        """The manifest.json beside the specimens (generation settings, truth), or None if there is none."""
        folder = self.specimen_path(self.specimens[0]).parent if self.specimens else self.data_dir
        return load_manifest(folder)


def is_transient_text(error: str | None) -> bool:
    """Whether a stored one-line error ``"TypeName: message"`` was a fault of the environment."""
    return bool(error) and str(error).split(":", 1)[0].strip() in TRANSIENT_NAMES


def connect_read_only(path: Path) -> sqlite3.Connection:
    if not path.exists():
        raise UserError(f"{path}: no such study database")
    kind = not_regular(path.stat().st_mode)
    if kind:  # opening a FIFO read-only would block until a writer comes
        raise UserError(f"{path}: is {kind}, not a study database")
    try:
        conn = sqlite3.connect(f"file:{path.resolve()}?mode=ro", uri=True)
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.DatabaseError as err:
        raise UserError(f"{path}: not a bwbench study database ({err})") from None
    missing = [t for t in REQUIRED_TABLES if t not in tables]
    if missing:
        conn.close()
        raise UserError(f"{path}: not a bwbench study database (no {', '.join(repr(t) for t in missing)} table)")
    return conn


def read_meta(conn) -> tuple[dict, dict]:
    """The study table and its configuration; ``ValueError`` naming the key for an edited cell."""
    meta = dict(conn.execute("SELECT key, value FROM study"))
    for key in ("config_json", "backends", "data_paths"):
        text = meta.get(key)
        try:
            value = json.loads(text) if isinstance(text, str) and text else {}
        except json.JSONDecodeError as err:
            raise ValueError(
                f"table study, key {key}: not JSON ({err.msg} at character {err.pos}): edited by hand?"
            ) from None
        if not isinstance(value, dict):
            raise ValueError(f"table study, key {key}: a JSON {type(value).__name__}, not an object: edited by hand?")
    config = json.loads(meta.pop("config_json", "{}") or "{}")
    return meta, config


def _run_name(row) -> str:
    return f"run {row['kind']}/{row['specimen']}/{row['optimizer']}/{row['replicate']}"


def _numeric_columns(runs: pd.DataFrame, columns) -> None:
    """Each of ``columns`` as floats in place; ``ValueError`` naming the run and column for a cell that
    holds text that is no number (NULL stays NaN: a run that failed has none)."""
    for column in columns:
        values = pd.to_numeric(runs[column], errors="coerce").astype(float)
        bad = runs[column].notna() & values.isna() & ~runs[column].astype(str).str.lower().isin(["nan", "none"])
        if bad.any():
            row = runs[bad].iloc[0]
            raise ValueError(f"{_run_name(row)}, column {column}: {row[column]!r} is not a number: edited by hand?")
        runs[column] = values


def read_runs(conn) -> pd.DataFrame:
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    if "timings" in tables:
        query = (
            "SELECT runs.*, timings.wall_s, timings.worker, timings.finished_utc FROM runs "
            "LEFT JOIN timings USING (kind, specimen, optimizer, replicate)"
        )
    else:
        query = "SELECT * FROM runs"
    runs = pd.read_sql(query + " ORDER BY kind, specimen, optimizer, replicate", conn)
    _numeric_columns(
        runs,
        [
            c
            for c in ("nfev", "mse", "f_err", "rmse_N", "budget", *legacy.numeric_columns(runs), "replicate")
            if c in runs
        ],
    )  # replicate last: it names the run
    if runs["replicate"].isna().any():
        raise ValueError(
            f"{_run_name(runs[runs['replicate'].isna()].iloc[0])}, column replicate: empty: edited by hand?"
        )
    runs["replicate"] = runs["replicate"].astype(int)
    return _expand_json(legacy.upgrade(runs, problems.DEFAULT))


def _expand_json(runs: pd.DataFrame) -> pd.DataFrame:
    """Add the parameters (``params_json``), metrics (``metrics_json``) and specimen facts
    (``meta_json``) that are not columns yet as columns (NaN where absent or null): e.g. ``m`` … ``nu``,
    ``test_multisine_erms_m``, ``material``."""
    new = {}
    for column in ("params_json", "metrics_json", "meta_json"):
        parsed = [_json_cell(row, column, numbers=column != "meta_json") for _, row in runs.iterrows()]
        for name in dict.fromkeys(k for d in parsed for k in d):
            raw = [d.get(name) for d in parsed]
            if all(isinstance(v, int) for v in raw):  # a count (a repeat): kept an integer
                values = np.array(raw, dtype=np.int64)
            elif all(v is None or isinstance(v, (int, float)) for v in raw):
                values = np.array([np.nan if v is None else v for v in raw], dtype=float)
            else:
                values = np.array([None if v is None else v for v in raw], dtype=object)
            if legacy.fill_from_json(runs, name, values):
                continue  # a column of an old layout: rows written since fill it from the JSON
            if name not in runs and name not in new:
                new[name] = values
    return pd.concat([runs, pd.DataFrame(new, index=runs.index)], axis=1) if new else runs


def _json_cell(row, column, numbers: bool = True) -> dict:
    """The JSON object of a run's ``column`` ({} when empty) whose values are numbers or null (with
    ``numbers``; else also text); ``ValueError`` naming the run and column otherwise (a database edited
    by hand)."""
    text = row[column]
    if not isinstance(text, str) or not text:
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(
            f"{_run_name(row)}, column {column}: not JSON ({err.msg} at character {err.pos}): edited by hand?"
        ) from None
    if not isinstance(value, dict):
        raise ValueError(
            f"{_run_name(row)}, column {column}: a JSON {type(value).__name__}, not an object of "
            "name -> number: edited by hand?"
        )
    for name, number in value.items():
        if not numbers and isinstance(number, str):
            continue
        if number is not None and (isinstance(number, bool) or not isinstance(number, (int, float))):
            raise ValueError(f"{_run_name(row)}, column {column}: {name} is {number!r}, not a number: edited by hand?")
    return value


def read_traces(conn) -> pd.DataFrame:
    traces = pd.read_sql("SELECT * FROM traces ORDER BY kind, specimen, optimizer, replicate, nfev", conn)
    traces["nfev"] = traces["nfev"].astype(int)
    traces["mse"] = traces["mse"].astype(float)
    return traces


def read_chains(conn) -> tuple:
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    if "chains" not in tables:
        return ()
    out = []
    rows = conn.execute(
        "SELECT kind, specimen, optimizer, replicate, steps, walkers, dim, chain, log_prob, "
        "acceptance_fraction, autocorr_json FROM chains ORDER BY kind, specimen, optimizer, replicate"
    )
    evidence = {}
    if "evidence" in tables:
        evidence = {
            tuple(r[:4]): json.loads(r[4])
            for r in conn.execute("SELECT kind, specimen, optimizer, replicate, evidence_json FROM evidence")
        }
    for kind, specimen, optimizer, replicate, steps, walkers, dim, blob, lp_blob, acc, autocorr in rows.fetchall():
        samples = np.frombuffer(blob, dtype=np.float64).reshape(steps, walkers, dim)
        log_prob = None if lp_blob is None else np.frombuffer(lp_blob, dtype=np.float64).reshape(steps, walkers)
        out.append(
            Chain(
                kind,
                specimen,
                optimizer,
                int(replicate),
                samples,
                log_prob,
                None if acc is None else float(acc),
                json.loads(autocorr) if autocorr else None,
                evidence.get((kind, specimen, optimizer, int(replicate))),
            )
        )
    return tuple(out)


def load_study(path, data_dir=None) -> Study:
    """Read a whole study database.

    ``data_dir``: where the study's data files are (the user's ``--data``); by default the problem
    type decides (``ProblemType.data_dir``: the folder the runner last recorded, if it still exists).
    Raises ``UserError`` for a missing file or one that is not a study database.
    """
    path = Path(path)
    with closing(connect_read_only(path)) as conn:
        try:
            meta, config = read_meta(conn)
            runs, traces, chains = read_runs(conn), read_traces(conn), read_chains(conn)
        except (sqlite3.DatabaseError, pd.errors.DatabaseError, KeyError, ValueError, TypeError) as err:
            raise UserError(f"{path}: unreadable study database: {err}") from None
    paths, recorded = {}, {}
    if data_dir is None:  # the files where the runner last found them, while they are still there
        try:
            recorded = {name: str(p) for name, p in json.loads(meta.get("data_paths") or "{}").items()}
        except (ValueError, AttributeError):  # edited by hand: the problem type's folder decides
            recorded = {}
        paths = {name: Path(p) for name, p in recorded.items() if Path(p).is_file()}
    study = Study(
        path=path,
        meta=meta,
        config=config,
        runs=runs,
        traces=traces,
        chains=chains,
        data_dir=Path("."),
        paths=paths,
        recorded=recorded,
    )
    folder = study.problem_type.data_dir(study, data_dir)
    return dataclasses.replace(study, data_dir=Path(folder) if folder is not None else Path("."))
