"""The geometry that the shape figures draw: centre lines, section ribbons, rigid bodies,
hinges, magnified configurations and the plane of a planar model.

This module's one job is turning node positions and Euler parameters into points to draw;
:mod:`spacarpy.results.plot_shapes` draws them. Nothing here needs matplotlib.

- **Centre lines** (:func:`centre_lines`): cubic Hermite curves through each element's nodes,
  with the end tangents along the element's x-axis rotated by the nodal orientations.
- **Section ribbons** (:func:`section_ribbons`): for each BEAM, the section's y-axis rotated
  by the orientation of its nodes (interpolated along the element), a band of half width
  ``w`` on both sides of the centre line; a torsion shows as a twist of the band.
- **Magnification** (:func:`magnify`): displacements times ``scale`` and rotations times
  ``scale`` exactly (the rotation vector of each node is multiplied: a node turned by 0.01 rad
  and magnified 20 times is drawn turned by 0.2 rad). A mode shape is drawn the same way
  (:func:`mode_configuration`): the position part times the amplitude, the rotation the
  mode's angular displacement ``2 dq q0*`` times the amplitude.
- **Planar models** (:func:`plane_of`): a configuration whose points all lie in a coordinate
  plane and whose rotations all turn about that plane's normal is drawn in 2-D in that
  plane's axes.
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.reader import ResultsFile
from spacarpy.results.schema import slot_roles
from spacarpy.rotation import rotate

__all__ = ["centre_lines", "straight_lines", "rigid_segments", "hinge_positions",
           "section_ribbons", "magnify", "mode_configuration", "rotation_vector",
           "from_rotation_vector", "plane_of", "model_size", "segments", "AXIS_NAMES"]

SUBDIVISIONS = 12        # points per element along the Hermite centre line, minus one
AXIS_NAMES = ("x", "y", "z")


# --------------------------------------------------------------------------------------------
# rotations
# --------------------------------------------------------------------------------------------

def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a b of Euler parameters (..., 4): R(a b) = R(a) R(b)."""
    a0, av, b0, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, axis=-1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], axis=-1)


def _conj(q: np.ndarray) -> np.ndarray:
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def rotation_vector(q: np.ndarray) -> np.ndarray:
    """(..., 3): the rotation vector (axis times angle in rad, angle <= pi) of the Euler
    parameters q (..., 4), normalized first."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = q * np.where(q[..., :1] < 0, -1.0, 1.0)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    with np.errstate(invalid="ignore", divide="ignore"):
        factor = np.where(s > 1e-300, angle / np.where(s > 0, s, 1.0), 2.0)
    return factor * q[..., 1:]


def from_rotation_vector(v: np.ndarray) -> np.ndarray:
    """(..., 4): Euler parameters of the rotation vector v (..., 3)."""
    v = np.asarray(v, dtype=float)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    with np.errstate(invalid="ignore", divide="ignore"):
        sinc = np.where(angle > 1e-300, np.sin(half) / np.where(angle > 0, angle, 1.0), 0.5)
    return np.concatenate([np.cos(half), sinc * v], axis=-1)


def magnify(m, pos, eul, scale: float):
    """Positions and Euler parameters with the displacements and the rotations (their
    rotation vectors) times ``scale``."""
    if scale == 1.0:
        return np.asarray(pos), np.asarray(eul)
    pos = m.position_x0 + scale * (np.asarray(pos) - m.position_x0)
    return pos, from_rotation_vector(scale * rotation_vector(eul))


def mode_rotation(eul0, d_eul) -> np.ndarray:
    """(n_rot, 3): the angular displacement (rad per unit of mode amplitude, spatial) of a
    mode whose Euler-parameter part is ``d_eul`` about the orientations ``eul0``:
    ``2 (dq q0*)``'s vector part."""
    q0 = np.asarray(eul0, dtype=float)
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    return 2.0 * _qmul(np.asarray(d_eul, dtype=float), _conj(q0))[..., 1:]


def mode_configuration(pos0, eul0, shape, amplitude: float):
    """Positions and Euler parameters of the static state ``(pos0, eul0)`` moved by the mode
    ``shape`` (a :class:`~spacarpy.results.views.ModeShape`) times ``amplitude``: its
    rotations are turned exactly by ``amplitude`` times :func:`mode_rotation`."""
    q0 = np.asarray(eul0, dtype=float)
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    turn = from_rotation_vector(amplitude * mode_rotation(q0, shape.euler))
    return np.asarray(pos0) + amplitude * np.asarray(shape.position), _qmul(turn, q0)


# --------------------------------------------------------------------------------------------
# lines, ribbons, bodies
# --------------------------------------------------------------------------------------------

def _beam_axes(m):
    """(n_elem, 3, 3): the undeformed element axes, rows x, y, z (from the chord and a
    perpendicular where the file has no axes)."""
    if m.element_axes is not None:
        return np.asarray(m.element_axes, dtype=float)
    rows = m.element_position_rows
    x0 = m.position_x0[rows]
    nx = (x0[:, 1] - x0[:, 0]) / m.element_length[:, None]
    helper = np.where(np.abs(nx[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[0.0, 1.0, 0.0]])
    ny = np.cross(helper, nx)
    ny /= np.linalg.norm(ny, axis=1, keepdims=True)
    return np.stack([nx, ny, np.cross(nx, ny)], axis=1)


def centre_lines(res: ResultsFile, position, euler, n_sub: int = SUBDIVISIONS) -> np.ndarray:
    """Smooth centre lines of all elements for one configuration.

    Parameters
    ----------
    res : ResultsFile
    position : (n_pos, 3) array
        Node positions.
    euler : (n_rot, 4) array
        Euler parameters (normalized here).
    n_sub : int
        Segments per element.

    Returns
    -------
    numpy.ndarray, shape (n_elem, n_sub + 1, 3)
        Points on the cubic Hermite curve from node p to node q of each element, with end
        tangents ``R(q) n_x0`` scaled by the current chord length.
    """
    m = res.model
    rows = m.element_position_rows
    rot = m.orientation_row(m.element_nodes[:, [1, 3]])
    nx0 = _beam_axes(m)[:, 0]
    q = euler / np.linalg.norm(euler, axis=-1, keepdims=True)
    p0, p1 = position[rows[:, 0]], position[rows[:, 1]]
    chord = np.linalg.norm(p1 - p0, axis=1)[:, None]
    t0 = rotate(q[rot[:, 0]], nx0) * chord
    t1 = rotate(q[rot[:, 1]], nx0) * chord
    s = np.linspace(0.0, 1.0, n_sub + 1)[None, :, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return (h00 * p0[:, None] + h10 * t0[:, None] + h01 * p1[:, None] + h11 * t1[:, None])


def section_ribbons(res: ResultsFile, position, euler, half_width: float,
                    n_sub: int = SUBDIVISIONS) -> tuple[np.ndarray, np.ndarray]:
    """The band along each BEAM: ``(centre, across)``, both (n_beam, n_sub + 1, 3): the
    points of the centre line and the section's y-axis there, times ``half_width``. At the
    nodes ``across`` is exactly ``R(q) n_y0`` of the node; between them it is interpolated
    and normalized."""
    m = res.model
    beams = np.flatnonzero(np.asarray(m.element_type) == "BEAM") if m.n_elem else []
    if len(beams) == 0:
        return np.zeros((0, n_sub + 1, 3)), np.zeros((0, n_sub + 1, 3))
    lines = centre_lines(res, position, euler, n_sub)[beams]
    rot = m.orientation_row(m.element_nodes[beams][:, [1, 3]])
    ny0 = _beam_axes(m)[beams, 1]
    q = euler / np.linalg.norm(euler, axis=-1, keepdims=True)
    a, b = rotate(q[rot[:, 0]], ny0), rotate(q[rot[:, 1]], ny0)
    s = np.linspace(0.0, 1.0, n_sub + 1)[None, :, None]
    across = (1 - s) * a[:, None] + s * b[:, None]
    across /= np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), 1e-300)
    return lines, half_width * across


def segments(lines: np.ndarray) -> np.ndarray:
    """(n_elem, n_pt, 3) polylines -> (n_elem * (n_pt - 1), 2, 3) line segments."""
    return np.stack([lines[:, :-1], lines[:, 1:]], axis=2).reshape(-1, 2, lines.shape[-1])


def straight_lines(res: ResultsFile, position) -> np.ndarray:
    """(n, 2, 3) straight segments between the first two position nodes of every element
    of the kinds other than BEAM and RBEAM (TRUSS, PLBEAM, PLTRUSS)."""
    m, out = res.model, []
    for kind in m.element_kinds:
        if kind in ("BEAM", "RBEAM"):
            continue
        cols = [j for j, r in enumerate(slot_roles(kind)) if r == "pos"][:2]
        if len(cols) == 2:
            rows = m.position_row(m.element_kind_nodes(kind)[:, cols])
            out.append(np.asarray(position)[rows])
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


def rigid_segments(res: ResultsFile, position) -> tuple[np.ndarray, list[np.ndarray]]:
    """Rigid bodies (RBEAM): (n_rbeam, 2, 3) bars from p to q, and one (k, 3) polygon per
    body (the RBEAMs sharing an orientation node) that joins k >= 3 distinct nodes."""
    m = res.model
    if "RBEAM" not in m.element_kinds:
        return np.zeros((0, 2, 3)), []
    nodes = m.element_kind_nodes("RBEAM")
    position = np.asarray(position)
    bars = position[m.position_row(nodes[:, [0, 2]])]
    polygons = []
    for body in dict.fromkeys(nodes[:, 1].tolist()):
        members = nodes[nodes[:, 1] == body]
        ids = list(dict.fromkeys(members[:, [0, 2]].ravel().tolist()))
        if len(ids) >= 3:
            pts = position[m.position_row(np.array(ids))]
            centre = pts.mean(axis=0)
            # order around the centre in the body's best-fit plane (a convex outline)
            _, _, vt = np.linalg.svd(pts - centre)
            local = (pts - centre) @ vt[:2].T
            polygons.append(pts[np.argsort(np.arctan2(local[:, 1], local[:, 0]))])
    return bars, polygons


def hinge_positions(res: ResultsFile, position) -> np.ndarray:
    """(n_hinge, 3): where each HINGE / PLHINGE sits: the position node that an element pairs
    with the hinge's second orientation node (else its first), in element order."""
    m = res.model
    hinges = [k for k in m.element_kinds if k in ("HINGE", "PLHINGE")]
    if not hinges:
        return np.zeros((0, 3))
    at = {}                              # orientation node -> its position node
    for kind in m.element_kinds:
        roles, nodes = slot_roles(kind), m.element_kind_nodes(kind)
        for j, role in enumerate(roles):
            if role == "rot" and j > 0 and roles[j - 1] == "pos":
                for rot, pos in zip(nodes[:, j].tolist(), nodes[:, j - 1].tolist()):
                    at.setdefault(rot, pos)
    out = []
    for kind in hinges:
        for r, s in m.element_kind_nodes(kind)[:, :2].tolist():
            node = at.get(s, at.get(r))
            if node is not None:
                out.append(np.asarray(position)[m.position_row(node)])
    return np.array(out).reshape(-1, 3)


def model_size(m) -> float:
    """The largest extent of the undeformed model (m)."""
    return float(np.max(np.ptp(m.position_x0, axis=0))) if m.n_pos else 0.0


_PLANE_TOL = 1e-9        # relative to the model's size (points) or in rad (rotations)


def plane_of(points, rotations=()) -> tuple[int, int] | None:
    """The axes (i, j) of the coordinate plane that holds every point of ``points`` (n, 3),
    if every rotation vector in ``rotations`` (m, 3) turns about its normal; else None. Of
    several such planes (a straight line of points) the x-y plane comes first, then x-z,
    then y-z."""
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if pts.size == 0:
        return None
    size = max(float(np.max(np.ptp(pts, axis=0))), 1e-300)
    rot = np.asarray(rotations, dtype=float).reshape(-1, 3)
    for normal, axes in ((2, (0, 1)), (1, (0, 2)), (0, (1, 2))):
        if np.ptp(pts[:, normal]) > _PLANE_TOL * size:
            continue
        if rot.size and np.max(np.abs(rot[:, list(axes)])) > _PLANE_TOL:
            continue
        return axes
    return None
