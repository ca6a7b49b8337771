"""``bwbench report``: the study report that says which optimiser to use, and why.

One engine for every problem: it writes ``report.md`` and one self-contained ``report.html``, plus
every figure and the CSV behind it, into the output folder. The sections every problem has (what
was compared, the ranking with its statistics and recommendation, convergence, runtime ECDF and
waterfall figures, limits) are ``bwbench.report.sections``; the problem's own (data, parameter
tables, identifiability, its figures) come from its ``ProblemType`` hooks.
"""

from __future__ import annotations

import sys
import typing
from dataclasses import dataclass, field
from pathlib import Path

from bwbench.analysis import statistics
from bwbench.data.output_paths import check_folder, refuse_inputs_in_folder, refuse_link_out, write_frame, write_text
from bwbench.database import reader as results_db
from bwbench.errors import UserError
from bwbench.render.document import Document
from bwbench.report import sections
from bwbench.report.decision import StudyDecision, decide_study

# What the report writes into its folder: a data file of one of these kinds there could be overwritten.
REPORT_SUFFIXES = (".csv", ".png", ".md", ".html")


@dataclass
class Report:
    """What the sections share: the study, the document being written, and the ranking statistics."""

    study: results_db.Study
    doc: Document
    out: Path
    log: typing.TextIO
    decision: StudyDecision  # the study's answer (``decide_study``), the one the API and the terminal give
    featured: list  # specimens shown in per-specimen figures: posterior ones first
    options: dict = field(default_factory=dict)  # e.g. profile_params, profile_grid

    @property
    def problem_type(self):
        return self.study.problem_type

    @property
    def table(self):
        """The ranking table in the decision rule's order."""
        return self.decision.table

    @property
    def tests(self) -> statistics.Comparison:
        return self.decision.tests

    @property
    def recommendation(self) -> dict:
        """verdict, best, choice, order, text (``StudyDecision.as_dict``)."""
        return self.decision.as_dict

    @property
    def omnibus(self):
        return self.tests.omnibus

    @property
    def verdict(self):
        return self.decision.verdict

    @property
    def best_backend(self) -> str:
        """The recommended label (the reference when the rule recommends nothing)."""
        return self.decision.best

    @property
    def noun(self) -> str | None:
        """What the study's variants are ("formulation", …), None when it compares none."""
        return self.decision.noun

    def progress(self, what: str) -> None:
        print(f"{what} ...", file=self.log, flush=True)

    def counter(self, what: str, unit: str = "step") -> Counter:
        """A ``(done, total)`` callback that shows long work (see ``Counter``)."""
        return Counter(what, unit, self.log)


class Counter:
    """Progress of a counted piece of work, called as ``(done, total)``: a tqdm bar on a terminal,
    otherwise a line at about every quarter (logs, CI)."""

    def __init__(self, what: str, unit: str, log):
        self.what, self.unit, self.log = what, unit, log
        self.interactive = hasattr(log, "isatty") and log.isatty()
        self.bar: typing.Any = None  # a tqdm bar while the work runs
        self.next = 0.25

    def __call__(self, done: int, total: int) -> None:
        from tqdm import tqdm

        if self.bar is None:
            self.bar = tqdm(
                total=total,
                desc=self.what,
                unit=self.unit,
                file=self.log,
                disable=not self.interactive,
                dynamic_ncols=True,
                leave=False,
            )
        self.bar.update(done - self.bar.n)
        if not self.interactive and (done / total >= self.next or done == total):
            print(f"{self.what}: {done} of {total} {self.unit}s", file=self.log, flush=True)
            while self.next <= done / total:
                self.next += 0.25
        if done >= total:
            self.bar.close()
            self.bar, self.next = None, 0.25


def featured_specimens(study, k: int = 3) -> list[str]:
    """Up to ``k`` specimens for the per-specimen figures: posterior ones first, and those where some
    ranking run found a finite loss before those where the model blew up at every point evaluated."""
    posterior = [c.specimen for c in study.chains if c.kind == "posterior"]
    runs = study.ranking
    fitted = set(runs.loc[(runs["status"] == "ok") & (runs["mse"].astype(float) < float("inf")), "specimen"])
    ordered = list(dict.fromkeys(posterior + study.specimens))
    return sorted(ordered, key=lambda s: s not in fitted)[:k]


def build_report(
    db,
    out,
    *,
    data_dir=None,
    identifiability_specimens: int = 3,
    profile_params: int = 2,
    profile_grid: int = 7,
    log=None,
    announce=None,
) -> Path:
    """Write report.md, report.html, the figures and their CSVs into ``out``; return report.html's path.

    ``profile_params``: profile likelihoods of that many parameters (the widest free ranges) on the
    first featured specimen (0: none; they cost about a second per grid point).
    A study with fewer runs than it plans (stopped part-way, or still running) is reported as
    provisional ("provisional: 16 of 36 runs") in the title, the first paragraph and the recommendation.
    ``log``: where progress goes (default stderr); ``announce``: where the recommendation is printed
    in one line once the report is written (None: nowhere).
    Raises ``UserError`` for a missing or non-study database, or one without finished ranking runs.
    """
    log = sys.stderr if log is None else log
    study = results_db.load_study(db, data_dir)
    if study.ranking.empty:
        raise UserError(f"{db}: the study has no ranking runs yet: nothing to report")
    finished = study.ranking[(study.ranking["status"] == "ok") & study.ranking["mse"].map(float).lt(float("inf"))]
    if finished.empty:
        raise UserError(f"{db}: no ranking run finished (every one raised or found nothing finite): nothing to report")
    refuse_changed_data(study)
    out = Path(out)
    refuse_inputs_in_folder("--out", out, [db, *report_inputs(study)], REPORT_SUFFIXES)
    check_folder("--out", out)
    for name in ("report.md", "report.html", "ranking.csv", "comparisons.csv"):
        refuse_link_out(out / name, "--out")  # before any work: a link out of the folder is not written through
    out.mkdir(parents=True, exist_ok=True)
    problem_type = study.problem_type
    print("ranking: statistics and the recommendation ...", file=log, flush=True)
    decision = decide_study(study)
    provisional = study.provisional  # "provisional: 16 of 36 runs" for an unfinished study
    report = Report(
        study,
        Document(out),
        out,
        log,
        decision,
        featured_specimens(study, identifiability_specimens),
        {"profile_params": profile_params, "profile_grid": profile_grid},
    )
    doc = report.doc

    title = f"{study.name} ({provisional})" if provisional else study.name
    doc.h(1, f"Optimiser comparison: {title}")
    if provisional:
        doc.banner(
            f"{provisional[0].upper()}{provisional[1:]}: the study is unfinished (still running, or stopped "
            "part-way); its recommendation may change when it completes."
        )
    synthetic = problem_type.is_synthetic(study)
    if synthetic:
        doc.banner(f"{synthetic if isinstance(synthetic, str) else 'SYNTHETIC DATA'} — not measured.")
    sections.recommendation(report)
    sections.setup(report)
    problem_type.report_intro(report)
    sections.ranking(report)
    write_frame(decision.ranking(), out / "ranking.csv", index=False)
    write_frame(sections.comparisons_frame(report), out / "comparisons.csv", index=False)
    report.progress("figures: convergence, runtime distributions, waterfall")
    sections.run_figures(report)
    problem_type.report_sections(report)
    sections.limits(report)

    write_text(out / "report.md", doc.markdown())
    html_path = out / "report.html"
    write_text(html_path, doc.html(f"bwbench report: {title}"))
    if announce is not None:
        print(decision.line(), file=announce)
    return html_path


def refuse_changed_data(study) -> None:
    """``UserError`` naming the first specimen file whose bytes are not those the study ran on (its
    SHA-256 is stored with the configuration): the report would draw edited data against old fits."""
    from bwbench.data.identity import files_sha256

    stored = {**study.config.get("specimens", {}), **(study.config.get("validation") or {})}
    for name in [*study.specimens, *(study.config.get("validation") or {})]:  # the held-out tests too
        digest, path = stored.get(name), study.specimen_path(name)
        if isinstance(digest, str) and path.is_file() and files_sha256([path], [""]) != digest:
            raise UserError(
                f"{path}: changed since the study ran (SHA-256 differs): the report would draw these "
                "data against fits made on others; restore the file, or point --data to the original"
            )


def report_inputs(study) -> list[Path]:
    """The data files the report of ``study`` reads: each specimen's file and the manifest beside it,
    or every file of the data folder of a problem whose data are a folder (the benchmark's)."""
    from bwbench.data.manifest import MANIFEST

    files = [study.specimen_path(s) for s in study.specimens]
    if files and all(f.is_file() for f in files):
        return [*files, *dict.fromkeys(f.parent / MANIFEST for f in files)]
    folder = Path(study.data_dir)
    return [p for p in folder.iterdir() if p.is_file()] if folder.is_dir() else []
