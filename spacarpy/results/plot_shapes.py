"""Figures of the structure itself: deformed shapes, mode shapes and animations (matplotlib).

This module's one job is drawing what :mod:`spacarpy.results.plot_geometry` computes. Beams
are smooth centre lines (cubic Hermite curves) and, in 3-D, a band along each beam that
follows the section's y-axis, so that a twist shows; rigid bodies (RBEAM) are thick bars
between their nodes, filled where one body joins three or more nodes; hinges (HINGE, PLHINGE)
are open circles at the node they connect; TRUSS, PLTRUSS and PLBEAM are straight lines.

**Planar models** (every drawn point in one coordinate plane, every rotation about its
normal; :func:`~spacarpy.results.plot_geometry.plane_of`) are drawn in 2-D in that plane's
axes with equal scales; the others in a 3-D box with equal scales.

**Magnification** (:func:`auto_scale`): a deformed shape whose largest displacement ``u`` is
below 5 % of the model's size ``L`` (the largest extent of the undeformed shape) and whose
largest rotation ``theta`` is below 0.1 rad is drawn with its displacements and rotations
multiplied by the largest factor 1, 2 or 5 x 10^k that keeps ``factor * u`` at most 10 % of
``L`` and ``factor * theta`` at most 0.5 rad. A mode shape (:func:`mode_amplitude`) is drawn
with the amplitude that makes its largest displacement 15 % of ``L`` or its largest rotation
0.5 rad, whichever is smaller. The title states the factor; ``scale`` (``--scale``)
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
from spacarpy.results.plot_geometry import (
    AXIS_NAMES,
    centre_lines,
    hinge_positions,
    magnify,
    mode_configuration,
    mode_rotation,
    model_size,
    plane_of,
    rigid_segments,
    rotation_vector,
    section_ribbons,
    segments,
    straight_lines,
)
from spacarpy.results.reader import ResultsFile, ResultsQueryError

__all__ = ["shape_figure", "mode_figure", "animate", "auto_scale", "mode_amplitude",
           "centre_lines", "straight_lines", "rigid_segments", "hinge_positions"]

_SMALL = 0.05            # magnify when the largest displacement is below this part of L
_TARGET = 0.10           # ... so that it becomes at most this part of L
_ROT_SMALL = 0.1         # ... and the largest rotation below this (rad)
_ROT_TARGET = 0.5        # ... so that it becomes at most this (rad)
_MODE_TARGET = 0.15      # a mode's largest displacement, part of L
_RIBBON = 0.04           # half width of the section band, part of L


def auto_scale(u_max: float, size: float, rot_max: float = 0.0) -> float:
    """The magnification of a drawn shape (see the module docstring)."""
    u_max, rot_max = float(u_max), float(rot_max)
    if not size > 0 or u_max >= _SMALL * size or rot_max >= _ROT_SMALL:
        return 1.0
    limits = [_TARGET * size / u_max if u_max > 0 else np.inf,
              _ROT_TARGET / rot_max if rot_max > 0 else np.inf]
    target = min(limits)
    if not np.isfinite(target):
        return 1.0
    k = int(np.floor(np.log10(target)))
    for mantissa in (5, 2, 1):
        if mantissa * 10.0 ** k <= target:
            return max(float(mantissa * 10.0 ** k), 1.0)
    return max(10.0 ** k, 1.0)      # pragma: no cover - 1 x 10^k <= target always


def mode_amplitude(u_amp: float, rot_amp: float, size: float) -> float:
    """The amplitude a mode is drawn with: its largest displacement ``u_amp`` (m per unit)
    at 15 % of ``size`` or its largest rotation ``rot_amp`` (rad per unit) at 0.5 rad,
    whichever is smaller (1 for a mode with neither)."""
    limits = [_MODE_TARGET * (size or 1.0) / u_amp if u_amp > 0 else np.inf,
              _ROT_TARGET / rot_amp if rot_amp > 0 else np.inf]
    amp = min(limits)
    return float(amp) if np.isfinite(amp) else 1.0


def _largest(values) -> float:
    return float(np.max(np.linalg.norm(values, axis=-1), initial=0.0))


def _scale_text(scale: float) -> str:
    return "" if scale == 1.0 else f", displacements x{scale:g}"


# --------------------------------------------------------------------------------------------
# drawing on 2-D or 3-D axes
# --------------------------------------------------------------------------------------------

class _Canvas:
    """One axes, 2-D (``plane`` = the two coordinate axes drawn) or 3-D (``plane`` None)."""

    def __init__(self, fig, plane, position=111):
        self.plane = plane
        self.ax = (fig.add_subplot(position) if plane is not None
                   else fig.add_subplot(position, projection="3d"))

    def _xy(self, pts):
        pts = np.asarray(pts)
        return pts if self.plane is None else pts[..., list(self.plane)]

    def lines(self, segs, **style):
        if not len(segs):
            return None
        if self.plane is None:
            from mpl_toolkits.mplot3d.art3d import Line3DCollection
            coll = Line3DCollection(segs, **style)
            self.ax.add_collection3d(coll)
        else:
            from matplotlib.collections import LineCollection
            coll = LineCollection(self._xy(segs), **style)
            self.ax.add_collection(coll)
        return coll

    def polygons(self, polys, **style):
        if not len(polys):
            return
        if self.plane is None:
            from mpl_toolkits.mplot3d.art3d import Poly3DCollection
            self.ax.add_collection3d(Poly3DCollection(list(polys), **style))
        else:
            from matplotlib.collections import PolyCollection
            self.ax.add_collection(PolyCollection([self._xy(p) for p in polys], **style))

    def scatter(self, pts, **style):
        pts = self._xy(np.asarray(pts).reshape(-1, 3))
        if self.plane is None:
            self.ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], depthshade=False, **style)
        else:
            self.ax.scatter(pts[:, 0], pts[:, 1], **style)

    def limits(self, points, view=None):
        """Equal scales around ``points`` (n, 3): a cube in 3-D (camera at ``view`` =
        (elevation, azimuth)), equal aspect in 2-D; axes labelled in m."""
        ax = self.ax
        points = np.asarray(points).reshape(-1, 3)
        lo, hi = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
        if self.plane is None:
            if view is not None:
                ax.view_init(elev=float(view[0]), azim=float(view[1]))
            centre, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-12) * 1.05
            ax.set_xlim(centre[0] - half, centre[0] + half)
            ax.set_ylim(centre[1] - half, centre[1] + half)
            ax.set_zlim(centre[2] - half, centre[2] + half)
            ax.set_box_aspect((1, 1, 1))
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.set_zlabel("z [m]")
            return
        i, j = self.plane
        pad = max(float(np.max(hi - lo)), 1e-12) * 0.06
        ax.set_xlim(lo[i] - pad, hi[i] + pad)
        ax.set_ylim(lo[j] - pad, hi[j] + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(f"{AXIS_NAMES[i]} [m]")
        ax.set_ylabel(f"{AXIS_NAMES[j]} [m]")
        ax.grid(True, alpha=0.3)


def _draw(cv, res, pos, eul, *, color, width, alpha=1.0, style="-", label=None,
          mises=None, fig=None, ribbon=0.0, cmap="viridis"):
    """Draw one configuration: beams (with their section band when ``ribbon`` > 0 and the
    axes are 3-D), other line elements, rigid bodies; returns the points drawn (for the axis
    limits)."""
    lines = centre_lines(res, pos, eul)
    if mises is not None:
        coll = cv.lines(segments(lines), cmap=cmap, linewidths=width, label=label)
        coll.set_array(np.repeat(mises, lines.shape[1] - 1))
        fig.colorbar(coll, ax=cv.ax, shrink=0.6, pad=0.1,
                     label="largest von Mises stress [MPa]")
        others = straight_lines(res, pos)
        label = None
    else:
        others = np.concatenate([segments(lines), straight_lines(res, pos)])
    if cv.lines(others, colors=color, linewidths=width, alpha=alpha, linestyles=style,
                label=label) is not None:
        label = None
    drawn = [lines.reshape(-1, 3), np.asarray(pos)]
    if ribbon > 0 and cv.plane is None:
        centre, across = section_ribbons(res, pos, eul, ribbon)
        a, b = centre - across, centre + across
        quads = np.stack([a[:, :-1], a[:, 1:], b[:, 1:], b[:, :-1]], axis=2).reshape(-1, 4, 3)
        cv.polygons(quads, facecolors=color, alpha=0.3 * alpha, edgecolors="none")
        cv.lines(segments(np.concatenate([a, b])), colors=color, linewidths=0.5,
                 alpha=0.6 * alpha)
        drawn += [a.reshape(-1, 3), b.reshape(-1, 3)]
    bars, polygons = rigid_segments(res, pos)
    cv.lines(bars, colors=color, linewidths=3 * width, alpha=0.6 * alpha, linestyles=style,
             capstyle="round", label=label)
    cv.polygons(polygons, facecolors=color, alpha=0.25 * alpha, edgecolors="none")
    return drawn + list(polygons)


def _hinges(cv, res, pos, label=True):
    hinge = hinge_positions(res, pos)
    if hinge.size:
        cv.scatter(hinge, s=70, facecolors="white", edgecolors="k", linewidths=1.5, zorder=5,
                   label="hinge" if label else None)


def _identity(m):
    euler0 = np.zeros((m.n_rot, 4))
    euler0[:, 0] = 1.0
    return euler0


def _plane(res, configs, ribbon=True):
    """The plane of the drawn configurations [(pos, eul), ...], or None (3-D)."""
    m = res.model
    pts = [m.position_x0] + [np.asarray(p) for p, _ in configs]
    pts += [centre_lines(res, p, e).reshape(-1, 3) for p, e in configs]
    return plane_of(np.concatenate(pts), np.concatenate(
        [rotation_vector(e) for _, e in configs] or [np.zeros((0, 3))]))


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
        Steps to draw (None: the last one; ``"all"``: every step). Several steps are
        coloured by their load factor (or time), with a colour bar that says which is which.
    color : {"auto", "stress", "plain"}
        ``auto`` colours a single drawn step by the largest von Mises stress of each element
        when the file has stresses.
    scale : float, optional
        Magnification of the displacements and rotations; default :func:`auto_scale` of the
        largest drawn displacement and rotation (1 when they are visible at true scale).
        Stated in the legend and the title.
    view : (float, float), optional
        Elevation and azimuth of the camera in degrees for a 3-D model (matplotlib's
        default: 30, -60); a planar model is drawn in 2-D.
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
    size = model_size(m)
    raw = [(s.position(step=int(k)), s.euler(step=int(k))) for k in steps]
    if scale is None:
        u_max = max(_largest(p - m.position_x0) for p, _ in raw)
        rot_max = max(_largest(rotation_vector(e)) for _, e in raw) if m.n_rot else 0.0
        scale = auto_scale(u_max, size, rot_max)
    scale = float(scale)
    configs = [magnify(m, p, e, scale) for p, e in raw]
    fig = Figure(figsize=(6.4, 5.6))
    cv = _Canvas(fig, _plane(res, configs))
    points = _draw(cv, res, m.position_x0, _identity(m), color="0.35", width=1.2, style="--",
                   label="undeformed")
    use_stress = (not transient and steps.size == 1
                  and (color == "stress" or (color == "auto" and s.has_stress)))
    magnified = _scale_text(scale)
    several = steps.size > 1
    if several:
        from matplotlib import colormaps, colors
        x = np.asarray(lf, dtype=float)[steps]
        norm = colors.Normalize(vmin=float(np.min(x)), vmax=float(np.max(x)) + (
            1e-12 if np.ptp(x) == 0 else 0.0))
        cmap = colormaps["viridis"]
    for i, (k, (pos, eul)) in enumerate(zip(steps, configs)):
        last = i == steps.size - 1
        label = f"step {k}, " + what_of.format(lf[k]) + magnified
        mises = (s.max_von_mises_stress(step=int(k)) / 1e6 if use_stress else None)
        tone = cmap(norm(x[i])) if several else "C0"
        points += _draw(cv, res, pos, eul, color=tone, width=2.0 if last else 1.3,
                        label=label if last else None, mises=mises, fig=fig,
                        ribbon=_RIBBON * size if last else 0.0)
        if last:
            cv.scatter(pos, s=6, color="k", zorder=4)
            _hinges(cv, res, pos)
    if several:
        from matplotlib.cm import ScalarMappable
        bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=cv.ax, shrink=0.6,
                           pad=0.12 if cv.plane is None else 0.04)
        bar.set_label("time [s]" if transient else "load factor")
        bar.set_ticks(sorted(set(np.round(x, 12).tolist()))[:12] if steps.size <= 12
                      else bar.get_ticks())
    cv.limits(np.concatenate(points), view)
    cv.ax.legend(loc="upper left", fontsize=8)
    what = ("deformed shape" if steps.size == 1 else
            f"deformed shapes, steps {steps[0]}..{steps[-1]} (colour: "
            f"{'time' if transient else 'load factor'})")
    cv.ax.set_title(title(res, what + magnified), fontsize=10)
    fig.spacarpy_scale = scale            # for scripts and tests: the factor drawn
    fig.spacarpy_plane = cv.plane
    return fig


def mode_figure(res: ResultsFile, mode: int = 1, step=None, group: str = "eigen",
                scale=None, view=None, **_):
    """A mode shape over the static state it was computed at, drawn at +amplitude and
    -amplitude: :func:`mode_amplitude` (or ``scale``), its rotations turned exactly
    (:func:`~spacarpy.results.plot_geometry.mode_configuration`), so that a torsion mode
    shows as the twist of the section band. The title states the amplitude and the largest
    displacement and rotation drawn."""
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
    u_amp = _largest(shape.position)
    rot_amp = _largest(mode_rotation(eul, shape.euler)) if len(eul) else 0.0
    if scale is None:
        scale = mode_amplitude(u_amp, rot_amp, size)
    scale = float(scale)
    configs = [mode_configuration(pos, eul, shape, sign * scale) for sign in (1, -1)]
    fig = Figure(figsize=(6.4, 5.6))
    cv = _Canvas(fig, _plane(res, configs + [(pos, eul)]))
    points = _draw(cv, res, pos, eul, color="0.55", width=1.0, style="--",
                   label=f"static state, step {k}")
    for (p, e), sign, tone in zip(configs, (1, -1), ("C3", "C0")):
        points += _draw(cv, res, p, e, color=tone, width=1.8, ribbon=1.5 * _RIBBON * size,
                        label=f"{'+' if sign > 0 else '-'} mode")
    _hinges(cv, res, pos)
    cv.limits(np.concatenate(points), view)
    cv.ax.legend(loc="upper left", fontsize=8)
    if group == "eigen":
        what = f"eigenmode {mode}: {lin.frequency[r, mode - 1]:.5g} Hz"
    else:
        what = f"buckling mode {mode}: load multiplier {lin.load_multiplier[r, mode - 1]:.5g}"
    drawn = (f"shape x{scale:.3g}: largest displacement {1e3 * scale * u_amp:.3g} mm, "
             f"rotation {np.degrees(scale * rot_amp):.3g} deg")
    cv.ax.set_title(title(res, f"{what} (step {k})\n{drawn}"), fontsize=10)
    fig.spacarpy_scale = scale
    fig.spacarpy_plane = cv.plane
    return fig


def animate(res: ResultsFile, out, fps: float = 20, max_frames: int = 200, scale=None,
            view=None, progress=None, **_):
    """Write an animation of the time steps (``/transient``; else the static steps) to
    ``out``: ``.gif`` (Pillow, which matplotlib needs anyway) or ``.mp4`` (needs ffmpeg).

    At most ``max_frames`` frames, evenly spread over the stored steps (the first and the
    last included); the axes stay fixed over all frames, 2-D for a planar model; ``scale``
    as in :func:`shape_figure` (its automatic factor over all frames). ``progress(done,
    total)`` is called after each frame. Returns the frame steps.
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
        rot = (np.linalg.norm(rotation_vector(euler[frames]), axis=-1) if m.n_rot
               else np.zeros(1))
        scale = auto_scale(float(np.max(u, initial=0.0)), model_size(m),
                           float(np.max(rot, initial=0.0)))
    scale = float(scale)
    configs = [magnify(m, position[k], euler[k], scale) for k in frames]
    every = np.concatenate([centre_lines(res, p, e).reshape(-1, 3) for p, e in configs]
                           + [p for p, _ in configs] + [m.position_x0])
    fig = Figure(figsize=(6.4, 5.6))
    FigureCanvasAgg(fig)
    plane = _plane(res, configs)
    cv = _Canvas(fig, plane)
    magnified = _scale_text(scale)
    ribbon = _RIBBON * model_size(m) if plane is None else 0.0
    # the undeformed shape, the axes and the legend are drawn once; each frame replaces
    # only the artists of the moving configuration
    _draw(cv, res, m.position_x0, _identity(m), color="0.6", width=1.0, style="--",
          label="undeformed")
    cv.limits(every, view)
    fixed = set(cv.ax.collections) | set(cv.ax.lines)

    def frame(i, k, pos, eul):
        """The moving artists of frame i (the configuration, its hinges, the title)."""
        for artist in list(cv.ax.collections) + list(cv.ax.lines):
            if artist not in fixed:
                artist.remove()
        _draw(cv, res, pos, eul, color="C0", width=2.0, ribbon=ribbon,
              label=f"deformed{magnified}")
        _hinges(cv, res, pos)
        cv.ax.set_title(title(res, what_of.format(x[k])), fontsize=10)
        return [a for a in list(cv.ax.collections) + list(cv.ax.lines) if a not in fixed]

    if out.suffix.lower() == ".gif":
        _blit_gif(fig, cv, frames, configs, frame, out, fps, progress)
        return frames
    with writer.saving(fig, str(out), dpi=80):
        for i, (k, (pos, eul)) in enumerate(zip(frames, configs)):
            frame(i, k, pos, eul)
            if i == 0:
                cv.ax.legend(loc="upper left", fontsize=8)
            writer.grab_frame()
            if progress is not None:
                progress(i + 1, frames.size)
    return frames


def _blit_gif(fig, cv, frames, configs, frame, out, fps, progress) -> None:
    """Write the GIF by blitting: the axes, ticks, legend and undeformed shape are drawn
    once; each frame restores that picture and draws only its own artists (the full redraw
    of every frame spent most of its time on tick labels)."""
    from PIL import Image

    fig.set_dpi(80)
    canvas = fig.canvas
    moving = frame(0, frames[0], *configs[0])
    cv.ax.legend(loc="upper left", fontsize=8)
    title_artist = cv.ax.title
    for a in moving + [title_artist]:
        a.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for i, (k, (pos, eul)) in enumerate(zip(frames, configs)):
        if i:
            moving = frame(i, k, pos, eul)
        canvas.restore_region(background)
        for a in moving:
            a.set_animated(True)
            if hasattr(a, "do_3d_projection"):
                a.do_3d_projection()
            cv.ax.draw_artist(a)
        fig.draw_artist(title_artist)
        images.append(Image.frombuffer("RGBA", canvas.get_width_height(),
                                       bytes(canvas.buffer_rgba()), "raw", "RGBA", 0, 1))
        if progress is not None:
            progress(i + 1, frames.size)
    images[0].save(out, save_all=True, append_images=images[1:],
                   duration=int(1000 / fps), loop=0)
