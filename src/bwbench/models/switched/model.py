"""The paper's switched (asymmetric) Bouc-Wen model as a model plug-in (docs/design.md#the-model, #formulations).

The equations and their integration are in ``bwbench.models.switched.simulation``; the symmetry-free
coordinates and the exact maps to and from the paper's 14 in
``bwbench.models.switched.identifiable``. This module says what the generic layers need:

- direct formulation "paper": the 14 parameters of eqs 2–5 in the Table 5 box, unit mass, no offsets;
- identifiable formulation: per branch x_y (mm), n, η and, in the shared state, ρ = z_s₋/z_s₊,
  searched in a box scaled from the data; F = m·ẍ + c_b·ẋ + k_b·x + h_b·w + f_b solved per branch.
"""

from __future__ import annotations

import numpy as np

from bwbench.models.base import Box, LinearLayout, Model, Parameter
from bwbench.models.switched import simulation as kernel
from bwbench.models.switched.kernel import HYSTERETIC_INDEX, N_PARAMS, PARAM_NAMES, STATES

LAYOUT = LinearLayout(
    names=("m", "c", "k", "h", "f"),
    units={"m": "N·s²/mm", "c": "N·s/mm", "k": "N/mm", "h": "N", "f": "N"},
    fixed=(("c", "v"), ("k", "x"), ("f", "1")),
    varying="h",
    branched=True,
    mass="m",
)
LINEAR_NAMES = ("m", "c+", "k+", "h+", "f+", "c-", "k-", "h-", "f-")  # = coefficient_names(LAYOUT)
LINEAR_TOLERANCE = 0.05  # see SwitchedBoucWen.linear_branches


class SwitchedBoucWen(Model):
    name = "switched-bouc-wen"
    title = "switched (asymmetric) Bouc-Wen model"
    reference = (
        "J. Zalewski et al., Parameter identification of Bouc-Wen model for vacuum packed particles "
        "based on genetic algorithm, Arch. Civ. Mech. Eng. 2019, eqs 2-5"
    )
    states = STATES
    direct_name = "paper"
    default_formulation = "paper"
    # c± are per-branch viscous terms, and the paper's own identifications have ξ₋ < 0 (c₋ < 0) on
    # specimens whose loops dissipate: a sign bound put 15 of the 45 synthetic truths out of reach
    # (MSE 35–806 × the noise). The loops' energy is carried by the whole branch pair, not by c₋.
    viscous_sign_bound = False
    rate_independent = True  # z is integrated in displacement

    def direct_parameters(self, state=None) -> tuple:
        from bwbench.models.switched.parameters import LABELS, UNITS

        return tuple(Parameter(n, UNITS[n], LABELS[n]) for n in PARAM_NAMES)

    def direct_box(self, signal, f, state=None) -> Box:
        from bwbench.models.switched.parameters import LOWER, UPPER

        return Box(PARAM_NAMES, LOWER, UPPER, np.zeros(N_PARAMS, dtype=bool))

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        """Force (N) of each paper 14-vector row (m, 14): the batched z kernel, then the force that is
        linear in z (eqs 2–3) branch by branch; +inf rows on blow-up."""
        state = self.check_state(state)
        P = np.atleast_2d(np.asarray(P, dtype=float))
        s = signal
        Z = kernel.hysteretic_state_batch(P[:, list(HYSTERETIC_INDEX)], s.t, s.x, s.v, state)
        plus = np.asarray(s.v) >= 0.0
        force = np.empty_like(Z)
        for branch, mask in ((P[:, :7], plus), (P[:, 7:], ~plus)):
            xi, wn, alpha = branch[:, 5:6], branch[:, 6:7], branch[:, 2:3]
            with np.errstate(invalid="ignore", over="ignore"):
                force[:, mask] = (
                    s.a[mask]
                    + 2.0 * xi * wn * s.v[mask]
                    + alpha * wn * wn * s.x[mask]
                    + (1.0 - alpha) * wn * wn * Z[:, mask]
                )
        return np.where(np.all(np.isfinite(force), axis=1)[:, None], force, np.inf)

    def mse_batch(self, P, signal, f, state=None) -> np.ndarray:
        s = signal
        return kernel.mse_batch(P, s.t, s.x, s.v, s.a, f, self.check_state(state))

    def hysteretic_parameters(self, state=None) -> tuple:
        from bwbench.models.switched import identifiable as fm

        return tuple(
            Parameter(n, fm.HYSTERETIC_UNITS[n], fm.LABELS[n]) for n in fm.hysteretic_names(self.check_state(state))
        )

    def hysteretic_box(self, signal, f, state=None) -> Box:
        from bwbench.models.switched import identifiable as fm

        b = fm.scaled_bounds(signal.x, f, self.check_state(state))
        return Box(b.names, b.lower, b.upper, b.log)

    def linear_layout(self, state=None) -> LinearLayout:
        return LAYOUT

    def trajectories(self, theta, signal, state=None) -> np.ndarray:
        """w = z/z_s₊ (–) at the samples for θ rows; +inf rows on blow-up."""
        from bwbench.models.switched import identifiable as fm

        state = self.check_state(state)
        s = signal
        H = fm.kernel_hysteretic(np.atleast_2d(np.asarray(theta, dtype=float)), state)
        return kernel.hysteretic_state_batch(H, s.t, s.x, s.v, state)

    # An evaluation with its sensitivities (8: ∂z/∂H of both branches' A, n, β, γ) took 1.6–1.7 plain
    # one-point simulations at random points of the identifiable box and at a fit's optimum, 1.8 in the
    # paper formulation (its force's sensitivities on top; 1,921 samples, benchmarks/bench_call_cost.py):
    # charged as 3 evaluations, against d = 7 (identifiable) or 14 (paper) for differences.
    sensitivity_cost = 3

    def trajectory_sensitivities(self, theta, signal, state=None):
        """(w (L,), ∂w/∂θ (L, d)) of one θ row, by forward sensitivities integrated with w by the
        kernel's own steps (``switched_sensitivity``); None on a blow-up."""
        from bwbench.models.switched import identifiable as fm
        from bwbench.models.switched.sensitivity import hysteretic_sensitivity, identifiable_jacobian

        state = self.check_state(state)
        theta = np.asarray(theta, dtype=float)
        H = fm.kernel_hysteretic(theta[None, :], state)[0]
        s = signal
        return hysteretic_sensitivity(H, identifiable_jacobian(theta, state), s.t, s.x, s.v, state)

    def force_sensitivities(self, P, signal, state=None):
        """(force (L,) N, ∂F/∂P (L, 14)) of one paper 14-vector, exact (``switched_sensitivity``);
        None on a blow-up."""
        from bwbench.models.switched.sensitivity import force_sensitivities

        return force_sensitivities(P, signal, self.check_state(state))

    def to_direct(self, theta, coef: dict, state=None):
        """The paper's 14 of the same loops with m = 1 and f± = 0 put in (the paper has neither), in
        the gauge nearest Table 5's centre (``identifiable.to_paper``); None where no gauge makes
        every ωn² positive."""
        from bwbench.models.switched import identifiable as fm

        linear = np.array([coef[n] for n in LINEAR_NAMES], dtype=float)
        linear[LINEAR_NAMES.index("m")] = 1.0
        linear[[LINEAR_NAMES.index("f+"), LINEAR_NAMES.index("f-")]] = 0.0
        if not np.all(np.isfinite(linear)):
            return None
        return fm.to_paper(theta, linear, self.check_state(state)).params

    def from_direct(self, P, state=None):
        from bwbench.models.switched import identifiable as fm

        theta, linear = fm.from_paper(P, self.check_state(state))
        return theta, dict(zip(LINEAR_NAMES, map(float, linear)))

    def parameter_limits(self, state=None) -> dict:
        """η± = 1 (γ = 0) in the identifiable formulation: the model's limit, not a search limit."""
        why = "η = 1 is γ = 0, the model's limit (beyond it unloading runs away from saturation)"
        return {f"eta{b}": {"upper": why} for b in "+-"}

    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        if "c+" in values:
            return {"+": values["c+"], "-": values["c-"]}
        if "xi+" in values:
            return {b: 2 * values[f"xi{b}"] * values[f"wn{b}"] for b in "+-"}
        return None

    def linear_branches(self, theta, trajectory, signal, state=None) -> dict:
        """A branch is linear when c·|w/w_sat|^n — the relative change of its rate dw/dx — stays below
        ``LINEAR_TOLERANCE`` on all its samples: its loop differs from a straight line by less than 5 %
        of its slope ("no yield within the stroke"; its n and η are not determined, only h/x_y)."""
        from bwbench.models.switched import identifiable as fm

        w = np.asarray(trajectory, dtype=float)
        if not np.all(np.isfinite(w)):
            return {}
        theta = np.asarray(theta, dtype=float)
        names = fm.hysteretic_names(self.check_state(state))
        rho = theta[names.index("rho")] if "rho" in names else 1.0
        plus = np.asarray(signal.v) >= 0
        out = {}
        for b, mask, scale, direction in (("+", plus, 1.0, 1.0), ("-", ~plus, rho, -1.0)):
            if not mask.any():
                continue
            n, eta = theta[names.index(f"n{b}")], theta[names.index(f"eta{b}")]
            ws = w[mask] / scale
            c = np.where(ws * direction > 0, 1.0, eta)  # loading (moving away from w = 0) or unloading
            out[b] = bool(np.max(np.abs(c) * np.abs(ws) ** n) < LINEAR_TOLERANCE)
        return out

    def linear_limits(self, state=None) -> dict:
        """Per branch η = 0 and n at the top of its box: unloading at the constant rate 1/x_y and loading
        at (1 − |w|ⁿ)/x_y, constant to 5 % while |w| < 0.76 of saturation — a branch linear until it
        yields, x_y setting where (beyond the stroke: never)."""
        from bwbench.models.switched import identifiable as fm

        return {b: {f"n{b}": fm.N_RANGE[1], f"eta{b}": 0.0} for b in "+-"}

    def reduced_gauge(self, held, state=None) -> set:
        """A branch held linear changes the w it hands over, which the hysteretic scales h± and the
        offsets f± absorb; an x_y held at the cap moves ρ along the ridge x_y₊·ρ (shared state)."""
        if not held:
            return set()
        out = {"h+", "h-", "f+", "f-"}
        if any(n.startswith("xy") for n in held) and self.check_state(state) == "shared":
            out.add("rho")
        return out

    def yield_parameters(self, state=None) -> dict:
        """x_y of each branch (its box ends at the cap, 50 × the amplitude)."""
        return {b: f"xy{b}" for b in "+-"}

    def symmetries(self, params, state=None) -> list:
        """z → s·z (``switched_identifiable.scale_paper``): one scale for both branches in the shared
        state, one per branch in the split state."""
        from bwbench.models.switched.identifiable import scale_paper

        if self.check_state(state) == "shared":
            return [("z → s·z in both branches", lambda s: scale_paper(params, s, s))]
        return [
            ("z₊ → s·z₊", lambda s: scale_paper(params, s, 1.0)),
            ("z₋ → s·z₋", lambda s: scale_paper(params, 1.0, s)),
        ]


MODEL = SwitchedBoucWen()
