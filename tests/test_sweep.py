"""``spacarpy sweep``: the docs/batch.md example (21 load ratios of a column: frequencies and
buckling multiplier in one file), locally and on a two-worker Dask LocalCluster, identical."""
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.batch.sweep import parse_sweep_axis
from spacarpy.cli import main

from helpers import docs_sweep_args

ROOT = Path(__file__).resolve().parents[1]


def test_parse_axis():
    ax = parse_sweep_axis("ratio=-0.95:-0.05:21")
    assert ax.name == "ratio" and len(ax.values) == 21 and ax.values[-1] == pytest.approx(-0.05)
    assert parse_sweep_axis("n=4,8").values == (4.0, 8.0)
    for bad in ("ratio", "ratio=1:2", "ratio=1:2:0", "ratio=a,b"):
        with pytest.raises(ValueError, match="NAME=START:STOP:COUNT"):
            parse_sweep_axis(bad)


def test_a_parameter_the_deck_does_not_set_is_refused_before_any_run(tmp_path, capsys):
    deck = tmp_path / "d.dat"
    deck.write_text("SET R 1\nSET F 2\nX 1 0 0 0\nEND\nEND\n")
    out = tmp_path / "s.h5"
    assert main(["sweep", str(deck), "--set", "nope=1:2:3", "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "--set nope: the deck has no 'SET nope' line" in err and "R, F" in err
    assert "Traceback" not in err and not out.exists()    # no point ran, no file written


@pytest.mark.slow
def test_docs_sweep_gives_the_frequency_table_in_one_file(column_sweep):
    with h5py.File(column_sweep) as f:
        assert f.attrs["filetype"] == "spacarpy-sweep"
        assert list(f.attrs["parameters"]) == ["ratio"]
        ratio = f["parameters/ratio"][()]
        freq = f["eigen/frequency"][()]
        crit = f["buckling/critical_load_multiplier"][()]
        assert ratio.shape == (21,) and freq.shape[0] == 21 and crit.shape == (21,)
        assert f["eigen/frequency"].dims[0].label == "ratio"
        assert (f["sweep/status"][()] == 0).all()
    np.testing.assert_allclose(freq[:, 0], np.pi / 2 * np.sqrt(1 + ratio), rtol=2e-3)
    np.testing.assert_allclose(crit, 1 / np.abs(ratio), rtol=1e-4)


@pytest.mark.slow
def test_sweep_on_a_two_worker_dask_local_cluster_gives_identical_numbers(column_sweep,
                                                                          tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed "
                                              "(pip install 'spacarpy[dask]')")
    out = tmp_path / "dask_sweep.h5"
    args = docs_sweep_args(out) + ["--dask", "local"]
    import os
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        assert main(args) == 0
    finally:
        os.chdir(cwd)
    with h5py.File(column_sweep) as a, h5py.File(out) as b:
        for path in ("parameters/ratio", "eigen/frequency", "buckling/critical_load_multiplier",
                     "sweep/status"):
            np.testing.assert_array_equal(a[path][()], b[path][()])


@pytest.mark.slow
def test_failed_points_are_nan_with_status(tmp_path, capsys):
    deck = tmp_path / "d.dat"
    deck.write_text((ROOT / "decks" / "sweep_column_load_ratio.dat").read_text())
    out = tmp_path / "s.h5"
    # n = 0 elements is a deck error: every point fails, the file is still written
    assert main(["sweep", str(deck), "--set", "n=0,8", "-q", "-o", str(out)]) == 1
    with h5py.File(out) as f:
        status = f["sweep/status"][()]
        assert list(status) == [2, 0]
        assert np.isnan(f["eigen/frequency"][0]).all() and not np.isnan(
            f["eigen/frequency"][1]).any()
        assert "n" in f["sweep/error"][0].decode()


def _run_in_root(args):
    import os
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        return main(args)
    finally:
        os.chdir(cwd)


@pytest.mark.slow
def test_leafspring_misalignment_sweep_locally_and_on_dask(tmp_path):
    """docs/batch.md's leaf-spring sweep: 21 misalignments in one file, the frequencies of the
    single 40-step run at the same angles, and identical numbers from a two-worker Dask
    LocalCluster."""
    local = tmp_path / "local.h5"
    assert _run_in_root(docs_sweep_args(local, "leafspring_guidance_sweep")) == 0
    single = tmp_path / "single.h5"
    assert main(["run", str(ROOT / "decks" / "leafspring_guidance_misalignment.dat"), "-o",
                 str(single), "-q"]) == 0
    with h5py.File(local) as f, h5py.File(single) as g:
        phi = f["parameters/phi"][()]
        freq = f["eigen/frequency"][()]
        assert phi.shape == (21,) and freq.shape == (21, 3)
        assert (f["sweep/status"][()] == 0).all()
        ref = g["eigen/frequency"][::2]                     # 0.05 mrad steps -> 0.1 mrad
    np.testing.assert_allclose(phi, np.linspace(0, 0.002, 21))
    np.testing.assert_allclose(freq, ref, rtol=1e-3)
    pytest.importorskip("distributed", reason="dask.distributed is not installed "
                                              "(pip install 'spacarpy[dask]')")
    dask_out = tmp_path / "dask.h5"
    assert _run_in_root(docs_sweep_args(dask_out, "leafspring_guidance_sweep")
                        + ["--dask", "local"]) == 0
    with h5py.File(local) as a, h5py.File(dask_out) as b:
        for path in ("parameters/phi", "eigen/frequency", "sweep/status"):
            np.testing.assert_array_equal(a[path][()], b[path][()])
