"""The element kernels' fast paths for small groups equal their general paths and the finite
differences: the BEAM's dense second derivatives (``dense=True``, groups of up to
``DENSE_MAX`` elements) against the block-by-block ones and central differences."""
import numpy as np
import pytest
from test_beam import random_elements

from spacarpy.elements.beam import (
    DENSE_MAX,
    Beam,
    beam_deformations,
    beam_state,
    beam_tangent,
    beam_weighted_hessian,
)

VARIANTS = ("basic", "modified")


@pytest.mark.parametrize("variant", VARIANTS)
def test_dense_and_blocked_second_derivatives_agree(variant):
    rng = np.random.default_rng(21)
    x, ny, nz, l0 = random_elements(rng, 30)
    st = beam_state(x, ny, nz, l0, variant)
    w = rng.normal(size=(30, 6))
    s = rng.normal(size=(30, 6, 6))
    s = s + s.transpose(0, 2, 1)
    for dense, blocked in ((beam_weighted_hessian(st, w, True), beam_weighted_hessian(st, w)),
                           (beam_tangent(st, s, w, True), beam_tangent(st, s, w))):
        scale = np.abs(blocked).max(axis=(1, 2))[:, None, None]
        assert np.all(np.abs(dense - blocked) <= 1e-13 * scale)


@pytest.mark.parametrize("variant", VARIANTS)
def test_dense_hessian_equals_central_differences_of_the_jacobian(variant):
    rng = np.random.default_rng(22)
    x, ny, nz, l0 = random_elements(rng, 12)
    w = rng.normal(size=(12, 6))
    h = beam_weighted_hessian(beam_state(x, ny, nz, l0, variant), w, dense=True)
    step = 1e-6
    fd = np.zeros_like(h)
    for k in range(14):
        dx = np.zeros(14)
        dx[k] = step
        dp = beam_state(x + dx, ny, nz, l0, variant).D
        dm = beam_state(x - dx, ny, nz, l0, variant).D
        fd[:, :, k] = np.einsum("ni,nij->nj", w, dp - dm) / (2 * step)
    scale = np.abs(h).max(axis=(1, 2))[:, None, None]
    assert np.all(np.abs(fd - h) <= 1e-7 * scale)


def test_the_kind_takes_the_dense_path_for_small_groups_only():
    """The BEAM kind's choice is the group's size; both sizes give the same tangent."""
    rng = np.random.default_rng(23)
    n = DENSE_MAX + 1
    x, ny, nz, l0 = random_elements(rng, n)
    kind = Beam()
    ref = dict(ny=ny, nz=nz, l0=l0, u=np.stack([ny, nz], axis=1))
    st = kind.state(x, ref, "modified", {})
    np.testing.assert_array_equal(st.e, beam_deformations(x, ny, nz, l0, "modified"))
    w = rng.normal(size=(n, 6))
    s = np.tile(np.eye(6), (n, 1, 1))
    big = kind.tangent(st, s, w)
    np.testing.assert_array_equal(big, beam_tangent(st, s, w, dense=False))
    small_ref = {k: v[:DENSE_MAX] for k, v in ref.items()}
    small = kind.tangent(kind.state(x[:DENSE_MAX], small_ref, "modified", {}), s[:DENSE_MAX],
                         w[:DENSE_MAX])
    np.testing.assert_allclose(small, big[:DENSE_MAX], rtol=0,
                               atol=1e-13 * np.abs(big).max())
