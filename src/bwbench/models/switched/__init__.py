"""bwbench.models.switched."""
