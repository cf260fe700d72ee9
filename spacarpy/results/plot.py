"""Figures of a results file with matplotlib (the optional ``plot`` extra): curves, and the
entry point of ``spacarpy plot``.

This module's one job is the curves: load-displacement, frequencies and buckling multipliers
against the load (or the quantity the run prescribes, :func:`~spacarpy.results.plot_base.
prescribed_axis`), step and time histories; and :func:`make_figure`, which picks any figure
by name. The 3D shapes, mode shapes and animations are in :mod:`spacarpy.results.plot_shapes`.
Each ``*_figure`` function returns a :class:`matplotlib.figure.Figure` built without pyplot (no
window, no global state); :func:`save` writes it as PNG, PDF or SVG.

matplotlib is imported on first use; without it, :class:`PlotUnavailableError` says how to
install it (``pip install "spacarpy[plot]"``).
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.plot_base import PlotUnavailableError, _mpl, save, static_view, title, x_axis
from spacarpy.results.plot_shapes import (
    animate,
    centre_lines,
    mode_figure,
    shape_figure,
    straight_lines,
)
from spacarpy.results.plot_sweep import root_locus_figure
from spacarpy.results.reader import ResultsFile, ResultsQueryError

__all__ = ["PlotUnavailableError", "PLOTS", "make_figure", "shape_figure",
           "load_displacement_figure", "path_figure", "frequency_figure", "buckling_figure",
           "history_figure", "mode_figure", "root_locus_figure", "animate", "save",
           "centre_lines", "straight_lines"]

_X = ("; x axis: the quantity the run prescribes (a DELINPE angle in mrad, a DELXF force in "
      "N) where it has one, else the load factor (--x)")

#: Plot kinds of ``spacarpy plot`` and what they show.
PLOTS = {
    "shape": "undeformed and deformed shape (2-D for a planar model, else 3-D; equal axes); "
             "--step, --all-steps, or --time for a "
             "transient run; displacements magnified automatically when small (--scale); "
             "coloured by the von Mises stress when cross-sections are known",
    "load-displacement": "load against the displacement of --node" + _X,
    "path": "the equilibrium path: the load (the reaction of a prescribed coordinate, a DELXF "
            "force or the load factor) against the displacement --dof (x, y, z) of --node "
            "(default: the loaded node), "
            "critical points marked where the file has them (docs/path.md)",
    "frequency": "natural frequencies against the load (--modes-per-step runs)" + _X,
    "buckling": "buckling load multipliers against the load" + _X,
    "history": "a quantity against the step: --quantity (displacement, position, reaction, "
               "section_forces, stress, strain_energy) with --node or --element, one panel "
               "per unit; for a "
               "transient run against the time: --quantity displacement, position, velocity, "
               "euler, deformation, stress_resultant or energy",
    "mode": "eigenmode --mode (default 1) at --step, over the deformed shape; a twist "
            "shows as the turn of the band along each beam",
    "buckling-mode": "buckling mode --mode (default 1) at --step",
    "root-locus": "a sweep file's poles (spacarpy sweep DECK --set V=0:10:101 --collect "
                  "/state_space/pole) against the swept parameter: real and imaginary parts "
                  "(docs/rolling.md)",
    "animate": "an animation of the time steps (or the load steps) to -o NAME.gif (or .mp4 "
               "when ffmpeg is installed)",
}


def make_figure(res: ResultsFile, kind: str, **options):
    """Build the figure ``kind`` (a key of :data:`PLOTS` other than ``animate``) with the
    options it takes."""
    builders = {"shape": shape_figure, "load-displacement": load_displacement_figure,
                "frequency": frequency_figure, "buckling": buckling_figure,
                "history": history_figure, "mode": mode_figure, "path": path_figure,
                "buckling-mode": lambda r, **kw: mode_figure(r, group="buckling", **kw),
                "root-locus": lambda r, **kw: root_locus_figure(r.path)}
    if kind not in builders:
        raise ResultsQueryError(f"unknown plot {kind!r}; choose one of "
                                f"{', '.join(k for k in PLOTS if k != 'animate')}")
    return builders[kind](res, **options)


def load_displacement_figure(res: ResultsFile, node=None, x="auto", **_):
    """The load (the prescribed quantity, or the load factor: ``x`` as in
    :func:`~spacarpy.results.plot_base.x_axis`) against the displacement components of
    ``node`` (default: the position node that moves most)."""
    _, Figure = _mpl()
    s, m = static_view(res), res.model
    if node is None:
        node = int(m.position_nodes[np.argmax(np.linalg.norm(s.displacement(step=-1),
                                                             axis=-1))])
    u = s.displacement(node=node)
    load, load_label = x_axis(res, s.load_factor, np.arange(s.n_step), x)
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    for c, name in enumerate(("ux", "uy", "uz")):
        if np.ptp(u[:, c]) > 0 or c == 0:
            ax.plot(u[:, c], load, "o-", ms=3, label=name)
    ax.plot(np.linalg.norm(u, axis=1), load, "k--", lw=1, label="|u|")
    ax.set_xlabel(f"displacement of node {node} [m]")
    ax.set_ylabel(load_label)
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title(res, f"load-displacement curve, node {node}"), fontsize=10)
    return fig


def path_figure(res: ResultsFile, node=None, dof=None, x="auto", **_):
    """The equilibrium path of :func:`~spacarpy.results.path.path_curve`: the load against
    the displacement ``dof`` of ``node``, its points in step order (an arc-length path may
    turn back), the critical points of ``/critical`` marked and labelled."""
    from spacarpy.results.path import loaded_node, path_curve

    _, Figure = _mpl()
    c = path_curve(res, node=node, dof=dof, x=x)
    named = (" (the loaded node)" if c.node == loaded_node(res) else
             " (the prescribed coordinate)" if node is None and c.load_name.startswith(
                 "reaction") else "")
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    ax.plot(c.displacement, c.load, "o-", ms=2.5, lw=1.2, label="stored steps")
    ax.plot(c.displacement[:1], c.load[:1], "ks", ms=5, label="step 0")
    markers = {"limit": "v", "bifurcation": "D"}
    for kind in dict.fromkeys(c.critical_kind):
        sel = np.array([k == kind for k in c.critical_kind])
        steps = c.critical_step[sel]
        ok = (steps >= 0) & (steps < c.step.size)
        if ok.any():
            ax.plot(c.displacement[steps[ok]], c.load[steps[ok]],
                    markers.get(kind.split()[0], "*"), ms=8, mfc="none", mew=1.5, label=kind)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(f"displacement u{c.dof} of node {c.node} [m]")
    ax.set_ylabel(c.load_label)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title(res, f"equilibrium path, node {c.node}{named}, u{c.dof}"),
                 fontsize=10)
    return fig


def frequency_figure(res: ResultsFile, mode=None, x="auto", **_):
    """Natural frequencies of the linearized steps against the load factor or the quantity
    the run prescribes (``x`` as in :func:`~spacarpy.results.plot_base.x_axis`). The legend
    stands to the right of the axes, clear of every curve."""
    _, Figure = _mpl()
    e = res.eigen
    if e is None or e.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no frequencies (run with --mode eigen or "
                                "--modes-per-step)")
    f = e.frequency
    lf, x_label = x_axis(res, e.load_factor, e.step, x)
    modes = np.arange(e.n_mode) if mode is None else np.array([e._mode_index(mode)])
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    for j in modes:
        ax.plot(lf, f[:, j], "o-", ms=3, label=f"mode {j + 1}")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(x_label)
    ax.set_ylabel("frequency [Hz] (negative: unstable)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.set_title(title(res, "natural frequencies against the load"), fontsize=10)
    return fig


def buckling_figure(res: ResultsFile, mode=None, x="auto", **_):
    """Critical buckling load multiplier (and the first multipliers) against the load
    factor or the quantity the run prescribes (``x`` as in
    :func:`~spacarpy.results.plot_base.x_axis`)."""
    _, Figure = _mpl()
    b = res.buckling
    if b is None or b.n_lin == 0:
        raise ResultsQueryError(f"{res.path} has no buckling results (run with --mode "
                                "buckling or --modes-per-step)")
    mult, crit = b.load_multiplier, b.critical_load_multiplier
    lf, x_label = x_axis(res, b.load_factor, b.step, x)
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot()
    ax.plot(lf, np.where(np.isfinite(crit), crit, np.nan), "ko-", ms=4,
            label="critical (smallest positive)")
    modes = range(min(b.n_mode, 4)) if mode is None else [b._mode_index(mode)]
    for j in modes:
        ax.plot(lf, mult[:, j], ".--", lw=0.8, label=f"multiplier {j + 1}")
    ax.set_xlabel(x_label)
    ax.set_ylabel("buckling load multiplier")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.set_title(title(res, "buckling load multipliers against the load"), fontsize=10)
    return fig


def history_figure(res: ResultsFile, quantity: str = "displacement", node=None, element=None,
                   **_):
    """A per-step quantity of one node or element against the step, with the load factor of
    each step on the top axis (ticks at the steps themselves).

    A file with time steps draws their time history (time on the x axis) for the quantities
    ``/transient`` has, also when a static preload (``START static``) precedes them.
    """
    from spacarpy.results.tables import extract

    timed = _TIMED.get(quantity)
    if timed is not None and res.transient is not None and res.transient.n_step:
        return _time_history_figure(res, timed, quantity, node, element)
    if quantity not in ("displacement", "position", "euler", "reaction", "section_forces",
                        "stress", "strain_energy", "deformation", "stress_resultant"):
        raise ResultsQueryError(f"history of {quantity!r} is not supported")
    if quantity in ("displacement", "position", "euler", "reaction") and node is None:
        raise ResultsQueryError(f"history of {quantity}: give --node")
    if quantity not in ("displacement", "position", "euler", "reaction") and element is None:
        raise ResultsQueryError(f"history of {quantity}: give --element")
    table = extract(res, quantity, node=node, element=element)
    names = table.names
    step = np.asarray(table.columns[0])
    curves = []                                   # (x, y, label, unit)
    if quantity == "reaction":
        comp = np.asarray(table.columns[3])
        value = np.asarray(table.columns[4], dtype=float)
        for c in dict.fromkeys(comp.tolist()):
            sel = comp == c
            curves.append((step[sel], value[sel], c, "N" if c[0] == "F" else "N m"))
    else:
        for j in range(3, len(names)):
            curves.append((step, np.asarray(table.columns[j], dtype=float), names[j],
                           table.units[j]))
    fig, axes = _unit_panels(quantity, curves, "o-", dict(ms=3))
    axes[-1].set_xlabel("step")
    _load_factor_ticks(axes[0], step, np.asarray(table.columns[1], dtype=float))
    what = f"node {node}" if element is None else f"element {element}"
    axes[0].set_title(title(res, f"{quantity}, {what}"), fontsize=10)
    return fig


_UNIT_NAMES = {"N": "force", "N m": "moment", "m": "length", "J": "energy", "MPa": "stress",
               "rad": "angle", "m/s": "velocity", "1": "value"}


def _unit_panels(quantity, curves, fmt, style):
    """A figure with one panel per unit of ``curves`` [(x, y, label, unit), ...] stacked on
    a shared x axis; each y axis labelled with the quantity and its one unit (stresses in
    MPa). Returns (figure, axes)."""
    _, Figure = _mpl()
    curves = [(x, y / 1e6, label, "MPa") if unit == "Pa" else (x, y, label, unit)
              for x, y, label, unit in curves]          # stresses in MPa, as the shapes
    units = list(dict.fromkeys(c[3] for c in curves))
    fig = Figure(figsize=(6.4, 4.4 if len(units) == 1 else 2.2 + 2.2 * len(units)))
    axes = fig.subplots(len(units), 1, sharex=True, squeeze=False)[:, 0]
    name = quantity.replace("_", " ")
    for ax, unit in zip(axes, units):
        mine = [c for c in curves if c[3] == unit]
        for n, (x, y, label, _) in enumerate(mine):
            # line styles and markers differ, so that equal curves do not hide each other
            ax.plot(x, y, ls=("-", "--", "-.", ":")[n % 4], label=label,
                    marker=("o", "s", "^", "v", "D", "x")[n % 6] if fmt.startswith("o")
                    else None, **style)
        what = name if len(units) == 1 else f"{name}: {_UNIT_NAMES.get(unit, unit)}"
        ax.set_ylabel(what if unit == "1" else f"{what} [{unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                  borderaxespad=0.0)
    return fig, axes


def _load_factor_ticks(ax, step, lf) -> None:
    """A top axis with the load factor of the steps, its ticks at (about 8 of) the steps
    themselves, the same as the bottom axis's, so that each label stands over its step."""
    step, first = np.unique(np.asarray(step, dtype=int), return_index=True)
    if step.size < 2:
        return
    from matplotlib.ticker import MaxNLocator

    lf = lf[first]
    ticks = [int(t) for t in MaxNLocator(nbins=8, integer=True).tick_values(step[0], step[-1])
             if t in set(step.tolist())]
    ax.set_xticks(ticks)
    top = ax.secondary_xaxis("top")
    top.set_xticks(ticks, labels=[f"{lf[np.searchsorted(step, t)]:.3g}" for t in ticks])
    top.set_xlabel("load factor")


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
    table = extract(res, what, node=node, element=element)
    time = np.asarray(table.columns[0], dtype=float)
    if what == "energy":
        return _energy_figure(res, table, time)
    names = table.names
    curves = [(time, np.asarray(table.columns[j], dtype=float), names[j], table.units[j])
              for j in range(3, len(names))]
    fig, axes = _unit_panels(quantity, curves, "-", dict(lw=1.2))
    axes[-1].set_xlabel("time [s]")
    ax = axes[0]
    what_of = f"node {node}" if element is None else f"element {element}"
    if res.static is not None and res.static.n_step > 1:
        what_of += f" (after {res.static.n_step - 1} static preload steps)"
    ax.set_title(title(res, f"{quantity} against time, {what_of}"), fontsize=10)
    return fig


def _energy_figure(res, table, time):
    """Energies against time (upper panel, J) and, on its own axis below, the balance
    ``T + U + D - W`` (kinetic, elastic, dissipated energy, work of the loads) and its drift
    from t = 0, which an exact integration keeps constant."""
    _, Figure = _mpl()
    col = {n: np.asarray(c, dtype=float) for n, c in zip(table.names, table.columns)}
    fig = Figure(figsize=(6.4, 6.2))
    top, low = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    names = {"kinetic_energy": "kinetic T", "elastic_energy": "elastic U",
             "external_work": "work of the loads W", "dissipated_energy": "dissipated D"}
    for j, (key, label) in enumerate(names.items()):
        if key == "dissipated_energy" and not np.any(col[key]):
            continue
        top.plot(time, col[key], ("-", "--", ":", "-.")[j], lw=1.4, label=label)
    top.set_ylabel("energy [J]")
    balance = col["kinetic_energy"] + col["elastic_energy"] + col["dissipated_energy"] \
        - col["external_work"]
    drift = balance - balance[0]
    low.plot(time, balance, "C4-", lw=1.2, label="T + U + D - W")
    low.axhline(balance[0], color="k", lw=0.6, ls=":", label=f"at t = {time[0]:.3g} s")
    low.set_ylabel("energy balance [J]")
    low.set_xlabel("time [s]")
    worst = int(np.argmax(np.abs(drift)))
    scale = max(float(np.max(np.abs(col["kinetic_energy"]))),
                float(np.max(np.abs(col["elastic_energy"]))),
                float(np.max(np.abs(col["external_work"]))))
    rel = f" ({abs(drift[worst]) / scale:.2g} of the largest energy)" if scale > 0 else ""
    low.set_title(f"drift: largest |change| {abs(drift[worst]):.3g} J at t = "
                  f"{time[worst]:.3g} s{rel}", fontsize=9)
    for ax in (top, low):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    pre = (f" (after {res.static.n_step - 1} static preload steps)"
           if res.static is not None and res.static.n_step > 1 else "")
    top.set_title(title(res, f"energies against time{pre}"), fontsize=10)
    fig.spacarpy_balance = balance
    return fig
