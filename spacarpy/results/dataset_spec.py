"""One dataset of the results schema: :class:`DatasetSpec`.

This module's one job is the record that :data:`spacarpy.results.schema.DATASETS` holds one
of per dataset (path, dtype, named shape, units and their 2.x string, companions).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DatasetSpec"]


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of the schema.

    Attributes
    ----------
    path : str
        Path relative to the root, e.g. ``static/elements/TRUSS/deformation``.
    dtype : str
        numpy dtype written (``"f8"``, ``"i8"``, ``"i4"``, ``"i1"``, ``"?"``), or ``"ascii"``
        / ``"utf-8"`` for strings.
    shape : tuple
        Named dimensions (see the module docstring) or fixed sizes; axis 0 of a step dataset
        is ``step``, ``time_step`` or ``linearized_step``.
    units, long_name : str
        The CF attributes stored on the dataset.
    since : tuple
        Schema version that introduced the quantity (its 2.0 path may be newer; see
        :data:`LEGACY_NAMES`).
    kind : str or None
        The element kind of a per-kind dataset.
    optional : bool
        Absent unless the run has it (prescribed deformations, surface stresses).
    units_v2 : str or None
        The ``units`` of the dataset in a file of schema 2.x, where they differ (the 2.x
        strings that UDUNITS2 and pint could not parse).
    index_units : tuple
        Where the indices of some axes have different units (``units`` is then ``"1"``):
        one unit per index of the dimensions ``index_dims``, row-major; written as the
        attributes ``units_per_index`` and ``units_per_index_dims``. Empty with
        ``index_dims`` set: the units are the run's (reactions, loads).
    attrs : tuple
        Further ``(name, value)`` string attributes (e.g. a mode shape's normalization).
    """

    path: str
    dtype: str
    shape: tuple
    units: str
    long_name: str
    since: tuple = (1, 0)
    kind: str | None = None
    optional: bool = False
    units_v2: str | None = None
    index_units: tuple = ()
    index_dims: tuple = ()
    attrs: tuple = ()

    def units_in(self, major: int) -> str:
        """The ``units`` of the dataset in a file of schema major version ``major``."""
        return self.units_v2 if major < 3 and self.units_v2 is not None else self.units

    @property
    def group(self) -> str:
        """Top-level group (``model``, ``static`` ...), ``""`` for ``/deck``."""
        return self.path.split("/")[0] if "/" in self.path else ""

    @property
    def kind_class(self) -> str:
        """``int``, ``float``, ``complex``, ``ascii``, ``bool`` or ``str``: what the validator
        checks."""
        if self.dtype == "ascii":
            return "ascii"
        if self.dtype == "utf-8":
            return "str"
        dt = np.dtype(self.dtype)
        return {"i": "int", "u": "int", "f": "float", "c": "complex", "b": "bool"}[dt.kind]
