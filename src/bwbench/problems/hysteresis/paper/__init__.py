"""What only the VPP paper (Zalewski et al.) needs: its parameter tables, its non-uniqueness against the
Table 5 box, and the paper-only problems used by tests and benchmarks."""
