"""3D figures of a results file: deformed shapes, mode shapes and animations (matplotlib).

This module's one job is drawing the structure itself. Beams are smooth centre lines: cubic
Hermite curves through the element's nodes, with the end tangents along the element's x-axis
rotated by the nodal orientations (the shape the DDM element describes). Rigid bodies (RBEAM)
are drawn as thick bars between their nodes, filled where one body joins three or more nodes;
hinges (HINGE, PLHINGE) as open circles at the node they connect; TRUSS and PLTRUSS elements
and planar beams as straight lines.

Displacement magnification (:func:`auto_scale`): a deformed shape whose largest displacement
``u`` is below 5 % of the model's size ``L`` (the largest extent of the undeformed shape) is
drawn with its displacements (and the rotations, through the vector part of the Euler
parameters) magnified by the largest factor 1, 2 or 5 x 10^k that keeps ``factor * u`` at
most 10 % of ``L``. The legend states the factor ("displacements x10"); ``scale`` (``--scale``)
overrides it, ``--scale 1`` draws the true scale.
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.plot_base import (
    ANIMATION_SUFFIXES,
    PlotUnavailableError,
    _mpl,
    check_output,
    static_view,
    title,
)
from spacarpy.results.reader import ResultsFile, ResultsQueryError
from spacarpy.results.schema import slot_roles
from spacarpy.rotation import rotate

__all__ = ["shape_figure", "mode_figure", "animate", "auto_scale", "centre_lines",
           "straight_lines", "rigid_segments", "hinge_positions"]

_SUBDIVISIONS = 12       # points per element along the Hermite centre line, minus one
_SMALL = 0.05            # magnify when the largest displacement is below this part of L
_TARGET = 0.10           # ... so that it becomes at most this part of L


def auto_scale(u_max: float, size: float) -> float:
    """The displacement magnification of a drawn shape (see the module docstring)."""
    if not (u_max > 0 and size > 0) or u_max >= _SMALL * size:
        return 1.0
    target = _TARGET * size / u_max
    k = int(np.floor(np.log10(target)))
    for mantissa in (5, 2, 1):
        if mantissa * 10.0 ** k <= target:
            return max(float(mantissa * 10.0 ** k), 1.0)
    return max(10.0 ** k, 1.0)      # pragma: no cover - 1 x 10^k <= target always


# --------------------------------------------------------------------------------------------
# geometry
# --------------------------------------------------------------------------------------------

def centre_lines(res: ResultsFile, position, euler, n_sub: int = _SUBDIVISIONS) -> np.ndarray:
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
    if m.element_axes is not None:
        nx0 = m.element_axes[:, 0]
    else:
        x0 = m.position_x0[rows]
        nx0 = (x0[:, 1] - x0[:, 0]) / m.element_length[:, None]
    q = euler / np.linalg.norm(euler, axis=-1, keepdims=True)
    p0, p1 = position[rows[:, 0]], position[rows[:, 1]]
    chord = np.linalg.norm(p1 - p0, axis=1)[:, None]
    t0 = rotate(q[rot[:, 0]], nx0) * chord
    t1 = rotate(q[rot[:, 1]], nx0) * chord
    s = np.linspace(0.0, 1.0, n_sub + 1)[None, :, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return (h00 * p0[:, None] + h10 * t0[:, None] + h01 * p1[:, None] + h11 * t1[:, None])


def _segments(lines: np.ndarray) -> np.ndarray:
    """(n_elem, n_pt, 3) polylines -> (n_elem * (n_pt - 1), 2, 3) line segments."""
    return np.stack([lines[:, :-1], lines[:, 1:]], axis=2).reshape(-1, 2, 3)


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


def _add_lines(ax, segments, **style):
    """Add a Line3DCollection unless there is nothing to draw."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    if len(segments):
        coll = Line3DCollection(segments, **style)
        ax.add_collection3d(coll)
        return coll
    return None


def _equal_axes(ax, points: np.ndarray, view=None) -> None:
    """Cube limits around ``points`` (n, 3) and a cubic box: equal scales on x, y, z; the
    camera at ``view`` = (elevation, azimuth) in degrees if given."""
    if view is not None:
        ax.view_init(elev=float(view[0]), azim=float(view[1]))
    lo, hi = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    centre, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-12) * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")


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


def _draw(ax, res, pos, eul, *, color, width, alpha=1.0, style="-", label=None,
          mises=None, fig=None):
    """Draw one configuration: beams, other line elements, rigid bodies and hinges; returns
    the points drawn (for the axis limits)."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    lines = centre_lines(res, pos, eul)
    if mises is not None:
        coll = Line3DCollection(_segments(lines), cmap="viridis", linewidths=width,
                                label=label)
        coll.set_array(np.repeat(mises, lines.shape[1] - 1))
        ax.add_collection3d(coll)
        fig.colorbar(coll, ax=ax, shrink=0.6, pad=0.1, label="largest von Mises stress [MPa]")
        others = straight_lines(res, pos)
        label = None
    else:
        others = np.concatenate([_segments(lines), straight_lines(res, pos)])
    if _add_lines(ax, others, colors=color, linewidths=width, alpha=alpha, linestyles=style,
                  label=label) is not None:
        label = None
    bars, polygons = rigid_segments(res, pos)
    _add_lines(ax, bars, colors=color, linewidths=3 * width, alpha=0.6 * alpha,
               linestyles=style, capstyle="round", label=label)
    for poly in polygons:
        ax.add_collection3d(Poly3DCollection([poly], facecolors=color, alpha=0.25 * alpha,
                                             edgecolors="none"))
    return [lines.reshape(-1, 3), np.asarray(pos)] + [p for p in polygons]


def _hinges(ax, res, pos, label=True):
    hinge = hinge_positions(res, pos)
    if hinge.size:
        ax.scatter(hinge[:, 0], hinge[:, 1], hinge[:, 2], s=70, facecolors="white",
                   edgecolors="k", linewidths=1.5, depthshade=False, zorder=5,
                   label="hinge" if label else None)


def _magnify(m, pos, eul, scale: float):
    """Positions and Euler parameters with the displacements and rotations x ``scale``."""
    if scale == 1.0:
        return pos, eul
    eul = eul * np.sign(eul[:, :1] + (eul[:, :1] == 0))       # lambda0 >= 0
    return (m.position_x0 + scale * (pos - m.position_x0),
            np.column_stack([eul[:, :1], scale * eul[:, 1:]]))


def _model_size(m) -> float:
    return float(np.max(np.ptp(m.position_x0, axis=0))) if m.n_pos else 0.0


# --------------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------------

def _step_group(res, time, step):
    """(view, steps-or-step, x values, 'label {:.4g}', transient?) for a shape figure."""
    transient = time is not None or (
        res.transient is not None and res.transient.n_step
        and (res.static is None or res.static.n_step == 0))
    if transient:
        if res.transient is None or res.transient.n_step == 0:
            raise ResultsQueryError(f"{res.path} has no time steps (/transient) to plot")
        s = res.transient
        if time is not None:
            times = np.atleast_1d(np.asarray(time, dtype=float))
            step = [s.step_at(float(t)) for t in times]
            step = step[0] if len(step) == 1 else step
        return s, step, s.time, "t = {:.4g} s", True
    s = static_view(res)
    return s, step, s.load_factor, "load factor {:.4g}", False


def shape_figure(res: ResultsFile, step=None, color: str = "auto", scale=None, view=None,
                 time=None, **_):
    """Undeformed shape (grey, dashed) and the deformed shape at the given step(s).

    Parameters
    ----------
    step : int, sequence of int, or None
        Steps to draw (None: the last one; ``"all"``: every step, lighter for earlier ones).
    color : {"auto", "stress", "plain"}
        ``auto`` colours the last drawn step by the largest von Mises stress of each element
        when the file has stresses.
    scale : float, optional
        Displacement magnification; default :func:`auto_scale` of the largest drawn
        displacement (1 when it is visible at true scale). Stated in the legend.
    view : (float, float), optional
        Elevation and azimuth of the camera in degrees (matplotlib's default: 30, -60).
    time : float or sequence of float, optional
        Draw the stored time steps of ``/transient`` nearest to these times (s); ``step``
        then counts time steps. A file with time steps and no load step draws ``/transient``.
    """
    _, Figure = _mpl()
    m = res.model
    s, step, lf, what_of, transient = _step_group(res, time, step)
    if transient and color == "auto":
        color = "plain"
    steps = (np.arange(s.n_step) if isinstance(step, str) and step == "all"
             else np.atleast_1d(s.step_index(-1 if step is None else step)))
    steps = np.arange(s.n_step)[steps]
    size = _model_size(m)
    if scale is None:
        u_max = max(float(np.max(np.linalg.norm(s.displacement(step=int(k)), axis=-1),
                                 initial=0.0)) for k in steps)
        scale = auto_scale(u_max, size)
    scale = float(scale)
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    euler0 = np.zeros((m.n_rot, 4))
    euler0[:, 0] = 1.0
    points = _draw(ax, res, m.position_x0, euler0, color="0.35", width=1.2, style="--",
                   label="undeformed")
    use_stress = not transient and (color == "stress" or (color == "auto" and s.has_stress))
    magnified = "" if scale == 1.0 else f", displacements x{scale:g}"
    for i, k in enumerate(steps):
        pos, eul = _magnify(m, s.position(step=int(k)), s.euler(step=int(k)), scale)
        last = i == steps.size - 1
        label = f"step {k}, " + what_of.format(lf[k]) + magnified
        mises = (s.max_von_mises_stress(step=int(k)) / 1e6 if last and use_stress else None)
        alpha = 1.0 if last else 0.25 + 0.5 * i / max(steps.size - 1, 1)
        points += _draw(ax, res, pos, eul, color="C0", width=2.0 if last else 1.0,
                        alpha=alpha, label=label if last else None, mises=mises, fig=fig)
        if last:
            ax.scatter(pos[:, 0], pos[:, 1], pos[:, 2], s=10, color="k", depthshade=False)
            _hinges(ax, res, pos)
    _equal_axes(ax, np.concatenate(points), view)
    ax.legend(loc="upper left", fontsize=8)
    what = ("deformed shape" if steps.size == 1 else
            f"deformed shapes, steps {steps[0]}..{steps[-1]}")
    ax.set_title(title(res, what + magnified), fontsize=10)
    fig.spacarpy_scale = scale            # for scripts and tests: the factor drawn
    return fig


def mode_figure(res: ResultsFile, mode: int = 1, step=None, group: str = "eigen",
                scale=None, view=None, **_):
    """A mode shape over the static state it was computed at.

    The mode's position part is scaled so that its largest nodal displacement is 15 % of the
    model's size (or by ``scale``); it is drawn at +scale and -scale.
    """
    _, Figure = _mpl()
    lin = getattr(res, group)
    if lin is None or lin.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no /{group} results")
    mode = 1 if mode is None else int(mode)
    r = lin.row(step)
    k = int(lin.step[r])
    shape = lin.shape(mode=mode, step=k)
    s = static_view(res)
    pos, eul = s.position(step=k), s.euler(step=k)
    size = float(np.max(np.ptp(pos, axis=0))) or 1.0
    amp = float(np.max(np.linalg.norm(shape.position, axis=1)))
    if scale is None:
        scale = 0.15 * size / amp if amp > 0 else 1.0
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    points = _draw(ax, res, pos, eul, color="0.55", width=1.0, style="--",
                   label=f"static state, step {k}")
    for sign, style in ((1, "C3"), (-1, "C0")):
        points += _draw(ax, res, pos + sign * scale * shape.position,
                        eul + sign * scale * shape.euler, color=style, width=1.8,
                        label=f"{'+' if sign > 0 else '-'} mode")
    _hinges(ax, res, pos)
    _equal_axes(ax, np.concatenate(points), view)
    ax.legend(loc="upper left", fontsize=8)
    if group == "eigen":
        f = lin.frequency[r, mode - 1]
        what = f"eigenmode {mode}: {f:.5g} Hz"
    else:
        what = f"buckling mode {mode}: load multiplier {lin.load_multiplier[r, mode - 1]:.5g}"
    ax.set_title(title(res, f"{what} (step {k}, shape x{scale:.3g})"), fontsize=10)
    return fig


def animate(res: ResultsFile, out, fps: float = 20, max_frames: int = 200, scale=None,
            view=None, **_):
    """Write an animation of the time steps (``/transient``; else the static steps) to
    ``out``: ``.gif`` (Pillow, which matplotlib needs anyway) or ``.mp4`` (needs ffmpeg).

    At most ``max_frames`` frames, evenly spread over the stored steps (the first and the
    last included); the axes stay fixed over all frames; ``scale`` as in
    :func:`shape_figure` (its automatic factor over all frames). Returns the frame steps.
    """
    matplotlib, Figure = _mpl()
    from matplotlib import animation
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    out = check_output(out, ANIMATION_SUFFIXES, "plot animate")
    if out.suffix.lower() == ".mp4":
        if not animation.FFMpegWriter.isAvailable():
            raise PlotUnavailableError("an MP4 animation needs ffmpeg, which is not on the "
                                       "PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps)
    else:
        writer = animation.PillowWriter(fps=fps)
    m = res.model
    if res.transient is not None and res.transient.n_step:
        s, x, what_of = res.transient, res.transient.time, "t = {:.4g} s"
    else:
        s = static_view(res)
        x, what_of = s.load_factor, "load factor {:.4g}"
    n = int(min(s.n_step, max(int(max_frames), 2)))
    frames = np.unique(np.round(np.linspace(0, s.n_step - 1, n)).astype(int))
    position, euler = s.position(), s.euler()
    if scale is None:
        u = np.linalg.norm(position[frames] - m.position_x0, axis=-1)
        scale = auto_scale(float(np.max(u, initial=0.0)), _model_size(m))
    scale = float(scale)
    configs = [_magnify(m, position[k], euler[k], scale) for k in frames]
    euler0 = np.tile([1.0, 0.0, 0.0, 0.0], (m.n_rot, 1))
    every = np.concatenate([centre_lines(res, p, e).reshape(-1, 3) for p, e in configs]
                           + [p for p, _ in configs] + [m.position_x0])
    fig = Figure(figsize=(6.4, 5.6))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    magnified = "" if scale == 1.0 else f", displacements x{scale:g}"
    with writer.saving(fig, str(out), dpi=80):
        for k, (pos, eul) in zip(frames, configs):
            ax.cla()
            _draw(ax, res, m.position_x0, euler0, color="0.6", width=1.0, style="--",
                  label="undeformed")
            _draw(ax, res, pos, eul, color="C0", width=2.0,
                  label=f"step {k}{magnified}")
            _hinges(ax, res, pos)
            _equal_axes(ax, every, view)
            ax.legend(loc="upper left", fontsize=8)
            ax.set_title(title(res, what_of.format(x[k])), fontsize=10)
            writer.grab_frame()
    return frames
