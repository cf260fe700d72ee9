"""A full disk (ENOSPC) never harms (issue 34, item 5; report N2): every command that writes
into a small tmpfs that fills up ends with one line, exit 1, the old good file byte-identical,
no 0-byte file or partial file left behind, and no segmentation fault.

The tmpfs is mounted by the test (root only; skipped where mounting is not allowed) and
unmounted in a ``finally``. Each command runs in a subprocess (a crash must not take pytest
with it), as root and, where the tests run as root, as the normal user ``nobody`` (a process that
imports everything as root and then switches user: ``helpers.spacarpy_as_nobody``).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from helpers import nobody_skip_reason, spacarpy_as_nobody

ROOT = Path(__file__).resolve().parents[1]
DECKS = ROOT / "decks"
pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="tmpfs mounts: Linux only")


def spacarpy(args, user="root", cwd=None, timeout=300):
    if user == "nobody":            # imports as root, then becomes nobody (tests/helpers.py)
        return spacarpy_as_nobody(args, cwd=cwd or "/", timeout=timeout)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "spacarpy", *map(str, args)], env=env,
                          cwd=cwd or "/", capture_output=True, text=True, timeout=timeout)


_NOBODY_OK = {}


def _nobody_reason() -> str | None:
    """Why the commands cannot run as ``nobody`` here (None when they can)."""
    if "reason" not in _NOBODY_OK:
        reason = None
        reason = nobody_skip_reason()
        if reason is None:
            try:
                r = spacarpy(["--version"], user="nobody", timeout=60)
                if r.returncode != 0:
                    reason = f"nobody cannot run spacarpy here: {r.stderr.strip()[-200:]}"
            except (OSError, subprocess.SubprocessError) as exc:
                reason = f"nobody cannot run spacarpy here: {exc}"
        _NOBODY_OK["reason"] = reason
    return _NOBODY_OK["reason"]


@pytest.fixture(params=["root", "nobody"])
def user(request):
    if request.param == "nobody" and _nobody_reason():
        pytest.skip(_nobody_reason())
    return request.param


@pytest.fixture
def tiny():
    """A 200 KiB tmpfs, writable by everyone, and a readable directory with the decks."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    base = Path(tempfile.mkdtemp(prefix="spacarpy-full-", dir="/tmp"))
    base.chmod(0o755)
    mnt, decks = base / "tiny", base / "decks"
    mnt.mkdir()
    decks.mkdir()
    for name in ("table2_bend_48el_modified.dat", "table2_bend_8el_modified.dat",
                 "pendulum_rigid_90deg.dat", "sweep_column_load_ratio.dat"):
        shutil.copy(DECKS / name, decks / name)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=200k,mode=1777", "tmpfs",
                        str(mnt)], capture_output=True, text=True)
    if r.returncode != 0:
        shutil.rmtree(base)
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
    try:
        yield mnt, decks
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
        shutil.rmtree(base, ignore_errors=True)


def fill(mnt: Path, kib: int) -> None:
    (mnt / "filler").write_bytes(bytes(kib * 1024))
    (mnt / "filler").chmod(0o644)


def assert_disk_full(r, mnt, keep=("filler",), warned=False):
    """One line, exit 1, 'disk full', nothing left in the tmpfs but ``keep``; ``warned``: a
    transient's warning before the run that its file will not fit comes first."""
    assert r.returncode == 1, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    if warned:
        assert "the result file will be about" in lines[0] and "free there" in lines[0]
        lines = lines[1:]
    assert len(lines) == 1, r.stderr
    assert "disk full" in lines[0] and "Traceback" not in r.stderr
    assert sorted(p.name for p in mnt.iterdir()) == sorted(keep)


def test_run_keeps_the_old_file_when_the_new_one_does_not_fit(tiny, user):
    mnt, decks = tiny
    out = mnt / "good.h5"
    r = spacarpy(["run", decks / "table2_bend_48el_modified.dat", "-o", out, "-q"], user)
    assert r.returncode == 0, r.stderr
    good = out.read_bytes()
    assert len(good) > 100_000          # a second copy cannot fit beside it
    r = spacarpy(["run", decks / "table2_bend_48el_modified.dat", "-o", out, "-q"], user)
    assert_disk_full(r, mnt, keep=("good.h5",))
    assert "the previous" in r.stderr and "is unchanged" in r.stderr
    assert out.read_bytes() == good


def test_run_filling_the_disk_between_steps(tiny, user):
    mnt, decks = tiny
    fill(mnt, 60)
    r = spacarpy(["run", decks / "table2_bend_48el_modified.dat", "-o", mnt / "new.h5", "-q"],
                 user)
    assert_disk_full(r, mnt)
    assert "static steps) was removed" in r.stderr and "no " in r.stderr


@pytest.mark.slow
def test_run_filling_the_disk_at_the_final_commit(tiny, user):
    """Some free space between 'all steps written' and 'file closed': scanned in 4 KiB
    steps, every run either succeeds with a complete file or fails cleanly, and at least
    one fails after all its steps were written (at the commit)."""
    mnt, decks = tiny
    at_commit = False
    for kib in range(0, 44, 2):     # (filled KiB; schema 3.0 files are ~20 % larger than 2.x)
        for p in mnt.iterdir():
            p.unlink()
        fill(mnt, kib)
        r = spacarpy(["run", decks / "table2_bend_48el_modified.dat", "-o", mnt / "new.h5",
                      "-q"], user)
        if r.returncode == 0:
            v = spacarpy(["validate", mnt / "new.h5"], user)
            assert v.returncode == 0, v.stdout + v.stderr
            continue
        assert_disk_full(r, mnt)
        at_commit |= "with 10 static steps" in r.stderr
    assert at_commit


def test_transient_run_filling_the_disk(tiny, user):
    mnt, decks = tiny
    fill(mnt, 150)
    r = spacarpy(["run", decks / "pendulum_rigid_90deg.dat", "-o", mnt / "p.h5", "-q"], user)
    assert_disk_full(r, mnt, warned=True)


@pytest.mark.parametrize("kib", [196, 190, 184])
def test_sweep_file_on_a_full_disk(tiny, kib):
    """Report N2's sweep case: exit 1, one line, nothing left (was exit 2 with HDF5's
    two-line text and a partial file left behind, or a segmentation fault). As root only:
    the sweep's runs are new processes of this interpreter, which nobody may not execute."""
    mnt, decks = tiny
    fill(mnt, kib)
    r = spacarpy(["sweep", decks / "sweep_column_load_ratio.dat", "--set", "ratio=-0.5,-0.4",
                  "-o", mnt / "s.h5", "-q", "-j", "1"])
    assert_disk_full(r, mnt)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """A pendulum (transient) and a bend (static) result, readable by nobody too."""
    base = Path(tempfile.mkdtemp(prefix="spacarpy-res-", dir="/tmp"))
    base.chmod(0o755)
    out = {}
    for key, deck in (("pend", "pendulum_rigid_90deg.dat"),
                      ("bend", "table2_bend_8el_modified.dat")):
        out[key] = base / f"{key}.h5"
        r = spacarpy(["run", DECKS / deck, "-o", out[key], "-q"])
        assert r.returncode in (0, 4), r.stderr
        out[key].chmod(0o644)
    yield out
    shutil.rmtree(base, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.parametrize("command", [
    ("extract", "pend", "time_position", "--csv", "-o", "x.csv"),
    ("plot", "bend", "shape", "-o", "x.png"),
    ("export", "pend", "--vtk", "-o", "x.pvd"),
    ("export", "pend", "--xdmf", "-o", "x.xdmf"),
], ids=["extract", "plot", "export-vtk", "export-xdmf"])
@pytest.mark.parametrize("old", [False, True], ids=["new", "old-file-kept"])
def test_result_commands_on_a_full_disk(tiny, results, user, command, old):
    """Each command fails cleanly with 4 KiB left; an old output stays byte-identical."""
    if command[0] == "plot":
        pytest.importorskip("matplotlib")
    if command[2] == "--vtk":
        pytest.importorskip("meshio")
    mnt, _ = tiny
    out = mnt / command[-1]
    keep = ["filler"]
    if old:
        out.write_bytes(b"old good file\n")
        out.chmod(0o666)
        keep.append(out.name)
    fill(mnt, 196)
    args = [command[0], results[command[1]], *command[2:-1], out]
    r = spacarpy(args, user)
    assert_disk_full(r, mnt, keep=keep)
    if old:
        assert out.read_bytes() == b"old good file\n"
        assert "is unchanged" in r.stderr


#: a library caller of ``spacarpy.cli.main``: several runs into the filling tmpfs in one
#: process, which then ends through the interpreter's normal exit (HDF5's own clean-up runs
#: then, unlike the ``spacarpy`` command's ``os._exit``)
_LIBRARY_CALLER = """
import json
import sys
from pathlib import Path
from spacarpy.cli import main
mnt, codes = Path(sys.argv[1]), []
for args, kib in json.loads(sys.argv[2]):
    for p in mnt.iterdir():
        p.unlink()
    (mnt / "filler").write_bytes(bytes(kib * 1024))
    codes.append(main(args))
print(codes)
"""


def test_a_library_caller_exits_normally_after_disk_full(tiny):
    """The disk fills while the header, the step groups, a step, the final commit or a time
    step is written, or a sweep file's header or points: each run returns 1 with one line,
    and the process then exits with 0, not a segmentation fault (HDF5 closing datasets
    whose flush had failed)."""
    mnt, decks = tiny
    bend, pend = decks / "table2_bend_48el_modified.dat", decks / "pendulum_rigid_90deg.dat"
    sweep = ["sweep", str(decks / "sweep_column_load_ratio.dat"), "--set",
             "ratio=-0.5:-0.1:6", "-o", str(mnt / "s.h5"), "-q", "-j", "1"]
    runs = [(["run", str(bend), "-o", str(mnt / "new.h5"), "-q"], k)
            for k in (196, 180, 156, 148, 140, 100, 60, 36, 28)]
    runs += [(["run", str(pend), "-o", str(mnt / "new.h5"), "-q"], k) for k in (172, 150, 100)]
    runs += [(sweep, k) for k in (196, 190, 186, 182)]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    r = subprocess.run([sys.executable, "-c", _LIBRARY_CALLER, str(mnt), json.dumps(runs)],
                       env=env, capture_output=True, text=True, timeout=600, cwd="/")
    assert r.returncode == 0, (r.returncode, r.stderr[-3000:])
    assert r.stdout.strip().splitlines()[-1] == str([1] * len(runs)), r.stdout
    lines = [ln for ln in r.stderr.splitlines() if "the result file will be about" not in ln]
    assert len(lines) == len(runs) and all("disk full" in ln for ln in lines), r.stderr
    assert sorted(p.name for p in mnt.iterdir()) == ["filler"]
