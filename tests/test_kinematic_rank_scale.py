"""The kinematic check's rank decision does not depend on the number of elements (issue 34,
item 10): long rigid chains and arches of 10 to 1000 elements, in the plane and in space,
with a known number of free motions and redundant constraints.

Before, an arch of 40 or 80 beams (radius 100 m) with only torsion and out-of-plane bending
rigid and one redundant support was reported "NOT CLEAR" and as a mechanism with 1 free
motion and 2 redundant constraints: the unit-row Jacobian mixed the element length with the
model's length scale, and its genuine singular values (falling like 1/n^2) crossed the fixed
thresholds. The Jacobians are now equilibrated (Ruiz), and the Newton matrix's null space
(large models) is separated from genuine small singular values by a gap test.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.errors import ModelError
from spacarpy.solvers.statics.diagnose import equilibrate, null_mask
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.kinematic_check import KINEMATIC_LIMIT, dof_report, kinematic_analysis


def arch(n, rigid, end_fix="1 2 3", extra="", radius=100.0, released=()):
    """A half-circle arch of n BEAMs in the xy plane, clamped at its first node; the modes
    ``rigid`` rigid, the others stiff (DYNE, ESTIFF); ``FIX <last node> end_fix``. The
    elements of ``released`` ((element, mode) pairs) are rigid but for that mode, released
    without stiffness."""
    t = np.linspace(0.0, np.pi, n + 1)
    lines = [f"X {2 * i + 1} {radius * math.cos(a)!r} {radius * math.sin(a)!r} 0"
             for i, a in enumerate(t.tolist())]
    lines += [f"BEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4} 0 0 1"
              for i in range(n)]
    flex = " ".join(str(k) for k in range(1, 7) if k not in rigid)
    free = dict(released)
    stiff = [e for e in range(1, n + 1) if e not in free]
    lines += [f"DYNE {e} {flex}" for e in stiff]
    lines += [f"RLSE {e} {k}" for e, k in free.items()]
    lines += ["FIX 1", "FIX 2", f"FIX {2 * n + 1} {end_fix}" if end_fix else "", extra, "END",
              "HALT"]
    lines += [f"ESTIFF {e} 1e6 1e3 1e3 1e3 0 0" for e in stiff]
    lines += ["END", "END"]
    return "\n".join(lines) + "\n"


def helix(n, end_fix, extra=""):
    """A rigid helix of n BEAMs (radius 1, pitch 0.5 per turn, 2 turns), clamped at its
    first node: one rigid body."""
    t = np.linspace(0.0, 4 * np.pi, n + 1)
    lines = [f"X {2 * i + 1} {math.cos(a)!r} {math.sin(a)!r} {0.5 * a / (2 * math.pi)!r}"
             for i, a in enumerate(t.tolist())]
    lines += [f"BEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4} 0 0 1"
              for i in range(n)]
    lines += ["FIX 1", "FIX 2", f"FIX {2 * n + 1} {end_fix}" if end_fix else "", extra,
              "END", "HALT", "END", "END"]
    return "\n".join(lines) + "\n"


def plane_arch(n, end_fix, extra=""):
    """A rigid planar arch of n PLBEAMs (radius 50), clamped at its first node."""
    t = np.linspace(0.0, np.pi, n + 1)
    lines = [f"X {2 * i + 1} {50 * math.cos(a)!r} {50 * math.sin(a)!r}"
             for i, a in enumerate(t.tolist())]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}"
              for i in range(n)]
    lines += ["FIX 1", "FIX 2", f"FIX {2 * n + 1} {end_fix}" if end_fix else "", extra,
              "END", "HALT", "END", "END"]
    return "\n".join(lines) + "\n"


def analysis(text):
    model, _ = job_from_text("MODE check\n" + text, "chain.dat")
    prob = StaticProblem(model)
    assert prob.num.n_unknown + prob.num.n_constraint <= KINEMATIC_LIMIT
    return prob, kinematic_analysis(prob)


def counts(ka):
    return len(ka.motions), len(ka.redundant)


SIZES = [10, 20, 40, 80]


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("end_fix,extra,released,expected", [
    ("1 2", "", 0, (0, 0)),                    # the far end on a roller: determinate
    ("1 2 3", "", 0, (0, 1)),                  # the reported case: one redundant support
    ("1 2 3", "FIX {mid} 3", 0, (0, 2)),       # and the crown held too
    ("1 2", "", 1, (1, 0)),                    # a torsion released: a free motion
    ("1 2", "", 2, (2, 0)),                    # and a bending at the clamp
])
def test_arch_with_rigid_torsion_and_out_of_plane_bending(n, end_fix, extra, released,
                                                          expected):
    extra = extra.format(mid=n + 1)
    rel = [(n // 2, 2), (1, 5)][:released]
    prob, ka = analysis(arch(n, (2, 5, 6), end_fix, extra, released=rel))
    assert counts(ka) == expected
    assert ka.clear, ka.rank.describe()
    report = dof_report(prob)
    assert "NOT CLEAR" not in report
    if expected[1]:
        assert f"'RLSE {n} 5' releases it" in report        # the last element's mode named
    if expected[0]:
        assert "nodes that move:" in report


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("end_fix,extra,expected", [
    ("", "", (0, 0)), ("1", "", (0, 1)), ("1 2", "", (0, 2)),
    ("", "RLSE {k} 2", (1, 0)), ("", "RLSE {k} 2\nRLSE 2 3", (2, 0)),
])
def test_rigid_helix_in_space(n, end_fix, extra, expected):
    _, ka = analysis(helix(n, end_fix, extra.format(k=n // 2)))
    assert counts(ka) == expected and ka.clear


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("end_fix,extra,expected", [
    ("", "", (0, 0)), ("1", "", (0, 1)), ("1 2", "", (0, 2)),
    ("", "RLSE {k} 2", (1, 0)), ("", "RLSE {k} 2\nRLSE 2 3", (2, 0)),
])
def test_rigid_arch_in_the_plane(n, end_fix, extra, expected):
    _, ka = analysis(plane_arch(n, end_fix, extra.format(k=n // 2)))
    assert counts(ka) == expected and ka.clear


def test_equilibration_removes_units_and_lengths():
    """Scaling rows and columns by arbitrary factors leaves the equilibrated singular values
    within a small factor; the rank and the null spaces are kept."""
    rng = np.random.default_rng(3)
    M = rng.normal(size=(6, 8)) @ np.diag([1, 1, 1, 1, 1, 0, 0, 1.0])
    M[5] = M[0] + M[1]
    big = np.diag(10.0 ** rng.uniform(-6, 6, 6)) @ M @ np.diag(10.0 ** rng.uniform(-6, 6, 8))
    S, r, c = equilibrate(big)
    assert np.abs(np.abs(S).max(axis=1) - 1).max() < 1e-2
    assert np.abs(np.abs(S).max(axis=0)[np.abs(M).max(axis=0) > 0] - 1).max() < 1e-2
    np.testing.assert_allclose(S * r[:, None] * c[None, :], big, rtol=1e-14)
    s = np.linalg.svd(S, compute_uv=False)
    assert s[4] > 1e-3 * s[0] and s[5] < 1e-12 * s[0]       # rank 5, visible


def test_null_mask_takes_the_gap_not_a_fixed_fraction():
    # genuine small values of a long chain (1e-11) above round-off zeros (1e-17)
    s = np.array([4.0, 1.0, 1e-9, 3e-11, 1e-17, 2e-18])
    np.testing.assert_array_equal(null_mask(s), [0, 0, 0, 0, 1, 1])
    # no gap: the fixed fraction decides
    np.testing.assert_array_equal(null_mask(np.array([1.0, 1e-3, 3e-11])), [0, 0, 1])


LARGE = [160, 320, 1000]


@pytest.mark.slow
@pytest.mark.parametrize("n", LARGE)
def test_large_arch_with_one_redundant_support_is_not_a_mechanism(n):
    """Beyond the dense analysis (KINEMATIC_LIMIT) the check before a run factorizes the
    Newton matrix: one redundant constraint, no free motion, at every size."""
    model, _ = job_from_text("MODE check\n" + arch(n, (2, 5, 6), "1 2 3"), "arch.dat")
    prob = StaticProblem(model)
    assert prob.num.n_unknown + prob.num.n_constraint > KINEMATIC_LIMIT
    with pytest.raises(ModelError) as exc:
        dof_report(prob)
    err = exc.value
    assert err.over_constrained and not err.mechanism, str(err)
    assert "1 redundant constraint" in str(err) and "'RLSE" in str(err)
