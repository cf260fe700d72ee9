"""``batch`` and ``sweep`` get the guarantees of ``run``: outputs checked before any run (one
line, exit 2, nothing created), damaged baselines reported per deck, ``--dask`` problems as
one line, and an interrupted batch or sweep keeps what finished (exit 130 / 143)."""
import json
import logging
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main

ROOT = Path(__file__).resolve().parents[1]
DECKS = ROOT / "decks"
SMALL = "table1_cantilever_2el_modified.dat"
SWEEP = "sweep_column_load_ratio.dat"
HANG = ("X 1 0 0 0\nBEAMS 1  1 2 3 4  200000\nX 3 1 0 0\nDYNE 1:200000 1 2 3 4 5 6\nFIX 1\n"
        "FIX 2\nEND\nHALT\nESTIFF 1:200000 1 1 1 1\nDELXF 3 0 1 0\nITERSTEP 20 100 1e-9\n"
        "END\nEND\n")


def tree(path: Path) -> dict:
    """Every file below ``path`` with its bytes (directories as None)."""
    return {p.relative_to(path).as_posix(): (p.read_bytes() if p.is_file() else None)
            for p in sorted(path.rglob("*"))}


def sweep_deck_with_include(tmp: Path) -> Path:
    deck = tmp / "col.dat"
    text = (DECKS / SWEEP).read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("FIX 3 2 3"))
    deck.write_text(text.replace(line, 'INCLUDE "extra.inc"'))
    (tmp / "extra.inc").write_text("FIX 3 2 3\n")
    return deck


# -- outputs checked before any run: one line, exit 2, nothing created ----------------------

@pytest.mark.parametrize("options, message", [
    (["--report", "{tmp}/adir"], "--report {tmp}/adir: is a directory"),
    (["--report", "{tmp}/missing/r.xml"], "the directory {tmp}/missing does not exist"),
    (["--report", "{tmp}/d.dat"], "is an input file of this run"),
    (["--output-dir", "{tmp}/afile.h5"], "--output-dir {tmp}/afile.h5: is a file"),
    (["--output-dir", "{tmp}/missing/out"], "the directory {tmp}/missing does not exist"),
    (["--baseline", "{tmp}/missing/base", "--update-baseline"],
     "--baseline {tmp}/missing/base: the directory {tmp}/missing does not exist"),
    (["--update-baseline"], "--update-baseline needs --baseline DIR"),
])
def test_batch_refuses_bad_outputs_before_any_run(tmp_path, capsys, options, message):
    shutil.copy(DECKS / SMALL, tmp_path / "d.dat")
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile.h5").write_bytes(b"not a directory")
    before = tree(tmp_path)
    t0 = time.perf_counter()
    rc = main(["batch", str(tmp_path / "d.dat"), "-q"]
              + [o.format(tmp=tmp_path) for o in options])
    assert rc == 2 and time.perf_counter() - t0 < 5       # refused, not run first
    err = capsys.readouterr().err
    assert message.format(tmp=tmp_path) in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert tree(tmp_path) == before


@pytest.mark.parametrize("options, message", [
    (["-o", "{tmp}/adir"], "-o {tmp}/adir: is a directory"),
    (["-o", "{tmp}/col.dat"], "is an input file of this run"),
    (["-o", "{tmp}/extra.inc"], "is an input file of this run"),
    (["-o", "{tmp}/link.h5"], "is an input file of this run"),
    (["-o", "{tmp}/missing/s.h5"], "the directory {tmp}/missing does not exist"),
    (["-o", "{tmp}/s.h5", "--csv", "{tmp}/adir"], "--csv {tmp}/adir: is a directory"),
    (["-o", "{tmp}/s.h5", "--csv", "{tmp}/extra.inc"], "is an input file of this run"),
    (["-o", "{tmp}/s.h5", "--csv", "{tmp}/missing/t.csv"], "{tmp}/missing does not exist"),
])
def test_sweep_refuses_bad_outputs_before_any_run(tmp_path, capsys, options, message):
    deck = sweep_deck_with_include(tmp_path)
    (tmp_path / "adir").mkdir()
    (tmp_path / "link.h5").symlink_to(deck.name)
    before = tree(tmp_path)
    rc = main(["sweep", str(deck), "--set", "ratio=-0.5,-0.4", "-q", "-j", "1"]
              + [o.format(tmp=tmp_path) for o in options])
    assert rc == 2
    err = capsys.readouterr().err
    assert message.format(tmp=tmp_path) in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert tree(tmp_path) == before                   # the deck and INCLUDE file unchanged


def _private_node(tmp_path, name, minor):
    """A private character device node c 1 <minor> (3: null, 7: full) in tmp_path: never the
    system's /dev/null, which a wrong replace would destroy for the whole machine."""
    path = tmp_path / name
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    except OSError as exc:
        pytest.skip(f"cannot make a device node here: {exc}")
    return path


def test_sweep_into_the_null_device_discards_and_leaves_it_alone(tmp_path, capsys):
    """``sweep -o NULL`` runs and discards the file: the node stays a character device and
    nothing is written beside it (no lock, no partial file)."""
    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(DECKS / SWEEP, work / "s.dat")
    dev = tmp_path / "dev"
    dev.mkdir()
    null = _private_node(dev, "null", 3)
    assert main(["sweep", str(work / "s.dat"), "--set", "ratio=-0.5,-0.4", "-q",
                 "-o", str(null), "--csv", str(null)]) == 0
    assert stat.S_ISCHR(os.stat(null).st_mode)
    assert sorted(p.name for p in dev.iterdir()) == ["null"]


def test_sweep_refuses_another_device_node(tmp_path, capsys):
    shutil.copy(DECKS / SWEEP, tmp_path / "s.dat")
    full = _private_node(tmp_path, "full", 7)
    assert main(["sweep", str(tmp_path / "s.dat"), "--set", "ratio=-0.5,-0.4", "-q",
                 "-o", str(full)]) == 2
    assert "is a character device, not a regular file" in capsys.readouterr().err
    assert stat.S_ISCHR(os.stat(full).st_mode)


_READ_ONLY_SCRIPT = """
import os, sys
import spacarpy.batch.backends, spacarpy.batch.commands, spacarpy.batch.report
import spacarpy.batch.runner, spacarpy.batch.sweep, spacarpy.deck.parser, spacarpy.outputs
import spacarpy.user_routines  # batch and sweep scan the decks for user routines
import spacarpy.results.dims, spacarpy.results.h5file, spacarpy.results.schema  # sweep files
from spacarpy.cli import main
import contextlib, io, locale  # noqa
tmp, deck, sweep, uid = sys.argv[1:5]
with contextlib.redirect_stderr(io.StringIO()):     # the lazy imports of the checks, now
    main(["batch", tmp + "/none*.dat", "-q"])
    main(["sweep", tmp + "/none.dat", "--set", "ratio=1,2", "-q"])
if int(uid) >= 0:
    os.setuid(int(uid))         # after the imports: the interpreter may live where it can't read
ro = os.path.join(tmp, "ro")
cases = [
    ["batch", deck, "--report", ro + "/r.xml"],
    ["batch", deck, "--output-dir", ro],
    ["batch", deck, "--output-dir", ro + "/out"],
    ["batch", deck, "--baseline", ro, "--update-baseline"],
    ["sweep", sweep, "--set", "ratio=-0.5,-0.4", "-o", ro + "/s.h5"],
    ["sweep", sweep, "--set", "ratio=-0.5,-0.4", "-o", tmp + "/s.h5", "--csv", ro + "/s.csv"],
]
print([main(c + ["-q", "-j", "1"]) for c in cases])
"""


def test_read_only_directories_are_refused_as_a_non_root_user():
    """As a user who cannot write there (os.setuid to nobody where the tests run as root:
    root may write into a read-only directory)."""
    uid = -1
    if os.geteuid() == 0:
        try:
            import pwd
            uid = pwd.getpwnam("nobody").pw_uid
        except (ImportError, KeyError):
            pytest.skip("no user 'nobody' to run as")
    tmp = Path(tempfile.mkdtemp(prefix="spacarpy-ro-"))
    try:
        tmp.chmod(0o777)
        shutil.copy(DECKS / SMALL, tmp / "d.dat")
        shutil.copy(DECKS / SWEEP, tmp / "s.dat")
        for f in tmp.iterdir():
            f.chmod(0o644)
        (tmp / "ro").mkdir()
        (tmp / "ro").chmod(0o555)
        before = tree(tmp)
        env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONDONTWRITEBYTECODE="1")
        proc = subprocess.run(
            [sys.executable, "-c", _READ_ONLY_SCRIPT, str(tmp), str(tmp / "d.dat"),
             str(tmp / "s.dat"), str(uid)], capture_output=True, text=True, timeout=120,
            env=env, cwd=str(tmp))
        assert proc.stdout.strip() == "[2, 2, 2, 2, 2, 2]", proc.stderr
        err = proc.stderr.splitlines()
        assert "Traceback" not in proc.stderr and len(err) == 6, proc.stderr
        assert f"--report {tmp}/ro/r.xml: the directory {tmp}/ro is not writable" in err[0]
        assert f"--output-dir {tmp}/ro: the directory is not writable" in err[1]
        assert f"cannot be created: the directory {tmp}/ro is not writable" in err[2]
        assert f"--baseline {tmp}/ro: the directory is not writable" in err[3]
        assert f"-o {tmp}/ro/s.h5: the directory {tmp}/ro is not writable" in err[4]
        assert f"--csv {tmp}/ro/s.csv: the directory {tmp}/ro is not writable" in err[5]
        assert tree(tmp) == before
    finally:
        (tmp / "ro").chmod(0o755)
        shutil.rmtree(tmp, ignore_errors=True)


def test_read_only_directories_are_refused_whoever_runs(tmp_path, monkeypatch, capsys):
    """The same checks where os.access says no (also as root)."""
    import spacarpy.outputs as outputs
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(outputs.os, "access",
                        lambda p, mode: False if Path(p) == ro else real(p, mode))
    shutil.copy(DECKS / SWEEP, tmp_path / "s.dat")
    assert main(["batch", str(DECKS / SMALL), "-q", "--output-dir", str(ro)]) == 2
    assert main(["batch", str(DECKS / SMALL), "-q", "--report", str(ro / "r.json")]) == 2
    assert main(["sweep", str(tmp_path / "s.dat"), "--set", "ratio=-0.5,-0.4", "-q", "-o",
                 str(ro / "s.h5")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"--output-dir {ro}: the directory is not writable",
                   f"--report {ro}/r.json: the directory {ro} is not writable",
                   f"-o {ro}/s.h5: the directory {ro} is not writable"]
    assert list(ro.iterdir()) == []


# -- --dask problems: one line, exit 2, before anything is written ------------------------

def test_dask_address_that_is_no_address_is_refused(tmp_path, capsys):
    shutil.copy(DECKS / SWEEP, tmp_path / "s.dat")
    for cmd in (["batch", str(DECKS / SMALL)],
                ["sweep", str(tmp_path / "s.dat"), "--set", "ratio=-0.5,-0.4"]):
        assert main(cmd + ["-q", "--dask", "nonsense"]) == 2
        err = capsys.readouterr().err
        assert "--dask 'nonsense': not a scheduler address" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.dat"]


def test_dask_local_without_dask_installed_is_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)     # import fails
    assert main(["batch", str(DECKS / SMALL), "-q", "--dask", "local"]) == 2
    err = capsys.readouterr().err
    assert "--dask needs dask.distributed, which is not installed" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_dask_scheduler_that_does_not_answer_is_refused_quickly(tmp_path, monkeypatch,
                                                                capsys):
    pytest.importorskip("distributed", reason="dask.distributed is not installed")
    import spacarpy.batch.backends as backends
    monkeypatch.setattr(backends, "DASK_CONNECT_TIMEOUT", 1.0)
    shutil.copy(DECKS / SWEEP, tmp_path / "s.dat")
    t0 = time.perf_counter()
    assert main(["sweep", str(tmp_path / "s.dat"), "--set", "ratio=-0.5,-0.4", "-q",
                 "--dask", "tcp://127.0.0.1:1"]) == 2
    assert time.perf_counter() - t0 < 15
    err = capsys.readouterr().err
    assert "--dask tcp://127.0.0.1:1: no Dask scheduler answered within 1 s" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.dat"]    # no sweep file


# -- damaged baselines: that deck FAILED, every other deck judged --------------------------

def test_damaged_baselines_fail_their_deck_only(tmp_path, capsys):
    decks, base = tmp_path / "decks", tmp_path / "base"
    decks.mkdir()
    base.mkdir()
    good = (DECKS / "baseline" / SMALL).with_suffix(".h5").read_bytes()
    names = ("a_good", "b_truncated", "c_lfs_pointer", "d_foreign", "e_schema")
    for name in names:
        shutil.copy(DECKS / SMALL, decks / f"{name}.dat")
    (base / "a_good.h5").write_bytes(good)
    (base / "b_truncated.h5").write_bytes(good[:len(good) // 2])
    (base / "c_lfs_pointer.h5").write_text(
        "version https://git-lfs.github.com/spec/v1\noid sha256:" + "0" * 64 + "\nsize 1\n")
    with h5py.File(base / "d_foreign.h5", "w") as f:
        f["x"] = np.arange(3.0)
    (base / "e_schema.h5").write_bytes(good)
    with h5py.File(base / "e_schema.h5", "r+") as f:
        f.attrs["schema_version"] = np.array([99, 0])
    report = tmp_path / "r.json"
    assert main(["batch", str(decks), "--baseline", str(base), "-q", "-j", "2",
                 "--report", str(report)]) == 1
    out = capsys.readouterr().out
    doc = {d["name"]: d for d in json.loads(report.read_text())["decks"]}
    assert doc["a_good.dat"]["status"] == "pass"
    reasons = {"b_truncated": f"it should be {len(good)} (truncated)",
               "c_lfs_pointer": "not an HDF5 file (no HDF5 signature)",
               "d_foreign": "not a spacarpy results file",
               "e_schema": "99"}
    for name, reason in reasons.items():
        d = doc[f"{name}.dat"]
        assert d["status"] == "failed" and d["message"].startswith("damaged baseline: ")
        assert reason in d["message"], d["message"]
    assert "5 decks: 1 pass, 0 changed, 4 failed, 0 new" in out


# -- interrupted batch and sweep: the finished part is kept, exit 130 / 143 ----------------

def _spacarpy(args, cwd, **kw):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "spacarpy", *args], cwd=cwd, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        # a Ctrl-C must reach Python even where this test runs in a background job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL), **kw)


def _wait_for(condition, proc, timeout=120.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            pytest.fail(f"ended early ({proc.returncode}): {proc.communicate()}")
        if condition():
            return
        time.sleep(0.1)
    proc.kill()
    pytest.fail("timed out waiting")


def _points_done(path: Path) -> int:
    try:
        with h5py.File(path, "r", locking=False) as f:
            return int(f.attrs["n_done"])
    except (OSError, KeyError, RuntimeError):
        return 0


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_sweep_keeps_every_finished_point(tmp_path, sig, code):
    shutil.copy(DECKS / SWEEP, tmp_path / "col.dat")
    proc = _spacarpy(["sweep", "col.dat", "--set", "ratio=-0.9:-0.1:2000", "-j", "1",
                      "--collect", "/eigen/frequency", "-o", "s.h5", "--csv", "s.csv"],
                     tmp_path)
    partial = tmp_path / "s.partial.h5"
    _wait_for(lambda: _points_done(partial) >= 3, proc)
    proc.send_signal(sig)
    t0 = time.monotonic()
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == code and time.monotonic() - t0 < 20, err
    assert "sweep: 2000 points" in err and "Traceback" not in err
    assert "sweep interrupted:" in err and "s.partial.h5" in err
    assert not (tmp_path / "s.h5").exists()        # only a complete sweep takes that name
    with h5py.File(partial) as f:
        assert not f.attrs["completed"]
        n = int(f.attrs["n_done"])
        status = f["sweep/status"][()]
        ratio = f["parameters/ratio"][()]
        freq = f["eigen/frequency"][()]
    assert 3 <= n < 2000 and (status == 0).sum() == n and (status == -2).sum() == 2000 - n
    done = status == 0
    np.testing.assert_allclose(freq[done, 0], np.pi / 2 * np.sqrt(1 + ratio[done]),
                               rtol=2e-3)
    assert np.isnan(freq[~done]).all()
    assert f"{2000 - n} of 2000 points not run (the sweep was interrupted)" in out
    assert len(out.splitlines()) == n + 2             # header, finished points, the count
    csv = (tmp_path / "s.csv").read_text().splitlines()
    assert len(csv) == 2001 and sum(",not run," in ln for ln in csv) == 2000 - n


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_batch_writes_its_table_and_reports(tmp_path, sig, code):
    decks = tmp_path / "decks"
    decks.mkdir()
    shutil.copy(DECKS / SMALL, decks / "a.dat")
    (decks / "z_hang.dat").write_text(HANG)
    proc = _spacarpy(["batch", "decks", "-j", "1", "--output-dir", "out", "--report",
                      "r.xml", "--report", "r.json"], tmp_path)
    _wait_for(lambda: (tmp_path / "out" / "a.h5").exists(), proc)
    time.sleep(0.5)                                    # z_hang is running now
    proc.send_signal(sig)
    t0 = time.monotonic()
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == code and time.monotonic() - t0 < 20, err
    assert "Traceback" not in err and "not run: z_hang.dat" in err
    assert "NEW      a.dat" in out and "NOT RUN  z_hang.dat" in out
    assert "2 decks: 0 pass, 0 changed, 0 failed, 1 new, 1 not run (interrupted)" in out
    doc = {d["name"]: d["status"] for d in json.loads((tmp_path / "r.json").read_text())
           ["decks"]}
    assert doc == {"a.dat": "new", "z_hang.dat": "not run"}
    suite = ET.parse(tmp_path / "r.xml").getroot().find("testsuite")
    assert suite.get("tests") == "2" and suite.get("skipped") == "2"


def test_a_large_sweep_says_how_many_points_and_the_size(tmp_path, caplog):
    from spacarpy.batch.sweep import _announce
    from spacarpy.batch.sweep_file import estimated_size
    caplog.set_level(logging.INFO, logger="spacarpy.batch.sweep")
    _announce(100_000, (100_000,), ("/eigen/frequency",))
    assert "sweep: 100000 points (100000): a very large sweep" in caplog.text
    assert f"at least {estimated_size(100_000, 1) / 1e6:.1f} MB" in caplog.text
    assert estimated_size(100_000, 1) == 100_000 * 28
    caplog.clear()
    _announce(21, (21,), ())
    assert "sweep: 21 points (21)" in caplog.text and "very large" not in caplog.text


def test_docs_count_the_shipped_baselines():
    """docs/batch.md's "(N of the M decks, about X MB" is the repository's state now."""
    import re
    text = (ROOT / "docs" / "batch.md").read_text()
    m = re.search(r"\((\d+) of the (\d+) decks, about ([\d.]+) MB", text)
    assert m, "docs/batch.md no longer counts the baselines"
    files = list((DECKS / "baseline").glob("*.h5"))
    assert int(m.group(1)) == len(files)
    assert int(m.group(2)) == len(list(DECKS.glob("*.dat")))
    assert abs(float(m.group(3)) - sum(p.stat().st_size for p in files) / 1e6) < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("code", ["ENOSPC", "EIO"])
def test_a_sweep_file_that_cannot_be_written_is_one_line(tmp_path, monkeypatch, capsys, code):
    """A write of the sweep file fails in the middle of a sweep: one line, no traceback. A
    full disk (as the commands' DiskFull: exit 1) removes the partial file, which could not
    be marked either (tests/test_disk_full.py on a real full disk); another error (exit 2)
    closes it, marked as stopped."""
    import errno

    from spacarpy.batch.sweep_file import SweepFile

    def failing(self, *args):
        raise OSError(getattr(errno, code), os.strerror(getattr(errno, code)))

    monkeypatch.setattr(SweepFile, "_add", failing)
    shutil.copy(DECKS / SWEEP, tmp_path / "s.dat")
    rc = main(["sweep", str(tmp_path / "s.dat"), "--set", "ratio=-0.5,-0.4", "-q", "-j", "1",
               "-o", str(tmp_path / "out.h5")])
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out.h5").exists()
    if code == "ENOSPC":
        assert rc == 1
        assert (f"disk full (or quota exceeded) while writing {tmp_path}/out.h5: No space "
                f"left on device; no {tmp_path}/out.h5 was written") in err
        assert not (tmp_path / "out.partial.h5").exists()
        return
    assert rc == 2
    assert f"cannot write the sweep file {tmp_path}/out.partial.h5: Input/output error" in err
    with h5py.File(tmp_path / "out.partial.h5") as f:
        assert not f.attrs["completed"] and "stopped after 0 of 2 points" in f.attrs["error"]
