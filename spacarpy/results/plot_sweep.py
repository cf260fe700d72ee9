"""Figures of a sweep file (``spacarpy sweep``, docs/batch.md): the root locus.

This module's one job is ``spacarpy plot SWEEP.h5 root-locus``: the poles that a sweep over one
SET parameter collected (``--collect /state_space/pole``, mode 9 or mode 3 runs) drawn against
that parameter, real parts as dots and the positive imaginary parts as a second colour, as in
Meijaard et al. (2007) Fig. 3 for the benchmark bicycle's eigenvalues against the forward speed
(docs/rolling.md). Poles that are exactly zero (the kinematic states' zeros of a steady motion,
certified zeros of the linearization) are left out and counted in the legend; points whose run
failed (``/sweep/status`` not 0) are left out and counted too. Where the largest real part of
the drawn poles changes sign between two neighbouring points (a change of stability: the
bicycle's weave and capsize speeds), a dashed line marks the parameter value interpolated
linearly between them, which is as exact as the sweep is fine.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from spacarpy.results.plot_base import _mpl
from spacarpy.results.reader import ResultsQueryError

__all__ = ["RootLocus", "read_root_locus", "root_locus_figure"]

#: The dataset of a sweep file that holds the collected poles.
POLES = "state_space/pole"


class RootLocus:
    """The poles of a sweep: ``parameter`` (name), ``values`` (n_points,) and ``poles``
    (n_points, n_state) of the points that ran; ``n_failed`` points left out."""

    def __init__(self, parameter: str, values, poles, n_failed: int, deck: str):
        self.parameter, self.values, self.poles = parameter, values, poles
        self.n_failed, self.deck = n_failed, deck

    def points(self):
        """(x, real parts, x, imaginary parts): every nonzero pole at its parameter value; the
        imaginary parts of those above the real axis (the conjugates mirror them)."""
        x = np.broadcast_to(self.values[:, None], self.poles.shape)
        keep = self.poles != 0
        upper = keep & (self.poles.imag > 0)
        return x[keep], self.poles.real[keep], x[upper], self.poles.imag[upper]

    def stability_changes(self) -> np.ndarray:
        """The parameter values where the largest real part of the nonzero poles changes
        sign, interpolated linearly between neighbouring points (in the order swept)."""
        re = np.where(self.poles != 0, self.poles.real, -np.inf).max(axis=1)
        out = []
        for i in range(re.size - 1):
            a, b = re[i], re[i + 1]
            if np.isfinite(a) and np.isfinite(b) and (a > 0) != (b > 0):
                x0, x1 = self.values[i], self.values[i + 1]
                out.append(x0 + (x1 - x0) * a / (a - b))
        return np.array(out)


def read_root_locus(path) -> RootLocus:
    """The poles of the sweep file ``path``.

    Raises
    ------
    ResultsQueryError
        When the file is not a sweep over one parameter that collected /state_space/pole.
    """
    import h5py
    path = Path(path)
    hint = (f"{path}: root-locus draws a sweep over one SET parameter that collected the "
            f"poles: spacarpy sweep DECK --set V=0:10:101 --collect /{POLES}")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ResultsQueryError(f"{hint} (cannot read it: {exc})") from None
    with f:
        kind = f.attrs.get("filetype")
        kind = kind.decode() if isinstance(kind, bytes) else kind
        if kind != "spacarpy-sweep" or POLES not in f:
            raise ResultsQueryError(hint)
        names = [n.decode() if isinstance(n, bytes) else str(n)
                 for n in np.atleast_1d(f.attrs.get("parameters", []))]
        if len(names) != 1:
            raise ResultsQueryError(f"{hint}; this one sweeps {len(names)} parameters "
                                    f"({', '.join(names)})")
        values = np.asarray(f["parameters"][names[0]][()], float)
        poles = np.asarray(f[POLES][()], complex).reshape(values.size, -1)
        status = np.asarray(f["sweep/status"][()]).reshape(-1)
        deck = f.attrs.get("deck_path", "")
        deck = deck.decode() if isinstance(deck, bytes) else str(deck)
    ok = (status == 0) & np.all(np.isfinite(poles), axis=1)
    if not ok.any():
        raise ResultsQueryError(f"{path}: no point of the sweep ran (see spacarpy show)")
    return RootLocus(names[0], values[ok], poles[ok], int(np.count_nonzero(~ok)), deck)


def root_locus_figure(path, **_):
    """The root locus of the sweep file ``path``: real (black) and imaginary (blue) parts of
    the poles against the swept parameter."""
    _, Figure = _mpl()
    rl = read_root_locus(path)
    xr, re, xi, im = rl.points()
    fig = Figure(figsize=(7.0, 5.0))
    ax = fig.add_subplot()
    ax.plot(xr, re, "k.", ms=3, label="real part")
    ax.plot(xi, im, ".", color="tab:blue", ms=3, label="imaginary part")
    ax.axhline(0.0, color="0.6", lw=0.8)
    for k, x in enumerate(rl.stability_changes()):
        ax.axvline(x, color="tab:red", ls="--", lw=0.8,
                   label="stability changes (interpolated)" if k == 0 else None)
        ax.annotate(f"{x:.4g}", (x, 1.0), xycoords=("data", "axes fraction"), fontsize=8,
                    color="tab:red", ha="left", va="top", xytext=(2, -2),
                    textcoords="offset points")
    n_zero = int(np.count_nonzero(rl.poles == 0))
    notes = []
    if n_zero:
        notes.append(f"{n_zero} zero poles not drawn")
    if rl.n_failed:
        notes.append(f"{rl.n_failed} failed points left out")
    ax.set_xlabel(f"{rl.parameter} (SET parameter)")
    ax.set_ylabel("pole λ (1/s)")
    ax.set_title(f"root locus: {Path(rl.deck).name or 'sweep'}"
                 + (f" ({'; '.join(notes)})" if notes else ""), fontsize=10)
    ax.legend(loc="best", fontsize=8)
    return fig
