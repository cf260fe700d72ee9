"""Following the equilibrium path beyond load stepping: stability along the path and switching
to a stable branch (stability), arc-length continuation through limit points (arclength)."""
