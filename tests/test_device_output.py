"""Outputs that are not regular files (issue 34, item 5; report N1): a device, a FIFO or a
socket named by -o is refused before the work, by every command; a path that resolves to
the null device means "discard": the command runs and the node is left untouched.

Never the real /dev/null or /dev/full: private device nodes made with ``os.mknod`` in
``tmp_path`` (skipped where that is not permitted), a FIFO (never opened by the test), a
socket.
"""
import os
import shutil
import socket
import stat
from pathlib import Path

import pytest

from spacarpy.cli import main
from spacarpy.outputs import OutputError, check_output_path, is_null_device

DECKS = Path(__file__).resolve().parents[1] / "decks"
DECK = "table1_cantilever_2el_modified.dat"


_SYSTEM = {3: "/dev/null", 7: "/dev/full"}


def node(tmp_path, name, minor):
    """A private character device node c 1 <minor> (3: null, 7: full). Where mknod is not
    permitted (a normal user), a symlink in tmp_path to the system's node: a command that
    wrongly replaced its output would replace the symlink, never the node (and a normal
    user cannot write in /dev anyway)."""
    path = tmp_path / name
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        return path
    except (PermissionError, OSError) as exc:
        reason = exc
    target = _SYSTEM[minor]
    try:
        st = os.stat(target)
    except OSError:
        st = None
    if os.geteuid() == 0 or st is None or not stat.S_ISCHR(st.st_mode) or \
            st.st_rdev != os.makedev(1, minor):
        pytest.skip(f"cannot make a device node here: {reason}")
    path.symlink_to(target)
    return path


def unchanged(path, minor):
    """Still the device (a node, or the symlink to the system's node that node() made)."""
    st = os.stat(path)
    if os.path.islink(path) and os.readlink(path) != _SYSTEM[minor]:
        return False
    return stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, minor)


@pytest.fixture
def deck(tmp_path):
    shutil.copy(DECKS / DECK, tmp_path / DECK)
    return tmp_path / DECK


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("res") / "r.h5"
    assert main(["run", str(DECKS / DECK), "-q", "-o", str(out)]) == 0
    return out


def test_run_into_the_null_device_discards_and_leaves_it_alone(tmp_path, deck, capsys):
    null = node(tmp_path, "devnull", 3)
    assert is_null_device(null)
    link = tmp_path / "link.h5"
    link.symlink_to(null)
    for out in (null, link):
        assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
        assert unchanged(null, 3)
        assert os.path.islink(link)
    # the EXPECT lines of the deck were checked against the discarded file
    assert "PASS" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([DECK, "devnull",
                                                                 "link.h5"])


@pytest.mark.parametrize("make", ["full", "fifo", "socket"])
def test_run_refuses_other_special_files_before_the_work(tmp_path, deck, capsys, make,
                                                         monkeypatch):
    if make == "full":
        out = node(tmp_path, "devfull.h5", 7)
    elif make == "fifo":
        out = tmp_path / "fifo.h5"
        os.mkfifo(out)
    else:
        out = tmp_path / "sock.h5"
        s = socket.socket(socket.AF_UNIX)
        try:
            s.bind(str(out))
        except OSError as exc:          # a path too long for a socket address
            pytest.skip(f"cannot bind a socket: {exc}")
        s.close()
    import spacarpy.run as run_mod
    monkeypatch.setattr(run_mod, "run_model", lambda *a, **k: pytest.fail("the run started"))
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "not a regular file" in err and err.count("\n") == 1
    mode = os.lstat(out).st_mode
    assert not stat.S_ISREG(mode)
    if make == "full":
        assert unchanged(out, 7)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([DECK, out.name])


def test_the_writer_never_replaces_a_device(tmp_path, monkeypatch):
    """The last guard: a device that appears at the output during the run is not
    replaced; the partial file keeps the results."""
    from spacarpy.outputs import refuse_non_regular
    out = node(tmp_path, "x.h5", 7)
    with pytest.raises(OutputError, match="not a regular file"):
        refuse_non_regular(out)
    refuse_non_regular(tmp_path / "absent.h5")
    (tmp_path / "f.h5").write_bytes(b"")
    refuse_non_regular(tmp_path / "f.h5")


def test_check_output_path_refuses_a_fifo_without_opening_it(tmp_path):
    fifo = tmp_path / "p"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="FIFO"):
        check_output_path(fifo, "-o")


def test_extract_into_the_null_device_and_a_fifo(tmp_path, result, capsys):
    null = node(tmp_path, "n.csv", 3)
    assert main(["extract", str(result), "position", "--csv", "-o", str(null)]) == 0
    assert unchanged(null, 3)
    fifo = tmp_path / "f.csv"
    os.mkfifo(fifo)
    assert main(["extract", str(result), "position", "--csv", "-o", str(fifo)]) == 2
    assert "FIFO" in capsys.readouterr().err


def test_plot_and_export_into_the_null_device(tmp_path, result, capsys):
    pytest.importorskip("matplotlib")
    null = node(tmp_path, "n.png", 3)
    assert main(["plot", str(result), "shape", "-o", str(null)]) == 0
    assert unchanged(null, 3)
    full = node(tmp_path, "f.png", 7)
    assert main(["plot", str(result), "shape", "-o", str(full)]) == 2
    assert "not a regular file" in capsys.readouterr().err
    assert unchanged(full, 7)
    vnull = node(tmp_path, "n.pvd", 3)
    assert main(["export", str(result), "--vtk", "-o", str(vnull)]) == 0
    xnull = node(tmp_path, "n.xdmf", 3)
    assert main(["export", str(result), "--xdmf", "-o", str(xnull)]) == 0
    assert unchanged(vnull, 3) and unchanged(xnull, 3)
    fifo = tmp_path / "f.xdmf"
    os.mkfifo(fifo)
    assert main(["export", str(result), "--xdmf", "-o", str(fifo)]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["n.png", "f.png", "n.pvd", "n.xdmf", "f.xdmf"])


def test_bench_markdown_into_a_fifo_is_refused(tmp_path, capsys):
    fifo = tmp_path / "b.md"
    os.mkfifo(fifo)
    assert main(["bench", "--markdown", str(fifo), "--sizes", "2", "--repeat", "1"]) == 2
    assert "FIFO" in capsys.readouterr().err


def test_ci_runs_the_nobody_variants():
    """In CI the normal-user variants run, never skip: .ci/run makes its virtual environment
    readable by everyone and sets SPACARPY_CI_NOBODY; where CI runs as root, a reason to skip
    (a private venv or checkout again) fails here instead of hiding those tests."""
    from helpers import nobody_skip_reason, nobody_uid
    if not os.environ.get("SPACARPY_CI_NOBODY"):
        pytest.skip("not .ci/run's own virtual environment (SPACARPY_CI_NOBODY unset)")
    if nobody_uid() is None:
        pytest.skip("not root (or no user nobody): the nobody variants cannot run")
    assert nobody_skip_reason() is None


def test_null_device_and_refusals_as_nobody():
    """The same guarantees as a normal user (``nobody``; root makes the nodes): run,
    extract, plot and export into a null device discard and leave it alone; a full device
    and a FIFO are refused with exit 2 and one line; nothing else appears."""
    import tempfile

    from helpers import nobody_skip_reason, nobody_uid, spacarpy_as_nobody
    if nobody_skip_reason():
        pytest.skip(nobody_skip_reason())
    base = Path(tempfile.mkdtemp(prefix="spacarpy-dev-", dir="/tmp"))
    try:
        base.chmod(0o777)
        shutil.copy(DECKS / DECK, base / DECK)
        (base / DECK).chmod(0o644)
        null = node(base, "null", 3)
        png, xdmf = node(base, "n.png", 3), node(base, "n.xdmf", 3)
        full = node(base, "full", 7)
        os.mkfifo(base / "fifo", 0o666)
        os.chmod(base / "fifo", 0o666)
        res = base / "r.h5"
        runs = [(["run", base / DECK, "-q", "-o", null], 0),
                (["run", base / DECK, "-q", "-o", res], 0),
                (["extract", res, "position", "--csv", "-o", null], 0),
                (["plot", res, "shape", "-o", png], 0),
                (["export", res, "--xdmf", "-o", xdmf], 0),
                (["run", base / DECK, "-q", "-o", full], 2),
                (["extract", res, "position", "--csv", "-o", base / "fifo"], 2)]
        for args, code in runs:
            r = spacarpy_as_nobody(args, cwd=base, timeout=120)
            assert r.returncode == code, (args, r.returncode, r.stderr)
            assert "Traceback" not in r.stderr
            if code:
                assert len(r.stderr.strip().splitlines()) == 1, r.stderr
                assert "not a regular file" in r.stderr or "FIFO" in r.stderr, r.stderr
        assert os.stat(res).st_uid == nobody_uid()
        assert all(unchanged(n, 3) for n in (null, png, xdmf)) and unchanged(full, 7)
        assert stat.S_ISFIFO(os.lstat(base / "fifo").st_mode)
        assert sorted(p.name for p in base.iterdir()) == sorted(
            [DECK, "null", "n.png", "n.xdmf", "full", "fifo", "r.h5"])
    finally:
        shutil.rmtree(base, ignore_errors=True)
