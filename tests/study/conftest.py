"""Fixtures the study tests share (defined in ``robustness_helpers``)."""

from robustness_helpers import tiny_db  # noqa: F401 (a pytest fixture, found here by name)
