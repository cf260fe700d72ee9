"""Damaged result files: every command gives the undamaged numbers or a clear error, fast.

Two real result files (a static run with eigen and buckling modes at every step, and a short
transient run of the rigid pendulum) are truncated at 20 points of their length, damaged by
overwriting bytes at 20 seeded random places, and replaced by random bytes. On each variant
``validate``, ``show``, ``extract``, ``plot``, ``export`` and :func:`spacarpy.open_results`
must either give exactly the output of the undamaged file (exit 0: a damaged byte in unused
space may pass) or exit 2 with a one-line message, within a time limit, with no traceback.
"""
from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.results import ResultsFormatError, open_results
from spacarpy.results.h5file import read_superblock

from helpers import run_and_kill

ROOT = Path(__file__).resolve().parents[1]

DECKS = Path(__file__).resolve().parents[1] / "decks"
_LIMIT = 20          # seconds any one command may take on any file
_N_TRUNCATE = 20
_N_FLIP = 20
_N_RANDOM = 3


class _Timeout(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds):
    def expire(signum, frame):
        raise _Timeout(f"took more than {seconds} s")
    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _cli(argv, path) -> tuple[int, str]:
    """Run the command line in-process: (exit code, stdout + stderr with the path as FILE)."""
    out, err = io.StringIO(), io.StringIO()
    with _time_limit(_LIMIT), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv + ["-q"])
        except BaseException as exc:       # noqa: BLE001 -- any escape is the failure
            pytest.fail(f"{argv}: {type(exc).__name__} escaped main(): {exc}")
    text = (out.getvalue() + err.getvalue()).replace(str(path), "FILE")
    return code, text


def _api(path):
    """Numbers read through open_results, or the ResultsFormatError message."""
    with _time_limit(_LIMIT):
        try:
            with open_results(path) as res:
                group = res.static if res.transient is None else res.transient
                out = [res.model.position_x0, group.position(), group.euler()]
                if res.eigen is not None:
                    out += [res.eigen.frequency, res.eigen.shape(mode=1).position]
                if res.buckling is not None:
                    out += [res.buckling.load_multiplier]
                return out
        except ResultsFormatError as exc:
            return str(exc)


_COMMANDS = {
    "validate": lambda p: ["validate", str(p), "--require-complete"],
    "show": lambda p: ["show", str(p)],
    "extract position": lambda p: ["extract", str(p), "position", "--csv"],
    "extract deformation": lambda p: ["extract", str(p), "deformation", "--json"],
    "extract mode_shape": lambda p: ["extract", str(p), "mode_shape", "--csv"],
}
# the commands that apply to a transient run (no mode shapes, no element deformations)
_TRANSIENT_COMMANDS = ("validate", "show", "extract position")


def _commands(name) -> dict:
    return {k: v for k, v in _COMMANDS.items()
            if name != "pendulum" or k in _TRANSIENT_COMMANDS}


def _reference(path, name) -> dict:
    ref = {command: _cli(argv(path), path) for command, argv in _commands(name).items()}
    for command, (code, text) in ref.items():
        assert code == 0, (command, text)
    return ref


@pytest.fixture(scope="module")
def originals(tmp_path_factory) -> dict:
    """{name: (bytes, reference outputs, reference numbers)} of two undamaged result files."""
    tmp = tmp_path_factory.mktemp("corruption")
    pend = tmp / "pendulum.dat"
    pend.write_text((DECKS / "pendulum_rigid_90deg.dat").read_text().replace(
        "TIMESTEP 2.2 440", "TIMESTEP 0.2 40"))
    runs = {"column": [str(DECKS / "column_pinned_axial_load_16el.dat"), "--modes-per-step"],
            "pendulum": [str(pend)]}
    out = {}
    for name, args in runs.items():
        path = tmp / f"{name}.h5"
        assert main(["run", *args, "-o", str(path), "-q"]) == 0
        out[name] = (path.read_bytes(), _reference(path, name), _api(path))
    return out


def _variants(data: bytes, seed: int):
    """(label, damaged bytes): truncations, overwritten bytes, random files."""
    rng = np.random.default_rng(seed)
    for k in range(1, _N_TRUNCATE + 1):
        n = len(data) * k // (_N_TRUNCATE + 1)
        yield f"truncated at {n}", data[:n]
    for k in range(_N_FLIP):
        b = bytearray(data)
        where = rng.integers(0, len(b), size=1 + k % 4)
        for i in where:
            b[i] ^= int(rng.integers(1, 256))
        yield f"bytes changed at {where.tolist()}", bytes(b)
    for k in range(_N_RANDOM):
        yield f"random file {k}", rng.integers(0, 256, size=2000 * (k + 1),
                                                dtype=np.uint8).tobytes()


def _same_numbers(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return False
    return len(a) == len(b) and all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))


def _without_unprotected(text: str, label: str, data: bytes) -> str:
    """``text``, less show's "written by" line where a changed byte lies in the text of the
    root attributes ``program_version`` or ``created``: HDF5 keeps more than eight
    attributes in its dense storage, whose values no checksum covers (HDF5's nor the file's
    CRC rows), so such a byte shows there. A known limit, the same in every layout (a byte
    of either value flipped in a file of main before the in-memory header showed it too);
    every other changed byte must leave the output identical."""
    import re

    from spacarpy import __version__
    where = [int(w) for w in re.findall(r"\d+", label)] if label.startswith("bytes") else []
    spans = []
    for value in (__version__.encode(), re.search(rb"\d{4}-\d\d-\d\dT[\d:+-]+", data).group()):
        start = data.find(value)
        spans.append(range(start, start + len(value)))
    if not any(w in span for w in where for span in spans):
        return text
    return "\n".join(ln for ln in text.splitlines() if not ln.lstrip().startswith("written"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["column", "pendulum"])
def test_every_command_on_damaged_files(originals, tmp_path, name):
    data, ref, numbers = originals[name]
    path = tmp_path / f"{name}.h5"
    passed = failed = 0
    for label, damaged in _variants(data, seed=17 if name == "column" else 23):
        path.write_bytes(damaged)
        for command, argv in _commands(name).items():
            code, text = _cli(argv(path), path)
            assert "Traceback" not in text, (label, command, text)
            assert code in (0, 2), (label, command, code, text)
            if code == 0:
                assert _without_unprotected(text, label, data) == \
                    _without_unprotected(ref[command][1], label, data), (label, command)
                passed += 1
            else:
                assert text.strip(), (label, command, "exit 2 without a message")
                failed += 1
        got = _api(path)
        if not isinstance(got, str):
            assert _same_numbers(got, numbers), (label, "open_results: other numbers")
        if label.startswith("truncated") and len(damaged) < len(data):
            assert isinstance(got, str) and "damaged" in got, (label, got)
    assert failed > 0 and passed > 0


@pytest.mark.slow
def test_plot_and_export_on_damaged_files(originals, tmp_path):
    pytest.importorskip("matplotlib")
    plots = {"column": ["mode"], "pendulum": ["history", "--node", "3"]}
    for name, kind in plots.items():
        data, _, _ = originals[name]
        path = tmp_path / f"{name}.h5"
        for k, (label, damaged) in enumerate(_variants(data, seed=5)):
            if k % 4:
                continue
            path.write_bytes(damaged)
            for argv in (["plot", str(path), *kind, "-o", str(tmp_path / "m.png")],
                         ["export", str(path), "--xdmf", "-o", str(tmp_path / "c.xdmf")]):
                code, text = _cli(argv, path)
                assert code in (0, 2) and "Traceback" not in text, (name, label, argv, code,
                                                                     text)


def test_half_truncated_file_is_damaged_with_its_sizes(originals, tmp_path):
    data, _, _ = originals["column"]
    path = tmp_path / "half.h5"
    path.write_bytes(data[:len(data) // 2])
    code, text = _cli(["validate", str(path), "--require-complete"], path)
    assert code == 2
    assert f"the file is {len(data) // 2} bytes, it should be {len(data)}" in text
    for argv in (["show", str(path)], ["extract", str(path), "mode_shape", "--csv"],
                 ["extract", str(path), "buckling_shape"]):
        code, text = _cli(argv, path)
        assert code == 2 and "damaged results file" in text, (argv, text)
        assert len(text.strip().splitlines()) == 1, text


def test_superblock_gives_the_stored_size(originals, tmp_path):
    data, _, _ = originals["pendulum"]
    path = tmp_path / "p.h5"
    path.write_bytes(data)
    sb = read_superblock(path)
    assert (sb.version, sb.size_needed, sb.swmr_write) == (3, len(data), False)
    path.write_bytes(b"not HDF5" * 100)
    assert read_superblock(path) is None


@pytest.mark.parametrize("cut", [2000, 0.5])
def test_subprocess_commands_end_in_time(originals, tmp_path, cut):
    """As a user runs them: the truncated file of D1 (2000 bytes hung every command), with
    `timeout`."""
    data, _, _ = originals["column"]
    n = cut if isinstance(cut, int) else int(len(data) * cut)
    path = tmp_path / "cut.h5"
    path.write_bytes(data[:n])
    for argv in (["validate", str(path)], ["extract", str(path), "buckling_shape"]):
        proc = subprocess.run([sys.executable, "-m", "spacarpy", *argv], capture_output=True,
                              text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr + proc.stdout
        assert "Traceback" not in proc.stderr + proc.stdout
        assert f"the file is {n} bytes, it should be {len(data)}" in proc.stderr + proc.stdout


@pytest.mark.slow
def test_damaged_file_of_a_killed_writer_ends_in_time(tmp_path, monkeypatch):
    """A killed writer's file carries the SWMR-write mark and is opened SWMR-read, where HDF5
    skips its end-of-file check and retries failing checksums: still bounded, still exit 2."""
    monkeypatch.setattr("spacarpy.results.h5file.SWMR_WAIT", 0.2)   # the wait for a writer
    run_and_kill(tmp_path, n_elem=2, pause=0.02)
    killed = tmp_path / "killed.partial.h5"
    data = killed.read_bytes()
    assert read_superblock(killed).swmr_write
    assert _cli(["validate", str(killed)], killed)[0] == 0
    path = tmp_path / "damaged.h5"
    rng = np.random.default_rng(11)
    for k in range(1, 6):
        cut = len(data) * k // 6
        path.write_bytes(data[:cut])
        code, text = _cli(["validate", str(path)], path)
        assert code == 2 and f"the file is {cut} bytes, it should be {len(data)}" in text
    for _ in range(6):
        b = bytearray(data)
        for i in rng.integers(0, len(b), size=3):
            b[i] ^= 0x5A
        path.write_bytes(bytes(b))
        for argv in (["validate", str(path)], ["show", str(path)]):
            code, text = _cli(argv, path)
            assert code in (0, 2) and "Traceback" not in text, (argv, text)


def test_the_bounded_swmr_open_uses_h5pys_own_hdf5_library():
    """netCDF4's wheel brings a second HDF5 library into the process (the xarray tests load
    it): the one-attempt SWMR-read setting must go to the library h5py uses, or a damaged
    file of a killed writer is retried for minutes (it hung CI once)."""
    pytest.importorskip("netCDF4")
    code = ("import netCDF4, h5py, os\n"
            "netCDF4.Dataset\n"
            "from spacarpy.results.hdf5_library import h5py_hdf5_library\n"
            "path, _ = h5py_hdf5_library()\n"
            "maps = [l.split()[-1] for l in open('/proc/self/maps') if '/libhdf5-' in l]\n"
            "assert len(set(maps)) >= 2, maps\n"
            "own = os.path.dirname(os.path.abspath(h5py.__file__))\n"
            "assert path.startswith(own), (path, sorted(set(maps)))\n")
    if not os.path.exists("/proc/self/maps"):
        pytest.skip("no /proc/self/maps on this system")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
