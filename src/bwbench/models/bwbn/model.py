"""The degrading, pinching Bouc-Wen model (BWBN) as a model plug-in: structures that lose strength and
stiffness with the energy they dissipate and whose loops pinch (reinforced concrete, timber joints).

Baber & Noori (1985, 1986)'s degrading Bouc-Wen model with Foliente (1995)'s pinching function, in the
form of Foliente (1995) and Ma, Zhang & Foliente (2004) with A = 1 (the gauge; their δ_A is, to first
order in the energy, δν together with δη) and the energy ε = ∫z·dx (mm²), in mm, s, N:

    F  = c·ẋ + α·k·x + (1 − α)·k·z
    dz = h(z, ε)·(1 − ν(ε)·(β·sign(z·dx) + γ)·|z|ⁿ)/η(ε)·dx
    ν  = 1 + δν·ε,  η = 1 + δη·ε,  z_u = (1/(ν·(β + γ)))^(1/n)
    h  = 1 − ζ₁·exp(−((z·sign(dx) − q·z_u)/ζ₂)²),  ζ₁ = ζ_s·(1 − e^(−p·ε)),  ζ₂ = (ψ + δψ·ε)·(λ + ζ₁)

Direct formulation: those 14 parameters (k, α, c, β, γ, n, δν, δη, ζ_s, p, q, ψ, δψ, λ), no mass and
no offset. Identifiable: in units of the initial ultimate z_u0 = (β + γ)^(−1/n) (= x_y, the yield
displacement, as A = 1), w = z/z_u0 and e = ∫w·dx = ε/z_u0 (mm); θ = (x_y, n, η, δν, δη, ζ_s, p, q,
ψ, δψ, λ) with η = (γ − β)/(β + γ) the unloading ratio and the energy rates per mm of e (the kernel:
``bwbench.models.bwbn.kernel``), and F = m·ẍ + c·ẋ + k·x + h·w + f solved by least squares.
"""

from __future__ import annotations

import numpy as np

from bwbench.models.base import Box, LinearLayout, Model, Parameter, amplitude
from bwbench.models.bwbn import kernel

DIRECT = (
    Parameter("k0", "N/mm", "k₀", "initial stiffness"),
    Parameter("alpha", "-", "α", "post-yield stiffness ratio"),
    Parameter("c", "N·s/mm", "c", "viscous damping"),
    Parameter("beta", "mm⁻ⁿ", "β"),
    Parameter("gamma", "mm⁻ⁿ", "γ"),
    Parameter("n", "-", "n"),
    Parameter("dnu", "mm⁻²", "δν", "strength degradation per unit ε = ∫z·dx"),
    Parameter("deta", "mm⁻²", "δη", "stiffness degradation per unit ε"),
    Parameter("zeta_s", "-", "ζ_s", "pinching severity"),
    Parameter("p", "mm⁻²", "p", "rate of the pinching's onset per unit ε"),
    Parameter("q", "-", "q", "where the pinching sits, in units of z_u"),
    Parameter("psi", "mm", "ψ", "initial width of the pinching"),
    Parameter("dpsi", "mm⁻¹", "δψ", "growth of the pinching's width per unit ε"),
    Parameter("lambda", "-", "λ", "how the width follows ζ₁"),
)
HYSTERETIC = (
    Parameter("xy", "mm", "x_y", "yield displacement z_u0/A"),
    Parameter("n", "-", "n", "smoothness of the yield"),
    Parameter("eta", "-", "η", "unloading ratio (γ − β)/(β + γ)"),
    Parameter("dnu_e", "mm⁻¹", "δν_e", "strength degradation per mm of e = ∫w·dx"),
    Parameter("deta_e", "mm⁻¹", "δη_e", "stiffness degradation per mm of e"),
    Parameter("zeta_s", "-", "ζ_s", "pinching severity"),
    Parameter("p_e", "mm⁻¹", "p_e", "rate of the pinching's onset per mm of e"),
    Parameter("q", "-", "q", "where the pinching sits, in units of w_u"),
    Parameter("psi_w", "-", "ψ_w", "initial width of the pinching, in units of w"),
    Parameter("dpsi", "mm⁻¹", "δψ", "growth of the pinching's width per mm of e"),
    Parameter("lambda", "-", "λ", "how the width follows ζ₁"),
)
THETA_NAMES = tuple(p.name for p in HYSTERETIC)
LAYOUT = LinearLayout(
    names=("m", "c", "k", "h", "f"),
    units={"m": "N·s²/mm", "c": "N·s/mm", "k": "N/mm", "h": "N", "f": "N"},
    fixed=(("c", "v"), ("k", "x"), ("f", "1")),
    varying="h",
    mass="m",
)
# The identifiable box, scaled by the amplitude a (mm) and the record's travel T = Σ|Δx| (mm), the
# largest e any w in [−1, 1] can reach: a rate r per mm of e moves ν (or η_d, ζ₁, the width) by at
# most r·T over the record, so [1e-3, 1e2]/T spans "no change within the record" to "all of it in
# the first per cent of the travel".
XY_RANGE = (1e-2, 10.0)  # × a: a structure yields within a fraction of its amplitude
N_RANGE = (1.0, 10.0)  # below 1 the yield rate |w|^(n−1) is unbounded at w = 0
ETA_RANGE = (-5.0, 1.0)
RATE_RANGE = (1e-3, 1e2)  # × 1/T, for δν, δη, p and δψ
ZETA_S_RANGE = (0.0, 0.99)
Q_RANGE = (0.0, 1.0)
PSI_RANGE = (1e-2, 2.0)  # a narrower band is a jump in the force (and costs 1/ψ substeps)
LAMBDA_RANGE = (1e-3, 2.0)


def travel(x) -> float:
    """Σ|Δx| (mm): the scale of the energy rates' box."""
    T = float(np.sum(np.abs(np.diff(np.asarray(x, dtype=float)))))
    if not T > 0:
        raise ValueError("the displacement does not move: no scale for the search box")
    return T


def _theta_of_direct(P):
    """(θ, z_u0, ∂θ/∂P (11, 14)) of one direct vector."""
    k, alpha, c, beta, gamma, n, dnu, deta, zs, p, q, psi, dpsi, lam = np.asarray(P, dtype=float)
    B = beta + gamma
    zu = B ** (-1.0 / n)
    theta = np.array([zu, n, (gamma - beta) / B, dnu * zu, deta * zu, zs, p * zu, q, psi / zu, dpsi, lam])
    dzu = np.zeros(14)
    dzu[[3, 4]] = -zu / (n * B)
    dzu[5] = zu * np.log(B) / n**2
    M = np.zeros((11, 14))
    M[0] = dzu
    M[1, 5] = 1.0
    M[2, 3], M[2, 4] = -2 * gamma / B**2, 2 * beta / B**2
    for row, rate, col in ((3, dnu, 6), (4, deta, 7), (6, p, 9)):
        M[row] = rate * dzu
        M[row, col] += zu
    M[5, 8] = M[7, 10] = M[9, 12] = M[10, 13] = 1.0
    M[8] = -psi / zu**2 * dzu
    M[8, 11] += 1.0 / zu
    return theta, zu, M


class BoucWenBaberNoori(Model):
    name = "bwbn"
    title = "degrading, pinching Bouc-Wen model (Baber–Noori, Foliente)"
    reference = (
        "T. T. Baber, M. N. Noori, Random vibration of degrading, pinching systems, J. Eng. Mech. "
        "111(8):1010-1026, 1985; G. C. Foliente, Hysteresis modeling of wood joints and structural "
        "systems, J. Struct. Eng. 121(6):1013-1022, 1995; F. Ma, H. Zhang, A. Bockstedte, G. C. Foliente, "
        "P. Paevere, Parameter analysis of the differential model of hysteresis, J. Appl. Mech. "
        "71(3):342-349, 2004"
    )
    default_formulation = "identifiable"
    rate_independent = True  # z is integrated in displacement

    def direct_parameters(self, state=None) -> tuple:
        return DIRECT

    def direct_box(self, signal, f, state=None) -> Box:
        a, T = amplitude(signal.x), travel(signal.x)
        F = max(float(np.max(np.abs(f))), 1e-12)
        v = max(float(np.max(np.abs(signal.v))), 1e-12)
        lo = [1e-2 * F / a, -0.5, 0.0, 1e-8, 1e-8, 1.0, 1e-3 / (a * T), 1e-3 / (a * T), 0.0, 1e-2 / (a * T)]
        hi = [1e2 * F / a, 1.0, 0.2 * F / v, 10.0, 10.0, 10.0, 1e2 / (a * T), 1e2 / (a * T), 0.99, 1e3 / (a * T)]
        lo += [0.0, 1e-3 * a, 1e-3 / T, 1e-3]
        hi += [1.0, 2.0 * a, 10.0 / T, 2.0]
        log = [True, False, False, True, True, True, True, True, False, True, False, True, True, True]
        return Box(tuple(p.name for p in DIRECT), np.array(lo), np.array(hi), np.array(log))

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        P = np.atleast_2d(np.asarray(P, dtype=float))
        out = np.empty((len(P), len(signal.x)))
        for r, row in enumerate(P):
            theta, zu, _ = _theta_of_direct(row)
            k, alpha, c = row[:3]
            w = self.trajectories(theta[None, :], signal)[0]
            with np.errstate(invalid="ignore", over="ignore"):
                out[r] = c * signal.v + alpha * k * signal.x + (1 - alpha) * k * zu * w
        return np.where(np.all(np.isfinite(out), axis=1)[:, None], out, np.inf)

    def hysteretic_parameters(self, state=None) -> tuple:
        return HYSTERETIC

    def hysteretic_box(self, signal, f, state=None) -> Box:
        a, T = amplitude(signal.x), travel(signal.x)
        ranges = {
            "xy": (XY_RANGE[0] * a, XY_RANGE[1] * a, True),
            "n": (*N_RANGE, True),
            "eta": (*ETA_RANGE, False),
            "zeta_s": (*ZETA_S_RANGE, False),
            "q": (*Q_RANGE, False),
            "psi_w": (*PSI_RANGE, True),
            "lambda": (*LAMBDA_RANGE, True),
        }
        for name in ("dnu_e", "deta_e", "p_e", "dpsi"):
            ranges[name] = (RATE_RANGE[0] / T, RATE_RANGE[1] / T, True)
        rows = [ranges[name] for name in THETA_NAMES]
        return Box(THETA_NAMES, *(np.array(col) for col in zip(*rows)))

    def linear_layout(self, state=None) -> LinearLayout:
        return LAYOUT

    def trajectories(self, theta, signal, state=None) -> np.ndarray:
        """w = z/z_u0 (–) at the samples for θ rows (m, 11); +inf rows where the simulation did not finish."""
        s = signal
        return kernel.trajectories(np.atleast_2d(np.asarray(theta, dtype=float)), s.t, s.x, s.v)

    # An evaluation with its sensitivities (11 of them: 24 states against 2) took 1.9–2.3 plain one-point
    # simulations in the identifiable formulation and 2.6–3.1 in the direct one (random points of the box
    # and a fit's optimum, benchmarks/bench_call_cost.py): charged as 4, against 11 or 14 for differences.
    sensitivity_cost = 4

    def trajectory_sensitivities(self, theta, signal, state=None):
        """(w (L,), ∂w/∂θ (L, 11)) of one θ, by RK4 on the variational equations along the kernel's own
        stages; (+inf w, None) where the simulation did not finish."""
        s = signal
        return kernel.sensitivities(theta, s.t, s.x, s.v)

    def force_sensitivities(self, P, signal, state=None):
        """(force (L,) N, ∂F/∂P (L, 14)) of one direct vector, exact: the trajectory's sensitivities
        carried through the map to the identifiable θ; None where the simulation did not finish."""
        P = np.asarray(P, dtype=float)
        theta, zu, M = _theta_of_direct(P)
        w, dW = self.trajectory_sensitivities(theta, signal)
        if dW is None:
            return None
        k, alpha, c = P[:3]
        x, v = np.asarray(signal.x, dtype=float), np.asarray(signal.v, dtype=float)
        F = c * v + alpha * k * x + (1 - alpha) * k * zu * w
        dF = (1 - alpha) * k * zu * (dW @ M)
        dF[:, 0] += alpha * x + (1 - alpha) * zu * w
        dF[:, 1] += k * x - k * zu * w
        dF[:, 2] += v
        dF += np.outer((1 - alpha) * k * w, M[0])  # through z_u0 = x_y in the force's h
        return F, dF

    def to_direct(self, theta, coef: dict, state=None):
        """The 14 direct parameters of the same loops (A = 1, so z_u0 = x_y); None when k + h/x_y ≤ 0
        (no positive initial stiffness). The direct force has no mass and no offset: m and f are left
        out (reported beside)."""
        theta = np.asarray(theta, dtype=float)
        xy, n, eta, dnu, deta, zs, p, q, psi, dpsi, lam = theta
        c, k_lin, h = coef["c"], coef["k"], coef["h"]
        if not np.all(np.isfinite([*theta, c, k_lin, h])):
            return None
        k = k_lin + h / xy
        if not k > 0:
            return None
        B = xy**-n
        beta, gamma = B * (1 - eta) / 2, B * (1 + eta) / 2
        return np.array([k, k_lin / k, c, beta, gamma, n, dnu / xy, deta / xy, zs, p / xy, q, psi * xy, dpsi, lam])

    def from_direct(self, P, state=None):
        theta, zu, _ = _theta_of_direct(P)
        k, alpha, c = np.asarray(P[:3], dtype=float)
        return theta, {"m": 0.0, "c": c, "k": alpha * k, "h": (1 - alpha) * k * zu, "f": 0.0}

    def coefficient_limits(self, state=None) -> dict:
        # k (= α·k) is not bounded: a column under axial load softens after yield (P-Δ, α < 0).
        return {"h": (0.0, np.inf, "h ≥ 0: the hysteretic force lags the motion and so dissipates")}

    def parameter_limits(self, state=None) -> dict:
        none_within = "no {} within the record (the rate times the travel is below 10⁻³)"
        return {
            "eta": {"upper": "η = 1 is β = 0, the model's limit (beyond it unloading runs away from saturation)"},
            "n": {"lower": "n = 1 is the model's limit here (below it the yield rate is unbounded at w = 0)"},
            "dnu_e": {"lower": none_within.format("strength degradation")},
            "deta_e": {"lower": none_within.format("stiffness degradation")},
            "p_e": {"lower": none_within.format("pinching onset")},
            "dpsi": {"lower": none_within.format("growth of the pinching's width")},
            "zeta_s": {
                "lower": "ζ_s = 0 is no pinching",
                "upper": "ζ_s → 1 is the model's limit (a pinched branch with no stiffness at all)",
            },
            "q": {
                "lower": "q = 0 is the model's limit: pinching centred on zero force",
                "upper": "q = 1 is the model's limit: pinching at the ultimate force",
            },
        }

    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        return {"": values["c"]} if "c" in values else None

    def plausibility(self, values: dict, signal, state=None) -> list:
        """[(name, value, unit, meaning, verdict)] of the identifiable fit's parameters (``Model.plausibility``)."""
        a = amplitude(signal.x)
        units = {p.name: p.unit for p in HYSTERETIC} | dict(LAYOUT.units)
        meanings = {p.name: p.description for p in HYSTERETIC} | {
            "c": "viscous damping (≥ 0)",
            "k": "post-yield stiffness α·k (negative: softening after yield, P-Δ)",
            "h": "force of the saturated hysteretic element (its yield force, ≥ 0)",
            "f": "constant force offset (a preload or the load cell's zero)",
        }
        rows = []
        for name, meaning in meanings.items():
            value = values.get(name)
            if isinstance(value, (int, float)) and np.isfinite(value):
                verdict = ""
                if name == "xy" and value > a:
                    verdict = f"x_y > the amplitude {a:.3g} mm: no yield within the stroke"
                rows.append((name, float(value), units[name], meaning, verdict))
        return rows


MODEL = BoucWenBaberNoori()
