"""The stability check of spacarpy/solvers/path/stability.py counts the index from the eigenvalues
alone and decomposes the eigenvectors only when a branch switch asks for them; both must be
exactly what one dense ``eigh`` of the Jacobi-scaled reduced tangent gives (the index, and
the modes bit for bit), and a branch's potential energy from the check's kernel states must
equal the one evaluated afresh. Checked along the perfect column (helpers.perfect_column, as
in tests/test_arclength_reduced.py) past its bifurcation (index 0, then 1)."""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from spacarpy.solvers.linalg.certificate import inertia
from spacarpy.solvers.linear.eigen import null_space_basis
from spacarpy.solvers.linear.linearize import linearize
from spacarpy.solvers.path.arclength import point_at
from spacarpy.solvers.path.stability import canonical_sign, potential_energy, stability

from helpers import perfect_column_path


def _eager(prob, x, mu, load):
    """The index and modes as one eigh gives them (the check before modes were lazy)."""
    lin = linearize(prob, x, mu, load)
    T = null_space_basis(lin.C, prob.pattern.n_x)
    k = T.T @ (lin.K @ T)
    k = 0.5 * (k + k.T)
    d = np.sqrt(np.abs(np.diag(k)))
    d = np.where(d > 1e-300, d, 1.0)
    lam, v = sla.eigh(k / d[:, None] / d[None, :])
    index, unsure, _ = inertia(lam, np.abs(lam).max(), lam.size)
    assert unsure == 0
    return index, canonical_sign(T @ (v[:, :max(index, 1)] / d[:, None]))


def test_lazy_modes_and_index_equal_one_eigh():
    prob, path, steps = perfect_column_path(setting="warn")
    seen = set()
    for step in steps:
        p = point_at(path, step)
        load = path.load(p.s)
        st = stability(prob, p.x, p.mu, load)
        index, modes = _eager(prob, p.x, p.mu, load)
        assert st.index == index == (0 if p.s < 1 / 1.5 else 1)
        assert np.array_equal(st.modes, modes)
        assert potential_energy(prob, p.x, p.mu, load, st.states) == \
            potential_energy(prob, p.x, p.mu, load)
        seen.add(index)
    assert seen == {0, 1}
