"""Data sets bwbench makes by simulating its models: the synthetic VPP specimens of the paper's
Tables 6–8 with their manifest, and the MR-damper tests of Spencer et al.'s model."""
