"""bwbench.optimizers.sampling."""
