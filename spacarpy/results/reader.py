"""Reading a results file (schema 1.x or 2.x): lazy open_results, eager read_results.

This module's one job is reading results: :func:`open_results` checks the file once (file
type, schema version, layout: :func:`spacarpy.results.validate.check_readable`) and returns a
:class:`ResultsFile` whose groups are views that read only what is asked for, by deck node and
element numbers; :func:`read_results` loads everything into arrays. Both address datasets by
their 2.0 names and read 1.x files through
:data:`spacarpy.results.schema.LEGACY_NAMES`::

    res = spacarpy.open_results("bend.h5")
    res.static.position(node=3)              # (n_step, 3): node 3 at every load step
    res.static.displacement(node=3, step=-1) # (3,): at the last step
    res.static.section_forces(element=1)     # (n_step, 6): N, T, My_p, My_q, Mz_p, Mz_q
    res.eigen.frequency                      # (n_lin, n_mode) Hz
    res.eigen.shape(mode=1).position         # (n_pos, 3) at the last linearized step
    res.buckling.critical_load_multiplier    # (n_lin,)
    res.transient.position(node=3)           # (n_t, 3): node 3 at every time step

Nothing but the root attributes is kept in memory: every access opens the file (SWMR-read for
a file whose writer was killed or is still running) and slices the dataset. Inside
``with open_results(path) as res:`` one file handle is kept open instead. Steps are the rows of
``/static`` (0 = the initial state, as ITERSTEP counts them; negative numbers count from the
end); only committed steps are visible. Modes are numbered from 1.

The views of the groups are in :mod:`spacarpy.results.views`, the eager reader in
:mod:`spacarpy.results.eager`; their names are exported here too.
"""
from __future__ import annotations

import hashlib
import logging
import os
from contextlib import contextmanager

import numpy as np

from spacarpy.results.eager import (
    LinearizedResults,
    Results,
    StaticResults,
    TransientResults,
    read_results,
)
from spacarpy.results.h5file import (
    bytes_array,
    damaged,
    damaged_steps,
    fixed_damaged,
    open_for_reading,
    reading,
    schema_major,
)
from spacarpy.results.header_crc import header_problems
from spacarpy.results.linearized_views import (
    BucklingView,
    ComplianceView,
    EigenView,
    StateSpaceView,
)
from spacarpy.results.schema import (
    STEP_GROUPS,
    legacy_name,
    new_name,
)
from spacarpy.results.validate import check_readable
from spacarpy.results.views import (
    ModelView,
    ModeShape,
    ResultsQueryError,
    RootAttributes,
    StaticView,
    TransientView,
)

__all__ = ["open_results", "ResultsFile", "ModelView", "StaticView", "TransientView",
           "EigenView", "BucklingView", "ComplianceView", "ModeShape", "ResultsQueryError",
           "read_results", "Results", "StaticResults", "TransientResults",
           "LinearizedResults", "RootAttributes"]

log = logging.getLogger(__name__)


def open_results(path, *, verify: bool = True) -> ResultsFile:
    """Open a results file for lazy reading.

    Parameters
    ----------
    path : str or os.PathLike
        A results file, complete or partial (``*.partial.h5`` of a failed or killed run).
    verify : bool
        Check each dataset against its checksums (schema 2.1) the first time it is read:
        the whole dataset is read once more. ``False`` skips it (very large files).

    Returns
    -------
    ResultsFile

    Raises
    ------
    ResultsFormatError
        The file cannot be opened, is not a spacarpy results file, has a newer major schema
        version than this spacarpy reads (the message names both versions), or violates the
        schema; also later, when a dataset read is damaged (truncated, or its values do not
        match its checksum).
    """
    return ResultsFile(path, verify=verify)


class ResultsFile(RootAttributes):
    """A results file opened by :func:`open_results`.

    Attributes
    ----------
    path : str
    attrs : dict
        Root attributes as Python values (``schema_version`` a tuple).
    model : ModelView
    static : StaticView or None
        ``None`` when the file has no ``/static`` group.
    transient : TransientView or None
        ``None`` when the file has no ``/transient`` group.
    eigen : EigenView or None
    buckling : BucklingView or None
    compliance : ComplianceView or None
    state_space : StateSpaceView or None
        The linearized equations and the state space of SPACAR mode 9.
    """

    def __init__(self, path, *, verify: bool = True):
        self.path = os.fspath(path)
        self.verify = verify
        self._verified: set[str] = set()
        self._handle = None
        self._context = None
        with open_for_reading(self.path) as f:
            self._load(f)

    def _load(self, f) -> None:
        """Check the open file ``f`` once and make the views of its groups."""
        self.attrs = check_readable(f, self.path)
        if self.verify and (problems := header_problems(f.attrs)):
            raise damaged(self.path, problems[0])
        groups = set(f.keys())
        self._major = schema_major(f)
        self.model = ModelView(self)
        self.static = StaticView(self) if "static" in groups else None
        self.transient = TransientView(self) if "transient" in groups else None
        self.eigen = EigenView(self, "eigen") if "eigen" in groups else None
        self.buckling = BucklingView(self, "buckling") if "buckling" in groups else None
        self.compliance = ComplianceView(self, "compliance") if "compliance" in groups else None
        self.state_space = (StateSpaceView(self, "state_space") if "state_space" in groups
                            else None)

    # -- file access --------------------------------------------------------------------------

    def __enter__(self) -> ResultsFile:
        if self._handle is None:
            self._context = open_for_reading(self.path)
            self._handle = self._context.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the handle kept open by ``with``; later accesses open the file again."""
        if self._handle is not None:
            context, self._handle, self._context = self._context, None, None
            context.__exit__(None, None, None)

    @contextmanager
    def _file(self):
        if self._handle is not None:
            with reading(self.path):
                yield self._handle
        else:
            with open_for_reading(self.path) as f:
                yield f

    def _name(self, path: str) -> str:
        """Where dataset ``path`` lives in this file: 2.0 names are mapped to 1.x names in a
        1.x file, 1.x names to 2.0 names in a 2.x file (:data:`~spacarpy.results.schema.
        LEGACY_NAMES`), so that either name reads either file."""
        path = path.lstrip("/")
        if self._major < 2:
            return legacy_name(path, self._major)
        return new_name(path) or path

    def _read(self, path: str, selection=()) -> np.ndarray:
        with self._file() as f:
            ds = f[self._name(path)]
            if self.verify and ds.name not in self._verified:
                self._check(f, ds)
            return bytes_array(ds, selection)

    def _check(self, f, ds) -> None:
        """Verify a whole dataset against its checksums, once (the first time it is read)."""
        group, _, inner = ds.name.lstrip("/").partition("/")
        if fixed_damaged(ds):
            raise damaged(self.path, f"{ds.name} does not match its checksum")
        if group in STEP_GROUPS and inner != "checksum":
            steps = damaged_steps(f[group], f[group][STEP_GROUPS[group]].shape[0], only=inner)
            for name, bad in steps.items():
                raise damaged(self.path, f"{name} does not match the checksum stored with "
                                         f"step{'s' * (len(bad) > 1)} {bad[:10]}")
        self._verified.add(ds.name)

    def _has(self, path: str) -> bool:
        with self._file() as f:
            return self._name(path) in f

    def _length(self, path: str) -> int:
        with self._file() as f:
            return int(f[self._name(path)].shape[0])

    # -- root attributes ----------------------------------------------------------------------

    @property
    def deck(self) -> str:
        """The deck text, verbatim."""
        with self._file() as f:
            text = f["deck"].asstr()[()]
        sha = self.attrs.get("deck_sha256")
        if self.verify and isinstance(sha, str) and \
                hashlib.sha256(text.encode("utf-8")).hexdigest() != sha:
            raise damaged(self.path, "/deck does not match the root attribute deck_sha256")
        return text

    def __repr__(self) -> str:
        parts = [f"{self.analysis} analysis",
                 "completed" if self.completed else "INCOMPLETE",
                 f"schema {self.schema_version[0]}.{self.schema_version[1]}"]
        groups = [name for name in ("static", "transient", "eigen", "buckling", "compliance",
                                    "state_space")
                  if getattr(self, name) is not None]
        return f"<ResultsFile {self.path!r}: {', '.join(parts)}; groups {', '.join(groups)}>"
