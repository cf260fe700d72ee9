"""The round-off certificate of stored classifications (spacarpy/solvers/linalg/certificate.py) and
the arc-length critical points it decides: an eigenvalue within its bound is undetermined,
never a bifurcation; a path turn is caught whatever the step (issue 34, items 1 and 3)."""
from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
import scipy.linalg as sla

from spacarpy.deck import job_from_text
from spacarpy.run import run_job
from spacarpy.solvers.linalg.certificate import (
    EPS,
    SAFETY,
    UNDETERMINED,
    Certificate,
    certified_sign,
    inertia,
    round_off_bound,
)
from spacarpy.solvers.path.stability import NEAR_ZERO, certify_crossing, window_negatives

from helpers import REPO


def _matrix_with(eigenvalue: float, n: int = 40, seed: int = 3) -> np.ndarray:
    """A symmetric matrix of norm 1 (eigenvalues up to 1) with one eigenvalue given."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = np.linspace(0.1, 1.0, n)
    lam[0] = eigenvalue
    return (q * lam) @ q.T


def test_an_eigenvalue_at_round_off_is_undetermined_one_above_it_decided():
    for value, want in ((1e-17, UNDETERMINED), (-1e-17, UNDETERMINED), (1e-6, 1), (-1e-6, -1)):
        a = _matrix_with(value)
        lam = sla.eigvalsh(a)
        neg, unsure, cert = inertia(lam, np.abs(lam).max(), a.shape[0])
        sign = certified_sign(lam, round_off_bound(np.abs(lam).max(), a.shape[0]))
        assert sign[np.argmin(np.abs(lam))] == want
        assert unsure == (want == UNDETERMINED) and neg == (want == -1)
        assert cert.decided == (want != UNDETERMINED)
        # the bound is the backward error's order for this matrix: 10 n eps ||A||
        assert cert.bound == pytest.approx(SAFETY * 40 * EPS, rel=1e-12)


def test_a_crossing_needs_certified_signs_at_both_ends():
    b = np.full(2, 1e-12)
    before = (np.array([2e-9, 5e-6]), b)
    assert certify_crossing(before, (np.array([-3e-9, 5e-6]), b))[0] == "crossing"
    assert certify_crossing(before, (np.array([3e-9, 5e-6]), b))[0] == "none"
    verdict, cert = certify_crossing(before, (np.array([-4e-13, 5e-6]), b))
    assert verdict == "undetermined" and cert.margin == 4e-13 and not cert.decided


def test_the_index_without_pivots_is_counted_in_the_common_window():
    """A pair crossing (the determinant keeps its sign) changes the count; an eigenvalue
    that leaves one set at its far end (outside the other's window) does not."""
    b = np.full(NEAR_ZERO, 1e-12)
    before = (np.array([1e-8, 2e-8, 3e-6, 4e-6, 5e-6, -6e-6]), b)
    pair = (np.array([-1e-8, -2e-8, 3e-6, 4e-6, 5e-6, -6e-6]), b)
    assert window_negatives(before, pair) == (1, 3)
    assert certify_crossing(before, pair)[0] == "crossing"
    drifted = (np.array([1e-8, 2e-8, 3e-6, 4e-6, 5e-6, 5.5e-6]), b)    # -6e-6 moved away
    assert window_negatives(before, drifted) == (0, 0)
    assert certify_crossing(before, drifted)[0] == "none"


def _critical(path):
    with h5py.File(path, "r") as f:
        g = f["critical"]
        return (np.asarray(g["point_type"][()], int).tolist(),
                np.asarray(g["load_factor"][()], float), np.asarray(g["margin"][()]),
                np.asarray(g["bound"][()]))


@pytest.mark.parametrize("ds", ["0.05", "0.02"])
def test_the_shallow_truss_snap_through_is_not_stepped_over(tmp_path, ds):
    """decks/two_bar_truss_arclength.dat: with ds0 = 0.05 a step jumped over both limit
    points (the determinant and the load tangent changed sign twice); now the tangent's turn
    halves it. Closed form of both limit loads: +-95.3029199790 N of the 200 N reference."""
    text = (REPO / "decks" / "two_bar_truss_arclength.dat").read_text()
    text = re.sub(r"^ARCLENGTH 400 0\.02", f"ARCLENGTH 400 {ds}", text, flags=re.M)
    out = tmp_path / "truss.h5"
    run_job(job_from_text(text, "truss.dat"), out)
    kinds, lf, margin, bound = _critical(out)
    assert kinds == [0, 1]
    assert 200 * lf == pytest.approx([95.3029199790, -95.3029199790], rel=1e-9)
    assert np.all(margin > bound)


def _column(tmp_path, n: int, imperfection: float):
    from spacarpy.bench.cases import arclength_column_deck
    from spacarpy.bench.decks import arclength_deck
    text = (arclength_column_deck(n, imperfection=0.0) if imperfection == 0.0
            else arclength_deck(n))
    out = tmp_path / "column.h5"
    run_job(job_from_text(text, "column.dat"), out)
    with h5py.File(out, "r") as f:
        if "critical/point_type" not in f:
            return [], np.zeros(0), np.zeros(0), np.zeros(0)
    return _critical(out)


@pytest.mark.parametrize("n", [10, 30, 100])
def test_the_perfect_column_has_its_euler_bifurcation_at_every_mesh(tmp_path, n):
    """The clamped-free unit column under 1.5 P_E without imperfection: one bifurcation at
    P_E = pi^2 EI / (4 L^2), load factor 2/3 (two equal bending modes cross zero together:
    the determinant's sign is unchanged, the index of the LDL^T rises by 2), certified.
    Measured 0.66666887 (10 elements), 0.66666831 (100): the mesh error 3e-6."""
    kinds, lf, margin, bound = _column(tmp_path, n, 0.0)
    assert kinds == [2]
    assert lf[0] == pytest.approx(2.0 / 3.0, rel=1e-5)
    assert margin[0] > bound[0]


@pytest.mark.slow
def test_the_imperfect_bench_column_has_no_critical_point(tmp_path):
    """The bench's arc-length column (imperfection 1e-2, 10^3 elements): a smooth path, no
    critical point (the docs' Limits recorded spurious bifurcations at 10^4)."""
    kinds, _, _, _ = _column(tmp_path, 1000, 1e-2)
    assert kinds == []


def test_an_eigenmode_whose_w2_is_within_round_off_is_undetermined():
    """docs/linearized.md: w^2 is unstable only when certified negative; a mode that deforms
    elements with |w^2| within SAFETY n eps lambda_max is undetermined (frequency 0), a
    rigid-body mode stays rigid-body, and the bound scales with the pencil's largest
    eigenvalue (or the largest K_ii / M_ii where only a few were computed)."""
    from types import SimpleNamespace

    import scipy.sparse as sp

    from spacarpy.solvers.linear import eigen as E
    lam_all = np.array([-1e-3, -1e-14, 1e-14, 3e-14, 2.0])
    bound = E.sign_bound(lam_all, None, lam_all.size)
    assert bound == pytest.approx(SAFETY * 5 * EPS * 2.0, rel=1e-12)
    lam = lam_all.astype(complex)
    rigid = np.array([False, False, False, True, False])
    kind = E.classify(lam, rigid, bound)
    assert kind.tolist() == [E.UNSTABLE, E.UNDETERMINED_SIGN, E.UNDETERMINED_SIGN,
                             E.RIGID_BODY, E.ELASTIC]
    f = E.frequencies(lam, kind)
    assert f[0] < 0 and f[1] == f[2] == f[3] == 0.0 and f[4] > 0
    # the bare sign (bound 0) is what decided before
    assert E.classify(lam, rigid).tolist()[:3] == [E.UNSTABLE, E.UNSTABLE, E.ELASTIC]
    # a few eigenvalues computed: the diagonal ratio 50 is the larger scale
    lin = SimpleNamespace(K=sp.diags([100.0, 4.0, 1.0]), M=sp.diags([2.0, 1.0, 1.0]))
    assert E.sign_bound(np.array([0.5, 1.0]), lin, 3) == pytest.approx(
        SAFETY * 3 * EPS * 50.0, rel=1e-12)
    from spacarpy.results.schema import MODE_KIND_NAMES
    assert tuple(E.KIND_NAMES[k] for k in range(len(E.KIND_NAMES))) == MODE_KIND_NAMES


def test_an_index_change_across_an_undetermined_stretch_is_told_and_a_flip_is_not(
        monkeypatch):
    """spacarpy/solvers/path/point_status.py: a stretch of undetermined points between two
    certified points of the same index stores nothing (a pivot flip inside it decides
    nothing); between different indices it is a certified, unlocated change; after a
    critical point the index is compared with nothing before it. The warning names the
    undetermined steps."""
    from types import SimpleNamespace

    from spacarpy.solvers.path import point_status as ps

    def fake(prob, load, q, m=0):
        cert = Certificate(0.0, 1.0)
        return ((ps.UNDETERMINED, None, cert) if q.index is None else
                (ps.STABLE if q.index == 0 else ps.UNSTABLE, q.index, cert))
    monkeypatch.setattr(ps, "point_status", fake)
    track = ps.StatusTrack(None, None)
    seen = []
    for index in (0, None, None, 0, None, 1, None, 1):
        status, changed = track.check(SimpleNamespace(index=index))
        track.stored(status)
        seen.append((status, changed))
    assert seen == [(0, False), (2, False), (2, False), (0, False), (2, False), (1, True),
                    (2, False), (1, False)]
    track.critical()
    for index in (None, 0):          # after a critical point: nothing to compare with
        status, changed = track.check(SimpleNamespace(index=index))
        assert not changed
        track.stored(status)
    assert track.steps == [0, 2, 2, 0, 2, 1, 2, 1, 3, 2, 0]
    assert track.undetermined == [1, 2, 4, 6, 9]
    assert ps._ranges(track.undetermined) == "1-2, 4, 6, 9"
