"""The classic, symmetric Bouc-Wen model as a model plug-in: one parameter set for both directions.

Bouc (1967), Wen (1976); the paper's eq 1 with ωn² in the z term (docs/design.md#the-model), in mm, s, N:

    F  = ẍ + 2·ξ·ωn·ẋ + α·ωn²·x + (1 − α)·ωn²·z
    dz = (A − (β + γ·sign(z·dx))·|z|^n)·dx

It is the switched model with equal '+' and '−' sets, and is simulated by the switched model's
kernel (``bwbench.models.switched.simulation``), so both share one tested integration path.

Direct parameters (A, n, α, β, γ, ξ, ωn) searched in the paper's Table 5 ranges of the tension
('+') set: a box for specimens like the paper's; for anything else use the identifiable
formulation, whose box is scaled from the data. Identifiable: θ = (x_y, n, η) as in the switched
model (x_y = z_s/A in mm, η = (β − γ)/(β + γ)) and F = m·ẍ + c·ẋ + k·x + h·w + f solved by least
squares (w = z/z_s); m follows the inertia rule of the linear solve (fitted only when the data
excite it, else the paper's 1 N·s²/mm).
"""

from __future__ import annotations

import numpy as np

from bwbench.models.base import Box, LinearLayout, Model, Parameter, amplitude
from bwbench.models.switched import simulation as switched

DIRECT = (
    Parameter("A", "-", "A"),
    Parameter("n", "-", "n"),
    Parameter("alpha", "-", "α"),
    Parameter("beta", "mm⁻ⁿ", "β"),
    Parameter("gamma", "mm⁻ⁿ", "γ"),
    Parameter("xi", "-", "ξ"),
    Parameter("wn", "rad/s", "ωn"),
)
HYSTERETIC = (
    Parameter("xy", "mm", "x_y", "yield displacement z_s/A"),
    Parameter("n", "-", "n", "smoothness of the yield"),
    Parameter("eta", "-", "η", "unloading ratio (β − γ)/(β + γ)"),
)
LAYOUT = LinearLayout(
    names=("m", "c", "k", "h", "f"),
    units={"m": "N·s²/mm", "c": "N·s/mm", "k": "N/mm", "h": "N", "f": "N"},
    fixed=(("c", "v"), ("k", "x"), ("f", "1")),
    varying="h",
    mass="m",
)
# Table 5's tension ranges (docs/design.md#parameters), the paper's box for eq 1.
TABLE5_PLUS = {
    "A": (0.001, 0.025),
    "n": (0.43, 10.75),
    "alpha": (0.07, 1.75),
    "beta": (0.1, 2.5),
    "gamma": (0.3, 7.5),
    "xi": (20.0, 500.0),
    "wn": (0.3, 7.5),
}
# As the switched model's identifiable box (bwbench.models.switched.identifiable), except η: an MR
# damper's sharp reversals want η well below −1 (β < 0, unloading faster than loading: −11.5 on a
# measured-like Spencer damper test, beyond a floor of −2), so as Spencer's box.
XY_RANGE = (1e-4, 1e2)
N_RANGE = (0.2, 10.75)
ETA_RANGE = (-50.0, 1.0)


class ClassicBoucWen(Model):
    name = "bouc-wen"
    title = "classic symmetric Bouc-Wen model"
    reference = (
        "R. Bouc, Forced vibration of mechanical systems with hysteresis, Proc. 4th Conf. on "
        "Nonlinear Oscillation, Prague, 1967; Y.-K. Wen, Method for random vibration of hysteretic "
        "systems, J. Eng. Mech. Div. 102(2):249-263, 1976"
    )
    default_formulation = "identifiable"
    rate_independent = True  # z is integrated in displacement

    def direct_parameters(self, state=None) -> tuple:
        return DIRECT

    def direct_box(self, signal, f, state=None) -> Box:
        names = tuple(p.name for p in DIRECT)
        return Box(
            names,
            np.array([TABLE5_PLUS[n][0] for n in names]),
            np.array([TABLE5_PLUS[n][1] for n in names]),
            np.zeros(7, dtype=bool),
        )

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        P = np.atleast_2d(np.asarray(P, dtype=float))
        s = signal
        return np.stack([switched.simulate(np.concatenate([p, p]), s.t, s.x, s.v, s.a) for p in P])

    def mse_batch(self, P, signal, f, state=None) -> np.ndarray:
        P = np.atleast_2d(np.asarray(P, dtype=float))
        s = signal
        return switched.mse_batch(np.concatenate([P, P], axis=1), s.t, s.x, s.v, s.a, f)

    def hysteretic_parameters(self, state=None) -> tuple:
        return HYSTERETIC

    def hysteretic_box(self, signal, f, state=None) -> Box:
        a = amplitude(signal.x)
        return Box(
            ("xy", "n", "eta"),
            np.array([XY_RANGE[0] * a, N_RANGE[0], ETA_RANGE[0]]),
            np.array([XY_RANGE[1] * a, N_RANGE[1], ETA_RANGE[1]]),
            np.array([True, True, False]),
        )

    def linear_layout(self, state=None) -> LinearLayout:
        return LAYOUT

    def trajectories(self, theta, signal, state=None) -> np.ndarray:
        """w = z/z_s (–) at the samples for θ rows (m, 3) = (x_y, n, η); +inf rows on blow-up."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        xy, n, eta = theta.T
        # w obeys the model's equation with A' = 1/x_y and β' + γ' = 1/x_y (z_s' = 1).
        half = np.column_stack([1.0 / xy, n, (1 + eta) / (2 * xy), (1 - eta) / (2 * xy)])
        s = signal
        return switched.hysteretic_state_batch(np.concatenate([half, half], axis=1), s.t, s.x, s.v)

    # An evaluation with its sensitivities (4: ∂z/∂(A, n, β, γ)) took 1.3–1.5 plain one-point simulations
    # in the identifiable formulation and 1.5–2.1 in the direct one (1,921 samples, random points of the
    # box and a fit's optimum, benchmarks/bench_call_cost.py): charged as 3 evaluations, against d = 3
    # (identifiable) or 7 (direct) for differences.
    sensitivity_cost = 3

    def trajectory_sensitivities(self, theta, signal, state=None):
        """(w (L,), ∂w/∂θ (L, 3)) of one θ = (x_y, n, η), by forward sensitivities integrated with w
        by the switched kernel's own steps (``switched_sensitivity``); None on a blow-up."""
        from bwbench.models.switched.sensitivity import hysteretic_sensitivity

        xy, n, eta = np.asarray(theta, dtype=float)
        half = np.array([1.0 / xy, n, (1 + eta) / (2 * xy), (1 - eta) / (2 * xy)])
        dhalf = np.array(
            [
                [-1.0 / xy**2, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-(1 + eta) / (2 * xy**2), 0.0, 1.0 / (2 * xy)],
                [-(1 - eta) / (2 * xy**2), 0.0, -1.0 / (2 * xy)],
            ]
        )
        s = signal
        return hysteretic_sensitivity(np.concatenate([half, half]), np.vstack([dhalf, dhalf]), s.t, s.x, s.v)

    def force_sensitivities(self, P, signal, state=None):
        """(force (L,) N, ∂F/∂P (L, 7)) of one direct vector (A, n, α, β, γ, ξ, ωn), exact: the
        switched kernel's sensitivities with both branches' (A, n, β, γ) the same; None on a blow-up."""
        from bwbench.models.switched.sensitivity import branch_force

        P = np.asarray(P, dtype=float)
        H = P[[0, 1, 3, 4]]
        M = np.vstack([np.eye(4), np.eye(4)])
        return branch_force(P, P, np.concatenate([H, H]), M, [0, 1, 3, 4], signal, "shared", 7)

    def to_direct(self, theta, coef: dict, state=None):
        """(A, n, α, β, γ, ξ, ωn) of the same loops, in the gauge z_s = x_y (A = 1) or, where that makes
        ωn² = k + h/z_s ≤ 0, one that does not; None when no gauge gives ωn² > 0. Eq 1 has unit mass
        and no offset: m and f are left out (reported beside)."""
        xy, n, eta = np.asarray(theta, dtype=float)
        c, k, h = coef["c"], coef["k"], coef["h"]
        if not np.all(np.isfinite([xy, n, eta, c, k, h])):
            return None
        z_s = xy
        if not k + h / z_s > 0:
            if h > 0 and k < 0:
                z_s = 0.5 * h / -k
            elif h < 0 and k > 0:
                z_s = 2.0 * -h / k
            else:
                return None
        A = z_s / xy
        bg = A * z_s**-n
        wn = np.sqrt(k + h / z_s)
        return np.array([A, n, k / wn**2, bg * (1 + eta) / 2, bg * (1 - eta) / 2, c / (2 * wn), wn])

    def from_direct(self, P, state=None):
        A, n, alpha, beta, gamma, xi, wn = np.asarray(P, dtype=float)
        z_s = (A / (beta + gamma)) ** (1.0 / n)
        theta = np.array([z_s / A, n, (beta - gamma) / (beta + gamma)])
        return theta, {"m": 1.0, "c": 2 * xi * wn, "k": alpha * wn**2, "h": (1 - alpha) * wn**2 * z_s, "f": 0.0}

    def coefficient_limits(self, state=None) -> dict:
        return {
            "k": (0.0, np.inf, "k ≥ 0: the spring in parallel with the hysteretic element pushes back"),
            "h": (0.0, np.inf, "h ≥ 0: the hysteretic force lags the motion and so dissipates"),
        }

    def parameter_limits(self, state=None) -> dict:
        return {"eta": {"upper": "η = 1 is γ = 0, the model's limit (beyond it unloading runs away from saturation)"}}

    def plausibility(self, values: dict, signal, state=None) -> list:
        """[(name, value, unit, meaning, verdict)] of the identifiable fit's parameters (``Model.plausibility``)."""
        a = amplitude(signal.x)
        rows = []
        table = (
            (
                "xy",
                "mm",
                "displacement over which the element yields",
                lambda v: (
                    f"x_y > the amplitude {a:.3g} mm: no yield within the stroke (n and η not determined)"
                    if v > a
                    else ""
                ),
            ),
            ("n", "-", "smoothness of the yield", lambda v: ""),
            (
                "eta",
                "-",
                "unloading ratio (β − γ)/(β + γ); below −1 (β < 0) the force unloads faster after a "
                "reversal than it loads, as an MR damper's",
                lambda v: "",
            ),
            ("c", "N·s/mm", "viscous damping (≥ 0)", lambda v: ""),
            ("k", "N/mm", "stiffness in parallel with the hysteresis (≥ 0)", lambda v: ""),
            ("h", "N", "force of the saturated hysteretic element (its yield force, ≥ 0)", lambda v: ""),
            ("f", "N", "constant force offset (a preload or the load cell's zero)", lambda v: ""),
        )
        for name, unit, meaning, verdict in table:
            value = values.get(name)
            if isinstance(value, (int, float)) and np.isfinite(value):
                rows.append((name, float(value), unit, meaning, verdict(float(value))))
        return rows

    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        if "c" in values:
            return {"": values["c"]}
        if "xi" in values:
            return {"": 2 * values["xi"] * values["wn"]}
        return None


MODEL = ClassicBoucWen()
