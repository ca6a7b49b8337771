"""How every model starts a record: one rule for all models, applied where a record is simulated (the
problems, a stored fit's predictions), never inside a model.

Every model's kernel starts at rest at the first sample it is given (the Bouc-Wen models z = 0,
Spencer's model y = x, z = 0). The rule decides what that first sample is (``initial_state``):

- ``"rest"``: the record's own first sample.
- ``"pre-roll"``: one cycle of the record's own motion: its first k samples (``preroll_end``: where,
  after two reversals, the record passes its starting displacement in its starting direction again),
  put before the record's start (times shifted by t[k] − t[0], displacement by x[0] − x[k] so that
  the cycle ends where the record begins) and simulated first; the model enters the record in the
  state that cycle leads to (for a periodic test, its steady state). The pre-rolled samples are not
  in the loss. A record without a full cycle, or whose first velocity sample is 0, starts from rest.
- ``"auto"`` (the default): from rest when the record starts from rest (``starts_from_rest``: still
  at mid-stroke or ramping in, or a loading protocol of growing amplitude; else judged by its force,
  which a record cut from a running test repeats a cycle of its own motion later and a specimen set
  moving from rest does not), else after the pre-roll.

``warmup_s``: the record's first seconds are simulated but left out of the loss, of the per-file
errors and of the checks of the residual (a record cut from a running test whose state the pre-roll
does not reach, e.g. random motion). A comparison of models uses the same rule for all of them: the
rule lives here and in the problem's settings, and a model cannot choose its own.

Values of the models' internal states at the first sample are not offered: each kernel starts its
states at rest internally (and the identifiable formulation searches a state scaled by its
saturation value, z/z_s), so a given z0 would need every kernel and its sensitivities changed.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from bwbench.errors import UserError

INITIAL_STATES = ("auto", "rest", "pre-roll")
RULE = (
    "every model starts the same way: from rest at the record's first sample when the record starts from "
    "rest, else after a pre-roll of one cycle of the record's own motion (left out of the loss)"
)
MIN_LOSS_SAMPLES = 10  # what a warm-up must leave of a record for the loss

REST_VELOCITY = 0.02  # × max|ẋ|: the record's first samples move slower than this: it starts from rest
REST_POSITION = 0.1  # × amplitude: ... and from near mid-stroke (a record cut at a reversal is at an end)


# × the force range: a start whose force is the one a cycle later is the steady state's. A record still at
# an end of its stroke: within 10 %. A record already moving: within 3 % (measured: records cut from running
# tests, the shipped MR tests and Dahl-friction tests with 8 N noise, repeat their start within 0.1-0.9 %;
# a sine simulated from rest at full speed differs by 5.6 %).
LOADED_MATCH = 0.1
MOVING_MATCH = 0.03
# × max|ẋ|: the force a cycle later says something of the state only where the motion repeats there
REPEAT_VELOCITY = 0.05


def starts_from_rest(t, x, v, f=None) -> bool:
    """Whether a record starts from rest, so that a model started at rest at its first sample matches it.

    Still over its first three samples (velocity within ``REST_VELOCITY`` × max|ẋ|) and near mid-stroke
    (within ``REST_POSITION`` × the amplitude of (x_max + x_min)/2) or ramping in (``steady_part``):
    from rest. Otherwise the measured force ``f`` (N) decides, by comparing the force at the start
    with the force a cycle of the record's own motion later (``preroll_end``) at the same displacement
    and direction: a record cut from a running test is in its steady state and repeats it, a specimen
    started from rest has not yet built up its hysteresis. Still at an end of its stroke (a machine's
    ramp test): from rest unless the two agree within ``LOADED_MATCH`` × the force range. A loading
    protocol of growing amplitude (``models.protocol``) starts its specimen from rest: such a test begins
    at its smallest cycle, and none of its cycles is the record's steady state. Already
    moving: from rest when they differ by more than ``MOVING_MATCH`` × the range while the motion
    itself repeats there (velocity within ``REPEAT_VELOCITY`` × max|ẋ|); where it does not repeat (a
    two-tone or random motion) the force cannot tell, and the record is taken as in motion. Without
    ``f``: a still record at an end, or a moving one, is not from rest.
    """
    from bwbench.data.steady_part import steady_part

    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    fastest = float(np.max(np.abs(v)))
    still = np.median(np.abs(v[:3])) <= REST_VELOCITY * fastest
    mid, amplitude = 0.5 * (x.max() + x.min()), 0.5 * float(np.ptp(x))
    if still and (abs(x[0] - mid) <= REST_POSITION * amplitude or steady_part(t, x).ramp_in_cycles > 0):
        return True
    if growing(x):
        return True
    if f is None:
        return False
    k = preroll_end(x, v)
    if k == 0:
        return bool(still)  # no cycle later to compare with: still means unloaded, moving means in motion
    f = np.asarray(f, dtype=float)
    apart = abs(np.median(f[:3]) - np.median(f[k : k + 3])) / float(np.ptp(f))
    if still:
        return bool(apart > LOADED_MATCH)
    repeats = abs(float(np.median(v[:3])) - float(np.median(v[k : k + 3]))) <= REPEAT_VELOCITY * fastest
    return bool(repeats and apart > MOVING_MATCH)


def growing(x) -> bool:
    """Whether the displacement ``x`` (mm) is a loading protocol of growing amplitude (``models.protocol``)."""
    from bwbench.models.protocol import protocol

    return protocol(x).kind == "growing amplitude"


def preroll_end(x, v) -> int:
    """The first sample after one full cycle of the record's own motion where it passes its starting
    displacement in its starting direction (after two reversals of ẋ); 0 when there is none or the first
    velocity sample is 0."""
    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    s0 = float(np.sign(v[0]))
    if s0 == 0.0 or len(x) < 3:
        return 0
    reversals = np.concatenate([[0], np.cumsum(v[1:] * v[:-1] < 0.0)])
    d = (x - x[0]) * s0
    passing = (reversals[1:] >= 2) & (v[1:] * s0 > 0.0) & (d[:-1] < 0.0) & (d[1:] >= 0.0)
    found = np.flatnonzero(passing)
    return int(found[0]) + 1 if found.size else 0


@dataclass(frozen=True)
class Start:
    """The start of one record: ``initial_state`` and ``warmup_s`` as asked, ``resolved`` ("rest" or
    "pre-roll"), ``preroll`` (samples put before the record, 0 from rest; ``preroll_s`` their span),
    ``warmup`` (the record's first samples left out of the loss), ``reason`` (why, in words)."""

    initial_state: str = "auto"
    warmup_s: float = 0.0
    resolved: str = "rest"
    preroll: int = 0
    preroll_s: float = 0.0
    warmup: int = 0
    reason: str = ""

    @property
    def plain(self) -> bool:
        """The record simulated and fitted as it is: from rest, nothing left out."""
        return self.preroll == 0 and self.warmup == 0

    @property
    def loss(self) -> slice:
        """The samples of the record in the loss."""
        return slice(self.warmup, None)

    def extend(self, signal):
        """The excitation the models simulate: ``signal`` (t, x, v, a) with the pre-roll put before it
        (the object itself when there is none). Array fields as long as the record are extended: the
        model sees the same kind of object."""
        k = self.preroll
        if k == 0:
            return signal
        t, x = np.asarray(signal.t, dtype=float), np.asarray(signal.x, dtype=float)
        n = len(t)
        shift = {"t": t[0] - t[k], "x": x[0] - x[k], "x_recorded": x[0] - x[k]}

        def longer(name, arr):
            arr = np.asarray(arr, dtype=float)
            return np.concatenate([arr[:k] + shift.get(name, 0.0), arr])

        if dataclasses.is_dataclass(signal) and not isinstance(signal, type):
            fields = {
                f.name: longer(f.name, getattr(signal, f.name))
                for f in dataclasses.fields(signal)
                if isinstance(getattr(signal, f.name), np.ndarray) and len(getattr(signal, f.name)) == n
            }
            return dataclasses.replace(signal, **fields)
        return SimpleNamespace(**{name: longer(name, getattr(signal, name)) for name in "txva"})

    def crop(self, values):
        """The record's samples (the last axis) of what was simulated on ``extend``'s excitation."""
        return values if values is None or self.preroll == 0 else values[..., self.preroll :]

    def describe(self) -> str:
        """The start in words, for the fit's notes, JSON and report."""
        warm = (
            f"; warm-up: the first {self.warmup_s:g} s ({self.warmup} samples) simulated but left out of the loss"
            if self.warmup
            else ""
        )
        if self.resolved == "pre-roll":
            return (
                f"after a pre-roll: one cycle of the record's own motion ({self.preroll} samples, "
                f"{self.preroll_s:.4g} s) simulated before its first sample and left out of the loss, the same for "
                f"every model ({self.reason}){warm}"
            )
        return f"from rest at the first sample, the same for every model ({self.reason}){warm}"

    def to_json(self) -> dict:
        """What the fit's JSON records: the rule as asked, its resolution and the spans left out."""
        return {
            "initial_state": self.initial_state,
            "warmup_s": self.warmup_s,
            "resolved": self.resolved,
            "preroll_samples": self.preroll,
            "preroll_s": self.preroll_s,
            "warmup_samples": self.warmup,
            "rule": RULE,
            "units": {"warmup_s": "s", "preroll_s": "s", "preroll_samples": "samples", "warmup_samples": "samples"},
        }


def rule_text(initial_state: str = "auto", warmup_s: float = 0.0) -> str:
    """The rule as asked, in words (a study's report says it once for all its records)."""
    text = {
        "auto": "from rest when it starts from rest, else after a pre-roll of one cycle of its own motion",
        "rest": "from rest at its first sample",
        "pre-roll": "after a pre-roll of one cycle of its own motion",
    }[initial_state]
    return text + (f", its first {warmup_s:g} s simulated but left out of the loss" if warmup_s else "")


def check(initial_state, warmup_s, flags=("--initial-state", "--warmup")) -> tuple[str, float]:
    """(initial_state, warmup_s) checked, ``UserError`` naming ``flags`` (the CLI's, the API's keywords or
    the TOML's keys) otherwise."""
    if initial_state not in INITIAL_STATES:
        raise UserError(f"{flags[0]} must be one of {', '.join(INITIAL_STATES)}, got {initial_state!r}")
    try:
        seconds = float(warmup_s) if not isinstance(warmup_s, bool) else float("nan")
    except (TypeError, ValueError):
        seconds = float("nan")
    if not (np.isfinite(seconds) and seconds >= 0.0):
        raise UserError(f"{flags[1]} must be a number of seconds ≥ 0, got {warmup_s!r}")
    return str(initial_state), seconds


def plan(signal, initial_state: str = "auto", warmup_s: float = 0.0, name: str = "the record", f=None) -> Start:
    """The ``Start`` of the record ``signal`` (t, x, v) with measured force ``f`` (N; None when there is
    none, e.g. a simulation) under the rule of the module docstring; ``UserError`` naming ``name`` when
    the warm-up leaves fewer than ``MIN_LOSS_SAMPLES`` samples."""
    initial_state, warmup_s = check(initial_state, warmup_s)
    t, x, v = (np.asarray(getattr(signal, k), dtype=float) for k in "txv")
    warmup = int(np.searchsorted(t, t[0] + warmup_s - 1e-9 * max(warmup_s, 1.0), side="left")) if warmup_s else 0
    if len(t) - warmup < MIN_LOSS_SAMPLES:
        raise UserError(
            f"{name}: a warm-up of {warmup_s:g} s leaves {max(len(t) - warmup, 0)} of its {len(t)} samples "
            f"({t[-1] - t[0]:.4g} s) for the loss; it needs at least {MIN_LOSS_SAMPLES}"
        )
    base = Start(initial_state, warmup_s, warmup=warmup)
    if initial_state == "rest":
        return dataclasses.replace(base, reason="initial state 'rest' asked")
    if initial_state == "auto" and starts_from_rest(t, x, v, f):
        moving = np.median(np.abs(v[:3])) > REST_VELOCITY * float(np.max(np.abs(v)))
        if not moving:
            why = "the record starts from rest"
        elif growing(x):
            why = "the record is a loading protocol of growing amplitude, which starts its specimen from rest"
        else:
            why = (
                "the record starts moving, but not in a steady state: its force there is not the one a cycle "
                "later (a specimen set moving from rest)"
            )
        return dataclasses.replace(base, reason=why)
    k = preroll_end(x, v)
    if k == 0:
        why = "its first velocity sample is 0" if v[0] == 0.0 else "it has no full cycle of motion to pre-roll"
        return dataclasses.replace(base, reason=f"the record starts moving but {why}")
    why = "the record starts in motion" if initial_state == "auto" else "initial state 'pre-roll' asked"
    return dataclasses.replace(base, resolved="pre-roll", preroll=k, preroll_s=float(t[k] - t[0]), reason=why)


def cut(record, part: slice):
    """The dataclass or namespace ``record`` (an excitation or a specimen) with every array field as long as
    the record cut to ``part``."""
    n = len(record.t)
    if dataclasses.is_dataclass(record) and not isinstance(record, type):
        fields = {
            f.name: getattr(record, f.name)[part]
            for f in dataclasses.fields(record)
            if isinstance(getattr(record, f.name), np.ndarray) and len(getattr(record, f.name)) == n
        }
        return dataclasses.replace(record, **fields)
    return SimpleNamespace(**{k: np.asarray(getattr(record, k))[part] for k in "txva"})
