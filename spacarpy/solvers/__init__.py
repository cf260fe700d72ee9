"""Solvers: equilibrium, load paths, linearized analyses and time integration of a model."""
