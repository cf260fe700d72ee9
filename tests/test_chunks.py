"""Element kernels evaluated in chunks (spacarpy.elements.chunks) give bit-identical results."""
import numpy as np

import spacarpy.elements.chunks as chunks
from spacarpy.elements import beam, beam_mass


def _beam_data(n, seed=0):
    rng = np.random.default_rng(seed)
    x = np.zeros((n, 14))
    x[:, 0] = np.arange(n) * 0.1
    x[:, 7] = x[:, 0] + 0.1
    x[:, :3] += 0.01 * rng.standard_normal((n, 3))
    for s in (3, 10):
        q = rng.standard_normal((n, 4)) * 0.1
        q[:, 0] = 1.0
        x[:, s:s + 4] = q / np.linalg.norm(q, axis=1)[:, None]
    ref = [np.tile([1.0, 0, 0], (n, 1)), np.tile([0, 1.0, 0], (n, 1)),
           np.tile([0, 0, 1.0], (n, 1)), np.full(n, 0.1)]
    return rng, x, ref


def test_chunked_kernels_are_bit_identical(monkeypatch):
    n = 53
    rng, x, (nx, ny, nz, l0) = _beam_data(n)
    v = rng.standard_normal((n, 14))
    w = rng.standard_normal((n, 6))
    mass = np.abs(rng.standard_normal((n, 5)))
    whole_state = beam.beam_state(x, ny, nz, l0, "modified")
    whole = (whole_state, beam.beam_weighted_hessian(whole_state, w),
             beam_mass.beam_mass_matrix(x, nx, ny, nz, l0, mass),
             beam_mass.beam_convective(x, v, nx, ny, nz, l0, mass))
    monkeypatch.setattr(chunks, "CHUNK", 7)                  # 8 chunks, the last one short
    st = chunks.in_chunks(beam.beam_state, n, x, ny, nz, l0, "modified")
    parts = (st, chunks.in_chunks(beam.beam_weighted_hessian, n, st, w),
             chunks.in_chunks(beam_mass.beam_mass_matrix, n, x, nx, ny, nz, l0, mass),
             chunks.in_chunks(beam_mass.beam_convective, n, x, v, nx, ny, nz, l0, mass))
    for a, b in zip(whole, parts):
        a, b = (a, b) if isinstance(a, tuple) else ((a,), (b,))
        for fa, fb in zip(a, b):
            assert (fa is None and fb is None) or np.array_equal(fa, fb)
    basic = chunks.in_chunks(beam.beam_state, n, x, ny, nz, l0, "basic")
    assert basic.J is None and np.array_equal(basic.e, beam.beam_state(x, ny, nz, l0,
                                                                       "basic").e)
