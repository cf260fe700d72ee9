"""User routines in Python (USERSIG, USERINP): the deck's routines refused unless the command
allows user code, found (``name.py`` beside the deck or a ``--user-module``), loaded, and
turned into the plain callables the solvers take; their failures as one clear message.

The calling convention (docs/user-routines.md) is SPACAR's translated to arrays:

- ``USERSIG name``: ``name(t, state) -> rows``, rows ``[node, direction, value]``: the
  force component ``direction`` (1-3: x, y, z, N) on a position node, the generalized force on
  Euler parameter ``lambda_(direction-1)`` (1-4) on an orientation node (SPACAR's; a moment
  M gives ``2 Lambda(q)^T M``, :func:`euler_moment`).
- ``USERINP name``: ``name(t) -> rows``, rows ``[node, coordinate, value, velocity,
  acceleration]`` of input coordinates (INPUTX).

``state`` gives the nodal coordinates ``x[node]`` and velocities ``xd[node]`` (3 values for a
position node, 4 Euler parameters for an orientation node) and the deformations ``e[element]``
and their rates ``ed[element]``, by deck numbers; a list of numbers gives the stacked rows.
"""
from __future__ import annotations

import importlib.util
import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from spacarpy.errors import UserCodeRefused, UserRoutineError

__all__ = ["ALLOW_FLAG", "UserState", "batch_run_args", "euler_moment", "find_module",
           "loaded_routines", "refuse_unless_allowed", "routine_report", "scan_decks"]

#: The command-line flag that lets a deck's user routines run.
ALLOW_FLAG = "--allow-user-code"

#: The analyses user routines act in: USERSIG in statics and transients, USERINP in
#: transients only.
USERSIG_ANALYSES = ("static", "transient")
USERINP_ANALYSES = ("transient",)


def euler_moment(q, moment) -> np.ndarray:
    """The generalized forces (4,) on the Euler parameters ``q`` (4,) of a moment (3,) in
    global axes: ``2 Lambda(q)^T M`` (what a USERSIG row on an orientation node gives)."""
    q = np.asarray(q, dtype=float)
    m = np.asarray(moment, dtype=float)
    return 2.0 * np.concatenate([[-q[1:] @ m], q[0] * m - np.cross(q[1:], m)])


def refuse_unless_allowed(model, allowed: bool) -> None:
    """Stop before any work when the deck names user routines and ``allowed`` is False: one
    line per routine, naming it, its deck line and :data:`ALLOW_FLAG`."""
    if allowed or not model.user_routines:
        return
    lines = [f"{r.loc}: error: {r.keyword} {r.name} names user code (the Python function "
             f"{r.name} of {r.name}.py beside the deck, or of a --user-module), which "
             f"spacarpy runs only when asked to: add {ALLOW_FLAG} if you trust it"
             for r in model.user_routines]
    raise UserCodeRefused("\n".join(lines))


def scan_decks(decks) -> list[str]:
    """``file:line:column: KEYWORD name`` of every USERSIG/USERINP line of the deck files
    (a text scan, nothing parsed or run): what ``batch`` and ``sweep`` refuse up front."""
    found = []
    for deck in decks:
        try:
            text = Path(deck).read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        for k, line in enumerate(text.splitlines(), 1):
            words = line.split()
            if words and words[0].upper() in ("USERSIG", "USERINP"):
                name = words[1] if len(words) > 1 else "?"
                col = len(line) - len(line.lstrip()) + 1
                found.append(f"{deck}:{k}:{col}: {words[0].upper()} {name}")
    return found


def batch_run_args(args, decks) -> list[str]:
    """The ``spacarpy run`` arguments a batch or sweep adds for user code: refused before any
    run when a deck names user routines and ``--allow-user-code`` is not given (in the
    command or its ``--run-args``); else the flag and the ``--user-module`` paths, made
    absolute (the runs work in their own folders)."""
    extra = []
    for mod in getattr(args, "user_module", ()):
        extra += ["--user-module", str(Path(mod).resolve())]
    if getattr(args, "allow_user_code", False):
        return [ALLOW_FLAG, *extra]
    if ALLOW_FLAG in (args.run_args or ""):
        return extra
    found = scan_decks(decks)
    if found:
        raise UserCodeRefused("\n".join(
            f"{f}: error: names user code, which spacarpy runs only when asked to: add "
            f"{ALLOW_FLAG} if you trust it" for f in found))
    return extra


def _defines(path: Path, name: str) -> bool:
    """Whether the Python file ``path`` defines ``name`` at its top level (read, not run)."""
    import ast
    try:
        tree = ast.parse(path.read_text(encoding="utf-8", errors="replace"))
    except (OSError, SyntaxError, ValueError):
        return False
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and \
                node.name == name:
            return True
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name
                                                for t in node.targets):
            return True
        if isinstance(node, (ast.Import, ast.ImportFrom)) and any(
                (a.asname or a.name.split(".")[0]) == name for a in node.names):
            return True
    return False


def find_module(name: str, deck_path, user_modules=()) -> Path | None:
    """The file that defines routine ``name``: the first ``--user-module`` (a .py file, or a
    folder holding ``name.py``) that defines it, else ``name.py`` beside the deck; None when
    there is none. Nothing is run: the files are read."""
    for mod in user_modules:
        mod = Path(mod)
        if mod.is_dir():
            cand = mod / f"{name}.py"
            if cand.is_file():
                return cand
        elif mod.is_file() and _defines(mod, name):
            return mod
    beside = Path(str(deck_path)).parent / f"{name}.py"
    return beside if beside.is_file() else None


def routine_report(model, deck_path, user_modules=()) -> list[str]:
    """The lines ``spacarpy check`` prints about the deck's user routines: each routine,
    its deck line and the file found for it (or that none was)."""
    out = []
    for r in model.user_routines:
        path = find_module(r.name, deck_path, user_modules)
        what = "loads" if r.keyword == "USERSIG" else "prescribed motion"
        where = (f"found in {path}" if path is not None else
                 f"NOT FOUND ({r.name}.py beside the deck, or give --user-module)")
        out.append(f"  {r.keyword} {r.name} (line {r.loc.line if r.loc else '?'}, {what}): "
                   f"{where}")
    return out


def _where(exc: BaseException, path: Path) -> str:
    """``file:line`` of the innermost frame of the traceback inside the user's file (else the
    innermost frame at all)."""
    frames = traceback.extract_tb(exc.__traceback__)
    inside = [f for f in frames if Path(f.filename) == path]
    f = (inside or frames or [None])[-1]
    return f"{f.filename}:{f.lineno}" if f is not None else str(path)


@dataclass
class _Routine:
    keyword: str
    name: str
    path: Path
    fn: object
    loc: object

    @property
    def label(self) -> str:
        return f"{self.keyword} {self.name} ({self.path})"

    def call(self, *args):
        try:
            return self.fn(*args)
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as exc:
            raise UserRoutineError(
                f"user routine {self.keyword} {self.name} raised {type(exc).__name__}: "
                f"{exc} (at {_where(exc, self.path)}; deck line {self.loc})") from None

    def fail(self, t, what: str):
        raise UserRoutineError(f"user routine {self.keyword} {self.name} ({self.path}) at "
                               f"t = {t:.6g}: {what} (deck line {self.loc})")


def _load(routine, deck_path, user_modules) -> _Routine:
    path = find_module(routine.name, deck_path, user_modules)
    if path is None:
        raise UserRoutineError(
            f"{routine.loc}: error: {routine.keyword} {routine.name}: no file defines it: "
            f"expected {routine.name}.py beside the deck, or a --user-module file that "
            f"defines {routine.name}")
    path = path.resolve()
    spec = importlib.util.spec_from_file_location(f"spacarpy_user_{routine.name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(path.parent))     # the routine's own helper modules beside it
    try:
        spec.loader.exec_module(module)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:
        raise UserRoutineError(
            f"{routine.loc}: error: {routine.keyword} {routine.name}: loading {path} raised "
            f"{type(exc).__name__}: {exc} (at {_where(exc, path)})") from None
    finally:
        try:
            sys.path.remove(str(path.parent))
        except ValueError:
            pass
    fn = getattr(module, routine.name, None)
    if not callable(fn):
        raise UserRoutineError(f"{routine.loc}: error: {routine.keyword} {routine.name}: "
                               f"{path} defines no function {routine.name}")
    return _Routine(routine.keyword, routine.name, path, fn, routine.loc)


class _ByNumber:
    """Rows of an array by deck numbers: ``m[n]`` one row, ``m[[n1, n2]]`` stacked rows."""

    def __init__(self, rows: dict, values, what: str, read: set | None = None):
        self._rows, self._values, self._what, self._read = rows, values, what, read

    def _value(self, n):
        try:
            where = self._rows[int(n)]
        except (KeyError, TypeError, ValueError):
            raise KeyError(f"{self._what} {n} is not in the model") from None
        if self._read is not None:
            self._read.add(int(n))
        return self._values(where)

    def __getitem__(self, n):
        if np.ndim(n) == 0:
            return self._value(n)
        return np.stack([self._value(k) for k in n]) if len(n) else np.zeros((0, 0))

    def __contains__(self, n) -> bool:
        return int(n) in self._rows

    def __iter__(self):
        return iter(self._rows)

    def __len__(self) -> int:
        return len(self._rows)

    def keys(self):
        return self._rows.keys()


class UserState:
    """What a USERSIG routine sees at one evaluation: ``t``; ``x``, ``xd`` (nodal
    coordinates and velocities by node number), ``e``, ``ed`` (deformations and their rates
    by element number); ``derivatives``: whether the solver takes the loads' derivatives
    from this call (a routine that can give them returns ``(rows, derivative_rows)``).
    Read-only: the routine cannot change the solver's state. ``read`` collects the nodes
    whose coordinates or velocities the routine read (the difference quotients perturb only
    those)."""

    def __init__(self, t, x, v, states, maps, derivatives: bool = False):
        self.t = float(t)
        self.derivatives = bool(derivatives)
        self.read: set[int] = set()
        node_idx, elem_rows, groups = maps
        x = x.view()                       # read-only views of the solver's arrays
        x.flags.writeable = False
        v = np.zeros_like(x) if v is None else v.view()
        v.flags.writeable = False
        self.x = _ByNumber(node_idx, lambda i: x[i], "node", self.read)
        self.xd = _ByNumber(node_idx, lambda i: v[i], "node", self.read)
        cache = {}

        def rates(gi):
            if gi not in cache:
                g = groups[gi]
                cache[gi] = np.einsum("nkj,nj->nk", states[gi].D, v[g.idx])
            return cache[gi]

        self.e = _ByNumber(elem_rows, lambda w: states[w[0]].e[w[1]].copy(), "element")
        self.ed = _ByNumber(elem_rows, lambda w: rates(w[0])[w[1]].copy(), "element")


def _node_maps(model, num):
    """node number -> its global coordinate indices; element number -> (group, row)."""
    node_idx = {int(n): num.pos_idx[i] for i, n in enumerate(model.position_ids)}
    node_idx.update({int(n): num.rot_idx[i] for i, n in enumerate(model.orientation_ids)})
    elem_rows = {int(e): (gi, r) for gi, g in enumerate(num.groups)
                 for r, e in enumerate(g.ids)}
    return node_idx, elem_rows, num.groups


def _rows(out, width: int, routine: _Routine, t: float, form: str) -> np.ndarray:
    """A routine's result as a finite (k, width) float array, or its clear failure."""
    if out is None:
        routine.fail(t, f"returned None; expected rows {form}")
    try:
        a = np.asarray(out, dtype=float)
    except (TypeError, ValueError) as exc:
        routine.fail(t, f"returned {type(out).__name__}, not numbers ({exc}); expected rows "
                        f"{form}")
    if a.size == 0:
        return np.zeros((0, width))
    if a.ndim == 1 and a.size == width:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != width:
        routine.fail(t, f"returned an array of shape {a.shape}; expected (k, {width}): rows "
                        f"{form}")
    bad = ~np.isfinite(a)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        routine.fail(t, f"returned {a[r, c]} in row {r + 1}, column {c + 1} (rows {form}); "
                        "every value must be finite")
    return a


def _lookup_table(node_idx) -> np.ndarray:
    """(max node + 1, 4) global coordinate index of (node, direction - 1); -1 where none."""
    table = np.full((max(node_idx, default=0) + 1, 4), -1, dtype=np.int64)
    for n, idx in node_idx.items():
        table[n, :len(idx)] = idx
    return table


def _coordinates(table, routine, t, nodes, dirs) -> np.ndarray:
    """The global coordinate indices of rows' (node, direction), or the routine's failure
    naming the first bad row."""
    n = nodes.astype(np.int64)
    c = dirs.astype(np.int64)
    ok = (n == nodes) & (c == dirs) & (n >= 0) & (n < table.shape[0]) & (c >= 1) & (c <= 4)
    idx = np.full(n.size, -1, dtype=np.int64)
    idx[ok] = table[n[ok], c[ok] - 1]
    bad = np.flatnonzero(idx < 0)
    if bad.size:
        k = int(bad[0])
        node = nodes[k]
        if not (n[k] == node and 0 <= n[k] < table.shape[0] and table[n[k], 0] >= 0):
            routine.fail(t, f"names node {node:g}, which is not a node of the model")
        n_dir = int((table[n[k]] >= 0).sum())
        routine.fail(t, f"gives direction {dirs[k]:g} of node {n[k]}, which has directions "
                        f"1-{n_dir}")
    return idx


#: The difference quotients' step (positions: times the model's length scale; Euler
#: parameters: absolute) for a routine that gives no derivatives.
USER_FD_STEP = 1e-7

#: The columns of a derivative row.
DERIVATIVE_FORM = "[node, direction, wrt_node, wrt_direction, d value/d x, d value/d xd]"


class _LoadAdapter:
    """USERSIG as the solvers' ``user(t, x, v, states) -> (n_coord,)``, with
    :meth:`tangent`, the loads' derivative for the Newton matrices."""

    FORM = "[node, direction, value]"

    def __init__(self, routine, model, num):
        self.routine, self.n = routine, num.n_coord
        self.maps = _node_maps(model, num)
        self.table = _lookup_table(self.maps[0])
        self.rot = np.zeros(num.n_coord, dtype=bool)
        self.rot[np.asarray(num.rot_idx, dtype=np.int64).ravel()] = True
        self.length_scale = float(num.length_scale)
        #: whether the routine returned derivative rows at its last derivative call
        #: (None before the first)
        self.gives_derivatives: bool | None = None
        self.calls = 0                   # routine calls (the solvers' cost report)

    def _evaluate(self, t, x, v, states, derivatives: bool):
        """(loads (n_coord,), derivative rows or None, the state the routine saw)."""
        state = UserState(t, x, v, states, self.maps, derivatives)
        self.calls += 1
        out = self.routine.call(t, state)
        drows = None
        if _is_pair(out):
            out, drows = out
            drows = _rows(drows, 6, self.routine, t, DERIVATIVE_FORM) if derivatives \
                else None
        rows = _rows(out, 3, self.routine, t, self.FORM)
        idx = _coordinates(self.table, self.routine, t, rows[:, 0], rows[:, 1])
        return np.bincount(idx, weights=rows[:, 2], minlength=self.n), drows, state

    def __call__(self, t, x, v, states):
        return self._evaluate(t, x, v, states, False)[0]

    def tangent(self, t, x, v, states, gamma: float, cols, difference: bool = True):
        """``d f/dx + gamma d f/dxd`` (sparse, n_coord rows, the columns ``cols``: global
        coordinate indices) at (t, x, v): from the routine's derivative rows where it gives
        them, else by one forward difference per column the routine read (the others have
        none), along ``(e_j, gamma e_j)``. ``v`` None: at rest (statics; the velocity
        part is then not asked for). The dependence on the deformations is not
        differentiated (the element states stay those at x). None where the routine gives
        no derivatives and ``difference`` is False."""
        cols = np.asarray(cols, dtype=np.int64)
        where = np.full(self.n, -1, dtype=np.int64)
        where[cols] = np.arange(cols.size)
        f0, drows, state = self._evaluate(t, x, v, states, True)
        self.gives_derivatives = drows is not None
        if drows is not None:
            i = _coordinates(self.table, self.routine, t, drows[:, 0], drows[:, 1])
            j = _coordinates(self.table, self.routine, t, drows[:, 2], drows[:, 3])
            val = drows[:, 4] + (gamma * drows[:, 5] if v is not None else 0.0)
            keep = where[j] >= 0
            return sp.csr_matrix((val[keep], (i[keep], where[j[keep]])),
                                 shape=(self.n, cols.size))
        if not difference:
            return None
        read = [np.asarray(self.maps[0][n]) for n in sorted(state.read)]
        read = np.concatenate(read) if read else np.zeros(0, dtype=np.int64)
        read = read[where[read] >= 0]
        rows, cc, vals = [], [], []
        xp = x.copy()
        vp = None if v is None else v.copy()
        for j in read:
            h = USER_FD_STEP * (1.0 if self.rot[j] else self.length_scale)
            xp[j] += h
            if vp is not None:
                vp[j] += gamma * h
            df = (self._evaluate(t, xp, vp, states, False)[0] - f0) / h
            xp[j] = x[j]
            if vp is not None:
                vp[j] = v[j]
            nz = np.flatnonzero(df)
            rows.append(nz)
            cc.append(np.full(nz.size, where[j]))
            vals.append(df[nz])
        if not rows:
            return sp.csr_matrix((self.n, cols.size))
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                     np.concatenate(cc))),
                             shape=(self.n, cols.size))


def _is_pair(out) -> bool:
    """Whether a USERSIG result is ``(rows, derivative_rows)``: a tuple of two whose second
    part has rows of 6 values (or none)."""
    if not (isinstance(out, tuple) and len(out) == 2):
        return False
    second = out[1]
    try:
        shape = np.shape(second)
    except (TypeError, ValueError):
        return False
    return (len(shape) == 2 and shape[1] == 6) or (
        len(shape) >= 1 and shape[0] == 0 and np.ndim(out[0]) != 1)


class _MotionAdapter:
    """USERINP as the transient's ``user_motion(t) -> (idx, x, v, a)`` (the input
    coordinates it drives) with :meth:`deformations` (the prescribed deformations it
    drives). The routine returns rows ``[node, coordinate, x, x', x'']`` of INPUTX
    coordinates, or a dict ``{"x": those rows, "e": rows [element, mode, e, e', e'']}`` of
    INPUTE deformations (either key may be left out)."""

    FORM = "[node, coordinate, value, velocity, acceleration]"
    FORM_E = "[element, mode, value, rate, second derivative]"

    def __init__(self, routine, model, num):
        self.routine = routine
        self.table = _lookup_table(_node_maps(model, num)[0])
        self.inputs = set(int(i) for i in num.prescribed_idx)
        # (element number, mode) -> rigid-mode constraint row, of the INPUTE modes
        self.modes = {}
        presc = num.rigid_prescribed
        for g in num.groups:
            for k, (el, mode) in enumerate(zip(g.rigid_elem, g.rigid_mode)):
                row = g.rigid_offset + k
                if row < presc.size and presc[row]:
                    self.modes[(int(g.ids[el]), int(mode) + 1)] = row
        self._at = None                  # (t, x part, e part) of the last call

    def _parts(self, t):
        if self._at is not None and self._at[0] == t:
            return self._at[1], self._at[2]
        out = self.routine.call(t)
        e_rows = None
        if isinstance(out, dict):
            unknown = set(out) - {"x", "e"}
            if unknown:
                self.routine.fail(t, f"returned a dict with the key(s) {sorted(unknown)}; "
                                     "expected 'x' (rows " + self.FORM + ") and/or 'e' (rows "
                                     + self.FORM_E + ")")
            e_rows = _rows(out.get("e", []), 5, self.routine, t, self.FORM_E)
            out = out.get("x", [])
        x_part = self._x_part(t, _rows(out, 5, self.routine, t, self.FORM))
        e_part = None if e_rows is None else self._e_part(t, e_rows)
        self._at = (t, x_part, e_part)
        return x_part, e_part

    def _x_part(self, t, rows):
        idx = _coordinates(self.table, self.routine, t, rows[:, 0], rows[:, 1])
        for r, i in zip(rows, idx):
            if int(i) not in self.inputs:
                self.routine.fail(t, f"gives node {int(r[0])} coordinate {int(r[1])}, which "
                                     "is not an input coordinate (declare it with INPUTX)")
        if len(set(idx.tolist())) != idx.size:
            self.routine.fail(t, "gives a coordinate twice")
        return idx, rows[:, 2].copy(), rows[:, 3].copy(), rows[:, 4].copy()

    def _e_part(self, t, rows):
        idx = []
        for r in rows:
            key = (int(r[0]), int(r[1]))
            if key != (r[0], r[1]) or key not in self.modes:
                self.routine.fail(t, f"gives element {r[0]:g} mode {r[1]:g}, which is not a "
                                     "prescribed deformation (declare it with INPUTE)")
            idx.append(self.modes[key])
        idx = np.asarray(idx, dtype=np.int64)
        if len(set(idx.tolist())) != idx.size:
            self.routine.fail(t, "gives a deformation twice")
        return idx, rows[:, 2].copy(), rows[:, 3].copy(), rows[:, 4].copy()

    def __call__(self, t):
        return self._parts(t)[0]

    def deformations(self, t):
        """(rigid-mode constraint rows, e, e', e'') the routine prescribes at time t, or
        None where it returns no ``"e"`` rows."""
        return self._parts(t)[1]


def loaded_routines(model, num, analysis: str, deck_path, user_modules=()):
    """(user loads, user motion): the deck's USERSIG and USERINP routines loaded and
    adapted to the solvers' callables (None where the deck has none). Call only after
    :func:`refuse_unless_allowed`: this runs the routines' modules."""
    loads = motion = None
    for r in model.user_routines:
        allowed = USERSIG_ANALYSES if r.keyword == "USERSIG" else USERINP_ANALYSES
        if analysis not in allowed:
            raise UserRoutineError(
                f"{r.loc}: error: {r.keyword} {r.name} acts in a {' or '.join(allowed)} "
                f"analysis, not in MODE {analysis}")
    for r in model.user_routines:
        routine = _load(r, deck_path, user_modules)
        if r.keyword == "USERSIG":
            loads = _LoadAdapter(routine, model, num)
        else:
            motion = _MotionAdapter(routine, model, num)
    return loads, motion
