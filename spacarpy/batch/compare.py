"""Compare a result file with its baseline: every numeric dataset both contain, with tolerances.

A dataset differs when some element fails ``|a - b| <= atol + rtol * |b| + floor * max|B|``
(b the baseline, max|B| the largest finite magnitude in the baseline dataset; NaN equals NaN,
inf equals inf of the same sign), or when the shapes differ. The last term is the round-off
of a value that is zero, or nearly so, in exact arithmetic beside large ones: a vanishing
reaction component next to a 10^6 N one, a frequency near a critical point where the
eigenvalue w^2 is a difference of much larger numbers. Such values change with every
change of the solver's iteration path (within its tolerance) and carry no information below
``floor`` (1e-9) of the dataset's scale. For each differing
dataset the worst element is reported: its index and its relative difference ``|a - b| / |b|``.
Datasets whose values legitimately vary between machines or runs (:data:`IGNORED`) are skipped.
The Newton residuals among them are still checked for a regression: a step whose residual
is above :data:`RESIDUAL_FLOOR` and more than :data:`RESIDUAL_GROWTH` times the baseline's
differs (a step accepted with a residual of 1.0 where the baseline had 0; round-off moves a
converged residual by far less).

Classified modes compare by their classification first, then by value (round-off must not
decide a comparison). ``/buckling/load_multiplier``: in each row a value that is NaN, inf or
larger in magnitude than :data:`INFINITE_MULTIPLIER` is infinite (a 1.x baseline may hold a
round-off 4.9e16 where the solver now stores NaN); each row of both files is put in the
solver's canonical order (finite ones by magnitude, ``+mu, -mu`` pairs by signed value, see
:mod:`spacarpy.solvers.linear.buckling`; then the infinite ones as NaN), so a pair that round-off
stored swapped compares equal and a different number of infinite multipliers is a
difference. ``/eigen/eigenvalue_*`` and ``/eigen/frequency`` compare only where both files'
``/eigen/kind`` agree and the mode is neither infinite nor complex; ``/eigen/kind`` itself
compares exactly.
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass

import numpy as np

__all__ = ["IGNORED", "INFINITE_MULTIPLIER", "RESIDUAL_FLOOR", "RESIDUAL_GROWTH",
           "DatasetDiff", "compare_files", "load_tolerances"]

#: Dataset paths (fnmatch patterns) not compared: the Newton residual, iteration counts and
#: acceptance rule (``converged_by``: a static residual near the tolerance may meet it or
#: not; the transient flag is decided by the floors now, issue 34, but the baselines hold
#: the earlier rule's, the residual's side of the tolerance) of static and transient runs
#: (they depend on round-off), and mode shapes (their sign, and the basis of repeated
#: eigenvalues, are arbitrary).
IGNORED = ("/static/residual", "/static/iterations", "/static/converged_by",
           "/transient/residual", "/transient/converged_by",
           "/transient/iterations", "/*/shape_position", "/*/shape_euler")

#: The residual datasets checked for a regression although :data:`IGNORED` skips their
#: values: a step's residual differs when it is above RESIDUAL_FLOOR and more than
#: RESIDUAL_GROWTH times the baseline's (the tolerances are 1e-10 to 5e-7, and a residual
#: accepted on its round-off floor stays far below 1e-6 relative).
RESIDUALS = ("/static/residual", "/transient/residual")
RESIDUAL_FLOOR = 1e-6
RESIDUAL_GROWTH = 100.0

#: A stored buckling multiplier above this magnitude is infinite: 1 / (SAFETY eps) of the
#: solver's bound (:mod:`spacarpy.solvers.linear.buckling`) with ``|v^T K v| / ||G||`` taken as 1;
#: a load 4.5e13 times smaller than the one that buckles the structure is round-off.
INFINITE_MULTIPLIER = 1.0 / (100.0 * np.finfo(float).eps)
#: Datasets compared only where ``/eigen/kind`` agrees and is finite (elastic, rigid-body,
#: unstable).
_EIGEN_VALUES = ("/eigen/eigenvalue_real", "/eigen/eigenvalue_imag", "/eigen/frequency")
_EIGEN_NOT_FINITE = (3, 4)          # complex, infinite (spacarpy.solvers.linear.eigen.KIND_NAMES)


@dataclass(frozen=True)
class DatasetDiff:
    """One dataset that differs from its baseline.

    Attributes
    ----------
    path : str
        HDF5 path of the dataset.
    index : tuple or None
        Index of the worst element (None when the shapes differ).
    value, baseline : float
        The worst element in the result and in the baseline.
    rel_diff : float
        ``|value - baseline| / |baseline|`` at that element (inf when the baseline is 0).
    n_bad : int
        Number of elements out of tolerance.
    message : str
        A one-line description.
    """

    path: str
    index: tuple | None
    value: float
    baseline: float
    rel_diff: float
    n_bad: int
    message: str


def _numeric_datasets(f) -> dict:
    """Numeric datasets by their schema-2.0 path (a 1.x file's names mapped through
    :data:`spacarpy.results.schema.LEGACY_NAMES`, so a 2.0 result compares with a 1.x
    baseline)."""
    import h5py

    from spacarpy.results.h5file import schema_major
    from spacarpy.results.schema import new_name

    legacy = schema_major(f) < 2
    out = {}

    def visit(name, obj):
        # checksums (schema 2.1) differ at any round-off difference: not a quantity
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "biuf" \
                and not name.endswith("/checksum"):
            path = new_name("/" + name) if legacy else "/" + name
            if path is not None:
                out[path] = obj
    f.visititems(visit)
    return out


def canonical_multipliers(mult: np.ndarray) -> np.ndarray:
    """Buckling multipliers (..., n_mode) with every row in the canonical order, infinite
    ones (NaN, inf, beyond :data:`INFINITE_MULTIPLIER`) as NaN at the end."""
    from spacarpy.solvers.linear.eigen import canonical_order

    mult = np.asarray(mult, dtype=float)
    out = np.full(mult.shape, np.nan)
    for idx in np.ndindex(mult.shape[:-1]):
        row = mult[idx]
        with np.errstate(invalid="ignore"):
            vals = row[np.isfinite(row) & (np.abs(row) <= INFINITE_MULTIPLIER)]
        out[idx][:vals.size] = vals[canonical_order(np.abs(vals), vals)]
    return out


def _compare(path, a, b, rtol, atol, floor=0.0, mask=None) -> DatasetDiff | None:
    """The difference of ``a`` from the baseline ``b``, or None; ``mask``: the elements to
    compare (default all)."""
    if a.shape != b.shape:
        return DatasetDiff(path, None, np.nan, np.nan, np.inf, -1,
                           f"{path}: shape {a.shape} differs from the baseline's {b.shape}")
    if a.size == 0:
        return None
    a = a.astype(float)
    b = b.astype(float)
    same_special = (np.isnan(a) & np.isnan(b)) | (np.isinf(a) & (a == b))
    if mask is not None:
        same_special |= ~mask
    finite = np.abs(b[np.isfinite(b)])
    scale = float(finite.max()) if finite.size else 0.0
    with np.errstate(invalid="ignore", over="ignore"):
        err = np.abs(a - b)
        allowed = atol + rtol * np.abs(b) + floor * scale
        bad = ~same_special & ~(err <= allowed)
    if not bad.any():
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where(bad, np.nan_to_num(err / np.where(allowed > 0, allowed, np.nan),
                                            nan=np.inf, posinf=np.inf), -1.0)
    flat = int(np.argmax(score))
    index = tuple(int(i) for i in np.unravel_index(flat, a.shape))
    va, vb = float(a[index]), float(b[index])
    rel = abs(va - vb) / abs(vb) if vb != 0 and np.isfinite(vb) else (
        0.0 if va == vb else np.inf)
    n_bad = int(bad.sum())
    return DatasetDiff(path, index, va, vb, rel, n_bad,
                       f"{path}: {n_bad} of {a.size} values differ; worst at "
                       f"{list(index)}: {va:.10g} vs baseline {vb:.10g} (relative "
                       f"difference {rel:.3g})")


def _residual_regression(path, a, b) -> DatasetDiff | None:
    """A step of ``a`` whose residual is above RESIDUAL_FLOOR and more than RESIDUAL_GROWTH
    times the baseline ``b``'s, or None (the worst such step; shapes that differ are
    reported by the other datasets)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape or a.size == 0:
        return None
    with np.errstate(invalid="ignore"):
        bad = (~(a <= RESIDUAL_FLOOR) & ~(a <= RESIDUAL_GROWTH * np.abs(b))) & ~(
            np.isnan(a) & np.isnan(b))
    if not bad.any():
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(bad, np.nan_to_num(a / np.abs(b), nan=np.inf, posinf=np.inf), -1.0)
    i = int(np.argmax(ratio))
    va, vb = float(a.flat[i]), float(b.flat[i])
    rel = abs(va - vb) / abs(vb) if vb != 0 and np.isfinite(vb) else np.inf
    n_bad = int(bad.sum())
    return DatasetDiff(path, (i,), va, vb, rel, n_bad,
                       f"{path}: {n_bad} of {a.size} steps have a residual above "
                       f"{RESIDUAL_FLOOR:g} and {RESIDUAL_GROWTH:g} times the baseline's; "
                       f"worst at [{i}]: {va:.3g} vs baseline {vb:.3g}")


def load_tolerances(path) -> dict:
    """A baseline's tolerance file (``<baseline>.tol.json``): ``{pattern: {"rtol": r,
    "atol": a, "why": "..."}}`` with fnmatch patterns of dataset paths, for datasets that
    are ill-conditioned in the model (a post-buckled soft frequency that moves by 1e-4 with
    round-off). ``why`` is required: a loosened tolerance must say what it tolerates.
    Raises ValueError naming the file and entry when the file is malformed."""
    import json
    from pathlib import Path
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a readable JSON file ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected an object {{dataset pattern: tolerances}}")
    for pattern, entry in data.items():
        if not _valid_tolerance(entry):
            raise ValueError(f"{path}: {pattern!r}: expected {{\"rtol\": r, \"atol\": a, "
                             f"\"why\": \"...\"}} with non-negative numbers and a reason")
    return {pattern: (entry.get("rtol"), entry.get("atol")) for pattern, entry in data.items()}


def _valid_tolerance(entry) -> bool:
    """An entry of a tolerance file: a reason, and rtol/atol non-negative numbers if given."""
    if not isinstance(entry, dict) or set(entry) - {"rtol", "atol", "why"}:
        return False
    if not (isinstance(entry.get("why"), str) and entry["why"].strip()):
        return False
    return all(type(entry.get(k, 0.0)) in (int, float) and entry.get(k, 0.0) >= 0
               for k in ("rtol", "atol"))


def compare_files(result, baseline, *, rtol: float = 1e-6, atol: float = 1e-9,
                  floor: float = 1e-9, ignore=IGNORED,
                  tolerances: dict | None = None) -> list[DatasetDiff]:
    """Compare every numeric dataset that both files contain.

    Parameters
    ----------
    result, baseline : path-like or file-like
        HDF5 result files.
    rtol, atol : float
        Relative and absolute tolerance.
    floor : float
        Round-off floor relative to each baseline dataset's largest magnitude.
    ignore : sequence of str
        fnmatch patterns of dataset paths not compared (default :data:`IGNORED`).
    tolerances : dict, optional
        ``{pattern: (rtol or None, atol or None)}`` (:func:`load_tolerances`): the first
        pattern that matches a dataset's path loosens its tolerances to those it gives.

    Returns
    -------
    list of DatasetDiff
        The differing datasets, in path order; empty when the files agree.
    """
    import h5py

    diffs = []
    with h5py.File(result, "r") as fa, h5py.File(baseline, "r") as fb:
        da, db = _numeric_datasets(fa), _numeric_datasets(fb)
        eigen_ok = None
        if "/eigen/kind" in da and "/eigen/kind" in db:
            ka, kb = da["/eigen/kind"][()], db["/eigen/kind"][()]
            if ka.shape == kb.shape:
                eigen_ok = (ka == kb) & ~np.isin(ka, _EIGEN_NOT_FINITE)
        for path in sorted(set(da) & set(db)):
            if path in RESIDUALS:
                d = _residual_regression(path, da[path][()], db[path][()])
                if d is not None:
                    diffs.append(d)
            if any(fnmatch.fnmatchcase(path, pat) for pat in ignore):
                continue
            r, a = rtol, atol
            for pat, (pr, pa) in (tolerances or {}).items():
                if fnmatch.fnmatchcase(path, pat):
                    r, a = max(r, pr or 0.0), max(a, pa or 0.0)     # loosen, never tighten
                    break
            va, vb, mask = da[path][()], db[path][()], None
            if path == "/buckling/load_multiplier":
                va, vb = canonical_multipliers(va), canonical_multipliers(vb)
            elif path in _EIGEN_VALUES and eigen_ok is not None and va.shape == eigen_ok.shape:
                mask = eigen_ok
            d = _compare(path, va, vb, r, a, floor, mask)
            if d is not None:
                diffs.append(d)
    return diffs
