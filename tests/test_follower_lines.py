"""Follower line loads on spatial beams and linear ones (QEL/DELQEL, issue 37,
spacarpy/solvers/statics/follower_lines.py): the load stiffness against central
differences, the lumping against the dead line load's, a 3D ring under follower pressure in
a tilted plane against 3 EI/R^3 and the planar ring, a cantilever in a rotated plane against
the planar one and against the small-load closed form, and two DELQEL with their own time
functions superposing, and Leipholz's column fluttering at its load."""
from __future__ import annotations

import h5py
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spacarpy.cli import main
from spacarpy.deck import job_from_text, model_from_text
from spacarpy.elements.line_load import lump_line_load
from spacarpy.solvers.statics.equilibrium import StaticProblem

#: Two inclined 3D beams (the second with a y-axis not normal to its chord) under a linear
#: QEL and a uniform DELQEL, and a BEAMW with a linear DELQEL.
FRAME = """X 1 0 0 0
X 3 1 0.2 0
X 5 1.5 1 0.3
X 7 1.2 1.4 1
BEAM 1 1 2 3 4 0 0 1
BEAM 2 3 4 5 6 0.3 1 0
BEAMW 3 5 6 8 7 9 10 1 0 0
FIX 1
FIX 2
END
HALT
ESTIFF 1 10 3 2 2.5
ESTIFF 2 12 3 2 2.5
ESTIFF 3 12 3 2 2.5 0 0 1
QEL 1 0.3 -0.2 0.5 0.1 0.4 -0.7
DELQEL 2 0.1 0.4 -0.3
DELQEL 3 -0.2 0.3 0.1 0.5 -0.6 0.2
END
END
"""


def _dense(part, k, n):
    out = np.zeros((n, n))
    for b in range(part.rows.shape[0]):
        np.add.at(out, (part.rows[b][:, None], part.cols[b][None, :]), k[b])
    return out


def _fd(part, x, amp, n, h=1e-6):
    fd = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        fd[:, j] = (part.force(x + e, amp, n) - part.force(x - e, amp, n)) / (2 * h)
    return fd


def test_spatial_line_load_stiffness_is_the_derivative_of_its_force():
    """At a configuration far from the reference (Euler parameters not normalized), random
    linear amplitudes: the analytic stiffness equals the central differences to 1e-8 of
    its size (measured 6e-11), and it is not symmetric."""
    prob = StaticProblem(model_from_text(FRAME, "frame.dat"))
    (part,) = prob.loads.parts
    assert part.name == "QEL line load" and part.rows.shape == (3, 14)
    rng = np.random.default_rng(1)
    n = prob.num.n_coord
    for _ in range(3):
        x = prob.num.x0 + 0.3 * rng.standard_normal(n)
        amp = rng.standard_normal(part.initial.shape)
        dense, fd = _dense(part, part.stiffness(x, amp), n), _fd(part, x, amp, n)
        scale = np.abs(fd).max()
        assert scale > 0.1
        np.testing.assert_allclose(dense, fd, rtol=0, atol=1e-8 * scale)
        assert np.abs(dense - dense.T).max() > 0.1 * scale


def test_planar_linear_line_load_stiffness_is_the_derivative_of_its_force():
    from tests.test_follower import _ring
    prob = StaticProblem(model_from_text(_ring(6, 0.4, "QEL", "DELQEL 2:4 0.3 -0.2 0.7 0.5"),
                                         "ring.dat"))
    (part,) = prob.loads.parts
    rng = np.random.default_rng(2)
    n = prob.num.n_coord
    x = prob.num.x0 + 0.3 * rng.standard_normal(n)
    amp = rng.standard_normal(part.initial.shape)
    amp[:, 2::3] = 0.0                              # a planar load has no z component
    dense, fd = _dense(part, part.stiffness(x, amp), n), _fd(part, x, amp, n)
    np.testing.assert_allclose(dense, fd, rtol=0, atol=1e-8 * np.abs(fd).max())


def test_lumping_in_the_reference_configuration_is_the_dead_line_loads():
    """In the reference configuration the element axes are the initial triad: QEL with
    components (qx, qy, qz) lumps exactly as QE with ``qx n_x + qy n_y + qz n_z`` (the
    consistent lumping of spacarpy.elements.line_load, checked there against quadrature)."""
    from spacarpy.elements.beam import reference_triads

    model = model_from_text(FRAME, "frame.dat")
    prob = StaticProblem(model)
    num = prob.num
    f = prob.loads.part_forces(num.x0, prob.loads.at(1.0, 1.0))
    x0 = {int(i): model.position_x0[k] for k, i in enumerate(model.position_ids)}
    want = np.zeros(num.n_coord)
    for ld in model.follower_line_loads:
        kw = "BEAMW" if ld.element == 3 else "BEAM"
        es = model.elements[kw]
        row = int(np.flatnonzero(es.ids == ld.element)[0])
        nodes = es.nodes[row]
        p, r, q, s = (nodes[[0, 1, 3, 4]] if kw == "BEAMW" else nodes)
        axes = reference_triads(x0[p][None], x0[q][None], es.vector[row][None])[:3]
        frame = np.stack([a[0] for a in axes], axis=1)          # columns n_x, n_y, n_z
        f_p, f_q, m_p, m_q = lump_line_load(x0[p], x0[q], frame @ ld.q_p, frame @ ld.q_q)
        pos = {int(i): k for k, i in enumerate(model.position_ids)}
        rot = {int(i): k for k, i in enumerate(model.orientation_ids)}
        want[num.pos_idx[pos[p]]] += f_p[0]
        want[num.pos_idx[pos[q]]] += f_q[0]
        # a moment T acts on identity Euler parameters as 2 Lambda^T T = (0, 2 T)
        want[num.rot_idx[rot[r]][1:]] += 2 * m_p[0]
        want[num.rot_idx[rot[s]][1:]] += 2 * m_q[0]
    assert np.abs(want).max() > 0.1
    np.testing.assert_allclose(f, want, rtol=0, atol=1e-14)


def _ring3d(n: int, p: float, rot: np.ndarray) -> str:
    """The planar ring of tests/test_follower.py (R = EI = 1 in its plane, EA = 1e6) as
    BEAMs in the plane turned by ``rot``: y-axes towards the centre (the planar element's
    z x t), out-of-plane bending and torsion stiff (100), clamped at node 1 (a statically
    determinate support of a free 3D body), under the follower pressure ``DELQEL 0 p 0``."""
    th = 2 * np.pi * np.arange(n) / n
    pts = np.stack([np.cos(th), np.sin(th), 0 * th], axis=1) @ rot.T
    lines = [f"X {2 * i + 1} " + " ".join(repr(float(v)) for v in x) for i, x in enumerate(pts)]
    for i in range(n):
        j = (i + 1) % n
        inward = -(pts[i] + pts[j]) / 2
        lines.append(f"BEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * j + 1} {2 * j + 2} "
                     + " ".join(repr(float(v)) for v in inward))
    lines += [f"DYNE 1:{n} 1 2 3 4 5 6", "FIX 1", "FIX 2", "END", "HALT",
              f"ESTIFF 1:{n} 1e6 100 100 1", f"DELQEL 1:{n} 0 {p!r} 0",
              "ITERSTEP 20 1 1e-10", "END", "END"]
    return "\n".join(lines) + "\n"


def _buckling(text: str):
    from spacarpy.solvers.linear.buckling import buckling_modes
    from spacarpy.solvers.linear.linearize import linearize
    from spacarpy.solvers.statics.static import solve_static

    job = job_from_text(text, "ring.dat")
    res = solve_static(job.model, job.settings)
    prob, st = res.problem, res.steps[-1]
    lin = linearize(prob, st.x, st.mu, prob.loads.at(1.0, st.load_factor))
    return res, buckling_modes(lin).multiplier


ROT = Rotation.from_rotvec([0.4, -0.9, 0.3]).as_matrix()


def test_tilted_3d_ring_under_follower_pressure_buckles_as_the_planar_one():
    """The ring in a tilted plane, 3D beams: it stays a circle of radius 1 - p/EA, and it
    buckles at the planar ring's pressures (n = 2 at 3 EI/R^3, n = 3 at 8 EI/R^3, within 1e-3
    and 2e-3 at 128 elements) to 1e-6 (the double roots split by 8e-8 under round-off): the
    same in-plane discretization, the current y-axis of the spatial element being the
    planar one's z x t. Both orientations, the plane xy and a tilted one."""
    from tests.test_follower import _ring

    p = 0.3
    _, flat = _buckling(_ring3d(128, p, np.eye(3)))
    res, mult = _buckling(_ring3d(128, p, ROT))
    st, num = res.steps[-1], res.problem.num
    pos = st.x[num.pos_idx]
    centre = pos.mean(axis=0)
    np.testing.assert_allclose(np.linalg.norm(pos - centre, axis=1), 1 - p / 1e6, rtol=1e-9)
    np.testing.assert_allclose((pos - centre) @ ROT[:, 2], 0.0, atol=1e-12)   # in its plane
    _, planar = _buckling(_ring(128, p))
    got = p * mult[:4]
    assert abs(got[0] / 3.0 - 1) < 1e-3 and abs(got[2] / 8.0 - 1) < 2e-3
    np.testing.assert_allclose(got, p * planar[:4], rtol=1e-6)
    np.testing.assert_allclose(p * flat[:4], p * planar[:4], rtol=1e-6)


def _cantilever(n: int, q: str, planar: bool, rot=None, extra: str = "") -> str:
    """A cantilever of length 1 along its x-axis (EI = 1 in the loaded plane, EA = 1e7),
    n elements, under the follower line load ``QEL`` line ``q`` on every element; 3D: the
    beam and its plane turned by ``rot``, out-of-plane stiffness 10."""
    rot = np.eye(3) if rot is None else rot
    xs = np.linspace(0.0, 1.0, n + 1)
    pts = np.stack([xs, 0 * xs, 0 * xs], axis=1) @ rot.T
    lines = [f"X {2 * i + 1} " + " ".join(repr(float(v)) for v in x) for i, x in enumerate(pts)]
    y = " ".join(repr(float(v)) for v in rot[:, 1])
    for i in range(n):
        a, b = 2 * i + 1, 2 * i + 3
        lines.append(f"PLBEAM {i + 1} {a} {a + 1} {b} {b + 1}" if planar else
                     f"BEAM {i + 1} {a} {a + 1} {b} {b + 1} {y}")
    dyne = "1 2 3" if planar else "1 2 3 4 5 6"
    stiff = "1e7 1" if planar else "1e7 10 10 1"
    lines += [f"DYNE 1:{n} {dyne}", "FIX 1", "FIX 2", "END", "HALT", f"ESTIFF 1:{n} {stiff}"]
    lines += [q.replace("ALL", f"1:{n}"), extra, "ITERSTEP 30 4 1e-12", "END", "END"]
    return "\n".join(lines) + "\n"


def _tip(tmp_path, text, name):
    deck = tmp_path / f"{name}.dat"
    deck.write_text(text)
    out = tmp_path / f"{name}.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        return f["static/position"][-1]


@pytest.mark.parametrize("q", ["DELQEL ALL 0.3 -2 0.4 -5", "DELQEL ALL 0 3"])
def test_rotated_3d_cantilever_is_the_planar_one(tmp_path, q):
    """A cantilever under a large follower line load (uniform, and linear with an axial
    part; tip rotations near a radian) in a plane turned out of xy: the 3D beams give the
    planar beams' deflected shape, turned, to 1e-9."""
    n = 16
    planar = _tip(tmp_path, _cantilever(n, q, True), "planar")
    q3 = " ".join(q.split()[:2]) + " " + " ".join(
        f"{a} {b} 0" for a, b in zip(q.split()[2::2], q.split()[3::2]))
    spatial = _tip(tmp_path, _cantilever(n, q3, False, ROT), "spatial")
    assert np.abs(planar[-1, :2] - [1.0, 0.0]).max() > 0.3             # a large deflection
    np.testing.assert_allclose(spatial, planar @ ROT.T, rtol=0, atol=1e-9)


def test_arc_length_reaches_the_load_steps_state(tmp_path):
    """ARCLENGTH follows the large linear follower line load of the turned cantilever (its
    load vector ``d f/ds`` at the current configuration) and ends at load factor 1 on the
    state the load steps reach, to 1e-12."""
    q = "DELQEL ALL 0.3 -2 0 0.4 -5 0"
    steps = _tip(tmp_path, _cantilever(16, q, False, ROT), "steps")
    deck = tmp_path / "arc.dat"
    deck.write_text(_cantilever(16, q, False, ROT, "ARCLENGTH 30 0.3"))
    assert main(["run", str(deck), "-o", str(tmp_path / "arc.h5"), "-q"]) == 0
    with h5py.File(tmp_path / "arc.h5", "r") as f:
        lf, arc = f["static/load_factor"][:], f["static/position"][-1]
    assert lf.size >= 3 and lf[-1] == pytest.approx(1.0, abs=1e-12)
    assert np.abs(steps[-1] - ROT[:, 0]).max() > 0.3       # the tip moved: a large load
    np.testing.assert_allclose(arc, steps, rtol=0, atol=1e-12)


def test_small_follower_line_load_gives_the_closed_form_deflection(tmp_path):
    """At a small load the follower line load is the dead one: a uniform q normal to a
    cantilever deflects its tip by q L^4 / 8 EI, a triangular load 0 -> q by 11 q L^4 /
    120 EI (the cubic beam is exact at its nodes; nonlinear terms are 1e-6 relative)."""
    q = 1e-6
    for line, want in ((f"DELQEL ALL 0 {q} 0", q / 8), (None, 11 * q / 120)):
        n = 4
        if line is None:                      # a linear load, element by element
            line = "\n".join(f"DELQEL {i + 1} 0 {q * i / n!r} 0 0 {q * (i + 1) / n!r} 0"
                             for i in range(n))
        tip = _tip(tmp_path, _cantilever(n, line, False), "small")
        assert tip[-1, 1] == pytest.approx(want, rel=1e-5)
        assert abs(tip[-1, 2]) < 1e-20


def _transient(a: float, b: float) -> str:
    """A 4-element 3D cantilever (L = EI = rhoA = 1) under two follower line loads: a
    uniform DELQEL a along its y-axis on elements 1-2 following ``pulse`` (sine 3 Hz) and a
    linear one b -> 2b along z on elements 3-4 following ``slow`` (smoothstep 0.2 s); the
    deck's own function is a ramp."""
    lines = ["MODE transient", "TIMEFUNCTION ramp 0.05", "TIMEFUNCTION pulse sine 3",
             "TIMEFUNCTION slow smoothstep 0.2", "X 1 0 0 0", "X 3 1 0 0",
             "BEAMS 1 1 2 3 4 4 0 1 0", "DYNE 1:4 1 2 3 4 5 6", "FIX 1", "FIX 2", "END",
             "HALT", "ESTIFF 1:4 1e4 1 1 1", "EM 1:4 1 2e-4 1e-4 1e-4 0",
             "ITERSTEP 30 1 1e-13"]
    if a:
        lines += [f"DELQEL 1:2 0 {a} 0", "LOADTF pulse DELQEL 1", "LOADTF pulse DELQEL 2"]
    if b:
        lines += [f"DELQEL 3:4 0 0 {b} 0 0 {2 * b}", "LOADTF slow DELQEL 3",
                  "LOADTF slow DELQEL 4"]
    lines += ["TIMESTEP 0.5 50", "END", "END"]
    return "\n".join(lines) + "\n"


def _history(tmp_path, text, name):
    deck = tmp_path / f"{name}.dat"
    deck.write_text(text)
    out = tmp_path / f"{name}.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        return f["transient/position"][:]


def test_two_follower_line_loads_with_their_own_functions_superpose(tmp_path):
    """In the linear range the response to both DELQEL is the sum of the responses to each,
    to 1e-12 m (4e-6 of the response, the round-off of positions of order 1 m); the two
    histories differ (one function for both would not)."""
    both = _history(tmp_path, _transient(3e-5, 2e-6), "ab")
    u = {k: r - r[0] for k, r in (("ab", both), ("a", _history(tmp_path, _transient(3e-5, 0),
                                                                "a")),
                                  ("b", _history(tmp_path, _transient(0, 2e-6), "b")))}
    size = np.abs(u["ab"]).max()
    assert 1e-8 < size < 1e-5
    assert np.abs(u["ab"] - u["a"] - u["b"]).max() < 1e-12      # round-off of 1 m positions
    ya, zb = u["a"][:, -1, 1], u["b"][:, -1, 2]
    assert np.abs(ya).max() > 0.1 * size and np.abs(zb).max() > 0.1 * size
    assert abs(np.corrcoef(ya, zb)[0, 1]) < 0.9


def test_line_and_follower_loads_are_in_the_model_group(tmp_path):
    """/model holds each QE, DELQE, QEL, DELQEL line (element, kind, force per length at the
    ends p and q) and each XFL, DELXFL line ([node, axes node], kind, components) (schema
    2.23), read back by the reader (the dead line loads first, then the follower ones, each
    in deck order); a model without them has none of these datasets."""
    from spacarpy.results import open_results

    text = _cantilever(2, "QEL 1 0 1 0 0 2 0\nDELQEL 2 0.5 0 -1\nQE 1 0 0 3\n"
                       "DELXFL 5 6 0 0 -2e-3\nXFL 6 6 1e-3 0 0", False)
    deck = tmp_path / "loads.dat"
    deck.write_text(text)
    assert main(["run", str(deck), "-o", str(tmp_path / "loads.h5"), "-q"]) == 0
    with open_results(tmp_path / "loads.h5") as res:
        m = res.model
        assert m.line_load_element.tolist() == [1, 1, 2]
        assert m.line_load_type.tolist() == ["QE", "QEL", "DELQEL"]
        np.testing.assert_array_equal(m.line_load_value, [
            [[0, 0, 3], [0, 0, 3]], [[0, 1, 0], [0, 2, 0]], [[0.5, 0, -1], [0.5, 0, -1]]])
        assert m.follower_load_node.tolist() == [[5, 6], [6, 6]]          # deck order
        assert m.follower_load_type.tolist() == ["DELXFL", "XFL"]
        np.testing.assert_array_equal(m.follower_load_value, [[0, 0, -2e-3], [1e-3, 0, 0]])
    deck.write_text(_cantilever(2, "DELXF 5 0 1e-3 0", False))
    assert main(["run", str(deck), "-o", str(tmp_path / "none.h5"), "-q"]) == 0
    with open_results(tmp_path / "none.h5") as res:
        assert res.model.line_load_element is None and res.model.follower_load_node is None
        assert res.model.load_type.tolist() == ["DELXF"]


def _leipholz(n: int, q: float) -> str:
    """Leipholz's column: a clamped-free column of 3D beams (L = EI = rhoA = 1 in the plane
    xy, out of it 10 times stiffer; rotary inertia 1e-6), under a uniform tangential follower
    line load q per length along the element's current -x axis (towards the clamp)."""
    xs = np.linspace(0.0, 1.0, n + 1)
    lines = [f"X {2 * i + 1} {float(x)!r} 0 0" for i, x in enumerate(xs)]
    lines += [f"BEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4} 0 1 0"
              for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3 4 5 6", "FIX 1", "FIX 2", "END", "HALT",
              f"ESTIFF 1:{n} 1e6 10 10 1", f"EM 1:{n} 1 2e-6 1e-6 1e-6 0",
              f"DELQEL 1:{n} {-q!r} 0 0", "ITERSTEP 20 1 1e-10", "END", "END"]
    return "\n".join(lines) + "\n"


def test_leipholz_column_flutters_at_its_load():
    """The eigenvalue analysis with the follower line load's stiffness: the two lowest w^2
    of Leipholz's column meet and become a complex conjugate pair at q L^3 / EI = 40.05
    (Leipholz 1962; Langthjem & Sugiyama 2000), within 1e-3 at 20 elements (measured 4e-4,
    by bisection); below it both are real and positive."""
    from spacarpy.solvers.linear.eigen import COMPLEX, ELASTIC, eigenmodes
    from tests.test_follower import _linearized

    def lowest(q):
        lin, prob = _linearized(_leipholz(20, q))
        return eigenmodes(lin, prob.num, prob.free, n_modes=2)

    lo, hi = 39.9, 40.2
    assert list(lowest(lo).kind) == [ELASTIC, ELASTIC]
    above = lowest(hi)
    assert list(above.kind) == [COMPLEX, COMPLEX]
    assert above.eigenvalue[0] == np.conj(above.eigenvalue[1])
    while hi - lo > 2e-5 * lo:
        mid = 0.5 * (lo + hi)
        if (lowest(mid).kind == COMPLEX).any():
            hi = mid
        else:
            lo = mid
    assert abs(0.5 * (lo + hi) / 40.05 - 1) < 1e-3
