"""The held slips assembled over the global coordinates (spacarpy.solvers.statics.slips)
equal the WHEEL kernels element by element and central differences of S(x) v."""
import numpy as np

from spacarpy.deck import job_from_text
from spacarpy.numbering import number_model
from spacarpy.solvers.statics.slips import held_slips

TWO_WHEELS = """X 1 0 0 0.3
X 3 0 0 0
X 4 2 0 -0.35
X 6 2 0 0
WHEEL 1 1 2 3 0 1 0
WHEEL 2 4 5 6 0 2 0
RLSE 2 5
END
HALT
END
END
"""


def model():
    return job_from_text(TWO_WHEELS, "two_wheels.dat").model


def state(num, rng):
    x = num.x0.copy()
    x += 0.05 * rng.normal(size=x.shape)
    return x, rng.normal(size=x.shape)


def test_the_held_slips_are_numbered_in_element_and_mode_order():
    hs = held_slips(number_model(model()))
    assert hs.n == 3
    assert hs.names() == ["WHEEL 1 mode 4", "WHEEL 1 mode 5", "WHEEL 2 mode 4"]


def test_assembly_equals_differences_and_the_kernels():
    rng = np.random.default_rng(3)
    num = number_model(model())
    hs = held_slips(num)
    x, v = state(num, rng)
    S = hs.jacobian(x).toarray()
    np.testing.assert_allclose(S @ v, hs.rates(x, v), rtol=1e-13, atol=1e-14)
    nu = rng.normal(size=hs.n)
    np.testing.assert_allclose(hs.force(x, nu), S.T @ nu, rtol=1e-13, atol=1e-14)
    h = 1e-6
    eye = np.eye(num.n_coord)
    d_sv = np.stack([(hs.rates(x + h * e, v) - hs.rates(x - h * e, v)) / (2 * h)
                     for e in eye], axis=1)
    scale = np.abs(d_sv).max()
    assert np.abs(hs.rates_dx(x, v).toarray() - d_sv).max() < 1e-7 * scale
    d_f = np.stack([(hs.force(x + h * e, nu) - hs.force(x - h * e, nu)) / (2 * h)
                    for e in eye], axis=1)
    assert np.abs(hs.force_dx(x, nu).toarray() - d_f).max() < 1e-7 * np.abs(d_f).max()


def test_columns_select_coordinates():
    rng = np.random.default_rng(4)
    num = number_model(model())
    hs = held_slips(num)
    x, v = state(num, rng)
    cols = np.flatnonzero(~num.fixed_mask)[::-1]
    full = hs.jacobian(x).toarray()
    np.testing.assert_array_equal(hs.jacobian(x, cols).toarray(), full[:, cols])
    nu = rng.normal(size=hs.n)
    fd = hs.force_dx(x, nu).toarray()
    np.testing.assert_array_equal(hs.force_dx(x, nu, cols).toarray(), fd[np.ix_(cols, cols)])
