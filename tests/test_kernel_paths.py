"""The element kernels' fast paths equal their general paths and the finite differences:
the BEAM's dense second derivatives (``dense=True``, groups of up to ``DENSE_MAX``
elements) against the block-by-block ones and central differences; the HINGE's
deformations alone against its full state's; the RBEAM with the kind's stacked reference
axes and without, the BEAM's mass kernels with its kept section inertia forms and without."""
import numpy as np
import pytest
from test_beam import random_elements

from spacarpy.elements.beam import (
    DENSE_MAX,
    Beam,
    BeamReference,
    beam_deformations,
    beam_state,
    beam_tangent,
    beam_weighted_hessian,
)
from spacarpy.elements.beam_mass import (
    beam_convective,
    beam_inertia_force,
    beam_mass_matrix,
    section_axes,
)
from spacarpy.elements.hinge import Hinge, hinge_deformations, hinge_reference, hinge_state
from spacarpy.elements.plhinge import PlHinge
from spacarpy.elements.rbeam import rbeam_reference, rbeam_state
from spacarpy.rotation import from_axis_angle

VARIANTS = ("basic", "modified")


@pytest.mark.parametrize("variant", VARIANTS)
def test_dense_and_blocked_second_derivatives_agree(variant):
    rng = np.random.default_rng(21)
    x, ny, nz, l0 = random_elements(rng, 30)
    st = beam_state(x, ny, nz, l0, variant)
    st_dense = beam_state(x, ny, nz, l0, variant, dense=True)    # with dy/dx kept
    assert st.z is None and st_dense.z is not None
    np.testing.assert_array_equal(st_dense.e, st.e)
    np.testing.assert_allclose(st_dense.D, st.D, rtol=0, atol=1e-15 * np.abs(st.D).max())
    w = rng.normal(size=(30, 6))
    s = rng.normal(size=(30, 6, 6))
    s = s + s.transpose(0, 2, 1)
    for dense, blocked in ((beam_weighted_hessian(st, w, True), beam_weighted_hessian(st, w)),
                           (beam_weighted_hessian(st_dense, w, True),
                            beam_weighted_hessian(st, w)),
                           (beam_tangent(st_dense, s, w, True), beam_tangent(st, s, w)),
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
    ref = BeamReference(np.cross(ny, nz), ny, nz, l0, u=np.stack([ny, nz], axis=1))
    st = kind.state(x, ref, "modified", {})
    np.testing.assert_array_equal(st.e, beam_deformations(x, ny, nz, l0, "modified"))
    w = rng.normal(size=(n, 6))
    s = np.tile(np.eye(6), (n, 1, 1))
    big = kind.tangent(st, s, w)
    np.testing.assert_array_equal(big, beam_tangent(st, s, w, dense=False))
    small_ref = ref.take(slice(DENSE_MAX))
    small = kind.tangent(kind.state(x[:DENSE_MAX], small_ref, "modified", {}), s[:DENSE_MAX],
                         w[:DENSE_MAX])
    np.testing.assert_allclose(small, big[:DENSE_MAX], rtol=0,
                               atol=1e-13 * np.abs(big).max())


def _hinge_data(n, seed):
    rng = np.random.default_rng(seed)
    a, b, c = hinge_reference(rng.normal(size=(n, 3)))
    x = np.concatenate([from_axis_angle(rng.normal(size=(n, 3)), 2.0 * rng.normal(size=n)),
                        from_axis_angle(rng.normal(size=(n, 3)), 2.0 * rng.normal(size=n))],
                       axis=1)
    return rng, x, a, b, c


@pytest.mark.parametrize("previous", [None, "array", 20.0])
def test_hinge_deformations_alone_equal_those_of_the_full_state(previous):
    rng, x, a, b, c = _hinge_data(15, 24)
    prev = rng.normal(size=15) * 10.0 if previous == "array" else previous
    st = hinge_state(x, a, b, c, prev)
    e = hinge_deformations(x, a, b, c, prev)
    assert np.all(np.abs(e - st.e) <= 1e-14 * np.maximum(1.0, np.abs(st.e)))
    if prev is not None:                    # the branch of the previous angle, as the state's
        assert np.all(np.abs(e[:, 0] - prev) <= np.pi)


def test_hinge_and_planar_hinge_kinds_give_their_states_deformations():
    rng, x, a, b, c = _hinge_data(6, 25)
    hinge, plhinge = Hinge(), PlHinge()
    ref = hinge.reference(None, rng.normal(size=(6, 3)))[0]
    prev = {"e1": rng.normal(size=6) * 7.0}
    np.testing.assert_allclose(hinge.deformations(x, ref, "modified", prev),
                               hinge.state(x, ref, "modified", prev).e, rtol=0, atol=1e-14)
    planar = from_axis_angle(np.tile([0.0, 0.0, 1.0], (6, 1)), rng.normal(size=6) * 3.0)
    xp = np.concatenate([planar, planar[::-1]], axis=1)
    pref = plhinge.reference(None, np.zeros((6, 3)))[0]
    np.testing.assert_allclose(plhinge.deformations(xp, pref, "modified", {}),
                               plhinge.state(xp, pref, "modified", {}).e, rtol=0, atol=1e-14)


def test_rbeam_state_with_and_without_the_stacked_reference_triad():
    rng = np.random.default_rng(26)
    xp = rng.normal(size=(9, 3))
    xq = xp + rng.normal(size=(9, 3))
    nx, ny, nz, l0 = rbeam_reference(xp, xq, rng.normal(size=(9, 3)))
    q = from_axis_angle(rng.normal(size=(9, 3)), rng.normal(size=9))
    x = np.concatenate([xp, q, xq + 0.1 * rng.normal(size=(9, 3))], axis=1)
    with_u = rbeam_state(x, nx, ny, nz, l0, np.stack([nx, ny, nz], axis=1))
    without = rbeam_state(x, nx, ny, nz, l0)
    for f, g in zip(with_u, without):
        np.testing.assert_array_equal(f, g)


@pytest.mark.parametrize("rotary", ["lumped", "consistent"])
def test_beam_mass_kernels_with_the_kept_section_forms_equal_those_without(rotary):
    """The kind passes its section inertia forms; a direct call makes them itself."""
    rng = np.random.default_rng(27)
    x, ny, nz, l0 = random_elements(rng, 7)
    nx = np.cross(ny, nz)
    axes = section_axes(np.stack([nx, ny, nz], axis=1))
    v, a = rng.normal(size=(7, 14)), rng.normal(size=(7, 14))
    mass = np.abs(rng.normal(size=(7, 5)))
    pairs = [(beam_mass_matrix(x, nx, ny, nz, l0, mass, rotary),
              beam_mass_matrix(x, nx, ny, nz, l0, mass, rotary, axes)),
             (beam_inertia_force(x, v, a, nx, ny, nz, l0, mass, rotary),
              beam_inertia_force(x, v, a, nx, ny, nz, l0, mass, rotary, axes))]
    pairs += list(zip(beam_convective(x, v, nx, ny, nz, l0, mass, rotary),
                      beam_convective(x, v, nx, ny, nz, l0, mass, rotary, axes)))
    for p, q in pairs:
        np.testing.assert_array_equal(p, q)
    # and the force without the mass matrix is M a + dM/dt v - grad/2
    m = beam_mass_matrix(x, nx, ny, nz, l0, mass, rotary)
    mdot, grad = beam_convective(x, v, nx, ny, nz, l0, mass, rotary)
    ref = np.einsum("nij,nj->ni", m, a) + mdot - 0.5 * grad
    np.testing.assert_allclose(pairs[1][0], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
