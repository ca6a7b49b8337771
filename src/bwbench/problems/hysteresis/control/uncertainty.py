"""The linearised uncertainty of a fit across the control range: the covariance of the law coefficients,
searched and solved together (cov = s²·(JᵀJ)⁻¹, the solved ones' columns the design's: the variable-
projection covariance), and each coefficient with its standard error."""

from __future__ import annotations

import numpy as np


def covariance(problem, params) -> tuple[tuple, np.ndarray, float]:
    """(names, covariance (physical units), s² in N²) of the searched and solved coefficients at
    ``params`` (a dict by name or the searched vector): cov = s²·(JᵀJ)⁻¹ with J the Jacobian of the
    weighted residual over both at once (the solved ones' columns are the design's: the variable-
    projection covariance), s² = Σr²/(N − p). A solved coefficient held on a bound is a constant
    (NaN row); a direction the data do not determine gives inf."""
    values = params if isinstance(params, dict) else problem.parameters(params)
    c = np.array([values[n] for n in problem.param_names], dtype=float)
    if problem.design is not None:
        design = problem._design(problem._eta(c))
        beta = np.array([values[n] for n in design.free_names], dtype=float)
        z = problem._stacked(c[None, :])[0]
        r = design.residual(z, beta)
        dZ = _trajectory_derivatives(problem, c)
        X = np.column_stack([design.G, design.S * z[:, None]])
        if dZ is not None:
            Jc = (design.S @ beta[len(design.g_names) :])[:, None] * dZ
        else:
            Jc = _differences(problem, c, lambda cc: design.residual(problem._stacked(cc[None, :])[0], beta))
        held = (beta <= design.lower) | (beta >= design.upper) if design.bounded else np.zeros(len(beta), bool)
        J = np.column_stack([Jc, X[:, ~held]])
        names = problem.param_names + tuple(n for n, h in zip(design.free_names, held) if not h)
    else:
        found = problem.residual_jacobian(c)
        if found is None or found[1] is None:
            r = problem.residual_batch(c[None, :])[0]
            J = _differences(problem, c, lambda cc: problem.residual_batch(cc[None, :])[0])
        else:
            r, J = found
        names = problem.param_names
    dof = max(len(r) - J.shape[1], 1)
    s2 = float(r @ r) / dof
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    A = (J / scale).T @ (J / scale)
    cov = s2 * np.linalg.pinv(A, rcond=1e-12) / np.outer(scale, scale)
    cov[:, np.linalg.norm(J, axis=0) == 0] = np.inf
    return names, cov, s2


def _trajectory_derivatives(problem, c):
    """∂(stacked trajectories)/∂c (N, D), exact at constant levels, else None."""
    if problem.jacobian_cost == 0 or problem.varying:  # a varying control: differences (once per fit)
        return None
    blocks = []
    for i, part in enumerate(problem.parts):
        level = float(problem.commands[i][0])
        found = problem.model.trajectory_sensitivities(
            problem._theta(c, np.array([level]))[0], part.signal, problem.state
        )
        if found is None or found[1] is None:
            return None
        blocks.append(found[1] @ problem._theta_jacobian(c, level))
    return np.concatenate(blocks, axis=0)


def _differences(problem, c, residual, step: float = 1e-5) -> np.ndarray:
    """Central differences of ``residual`` in the box's unit coordinates, carried to physical units."""
    from bwbench.engine.box import box_derivative

    u0 = problem.to_unit(c)
    cols = []
    for j in range(len(c)):
        up, down = u0.copy(), u0.copy()
        up[j] += step
        down[j] -= step
        cols.append((residual(problem.from_unit(up)) - residual(problem.from_unit(down))) / (2 * step))
    J = np.column_stack(cols)
    return J / box_derivative(c, problem.lower, problem.upper, problem.log_scaled)[None, :]


def law_table(problem, params) -> list[dict]:
    """Each coefficient (searched and solved) with its value, standard error and unit."""
    values = params if isinstance(params, dict) else problem.parameters(params)
    names, cov, _ = problem.covariance(values)
    se = dict(zip(names, np.sqrt(np.abs(np.diag(cov)))))
    units = problem.units(list(values))
    return [
        {"name": n, "value": float(v), "stderr": float(se.get(n, np.nan)), "unit": units.get(n, "")}
        for n, v in values.items()
    ]


def uncertainty(problem, params):
    """``fit_summary.Uncertainty`` of a fit across the control range (``FitResult.summary()``, ``.report()``)."""
    import math

    from bwbench.problems.hysteresis.fit_summary import Uncertainty

    values = dict(params)
    names, cov, s2 = covariance(problem, values)
    sd = np.sqrt(np.abs(np.diag(cov)))
    stderr = {n: float(v) if math.isfinite(v) else math.inf for n, v in zip(names, sd)}
    searched = set(problem.param_names)
    roles = {n: ("searched" if n in searched else "solved") for n in names}
    for n in values:
        if n not in roles:
            roles[n] = "held"
            stderr[n] = math.nan
    chi2 = s2 * max(problem.n_data - len(names), 1)
    return Uncertainty(tuple(names), cov, stderr, roles, s2, problem.n_data, chi2)
