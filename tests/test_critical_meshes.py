"""Every mesh gives the same critical points (issue 34, item 1): Lee's frame, the curved
bistable beam, the perfect and the imperfect column by arc length, at each mesh of the
issue, run as ``spacarpy run`` with one and with two BLAS threads (the CLI's own setting,
the environment overriding it). The type of every stored critical point and its load factor
(to 1e-6 of the value measured here) must not depend on the thread count, and the load
factors of the meshes must converge (docs/path.md, "Critical points at every mesh").

Load factors were measured on the 2-core development machine with one BLAS thread
(2026-11-27); a point's load factor depends on round-off only through the refinement's
bracket (the solver tolerance times the step), far below 1e-6. Every run with two threads is
slow on a shared machine (the bistable beam at 16 elements: 4.9 s with one thread, 30 s
with two at a load of 7 on 2 cores), so all but the smallest column are marked slow."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import h5py
import numpy as np
import pytest

from helpers import REPO

DECKS = REPO / "decks"


def bistable_deck(n: int) -> str:
    """decks/bistable_curved_beam.dat with ``n`` elements on the half beam, pushed down by a
    dead midpoint force (1.5 times Qiu's switching force 740.7 EI h/L^3 on the whole beam,
    as in tests/test_path_cases.py) followed by arc length with ``BIFURCATION switch``."""
    text = (DECKS / "bistable_curved_beam.dat").read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith(("X ", "BEAM "))]
    body = [f"X {2 * i + 1} {{{i}*L/(2*n)}} {{h/2*(1-cos(2*pi*{i}/(2*n)))}} 0"
            for i in range(n + 1)]
    body += [f"BEAM {e} {2 * e - 1} {2 * e} {2 * e + 1} {2 * e + 2} 0 1 0"
             for e in range(1, n + 1)]
    at = next(k for k, ln in enumerate(lines) if ln.startswith("DYNE"))
    text = "\n".join(lines[:at] + body + lines[at:]) + "\n"
    half = 1.5 * 740.7 * 0.05 / 2                       # N on the half beam
    for old, new in (("SET n 16 ", f"SET n {n} "), ("FIX 33 1", f"FIX {2 * n + 1} 1"),
                     ("FIX 34 4", f"FIX {2 * n + 2} 4"),
                     ("DELINPX 33 2 {-2.04*h}", f"DELXF {2 * n + 1} 0 {-half!r} 0")):
        assert old in text, old
        text = text.replace(old, new)
    text = re.sub(r"^INPUTX 33 2.*\n", "", text, flags=re.M)
    return re.sub(r"^(ITERSTEP .*)$", r"\1\nBIFURCATION switch\nARCLENGTH 2000 0.01", text,
                  count=1, flags=re.M)


def lee_deck(m: int) -> str:
    """decks/lees_frame_arclength.dat with 20 m beams."""
    text = (DECKS / "lees_frame_arclength.dat").read_text()
    assert "SET m 2 " in text
    return text.replace("SET m 2 ", f"SET m {m} ")


def column_deck(n: int, imperfect: bool) -> str:
    """The bench's arc-length column (imperfection 1e-2, spacarpy.bench.decks) or the perfect
    one (tests/test_certificate.py), ``n`` elements."""
    from spacarpy.bench.cases import arclength_column_deck
    from spacarpy.bench.decks import arclength_deck
    return arclength_deck(n) if imperfect else arclength_column_deck(n, imperfection=0.0)


def _run(text: str, tmp_path, threads: int):
    """(point types, load factors, margins, bounds, per-step stability) of a ``spacarpy
    run`` of the deck with ``threads`` BLAS threads."""
    deck = tmp_path / f"deck{threads}.dat"
    out = tmp_path / f"out{threads}.h5"
    deck.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(REPO), OPENBLAS_NUM_THREADS=str(threads),
               OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads))
    proc = subprocess.run([sys.executable, "-m", "spacarpy", "run", str(deck), "-o", str(out),
                           "-q"], env=env, capture_output=True, text=True, cwd=REPO)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with h5py.File(out, "r") as f:
        stability = np.asarray(f["static/stability"][()], int).tolist()
        if "critical/point_type" not in f:
            return [], np.zeros(0), np.zeros(0), np.zeros(0), stability
        g = f["critical"]
        return (np.asarray(g["point_type"][()], int).tolist(),
                np.asarray(g["load_factor"][()], float), np.asarray(g["margin"][()], float),
                np.asarray(g["bound"][()], float), stability)


def _both(text: str, tmp_path):
    """The runs with one and with two BLAS threads, side by side (two cores)."""
    with ThreadPoolExecutor(2) as pool:
        return list(pool.map(lambda t: _run(text, tmp_path, t), (1, 2)))


def _check(runs, kinds, load_factors):
    """The critical points of both runs, and the same per-step stability in both (decided by
    round-off bounds: spacarpy/solvers/path/point_status.py), with a critical point's row
    marked 3 in it."""
    for got_kinds, lf, margin, bound, stability in runs:
        assert got_kinds == kinds
        assert lf == pytest.approx(load_factors, rel=1e-6, abs=1e-9)
        for k, mg, bd in zip(got_kinds, margin, bound):
            if k == 2:                           # a bifurcation: its crossing certified
                assert mg > bd
        assert stability.count(3) == len(kinds) - kinds.count(3)
    assert runs[0][4] == runs[1][4]


# --- Lee's frame: only its two limit points, 20 to 1000 beams -------------------------------
#: (load maximum, load minimum) measured per m (20 m beams); the mesh error against m = 50:
#: m = 1 1.5 % and 6 %, m = 5 6e-4 and 2.5e-3, m = 15 6e-5 and 2.5e-4 (falling as 1/m^2).
LEE = {1: (0.91382865, -0.44227874), 5: (0.92726635, -0.46955727),
       15: (0.92777300, -0.47059210), 50: (0.92783067, -0.47070992)}


@pytest.mark.slow
@pytest.mark.parametrize("m", [1, 5, 15, 50])
def test_lees_frame_has_its_two_limit_points_at_every_mesh_and_thread_count(tmp_path, m):
    _check(_both(lee_deck(m), tmp_path), [0, 1], LEE[m])


def test_lees_frame_limit_loads_converge_with_the_mesh():
    fine = np.array(LEE[50])
    for m, tol in ((1, 7e-2), (5, 3e-3), (15, 3e-4)):
        assert np.array(LEE[m]) == pytest.approx(fine, rel=tol)


# --- the curved bistable beam: its switching and its return bifurcation -------------------
#: (switching, return) load factors of 1.5 * 740.7 EI h / L^3 per n (elements on the half
#: beam); the differences 16 -> 32 -> 64 fall by 4: the mesh error goes as h^2.
BISTABLE = {16: (0.66667314, -0.33539691), 32: (0.66831985, -0.33642807),
            64: (0.66873716, -0.33669142)}


@pytest.mark.slow
@pytest.mark.parametrize("n", [16, 32, 64])
def test_the_bistable_beam_has_its_two_bifurcations_at_every_mesh(tmp_path, n):
    """The return bifurcation is seen from the crossing branch (a turn with the certified
    signs kept) at every mesh; at 32 elements the corrector left the crossing branch for the
    fundamental one just before it, and a spurious "bifurcation" at -0.3134 was stored,
    after which the path failed (now the step is halved: no eigenvalue passed zero)."""
    _check(_both(bistable_deck(n), tmp_path), [2, 2], BISTABLE[n])


def test_the_bistable_beam_bifurcations_converge_as_h_squared():
    a, b, c = (np.array(BISTABLE[n]) for n in (16, 32, 64))
    ratio = (b - a) / (c - b)
    assert np.all((3.0 < ratio) & (ratio < 5.0))


# --- the columns -------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [10, pytest.param(100, marks=pytest.mark.slow)])
def test_the_perfect_column_has_its_euler_bifurcation_with_either_thread_count(tmp_path, n):
    """Load factor 2/3 (P_E over 1.5 P_E) to the mesh error 3e-6; measured 0.66666887 at 10
    elements, 0.66666831 at 100 (tests/test_certificate.py)."""
    runs = _both(column_deck(n, imperfect=False), tmp_path)
    _check(runs, [2], {10: (0.66666887,), 100: (0.66666831,)}[n])
    stability = runs[0][4]            # proven stable before it, proven unstable after it
    at = stability.index(3)
    assert at >= 2 and set(stability[:at]) == {0} and set(stability[at + 1:]) == {1}


@pytest.fixture(scope="module")
def perfect_1000(tmp_path_factory):
    """The perfect column at 10^3 elements, run with one and with two threads."""
    return _both(column_deck(1000, imperfect=False), tmp_path_factory.mktemp("perfect"))


@pytest.mark.slow
def test_the_perfect_column_at_1000_elements_has_its_bifurcation(perfect_1000):
    """At 10^3 elements the eigenvalues nearest zero at the points that bracket the Euler
    load are 2.5e-13 and -7.1e-14 of the Jacobi-scaled tangent, below their normwise bound
    3.1e-11 (``n eps ||ks||``): the crossing was stored as undetermined. The componentwise
    bound of two shifted LDL^T factorizations (spacarpy/solvers/path/inertia_bracket.py,
    docs/path.md, Limits) proves the index there (0 before, 2 after: the double Euler
    mode), with the shift tau = 4.7e-14 above its bound 3.7e-14; the pivots' bisection
    stops at 0.66670 (their round-off), the element-wise Rayleigh quotient of the critical
    mode puts the crossing at 0.6666683, as at 100 elements; the same with either thread
    count."""
    _check(perfect_1000, [2], (0.6666683,))
    for _, _, margin, bound, _ in perfect_1000:
        assert bound[0] < margin[0] < 2 * bound[0] and bound[0] < 1e-13


@pytest.mark.slow
def test_the_imperfect_column_has_no_critical_point_at_1000_elements(tmp_path):
    """No critical point at all, and no undetermined one, with either thread count. The
    points are proven stable up to load factor 0.56 (step 28); past it the bent column's
    out-of-plane eigenvalue falls within its bound (docs/path.md, Limits): undetermined,
    never unstable."""
    runs = _both(column_deck(1000, imperfect=True), tmp_path)
    _check(runs, [], ())
    stability = runs[0][4]
    assert stability[:20] == [0] * 20 and set(stability) == {0, 2}


@pytest.fixture(scope="module")
def column_10000(tmp_path_factory):
    """The bench's imperfect column at 10^4 elements, run with one and with two threads."""
    return _both(column_deck(10000, imperfect=True), tmp_path_factory.mktemp("col"))


@pytest.mark.slow
def test_the_imperfect_column_at_10000_elements_has_no_critical_point(column_10000):
    """At 10^4 elements no round-off bound of the assembled tangent decides the sign of its
    soft bending eigenvalues (docs/path.md, Limits: 2e-17 of the Jacobi-scaled tangent
    unloaded, against a componentwise bound of 5e-14; past buckling the out-of-plane
    rotation of the bent column about its load line, 1e-19). The LDL^T pivots flipped there
    with round-off and stored up to four "undetermined" points of /critical with one thread
    and none with two. Now every point's stability is certified or undetermined by the
    bound (/static/stability): no critical point at all, the same statuses with either
    thread count, and undetermined from step 0 on (where the unloaded column is stable but
    the bound cannot tell: the honest answer at this mesh)."""
    _check(column_10000, [], ())
    for *_, stability in column_10000:
        assert set(stability) == {2}
