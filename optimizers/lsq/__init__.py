"""bwbench.optimizers.lsq."""
