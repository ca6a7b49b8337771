"""The registry of optimiser backends, and the contract a backend keeps.

Writing a backend (built in, or in another package)
---------------------------------------------------
A backend is one function registered by name, with its options declared::

    from bwbench.engine.options import Float
    from bwbench.engine.registry import register

    @register("my-search", family="local", description="what it does, in one line",
              options={"step": Float(0.25, minimum=0.0, maximum=1.0, exclusive_minimum=True)},
              batched=False)
    def minimize(objective, *, rng, step=0.25):
        ...
        return {"message": "why it stopped"}          # optional extras

- **Coordinates.** The backend sees only the unit box u ∈ [0, 1]^d (``objective.dim``); the problem
  maps it to physical units. Points outside the box are clipped (and counted).
- **Evaluations.** ``objective(u)`` gives the loss of one point (a float), ``objective.batch(U)`` the
  losses of the rows of U, shape (m, d), in one call — use it for populations: a batch is simulated
  in parallel. Declare ``batched=True`` if the backend asks for whole populations at a time, False if
  it asks for one point per call (``bwbench optimizers`` and the report show it: it explains wall-time
  differences at equal evaluation budgets). A loss may be +inf (the model blew up); never NaN.
- **The budget** belongs to the objective, never to the library: asking for evaluation number
  budget + 1 raises ``bwbench.errors.BudgetExhausted`` (a batch larger than what is left is cut, its
  cut rows read +inf, and the next call raises). Letting that exception propagate out of
  ``minimize`` is the normal way to stop: ``bwbench.engine.fitting.run`` catches it. A library
  that breaks when its objective raises (NLopt can lose the exception; nevergrad's NgIohTuned fails
  when asked one point past its budget; emcee prints a traceback) must instead check
  ``objective.exhausted`` (or ``objective.remaining``) before asking, and stop by itself.
- **Randomness.** Every draw comes from ``rng`` (a ``numpy.random.Generator`` made from the run's
  seed): the same seed must give a bit-identical run. A library that draws from numpy's global
  generator runs inside ``bwbench.engine.global_rng.seeded_global_rng(rng)``.
- **+inf.** A library that mishandles +inf (finite differences, quadratic models) gets
  ``bwbench.engine.finite_penalty.WorstFinitePenalty`` applied to the losses.
- **What is kept.** The best point, its loss and the best-so-far trace are recorded by the objective
  itself. The returned dict's ``message`` becomes the result's message (default: "budget
  exhausted" when BudgetExhausted stopped it); scalar extras go into the result JSON, and a
  ``chain`` (steps, walkers, d), with ``log_prob`` and ``acceptance_fraction``, is stored by a study
  in its ``chains`` table (MCMC backends).
- **Options** are keyword arguments, declared in ``options={name: declaration}`` with a type, a
  valid range and a default (``bwbench.engine.options``: ``Int``, ``Float``, ``Choice``, ``Bool``,
  ``FloatOrPair``; ``none=`` also accepts None). ``resolve_options`` checks every value against its
  declaration before the run starts (``bwbench fit --option``, a study's ``[optimizers]`` table,
  ``bwbench.engine.fitting.run``), so ``minimize`` receives only values in the declared ranges.
  Declare ranges the algorithm is actually valid on, and no value in them may make the backend loop
  without spending budget (a restart that evaluates nothing must end the run, with a message). A
  limit that depends on the problem (e.g. emcee's walkers ≥ 2·d) is checked by the backend itself at
  the start of ``minimize``, raising ``bwbench.engine.options.OptionError`` (one line:
  ``name: option X must be ..., got V``). A study stores the options with every run, so they must
  be plain JSON values.
- **Untyped options**: ``defaults={"step": 0.25}`` instead of
  ``options=`` still works; only unknown names are refused, values reach ``minimize`` unchecked,
  and ``bwbench optimizers`` shows them as untyped. Give one of ``options=`` and ``defaults=``.

``bwbench.testing.check_backend(name)`` runs the contract's checks (exact budget at several budgets,
same seed same run, +inf survived, a run at every declared option's edge values ends);
``examples/plugin/`` is a complete, installable plugin package.

Registration
------------
Built-in backends live in ``bwbench.optimizers``; other packages plug in theirs through the
entry-point group ``bwbench.optimizers`` (each entry point names a module to import, whose
``register`` calls add its backends). A second backend of an existing name is refused. A plug-in
that fails to import breaks only itself (``bwbench.plugins``): asking for it by its entry point's
name gives one line naming it and its error.
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from typing import Callable

import bwbench.plugins as plugins
from bwbench.engine.options import Option, show
from bwbench.errors import UserError

ENTRY_POINT_GROUP = "bwbench.optimizers"


@dataclass(frozen=True)
class Backend:
    """A registered optimiser backend: what ``register`` records and ``get`` returns.

    Parameters
    ----------
    name : str
        The registry key (``--optimizer NAME``).
    family : str
        Its family, e.g. "local", "swarm", "mcmc".
    description : str
        What it does, in one line.
    minimize : callable
        ``minimize(objective, *, rng, **options)``: the search (see the module docstring).
    defaults : dict, default {}
        {option: default}; derived from ``options`` when typed.
    batched : bool, default True
        Asks for whole populations per ``objective.batch`` call (True) or one point per call (False).
    options : dict, default {}
        {option: declaration} (``bwbench.engine.options``); empty for a backend registered with
        ``defaults=`` only.

    Examples
    --------
    >>> backend = get("lsq-trf")
    >>> backend.family, backend.batched, sorted(backend.options)[:2]
    """

    name: str
    family: str
    description: str
    minimize: Callable
    defaults: dict = field(default_factory=dict)  # name -> default; derived from ``options`` when typed
    # Asks for whole populations per objective.batch call (True) or one point per call (False).
    batched: bool = True
    # name -> declaration (bwbench.engine.options); empty for a backend registered with defaults= only.
    options: dict = field(default_factory=dict)


# The built-in backends and the module of ``bwbench.optimizers`` each lives in: running one backend
# imports only its module and the libraries it needs (emcee, scipy.optimize, nlopt and pyswarms cost
# a second or more together). A test checks this table against what the modules register.
BUILTIN = {
    "random": "random_search",
    "paper-ga": "paper_ga",
    "firefly": "firefly",
    "pso": "pso",
    "anneal": "anneal",
    "nlopt-bobyqa": "nlopt_local",
    "nlopt-sbplx": "nlopt_local",
    "nlopt-neldermead": "nlopt_local",
    "cmaes": "cmaes",
    "de": "de",
    "emcee": "emcee_sampler",
    "lsq-trf": "lsq_trf",
    "nested": "nested_sampler",
}
REGISTRY: plugins.Registry[Backend] = plugins.Registry(
    "optimiser",
    ENTRY_POINT_GROUP,
    {name: f"bwbench.optimizers.{module}" for name, module in BUILTIN.items()},
    known="available",
)


def register(
    name: str,
    *,
    family: str,
    description: str,
    options: dict | None = None,
    defaults: dict | None = None,
    batched: bool = True,
):
    """Register a backend's ``minimize`` under ``name`` (a decorator).

    A second backend of the same name is refused.

    Parameters
    ----------
    name : str
        The backend's name (``--optimizer NAME``).
    family : str
        Its family, e.g. "local", "swarm", "mcmc".
    description : str
        What it does, in one line.
    options : dict or None, default None
        {name: declaration} (``bwbench.engine.options``: typed, checked before every run).
    defaults : dict or None, default None
        {name: value}: the untyped contract, names checked only. Give one of ``options`` and
        ``defaults``, or neither.
    batched : bool, default True
        Whether ``minimize`` asks for whole populations per ``objective.batch`` call (True) or one
        point per call (False).

    Returns
    -------
    callable
        The decorator; it returns ``minimize`` unchanged.

    Raises
    ------
    ValueError
        When both ``options`` and ``defaults`` are given.
    TypeError
        When an option is not declared with ``bwbench.engine.options``.

    Examples
    --------
    >>> from bwbench.engine.options import Float
    >>> @register("my-search", family="local", description="what it does, in one line",
    ...           options={"step": Float(0.25, minimum=0.0, maximum=1.0, exclusive_minimum=True)},
    ...           batched=False)
    ... def minimize(objective, *, rng, step=0.25):
    ...     return {"message": "why it stopped"}
    """
    if options and defaults:
        raise ValueError(f"{name}: give options= (typed) or defaults= (untyped), not both")
    options = dict(options or {})
    for key, declaration in options.items():
        if not isinstance(declaration, Option):
            raise TypeError(
                f"{name}: option {key!r} must be declared with bwbench.engine.options "
                f"(Int, Float, Choice, Bool, ...), got {declaration!r}; plain defaults go in defaults="
            )
    if options:
        defaults = {key: declaration.default for key, declaration in options.items()}

    def decorate(minimize: Callable) -> Callable:
        backend = Backend(name, family, description, minimize, dict(defaults or {}), bool(batched), options)
        REGISTRY.add(name, backend, same=lambda a, b: a.minimize is b.minimize)
        return minimize

    return decorate


def _load() -> None:
    """Every built-in backend's module (by name: the backends sit above this engine), then the plug-ins."""
    builtin = importlib.import_module("bwbench.optimizers")
    for module in pkgutil.iter_modules(builtin.__path__):
        importlib.import_module(f"{builtin.__name__}.{module.name}")
    REGISTRY.load_plugins()


def broken() -> dict[str, str]:
    """The installed optimiser plug-ins that failed to load.

    Returns
    -------
    dict of str to str
        Entry point name -> the line naming it and its error.

    Examples
    --------
    >>> for name, line in broken().items():
    ...     print(line)
    """
    _load()
    return dict(REGISTRY.broken)


def available() -> dict[str, Backend]:
    """Every registered backend, built-in and plugged in.

    Returns
    -------
    dict of str to Backend
        The backends by name, sorted.

    Examples
    --------
    >>> sorted(available())[:3]
    ['anneal', 'cmaes', 'de']
    """
    _load()
    with REGISTRY.lock:
        return dict(sorted(REGISTRY.items.items()))


def get(name: str) -> Backend:
    """The backend ``name``: a built-in one by importing its module only, else after loading them all.

    Parameters
    ----------
    name : str
        The backend's name.

    Returns
    -------
    Backend

    Raises
    ------
    bwbench.errors.UserError
        One line when there is no such backend (or its plug-in failed to load), naming what there is.

    Examples
    --------
    >>> get("cmaes").family
    'evolution-strategy'
    """
    return REGISTRY.lookup(name, lambda: list(available()))


def resolve_options(backend_name: str, given: dict | None = None, *, label: str | None = None) -> dict:
    """The options a run of ``backend_name`` gets, checked.

    Its defaults updated with ``given``, every value checked against its declaration and normalised
    (an untyped backend's values are passed unchecked).

    Parameters
    ----------
    backend_name : str
        The backend's name.
    given : dict or None, default None
        {option: value} as the user gave them.
    label : str or None, default None
        What starts the error message; default: the backend's name.

    Returns
    -------
    dict
        {option: value} for every option of the backend.

    Raises
    ------
    bwbench.errors.UserError
        ``OptionError`` for a bad value, with one line starting with ``label``, e.g. ``paper-ga:
        option population must be an integer in [2, 100000], got 'abc'`` or ``random: unknown
        option(s) colour; it takes batch_size``.

    Examples
    --------
    >>> resolve_options("paper-ga", {"population": 60})["population"]
    60
    """
    backend = get(backend_name)
    label = backend_name if label is None else label
    if given is None:
        given = {}
    if not isinstance(given, dict):
        raise UserError(f"{label}: options must be a table of name = value, got {show(given)}")
    known = backend.options or backend.defaults
    unknown = sorted((key for key in given if key not in known), key=str)
    if unknown:
        raise UserError(
            f"{label}: unknown option(s) {', '.join(map(str, unknown))}; it takes {', '.join(known) or 'none'}"
        )
    if not backend.options:  # untyped (defaults=): names only, values unchecked
        return {**backend.defaults, **given}
    # The default goes through validate too: a fresh copy, so a backend may modify what it gets.
    return {
        key: declaration.validate(given[key] if key in given else declaration.default, f"{label}: option {key}")
        for key, declaration in backend.options.items()
    }
