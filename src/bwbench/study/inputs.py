"""What a study reads, checked before any run: every input file (no output may be one of them), the
specimens screened by data check's plausibility checks, and a user's search box that blows the model up
at every probed corner."""

from __future__ import annotations

from pathlib import Path

import bwbench.problems as problems
from bwbench.errors import UserError


def study_inputs(config, bounds=None) -> list[Path]:
    """Every file the study ``config`` reads: its TOML, the ``--bounds`` file, each specimen file and the
    manifest beside it, every file of a data folder (the benchmark's): no output may be one of them."""
    from bwbench.data.manifest import MANIFEST

    files = [Path(p) for p in (None if config.path == "--specimens" else config.path, bounds) if p is not None]
    entries = [
        *config.specimens,
        *config.setup.available.values(),
        *(config.posterior.specimens if config.posterior else ()),
        *config.validation,
    ]
    for entry in entries:
        path = Path(entry.path)
        if path.is_dir():
            files += [p for p in path.iterdir() if p.is_file()]
        else:
            files += [path, path.parent / MANIFEST]
    return list(dict.fromkeys(files))


def screen_specimens(config) -> list:
    """data check's plausibility checks on every specimen CSV the study fits or predicts, before any run:
    an unusable one (a dead channel, no force) refused naming the file; the specimens returned, for
    their warnings."""
    from bwbench.data import plausibility
    from bwbench.data.specimen import read_specimen

    entries = [*config.specimens, *(config.posterior.specimens if config.posterior else ())]
    specimens = []
    for path in dict.fromkeys(Path(entry.path) for entry in entries):
        if path.is_file():
            try:
                specimens.append(read_specimen(path))
            except UserError:  # not a specimen CSV: a problem with its own format (its reader checked it)
                continue
    plausibility.screen(specimens, warn=False)
    held = []
    for path in dict.fromkeys(Path(entry.path) for entry in config.validation):
        try:
            held.append(read_specimen(path))
        except UserError:
            continue
    plausibility.screen(held, force_needed=False, warn=False)
    return specimens + held


def refuse_blowing_box(config, bounds_file=None) -> None:
    """With a user's search box (``--bounds`` or ``[bounds]``): ``UserError`` if the model blows up at
    every probed corner of it on some specimen (``bwbench.data.bounds.refuse_if_blows_up``)."""
    if not config.settings.get("bounds"):
        return
    from bwbench.data.bounds import refuse_if_blows_up

    where = f"--bounds {bounds_file}" if bounds_file else f"{config.path}: [bounds]"
    problem_type = problems.get(config.problem)
    for _, settings in config.setup.variants or (("", config.settings),):
        for entry in config.specimens:
            refuse_if_blows_up(problem_type.make_problem(settings, entry), where)
