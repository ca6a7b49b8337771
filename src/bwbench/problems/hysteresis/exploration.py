"""A cheaper copy of a fit's problem for its exploring local searches (``lsq-trf`` with the fit's early
stop): the same box and linear solve, the model simulated at a looser integration tolerance
(``model.exploring()``, e.g. ``Spencer.exploring``) and, for a single record sampled far more finely
than its motion needs, every k-th sample only (``decimation``). The searches find and agree on the
optimum there; the best end is then polished on the problem itself, so the reported fit is the model's
own numbers on every sample."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

# Samples per cycle of the motion the exploring searches keep at least. The yield of an MR damper takes
# ~1 % of a cycle (x_y ≈ 0.03 mm at ±25 mm); records sampled at 200 Hz–1 kHz carry 100–5,000 samples per
# cycle of 0.2–4 Hz tests. At 200 kept, a 200 Hz rig test at 0.5 Hz (400 per cycle, so every 2nd sample)
# was polished to a local optimum 0.3 % above the one found on every sample, on three seeds of three; at
# 500 kept, 26 fits (13 tests, 2 seeds) end within ±0.07 % of the MSE of searching on every sample.
MIN_SAMPLES_PER_CYCLE = 500


def exploration(problem, decimate: bool = True):
    """A copy of ``problem`` (one file or joint) whose model is ``problem.model.exploring(k)`` and, for one
    oversampled record (``decimate``), every ``decimation(problem)``-th sample only; None when the model
    has no cheaper simulation."""
    if not problem.model.has_exploring:
        return None
    exploring = problem.model.exploring
    cheaper = copy.copy(problem)
    if hasattr(problem, "parts"):
        cheaper.model = exploring()
        cheaper = _joint_exploration(problem, cheaper, decimate)
    else:
        k = decimation(problem) if decimate else 1
        cheaper.model = exploring(k)  # its step budget is per interval of the record's sampling
        if k > 1:
            _keep_every(cheaper, k)
    cheaper.exploration_note = exploration_note(cheaper)  # what the searches' message says it changed
    return cheaper


def _joint_exploration(problem, cheaper, decimate: bool):
    """The exploring copy of a joint problem: its files' exploring copies, restacked when some of them keep
    every k-th sample only (an identifiable joint fit weighting its files equally, so that the files
    weigh the same in both), on the joint problem's own box."""
    parts = [exploration(part, decimate) for part in problem.parts]
    design = getattr(problem, "design", None)
    if design is None or problem.weighting != "equal" or all(getattr(p, "decimated", 1) == 1 for p in parts):
        cheaper.parts = [exploration(part, decimate=False) for part in problem.parts]
        return cheaper
    restacked = type(problem)(  # a JointProblem (not imported: it imports this module)
        parts, problem.weighting, fix_mass=design.fix_mass, offsets=design.offsets, coefficient_bounds=design.bounds
    )
    restacked.lower, restacked.upper, restacked.workers = problem.lower, problem.upper, problem.workers
    restacked.model = problem.model.exploring(max(getattr(p, "decimated", 1) for p in parts))  # for every file
    return restacked


def exploration_note(problem) -> str:
    """What the exploring copy changes, in words ("" when there is none)."""
    note = problem.model.exploration_note
    k = getattr(problem, "decimated", 1)
    ks = [getattr(part, "decimated", 1) for part in getattr(problem, "parts", ())]
    if any(k > 1 for k in ks):
        return f"{note}, every k-th sample of each file (k = {', '.join(map(str, ks))})"
    return f"{note}, every k-th sample (k = {k})" if k > 1 else note


def samples_per_cycle(v) -> float:
    """Samples per cycle of the motion: the record's length over half its reversals (sign changes of the
    velocity where it is more than 5 % of its peak, so that noise about a reversal counts once)."""
    v = np.asarray(v, dtype=float)
    moving = np.sign(v[np.abs(v) > 0.05 * np.max(np.abs(v))])
    reversals = int(np.count_nonzero(moving[1:] != moving[:-1]))
    return len(v) / max(reversals / 2.0, 1.0)


def decimation(problem) -> int:
    """Keep every k-th sample in the exploring searches: k so that ``MIN_SAMPLES_PER_CYCLE`` remain; 1
    for a problem without a linear solve. The shorter record starts as the record does (the start's
    resolved rule: ``_keep_every``)."""
    if getattr(problem, "design", None) is None:
        return 1
    return max(int(samples_per_cycle(problem.signal.v) // MIN_SAMPLES_PER_CYCLE), 1)


def _every(record, k: int):
    """The dataclass ``record`` (an excitation or a specimen) with every array field cut to every k-th sample."""
    cut = {
        f.name: getattr(record, f.name)[::k]
        for f in dataclasses.fields(record)
        if isinstance(getattr(record, f.name), np.ndarray)
    }
    return dataclasses.replace(record, **cut)


def _keep_every(cheaper, k: int) -> None:
    """Every k-th sample of the record, started by the rule the record's own start resolved to (from
    rest, or a pre-roll of the shorter record's own cycle), its warm-up as long in seconds."""
    start = cheaper.start
    cheaper.signal = _every(cheaper.signal, k)
    cheaper.specimen = _every(cheaper.specimen, k)
    cheaper.set_start(start.resolved, start.warmup_s)
    cheaper.design = dataclasses.replace(cheaper.design, signal=cheaper.loss_signal, f=cheaper.f_loss, notes=[])
    cheaper.decimated = k
