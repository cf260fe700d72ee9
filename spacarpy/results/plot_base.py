"""What the figure modules share: matplotlib on demand, output checks, titles, and the
prescribed quantity of a run as an x axis.

This module's one job is the plumbing under :mod:`spacarpy.results.plot` (curves) and
:mod:`spacarpy.results.plot_shapes` (3D shapes and animations). matplotlib is imported on first
use; without it, :class:`PlotUnavailableError` says how to install it.

The prescribed quantity (:func:`prescribed_axis`) is what a static run drives with the load
factor, in its own units:

- a prescribed deformation (``INPUTE`` with ``DELINPE``): the first one's value read back from
  ``/static/elements/<KIND>/deformation`` at every step; an angle (the first mode of a HINGE
  or PLHINGE) in mrad, a length in mm;
- otherwise a ``DELXF`` load: the load factor times the magnitude of the largest ``DELXF``
  line, in N (a force on a position node) or N m (a moment on an orientation node).

Plots of frequencies, buckling multipliers and load-displacement curves put it on the x axis
(``--x prescribed``, the default where the run has one) instead of the load factor.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.reader import ResultsQueryError

__all__ = ["PlotUnavailableError", "PlotOutputError", "IMAGE_SUFFIXES", "ANIMATION_SUFFIXES",
           "check_output", "save", "PrescribedAxis", "prescribed_axis", "x_axis"]

#: image formats of ``spacarpy plot`` (the suffix of ``-o``)
IMAGE_SUFFIXES = (".png", ".pdf", ".svg")
#: animation formats of ``spacarpy plot ... animate``
ANIMATION_SUFFIXES = (".gif", ".mp4")


class PlotUnavailableError(SpacarError):
    """matplotlib (or the animation writer) is not installed."""

    exit_code = EXIT_INPUT


class PlotOutputError(SpacarError):
    """The output file cannot be written (no such directory, a directory, an unknown
    format): found before any work."""

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


def check_output(path, suffixes=IMAGE_SUFFIXES, what: str = "plot") -> Path:
    """``path`` as a :class:`~pathlib.Path` if it can be written with one of ``suffixes``;
    else :class:`PlotOutputError` saying why (checked before any work is done)."""
    path = Path(path)
    if str(path) in ("", "."):
        raise PlotOutputError(f"{what}: -o needs a file name")
    if path.suffix.lower() not in suffixes:
        raise PlotOutputError(f"{what}: cannot write {path}: unknown format "
                              f"{path.suffix or '(no suffix)'!r}; use "
                              f"{', '.join(suffixes)}")
    if path.is_dir():
        raise PlotOutputError(f"{what}: cannot write {path}: it is a directory")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise PlotOutputError(f"{what}: cannot write {path}: the directory {parent} does not "
                              "exist")
    if not os.access(parent, os.W_OK):
        raise PlotOutputError(f"{what}: cannot write {path}: the directory {parent} is not "
                              "writable")
    return path


def save(fig, path) -> None:
    """Write ``fig`` to ``path``; the format follows the suffix (.png, .pdf, .svg)."""
    fig.savefig(check_output(path), dpi=110, bbox_inches="tight")


def static_view(res):
    """``res.static`` with at least one step, else :class:`ResultsQueryError`."""
    if res.static is None or res.static.n_step == 0:
        raise ResultsQueryError(f"{res.path} has no static load steps to plot")
    return res.static


def title(res, text: str) -> str:
    """The figure title: the deck's name (and whether the run finished), then ``text``."""
    name = str(res.attrs.get("deck_path", res.path)).rsplit("/", 1)[-1]
    state = "" if res.completed else " (incomplete run)"
    return f"{name}{state}\n{text}"


@dataclass(frozen=True)
class PrescribedAxis:
    """A quantity a static run prescribes, per static step: ``values`` (n_step,) in ``unit``;
    ``label`` is the axis label."""

    values: np.ndarray
    unit: str
    label: str


_ANGLE_KINDS = ("HINGE", "PLHINGE")


def prescribed_axis(res) -> PrescribedAxis | None:
    """The prescribed quantity of the run's static steps (see the module docstring), or None
    when it prescribes nothing (only XF loads, or a prescribed coordinate)."""
    s, m = res.static, res.model
    if s is None or s.n_step == 0:
        return None
    inputs = (res._read("model/input_deformation") if res._has("model/input_deformation")
              else np.zeros((0, 2)))
    for element, mode in np.asarray(inputs, dtype=int).reshape(-1, 2):
        for kind in m.element_kinds:
            ids = m.element_ids(kind)
            if element not in ids or not res._has(f"static/elements/{kind}/deformation"):
                continue
            value = s.deformation(element=int(element), kind=kind)[:, mode - 1]
            if kind in _ANGLE_KINDS and mode == 1:
                return PrescribedAxis(1e3 * value, "mrad",
                                      f"prescribed angle of {kind} {element} [mrad]")
            return PrescribedAxis(1e3 * value, "mm", f"prescribed deformation {mode} of "
                                                     f"{kind} {element} [mm]")
    if res._has("model/load_type") and res._length("model/load_type"):
        kinds = np.asarray([str(t.decode() if isinstance(t, bytes) else t)
                            for t in res._read("model/load_type")])
        value = np.asarray(res._read("model/load_value"), dtype=float)
        nodes = np.asarray(res._read("model/load_node"), dtype=int)
        rows = np.flatnonzero(kinds == "DELXF")
        if rows.size:
            size = np.linalg.norm(value[rows], axis=1)
            j = rows[int(np.argmax(size))]           # first of equal ones: argmax is stable
            if size.max() > 0:
                moment = m.node_kind(int(nodes[j])) == "orientation"
                unit = "N m" if moment else "N"
                what = "moment" if moment else "force"
                return PrescribedAxis(s.load_factor * float(np.linalg.norm(value[j])), unit,
                                      f"DELXF {what} on node {nodes[j]} [{unit}]")
    return None


def x_axis(res, load_factor, steps, choice: str = "auto"):
    """(values, label) of the x axis for quantities at the static steps ``steps``:
    ``choice`` = ``"load-factor"``, ``"prescribed"`` or ``"auto"`` (the prescribed quantity
    when the run has one)."""
    if choice not in ("auto", "prescribed", "load-factor"):
        raise ResultsQueryError(f"--x {choice!r}: choose auto, prescribed or load-factor")
    if choice != "load-factor":
        axis = prescribed_axis(res)
        if axis is not None:
            return axis.values[np.asarray(steps, dtype=int)], axis.label
        if choice == "prescribed":
            raise ResultsQueryError(f"{res.path}: the run prescribes no deformation "
                                    "(INPUTE) and no DELXF load; use --x load-factor")
    return np.asarray(load_factor, dtype=float), "load factor"
