"""One model fitted across a damper's control range: some parameters are laws of the control u.

The files (one or several; each with its control: ``bwbench.data.control``) are fitted jointly, as a
``JointProblem`` does (loss Σ w_i·MSE_i, the same weights), with one parameter vector of

- every searched parameter without a law, as in the plain formulation;
- the coefficients of each searched parameter's law (``laws``): θ(u) from them at each file's level,
  or at each sample where the control varies within a file;
- in the identifiable formulation, the coefficients of each solved coefficient's law stay in the
  linear solve (``design.ControlDesign``: extra columns ℓ_k(u)·g);
- with ``control_filter``, the rate η (1/s) of Spencer's first-order lag between the command v in
  the file and the control u that acts, u̇ = −η·(u − v), u = v at the first sample.

Where every file's control is constant (and no filter), each file is the plain model at its level,
simulated by the model's own kernels, and the exact Jacobian is the model's sensitivities carried to
the law coefficients by the chain rule (∂θ_i/∂c of the laws at u_i). A control that varies within a
file needs a model that takes per-sample parameters (``Model.trajectories_varying``: Spencer's); its
Jacobian is then taken by differences.
"""

from __future__ import annotations

import math

import numpy as np

from bwbench.errors import UserError
from bwbench.problems.hysteresis.control import laws as laws_mod
from bwbench.problems.hysteresis.control.lag import FILTER, filtered
from bwbench.problems.hysteresis.joint_problem import PartsProblem, file_weights, stack_signals


class ControlledProblem(PartsProblem):
    """See the module docstring. ``parts``: the plain problems of the files (``DirectProblem`` or
    ``IdentifiableProblem`` of one model, formulation and state), each specimen with its control;
    ``laws``: {parameter name: law name or ``Law``}; names the formulation does not have are refused."""

    lower: np.ndarray
    upper: np.ndarray
    settings: dict = {}  # the problem settings it was built with (``build``)
    law_choices: tuple = ()  # ``--law auto``'s choices (``control.setup``)
    law_points: dict = {}  # the per-level values behind them, for the figure

    def __init__(
        self,
        parts,
        laws: dict,
        *,
        weighting: str = "equal",
        fix_mass="auto",
        offsets=True,
        coefficient_bounds: dict | None = None,
        control_filter: bool = False,
        bounds: dict | None = None,
    ):
        first = parts[0]
        self.parts = list(parts)
        self.model, self.state, self.excitation = first.model, first.state, first.excitation
        self.formulation, self.parameter_list = first.formulation, first.parameter_list
        missing = [p.specimen.path for p in parts if p.specimen.control is None]
        if missing:
            raise UserError(f"{missing[0]}: no control for this file (name it with --control)")
        names = {p.specimen.control_name for p in parts}
        if len(names) > 1:
            raise UserError(f"the files carry different controls ({', '.join(sorted(names))}): a fit has one")
        self.control_name = first.specimen.control_name
        from bwbench.data.control import ControlSpec

        self.control_unit = ControlSpec(self.control_name).unit
        self.weighting = weighting
        self.workers = 1
        self.lengths = np.array([p.n_data for p in parts])
        self.file_weight = file_weights(self.lengths, weighting)
        self.N = int(self.lengths.sum())
        self.sample_weight = np.repeat(self.N * self.file_weight / self.lengths, self.lengths)
        self.signal = stack_signals([p.signal for p in parts])
        self.f = np.concatenate([p.specimen.f for p in parts])
        self.commands = [np.asarray(p.specimen.control, dtype=float) for p in parts]
        u_all = np.concatenate(self.commands)
        self.u_lo, self.u_hi = float(u_all.min()), float(u_all.max())
        self.filtered = bool(control_filter)
        self.varying = self.filtered or any(np.ptp(u) > 0 for u in self.commands)
        self.levels = sorted({float(u[0]) for u in self.commands}) if not self.varying else None
        self.base_names = tuple(first.param_names)
        with np.errstate(divide="ignore", invalid="ignore"):
            base_lower = np.min([p.lower for p in parts], axis=0)
            base_upper = np.max([p.upper for p in parts], axis=0)
        self.solved_names = tuple(first.linear_names) if self.formulation == "identifiable" else ()
        self.laws = self._check_laws(laws, base_lower, base_upper)
        self._searched_layout(base_lower, base_upper, first.log_scaled)
        if self.varying and not hasattr(self.model, "trajectories_varying"):
            raise UserError(
                f"the control varies within a file{' (--control-filter)' if self.filtered else ''}: model "
                f"{self.model.name!r} takes no per-sample parameters (spencer does); fit files of constant control"
            )
        self._design_args = dict(fix_mass=fix_mass, offsets=offsets, coefficient_bounds=coefficient_bounds)
        self._designs: dict = {}
        self.design = None
        if self.formulation == "identifiable":
            self.design = self._design(None)
            self.linear_names = self._all_coefficients()
            units = dict(first.linear_units)
            self.linear_units = {**units, **{n: units.get(self._owner(n), "") for n in self.linear_names}}
        if bounds:
            from bwbench.data import bounds as bounds_mod

            # a base parameter's bound bounds each of its law's coefficients ({"vy": [1, 9]}: vy@0V, vy@2.25V)
            box = {k: tuple(bounds[self._owner(k)]) for k in self.param_names if self._owner(k) in bounds}
            box.update({k: tuple(v) for k, v in bounds.items() if k in self.param_names})
            lower, upper = bounds_mod.apply(self.lower, self.upper, self.param_names, box)
            self.lower, self.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)

    # -- set-up -----------------------------------------------------------------------------------------
    def _check_laws(self, laws, lower, upper) -> dict:
        known = self.base_names + tuple(n for n in self.solved_names)
        out = {}
        for name, spec in dict(laws or {}).items():
            if name not in known:
                raise UserError(
                    f"--law {name}: {self.model.name} ({self.formulation}) has no parameter {name!r}; its "
                    f"parameters are {', '.join(known)}"
                )
            law = laws_mod.law_of(spec)
            if law.name == "constant":
                continue
            if name in self.solved_names and not law.linear:
                raise UserError(
                    f"--law {name}={law.name}: {name} is solved by least squares, so its law must be linear in its "
                    "coefficients (linear or quadratic); give the law to a searched parameter, or use the direct formulation"
                )
            distinct = len(self.levels) if self.levels is not None else math.inf
            if not isinstance(law, laws_mod.CallableLaw) and distinct < law.n:
                raise UserError(
                    f"--law {name}={law.name}: a {law.name} law needs {law.n} control levels, the files have "
                    f"{distinct} ({', '.join(f'{v:g}' for v in self.levels or ())} {self.control_unit})"
                )
            if law.needs_positive and name in self.base_names:
                j = self.base_names.index(name)
                if not lower[j] > 0:
                    raise UserError(
                        f"--law {name}={law.name}: an exponential law keeps its parameter positive, and {name}'s "
                        f"box reaches {lower[j]:g}; use linear or quadratic"
                    )
            out[name] = law
        return out

    def _searched_layout(self, lower, upper, log):
        nodes = self.law_nodes
        names, lo, hi, lg, self._slices = [], [], [], [], []
        for j, name in enumerate(self.base_names):
            law = self.laws.get(name)
            start = len(names)
            if law is None:
                names.append(name)
                lo.append(lower[j])
                hi.append(upper[j])
                lg.append(log[j])
            elif isinstance(law, laws_mod.CallableLaw):
                names += law.coefficient_names(name, None, self.control_unit)
                b = law.box()
                lo += list(b[0])
                hi += list(b[1])
                lg += list(b[2])
            else:
                names += law.coefficient_names(name, law.nodes(*nodes), self.control_unit)
                lo += [lower[j]] * law.n
                hi += [upper[j]] * law.n
                lg += [log[j]] * law.n
            self._slices.append(slice(start, len(names)))
        if self.filtered:
            dt = min(float(np.median(np.diff(p.specimen.t))) for p in self.parts)
            duration = max(p.specimen.duration_s for p in self.parts)
            names.append(FILTER)
            lo.append(1.0 / duration)
            hi.append(2.0 / dt)
            lg.append(True)
        self.param_names = tuple(names)
        self.lower, self.upper = np.array(lo, dtype=float), np.array(hi, dtype=float)
        self.log_scaled = np.array(lg, dtype=bool)

    @property
    def law_nodes(self) -> tuple[float, float]:
        return self.u_lo, self.u_hi

    def _owner(self, name: str) -> str:
        """The base parameter or coefficient a law coefficient belongs to (``alpha@2.25V`` → ``alpha``)."""
        return name.split("@", 1)[0]

    def _expansions(self, u_all) -> dict:
        from bwbench.problems.hysteresis.control.design import Expansion

        out = {}
        for name, law in self.laws.items():
            if name in self.solved_names:
                nodes = law.nodes(*self.law_nodes)
                out[name] = Expansion(
                    name, law.coefficient_names(name, nodes, self.control_unit), law.basis(u_all, nodes)
                )
        return out

    def _design(self, eta):
        """The ``ControlDesign`` for filter rate ``eta`` (None: no filter); cached (the solved laws' columns
        depend on the control that acts)."""
        key = None if not self.solved_laws or eta is None else float(eta)
        if key in self._designs:
            return self._designs[key]
        from bwbench.problems.hysteresis.control.design import ControlDesign
        from bwbench.problems.hysteresis.linear.solve import LinearDesign
        from bwbench.problems.hysteresis.model_problem import coefficient_bounds_of

        layout = self.model.linear_layout(self.state)
        bounds, notes = coefficient_bounds_of(
            self.model, layout, self.signal, self.f, self._design_args["coefficient_bounds"]
        )
        plain = LinearDesign(
            self.signal,
            self.f,
            layout,
            fix_mass=self._design_args["fix_mass"],
            offsets=self._design_args["offsets"],
            bounds=bounds,
            weights=self.sample_weight,
            notes=notes,
        )
        u_all = np.concatenate([s[0] for s in self._acting(eta)])
        design = ControlDesign(plain, self._expansions(u_all))
        if len(self._designs) > 4:
            self._designs.clear()
        self._designs[key] = design
        return design

    @property
    def solved_laws(self) -> list:
        return [n for n in self.laws if n in self.solved_names]

    # -- the control that acts ----------------------------------------------------------------------------
    def _acting(self, eta):
        """Per file (u at each sample, u averaged over each sample interval): the command itself, or
        through the first-order lag at rate ``eta`` (exact for a command held over each interval)."""
        out = []
        for v, part in zip(self.commands, self.parts):
            if eta is None or np.ptp(v) == 0:
                out.append((v, v[:-1]))
                continue
            dt = np.diff(np.asarray(part.specimen.t, dtype=float))
            out.append(filtered(v, dt, float(eta)))
        return out

    def _theta(self, c, u) -> np.ndarray:
        """The base parameters (L, d) at controls u (L,) for the searched vector c."""
        u = np.atleast_1d(u)
        out = np.empty((len(u), len(self.base_names)))
        nodes = self.law_nodes
        for j, name in enumerate(self.base_names):
            coefs = c[self._slices[j]]
            law = self.laws.get(name)
            out[:, j] = coefs[0] if law is None else law.value(coefs, u, law.nodes(*nodes))
        return out

    def _theta_jacobian(self, c, level: float) -> np.ndarray:
        """∂θ/∂c (d, D) at one control level."""
        T = np.zeros((len(self.base_names), len(self.param_names)))
        nodes = self.law_nodes
        for j, name in enumerate(self.base_names):
            s = self._slices[j]
            law = self.laws.get(name)
            T[j, s] = 1.0 if law is None else law.jacobian(c[s], np.array([level]), law.nodes(*nodes))[0]
        return T

    def _theta_jacobian_rows(self, c, u) -> np.ndarray:
        """∂θ/∂c (L, d, D) at controls u (L,); the filter's column 0 (taken by a difference)."""
        T = np.zeros((len(u), len(self.base_names), len(self.param_names)))
        nodes = self.law_nodes
        for j, name in enumerate(self.base_names):
            s = self._slices[j]
            law = self.laws.get(name)
            T[:, j, s] = 1.0 if law is None else law.jacobian(c[s], u, law.nodes(*nodes))
        return T

    def _varying_sensitivities(self, c, i):
        """(trajectory (L,), ∂trajectory/∂c (L, D)) of file i under its varying control."""
        u_smp, u_int = self._acting(self._eta(c))[i]
        return self.model.trajectory_sensitivities_varying(
            self._theta(c, u_int),
            self._theta(c, u_smp),
            self._theta_jacobian_rows(c, u_int),
            self._theta_jacobian_rows(c, u_smp),
            self.parts[i].signal,
            self.state,
        )

    def _eta(self, c):
        return float(c[-1]) if self.filtered else None

    # -- simulation ---------------------------------------------------------------------------------------
    def _file_outputs(self, C, kind: str) -> list:
        """Per file, (m, L_i): the trajectories (identifiable) or forces (direct) of the rows of C."""
        out = []
        m = len(C)
        for i, part in enumerate(self.parts):
            block = np.empty((m, part.n_data))
            constant = not self.varying or (np.ptp(self.commands[i]) == 0)
            if constant:
                level = float(self.commands[i][0])
                theta = np.vstack([self._theta(c, np.array([level]))[0] for c in C])
                block[:] = self._plain(part, theta, kind)
            else:
                for r, c in enumerate(C):
                    u_smp, u_int = self._acting(self._eta(c))[i]
                    block[r] = self._plain_varying(part, self._theta(c, u_int), self._theta(c, u_smp), kind)
            out.append(block)
        return out

    def _plain(self, part, theta, kind):
        # each file starts by the common rule (``bwbench.models.start``): its pre-roll simulated and cropped
        if kind == "trajectory":
            return part.start.crop(self.model.trajectories(theta, part.sim_signal, self.state))
        return part.start.crop(self.model.force_batch(theta, part.sim_signal, self.state))

    def _plain_varying(self, part, theta_int, theta_smp, kind):
        if kind == "trajectory":
            return self.model.trajectories_varying(theta_int, theta_smp, part.signal, self.state)
        return self.model.force_varying(theta_int, theta_smp, part.signal, self.state)

    def _kind(self) -> str:
        return "trajectory" if self.design is not None else "force"

    # -- what the objective, the runner and the result need ---------------------------------------------------
    @property
    def info(self) -> dict:
        return self.parts_info(control=self.control_info())

    def control_info(self) -> dict:
        return {
            "name": self.control_name,
            "unit": self.control_unit,
            "range": [self.u_lo, self.u_hi],
            "levels": self.levels,
            "varying": self.varying,
            "filter": "first-order lag u' = -eta_u·(u - v)" if self.filtered else None,
            "laws": {n: law.name for n, law in self.laws.items()},
            "law_nodes": [self.u_lo, self.u_hi],
        }

    def exploration(self):
        """A copy simulating more cheaply for lsq-trf's exploring searches (the model's ``exploring``: Spencer's
        at a looser tolerance), or None; no decimation (the laws' columns are per sample)."""
        exploring = getattr(self.model, "exploring", None)
        if not callable(exploring):
            return None
        import copy

        cheaper = copy.copy(self)
        cheaper.model = exploring()
        cheaper.exploration_note = str(getattr(cheaper.model, "exploration_note", ""))
        return cheaper

    def from_unit(self, U) -> np.ndarray:
        from bwbench.engine.box import box_from_unit

        return box_from_unit(U, self.lower, self.upper, self.log_scaled)

    def to_unit(self, P) -> np.ndarray:
        from bwbench.engine.box import box_to_unit

        return box_to_unit(P, self.lower, self.upper, self.log_scaled)

    def units(self, names) -> dict:
        from bwbench.problems.hysteresis.fit_checks import units

        base = units(self, [self._owner(n) for n in names])
        base.update({n: u for n, u in getattr(self, "linear_units", {}).items()})
        out = {n: base.get(self._owner(n), base.get(n)) for n in names}
        if FILTER in names:
            out[FILTER] = "1/s"
        return {n: u for n, u in out.items() if u is not None}

    # -- the loss -------------------------------------------------------------------------------------------
    def _stacked(self, C):
        return np.concatenate(self._file_outputs(C, self._kind()), axis=1)

    def loss_batch(self, P) -> np.ndarray:
        """Σ_i w_i·MSE_i (N²) of each row of P; +inf where the model blows up on any file."""
        C = np.atleast_2d(np.asarray(P, dtype=float))
        if self.design is not None:
            Z = self._stacked(C)
            out = np.empty(len(C))
            for r, c in enumerate(C):
                _, rss = self._design(self._eta(c)).solve(Z[r : r + 1])
                out[r] = rss[0] / self.N
            return np.where(np.isfinite(out), out, np.inf)
        F = self._stacked(C)
        with np.errstate(invalid="ignore", over="ignore"):
            losses = np.sum(self.sample_weight * (F - self.f) ** 2, axis=1) / self.N
        return np.where(np.isfinite(losses), losses, np.inf)

    def residual_batch(self, P) -> np.ndarray:
        """Weighted residuals (m, N) (model − measured force, N, × √(N·w_i/L_i)); +inf rows on blow-up."""
        C = np.atleast_2d(np.asarray(P, dtype=float))
        out = np.full((len(C), self.N), np.inf)
        stacked = self._stacked(C)
        for r, c in enumerate(C):
            if self.design is not None:
                design = self._design(self._eta(c))
                coef, rss = design.solve(stacked[r : r + 1])
                if np.isfinite(rss[0]):
                    out[r] = design.residual(stacked[r], coef[0])
            else:
                with np.errstate(invalid="ignore", over="ignore"):
                    R = (stacked[r] - self.f) * np.sqrt(self.sample_weight)
                if np.all(np.isfinite(R)):
                    out[r] = R
        return out

    @property
    def jacobian_cost(self) -> int:
        """Plain evaluations an exact Jacobian is charged (0: none, take differences). Under a varying
        control (Spencer's model, identifiable formulation): the sensitivities' cost for the state and each
        block of six coefficients (``spencer_varying``), plus one plain evaluation for the filter's rate."""
        if self.varying:
            if self.design is None or not hasattr(self.model, "trajectory_sensitivities_varying"):
                return 0
            coefficients = self.dim - int(self.filtered)
            return int(self.model.sensitivity_cost) * (1 + -(-coefficients // 6)) + int(self.filtered)
        if self.design is not None:
            return int(self.model.sensitivity_cost)
        return int(self.model.sensitivity_cost) if hasattr(self.model, "force_sensitivities") else 0

    def residual_jacobian(self, params):
        """(weighted residuals (N,), their Jacobian (N, D)) of one searched vector, exact (the model's
        sensitivities at each file's level, carried to the law coefficients by the chain rule, and
        through the linear solve); None where they cannot be had (a control varying within a file)."""
        if self.jacobian_cost == 0:
            return None
        c = np.asarray(params, dtype=float)
        values, derivatives = [], []
        for i, part in enumerate(self.parts):
            if self.varying and (self.filtered or np.ptp(self.commands[i]) > 0):
                found = self._varying_sensitivities(c, i)
                if found[1] is None:
                    return np.full(self.N, np.inf), None
                values.append(found[0])
                derivatives.append(found[1])
                continue
            level = float(self.commands[i][0])
            theta = self._theta(c, np.array([level]))[0]
            T = self._theta_jacobian(c, level)
            if self.design is not None:
                found = self.model.trajectory_sensitivities(theta, part.sim_signal, self.state)
            else:
                found = self.model.force_sensitivities(theta, part.sim_signal, self.state)
            if found is None:
                return None
            if found[1] is None:
                return np.full(self.N, np.inf), None
            k = part.start.preroll  # the pre-roll's samples cropped: (L,) values, (L, d) derivatives
            found = (found[0][k:], found[1][k:])
            values.append(found[0])
            derivatives.append(found[1] @ T)
        z, dZ = np.concatenate(values), np.concatenate(derivatives, axis=0)
        if self.design is not None:
            found = self._design(self._eta(c)).residual_jacobian(z, dZ)
            if found is not None and self.filtered:  # the rate moves the control every column sees: a difference
                r, J = found
                step = c.copy()
                step[-1] *= 1.0 + 1e-6
                J[:, -1] = (self.residual_batch(step[None, :])[0] - r) / (step[-1] - c[-1])
            return found
        sw = np.sqrt(self.sample_weight)
        return (z - self.f) * sw, dZ * sw[:, None]

    # -- one parameter vector -------------------------------------------------------------------------------
    def _all_coefficients(self) -> tuple:
        """Every coefficient of the layout, a law's in its coefficients: solved, held, tied or dropped."""
        from bwbench.problems.hysteresis.linear.columns import coefficient_names

        out: list[str] = []
        for name in coefficient_names(self.model.linear_layout(self.state)):
            law = self.laws.get(name)
            out += [name] if law is None else law.coefficient_names(name, law.nodes(*self.law_nodes), self.control_unit)
        return tuple(out)

    def linear(self, params) -> np.ndarray:
        """The coefficients (``linear_names``) of one searched vector: solved, held (a mass the data do not
        excite), tied (a continuous offset), NaN for a branch without samples, 0 where dropped."""
        c = np.asarray(params, dtype=float)
        design = self._design(self._eta(c))
        coef, _ = design.solve(self._stacked(c[None, :]))
        values = dict(zip(design.free_names, map(float, coef[0])))
        values.update(design.held)
        for tied, source in design.tied.items():
            values[tied] = values.get(source, 0.0)
        absent = {
            f"{n}{b}" for b, mask in design.plain.masks.items() if not mask.any() for n in design.plain.layout.names
        }
        return np.array([values.get(n, np.nan if self._owner(n) in absent else 0.0) for n in self.linear_names])

    def parameters(self, params) -> dict:
        """The searched coefficients, and in the identifiable formulation the solved ones, by name."""
        c = np.asarray(params, dtype=float)
        out = dict(zip(self.param_names, map(float, c)))
        if self.design is not None and np.all(np.isfinite(c)):
            out.update(zip(self.linear_names, map(float, self.linear(c))))
        return out

    def forces(self, params) -> list[np.ndarray]:
        """The model force (N) on each file (+inf on blow-up)."""
        c = np.asarray(params, dtype=float)
        if self.design is None:
            return [block[0] for block in self._file_outputs(c[None, :], "force")]
        r = self.residual_batch(c[None, :])[0] / np.sqrt(self.sample_weight)
        return [r[s] + p.specimen.f for s, p in zip(self.signal.segments, self.parts)]

    def per_file(self, params) -> list[dict]:
        """Each file's name, samples, weight, MSE (N²), RMSE (N), NRMSE (RMSE/max|F|) and control level."""
        out = []
        for force, p, w, u in zip(self.forces(params), self.parts, self.file_weight, self.commands):
            with np.errstate(over="ignore", invalid="ignore"):
                mse = float(np.mean((force - p.specimen.f) ** 2))
            mse = mse if np.isfinite(mse) else float("inf")
            peak = float(np.max(np.abs(p.specimen.f)))
            row = {
                "specimen": p.specimen.name,
                "n": p.n_data,
                "weight": float(w),
                "mse": mse,
                "rmse_N": float(np.sqrt(mse)),
                "nrmse": float(np.sqrt(mse)) / peak if peak > 0 else float("inf"),
            }
            row[self.control_name] = float(u[0]) if np.ptp(u) == 0 else [float(u.min()), float(u.max())]
            out.append(row)
        return out

    def laws_json(self, values: dict) -> dict:
        """What a result records to simulate the model at any control level: the control, and for each
        parameter with a law its law, nodes and coefficient names (values in ``params``)."""
        laws = {}
        for name, law in self.laws.items():
            nodes = law.nodes(*self.law_nodes)
            coefs = law.coefficient_names(name, nodes, self.control_unit)
            entry = {"law": law.name, "coefficients": coefs}
            if not isinstance(law, laws_mod.CallableLaw):
                entry["nodes"] = [float(v) for v in nodes]
                c = np.array([values.get(k, np.nan) for k in coefs], dtype=float)
                if np.all(np.isfinite(c)):
                    entry["closed_form"] = law.monomials(c, nodes)
            laws[name] = entry
        return {**self.control_info(), "laws": laws}

    # -- uncertainty (``uncertainty``) ----------------------------------------------------------------------
    def covariance(self, params) -> tuple[tuple, np.ndarray, float]:
        """``uncertainty.covariance`` of this problem."""
        from bwbench.problems.hysteresis.control.uncertainty import covariance

        return covariance(self, params)

    def law_table(self, params) -> list[dict]:
        """``uncertainty.law_table`` of this problem."""
        from bwbench.problems.hysteresis.control.uncertainty import law_table

        return law_table(self, params)

    def result_json(self, values: dict) -> dict:
        """What a fit's result JSON adds: ``control`` (``laws_json``), ``coefficients`` (each with its
        standard error and unit) and, after ``--law auto``, ``law_choices`` (each parameter's law and why)."""
        out = {"control": self.laws_json(values), "coefficients": self.law_table(values)}
        choices = getattr(self, "law_choices", ())
        if choices:
            out["law_choices"] = {c.parameter: {"law": c.law, "why": c.reason} for c in choices}
        return out

    def fit_checks(self, result, synthetic: bool = False):
        """``fit_checks.check`` of each file at a constant level with the plain model there (its energy,
        residual and plausibility checks), as a joint fit's files are checked; a file whose control
        varies is not checked. A finding every checked file makes is said once."""
        from bwbench.problems.hysteresis import fit_checks
        from bwbench.problems.hysteresis.control.fitted import parameters_at
        from bwbench.problems.hysteresis.joint_problem import FileView

        merged = fit_checks.FitChecks()
        values = dict(result.params)
        c = np.array([values.get(n, np.nan) for n in self.param_names], dtype=float)
        if not np.all(np.isfinite(c)):
            return merged
        control = self.laws_json(values)
        findings = []
        for force, part, u in zip(self.forces(c), self.parts, self.commands):
            if np.ptp(u) > 0 or self.filtered:
                continue
            at_level = parameters_at(control, values, float(u[0]), dict(self.laws))
            theta = np.array([at_level[n] for n in part.param_names], dtype=float)
            checks = fit_checks.check(FileView(part, force, at_level), theta, synthetic, {})
            merged.json.setdefault("files", {})[part.specimen.name] = checks.json
            merged.notes += [f"{part.specimen.name}: {n}" for n in checks.notes]
            merged.warnings += [f"{part.specimen.name}: {w}" for w in checks.warnings]
            merged.explained |= checks.explained
            findings.append((part.specimen.name, checks.findings))
        common = set.intersection(*(set(f) for _, f in findings)) if findings else set()
        merged.findings += [f for f in findings[0][1] if f in common] if findings else []
        merged.findings += [f"{name}: {f}" for name, fs in findings for f in fs if f not in common]
        return merged


def build(specimens, settings: dict, laws: dict, control_filter: bool = False) -> ControlledProblem:
    """The ``ControlledProblem`` of specimens (each with its control) for problem ``settings`` (those of
    ``formulations.make_problem``: model, formulation, state, excitation, fix_mass, offsets, weighting,
    bounds), ``laws`` ({parameter: law}) and the filter."""
    from bwbench.problems.hysteresis.formulations import make_problem, solved_bounds

    one = {k: v for k, v in settings.items() if k != "bounds"}
    parts = [make_problem(s, one) for s in specimens]
    model, state = parts[0].model, parts[0].state
    bounds = dict(settings.get("bounds", {}))
    problem = ControlledProblem(
        parts,
        laws,
        weighting=settings.get("weighting", "equal"),
        fix_mass=settings.get("fix_mass", "auto"),
        offsets=settings.get("offsets", True),
        coefficient_bounds=solved_bounds(model, state, bounds) if parts[0].formulation == "identifiable" else None,
        control_filter=control_filter,
        bounds=bounds,
    )
    problem.settings = dict(settings)  # what the problem was built with: a refit (leave one level out) takes them
    return problem
