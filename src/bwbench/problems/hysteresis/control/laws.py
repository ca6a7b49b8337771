"""Laws: how a parameter depends on the control u (current, voltage, underpressure).

Built-in laws are written in the values of the parameter at nodes of the fitted control range
[u_lo, u_hi] (Lagrange form), not in monomial coefficients: a node value has the parameter's own unit
and the parameter's own search box (a log-scaled one stays log-scaled), and a bound on the parameter
(c₁ ≥ 0) holds at every node. The monomial coefficients are reported beside (``monomials``).

- ``constant``: θ(u) = θ (one coefficient, the parameter's own name);
- ``linear``: θ at u_lo and u_hi, θ(u) = θ_lo·ℓ_lo(u) + θ_hi·ℓ_hi(u) = a₀ + a₁·u;
- ``quadratic``: θ at u_lo, (u_lo + u_hi)/2 and u_hi = a₀ + a₁·u + a₂·u²;
- ``exponential``: θ at u_lo and u_hi, θ(u) = θ_lo^ℓ_lo(u)·θ_hi^ℓ_hi(u) = a·exp(b·u) (θ > 0);
- ``CallableLaw(function, coefficients)``: θ(u) = function(u, *c), a user's law of named coefficients,
  each searched in the box given.

The first three are linear in their coefficients (``basis``): on a coefficient the force is linear in
(a solved one) they are extra columns ℓ_k(u)·g of the linear solve. The coefficient of a law is named
``<parameter>@<node><unit>`` (``alpha@2.25V``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bwbench.errors import UserError

BUILT_IN = ("constant", "linear", "quadratic", "exponential")


class Law:
    """A law of one parameter of u; see the module docstring. ``n``: its coefficients; ``linear``: θ is
    linear in them (``basis``)."""

    name = "law"
    n = 1
    linear = True
    needs_positive = False

    def nodes(self, lo: float, hi: float) -> np.ndarray:
        raise NotImplementedError

    def basis(self, u, nodes) -> np.ndarray:
        """(L, n): θ(u) = basis(u)·c for a law linear in its coefficients c."""
        raise NotImplementedError

    def value(self, c, u, nodes) -> np.ndarray:
        """θ at each u (L,) for the coefficients c (n,) (rows (m, n) give (m, L))."""
        return np.asarray(c, dtype=float) @ self.basis(u, nodes).T

    def jacobian(self, c, u, nodes) -> np.ndarray:
        """∂θ(u)/∂c (L, n) at one coefficient vector c."""
        return self.basis(u, nodes)

    def coefficient_names(self, parameter: str, nodes, unit: str) -> list[str]:
        if self.n == 1:
            return [parameter]
        return [f"{parameter}@{node:g}{unit}" for node in nodes]

    def monomials(self, c, nodes) -> dict:
        """The law's coefficients in its closed form (a₀, a₁, ... or a, b), with the formula."""
        return {}


class Constant(Law):
    name = "constant"
    n = 1

    def nodes(self, lo, hi):
        return np.array([0.5 * (lo + hi)])

    def basis(self, u, nodes):
        return np.ones((np.size(u), 1))

    def monomials(self, c, nodes):
        return {"formula": "θ(u) = a0", "a0": float(c[0])}


class Polynomial(Law):
    """θ(u) through its values at ``n`` equally spaced nodes of [u_lo, u_hi] (Lagrange form)."""

    def __init__(self, name: str, degree: int):
        self.name, self.n = name, degree + 1

    def nodes(self, lo, hi):
        return np.linspace(lo, hi, self.n)

    def basis(self, u, nodes):
        u = np.atleast_1d(np.asarray(u, dtype=float))
        B = np.ones((len(u), self.n))
        for k in range(self.n):
            for j in range(self.n):
                if j != k:
                    B[:, k] *= (u - nodes[j]) / (nodes[k] - nodes[j])
        return B

    def monomials(self, c, nodes):
        a = np.linalg.solve(np.vander(np.asarray(nodes, dtype=float), self.n, increasing=True), np.asarray(c, float))
        terms = " + ".join(["a0", "a1·u", "a2·u²"][: self.n])
        return {"formula": f"θ(u) = {terms}", **{f"a{k}": float(v) for k, v in enumerate(a)}}


class Exponential(Law):
    """θ(u) = θ_lo^ℓ_lo(u)·θ_hi^ℓ_hi(u) = a·exp(b·u): log θ linear in u, θ > 0."""

    name = "exponential"
    n = 2
    linear = False
    needs_positive = True

    def nodes(self, lo, hi):
        return np.array([lo, hi], dtype=float)

    def _ell(self, u, nodes):
        return Polynomial("linear", 1).basis(u, nodes)

    def value(self, c, u, nodes):
        c = np.asarray(c, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_c = np.where(c > 0, np.log(np.where(c > 0, c, 1.0)), np.nan)
        return np.exp(log_c @ self._ell(u, nodes).T)

    def jacobian(self, c, u, nodes):
        c = np.asarray(c, dtype=float)
        return self.value(c, u, nodes)[:, None] * self._ell(u, nodes) / c[None, :]

    def monomials(self, c, nodes):
        lo, hi = nodes
        b = math.log(c[1] / c[0]) / (hi - lo) if c[0] > 0 and c[1] > 0 else math.nan
        return {"formula": "θ(u) = a·exp(b·u)", "a": float(c[0] * math.exp(-b * lo)), "b": b}


@dataclass
class CallableLaw(Law):
    """A user's law θ(u) = function(u, *c) of named coefficients, each searched in ``coefficients[name] =
    (lower, upper)`` (``log``: names searched on a log scale). ∂θ/∂c by central differences of the law
    (a cheap function of u: the chain rule through the model stays exact)."""

    function: object = None
    coefficients: dict = field(default_factory=dict)
    log: tuple = ()
    name: str = "callable"

    def __post_init__(self):
        if not callable(self.function):
            raise UserError(f"a callable law needs a function of (u, *coefficients), got {self.function!r}")
        if not self.coefficients:
            raise UserError("a callable law needs its coefficients: {name: (lower, upper)}")
        self.n = len(self.coefficients)
        self.linear = False

    def nodes(self, lo, hi):
        return np.array([lo, hi], dtype=float)

    def coefficient_names(self, parameter, nodes, unit):
        return [f"{parameter}@{name}" for name in self.coefficients]

    def value(self, c, u, nodes):
        c = np.asarray(c, dtype=float)
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if c.ndim == 2:
            return np.array([self.value(row, u, nodes) for row in c])
        with np.errstate(all="ignore"):
            out = np.asarray(self.function(u, *c), dtype=float)
        return np.broadcast_to(out, u.shape).astype(float)

    def jacobian(self, c, u, nodes):
        c = np.asarray(c, dtype=float)
        J = np.empty((np.size(u), self.n))
        for k in range(self.n):
            h = 1e-6 * max(abs(c[k]), 1e-8)
            up, down = c.copy(), c.copy()
            up[k] += h
            down[k] -= h
            J[:, k] = (self.value(up, u, nodes) - self.value(down, u, nodes)) / (2 * h)
        return J

    def box(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        names = list(self.coefficients)
        lower = np.array([float(self.coefficients[n][0]) for n in names])
        upper = np.array([float(self.coefficients[n][1]) for n in names])
        return lower, upper, np.array([n in self.log for n in names])


def law_of(spec) -> Law:
    """A ``Law`` from a name (``BUILT_IN``) or a ``Law``; a plain callable needs ``CallableLaw``."""
    if isinstance(spec, Law):
        return spec
    if spec == "constant":
        return Constant()
    if spec == "linear":
        return Polynomial("linear", 1)
    if spec == "quadratic":
        return Polynomial("quadratic", 2)
    if spec == "exponential":
        return Exponential()
    if callable(spec):
        raise UserError("a callable law needs its coefficients: CallableLaw(function, {name: (lower, upper)})")
    raise UserError(f"unknown law {spec!r}: a law is one of {', '.join(BUILT_IN)}, auto, or a CallableLaw")


def parse(text) -> dict | str:
    """``--law alpha=quadratic,c0=linear`` as {parameter: law name}; "auto" as "auto"; a dict as given."""
    if isinstance(text, dict):
        return dict(text)
    if not isinstance(text, str) or not text.strip():
        raise UserError(f"--law must be NAME=LAW,... or auto, got {text!r}")
    if text.strip() == "auto":
        return "auto"
    out: dict = {}
    for item in text.split(","):
        name, sep, law = (p.strip() for p in item.partition("="))
        if not sep or not name or not law:
            raise UserError(f"--law {text}: {item!r} is not NAME=LAW (LAW one of {', '.join(BUILT_IN)})")
        if law not in BUILT_IN:
            raise UserError(f"--law {text}: unknown law {law!r} for {name}; a law is one of {', '.join(BUILT_IN)}")
        if name in out:
            raise UserError(f"--law {text}: {name} is given a law twice")
        out[name] = law
    return out
