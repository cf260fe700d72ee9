"""The BEAM's local coordinate layout and the layout of its intermediate vectors, shared by its
stiffness, second-derivative and mass kernels.

An element vector is ``[r^p, q^p, r^q, q^q]``: the position of node p (3), the Euler
parameters of its orientation node (4), then the same for node q. The deformations depend on
it through the five vectors ``y = [d, n_y^p, n_z^p, n_y^q, n_z^q]`` (d = r^q - r^p).
"""
import numpy as np

N_LDOF = 14

#: Local coordinate slices: position p, Euler parameters at p, position q, Euler parameters at q.
RP, QP, RQ, QQ = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 14)

#: The bending modes e3..e6 of Eq. (7), ``e_j = s_j l0 (n1 . a_j)``: (sign s_j, index of the
#: nodal vector a_j in y, its name).
BENDING = ((-1.0, 2, "nzp"), (1.0, 4, "nzq"), (1.0, 1, "nyp"), (-1.0, 3, "nyq"))
BEND_SIGN = np.array([b[0] for b in BENDING])
BEND_Y = np.array([b[1] for b in BENDING])
