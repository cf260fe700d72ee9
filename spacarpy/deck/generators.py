"""Beam generators (spacarpy extension): BEAMS and BEAMARC lines -> X and BEAM statements.

``BEAMS e p r q s count [ox oy oz]`` divides the straight line from position node p to
position node q into ``count`` equal BEAM elements; ``BEAMARC e p r q s count cx cy cz
[ox oy oz] [shape]`` places them on the circular arc about the centre (cx, cy, cz): as
straight chords (BEAM, shape ``chords``, the default) or, with ``curved``, as initially
curved BEAMC elements on the arc itself (:mod:`spacarpy.elements.beamc`; then an orientation
vector given must be the BEAMC's local y-axis, the arc's normal ``(q - c) x (p - c)``). Both
end nodes are ordinary nodes of the deck (they need X lines; r and s are the orientation nodes
at the ends); the intermediate nodes are created here.

Numbering rule (stable, documented in docs/deck.md): let N be the largest node number that an X
line or an element line (BEAM, a generator's end nodes, an unsupported element) uses anywhere in
the deck. The generator lines are taken in deck order; the k-th intermediate point of a
generator (k = 1 .. count-1, from p towards q) gets position node ``M + 2k - 1`` and orientation
node ``M + 2k``, where M is N for the first generator and, for the next ones, the last number
the previous generator used. The elements are numbered e, e+1, ..., e+count-1 from p to q.
This is SPACAR Light's rule for subdivided elements.

The generated statements take the place of the generator line, so the intermediate position
nodes come in deck order where the generator is (results list nodes in that order).
"""
from __future__ import annotations

import numpy as np

from spacarpy.deck.keywords import GENERATORS, KEYWORDS, VISUALIZATION_KEYWORDS
from spacarpy.deck.statement import Statement

__all__ = ["MAX_GENERATED", "arc_points", "count_elements", "expand_generators", "line_points",
           "max_node_number"]

#: Most elements one generator line may create.
MAX_GENERATED = 1_000_000
#: Relative tolerance on the two radii ``|p - c|`` and ``|q - c|`` of an arc.
RADIUS_RTOL = 1e-6
#: Orientation vectors shorter than this, or with ``|axis x o| < this * |o|``, are rejected.
ORIENTATION_TOL = 1e-5


def line_points(a, b, count: int) -> np.ndarray:
    """The ``count - 1`` interior points dividing the segment a-b into ``count`` equal parts.

    Returns
    -------
    (count - 1, 3) float
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    t = np.arange(1, count)[:, None] / count
    return a + t * (b - a)


def arc_geometry(a, b, center):
    """Radii, in-plane basis and angle of the arc from a to b about ``center``.

    Returns
    -------
    ra, rb : float
        ``|a - c|`` and ``|b - c|``.
    u, w : (3,) float
        Unit vector from c to a, and the unit vector perpendicular to it in the arc plane,
        towards b.
    theta : float
        The angle of the arc (0 < theta < pi for a valid arc; 0 or pi when undefined).
    """
    c = np.asarray(center, dtype=float)
    da = np.asarray(a, dtype=float) - c
    db = np.asarray(b, dtype=float) - c
    ra, rb = float(np.linalg.norm(da)), float(np.linalg.norm(db))
    if ra == 0.0 or rb == 0.0:
        return ra, rb, np.zeros(3), np.zeros(3), 0.0
    u, v = da / ra, db / rb
    cross = float(np.linalg.norm(np.cross(u, v)))
    theta = float(np.arctan2(cross, float(u @ v)))
    perp = v - (u @ v) * u
    norm = float(np.linalg.norm(perp))
    w = perp / norm if norm > 0 else np.zeros(3)
    return ra, rb, u, w, theta


def arc_points(a, b, center, count: int) -> np.ndarray:
    """The ``count - 1`` interior points dividing the arc from a to b about ``center`` into
    ``count`` equal angles (the shorter arc, less than 180 degrees).

    If the radii at a and b differ slightly, the radius varies linearly along the arc, so that
    both ends are met exactly.

    Returns
    -------
    (count - 1, 3) float
    """
    ra, rb, u, w, theta = arc_geometry(a, b, center)
    t = np.arange(1, count)[:, None] / count
    radius = ra + t * (rb - ra)
    phi = t * theta
    return np.asarray(center, dtype=float) + radius * (np.cos(phi) * u + np.sin(phi) * w)


def max_node_number(statements) -> int:
    """The largest node number used by an X line or an element line (0 if there is none)."""
    largest = 0
    for st in statements:
        if st.module < 0 or st.keyword in VISUALIZATION_KEYWORDS:
            continue
        spec = KEYWORDS.get(st.keyword)
        if st.keyword == "X":
            numbers = st.fields[:1]
        elif spec is not None and spec.node_roles:
            numbers = st.fields[1:1 + len(spec.node_roles)]
        else:
            continue
        ints = [v for v in numbers if isinstance(v, int)]
        if ints:
            largest = max(largest, max(ints))
    return largest


def _positions(statements) -> dict:
    out = {}
    for st in statements:
        if st.keyword == "X" and st.module >= 0:
            # (a planar X line has no z; the model builder checks where that is allowed)
            out.setdefault(st.fields[0], np.array((tuple(st.fields[1:4]) + (0.0,))[:3],
                                                  dtype=float))
    return out


class _Generator:
    """One BEAMS/BEAMARC statement being expanded."""

    def __init__(self, st: Statement):
        self.st = st
        f = st.fields
        self.e, self.p, self.r, self.q, self.s, self.count = f[:6]
        self.arc = st.keyword == "BEAMARC"
        self.center = np.array(f[6:9], dtype=float) if self.arc else None
        rest = f[9:12] if self.arc else f[6:]
        self.orientation = tuple(rest) if rest else None
        self.o_index = 9 if self.arc else 6       # field index of ox
        #: BEAMARC's shape: straight chords (BEAM) or curved arcs (BEAMC)
        self.curved = self.arc and len(f) > 12 and str(f[12]).lower() == "curved"


def count_elements(statements) -> int:
    """The number of elements the statements define, generators counted by their ``count``
    field, without expanding them: the size of the model before it is built."""
    n = 0
    for st in statements:
        if st.keyword in GENERATORS:
            n += int(st["count"])
        elif st.keyword in KEYWORDS and KEYWORDS[st.keyword].is_element:
            n += 1
    return n


def expand_generators(statements):
    """Replace every BEAMS/BEAMARC statement by the X and BEAM statements it stands for.

    Parameters
    ----------
    statements : list of Statement

    Returns
    -------
    statements : list of Statement
        With the generated statements (``origin`` = the generator keyword) in place of each
        generator line.
    errors : list of (SourceLoc, str, str)
        Problems with a generator line (end node without an X line, zero length, an arc whose
        end points are not on one circle, an orientation vector parallel to an element, ...).
        A generator with a problem generates nothing.
    failed_elements : set of int
        Element numbers a failed generator would have created (the model builder does not
        report DYNE/ESTIFF/... lines for them as undefined, to avoid a cascade of errors).
    failed_nodes : set of int
        End nodes of failed generators (not reported as unconnected, for the same reason).
    """
    statements = list(statements)
    if not any(st.keyword in GENERATORS for st in statements):
        return statements, [], set(), set()
    positions = _positions(statements)
    next_node = max_node_number(statements)
    out: list[Statement] = []
    errors: list = []
    failed: set[int] = set()
    failed_nodes: set[int] = set()
    for st in statements:
        if st.keyword not in GENERATORS or st.module < 0:
            out.append(st)
            continue
        gen = _Generator(st)
        points = _points(gen, positions, errors)
        if points is None:
            failed.update(range(gen.e, gen.e + min(gen.count, MAX_GENERATED)))
            failed_nodes.update((gen.p, gen.q))
            continue
        if gen.e + gen.count - 1 > 2**31 - 1 or next_node + 2 * gen.count > 2**31 - 1:
            errors.append((st.field_locs[0], f"{st.keyword}: the generated element or node "
                                             "numbers would exceed 2147483647", st.source_line))
            failed.update(range(gen.e, gen.e + min(gen.count, MAX_GENERATED)))
            failed_nodes.update((gen.p, gen.q))
            continue
        out.extend(_generated(gen, points, next_node))
        next_node += 2 * (gen.count - 1)
    return out, errors, failed, failed_nodes


def _points(gen: _Generator, positions: dict, errors: list):
    """Interior points of one generator, or None after recording its errors."""
    st = gen.st
    kw = st.keyword

    def fail(index, message):
        errors.append((st.field_locs[index] if index is not None else st.loc,
                       f"{kw}: {message}", st.source_line))

    if gen.count > MAX_GENERATED:
        fail(5, f"at most {MAX_GENERATED} elements per line, got {gen.count}")
        return None
    ok = True
    for index, slot in ((1, "p"), (3, "q")):
        node = st.fields[index]
        if node not in positions:
            fail(index, f"position node {node} (at {slot}) has no X line")
            ok = False
    if not ok:
        return None
    if gen.p == gen.q:
        fail(3, f"p and q are the same node ({gen.p})")
        return None
    a, b = positions[gen.p], positions[gen.q]
    scale = max(float(np.abs(np.concatenate([a, b])).max()), 1.0)
    chord = float(np.linalg.norm(b - a))
    if chord <= 1e-12 * scale:
        fail(None, f"nodes {gen.p} and {gen.q} are at the same position")
        return None
    if gen.arc:
        ra, rb, _, _, theta = arc_geometry(a, b, gen.center)
        if min(ra, rb) <= 1e-12 * scale:
            fail(6, "the centre coincides with an end node")
            return None
        if abs(ra - rb) > RADIUS_RTOL * max(ra, rb):
            fail(6, f"node {gen.q} is not on the circle through node {gen.p} about the centre: "
                    f"|p - c| = {ra:.10g}, |q - c| = {rb:.10g}")
            return None
        if not 1e-9 < theta < np.pi - 1e-9:
            fail(6, "the centre lies on the line through p and q, so the plane of the arc is "
                    "undefined (a half circle); split the arc into two BEAMARC lines")
            return None
        inner = arc_points(a, b, gen.center, gen.count)
        if gen.curved and gen.orientation is not None:
            o = np.array(gen.orientation, dtype=float)
            normal = np.cross(b - gen.center, a - gen.center)
            normal /= np.linalg.norm(normal)
            if np.linalg.norm(np.cross(o, normal)) > ORIENTATION_TOL * max(
                    float(np.linalg.norm(o)), 1e-300) or float(o @ normal) <= 0.0:
                shown = ", ".join(f"{v:.6g}" for v in normal)
                fail(gen.o_index, "curved elements have their local y-axis normal to the "
                                  f"arc's plane, ({shown}) (docs/curved-beam.md); give that "
                                  "vector or leave the orientation out")
                return None
    else:
        inner = line_points(a, b, gen.count)
    points = np.concatenate([a[None], inner, b[None]])
    if gen.orientation is not None and not gen.curved:
        o = np.array(gen.orientation, dtype=float)
        norm = float(np.linalg.norm(o))
        shown = "(" + ", ".join(f"{v:g}" for v in o) + ")"
        if norm < ORIENTATION_TOL:
            fail(gen.o_index, f"the orientation vector {shown} is (nearly) zero")
            return None
        axes = np.diff(points, axis=0)
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        parallel = np.linalg.norm(np.cross(axes, o), axis=1) < ORIENTATION_TOL * norm
        if parallel.any():
            k = int(np.flatnonzero(parallel)[0])
            fail(gen.o_index, f"the orientation vector {shown} is parallel to the axis of "
                              f"element {gen.e + k}; give a local y-axis perpendicular to all "
                              "the elements")
            return None
    return inner


def _generated(gen: _Generator, inner: np.ndarray, base: int) -> list[Statement]:
    """The X and BEAM statements of one generator; intermediate nodes numbered after base."""
    st = gen.st
    kw = st.keyword
    locs = st.field_locs
    count = gen.count
    k = np.arange(1, count)
    pos_ids = base + 2 * k - 1
    rot_ids = base + 2 * k
    out = [Statement(keyword="X", fields=(int(n),) + tuple(float(v) for v in x),
                     loc=st.loc, field_locs=(locs[5],) * 4, source_line=st.source_line,
                     module=st.module, origin=kw)
           for n, x in zip(pos_ids, inner)]
    pos = [gen.p] + [int(n) for n in pos_ids] + [gen.q]
    rot = [gen.r] + [int(n) for n in rot_ids] + [gen.s]
    o_fields = tuple(float(v) for v in gen.orientation) if gen.orientation else ()
    o_locs = tuple(locs[gen.o_index:gen.o_index + 3]) if gen.orientation else ()
    keyword = "BEAM"
    if gen.curved:                 # BEAMC lines: the arc's centre is their trailing point
        keyword = "BEAMC"
        o_fields = tuple(float(v) for v in gen.center)
        o_locs = tuple(locs[6:9])
    for i in range(count):
        field_locs = (locs[0], locs[1] if i == 0 else locs[5], locs[2] if i == 0 else locs[5],
                      locs[3] if i == count - 1 else locs[5],
                      locs[4] if i == count - 1 else locs[5]) + o_locs
        out.append(Statement(keyword=keyword,
                             fields=(gen.e + i, pos[i], rot[i], pos[i + 1], rot[i + 1]) + o_fields,
                             loc=st.loc, field_locs=field_locs, source_line=st.source_line,
                             module=st.module, origin=kw))
    return out
