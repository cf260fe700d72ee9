"""Per-step appends of :class:`spacarpy.results.steps.StepAppender` (issue 20): the low-level
writes store the same bytes as h5py's ``resize`` + ``__setitem__``, in every dtype and row
shape of the step datasets, and a step is committed by its scale entry after its rows."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from spacarpy.results import h5file
from spacarpy.results.steps import StepAppender, checksum_row

#: (trailing shape, dtype) of step datasets as the schema has them: a scalar per step, a
#: vector, a matrix, a kind without elements (empty rows), int8 codes.
SHAPES = [((), "f8"), ((), "i4"), ((5, 3), "f8"), ((0, 6), "f8"), ((4,), "i1"),
          ((2, 7), "i8")]


def _datasets(f):
    return {f"d{i}": f.create_dataset(f"d{i}", shape=(0, *trailing),
                                      maxshape=(None,) + tuple(n or None for n in trailing),
                                      chunks=(3,) + tuple(max(n, 1) for n in trailing),
                                      dtype=dtype)
            for i, (trailing, dtype) in enumerate(SHAPES)}


def _scale(f):
    return f.create_dataset("scale", shape=(0,), maxshape=(None,), chunks=(3,), dtype="f8")


def _rows(rng, k):
    rows = {}
    for i, (trailing, dtype) in enumerate(SHAPES):
        values = rng.standard_normal(trailing) * 100
        # float64 rows for integer datasets: converted as h5py converts them
        rows[f"d{i}"] = values if dtype == "f8" else np.round(values)
    rows["d1"] = k                          # a Python int for a scalar dataset
    if k % 2:       # not in C order: converted first (the others are written as they are)
        rows["d2"] = np.asfortranarray(rows["d2"])
    return rows


def test_low_level_appends_store_the_bytes_of_h5py_writes(tmp_path):
    rng = np.random.default_rng(7)
    steps = [_rows(rng, k) for k in range(8)]            # more steps than a chunk holds
    with h5py.File(tmp_path / "high.h5", "w", libver=h5file.LIBVER) as f:
        ds, scale = _datasets(f), _scale(f)
        for k, rows in enumerate(steps):
            for name, row in rows.items():
                ds[name].resize(k + 1, axis=0)
                ds[name][k] = row
            scale.resize(k + 1, axis=0)
            scale[k] = 0.5 * k
    with h5py.File(tmp_path / "low.h5", "w", libver=h5file.LIBVER) as f:
        appender = StepAppender(f, _datasets(f), _scale(f))
        f.swmr_mode = True
        for k, rows in enumerate(steps):
            appender.append(rows, 0.5 * k, k)
    with h5py.File(tmp_path / "high.h5", "r") as a, h5py.File(tmp_path / "low.h5", "r") as b:
        for name in [*(f"d{i}" for i in range(len(SHAPES))), "scale"]:
            assert a[name].shape == b[name].shape and a[name].dtype == b[name].dtype, name
            assert a[name][()].tobytes() == b[name][()].tobytes(), name
        assert b["scale"][()].tolist() == [0.5 * k for k in range(8)]
        assert b["d3"].shape == (8, 0, 6)


def test_a_step_is_committed_by_its_scale_after_its_rows(tmp_path):
    """A row that cannot be written stops the step before its scale entry: the scale keeps
    counting the committed steps only; a scalar fills a whole row, as h5py's does."""
    with h5py.File(tmp_path / "t.h5", "w", libver=h5file.LIBVER) as f:
        ds, scale = _datasets(f), _scale(f)
        checksum = f.create_dataset("checksum", shape=(0, len(SHAPES) + 1),
                                    maxshape=(None, len(SHAPES) + 1), chunks=(3, 7),
                                    dtype="i8")
        columns = [h5file.SCALE_COLUMN, *ds]
        appender = StepAppender(f, ds, scale, (checksum, columns))
        rows = _rows(np.random.default_rng(1), 0)
        appender.append(rows, 0.25, 0)
        assert checksum[0].tolist() == checksum_row(np.float64(0.25), rows,
                                                           columns).tolist()
        with pytest.raises(ValueError, match="d2: a row of shape"):
            appender.append({**rows, "d2": np.zeros(4)}, 0.5, 1)
        assert scale.shape == (1,)                          # step 1 not committed
        appender.append({**rows, "d2": 2.0}, 0.5, 1)        # a scalar fills the row
        assert scale[()].tolist() == [0.25, 0.5]
        assert (ds["d2"][1] == 2.0).all()
