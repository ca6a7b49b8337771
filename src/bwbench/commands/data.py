"""``bwbench data check`` and ``bwbench data generate``."""

from __future__ import annotations

import argparse
import sys

from bwbench.errors import UserError


def check(args) -> int:
    """Exit 0 if every file is a valid specimen CSV, else 2 with one error line per bad file; valid
    files that are probably not what their header promises get warnings (exit status still 0)."""
    from bwbench.data import control, manifest, plausibility
    from bwbench.data.specimen import read_specimen
    from bwbench.models.protocol import protocol

    status = 0
    named = control.parse_all(getattr(args, "control", None))  # a bad --control: one line before any file
    for path in args.files:
        try:
            spec = read_specimen(path) if named is None else control.read(path, named)
        except UserError as err:
            print(f"error: {err}", file=sys.stderr)
            status = 2
        else:
            rate = (spec.n_samples - 1) / spec.duration_s
            sampling = (
                f"{spec.n_samples} points, quasi-static (no time_s column: read as a sequence along the "
                "displacement path)"
                if spec.quasi_static
                else f"{spec.n_samples} samples at {rate:.4g} Hz, {spec.duration_s:.4g} s"
            )
            print(
                f"ok: {path}: {sampling}, displacement "
                f"{spec.x.min():.4g} … {spec.x.max():.4g} mm, force {spec.f.min():.4g} … {spec.f.max():.4g} N"
            )
            if spec.reading_notes:
                print(f"  read: {'; '.join(spec.reading_notes)}")
            print(f"  protocol: {protocol(spec.x).describe()}")
            print(f"  {signals_text(spec)}")
            if named is not None:
                print(f"  {control.summary(spec).text()}")  # type: ignore[union-attr]
            ramps = ramps_text(spec)
            if ramps:
                print(f"  {ramps}")
            texts = plausibility.all_warnings(spec, synthetic=manifest.is_synthetic(path))
            for text in texts:
                print(
                    text if text.startswith("note:") else f"warning: {path}: {text}",
                    file=sys.stdout if text.startswith("note:") else sys.stderr,
                )
    return status


# A viscous coefficient to express a velocity error as a force: round, and of the order of the paper's
# identified 2·ξ·ωn (Tables 6–8: 20–18,000 N·s/mm).
REFERENCE_VISCOUS = 1000.0  # N·s/mm


def ramps_text(spec) -> str:
    """The ramp-in/out cycles of a constant-amplitude test and its steady part; "" when it has none."""
    from bwbench.data.steady_part import steady_part

    steady = steady_part(spec.t, spec.x)
    if not steady.ramped:
        return ""
    return (
        f"ramps: {steady.describe()}; steady part t = {spec.t[steady.start]:.4g} … {spec.t[steady.stop - 1]:.4g} s "
        "(the inertia rule judges the excitation there; fit figures draw the ramp cycles lighter)"
    )


def signals_text(spec) -> str:
    """Which signals drive the model measured and which estimated, and for an estimated velocity its
    expected error (mm/s rms) and the force error that makes per ``REFERENCE_VISCOUS`` of ∂F/∂ẋ."""
    from bwbench.models import derivatives

    if spec.quasi_static:
        from bwbench.models.protocol import dead_band

        return (
            "signals: the displacement path and its direction of motion (a reversal counts once the motion "
            f"goes back by more than {dead_band(spec.x):.3g} mm, against digitising jitter); no velocity or "
            "acceleration: the models' viscous and inertia terms are off"
        )
    if spec.v is not None:
        return "signals: displacement and velocity measured (velocity_mm_s), acceleration " + (
            "measured (acceleration_mm_s2)" if spec.a is not None else "estimated from the velocity"
        )
    estimate = derivatives.estimate(spec.t, spec.x)
    error = derivatives.velocity_error(spec.t, spec.x, estimate)
    estimated = (
        "velocity estimated from it, acceleration measured (acceleration_mm_s2)"
        if spec.a is not None
        else "velocity and acceleration estimated from it"
    )
    return (
        f"signals: displacement measured, {estimated} ({derivatives.SPLINE_NAME}; displacement noise "
        f"{estimate.noise * 1e3:.3g} µm): expected velocity error {error:.2g} mm/s rms, a force error of "
        f"{error * REFERENCE_VISCOUS:.2g} N rms per {REFERENCE_VISCOUS:g} N·s/mm of viscous coefficient ∂F/∂ẋ; "
        "a recorded velocity column (velocity_mm_s) removes it"
    )


def generate(args) -> int:
    from bwbench.data import manifest
    from bwbench.data.output_paths import check_folder, refuse_inputs_in_folder, writing
    from bwbench.datasets import mr_dataset, synthetic

    out = args.out or default_generate_folder(args.mr_damper)
    refuse_inputs_in_folder("--out", out, [synthetic.PAPER_PARAMETERS], (".csv", ".json"))
    check_folder("--out", out)
    from bwbench.datasets import shipped

    # the default folder of a checkout is the dataset's own: regenerated in place; any other is a user's
    if (args.out or shipped.CHECKOUT is None) and not args.force:
        from pathlib import Path

        names = mr_dataset.file_names() if args.mr_damper else synthetic.file_names()
        there = [name for name in names if (Path(out) / name).exists()]
        if there:
            shown = (
                ", ".join(there[:3]) + f" and {len(there) - 3} more"
                if len(there) > 3
                else " and ".join([", ".join(there[:-1]), there[-1]])
                if len(there) > 1
                else there[0]
            )
            raise UserError(
                f"--out {out} holds {shown}, which this command would replace: choose an empty folder, "
                "or add --force to replace them"
            )
    with writing(out):
        written = mr_dataset.generate(out) if args.mr_damper else synthetic.generate(out)
    print(f"wrote {len(written) - 1} specimens and {manifest.MANIFEST} to {out}")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="data_command", required=True, metavar="SUBCOMMAND")
    text = argparse.RawDescriptionHelpFormatter
    p = sub.add_parser(
        "check",
        help="validate specimen CSV files",
        formatter_class=text,
        description="Validate specimen CSV files: exit 0 if every file is valid, else 2 with one\n"
        "line per bad file; say which signals are measured and which estimated.",
        epilog="example:\n  bwbench data check mytest.csv data/mr_damper/*.csv",
    )
    p.add_argument("files", nargs="+", help="specimen CSV files")
    p.add_argument(
        "--control",
        action="append",
        metavar="COLUMN[=VALUE]",
        help="the control column to read and report (current_A, voltage_V, underpressure_MPa: <quantity>_<unit>); "
        "=VALUE: the level of files without the column",
    )
    from bwbench.commands import reading_options

    reading_options.add(p)
    p.set_defaults(func=check)
    p = sub.add_parser(
        "generate",
        help="rebuild a synthetic dataset, byte-identical",
        formatter_class=text,
        description="Rebuild a shipped synthetic dataset, byte for byte, from its generator.",
        epilog="example:\n  bwbench data generate --out /tmp/specimens\n"
        "  bwbench data generate --mr-damper --out /tmp/mr_damper",
    )
    p.add_argument(
        "--mr-damper",
        action="store_true",
        help="the MR-damper dataset (Spencer et al. 1997's model, data/mr_damper) instead of the "
        "paper's VPP specimens (data/specimens)",
    )
    p.add_argument("--out", help="output folder (default: the dataset's folder in the repository)")
    p.add_argument("--force", action="store_true", help="replace files of the same names in --out")
    p.set_defaults(func=generate)


def default_generate_folder(mr_damper: bool):
    """Where ``data generate`` writes without ``--out``: the shipped dataset's own folder in a source
    checkout (regenerated in place), else ``specimens/`` or ``mr_damper/`` in the current folder (an
    installed bwbench's data are not to be rewritten)."""
    from pathlib import Path

    from bwbench.datasets import mr_dataset, shipped, synthetic

    if shipped.CHECKOUT is not None:
        return mr_dataset.DATASET_DIR if mr_damper else synthetic.SPECIMEN_DIR
    return Path("mr_damper" if mr_damper else "specimens")
