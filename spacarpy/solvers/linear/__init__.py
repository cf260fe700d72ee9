"""Linearized analyses about an equilibrium: the linearized matrices (linearize), natural
frequencies (eigen, eigen_tangent for large models; refine: accurate eigenvalues and poles of
wide spectra with their error bounds), buckling multipliers (buckling), nodal compliance
(compliance) and the state-space form in SPACAR's degrees of freedom (state_space)."""
