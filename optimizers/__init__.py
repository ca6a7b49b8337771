"""Optimiser backends, one module each."""
