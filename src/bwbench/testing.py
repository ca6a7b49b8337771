"""The contract every optimiser backend keeps, as checks a plugin package can run on its own backends.

    from bwbench.testing import check_backend

    def test_my_backend_keeps_the_contract():
        check_backend("my-backend")            # raises AssertionError naming what broke

Each check runs the backend through ``bwbench.engine.fitting.run`` on ``SphereProblem``, a cheap
14-D stand-in for a model (a shifted sphere in unit coordinates with a region of +inf, the "blow-up"
of a real model; it has residuals too, for least-squares backends), which counts every evaluation
itself, independently of the ``Objective``:

- ``check_exact_budget``: never one evaluation over the budget, and the whole budget spent unless
  the backend says why it stopped early — at ``BUDGETS`` (some backends change algorithm above
  1,000 evaluations, so both sides are checked);
- ``check_same_seed``: the same seed gives a bit-identical run, another seed a different one;
- ``check_infinite_loss``: a problem that is +inf on 90 % of the box is survived (no exception, no
  NaN result);
- ``check_options_end``: for every declared option, a run with the option at each edge of its range
  (``declaration.edges()``: bounds, just inside them, every choice, None where allowed; the other
  options at their defaults) ends — the budget spent, or stopped early saying why, or refused with
  a one-line ``UserError`` naming the backend (a limit the declaration cannot express, e.g. one
  that depends on the dimension). Nothing may loop without spending budget.
"""

from __future__ import annotations

import threading

import numpy as np

from bwbench.engine import fitting, registry
from bwbench.engine.options import show
from bwbench.errors import UserError

BUDGETS = (1, 57, 600, 1500)
# A run at an option's edge that has not ended after this long counts as hung. A hang detector,
# not a speed limit: each such run takes well under a second on SphereProblem; the margin is for a
# loaded machine, so that only "still looping" fails.
HANG_AFTER_S = 60.0


class SphereProblem:
    """A counting shifted sphere: identity map from the unit box, optional region of +inf.

    It counts every evaluation itself (``evaluated``, ``call_sizes``, ``blew_up``), independently of
    the ``Objective``. Its loss is Σ (P − centre)², its residuals (for least-squares backends) have
    that mean square.

    Parameters
    ----------
    dim : int, default 14
        The dimension d.
    centre : array_like or None, default None
        The minimum, in unit coordinates; default evenly spaced in [0.2, 0.8].
    blow_up : callable or None, default None
        P (m, d) -> bool mask of the rows that blow up (loss +inf); None: nowhere.
    n_data : int, default 100
        The number of residuals per point (at least ``dim``).

    Examples
    --------
    >>> problem = SphereProblem(dim=3)
    >>> problem.loss_batch([[0.2, 0.5, 0.8]])
    array([0.])
    >>> problem.evaluated
    1
    """

    def __init__(self, dim=14, centre=None, blow_up=None, n_data=100):
        self.dim = dim
        self.param_names = tuple(f"p{i}" for i in range(dim))
        self.lower = np.zeros(dim)
        self.upper = np.ones(dim)
        self.info: dict = {}
        self.n_data = n_data
        self.centre = np.linspace(0.2, 0.8, dim) if centre is None else np.broadcast_to(centre, (dim,))
        self.blow_up = blow_up  # P -> bool mask of rows that blow up, or None
        self.evaluated = 0
        self.blew_up = 0
        self.call_sizes: list[int] = []

    def from_unit(self, U):
        """Unit coordinates to the problem's: the identity.

        Parameters
        ----------
        U : array_like, shape (..., d)
            Points in the unit box.

        Returns
        -------
        numpy.ndarray
        """
        return np.asarray(U, dtype=float)

    def to_unit(self, P):
        """The problem's coordinates to unit ones: the identity.

        Parameters
        ----------
        P : array_like, shape (..., d)
            Points in the problem's coordinates.

        Returns
        -------
        numpy.ndarray
        """
        return np.asarray(P, dtype=float)

    def loss_batch(self, P):
        """The loss of each row, counted.

        Parameters
        ----------
        P : array_like, shape (m, d)
            Points, one per row.

        Returns
        -------
        numpy.ndarray, shape (m,)
            Σ (P − centre)² per row; +inf where it blows up.
        """
        P = np.atleast_2d(P)
        self.evaluated += len(P)
        self.call_sizes.append(len(P))
        loss = np.sum((P - self.centre) ** 2, axis=1)
        if self.blow_up is None:
            return loss
        blown = self.blow_up(P)
        self.blew_up += int(blown.sum())
        return np.where(blown, np.inf, loss)

    def residual_batch(self, P):
        """Residuals whose mean square is ``loss_batch``; counted like ``loss_batch``.

        Parameters
        ----------
        P : array_like, shape (m, d)
            Points, one per row.

        Returns
        -------
        numpy.ndarray, shape (m, n_data)
            √n_data·(P − centre) in the first d columns, zeros after; rows of +inf where it blows up.

        Raises
        ------
        ValueError
            When ``n_data`` < ``dim``: no room for the residuals.
        """
        P = np.atleast_2d(P)
        if self.n_data < self.dim:
            raise ValueError(f"n_data ({self.n_data}) < dim ({self.dim}): no room for the residuals")
        self.evaluated += len(P)
        self.call_sizes.append(len(P))
        R = np.zeros((len(P), self.n_data))
        R[:, : self.dim] = np.sqrt(self.n_data) * (P - self.centre)
        if self.blow_up is None:
            return R
        blown = self.blow_up(P)
        self.blew_up += int(blown.sum())
        R[blown] = np.inf
        return R


class LossOnlySphereProblem(SphereProblem):
    """``SphereProblem`` without residuals: what a problem that only has a loss looks like.

    Parameters
    ----------
    dim, centre, blow_up, n_data
        As ``SphereProblem``.

    Examples
    --------
    >>> LossOnlySphereProblem().residual_batch is None
    True
    """

    residual_batch = None  # type: ignore[assignment]  # the point: this problem has none


def counting_problem() -> SphereProblem:
    """14-D shifted sphere that blows up (+inf) where u₀ > 0.9.

    Returns
    -------
    SphereProblem

    Examples
    --------
    >>> problem = counting_problem()
    >>> problem.loss_batch(np.full((1, 14), 0.95))
    array([inf])
    """
    return SphereProblem(blow_up=lambda P: P[:, 0] > 0.9)


def check_exact_budget(name: str, budgets=BUDGETS, options: dict | None = None) -> None:
    """Check that a backend never spends one evaluation over the budget, and spends it all.

    Unless the backend says why it stopped early (its message is not "budget exhausted"). Checked at
    every budget (some backends change algorithm above 1,000 evaluations, so both sides are checked).

    Parameters
    ----------
    name : str
        The registered backend.
    budgets : tuple of int, default ``BUDGETS`` (1, 57, 600, 1500)
        The budgets tried, in evaluations.
    options : dict or None, default None
        The backend's options; default its defaults.

    Raises
    ------
    AssertionError
        Naming the backend and what broke.

    Examples
    --------
    >>> check_exact_budget("my-backend")
    """
    for budget in budgets:
        problem = counting_problem()
        result = fitting.run(problem, name, budget, seed=11, options=options)
        assert problem.evaluated == result.nfev, (
            f"{name}: the problem counted {problem.evaluated} evaluations, the objective {result.nfev}"
        )
        assert result.nfev <= budget, f"{name}: {result.nfev} evaluations on a budget of {budget}"
        stopped_early = result.message != "budget exhausted"
        assert result.nfev == budget or stopped_early, (
            f"{name}: stopped after {result.nfev} of {budget} evaluations without saying why"
        )


def check_same_seed(name: str, budget: int = 400, options: dict | None = None) -> None:
    """Check that the same seed gives a bit-identical run, another seed a different one.

    Parameters
    ----------
    name : str
        The registered backend.
    budget : int, default 400
        Evaluations per run.
    options : dict or None, default None
        The backend's options; default its defaults.

    Raises
    ------
    AssertionError
        Naming the backend and what differed.

    Examples
    --------
    >>> check_same_seed("my-backend")
    """
    runs = [fitting.run(counting_problem(), name, budget, seed=s, options=options) for s in (5, 5, 6)]
    assert runs[0].trace_mse == runs[1].trace_mse and runs[0].trace_nfev == runs[1].trace_nfev, (
        f"{name}: the same seed gave different runs"
    )
    assert runs[0].params == runs[1].params and runs[0].nfev == runs[1].nfev, f"{name}: same seed, other result"
    assert runs[0].trace_mse != runs[2].trace_mse, f"{name}: seeds 5 and 6 gave the same run"


def check_infinite_loss(name: str, budget: int = 300, options: dict | None = None) -> None:
    """Check that a problem that is +inf on 90 % of the box is survived: no exception, no NaN result.

    Parameters
    ----------
    name : str
        The registered backend.
    budget : int, default 300
        Evaluations of the run.
    options : dict or None, default None
        The backend's options; default its defaults.

    Raises
    ------
    AssertionError
        When the run overspends or its best loss is NaN (an exception of the backend propagates).

    Examples
    --------
    >>> check_infinite_loss("my-backend")
    """
    # +inf on 90 % of the box: a hostile, mostly blown-up model
    mostly_infinite = SphereProblem(blow_up=lambda P: (P[:, 0] > 0.9) | (P[:, 1] > 0.1))
    result = fitting.run(mostly_infinite, name, budget, seed=2, options=options)
    assert result.nfev <= budget, f"{name}: {result.nfev} evaluations on a budget of {budget}"
    assert not np.isnan(result.mse), f"{name}: NaN best loss on a problem that is +inf on 90 % of the box"


def option_edge_cases(name: str) -> list[tuple[str, object]]:
    """Every declared option of a backend with every value at its edges.

    Parameters
    ----------
    name : str
        The registered backend.

    Returns
    -------
    list of (str, object)
        (option, value) pairs, from each declaration's ``edges()``.

    Examples
    --------
    >>> option_edge_cases("random")[:2]
    [('batch_size', 1), ('batch_size', 2)]
    """
    return [
        (option, value) for option, declaration in registry.get(name).options.items() for value in declaration.edges()
    ]


def check_option_ends(name: str, option: str, value, budget: int = 200, hang_after: float = HANG_AFTER_S) -> None:
    """Check that a run of ``name`` with ``option = value`` on the 14-D sphere ends.

    The other options are at their defaults. The run ends if the budget is spent, or it stopped early
    saying why, or it was refused with a one-line ``UserError`` starting with the backend's name (a
    limit the declaration cannot express); see the module docstring.

    Parameters
    ----------
    name : str
        The registered backend.
    option : str
        The option set.
    value : object
        Its value.
    budget : int, default 200
        Evaluations of the run.
    hang_after : float, default ``HANG_AFTER_S`` (60 s)
        Seconds after which a run still going counts as hung: a hang detector, not a speed limit.

    Raises
    ------
    AssertionError
        Naming the backend, the option and value, and what broke.

    Examples
    --------
    >>> check_option_ends("my-backend", "step", 1.0)
    """
    problem = SphereProblem()
    outcome: dict = {}

    def run():
        try:
            outcome["result"] = fitting.run(problem, name, budget, seed=7, options={option: value})
        except BaseException as err:  # re-raised, or judged, in the calling thread
            outcome["error"] = err

    # A thread rather than a direct call only so that a hang fails this check instead of freezing the
    # test session; a hung thread is left running (daemon) — it cannot be stopped from outside.
    thread = threading.Thread(target=run, name=f"bwbench-option-edge {name}", daemon=True)
    thread.start()
    thread.join(hang_after)
    what = f"{name} with {option} = {show(value)}"
    assert not thread.is_alive(), (
        f"{what}: still running after {hang_after:g} s: a loop that spends no budget? "
        "(a hang detector, not a speed limit)"
    )
    error = outcome.get("error")
    if isinstance(error, UserError):  # refused: fine if the user would read one clear line
        text = str(error)
        assert "\n" not in text and text.startswith(f"{name}: "), (
            f"{what}: a refusal must be one line starting with '{name}: ', got {text!r}"
        )
        return
    if error is not None:
        raise AssertionError(f"{what}: {type(error).__name__}: {error}") from error
    result = outcome["result"]
    assert problem.evaluated == result.nfev, (
        f"{what}: the problem counted {problem.evaluated} evaluations, the objective {result.nfev}"
    )
    assert result.nfev <= budget, f"{what}: {result.nfev} evaluations on a budget of {budget}"
    assert result.nfev == budget or result.message != "budget exhausted", (
        f"{what}: stopped after {result.nfev} of {budget} evaluations without saying why"
    )


def check_options_end(name: str, budget: int = 200, hang_after: float = HANG_AFTER_S) -> None:
    """``check_option_ends`` for every edge case of every declared option of ``name``.

    Untyped options, declared with ``defaults=``, have no range and are not tried.

    Parameters
    ----------
    name : str
        The registered backend.
    budget : int, default 200
        Evaluations of each run.
    hang_after : float, default ``HANG_AFTER_S`` (60 s)
        Seconds after which a run still going counts as hung.

    Raises
    ------
    AssertionError
        At the first edge case that does not end.

    Examples
    --------
    >>> check_options_end("my-backend")
    """
    for option, value in option_edge_cases(name):
        check_option_ends(name, option, value, budget, hang_after)


def check_backend(name: str, options: dict | None = None) -> None:
    """Run every check of the contract on a registered backend.

    ``check_exact_budget``, ``check_same_seed`` and ``check_infinite_loss`` with ``options``;
    ``check_options_end`` varies one option at a time from the defaults.

    Parameters
    ----------
    name : str
        The registered backend.
    options : dict or None, default None
        The backend's options; default its defaults.

    Raises
    ------
    AssertionError
        Naming what broke.

    Examples
    --------
    >>> from bwbench.testing import check_backend
    >>> def test_my_backend_keeps_the_contract():
    ...     check_backend("my-backend")
    """
    check_exact_budget(name, options=options)
    check_same_seed(name, options=options)
    check_infinite_loss(name, options=options)
    check_options_end(name)
