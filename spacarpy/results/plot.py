"""Figures of a results file with matplotlib (the optional ``plot`` extra).

This module's one job is drawing results: deformed shapes in 3D with equal axes (coloured by
the von Mises stress when cross-sections are known), load-displacement curves, frequencies and
buckling multipliers versus the load factor, step histories of any extractable quantity, and
mode shapes. Each ``*_figure`` function returns a :class:`matplotlib.figure.Figure` built
without pyplot (no window, no global state); :func:`save` writes it as PNG, PDF or SVG.

Beams are drawn as smooth centre lines: cubic Hermite curves through the element's nodes,
with the end tangents along the element's x-axis rotated by the nodal orientations (the
shape the DDM element describes), so that a few elements already look like the structure.

matplotlib is imported on first use; without it, :class:`PlotUnavailableError` says how to
install it (``pip install "spacarpy[plot]"``).
"""
from __future__ import annotations

import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.reader import ResultsFile, ResultsQueryError
from spacarpy.rotation import rotate

__all__ = ["PlotUnavailableError", "PLOTS", "make_figure", "shape_figure",
           "load_displacement_figure", "frequency_figure", "buckling_figure", "history_figure",
           "mode_figure", "save", "centre_lines", "straight_lines"]

#: Plot kinds of ``spacarpy plot`` and what they show.
PLOTS = {
    "shape": "undeformed and deformed shape in 3D (equal axes); --step, or --time for a "
             "transient run; coloured by the von Mises stress when cross-sections are known",
    "load-displacement": "load factor against the displacement of --node",
    "frequency": "natural frequencies against the load factor (--modes-per-step runs)",
    "buckling": "buckling load multipliers against the load factor",
    "history": "a quantity against the step: --quantity (displacement, position, reaction, "
               "section_forces, stress, strain_energy) with --node or --element; for a "
               "transient run against the time: --quantity displacement, position, velocity, "
               "euler, deformation, stress_resultant or energy",
    "mode": "eigenmode --mode (default 1) at --step, over the deformed shape",
    "buckling-mode": "buckling mode --mode (default 1) at --step",
}

_SUBDIVISIONS = 12       # points per element along the Hermite centre line, minus one


class PlotUnavailableError(SpacarError):
    """matplotlib is not installed."""

    exit_code = EXIT_INPUT


def _mpl():
    try:
        import matplotlib
        from matplotlib.figure import Figure
    except ImportError as exc:   # pragma: no cover - depends on the environment
        raise PlotUnavailableError(
            "plotting needs matplotlib, which is not installed: pip install "
            "\"spacarpy[plot]\" (or pip install matplotlib)") from exc
    return matplotlib, Figure


def save(fig, path) -> None:
    """Write ``fig`` to ``path``; the format follows the suffix (.png, .pdf, .svg)."""
    fig.savefig(path, dpi=110, bbox_inches="tight")


def make_figure(res: ResultsFile, kind: str, **options):
    """Build the figure ``kind`` (a key of :data:`PLOTS`) with the options it takes."""
    builders = {"shape": shape_figure, "load-displacement": load_displacement_figure,
                "frequency": frequency_figure, "buckling": buckling_figure,
                "history": history_figure, "mode": mode_figure,
                "buckling-mode": lambda r, **kw: mode_figure(r, group="buckling", **kw)}
    if kind not in builders:
        raise ResultsQueryError(f"unknown plot {kind!r}; choose one of {', '.join(PLOTS)}")
    return builders[kind](res, **options)


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
    of the other kinds than BEAM (TRUSS, RBEAM, PLTRUSS ...)."""
    from spacarpy.results.schema import slot_roles

    m, out = res.model, []
    for kind in m.element_kinds:
        if kind == "BEAM":
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


def _static(res):
    if res.static is None or res.static.n_step == 0:
        raise ResultsQueryError(f"{res.path} has no static load steps to plot")
    return res.static


def _title(res, text: str) -> str:
    name = str(res.attrs.get("deck_path", res.path)).rsplit("/", 1)[-1]
    state = "" if res.completed else " (incomplete run)"
    return f"{name}{state}\n{text}"


# --------------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------------

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
        Displacement magnification (default 1, true scale). Rotations are magnified through
        the vector part of the Euler parameters, which is exact for small rotations.
    view : (float, float), optional
        Elevation and azimuth of the camera in degrees (matplotlib's default: 30, -60).
    time : float, optional
        Draw the stored time step of ``/transient`` nearest to this time (s); ``step`` then
        counts time steps. A file with time steps and no load step draws ``/transient``.
    """
    _, Figure = _mpl()
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    m = res.model
    transient = time is not None or (
        res.transient is not None and res.transient.n_step
        and (res.static is None or res.static.n_step == 0))
    if transient:
        if res.transient is None or res.transient.n_step == 0:
            raise ResultsQueryError(f"{res.path} has no time steps (/transient) to plot")
        s = res.transient
        if time is not None:
            step = s.step_at(float(time))
        lf = s.time
        what_of = "t = {:.4g} s"
        color = "plain" if color == "auto" else color
    else:
        s = _static(res)
        lf = s.load_factor
        what_of = "load factor {:.4g}"
    steps = (np.arange(s.n_step) if isinstance(step, str) and step == "all"
             else np.atleast_1d(s.step_index(-1 if step is None else step)))
    steps = np.arange(s.n_step)[steps]
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    euler0 = np.zeros((m.n_rot, 4))
    euler0[:, 0] = 1.0
    undeformed = centre_lines(res, m.position_x0, euler0)
    _add_lines(ax, np.concatenate([_segments(undeformed), straight_lines(res, m.position_x0)]),
               colors="0.35", linestyles="--", linewidths=1.2, label="undeformed")
    points = [undeformed.reshape(-1, 3), m.position_x0]
    use_stress = not transient and (color == "stress" or (color == "auto" and s.has_stress))
    scale = 1.0 if scale is None else float(scale)

    def magnified(k):
        pos, eul = s.position(step=int(k)), s.euler(step=int(k))
        if scale == 1.0:
            return pos, eul
        eul = eul * np.sign(eul[:, :1] + (eul[:, :1] == 0))       # lambda0 >= 0
        return (m.position_x0 + scale * (pos - m.position_x0),
                np.column_stack([eul[:, :1], scale * eul[:, 1:]]))

    for i, k in enumerate(steps):
        pos, eul = magnified(k)
        lines = centre_lines(res, pos, eul)
        points.append(lines.reshape(-1, 3))
        points.append(pos)
        last = i == steps.size - 1
        label = f"step {k}, " + what_of.format(lf[k])
        if last and use_stress:
            mises = s.max_von_mises_stress(step=int(k)) / 1e6
            coll = Line3DCollection(_segments(lines), cmap="viridis", linewidths=2.4,
                                    label=label)
            coll.set_array(np.repeat(mises, lines.shape[1] - 1))
            ax.add_collection3d(coll)
            fig.colorbar(coll, ax=ax, shrink=0.6, pad=0.1,
                         label="largest von Mises stress [MPa]")
        else:
            alpha = 1.0 if last else 0.25 + 0.5 * i / max(steps.size - 1, 1)
            _add_lines(ax, np.concatenate([_segments(lines), straight_lines(res, pos)]),
                       colors="C0", linewidths=2.0 if last else 1.0, alpha=alpha,
                       label=label if last else None)
        if last:
            ax.scatter(pos[:, 0], pos[:, 1], pos[:, 2], s=10, color="k", depthshade=False)
    _equal_axes(ax, np.concatenate(points), view)
    ax.legend(loc="upper left", fontsize=8)
    what = ("deformed shape" if steps.size == 1 else
            f"deformed shapes, steps {steps[0]}..{steps[-1]}")
    if scale != 1.0:
        what += f", displacements x{scale:g}"
    ax.set_title(_title(res, what), fontsize=10)
    return fig


def load_displacement_figure(res: ResultsFile, node=None, **_):
    """Load factor against the displacement components of ``node`` (default: the position
    node that moves most)."""
    _, Figure = _mpl()
    s, m = _static(res), res.model
    if node is None:
        node = int(m.position_nodes[np.argmax(np.linalg.norm(s.displacement(step=-1),
                                                             axis=-1))])
    u = s.displacement(node=node)
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    for c, name in enumerate(("ux", "uy", "uz")):
        if np.ptp(u[:, c]) > 0 or c == 0:
            ax.plot(u[:, c], s.load_factor, "o-", ms=3, label=name)
    ax.plot(np.linalg.norm(u, axis=1), s.load_factor, "k--", lw=1, label="|u|")
    ax.set_xlabel(f"displacement of node {node} [m]")
    ax.set_ylabel("load factor")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(_title(res, f"load-displacement curve, node {node}"), fontsize=10)
    return fig


def frequency_figure(res: ResultsFile, mode=None, **_):
    """Natural frequencies of the linearized steps against the load factor."""
    _, Figure = _mpl()
    e = res.eigen
    if e is None or e.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no frequencies (run with --mode eigen or "
                                "--modes-per-step)")
    f, lf = e.frequency, e.load_factor
    modes = np.arange(e.n_mode) if mode is None else np.array([e._mode_index(mode)])
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    for j in modes:
        ax.plot(lf, f[:, j], "o-", ms=3, label=f"mode {j + 1}")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("load factor")
    ax.set_ylabel("frequency [Hz] (negative: unstable)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.set_title(_title(res, "natural frequencies against the load"), fontsize=10)
    return fig


def buckling_figure(res: ResultsFile, mode=None, **_):
    """Critical buckling load multiplier (and the first multipliers) against the load
    factor."""
    _, Figure = _mpl()
    b = res.buckling
    if b is None or b.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no buckling results (run with --mode "
                                "buckling or --modes-per-step)")
    lf, mult, crit = b.load_factor, b.load_multiplier, b.critical_load_multiplier
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    ax.plot(lf, np.where(np.isfinite(crit), crit, np.nan), "ko-", ms=4,
            label="critical (smallest positive)")
    modes = range(min(b.n_mode, 4)) if mode is None else [b._mode_index(mode)]
    for j in modes:
        ax.plot(lf, mult[:, j], ".--", lw=0.8, label=f"multiplier {j + 1}")
    ax.set_xlabel("load factor")
    ax.set_ylabel("buckling load multiplier")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(_title(res, "buckling load multipliers against the load"), fontsize=10)
    return fig


def history_figure(res: ResultsFile, quantity: str = "displacement", node=None, element=None,
                   **_):
    """A per-step quantity of one node or element against the step (and load factor)."""
    from spacarpy.results.tables import extract

    timed = _TIMED.get(quantity)
    if timed is not None and res.transient is not None and res.transient.n_step and (
            res.static is None or res.static.n_step == 0 or quantity in ("velocity",
                                                                         "energy")):
        return _time_history_figure(res, timed, quantity, node, element)
    if quantity not in ("displacement", "position", "euler", "reaction", "section_forces",
                        "stress", "strain_energy", "deformation", "stress_resultant"):
        raise ResultsQueryError(f"history of {quantity!r} is not supported")
    if quantity in ("displacement", "position", "euler", "reaction") and node is None:
        raise ResultsQueryError(f"history of {quantity}: give --node")
    if quantity not in ("displacement", "position", "euler", "reaction") and element is None:
        raise ResultsQueryError(f"history of {quantity}: give --element")
    _, Figure = _mpl()
    table = extract(res, quantity, node=node, element=element)
    names = table.names
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    step = np.asarray(table.columns[0])
    if quantity == "reaction":
        comp = np.asarray(table.columns[3])
        value = np.asarray(table.columns[4], dtype=float)
        for c in dict.fromkeys(comp.tolist()):
            sel = comp == c
            unit = "N" if c[0] == "F" else "N m"
            ax.plot(step[sel], value[sel], "o-", ms=3, label=f"{c} [{unit}]")
    else:
        for j in range(3, len(names)):
            ax.plot(step, np.asarray(table.columns[j], dtype=float), "o-", ms=3,
                    label=f"{names[j]} [{table.units[j]}]")
    ax.set_xlabel("step")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    lf = np.asarray(table.columns[1], dtype=float)
    if step.size > 1 and np.all(np.diff(lf) > 0):      # a second axis with the load factor
        top = ax.secondary_xaxis("top", functions=(
            lambda x: np.interp(x, step, lf), lambda y: np.interp(y, lf, step)))
        top.set_xlabel("load factor")
    what = f"node {node}" if element is None else f"element {element}"
    ax.set_title(_title(res, f"{quantity}, {what}"), fontsize=10)
    return fig


#: quantities of ``plot history`` with a time history in ``/transient``
_TIMED = {"displacement": "time_displacement", "position": "time_position",
          "velocity": "time_velocity", "euler": "time_euler",
          "deformation": "time_deformation", "stress_resultant": "time_stress_resultant",
          "energy": "energy"}


def _time_history_figure(res, what, quantity, node, element):
    """A time history of ``/transient`` (time on the x axis)."""
    from spacarpy.results.tables import extract

    if quantity in ("displacement", "position", "velocity", "euler") and node is None:
        raise ResultsQueryError(f"history of {quantity}: give --node")
    _, Figure = _mpl()
    table = extract(res, what, node=node, element=element)
    time = np.asarray(table.columns[0], dtype=float)
    first = 4 if what == "energy" else 3          # after time, step and the entity
    names = table.names
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    for j in range(first, len(names)):
        unit = table.units[j]
        ax.plot(time, np.asarray(table.columns[j], dtype=float), "-", lw=1.2,
                label=f"{names[j]} [{unit}]" if unit != "1" else names[j])
    ax.set_xlabel("time [s]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    what_of = ("energies" if what == "energy" else
               f"node {node}" if element is None else f"element {element}")
    ax.set_title(_title(res, f"{quantity} against time, {what_of}"), fontsize=10)
    return fig


def mode_figure(res: ResultsFile, mode: int = 1, step=None, group: str = "eigen",
                scale=None, view=None, **_):
    """A mode shape over the static state it was computed at.

    The mode's position part is scaled so that its largest nodal displacement is 15 % of the
    model's size (or by ``scale``); it is drawn at +scale and -scale.
    """
    _, Figure = _mpl()
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    lin = getattr(res, group)
    if lin is None or lin.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no /{group} results")
    mode = 1 if mode is None else int(mode)
    r = lin.row(step)
    k = int(lin.step[r])
    shape = lin.shape(mode=mode, step=k)
    s = _static(res)
    pos, eul = s.position(step=k), s.euler(step=k)
    size = float(np.max(np.ptp(pos, axis=0))) or 1.0
    amp = float(np.max(np.linalg.norm(shape.position, axis=1)))
    if scale is None:
        scale = 0.15 * size / amp if amp > 0 else 1.0
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    base = centre_lines(res, pos, eul)
    ax.add_collection3d(Line3DCollection(_segments(base), colors="0.55", linestyles="--",
                                         linewidths=1.0, label=f"static state, step {k}"))
    points = [base.reshape(-1, 3)]
    for sign, style in ((1, "C3"), (-1, "C0")):
        lines = centre_lines(res, pos + sign * scale * shape.position,
                             eul + sign * scale * shape.euler)
        points.append(lines.reshape(-1, 3))
        ax.add_collection3d(Line3DCollection(_segments(lines), colors=style, linewidths=1.8,
                                             label=f"{'+' if sign > 0 else '-'} mode"))
    _equal_axes(ax, np.concatenate(points), view)
    ax.legend(loc="upper left", fontsize=8)
    if group == "eigen":
        f = lin.frequency[r, mode - 1]
        what = f"eigenmode {mode}: {f:.5g} Hz"
    else:
        what = f"buckling mode {mode}: load multiplier {lin.load_multiplier[r, mode - 1]:.5g}"
    ax.set_title(_title(res, f"{what} (step {k}, shape x{scale:.3g})"), fontsize=10)
    return fig
