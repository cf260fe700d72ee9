"""Linear algebra of the solvers: the sparse factorizations chosen on measurements (sparse) and
the block forward substitution for the square Jacobian of trees (triangular). Lowest layer of
solvers/: imports nothing else from it."""
