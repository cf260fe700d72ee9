"""The BEAM's local coordinate layout, shared by its stiffness and mass kernels.

An element vector is ``[r^p, q^p, r^q, q^q]``: the position of node p (3), the Euler
parameters of its orientation node (4), then the same for node q.
"""

N_LDOF = 14

#: Local coordinate slices: position p, Euler parameters at p, position q, Euler parameters at q.
RP, QP, RQ, QQ = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 14)
