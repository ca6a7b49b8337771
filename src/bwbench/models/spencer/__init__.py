"""bwbench.models.spencer."""
