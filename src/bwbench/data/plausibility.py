"""Warnings for a valid specimen file that is probably not what its header promises.

Sign convention (bwbench's, and the paper's eqs 2–5): displacement x in mm, positive in elongation;
force F in N, positive in tension (the specimen is pulled); ẋ ≥ 0 selects the '+' (tension)
parameter set, ẋ < 0 the '−' (compression) set. A passive specimen dissipates energy, so its loop
runs counter-clockwise in the (x, F) plane: ∮F·dx > 0.

The paper's Table 5 forces ξ₊ > 0 and ξ₋ < 0, so its viscous term 2ξωn·ẋ is positive whichever
way the specimen moves; with the identified Tables 6–8, where |ξ₋|ωn₋ ≫ ξ₊ωn₊, the paper's fits
(and the synthetic specimens generated from them) run clockwise: ∮F·dx < 0. Under the convention
above that loop generates energy, so the paper's data were most likely recorded with the opposite
force sign. Fitting a user's counter-clockwise test with the paper's box therefore cannot work;
the identifiable formulation solves c₊, c₋ with either sign.
"""

from __future__ import annotations

import numpy as np

# Displacement amplitudes (mm) outside this range are more likely metres or micrometres.
AMPLITUDE_RANGE_MM = (0.01, 1000.0)
# A loading cycle longer than this (s), or samples further apart than this (s), more likely means a time
# column in milliseconds: the synthetic quasi-static specimens take 480 s a cycle at 1 Hz, an MR-damper test
# recorded in ms at 1 kHz reads as 1 Hz with cycles of 1,000 s and more.
SLOWEST_CYCLE_S = 1000.0
SPARSEST_STEP_S = 10.0
# Force varying by less than this fraction of its magnitude is flat: nothing to fit.
FLAT_FORCE_FRACTION = 1e-6
# Below this force (N) in every row a record is effectively zero (1e-310 N would give a loss of 0).
TINY_FORCE_N = 1e-9
# Beyond this force (N) a record is a unit or export error, not a test: bwbench refuses to fit it.
MAX_PLAUSIBLE_FORCE_N = 1e9
# |∮F dx| below this fraction of (2·amplitude × force range × cycles) is too small a loop to call its sign.
LOOP_SIGN_FRACTION = 0.01


def loop_work(x, f) -> tuple[float, float]:
    """(∮F·dx per cycle in N·mm, number of cycles) over the whole record (trapezoid rule)."""
    x, f = np.asarray(x, dtype=float), np.asarray(f, dtype=float)
    work = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))
    amplitude = 0.5 * float(x.max() - x.min())
    cycles = float(np.sum(np.abs(np.diff(x)))) / (4.0 * amplitude) if amplitude > 0 else 0.0
    return (work / cycles if cycles > 0 else 0.0), cycles


def thousands_separator(f) -> str | None:
    """A sentence when a column reads like numbers written with a point as thousands separator (German,
    "1.141" for 1141 N) and read as decimals: every value with a fraction has at most three decimals,
    none reaches 1000, and where a whole number meets one with a fraction the record jumps more than
    twice as far read as decimals than read as thousands. None otherwise."""
    f = np.asarray(f, dtype=float)
    fraction = f != np.round(f)
    if not fraction.any() or fraction.all() or float(np.abs(f).max()) >= 1000.0:
        return None
    scaled = f[fraction] * 1000.0
    if float(np.abs(scaled - np.round(scaled)).max()) > 1e-6:
        return None
    as_thousands = np.where(fraction, f * 1000.0, f)
    crossing = fraction[1:] != fraction[:-1]  # a whole number next to one with a fraction
    jump_as_read = float(np.median(np.abs(np.diff(f))[crossing]))
    if jump_as_read <= 2.0 * float(np.median(np.abs(np.diff(as_thousands))[crossing])):
        return None
    k = int(np.argmax(fraction))
    return (
        f"force_N reads like numbers with a thousands separator: {f[k]:.3f} among whole numbers below 1000 "
        f"(read as {as_thousands[k]:.0f} N it joins its neighbours, read as {f[k]:.3f} N it jumps); remove "
        "the separators (bwbench reads a point as the decimal point)"
    )


def time_unit_warnings(spec) -> list[str]:
    """A sentence when the time column looks like milliseconds (see ``SLOWEST_CYCLE_S``)."""
    if getattr(spec, "quasi_static", False):
        return []  # no time column
    step = spec.duration_s / (spec.n_samples - 1)
    _, cycles = loop_work(spec.x, spec.f)
    period = spec.duration_s / cycles if cycles >= 0.5 else None
    if step <= SPARSEST_STEP_S and (period is None or period <= SLOWEST_CYCLE_S):
        return []
    what = (
        f"samples are {step:.4g} s apart ({1 / step:.3g} Hz)"
        if step > SPARSEST_STEP_S
        else f"one loading cycle takes {period:.4g} s ({cycles:.3g} cycles in {spec.duration_s / 3600:.3g} h)"
    )
    return [f"{what}: is time_s in milliseconds? the header promises seconds (divide by 1000 if so)"]


# A peak force below this (N) is small for a test machine's load cell: more likely kN or kips (an
# inch–kip friction damper's ±5 kips read as ±5 N), unless the file declares its unit (force_kip, --units).
SMALL_FORCE_N = 20.0
# With such a force, an amplitude below this (mm) is more likely inches.
SMALL_AMPLITUDE_MM = 5.0


def unit_warnings(spec) -> list[str]:
    """A sentence naming the likely units when a file that declares none has magnitudes of another
    (``SMALL_FORCE_N``: kips or kN; with ``SMALL_AMPLITUDE_MM`` also inches); [] otherwise."""
    if getattr(spec, "reading_notes", ()):
        return []  # units were declared (a column name or --units): the user has said what they are
    peak = float(np.abs(spec.f).max())
    if not 0 < peak < SMALL_FORCE_N:
        return []
    amplitude = 0.5 * float(spec.x.max() - spec.x.min())
    if amplitude < SMALL_AMPLITUDE_MM:
        return [
            f"force_N peaks at {peak:.3g} N and the displacement amplitude is {amplitude:.3g} mm: small for a test "
            f"machine — an inch–kip file? (then {peak:.3g} kips = {peak * 4.4482216:.3g} kN and {amplitude:.3g} in = "
            f"{amplitude * 25.4:.3g} mm: name the columns displacement_in and force_kip, or add --units "
            "displacement=in,force=kip)"
        ]
    return [
        f"force_N peaks at {peak:.3g} N: small for a test machine — is it in kN or kips? (name the column "
        "force_kN or force_kip, or add --units force=kN)"
    ]


def force_warnings(spec) -> list[str]:
    """A sentence when the force is zero, constant, flat or effectively zero (below ``TINY_FORCE_N``), or
    written with thousands separators: no hysteresis loop to fit, or not the loop the file means."""
    f = spec.f
    span, size = float(f.max() - f.min()), float(np.abs(f).max())
    if size == 0.0:
        return ["force_N is 0 in every row: no force was recorded (load cell off, or an empty column?)"]
    if size < TINY_FORCE_N:
        return [
            f"force_N is at most {size:.3g} N in every row: effectively 0 (every loss would read 0); "
            "no test records that (a unit or export error?)"
        ]
    separator = thousands_separator(f)
    if separator:
        return [separator]
    if span <= FLAT_FORCE_FRACTION * size:
        return [
            f"force_N is flat ({float(f.mean()):.6g} N, varying by {span:.3g} N): no loop to fit "
            "(load cell off, or the wrong column?)"
        ]
    return []


def warnings(spec, synthetic: bool = False) -> list[str]:
    """Plain sentences about ``spec`` (a ``Specimen``) that deserve a look; [] when nothing does."""
    out = [*time_unit_warnings(spec), *force_warnings(spec), *unit_warnings(spec), *dead_channels(spec)]
    peak = float(np.abs(spec.f).max())
    if peak > MAX_PLAUSIBLE_FORCE_N:
        out.append(
            f"force_N reaches {peak:.3g} N, above {MAX_PLAUSIBLE_FORCE_N:.0e} N: no test machine records "
            "that (a unit or export error?)"
        )
    amplitude = 0.5 * float(spec.x.max() - spec.x.min())
    low, high = AMPLITUDE_RANGE_MM
    if amplitude < low:
        out.append(
            f"displacement amplitude {amplitude:.3g} mm is below {low:g} mm: is the displacement in metres? "
            "the header promises mm"
        )
    elif amplitude > high:
        out.append(
            f"displacement amplitude {amplitude:.3g} mm is above {high:g} mm: is the displacement in µm? "
            "the header promises mm"
        )
    per_cycle, cycles = loop_work(spec.x, spec.f)
    scale = 2.0 * amplitude * float(spec.f.max() - spec.f.min())
    if cycles >= 0.5 and scale > 0 and per_cycle < -LOOP_SIGN_FRACTION * scale:
        if synthetic:
            out.append(
                f"note: the loop runs clockwise (∮F·dx = {per_cycle:.3g} N·mm per cycle), as the paper's "
                "identified parameters make it (a synthetic specimen)"
            )
        else:
            out.append(
                f"the loop runs clockwise (∮F·dx = {per_cycle:.3g} N·mm per cycle): a passive specimen "
                "dissipates energy (∮F·dx > 0 with force positive in tension and displacement positive in "
                "elongation), so force or displacement is probably flipped"
            )
    return out


# A recorded velocity whose integral follows the displacement with a gain outside this range, or that
# leaves more than SIGNAL_MISFIT of the displacement range unexplained, is probably another unit, sign
# or channel. Commanded and measured motion of a servo machine agree far better than 10 %.
SIGNAL_GAIN_RANGE = (0.9, 1.1)
SIGNAL_MISFIT = 0.05
# recorded / implied -> the unit it was in
_UNIT_SLIPS = {
    60.0: "mm/min",
    1000.0: "µm/s",
    1e-3: "m/s",
    1 / 25.4: "in/s (velocity_in_s)",
    25.4: "mm/s while the displacement is in inches (displacement_in)",
}


def _integral(t, y):
    """Cumulative trapezoid integral of y over t, starting at 0."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])


def _fit_displacement(columns, x):
    """Least-squares fit of x on ``columns`` (a list of arrays); (coefficients, residual RMS)."""
    design = np.column_stack(columns)
    coef, *_ = np.linalg.lstsq(design, x, rcond=None)
    return coef, float(np.sqrt(np.mean((x - design @ coef) ** 2)))


def signal_warnings(spec) -> list[str]:
    """Sentences about recorded velocity (mm/s) and acceleration (mm/s²) columns that do not match the
    displacement: the displacement is fitted by x₀ + g·∫v dt (and x₀ + v₀·t + g·∬a dt²); a gain g far
    from 1 is a wrong sign or unit, a large residual another channel or a time shift. [] when fine."""
    out = []
    t, x = spec.t, spec.x
    span = float(x.max() - x.min())
    one = np.ones_like(t)
    checks = []
    if spec.v is not None:
        checks.append(("velocity_mm_s", "velocity", [one, _integral(t, spec.v)]))
    if spec.a is not None:
        checks.append(("acceleration_mm_s2", "acceleration", [one, t - t[0], _integral(t, _integral(t, spec.a))]))
    for column, what, columns in checks:
        coef, misfit = _fit_displacement(columns, x)
        gain = float(coef[-1])
        if misfit > SIGNAL_MISFIT * span:  # the shape is wrong: no gain can fix it
            out.append(
                f"column {column} does not follow the displacement: its integral leaves {misfit:.3g} mm rms "
                f"({misfit / span:.0%} of the displacement range) unexplained (another channel, or shifted in "
                f"time?); bwbench drives the model with the recorded {what}"
            )
        elif not SIGNAL_GAIN_RANGE[0] <= gain <= SIGNAL_GAIN_RANGE[1]:
            factor = 1.0 / gain if gain != 0 else np.inf
            hint = "the opposite sign convention" if factor < 0 else ""
            for slip, unit in _UNIT_SLIPS.items():
                if abs(abs(factor) / slip - 1) < 0.1:
                    slipped = f"{unit} instead of the header's unit"
                    if slip == 1000.0:  # the time column first: in ms it makes every rate look 1000× too small
                        rate = (spec.n_samples - 1) / spec.duration_s
                        slipped = (
                            f"time_s in milliseconds (the test would then last {spec.duration_s / 1000:.4g} s, "
                            f"sampled at {rate * 1000:.4g} Hz), or the {what} in {unit}"
                        )
                    hint = (hint + " and " if hint else "") + slipped
            out.append(
                f"column {column} does not match the displacement: the {what} recorded is "
                f"{factor:.3g} × the one the displacement implies"
                + (f" ({hint}?)" if hint else "")
                + f"; bwbench drives the model with the recorded {what}"
            )
    return out


def dead_channels(spec) -> list[str]:
    """A sentence per recorded velocity or acceleration column that is constant (0, or one value in every
    row) while the displacement moves: a channel that recorded nothing."""
    out = []
    for column, values, what in (("velocity_mm_s", spec.v, "velocity"), ("acceleration_mm_s2", spec.a, "acceleration")):
        if values is None or float(values.max() - values.min()) > 0.0:
            continue
        out.append(
            f"column {column} is {float(values[0]):.6g} in every row while the displacement moves: a dead "
            f"channel (remove the column and bwbench estimates the {what} from the displacement)"
        )
    return out


def all_warnings(spec, synthetic: bool = False) -> list[str]:
    """What ``bwbench data check`` says about a valid file: ``warnings`` and ``signal_warnings``. A time
    column that looks like milliseconds is said first and alone of the signal checks: it also makes
    every recorded velocity look 1000× too large, and that is not the velocity's fault."""
    out = warnings(spec, synthetic)
    if not time_unit_warnings(spec) and not dead_channels(spec):
        out += signal_warnings(spec)
    return out


def unusable(spec, force_needed: bool = True) -> str | None:
    """Why ``spec`` cannot be fitted or analysed at all (a dead signal channel; with ``force_needed``
    also zero or flat force, an absurd force), or None. Its words are those of ``all_warnings``."""
    dead = dead_channels(spec)
    if dead:
        return dead[0]
    if not force_needed:
        return None
    flat = force_warnings(spec)
    if flat:
        return flat[0]
    peak = float(np.abs(spec.f).max())
    if peak > MAX_PLAUSIBLE_FORCE_N:
        return (
            f"force_N reaches {peak:.3g} N, above {MAX_PLAUSIBLE_FORCE_N:.0e} N: no test machine records that "
            "(a unit or export error?)"
        )
    return None


def screen(specimens, synthetic: bool | None = None, force_needed: bool = True, stream=None, warn: bool = True) -> None:
    """The check of ``data check`` before a command's work: ``UserError`` naming the file for the first
    specimen that is ``unusable`` (``force_needed``: a fit or an analysis of the measured force), then each specimen's other warnings printed as
    ``warning: FILE: ...`` lines on ``stream`` (stderr), notes on stdout. Refusals come first, so a
    refused command prints one line only."""

    from bwbench.errors import UserError

    specimens = list(specimens)
    for spec in specimens:
        why = unusable(spec, force_needed)
        if why:
            raise UserError(f"{spec.path}: {why}")
    if warn:
        print_warnings(specimens, synthetic, stream)


def print_warnings(specimens, synthetic: bool | None = None, stream=None) -> None:
    """Each specimen's ``all_warnings`` as ``warning: FILE: ...`` lines on ``stream`` (stderr); a command
    prints them once every refusal is behind it, so a refused command prints one line only.
    ``synthetic``: None asks each file's manifest (a shipped synthetic specimen's clockwise loop is the
    paper's, not a flipped sign)."""
    import sys

    from bwbench.data import manifest

    for spec in specimens:
        made = synthetic if synthetic is not None else bool(spec.path) and manifest.is_synthetic(spec.path)
        for text in all_warnings(spec, made):
            if text.startswith("note:"):
                continue  # a synthetic specimen's notes belong to data check, not to every command
            print(f"warning: {spec.path}: {text}", file=stream or sys.stderr)
