"""Equilibrium at one load and along a load-stepped path: the residual and Newton matrix
(equilibrium), loads, Newton's method, the kinematic correction, the tangent-space steps
(reduced), the initial kinematic check and its diagnosis, the conditioning limit, the load
path driver (static) and StepFailed (errors), which the other subpackages share."""
