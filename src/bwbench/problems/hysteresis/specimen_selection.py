"""Which specimens a study of the hysteresis problem fits: files named by path patterns, or a data
folder's manifest filtered by material, table, underpressure and repeat; each refused mistake one
line naming the key."""

from __future__ import annotations

import glob
import math
from pathlib import Path

from bwbench.data import manifest as manifest_mod
from bwbench.problems.base import Fail, SpecimenEntry

FILTER_KEYS = ("material", "table", "underpressure_MPa", "repeat")


def specimens_from_files(fail, patterns, base_dir: Path, label: str) -> list[SpecimenEntry]:
    """Specimen files named by paths or globs (relative to ``base_dir``), read and checked now, so a
    bad file stops the study before any run; names (file stems) must be unique."""
    if isinstance(patterns, str):
        patterns = [patterns]
    if not isinstance(patterns, list) or not patterns or not all(isinstance(p, str) and p for p in patterns):
        fail(f"{label} must be a non-empty list of file paths or globs")
    paths: list[Path] = []
    for pattern in patterns:
        full = Path(pattern).expanduser()
        full = full if full.is_absolute() else base_dir / full
        if glob.has_magic(str(full)) and not full.exists():  # an existing run[1].csv is a file, not a glob
            found = sorted(Path(p) for p in glob.glob(str(full)) if Path(p).is_file())
            if not found:
                fail(f"{label}: {pattern!r} matches no file (relative to {base_dir})")
        elif not full.exists():
            fail(f"{label}: {pattern}: no such file (relative to {base_dir})")
        else:
            found = [full]
        paths += [p for p in found if p.resolve() not in {q.resolve() for q in paths}]
    return [_entry(fail, path, manifest_mod.manifest_entry(path) or {}) for path in _unique_stems(fail, paths, label)]


def _unique_stems(fail, paths, label) -> list[Path]:
    seen: dict = {}
    for path in paths:
        if path.stem in seen:
            fail(
                f"{label}: two specimens are named {path.stem!r} ({seen[path.stem]} and {path}): "
                "names (file stems) must be unique in a study"
            )
        seen[path.stem] = path
    return paths


def _entry(fail, path: Path, row: dict) -> SpecimenEntry:
    from bwbench.data.identity import files_sha256
    from bwbench.data.specimen import read_specimen
    from bwbench.errors import UserError

    try:
        read_specimen(path)
    except UserError as err:
        fail(f"specimen {err}")
    meta = {key: row[key] for key in ("material", "underpressure_MPa", "repeat") if key in row}
    return SpecimenEntry(name=path.stem, path=str(path), meta={**meta, "sha256": files_sha256([path], [""])})


def from_manifest(fail, study, filters_table, base_dir, data_override):
    if data_override is None:
        if "data" not in study:
            fail(
                'no specimens: list them with [specimens] files = [...], or give [study] data = "FOLDER" '
                "(with a manifest.json) and manifest filters"
            )
        data = study["data"]
        if not isinstance(data, str) or not data:
            fail("[study] data must be a folder path (a string)")
        data_dir = Path(data).expanduser()
        data_dir = data_dir if data_dir.is_absolute() else base_dir / data_dir
    else:
        data_dir = Path(data_override).resolve()
    manifest = _read_manifest(fail, data_dir)
    unknown = [k for k in filters_table if k not in FILTER_KEYS]
    if unknown:
        fail(f"[specimens] unknown key {unknown[0]!r} (known: files, {', '.join(FILTER_KEYS)})")
    filters = {key: _filter_values(fail, key, value) for key, value in filters_table.items()}
    selected = {row["file"] for row in _select(fail, manifest, filters)}
    available = {}  # a [posterior] may name any specimen of the manifest
    for row in manifest:
        if not (data_dir / row["file"]).is_file():
            if row["file"] in selected:
                fail(f"[study] data: {row['file']} is in {data_dir / manifest_mod.MANIFEST} but not in the folder")
            continue
        available[Path(row["file"]).stem] = _entry(fail, data_dir / row["file"], row)
    entries = [available[Path(row["file"]).stem] for row in manifest if row["file"] in selected]
    return entries, available


def _read_manifest(fail: Fail, data_dir: Path) -> list[dict]:
    try:
        document = manifest_mod.load_manifest(data_dir)
        if document is None:
            fail(f"[study] data: no {manifest_mod.MANIFEST} in {data_dir}")
        return list(document["specimens"])
    except (OSError, ValueError, KeyError, TypeError) as err:
        fail(f"[study] data: cannot read {data_dir / manifest_mod.MANIFEST}: {err}")


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
                fail(
                    f"[specimens] {key}: no specimen has {wanted!r} (the manifest has "
                    f"{', '.join(str(p) for p in present)})"
                )
    selected = [
        row for row in manifest if all(any(_matches(k, row[k], w) for w in values) for k, values in filters.items())
    ]
    if not selected:
        fail("[specimens] the filters together select no specimen")
    return selected
