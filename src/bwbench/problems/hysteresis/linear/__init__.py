"""The force's linear part (stiffness, damping, mass, offsets), solved exactly by bounded least squares
at every evaluation of the identifiable formulation: its columns, bounds, solve and the numba kernel."""
