"""One parameter set fitted to several tests at once: a joint fit (``bwbench fit A.csv B.csv ...``).

Every file is simulated from its own start with the same parameters (one rule for all files,
``bwbench.models.start``: each is from rest or pre-rolled as its own record asks, its warm-up left
out), and the loss combines the files' MSEs (N²) over their samples in the loss with weights w_i
(Σ w_i = 1):

    loss = Σ_i w_i · MSE_i

``weighting="equal"`` (the default): w_i = 1/F, each of the F files counts equally whatever its
length, so a long slow test does not drown a short fast one; ``"samples"``: w_i = L_i/N, every
sample counts equally (the files joined end to end). **One evaluation is one simulation of every
file** with one parameter vector: a budget of 4,100 evaluations runs each file 4,100 times.

What is shared: everything. The searched parameters are one vector; in the identifiable
formulation the linear coefficients (mass, damping, stiffness, hysteretic weight, offsets) are
solved once over the stacked files — the rows of file i weighted by √(N·w_i/L_i), so the weighted
least squares minimises the loss above — one model of the damper, which is what a prediction of
another test needs. The search box is the envelope of the files' own data-scaled boxes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

WEIGHTINGS = ("equal", "samples")


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class StackedSignal:
    """The excitations of several records end to end: t (s, each record's own), x (mm), v (mm/s),
    a (mm/s²), ``segments`` (one slice per record), ``sources`` of the first record."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    segments: tuple
    sources: dict = field(default_factory=dict)
    x_recorded: np.ndarray | None = None

    @property
    def velocity_estimated(self) -> bool:
        return self.sources.get("velocity") == "estimated"


def stack_signals(signals) -> StackedSignal:
    """One ``StackedSignal`` of excitations (objects with t, x, v, a, each (L_i,))."""
    lengths = [len(s.x) for s in signals]
    edges = np.concatenate([[0], np.cumsum(lengths)])
    segments = tuple(slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]))
    join = [np.concatenate([np.asarray(getattr(s, k), dtype=float) for s in signals]) for k in "txva"]
    recorded = [getattr(s, "x_recorded", None) for s in signals]
    x_recorded: np.ndarray | None = (
        np.concatenate([np.asarray(r) for r in recorded]) if all(r is not None for r in recorded) else None
    )
    t, x, v, a = join
    return StackedSignal(t, x, v, a, segments, dict(getattr(signals[0], "sources", {})), x_recorded)


def file_weights(lengths, weighting: str = "equal") -> np.ndarray:
    """w_i of the module docstring (sum 1) for files of ``lengths`` samples."""
    lengths = np.asarray(lengths, dtype=float)
    if weighting == "equal":
        return np.full(len(lengths), 1.0 / len(lengths))
    if weighting == "samples":
        return lengths / lengths.sum()
    raise ValueError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")


class PartsProblem:
    """What a problem made of several files' parts says of itself, shared by a joint fit and a fit across
    a control: needs ``parts``, ``param_names``, ``N``, ``design``, ``model``, ``state``, ``excitation``,
    ``formulation`` and ``weighting``."""

    parts: list
    param_names: Any
    N: int
    design: Any
    model: Any
    state: str | None
    excitation: str
    formulation: str
    weighting: str

    @property
    def specimens(self) -> list:
        return [p.specimen for p in self.parts]

    @property
    def name(self) -> str:
        return " + ".join(p.specimen.name for p in self.parts)

    @property
    def dim(self) -> int:
        return len(self.param_names)

    @property
    def n_data(self) -> int:
        return self.N

    @property
    def notes(self) -> list[str]:
        return list(self.design.notes) if self.design is not None else []

    def parts_info(self, **extra) -> dict:
        """The result's description of the problem; ``extra`` after the weighting (a control's)."""
        out = {
            "specimen": self.name,
            "specimens": [p.specimen.name for p in self.parts],
            "model": self.model.name,
            "excitation": self.excitation,
            "formulation": self.formulation,
            "weighting": self.weighting,
            **extra,
        }
        if self.state is not None:
            out["state"] = self.state
        if self.design is not None:
            out["linear_solve"] = "; ".join(self.notes)
        return out


class JointProblem(PartsProblem):
    """The problems of several specimens (``parts``: ``DirectProblem`` or ``IdentifiableProblem`` of
    one model, formulation, state and excitation) as one fit; see the module docstring."""

    def __init__(
        self, parts, weighting: str = "equal", *, fix_mass="auto", offsets=True, coefficient_bounds: dict | None = None
    ):
        if len(parts) < 2:
            raise ValueError("a joint problem needs at least two specimens")
        first = parts[0]
        self.parts = list(parts)
        self.model, self.state, self.excitation = first.model, first.state, first.excitation
        self.formulation, self.parameter_list = first.formulation, first.parameter_list
        self.param_names, self.log_scaled = first.param_names, first.log_scaled
        self.weighting = weighting
        # Threads over the files of one evaluation (``bwbench fit --workers``): each file's simulation is
        # independent and the results are joined in file order, so the numbers do not depend on it.
        self.workers = 1
        self.lengths = np.array([p.n_data for p in parts])
        self.file_weight = file_weights(self.lengths, weighting)
        self.N = int(self.lengths.sum())
        # Sample weights N·w_i/L_i: Σ_l weight_l·r_l²/N = Σ_i w_i·MSE_i.
        self.sample_weight = np.repeat(self.N * self.file_weight / self.lengths, self.lengths)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.lower = np.min([p.lower for p in parts], axis=0)
            self.upper = np.max([p.upper for p in parts], axis=0)
        self.signal = stack_signals([p.loss_signal for p in parts])  # the samples in the loss
        self.f = np.concatenate([p.f_loss for p in parts])
        self.design = None
        if self.formulation == "identifiable":
            from bwbench.problems.hysteresis.linear.solve import LinearDesign
            from bwbench.problems.hysteresis.model_problem import coefficient_bounds_of as default_bounds

            layout = self.model.linear_layout(self.state)
            bounds, notes = default_bounds(self.model, layout, self.signal, self.f, coefficient_bounds)
            self.design = LinearDesign(
                self.signal,
                self.f,
                layout,
                fix_mass=fix_mass,
                offsets=offsets,
                bounds=bounds,
                weights=self.sample_weight,
                notes=notes,
            )
            self.linear_names, self.linear_units = first.linear_names, first.linear_units

    # -- what the objective, the runner and the result need -----------------------------------
    @property
    def info(self) -> dict:
        return self.parts_info()

    def exploration(self):
        """A copy simulating more cheaply for a fit's exploring searches, or None (``exploration``)."""
        from bwbench.problems.hysteresis.exploration import exploration

        return exploration(self)

    def from_unit(self, U) -> np.ndarray:
        from bwbench.engine.box import box_from_unit

        return box_from_unit(U, self.lower, self.upper, self.log_scaled)

    def to_unit(self, P) -> np.ndarray:
        from bwbench.engine.box import box_to_unit

        return box_to_unit(P, self.lower, self.upper, self.log_scaled)

    def units(self, names) -> dict:
        from bwbench.problems.hysteresis.fit_checks import units

        return units(self, names)

    # -- the loss -------------------------------------------------------------------------------
    def solve(self, P, residual: bool = False):
        """The joint linear solve (``LinearSolution`` over the stacked files) of each θ row of P."""
        theta = np.atleast_2d(np.asarray(P, dtype=float))
        Z = np.concatenate(self._each_file(lambda p: p.loss_trajectories(theta)), axis=1)
        assert self.design is not None  # the identifiable formulation's: solve is not called otherwise
        return self.design.solve(Z, residual)

    def loss_batch(self, P) -> np.ndarray:
        """Σ_i w_i·MSE_i (N²) of each row of P (m, d); +inf where the model blows up on any file."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        if self.design is not None:  # the loss alone (``LinearDesign.mse``): the same numbers as solve(P).mse
            Z = np.concatenate(self._each_file(lambda p: p.loss_trajectories(P)), axis=1)
            return self.design.mse(Z)
        losses = sum(w * loss for w, loss in zip(self.file_weight, self._each_file(lambda p: p.loss_batch(P))))
        return np.where(np.isfinite(losses), losses, np.inf)

    def residual_batch(self, P) -> np.ndarray:
        """Weighted residuals (m, N): file i's model − measured force (N) × √(N·w_i/L_i), so that
        their mean square is the loss; rows of +inf where the model blows up."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        if self.design is not None:
            solution = self.solve(P, residual=True)
            R = solution.residual * np.sqrt(self.sample_weight)
            ok = np.isfinite(solution.mse) & np.all(np.isfinite(R), axis=1)
        else:
            R = np.concatenate(self._each_file(lambda p: p.residual_batch(P)), axis=1) * np.sqrt(self.sample_weight)
            ok = np.all(np.isfinite(R), axis=1)
        return np.where(ok[:, None], R, np.inf)

    @property
    def jacobian_cost(self) -> int:
        """Plain evaluations (of every file) one ``residual_jacobian`` is charged; 0: none to be had."""
        return int(self.model.sensitivity_cost) if self.design is not None else 0

    def residual_jacobian(self, params):
        """(weighted residuals (N,), their Jacobian (N, d) in physical units) of one θ vector, exact;
        None where the sensitivities cannot be had on some file (then take differences); (+inf
        residuals, None) where a file's simulation did not finish."""
        if self.design is None:
            return None
        theta = np.asarray(params, dtype=float)
        found = self._each_file(lambda p: p.loss_sensitivities(theta))
        if any(f is not None and f[1] is None for f in found):
            return np.full(self.design.L, np.inf), None  # a file's simulation did not finish: no plain one either
        if any(f is None for f in found):
            return None
        return self.design.residual_jacobian(
            np.concatenate([f[0] for f in found]), np.concatenate([f[1] for f in found], axis=0)
        )

    def _each_file(self, run) -> list:
        """``run(part)`` of every file, in file order; on ``workers`` threads when more than one (the
        kernels release the GIL)."""
        if self.workers <= 1:
            return [run(p) for p in self.parts]
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=min(self.workers, len(self.parts))) as pool:
            return list(pool.map(run, self.parts))

    # -- one parameter vector -------------------------------------------------------------------
    def linear(self, params) -> np.ndarray:
        """The jointly solved coefficients (``linear_names``) of one θ vector."""
        return self.solve(np.asarray(params, dtype=float)[None, :]).coef[0]

    def parameters(self, params) -> dict:
        """The searched parameters, and in the identifiable formulation the joint coefficients and the
        model's direct parameters of the same force where they exist."""
        from bwbench.problems.hysteresis.model_problem import identifiable_parameters

        if self.design is None:  # a direct formulation: the searched parameters are all there is
            return dict(zip(self.param_names, map(float, np.asarray(params, dtype=float))))
        return identifiable_parameters(self, params)

    def forces(self, params) -> list[np.ndarray]:
        """The model force (N) on each file's samples (its warm-up's too) with these parameters (one set
        for all); +inf on blow-up."""
        params = np.asarray(params, dtype=float)
        if self.design is None:
            return [p.simulate(params) for p in self.parts]
        if any(p.start.warmup for p in self.parts):
            coef = self.linear(params)
            return [p.force_with(params, coef) for p in self.parts]
        residual = self.solve(params[None, :], residual=True).residual[0]
        return [residual[s] + p.specimen.f for s, p in zip(self.signal.segments, self.parts)]

    def per_file(self, params) -> list[dict]:
        """Each file's name, samples, weight, MSE (N²), RMSE (N) and NRMSE (RMSE/max|F|) at ``params``, over
        its samples in the loss."""
        out = []
        for force, p, w in zip(self.forces(params), self.parts, self.file_weight):
            with np.errstate(over="ignore", invalid="ignore"):
                mse = float(np.mean((force[p.start.loss] - p.f_loss) ** 2))
            mse = mse if np.isfinite(mse) else float("inf")
            peak = float(np.max(np.abs(p.f_loss)))
            out.append(
                {
                    "specimen": p.specimen.name,
                    "n": p.n_data,
                    "weight": float(w),
                    "mse": mse,
                    "rmse_N": float(np.sqrt(mse)),
                    "nrmse": float(np.sqrt(mse)) / peak if peak > 0 else float("inf"),
                }
            )
        return out

    def fit_checks(self, result, synthetic: bool = False):
        """``fit_checks.check`` of each file with the joint parameters; JSON under "files" by name,
        notes and warnings prefixed with the file's name."""
        from bwbench.problems.hysteresis import fit_checks

        params = np.array([result.params.get(n, np.nan) for n in self.param_names])
        merged = fit_checks.FitChecks()
        if not np.all(np.isfinite(params)):
            return merged
        values = result.params
        findings = []
        for force, part in zip(self.forces(params), self.parts):
            view = FileView(part, force, values)
            checks = fit_checks.check(view, params, synthetic, result.at_bound)
            merged.json.setdefault("files", {})[part.specimen.name] = checks.json
            merged.notes += [f"{part.specimen.name}: {n}" for n in checks.notes]
            merged.warnings += [f"{part.specimen.name}: {w}" for w in checks.warnings]
            merged.explained |= checks.explained
            findings.append((part.specimen.name, checks.findings))
        # A finding every file makes (a parameter on a physical limit) is said once, the others per file.
        common = set.intersection(*(set(f) for _, f in findings)) if findings else set()
        merged.findings += [f for f in findings[0][1] if f in common] if findings else []
        merged.findings += [f"{name}: {f}" for name, fs in findings for f in fs if f not in common]
        fit_checks.physical_limit_findings(self, params, {}, merged)  # the solved coefficients, jointly
        fit_checks.edge_findings(self, params, result.at_bound, merged)  # the box edges, on the joint loss
        return merged


class FileView:
    """One file of a joint fit as ``fit_checks`` sees a problem: its signal, and the joint fit's force."""

    def __init__(self, part, force, values):
        self.model, self.state, self.formulation = part.model, part.state, part.formulation
        self.signal, self.specimen = part.signal, part.specimen
        self.start, self.loss_signal, self.f_loss = part.start, part.loss_signal, part.f_loss
        self.record_trajectories = part.record_trajectories
        self._force, self._values = force, values

    def simulate(self, params):
        return self._force

    def parameters(self, params):
        return self._values
