"""Typed backend options: what each option of a backend accepts, checked before a run starts.

A backend declares its options when it registers (``bwbench.engine.registry``)::

    from bwbench.engine.options import Bool, Choice, Float, Int

    @register("my-search", ..., options={
        "population": Int(40, minimum=2, maximum=10_000),
        "step": Float(0.25, minimum=0.0, maximum=1.0, exclusive_minimum=True),
        "strategy": Choice("best", ("best", "random")),
        "restart": Bool(True),
        "size": Int(None, minimum=2, none="4 + 3·ln d, the library's default"),
    })

Every declaration has

- ``default``: the value when the option is not given (itself checked when declared);
- ``validate(value, label) -> value``: the value normalised, or ``OptionError`` (a ``UserError``, so
  the command line prints it as one line, and a ``ValueError``) reading
  ``<label> must be <what it takes>, got <value>`` — ``label`` is e.g. ``paper-ga: option population``;
- ``describe() -> str``: the type, range and default for ``bwbench optimizers``, e.g.
  ``int in [2, 100000], default 100``;
- ``edges() -> list``: valid values at the edges of the range (each bound, a value just inside it,
  a large value when there is no maximum, every choice, None where allowed), which
  ``bwbench.testing.check_options_end`` runs the backend with.

Values arrive as JSON (``bwbench fit --option population=100``: a bare word stays a string) or TOML
(a study's ``[optimizers]`` table). A bool is not an int (``true`` is not 1), and an int is fine where
a float is expected; it is kept as an int, so a study written before the options were typed keeps
its configuration hash. ``none="what None means"`` also accepts None (JSON ``null``; TOML has no
null: leave the option out). NaN and infinities are refused everywhere.
"""

from __future__ import annotations

import json
import math
import numbers

import numpy as np

from bwbench.errors import UserError

# Edge values tried where a range has no upper bound: large enough to matter, small enough to run.
LARGE_INT = 10**6
LARGE_FLOAT = 1e6
_INVALID = object()


class OptionError(UserError, ValueError):
    """A backend option with a value it cannot take: one line naming backend, option, value, range.

    A ``UserError`` (the command line prints it as one line, exit status 2) and a ``ValueError``.

    Examples
    --------
    >>> raise OptionError("paper-ga: option population must be an integer in [2, 100000], got 'abc'")
    """


def show(value) -> str:
    """A value as the user wrote it: strings quoted, the rest as JSON.

    Parameters
    ----------
    value : object
        Any option value.

    Returns
    -------
    str
        ``repr`` of a string, else the JSON text (true, null, [0.5, 1]), else ``repr``.

    Examples
    --------
    >>> show(True), show(None), show("best"), show([0.5, 1])
    ('true', 'null', "'best'", '[0.5, 1]')
    """
    if isinstance(value, str):
        return repr(value)
    try:
        return json.dumps(value, allow_nan=True)
    except (TypeError, ValueError):
        return repr(value)


def _number(value, integer: bool):
    """``value`` as a Python int/float if it is a finite (integer) number, else ``_INVALID``."""
    if isinstance(value, (bool, np.bool_)):  # True is an Integral to Python, not to a user
        return _INVALID
    if isinstance(value, numbers.Integral):
        if not integer and abs(int(value)) > 1e308:  # JSON ints are unbounded; a library converts to a double
            return _INVALID
        return int(value)
    if integer or not isinstance(value, numbers.Real) or not math.isfinite(value):
        return _INVALID
    return float(value)


def _bound(x) -> str:
    text = repr(x)  # exact, unlike :g; but 1 reads better than 1.0
    return text[:-2] if isinstance(x, float) and text.endswith(".0") else text


def _interval(minimum, maximum, exclusive_minimum=False, exclusive_maximum=False) -> str:
    """``≥ 2``, ``> 0``, ``in [0, 1]``, ``in (0, 1]``, or "" when unbounded."""
    lo, hi = _bound(minimum), _bound(maximum)
    if minimum is not None and maximum is not None:
        return f"in {'(' if exclusive_minimum else '['}{lo}, {hi}{')' if exclusive_maximum else ']'}"
    if minimum is not None:
        return f"{'>' if exclusive_minimum else '≥'} {lo}"
    if maximum is not None:
        return f"{'<' if exclusive_maximum else '≤'} {hi}"
    return ""


class Option:
    """Base of the option declarations.

    Subclasses define ``_normalise``, ``_expected``, ``_summary`` and ``_edges``.

    Parameters
    ----------
    default : object
        The value when the option is not given; checked when declared (a wrong default raises
        ``OptionError`` at import, not in a user's run).
    none : str or None, default None
        What None means, when None is accepted (JSON ``null``); None: None is refused.
    """

    def __init__(self, default, *, none: str | None = None):
        self.none = none  # what None means, when None is accepted
        # A wrong default is the backend author's mistake: raise at import, not in a user's run.
        self.default = self.validate(default, "the declared default")

    def validate(self, value, label: str):
        """Check a value against the declaration and normalise it.

        Parameters
        ----------
        value : object
            The value given (from JSON or TOML).
        label : str
            What names the option in the message, e.g. ``paper-ga: option population``.

        Returns
        -------
        object
            The value normalised (an int stays an int where a float is expected; a pair becomes a list).

        Raises
        ------
        OptionError
            ``<label> must be <what it takes>, got <value>``.

        Examples
        --------
        >>> Int(40, minimum=2).validate(100, "paper-ga: option population")
        100
        """
        if value is None and self.none is not None:
            return None
        normalised = self._normalise(value)
        if normalised is _INVALID:
            raise OptionError(f"{label} must be {self.expected()}, got {show(value)}")
        return normalised

    def expected(self) -> str:
        """What the option takes, as the end of "must be ...".

        Returns
        -------
        str
            E.g. ``an integer ≥ 2``, with what None means where it is accepted.
        """
        return self._expected() + (f" (or null: {self.none})" if self.none is not None else "")

    def describe(self) -> str:
        """Type, range and default, as ``bwbench optimizers`` shows them.

        Returns
        -------
        str
            E.g. ``int in [2, 1000] or null (cma's default), default null``.
        """
        text = self._summary() + (f" or null ({self.none})" if self.none is not None else "")
        default = self.default if isinstance(self.default, str) else show(self.default)  # as choices are listed
        return f"{text}, default {default}"

    def edges(self) -> list:
        """Valid values at the edges of the range, which ``bwbench.testing.check_options_end`` runs.

        Returns
        -------
        list
            Each bound, a value just inside it, a large value when there is no maximum, every choice,
            the default, None where allowed; no repeats.
        """
        values = [*self._edges(), self.default] + ([None] if self.none is not None else [])
        unique: list = []
        for v in values:  # keep order, drop repeats
            if not any(type(v) is type(u) and v == u for u in unique):
                unique.append(v)
        return unique

    def _normalise(self, value):
        raise NotImplementedError

    def _expected(self) -> str:
        raise NotImplementedError

    def _summary(self) -> str:
        raise NotImplementedError

    def _edges(self) -> list:
        return []


class Int(Option):
    """An integer option in [minimum, maximum].

    Parameters
    ----------
    default : int or None
        The value when the option is not given.
    minimum, maximum : int or None, default None
        The inclusive bounds; None: unbounded on that side.
    none : str or None, default None
        What None means, when None is accepted.

    Examples
    --------
    >>> Int(40, minimum=2, maximum=10_000).describe()
    'int in [2, 10000], default 40'
    """

    def __init__(self, default, minimum: int | None = None, maximum: int | None = None, *, none=None):
        self.minimum, self.maximum = minimum, maximum
        super().__init__(default, none=none)

    def _normalise(self, value):
        value = _number(value, integer=True)
        if (
            value is _INVALID
            or (self.minimum is not None and value < self.minimum)
            or (self.maximum is not None and value > self.maximum)
        ):
            return _INVALID
        return value

    def _expected(self) -> str:
        return " ".join(filter(None, ("an integer", _interval(self.minimum, self.maximum))))

    def _summary(self) -> str:
        return " ".join(filter(None, ("int", _interval(self.minimum, self.maximum))))

    def _edges(self) -> list:
        lo = self.minimum if self.minimum is not None else -LARGE_INT
        if self.maximum is None:
            return [lo, lo + 1, max(lo + 2, LARGE_INT)]
        return [v for v in (lo, lo + 1, self.maximum - 1, self.maximum) if lo <= v <= self.maximum]


class Float(Option):
    """A finite number option in the interval the bounds give.

    Parameters
    ----------
    default : float or None
        The value when the option is not given.
    minimum, maximum : float or None, default None
        The bounds; None: unbounded on that side.
    exclusive_minimum, exclusive_maximum : bool, default False
        Exclude that bound (each is inclusive otherwise).
    none : str or None, default None
        What None means, when None is accepted.

    Examples
    --------
    >>> Float(0.25, minimum=0.0, maximum=1.0, exclusive_minimum=True).expected()
    'a number in (0, 1]'
    """

    def __init__(
        self,
        default,
        minimum: float | None = None,
        maximum: float | None = None,
        exclusive_minimum: bool = False,
        exclusive_maximum: bool = False,
        *,
        none=None,
    ):
        self.minimum, self.maximum = minimum, maximum
        self.exclusive_minimum, self.exclusive_maximum = exclusive_minimum, exclusive_maximum
        super().__init__(default, none=none)

    def _normalise(self, value):
        number = _number(value, integer=False)
        return number if number is not _INVALID and self._inside(number) else _INVALID

    def _inside(self, x) -> bool:
        lo, hi = self.minimum, self.maximum
        if lo is not None and (x < lo or (self.exclusive_minimum and x == lo)):
            return False
        return hi is None or not (x > hi or (self.exclusive_maximum and x == hi))

    def _interval(self) -> str:
        return _interval(self.minimum, self.maximum, self.exclusive_minimum, self.exclusive_maximum)

    def _expected(self) -> str:
        return " ".join(filter(None, ("a number", self._interval())))

    def _summary(self) -> str:
        return " ".join(filter(None, ("float", self._interval())))

    def _edges(self) -> list:
        out = []
        for bound, exclusive, inward in (
            (self.minimum, self.exclusive_minimum, 1.0),
            (self.maximum, self.exclusive_maximum, -1.0),
        ):
            if bound is None:
                out.append(-inward * LARGE_FLOAT)
                continue
            # "just inside": a millionth of the bound's scale, the closest a user plausibly comes
            out += ([] if exclusive else [bound]) + [bound + inward * 1e-6 * max(1.0, abs(bound))]
        return [x for x in out if self._inside(x)]


class Choice(Option):
    """An option that is one of a fixed set of values (strings, usually).

    Parameters
    ----------
    default : object
        The value when the option is not given.
    choices : iterable
        The values accepted (compared by type and value: True is not 1).
    none : str or None, default None
        What None means, when None is accepted.

    Examples
    --------
    >>> Choice("best", ("best", "random")).describe()
    'one of best, random, default best'
    """

    def __init__(self, default, choices, *, none=None):
        self.choices = tuple(choices)
        super().__init__(default, none=none)

    def _normalise(self, value):
        # type() as well as ==: True must not pass for a choice 1
        return next((c for c in self.choices if type(c) is type(value) and c == value), _INVALID)

    def _expected(self) -> str:
        return "one of " + ", ".join(show(c) for c in self.choices)

    def _summary(self) -> str:
        return "one of " + ", ".join(map(str, self.choices))

    def _edges(self) -> list:
        return list(self.choices)


class Bool(Option):
    """A switch: true or false (not 0 or 1: a switch written as a number is more likely a mistake).

    Parameters
    ----------
    default : bool or None
        The value when the option is not given.
    none : str or None, default None
        What None means, when None is accepted.

    Examples
    --------
    >>> Bool(True).validate(False, "my-search: option restart")
    False
    """

    def _normalise(self, value):
        return bool(value) if isinstance(value, (bool, np.bool_)) else _INVALID

    def _expected(self) -> str:
        return "true or false"

    def _summary(self) -> str:
        return "bool"

    def _edges(self) -> list:
        return [False, True]


class FloatOrPair(Option):
    """A number, or a pair [lo, hi] with lo ≤ hi, each in the interval.

    E.g. scipy DE's ``mutation``: a constant, or a range to dither in. A pair is normalised to a list,
    as JSON and TOML give it.

    Parameters
    ----------
    default : float, list or None
        The value when the option is not given.
    minimum, maximum : float or None, default None
        The bounds of each number; None: unbounded on that side.
    exclusive_minimum, exclusive_maximum : bool, default False
        Exclude that bound (each is inclusive otherwise).
    none : str or None, default None
        What None means, when None is accepted.

    Examples
    --------
    >>> FloatOrPair([0.5, 1.0], minimum=0.0, maximum=2.0).validate((0.5, 1), "de: option mutation")
    [0.5, 1]
    """

    def __init__(
        self, default, minimum=None, maximum=None, exclusive_minimum=False, exclusive_maximum=False, *, none=None
    ):
        # checks one number; its default (None, hence none=) is never used
        self.number = Float(None, minimum, maximum, exclusive_minimum, exclusive_maximum, none="unused")
        super().__init__(default, none=none)

    def _normalise(self, value):
        if isinstance(value, (list, tuple)):
            if len(value) != 2:
                return _INVALID
            lo, hi = (self.number._normalise(v) for v in value)
            return _INVALID if _INVALID in (lo, hi) or lo > hi else [lo, hi]
        return self.number._normalise(value)

    def _expected(self) -> str:
        return f"{self.number._expected()}, or a pair [lo, hi] of such numbers with lo ≤ hi"

    def _summary(self) -> str:
        interval = self.number._interval()
        return "float or pair [lo, hi] with lo ≤ hi" + (f", each {interval}" if interval else "")

    def _edges(self) -> list:
        singles = self.number._edges()
        return singles + [[singles[0], singles[0]], [singles[0], singles[-1]], [singles[-1], singles[-1]]]
