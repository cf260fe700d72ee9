"""Views of the linearized groups of a results file: ``/eigen``, ``/buckling``, ``/compliance``.

One row per linearized static step; modes numbered from 1. Handed out by
:class:`spacarpy.results.reader.ResultsFile` like the views of :mod:`spacarpy.results.views`.
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.labelled import LabelledView
from spacarpy.results.schema import MODE_KIND_NAMES
from spacarpy.results.views import ModeShape, ResultsQueryError, _number_list

# --------------------------------------------------------------------------------------------
# linearized analyses
# --------------------------------------------------------------------------------------------

def _row_of(steps: np.ndarray, step: int, missing: str) -> int:
    """The last row of ``steps`` that holds ``step``; a ResultsQueryError ``missing`` plus
    the steps there are where there is none."""
    hit = np.flatnonzero(steps == step)
    if not hit.size:
        raise ResultsQueryError(f"{missing} {_number_list(steps)})")
    return int(hit[-1])


class _LinearizedView:
    """A linearized group: one row per linearized static step."""

    def __init__(self, results, group: str):
        self._res = results
        self._group = group

    @property
    def step(self) -> np.ndarray:
        """(n_lin,): the static step (row of ``/static``) of each linearization."""
        return self._res._read(f"{self._group}/step")

    @property
    def n_lin(self) -> int:
        return self._res._length(f"{self._group}/step")

    @property
    def n_mode(self) -> int:
        with self._res._file() as f:
            return int(f[self._group].attrs["n_mode"])

    @property
    def load_factor(self) -> np.ndarray:
        """(n_lin,): load factor of each linearized step."""
        if self._res.static is None:
            return np.full(self.n_lin, np.nan)
        return self._res.static.load_factor[self.step]

    def _array(self, name: str) -> np.ndarray:
        return self._res._read(f"{self._group}/{name}", np.s_[:self.n_lin])

    def row(self, step=None) -> int:
        """Row of the linearization at static step ``step`` (None: the last one)."""
        steps = self.step
        if steps.size == 0:
            raise ResultsQueryError(f"/{self._group} holds no linearized step")
        if step is None:
            return steps.size - 1
        if self._res.static is not None:
            step = self._res.static.step_index(step)
        return _row_of(steps, step, f"static step {step} was not linearized ({self._group} "
                                    f"results exist at steps")

    def _mode_index(self, mode: int) -> int:
        n = self.n_mode
        if not 1 <= int(mode) <= n:
            raise ResultsQueryError(f"mode {mode} does not exist: modes are numbered 1..{n}")
        return int(mode) - 1

    def shape(self, mode: int = 1, step=None) -> ModeShape:
        """Mode shape ``mode`` (1 = first) at static step ``step`` (None: last linearized)."""
        if self._group == "compliance":
            raise ResultsQueryError("/compliance has no mode shapes")
        r, m = self.row(step), self._mode_index(mode)
        return ModeShape(self._res._read(f"{self._group}/shape_position", (r, m)),
                         self._res._read(f"{self._group}/shape_euler", (r, m)))


class EigenView(LabelledView, _LinearizedView):
    """``/eigen``: natural frequencies and mass-normalized mode shapes."""

    @property
    def frequency(self) -> np.ndarray:
        """(n_lin, n_mode) Hz (negative: unstable, NaN: complex/infinite, 0: rigid-body)."""
        return self._array("frequency")

    @property
    def eigenvalue(self) -> np.ndarray:
        """(n_lin, n_mode) complex: omega^2 (s^-2)."""
        return self._array("eigenvalue_real") + 1j * self._array("eigenvalue_imag")

    @property
    def kind(self) -> np.ndarray:
        """(n_lin, n_mode) int8: 0 elastic, 1 rigid-body, 2 unstable, 3 complex, 4 infinite."""
        return self._array("kind")

    kind_names = MODE_KIND_NAMES

    @property
    def n_modes_available(self) -> np.ndarray:
        """(n_lin,) int: the number of finite modes each linearization has (degrees of
        freedom minus the motions without inertia; -1: not counted). A file older than
        schema 2.3 has no such dataset: its columns of kind 4 (infinite) were the surplus,
        so the count of the other columns is returned (a lower bound where every column
        was finite)."""
        if self._res._has("eigen/n_modes_available"):
            return self._array("n_modes_available").astype(np.int64)
        return np.sum(self.kind != 4, axis=1).astype(np.int64)


class BucklingView(LabelledView, _LinearizedView):
    """``/buckling``: load multipliers and buckling shapes."""

    @property
    def load_multiplier(self) -> np.ndarray:
        """(n_lin, n_mode): multipliers of the load acting in the step."""
        return self._array("load_multiplier")

    @property
    def critical_load_multiplier(self) -> np.ndarray:
        """(n_lin,): smallest positive multiplier (inf: none)."""
        return self._array("critical_load_multiplier")

    @property
    def kind(self) -> np.ndarray:
        """(n_lin, n_mode) int8: 0 finite, 4 infinite (a NaN multiplier). Files older than
        schema 2.2 store no kind: there it is 4 where the multiplier is NaN."""
        if self._res._has(f"{self._group}/kind"):
            return self._array("kind")
        return np.where(np.isnan(self.load_multiplier), 4, 0).astype(np.int8)

    kind_names = MODE_KIND_NAMES


class ComplianceView(LabelledView, _LinearizedView):
    """``/compliance``: 6x6 compliance of one node at each linearized step."""

    @property
    def global_(self) -> np.ndarray:
        """(n_lin, 6, 6): compliance in global axes."""
        return self._array("global")

    @property
    def local(self) -> np.ndarray:
        """(n_lin, 6, 6): compliance in the node's current body axes."""
        return self._array("local")

    @property
    def node(self) -> tuple[int, int]:
        """(position node, orientation node) whose compliance is stored."""
        with self._res._file() as f:
            a = f[self._group].attrs
            return int(a["position_node"]), int(a["orientation_node"])


class StateSpaceView(LabelledView, _LinearizedView):
    """``/state_space``: the linearized equations in the degrees of freedom and the
    first-order system ``dz/dt = A z + B u, y = C z + D u`` at each linearized step
    (SPACAR mode 9, docs/linearized.md)."""

    @property
    def n_mode(self) -> int:
        return 0

    @property
    def along_trajectory(self) -> bool:
        """True in a transient_linearized file (SPACAR 3): ``step`` is a row of /transient."""
        return self._res.analysis == "transient_linearized"

    @property
    def load_factor(self) -> np.ndarray:
        """(n_lin,): load factor of each linearized static step (NaN along a trajectory)."""
        if self.along_trajectory:
            return np.full(self.n_lin, np.nan)
        return super().load_factor

    @property
    def time(self) -> np.ndarray:
        """(n_lin,) time of each linearized state (SPACAR 3); NaN for static steps (and
        for a file older than schema 2.6)."""
        with self._res._file() as f:
            if f"{self._group}/time" not in f:
                return np.full(self.n_lin, np.nan)
        return self._array("time")

    def row(self, step=None) -> int:
        """Row of the linearization at static step ``step`` (in a transient_linearized file:
        time step ``step``, a row of /transient; None: the last one)."""
        if not self.along_trajectory or step is None or self._res.transient is None:
            return super().row(step)
        step = self._res.transient.step_index(step)
        return _row_of(self.step, step,
                       f"time step {step} was not linearized (/state_space holds steps")

    def _names(self, name: str) -> list[str]:
        from spacarpy.results.h5file import str_list
        with self._res._file() as f:
            return str_list(f[f"{self._group}/{name}"])

    @property
    def state_name(self) -> list[str]:
        """The states: ``BEAM 3 mode 2`` (a deformation), then ``rate of BEAM 3 mode 2``."""
        return self._names("state_name")

    @property
    def input_name(self) -> list[str]:
        """The inputs by their deck line, ``INPUTF 1 9 2``."""
        return self._names("input_name")

    @property
    def output_name(self) -> list[str]:
        """The outputs by their deck line, ``OUTX 1 9 2``."""
        return self._names("output_name")

    @property
    def dof(self) -> np.ndarray:
        """(n_dof, 2): [element, mode] of each degree of freedom."""
        return np.stack([self._res._read(f"{self._group}/dof_element"),
                         self._res._read(f"{self._group}/dof_mode")], axis=1)

    def matrix(self, name: str, step=None) -> np.ndarray:
        """Matrix ``name`` (M0, C0, K0, B0, A, B, C or D) at static step ``step`` (None: the
        last linearized one)."""
        if name not in ("M0", "C0", "K0", "B0", "A", "B", "C", "D"):
            raise ResultsQueryError(f"/state_space has no matrix {name!r}: M0, C0, K0, B0, A, "
                                    "B, C or D")
        return self._res._read(f"{self._group}/{name}", self.row(step))

    def matrices(self, step=None) -> dict:
        """A, B, C, D at static step ``step`` (None: the last linearized one)."""
        return {k: self.matrix(k, step) for k in ("A", "B", "C", "D")}

    def system(self, step=None):
        """The system at static step ``step`` (None: the last) as
        :class:`scipy.signal.StateSpace`."""
        from scipy.signal import StateSpace
        m = self.matrices(step)
        return StateSpace(m["A"], m["B"], m["C"], m["D"])

    def control_system(self, step=None):
        """The system as a python-control ``StateSpace`` (``pip install control``), with
        the state, input and output names."""
        try:
            import control
        except ImportError:
            raise ResultsQueryError("control_system() needs the python-control package "
                                    "(pip install control); system() gives scipy's "
                                    "StateSpace") from None
        m = self.matrices(step)
        return control.ss(m["A"], m["B"], m["C"], m["D"], states=self.state_name,
                          inputs=self.input_name, outputs=self.output_name)
