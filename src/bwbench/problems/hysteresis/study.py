"""A hysteresis model fitted to force-displacement specimens, as a study problem
(``problem = "hysteresis"``, the default, formerly called "switched-bouc-wen": any model of
``bwbench models`` can be fitted and several compared).

Its ``[study]`` keys and ``[specimens]`` / ``[bounds]`` / ``[validation]`` tables::

    [study]
    model = "switched-bouc-wen"   # or "spencer", "bouc-wen", a plug-in, or a list compared side by side
    formulation = "paper"     # "paper"/"direct", "identifiable", or a list; default: each model's own
    state = "shared"          # or "split" (the switched model's state convention)
    excitation = "measured"   # or "sine"
    fix_mass = "auto"         # identifiable: "auto" (the inertia rule), "fit", or a mass in N·s²/mm
    offsets = "branch"        # identifiable, switched model: or "continuous" (one constant force)
    initial_state = "auto"    # how every model starts each record: "auto", "rest" or "pre-roll"
    warmup_s = 0.0            # seconds at the start of each record simulated but left out of the loss
    data = "../data/specimens"   # only with manifest filters: a folder with manifest.json

    [specimens]               # either files (no manifest needed) ...
    files = ["tests/run1.csv", "more/*.csv"]
                              # ... or manifest filters, each a value or a list; omitted key = all
    material = ["POM MT24u01"]
    underpressure_MPa = [0.01, 0.09]
    repeat = [1]

    [bounds]                  # optional: the search box, name = [lower, upper]; default Table 5
    "xi-" = [-800.0, -10.0]   # (a solved coefficient's name, e.g. "m" or "c+", bounds the linear solve)

    [validation]              # optional: held-out tests, never fitted; the report ranks by their error
    files = ["held_out/*.csv"]

Relative paths resolve against the TOML's own folder (``--data PATH`` on the command line, relative
to the current folder, replaces ``[study] data``). A ``manifest.json`` next to the files is
optional: when present, its facts (material, underpressure, repeat, truth of synthetic specimens)
are used by the report. The study's identity holds every specimen's name and the SHA-256 of its
bytes, not its path: the same files reached by another path are the same study; a file edited at
the same path is refused.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bwbench.data import manifest as manifest_mod
from bwbench.models import registry as model_registry
from bwbench.models.excitation import EXCITATIONS
from bwbench.models.switched.kernel import STATES
from bwbench.problems.base import ProblemSetup, ProblemType, SpecimenEntry, choice
from bwbench.problems.hysteresis.formulations import bound_names, check_pairs, parse_models
from bwbench.problems.hysteresis.formulations import parse as _formulations
from bwbench.problems.hysteresis.specimen_selection import FILTER_KEYS, from_manifest, specimens_from_files

OFFSETS = ("branch", "continuous")


def mass_setting(fail, label: str, value):
    """ "auto", None ("fit": always fitted) or a mass ≥ 0 (N·s²/mm) of a study's fix_mass; ``fail`` otherwise."""
    if value == "fit" or value is None:
        return None
    if isinstance(value, str) and value != "auto":  # from the command line
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        value = number if math.isfinite(number) else value
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if value == "auto" or (number and math.isfinite(value) and value >= 0):  # inf (TOML's inf) is no mass
        return value
    fail(f'{label} must be "auto", "fit" or a finite mass ≥ 0 in N·s²/mm (1 N·s²/mm = 1 t), got {value!r}')


class HysteresisProblem(ProblemType):
    name = "hysteresis"
    description = (
        "a hysteresis model (default: the paper's switched Bouc-Wen) fitted to force-displacement "
        "specimens (loss: MSE in N²)"
    )
    loss_unit = "N²"
    residual_unit = "N"
    study_keys = (
        "model",
        "state",
        "excitation",
        "data",
        "formulation",
        "fix_mass",
        "offsets",
        "initial_state",
        "warmup_s",
    )
    tables = ("specimens", "bounds", "validation")

    # ------------------------------------------------------------------------ configuration
    def configure(self, fail, study, document, base_dir, data_override=None) -> ProblemSetup:
        model_names = parse_models(fail, study.get("model", model_registry.DEFAULT))
        state = choice(fail, "[study] state", study.get("state", "shared"), STATES)
        if "state" in study and not any(model_registry.get(m).states for m in model_names):
            fail(f"[study] state does not apply to {', '.join(model_names)} (no state convention to choose)")
        excitation = choice(fail, "[study] excitation", study.get("excitation", "measured"), EXCITATIONS)
        formulations = _formulations(fail, study["formulation"]) if "formulation" in study else None
        check_pairs(fail, model_names, formulations)
        fix_mass = mass_setting(fail, "[study] fix_mass", study.get("fix_mass", "auto"))
        offsets = choice(fail, "[study] offsets", study.get("offsets", "branch"), OFFSETS)
        start = start_setting(fail, study.get("initial_state", "auto"), study.get("warmup_s", 0.0), "[study] ")
        table = document.get("specimens", {})
        if not isinstance(table, dict):
            fail("[specimens] must be a table: files = [...] or manifest filters")
        if "files" in table:
            if "data" in study or any(k in table for k in FILTER_KEYS):
                fail("[specimens] files lists the specimens itself: remove [study] data and the manifest filters")
            if data_override is not None:
                fail("--data does not apply to a study that lists its files ([specimens] files)")
            entries = specimens_from_files(fail, table["files"], base_dir, "[specimens] files")
            available = {e.name: e for e in entries}
        else:
            entries, available = from_manifest(fail, study, table, base_dir, data_override)
        paths = [e.path for e in entries]
        _refuse_unused(fail, "[study] ", model_names, formulations, fix_mass, offsets, paths)
        bounds = {}
        if "bounds" in document:
            from bwbench.data.bounds import validate
            from bwbench.errors import InputFileError

            names = bound_names(formulations, state, model_names, paths)
            try:
                bounds = validate(document["bounds"], names, "[bounds]")
            except InputFileError as err:
                fail(err.problem if err.problem.startswith("[") else f"[bounds] {err.problem}")
        return self.setup(
            state, excitation, entries, available, bounds, formulations, fix_mass, model_names, offsets, start
        )

    def held_out_entries(self, fail, files, base_dir, label: str) -> list:
        """The held-out specimens (``[validation] files`` or ``--validate``): like ``[specimens] files``."""
        return specimens_from_files(fail, files, base_dir, label)

    def setup_from_files(
        self,
        fail,
        files,
        base_dir,
        state=None,
        excitation="measured",
        bounds_file=None,
        formulation=None,
        model=None,
        fix_mass="auto",
        offsets="branch",
        initial_state="auto",
        warmup_s=0.0,
    ):
        model_names = parse_models(
            fail, model.split(",") if isinstance(model, str) else model or model_registry.DEFAULT
        )
        if state is not None and not any(model_registry.get(m).states for m in model_names):
            fail(f"--state does not apply to {', '.join(model_names)} (no state convention to choose)")
        state = choice(fail, "--state", state or "shared", STATES)
        choice(fail, "--excitation", excitation, EXCITATIONS)
        formulations = (
            _formulations(fail, formulation.split(",") if isinstance(formulation, str) else formulation)
            if formulation
            else None
        )
        check_pairs(fail, model_names, formulations)
        fix_mass = mass_setting(fail, "--fix-mass", fix_mass)
        offsets = choice(fail, "--offsets", offsets, OFFSETS)
        entries = specimens_from_files(fail, files, base_dir, "--specimens")
        paths = [e.path for e in entries]
        _refuse_unused(fail, "--", model_names, formulations, fix_mass, offsets, paths)
        start = start_setting(fail, initial_state, warmup_s, "--")
        bounds = None
        if bounds_file is not None:
            from bwbench.data import bounds as bounds_mod

            bounds = bounds_mod.read_json(bounds_file, bound_names(formulations, state, model_names, paths))
        return self.setup(
            state,
            excitation,
            entries,
            bounds=bounds,
            formulations=formulations,
            fix_mass=fix_mass,
            models=model_names,
            offsets=offsets,
            start=start,
        )

    def setup(
        self,
        state,
        excitation,
        entries,
        available=None,
        bounds=None,
        formulations=None,
        fix_mass="auto",
        models=(model_registry.DEFAULT,),
        offsets="branch",
        start=None,
    ) -> ProblemSetup:
        """The ``ProblemSetup`` of these specimens (``SpecimenEntry`` with ``meta["sha256"]``); several
        models or formulations are variants compared side by side, every one started by the same rule
        (``start``: {"initial_state", "warmup_s"}, absent when the defaults)."""
        from bwbench.problems.hysteresis.formulations import variants as variant_list

        bounds = {k: list(v) for k, v in (bounds or {}).items()}
        settings = {"state": state, "excitation": excitation, **({"bounds": bounds} if bounds else {})}
        settings.update(start or {})  # absent for the defaults: studies stored before stay the same
        identity = dict(settings)
        pairs = variant_list(models, formulations, [e.path for e in entries])
        if list(models) != [model_registry.DEFAULT]:  # absent for the paper's model: stored studies stay the same
            identity["model"] = models[0] if len(models) == 1 else list(models)
        resolved = list(dict.fromkeys(f for _, _, f in pairs))
        linear = {"fix_mass": fix_mass, **({"offsets": offsets} if offsets != "branch" else {})}
        if resolved != ["paper"]:  # absent for the paper's formulation: studies stored before stay the same
            identity["formulation"] = resolved[0] if len(resolved) == 1 else resolved
            identity.update(linear)
        variants = [
            (label, {**settings, "model": m, "formulation": f, **linear, "variant": label}) for label, m, f in pairs
        ]
        return ProblemSetup(
            settings=variants[0][1],
            study_json=identity,
            specimens_json={e.name: e.meta["sha256"] for e in entries},
            specimens=tuple(entries),
            available=available or {e.name: e for e in entries},
            data_location={e.name: str(Path(e.path).resolve()) for e in entries},
            variants=tuple(variants) if len(variants) > 1 else (),
        )

    def make_problem(self, settings, entry):
        """The problem of one run: ``setup.setup_fit``, the path every fit takes, with the run's
        variant (a fixed mass or continuous offsets only where the variant can use them)."""
        from bwbench.problems.hysteresis.setup import setup_fit

        model = model_registry.get(settings.get("model", model_registry.DEFAULT))
        formulation = settings.get("formulation") or model.direct_name
        state = settings.get("state") if model.states else None
        layout = model.linear_layout(state) if formulation == "identifiable" and model.has_linear_part else None
        names = bound_names([formulation], state or "shared", [model.name])
        bounds = {k: v for k, v in (settings.get("bounds") or {}).items() if k in names}  # this variant's
        return setup_fit(
            entry.path,
            model=model.name,
            formulation=formulation,
            state=state,
            excitation=settings.get("excitation"),
            fix_mass=settings.get("fix_mass", "auto") if layout is not None and layout.mass else "auto",
            offsets=settings.get("offsets") if layout is not None and layout.branched else None,
            bounds=bounds or None,
            initial_state=settings.get("initial_state", "auto"),
            warmup=settings.get("warmup_s", 0.0),
        ).problem

    def record_columns(self, settings, entry, result=None) -> dict:
        model_name = settings.get("model", model_registry.DEFAULT)
        columns = {
            "state": settings.get("state") if model_registry.get(model_name).states else None,
            "excitation": settings.get("excitation"),
            "model": model_name,
            "formulation": settings.get("formulation", "paper"),
            "variant": settings.get("variant"),
        }
        if result is not None:
            columns.update(rmse_N=result.rmse_N, **result.params)
        return columns

    def specimen_meta(self, entry) -> dict:
        """A manifest's facts of the specimen (material, underpressure_MPa, repeat), its digest left out."""
        return {k: v for k, v in entry.meta.items() if k != "sha256"}

    # ------------------------------------------------------------------------------- report
    def data_dir(self, study, override=None) -> Path:
        if override is not None:
            return Path(override)
        recorded = study.meta.get("data_dir")
        if recorded and Path(recorded).is_dir():
            return Path(recorded)
        if study.paths:
            return Path(next(iter(study.paths.values()))).parent
        from bwbench.datasets.shipped import working_root

        data = Path(study.settings.get("data", "data/specimens"))
        return data if data.is_absolute() else working_root() / data

    def is_synthetic(self, study) -> str:
        """ "SYNTHETIC DATA (generated from <source>)" when a manifest marks the study's specimens
        synthetic ('' otherwise: a false value), for banners and the mark on every figure."""
        found = [manifest_mod.synthetic_source(study.specimen_path(s)) for s in study.specimens]
        sources = [s for s in dict.fromkeys(found) if s]
        return f"SYNTHETIC DATA (generated from {' and '.join(sources)})" if sources else ""

    def noise_floor(self, study, specimen):
        found = manifest_mod.truth(study.specimen_path(specimen))
        if found is None:
            return None
        # The truth in its own model's direct parameters, whatever the study compared.
        from bwbench.models import registry

        model_name, values = found
        model = registry.get(model_name)
        truth = np.array([values[p.name] for p in model.direct_parameters(model.check_state(None))])
        s = study.settings
        settings = {
            "state": s.get("state", "shared"),
            "excitation": s.get("excitation", "measured"),
            "model": model_name,
            "formulation": model.direct_name,
            **{k: s[k] for k in ("initial_state", "warmup_s") if k in s},
        }
        problem = self.make_problem(settings, SpecimenEntry(specimen, str(study.specimen_path(specimen))))
        return float(problem.loss_batch(truth[None, :])[0])

    def setup_text(self, report) -> str:
        from bwbench.problems.hysteresis.report import sections

        return sections.setup_text(report)

    def report_intro(self, report) -> None:
        from bwbench.problems.hysteresis.report import sections

        sections.data_section(report)

    def report_sections(self, report) -> None:
        from bwbench.problems.hysteresis.report import sections

        sections.add_sections(report)

    def limits(self, report) -> list[str]:
        from bwbench.problems.hysteresis.report import sections

        return sections.limits(report)


def start_setting(fail, initial_state, warmup_s, prefix: str) -> dict:
    """{"initial_state", "warmup_s"} of a study, checked (``bwbench.models.start.check``); {} for the
    defaults, so that a study's identity stays what it was before the keys."""
    from bwbench.errors import UserError
    from bwbench.models import start

    flags = ("--initial-state", "--warmup") if prefix == "--" else ("[study] initial_state", "[study] warmup_s")
    try:
        initial_state, warmup_s = start.check(initial_state, warmup_s, flags)
    except UserError as err:
        fail(str(err))
    out = {"initial_state": initial_state} if initial_state != "auto" else {}
    return {**out, "warmup_s": warmup_s} if warmup_s else out


def _refuse_unused(fail, prefix: str, models, formulations, fix_mass, offsets, paths) -> None:
    """``fail`` when a fixed mass or continuous offsets are asked for but no variant of the study can use
    them (as ``bwbench fit`` refuses them): no identifiable formulation with a mass term, or with branches."""
    from bwbench.problems.hysteresis.formulations import variants as variant_list

    layouts = []
    for _, name, formulation in variant_list(models, formulations, paths):
        model = model_registry.get(name)
        if formulation == "identifiable" and model.has_linear_part:
            layouts.append(model.linear_layout(model.states[0] if model.states else None))
    flag = (lambda key: f"--{key.replace('_', '-')}") if prefix == "--" else (lambda key: f"[study] {key}")
    if fix_mass != "auto" and not any(layout.mass for layout in layouts):
        fail(
            f"{flag('fix_mass')} applies to the identifiable formulation of a model with a mass term: no variant "
            f"of this study ({', '.join(models)}) has one"
        )
    if offsets != "branch" and not any(layout.branched for layout in layouts):
        fail(
            f"{flag('offsets')} applies to the identifiable formulation of the switched model: no variant of this "
            f"study ({', '.join(models)}) has branches"
        )


PROBLEM_TYPE = HysteresisProblem()
