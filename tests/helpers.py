"""Plain functions shared by several test modules (pytest puts tests/ on sys.path).

Fixtures live in conftest.py; this module holds what is called, not injected: deck-error
collection, finite differences, an independent planar four-bar solution, the arguments of the
documented sweep, a results writer process killed with SIGKILL, the perfect column's
arc-length path, the kinematic correction's pattern of a chain, the driven slider deck and
the rolling coin deck. No test module imports another test module.
"""
from __future__ import annotations

import re
import shlex
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from spacarpy.deck import model_from_text
from spacarpy.errors import DeckError
from spacarpy.model import ElementSet, Model
from spacarpy.results import ResultsWriter

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
DECK_TEXT = "# tiny test deck, ünïcödé\nBEAM 1 1 2 3 4\nBEAM 2 3 4 5 6\nEND\n"
REACTION_COMPONENT = ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]

#: a spatial deck with mass of every kind: beams, a rigid rod, a truss, point masses and a
#: nodal rotary inertia
MIXED_MASS_DECK = """\
X 1 0 0 0
X 3 1 0.2 0.1
X 5 1.5 0.6 0
BEAM 1 1 2 3 4 0 0 1
RBEAM 2 3 4 5 0 0 1
TRUSS 3 1 5
DYNE 1 1 2 3 4 5 6
DYNE 3 1
FIX 1
FIX 2
END
HALT
ESTIFF 1 100 1 1 1
ESTIFF 3 10
EM 1 2.0 0.1 0.04 0.06 0.01
EM 2 1.5 0.02 0.01 0.01 0
EM 3 0.5
XM 5 0.3
XM 4 0.1 0 0 0.2 0 0.3
END
END
"""


def deck_errors(text: str, name: str = "t.dat") -> list[tuple[int, str]]:
    """(line, message) of every problem building the deck text must report."""
    with pytest.raises(DeckError) as info:
        model_from_text(text, name)
    return [(loc.line, msg) for loc, msg, _ in info.value.items]


def fd_columns(func, x, h=1e-6):
    """Central differences of func(x) (n, ...) with respect to every column of x (n, m)."""
    cols = []
    for k in range(x.shape[1]):
        dx = np.zeros(x.shape[1])
        dx[k] = h
        cols.append((func(x + dx) - func(x - dx)) / (2 * h))
    return np.stack(cols, axis=-1)


def planar_four_bar_equilibrium(k=2.0, P=1.5):
    """Independent planar solution: loop closure by circle intersection, virtual work
    k phi = P dx_C/dphi (derivative of the closed-form C(phi) by a central difference)."""
    A, D = np.array([0, 0.0]), np.array([1, 0.0])
    L1, L2, L3 = 0.3, np.hypot(1.0, 0.5), 0.8

    def c_of(phi):
        B = A + L1 * np.array([-np.sin(phi), np.cos(phi)])
        d = np.linalg.norm(D - B)
        a = (L2**2 - L3**2 + d**2) / (2 * d)
        h = np.sqrt(L2**2 - a**2)
        mid = B + a * (D - B) / d
        perp = np.array([-(D - B)[1], (D - B)[0]]) / d
        return max(mid + h * perp, mid - h * perp, key=lambda c: c[1])   # the upper branch

    phi = brentq(lambda p: k * p - P * (c_of(p + 1e-6)[0] - c_of(p - 1e-6)[0]) / 2e-6,
                 -1.0, 1.0)
    return phi, c_of(phi)


def perfect_column(n: int = 10, setting: str = "switch"):
    """(model, settings) of the straight clamped column at 1.5 times its Euler load with
    EIy = 2 EIz (one buckling mode, a bifurcation at the load factor 1/1.5), followed by arc
    length with ``BIFURCATION setting``."""
    from spacarpy.bench.cases import arclength_column_deck
    from spacarpy.deck import job_from_text
    text = arclength_column_deck(n, imperfection=0.0, ds0=0.02).replace(
        "ARCLENGTH 200 0.02", "ARCLENGTH 200 0.02 0.0001 0.02").replace(
        "MODE static", f"MODE static\nBIFURCATION {setting}").replace(
        "1000000 1 1 1", "1000000 1 2 1")
    return job_from_text(text, "<column>")


def perfect_column_path(setting: str = "warn"):
    """The perfect column (:func:`perfect_column`) solved along its arc-length path:
    ``(prob, path, steps)`` with its ``ArcLengthPath`` and every fourth stored step after
    the first (for :func:`spacarpy.solvers.path.arclength.point_at`)."""
    from spacarpy.solvers.path.arclength import ArcLengthPath
    from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static
    model, settings = perfect_column(setting=setting)
    prob = StaticProblem(model)
    res = solve_static(model, settings, problem=prob)
    path = ArcLengthPath(prob, StaticOptions.from_settings(settings), settings.static.arclength)
    return prob, path, res.steps[1::4]


def docs_sweep_args(out, deck: str = "sweep_column_load_ratio") -> list[str]:
    """The arguments of docs/batch.md's ``spacarpy sweep decks/<deck>...`` example, writing to
    ``out``, quiet, on two processes (run from the repository root)."""
    text = (REPO / "docs" / "batch.md").read_text()
    cmd = re.search(r"```console\n\$ spacarpy (sweep decks/" + deck + r".*?)\n", text).group(1)
    args = shlex.split(cmd)
    args[args.index("-o") + 1] = str(out)
    return args + ["-q", "-j", "2"]


# --- a results writer in its own process ------------------------------------------------------

def as_schema_2(f, minor: int) -> None:
    """Turn an open (``r+``) schema-3.0 results file into the layout of schema ``2.minor``,
    as a file of that version was written: the checksums back in ``/<group>/checksum``, the
    2.x ``units`` strings, ``schema_version``. The 3.0 dimension scales are left (a 2.x
    reader ignores datasets it does not know)."""
    import h5py

    from spacarpy.results.schema import DATASETS

    for group in list(f):
        inner = f.get(f"{group}/integrity/checksum")
        if isinstance(inner, h5py.Dataset):
            for scale in list(inner.dims[1].values()):      # its columns' scale goes
                inner.dims[1].detach_scale(scale)
            f.move(f"{group}/integrity/checksum", f"{group}/checksum")
            del f[f"{group}/integrity"]

    def units(name, obj):
        spec = DATASETS.get(name)
        if isinstance(obj, h5py.Dataset) and spec is not None and spec.units_v2 is not None:
            obj.attrs["units"] = spec.units_v2
    f.visititems(units)
    f.attrs["schema_version"] = np.array([2, minor], dtype=np.int32)
    if minor >= 18:                 # 2.18 wrote the CRC of the header, its version in it
        from spacarpy.results.header_crc import HEADER_CRC_ATTR, header_crc
        f.attrs[HEADER_CRC_ATTR] = header_crc(f.attrs)


def chain_model(n_elem: int = 2, source_path: str = "decks/tiny.dat") -> Model:
    """A straight chain of ``n_elem`` beams along x; positions odd, orientations even numbers."""
    pos = np.arange(n_elem + 1) * 2 + 1
    rot = pos + 1
    nodes = np.column_stack([pos[:-1], rot[:-1], pos[1:], rot[1:]])
    beams = ElementSet("BEAM", ids=np.arange(1, n_elem + 1), nodes=nodes,
                       vector=np.full((n_elem, 3), np.nan),
                       def_class=np.ones((n_elem, 6)), stiffness=np.ones((n_elem, 6)),
                       has_stiffness=np.ones(n_elem, bool))
    x0 = np.column_stack([np.linspace(0.0, 1.0, n_elem + 1), np.zeros((n_elem + 1, 2))])
    return Model(position_ids=pos, position_x0=x0, orientation_ids=rot, elements={"BEAM": beams},
                 source_path=source_path, source_text=DECK_TEXT)


def step_data(model: Model, k: int) -> dict:
    """Deterministic, distinguishable arrays for load step ``k``."""
    n_pos, n_rot = model.position_ids.size, model.orientation_ids.size
    n_elem = model.elements["BEAM"].n_elem
    angle = 0.01 * k * np.arange(n_rot)
    euler = np.column_stack([np.cos(angle / 2), np.zeros(n_rot), np.zeros(n_rot),
                             np.sin(angle / 2)])
    return dict(
        load_factor=0.1 * k,
        position=model.position_x0 + 1e-3 * k * np.arange(3 * n_pos).reshape(n_pos, 3),
        euler=euler,
        deformation={"BEAM": 1e-4 * (k + 1) * np.arange(6 * n_elem, dtype=float)
                     .reshape(n_elem, 6)},
        stress_resultant={"BEAM": -10.0 * (k + 1) * np.arange(6 * n_elem, dtype=float)
                          .reshape(n_elem, 6)},
        reaction=np.arange(6, dtype=float) - 2.5 * k,
        iterations=k + 2,
        residual=10.0 ** -(k + 7),
    )


def begin(w: ResultsWriter, model: Model) -> None:
    w.begin_static(model.position_ids.size, model.orientation_ids.size,
                   reaction_node=[1, 1, 1, 2, 2, 2], reaction_component=REACTION_COMPONENT)


def writer(path, model) -> ResultsWriter:
    return ResultsWriter(path, model, program_version="0.1.0", deformations="modified",
                         analysis="static")


CHILD = textwrap.dedent("""
    import sys, time
    sys.path[:0] = [{tests!r}, {repo!r}]
    from helpers import chain_model, step_data, writer, begin
    out, n_elem, pause = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    model = chain_model(n_elem)
    with writer(out, model) as w:
        begin(w, model)
        k = 0
        while True:
            w.static_step(**step_data(model, k))
            k += 1
            print(k, flush=True)
            time.sleep(pause)
""")


def run_and_kill(tmp_path, n_elem: int, pause: float, kill_after: int = 3, on_running=None):
    """Start a writer process, SIGKILL it once it reports ``kill_after`` written steps.

    ``on_running(partial_path, reported)`` is called just before the kill.
    """
    script = tmp_path / "child.py"
    script.write_text(CHILD.format(tests=str(TESTS), repo=str(REPO)))
    out = tmp_path / "killed.h5"
    proc = subprocess.Popen([sys.executable, str(script), str(out), str(n_elem), str(pause)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        reported = 0
        while reported < kill_after:
            line = proc.stdout.readline()
            assert line, f"writer process died: {proc.stderr.read()}"
            reported = int(line)
        if on_running is not None:
            on_running(tmp_path / "killed.partial.h5", reported)
        proc.send_signal(signal.SIGKILL)
        assert proc.wait(timeout=10) == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        proc.stderr.close()
    return out, reported


def kinematic_chain_pattern(rng, n_nodes, s=7):
    """The kinematic correction's pattern for a chain of beams: each node's ``s``
    coordinates (a diagonal block) depend on the previous node's (below the diagonal).
    Returns ``(rows, cols, data, n)``, the data random with a dominant diagonal."""
    rows, cols = [], []
    for k in range(n_nodes):
        r = np.arange(k * s, (k + 1) * s)
        for c in ([r] if k == 0 else [r, r - s]):
            rr, cc = np.meshgrid(r, c, indexing="ij")
            rows.append(rr.ravel())
            cols.append(cc.ravel())
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    return rows, cols, rng.standard_normal(rows.size) + 4.0 * (rows == cols), n_nodes * s


def dense_reference(rows, cols, data, n: int, b) -> tuple[np.ndarray, float]:
    """The solution of the ``n x n`` system with entries ``data`` at ``(rows, cols)`` and
    right side ``b`` by numpy's dense solver, and its largest magnitude (for tolerances)."""
    a = np.zeros((n, n))
    a[rows, cols] = data
    x = np.linalg.solve(a, b)
    return x, float(np.abs(x).max())


#: run in a fresh interpreter as root: import spacarpy, every module of it and the
#: third-party packages its commands import lazily, THEN become ``nobody`` and run the CLI
#: (the interpreter and its packages may live where ``nobody`` cannot read, e.g. /root)
_AS_NOBODY_SCRIPT = """
import importlib, json, os, pkgutil, sys
os.environ.setdefault("MPLBACKEND", "Agg")
import spacarpy
from spacarpy.cli import main
from spacarpy.cli.process import exit_process
for mod in pkgutil.walk_packages(spacarpy.__path__, "spacarpy."):
    if mod.name.endswith("__main__"):
        continue
    try:
        importlib.import_module(mod.name)
    except Exception:
        pass
for name in ("numpy", "scipy.sparse", "scipy.sparse.linalg", "scipy.linalg",
             "scipy.optimize", "scipy.interpolate", "h5py", "matplotlib", "matplotlib.pyplot",
             "matplotlib.backends.backend_agg", "meshio", "meshio.vtu", "meshio.xdmf",
             "xml.etree.ElementTree", "csv", "json", "encodings.idna", "uuid", "zipfile",
             "zlib", "PIL.PngImagePlugin", "lark", "qdldl"):
    try:
        importlib.import_module(name)
    except Exception:
        pass
# every module of the smaller packages (h5py imports h5py._hl.dims on first use of a
# dataset's dimension scales; in a virtual environment that nobody cannot read, such a
# deferred import fails after the switch)
for pkg in ("h5py", "meshio", "lark"):
    try:
        root = importlib.import_module(pkg)
    except Exception:
        continue
    for mod in pkgutil.walk_packages(root.__path__, pkg + "."):
        if ".tests" in mod.name or mod.name.endswith("__main__"):
            continue
        try:
            importlib.import_module(mod.name)
        except Exception:
            pass
try:            # a figure drawn once: the font files it needs are opened and cached now
    import io
    import matplotlib.pyplot as _plt
    _fig, _ax = _plt.subplots()
    _ax.plot([0, 1], [0, 1], label="x")
    _ax.set_title("x")
    _ax.legend()
    _fig.savefig(io.BytesIO(), format="png")
    _fig.savefig(io.BytesIO(), format="pdf")
    _plt.close(_fig)
except Exception:
    pass
try:            # the font list, read once now from the package files
    import matplotlib.font_manager
    matplotlib.font_manager.fontManager
except Exception:
    pass
uid = int(sys.argv[1])
os.setgroups([])
os.setgid(uid)
os.setuid(uid)
exit_process(main(json.loads(sys.argv[2])))  # as console(): no teardown
"""


def nobody_uid() -> int | None:
    """The uid of the user ``nobody`` where this process may become it (root), else None."""
    import os
    if not hasattr(os, "setuid") or os.geteuid() != 0:
        return None
    try:
        import pwd
        return pwd.getpwnam("nobody").pw_uid
    except (ImportError, KeyError):
        return None


def nobody_skip_reason() -> str | None:
    """Why the commands cannot run as ``nobody`` here, None when they can: not root, no such
    user, or a Python environment ``nobody`` cannot read (a virtual environment inside a
    private directory, as CI's ``mktemp -d``: the packages' data files, fonts and deferred
    submodules are read after the switch), or a checkout it cannot read (the commands import
    spacarpy, and read its grammar files, from :data:`REPO`)."""
    import os
    import stat
    if nobody_uid() is None:
        return "not root (or no user nobody): cannot switch to the user nobody"
    import h5py
    import matplotlib
    for what, start in (("Python environment", h5py.__file__),
                        ("Python environment", matplotlib.__file__),
                        ("checkout", REPO / "spacarpy" / "__init__.py")):
        path = os.path.dirname(os.path.realpath(start))
        while True:
            mode = os.stat(path).st_mode
            if not mode & stat.S_IXOTH or not mode & stat.S_IROTH:
                return (f"the user nobody cannot read this {what} ({path} is "
                        f"mode {stat.S_IMODE(mode):o})")
            parent = os.path.dirname(path)
            if parent == path:
                break
            path = parent
    return None


def spacarpy_as_nobody(args, cwd="/", timeout=300, env=None) -> subprocess.CompletedProcess:
    """``spacarpy ARGS`` (the CLI argument list) as the user ``nobody``, in a process that
    imported everything as root first; the caller checks :func:`nobody_uid` (skip if None).
    MPLCONFIGDIR is a fresh directory that ``nobody`` may write."""
    import json
    import os
    import shutil
    import tempfile
    uid = nobody_uid()
    if uid is None:
        raise RuntimeError("only root can run a command as nobody")
    mpl = tempfile.mkdtemp(prefix="spacarpy-mpl-", dir="/tmp")
    try:
        os.chmod(mpl, 0o777)
        full_env = dict(os.environ if env is None else env, PYTHONPATH=str(REPO),
                        PYTHONDONTWRITEBYTECODE="1", MPLCONFIGDIR=mpl,
                        OPENBLAS_NUM_THREADS="1")
        return subprocess.run([sys.executable, "-c", _AS_NOBODY_SCRIPT, str(uid),
                               json.dumps([str(a) for a in args])], env=full_env,
                              cwd=str(cwd), capture_output=True, text=True, timeout=timeout)
    finally:
        shutil.rmtree(mpl, ignore_errors=True)


def slider_deck(v0: float, a0: float, steps: int = 50, gravity: bool = False) -> str:
    """A 2 kg slider on node 3 whose x the 5-field ``INPUTX 3 1 1.0 v0 a0`` drives at a
    constant acceleration a0 from the velocity v0 over one second in ``steps`` steps (with
    gravity along -y if asked: it does no work on the slider)."""
    g = "GRAVITY 0 -9.81 0\n" if gravity else ""
    return ("# a 2 kg slider on node 3, its x driven by INPUTX n c value velocity acceleration\n"
            "X 1 0 0 0\nX 3 1 0 0\nTRUSS 1 1 3\nRLSE 1 1\nFIX 1\nFIX 3 2 3\nINPUTX 3 1\n"
            f"END\nHALT\nXM 3 2.0\nINPUTX 3 1 1.0 {v0} {a0}\n{g}TIMESTEP 1.0 {steps}\n"
            "MODE transient\nEND\nEND\n")


def rolling_coin_deck(gravity: str = "0 0 -9.81", timestep: str = "0 0", sets: str = "",
                      title: str = "a uniform thin disc rolling upright on the ground (z up)"
                      ) -> str:
    """A uniform thin disc (m = 2 kg, r = R = 0.3 m, A = 0.045, C = 0.09 kg m^2) rolling
    upright at V = 3 m/s (``SET V``), heading, lean and spin DYNE, the contact's x and y
    KINX, in MODE 3 with the given GRAVITY, TIMESTEP and extra SET lines."""
    return (f"# {title}\nSET V 3\nSET R 0.3\n{sets}"
            "X 1 0 0 {R}                    # hub\n"
            "X 2 0 0 0                      # contact point\n"
            "HINGE 1 3 4 0 0 1              # heading\n"
            "HINGE 2 4 5 1 0 0              # lean\n"
            "HINGE 3 5 6 0 1 0              # spin\n"
            "WHEEL 4 1 6 2 0 1 0\nFIX 3\nDYNE 1 1\nDYNE 2 1\nDYNE 3 1\nKINX 2 1\nKINX 2 2\n"
            "END\nHALT\nXM 1 2.0\n"
            "XM 6 0.045 0 0 0.09 0 0.045    # A about a diameter, C about the axle\n"
            f"GRAVITY {gravity}\nSTARTDE 3 1 {{V/R}}\nMODE 3\nTIMESTEP {timestep}\n"
            "END\nEND\n")
