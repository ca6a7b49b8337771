"""``--plugin FILE.py``: a model, problem or optimiser backend loaded from a file, not installed
(``bwbench.plugins.load_files``); each file must give at least one of them."""

from __future__ import annotations

import argparse

from bwbench.errors import UserError

# The commands that look models, problems or backends up by name.
COMMANDS = ("simulate", "evaluate", "optimizers", "models", "fit", "predict", "compare", "report", "identifiability")


def add(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--plugin",
        action="append",
        metavar="FILE.py",
        help="load a model (a module with MODEL), problem (PROBLEM_TYPE) or optimiser backend (registered "
        "with bwbench.engine.registry.register) from this Python file, without installing it; repeatable",
    )


def registered() -> set:
    """Every model, problem and backend name known in this process, by kind."""
    import bwbench.problems as problems
    from bwbench.engine import registry as backends
    from bwbench.models import registry as models

    return (
        {("model", n) for n in models.names()}
        | {("problem", n) for n in problems.names()}
        | {("optimiser backend", n) for n in backends.available()}
    )


def load(paths) -> list[str]:
    """Load each file of ``paths`` (``plugins.load_files``); ``UserError`` for a file that gives nothing.
    Returns what each gave, e.g. "plug-in file x.py: model 'linear-damper'"."""
    import bwbench.plugins as plugins

    out = []
    for path in paths or ():
        before = registered()
        (loaded,) = plugins.load_files([path])
        new = sorted(registered() - before)
        if not new:
            raise UserError(
                f"--plugin {path}: defines no MODEL (a bwbench.models.base.Model) or PROBLEM_TYPE, and registers "
                "no optimiser backend (bwbench.engine.registry.register): nothing to use"
            )
        out.append(f"plug-in file {loaded}: " + ", ".join(f"{kind} {name!r}" for kind, name in new))
    return out
