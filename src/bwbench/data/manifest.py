"""A data folder's optional ``manifest.json``: facts about each specimen file (material, underpressure,
repeat, whether it is synthetic and, if so, its truth parameters). No command needs one; the report uses
it when present.
"""

from __future__ import annotations

import json
from pathlib import Path

MANIFEST = "manifest.json"  # JSON, so that `bwbench data check data/specimens/*.csv` sees only specimens


def load_manifest(directory) -> dict | None:
    """The manifest.json of a data folder as a dict, or None when the folder has none, or has one that
    is not bwbench's (another program's file of that name: ignored, with a warning saying so)."""
    path = Path(directory) / MANIFEST
    if not path.exists():
        return None
    from bwbench.data.input_files import read_text  # a regular file of bounded size: a FIFO would block

    try:
        document = json.loads(read_text(path))
    except ValueError as err:  # not JSON (or not UTF-8)
        _not_ours(path, f"not JSON ({err})")
        return None
    specimens = document.get("specimens") if isinstance(document, dict) else None
    if not isinstance(specimens, list) or not all(
        isinstance(e, dict) and isinstance(e.get("file"), str) for e in specimens
    ):
        _not_ours(path, 'no "specimens" list of objects naming their "file"')
        return None
    return document


def _not_ours(path, why: str) -> None:
    from bwbench.notices import assume

    assume(f"{path} is not a bwbench manifest ({why}): ignored; the specimens are read as measured data")


def read_manifest(directory):
    """The manifest as a pandas DataFrame: one row per specimen file, truth parameters as columns."""
    import pandas as pd

    document = load_manifest(directory)
    if document is None:
        raise FileNotFoundError(Path(directory) / MANIFEST)
    rows = [{**{k: v for k, v in e.items() if k != "truth"}, **(e.get("truth") or {})} for e in document["specimens"]]
    return pd.DataFrame(rows)


def manifest_entry(specimen_path) -> dict | None:
    """The manifest entry of a specimen file, when it sits next to a manifest; else None."""
    path = Path(specimen_path)
    document = load_manifest(path.parent)
    if document is None:
        return None
    for entry in document["specimens"]:
        if entry["file"] == path.name:
            return entry
    return None


PAPER_SOURCE = "the paper's Tables 6–8"  # manifests written before the "source" key are the paper's


def is_synthetic(specimen_path) -> bool:
    entry = manifest_entry(specimen_path)
    return bool(entry and entry.get("synthetic"))


def synthetic_source(specimen_path) -> str | None:
    """What a synthetic specimen was generated from (the manifest's ``source``), or None when it is not
    marked synthetic."""
    if not is_synthetic(specimen_path):
        return None
    return (load_manifest(Path(specimen_path).parent) or {}).get("source", PAPER_SOURCE)


def is_paper_data(specimen_path) -> bool:
    """Whether the specimen is one of the paper's synthetic specimens (generated from its Tables 6–8
    with the switched model): only then may a report speak of the paper's tables and figures."""
    return synthetic_source(specimen_path) == PAPER_SOURCE


def truth(specimen_path) -> tuple[str, dict] | None:
    """(model name, truth parameters by name) of a synthetic specimen, or None."""
    entry = manifest_entry(specimen_path)
    if entry is None or not isinstance(entry.get("truth"), dict):
        return None
    return entry.get("model", "switched-bouc-wen"), dict(entry["truth"])
