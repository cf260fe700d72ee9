"""Time integration: inertia forces (inertia), the generalized-alpha transient (transient), the
rotating frame a step is taken in (frame), and the linearized equations along a trajectory
(trajectory)."""
