"""The switched Bouc-Wen specimen fit as a study problem (``problem = "switched-bouc-wen"``, the default).

Its ``[study]`` keys and ``[specimens]`` table::

    [study]
    state = "shared"          # or "split"
    excitation = "measured"   # or "sine"
    data = "data/specimens"   # folder with manifest.json

    [specimens]               # manifest filters, each a value or a list; omitted key = all
    material = ["POM MT24u01"]
    underpressure_MPa = [0.01, 0.09]
    repeat = [1]

Relative paths (``data``, and the default database) are relative to the repository root: the parent
of the ``studies/`` folder holding the configuration, or, for a configuration kept anywhere else, the
bwbench checkout itself. ``--data PATH`` on the command line (relative to the current directory)
replaces ``[study] data``. ``data`` is part of the study's identity as written (the folder defines
the specimens).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bwbench.data import manifest as manifest_mod
from bwbench.models import switched_bouc_wen as model
from bwbench.models.excitation import EXCITATIONS
from bwbench.problems.base import ProblemSetup, ProblemType, SpecimenEntry

FILTER_KEYS = ("material", "table", "underpressure_MPa", "repeat")


class SwitchedVPP(ProblemType):
    name = "switched-bouc-wen"
    description = "the paper's switched Bouc-Wen model fitted to force-displacement specimens (loss: MSE in N²)"
    loss_unit = "N²"
    residual_unit = "N"
    study_keys = ("state", "excitation", "data")
    tables = ("specimens",)

    # ------------------------------------------------------------------------ configuration
    def configure(self, fail, study, document, base_dir, data_override=None) -> ProblemSetup:
        from bwbench.study.config import choice

        state = choice(fail, "[study] state", study.get("state", "shared"), model.STATES)
        excitation = choice(fail, "[study] excitation", study.get("excitation", "measured"), EXCITATIONS)
        if data_override is None:
            data = study.get("data", "data/specimens")
            if not isinstance(data, str) or not data:
                fail("[study] data must be a folder path (a string)")
            data_dir = Path(data) if Path(data).is_absolute() else base_dir / data
        else:
            data_dir = Path(data_override).resolve()
            data = str(data_dir)
        manifest = _read_manifest(fail, data_dir)
        filters_table = document.get("specimens", {})
        if not isinstance(filters_table, dict):
            fail("[specimens] must be a table of manifest filters")
        unknown = [k for k in filters_table if k not in FILTER_KEYS]
        if unknown:
            fail(f"[specimens] unknown key {unknown[0]!r} (known: {', '.join(FILTER_KEYS)})")
        filters = {key: _filter_values(fail, key, value) for key, value in filters_table.items()}
        selected = [_entry(row, data_dir) for row in _select(fail, manifest, filters)]
        for entry in selected:
            if not Path(entry.path).is_file():
                fail(f"[study] data: {Path(entry.path).name} is in {data_dir / manifest_mod.MANIFEST} "
                     "but not in the folder")
        return ProblemSetup(
            settings={"state": state, "excitation": excitation},
            study_json={"state": state, "excitation": excitation, "data": data},
            specimens_json={"filters": {k: list(v) for k, v in filters.items()},
                            "files": [s.name for s in selected]},
            specimens=tuple(selected),
            available={Path(row["file"]).stem: _entry(row, data_dir) for row in manifest}, data_location=str(data_dir.resolve()),
        )

    def make_problem(self, settings, entry):
        from bwbench.data.specimen import read_specimen
        from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem

        return SwitchedBoucWenProblem(read_specimen(entry.path), settings["state"], settings["excitation"])

    def record_columns(self, settings, entry, result=None) -> dict:
        columns = {"state": settings.get("state"), "excitation": settings.get("excitation"), **entry.meta}
        if result is not None:
            columns.update(rmse_N=result.rmse_N, **result.params)
        return columns

    # ------------------------------------------------------------------------------- report
    def data_dir(self, study, override=None) -> Path:
        if override is not None:
            return Path(override)
        recorded = study.meta.get("data_dir")
        if recorded and Path(recorded).is_dir():
            return Path(recorded)
        from bwbench.data.synthetic import REPO

        data = Path(study.settings.get("data", "data/specimens"))
        return data if data.is_absolute() else REPO / data

    def is_synthetic(self, study) -> bool:
        return any(manifest_mod.is_synthetic(study.specimen_path(s)) for s in study.specimens)

    def noise_floor(self, study, specimen):
        truth = manifest_mod.truth_params(study.specimen_path(specimen))
        if truth is None:
            return None
        problem = self.make_problem(study.settings, SpecimenEntry(specimen, str(study.specimen_path(specimen))))
        return float(problem.loss_batch(truth[None, :])[0])

    def setup_text(self, report) -> str:
        from bwbench.problems.switched_vpp import report as sections

        return sections.setup_text(report)

    def report_intro(self, report) -> None:
        from bwbench.problems.switched_vpp import report as sections

        sections.data_section(report)

    def report_sections(self, report) -> None:
        from bwbench.problems.switched_vpp import report as sections

        sections.add_sections(report)

    def limits(self, report) -> list[str]:
        from bwbench.problems.switched_vpp import report as sections

        return sections.limits(report)


def _read_manifest(fail, data_dir: Path) -> list[dict]:
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
                fail(f"[specimens] {key}: no specimen has {wanted!r} (the manifest has "
                     f"{', '.join(str(p) for p in present)})")
    selected = [row for row in manifest
                if all(any(_matches(k, row[k], w) for w in values) for k, values in filters.items())]
    if not selected:
        fail("[specimens] the filters together select no specimen")
    return selected


def _entry(row, data_dir: Path) -> SpecimenEntry:
    return SpecimenEntry(
        name=Path(row["file"]).stem, path=str(data_dir / row["file"]),
        meta={"material": row["material"], "underpressure_MPa": float(row["underpressure_MPa"]),
              "repeat": int(row["repeat"])},
    )


PROBLEM_TYPE = SwitchedVPP()
