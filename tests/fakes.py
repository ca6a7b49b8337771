"""The cheap stand-in problem shared by the backend tests lives in ``bwbench.testing`` (plugins use it too)."""

from bwbench.testing import SphereProblem, counting_problem

__all__ = ["SphereProblem", "counting_problem"]
