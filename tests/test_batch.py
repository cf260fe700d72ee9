"""``spacarpy batch``: the shipped decks against their committed baselines, a perturbed deck
reported as changed, failing and hanging decks reported as failed, reports, docs/batch.md."""
import json
import re
import shlex
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from spacarpy.batch.compare import compare_files
from spacarpy.batch.runner import find_decks
from spacarpy.cli import main

ROOT = Path(__file__).resolve().parents[1]
DECKS = ROOT / "decks"
BASELINE = DECKS / "baseline"


def test_every_shipped_deck_has_a_baseline_and_they_are_small():
    decks = find_decks([DECKS])
    assert len(decks) >= 32
    for _, rel in decks:
        assert (BASELINE / Path(rel).with_suffix(".h5")).exists() or \
            "run.exit_code" in (DECKS / rel).read_text(), rel
    # 10.2 MB: the 59 baselines, the path-following ones (hundreds of points) included. Raised
    # from 9.5 MB in session 13 for the eight rolling-contact and driven decks (70-135 kB each
    # with the 4 KiB step chunks), and in session 14 for the Twente bicycle deck (157 kB for
    # two static steps: 68 step datasets of one 4 KiB chunk each, not points). A deck that
    # needs more should store fewer points; the next saving is chunks no longer than the
    # number of steps a run will store. Raised to 10.6 MB in issue 32 (the Lie-group update of
    # the Euler parameters renewed seven transient baselines, written before the per-kind
    # element datasets, deformation rates and checksums: 10.14 -> 10.51 MB), then by 200 370
    # bytes for the two line-load decks (issue 37: heavy_column_greenhill 85 140,
    # beam_line_load_gust 115 230), 71 785 for the curved Table 2 bend
    # (table2_bend_8el_curved), 67 kB for the follower-moment circle and 94 kB for the ring
    # under follower pressure, 96 357 bytes for the ring under follower pressure in a tilted
    # plane (ring_follower_pressure_3d), and by 406 962 bytes for the 3D beam lattice (issue
    # 36: 495 beams, two load steps, every step's element datasets)
    assert sum(p.stat().st_size for p in BASELINE.glob("*.h5")) < (10.6e6 + 200_370 + 71_785
                                                                  + 67e3 + 94e3 + 96_357
                                                                  + 406_962)


@pytest.mark.slow
def test_batch_over_shipped_decks_passes_against_committed_baselines(tmp_path, capsys):
    """Every shipped deck against its baseline; and every deck's new result file opens in
    the netCDF world (issue 35): each group with both xarray engines, every unit parsed by
    pint (and UDUNITS2 where cf-units imports) into the schema's dimension, every group,
    variable and attribute read by netCDF4-python and listed by ncdump -h where installed."""
    from test_netcdf import check_ncdump, check_units, open_headers

    report, kept = tmp_path / "r.json", tmp_path / "results"
    assert main(["batch", str(DECKS), "--baseline", str(BASELINE), "-j", "2", "-q",
                 "--report", str(report), "--output-dir", str(kept)]) == 0
    out = capsys.readouterr().out
    doc = json.loads(report.read_text())
    assert doc["summary"]["pass"] == doc["summary"]["total"] >= 32, out
    assert re.search(r"\d+ decks: \d+ pass, 0 changed, 0 failed, 0 new", out)
    files = sorted(kept.rglob("*.h5"))
    # the mode-0 decks write no file
    assert len(files) >= doc["summary"]["total"] - 2, [p.name for p in files]
    for path in files:
        open_headers(path)
        check_units(path)
        check_ncdump(path)


@pytest.mark.slow
def test_changed_failed_and_timeout_are_reported_while_the_others_complete(tmp_path, capsys):
    d = tmp_path / "decks"
    d.mkdir()
    shutil.copy(DECKS / "table2_bend_8el_modified.dat", d)
    text = (DECKS / "column_clamped_buckling_16el.dat").read_text()
    assert "ESTIFF 1:16 1000000 1 1 1" in text
    (d / "column_clamped_buckling_16el.dat").write_text(
        text.replace("ESTIFF 1:16 1000000 1 1 1", "ESTIFF 1:16 1000000 1 1.01 1.01"))
    (d / "broken.dat").write_text("X 1 0 0 0\nBEEM 1 1 2 3 4\nEND\nEND\n")
    # a run that outlasts the timeout: the rigid pendulum swung for 10^4 s in 2 * 10^6 steps
    # (a valid model: a deck refused before its solve would not test the timeout)
    (d / "hang.dat").write_text(
        (DECKS / "pendulum_rigid_90deg.dat").read_text().replace("TIMESTEP 2.2 440",
                                                                 "TIMESTEP 10000 2000000"))
    xml_report, json_report = tmp_path / "r.xml", tmp_path / "r.json"
    rc = main(["batch", str(d), "--baseline", str(BASELINE), "-j", "2", "--timeout", "30",
               "-q", "--report", str(xml_report), "--report", str(json_report)])
    assert rc == 1
    out = capsys.readouterr().out
    doc = {x["name"]: x for x in json.loads(json_report.read_text())["decks"]}
    assert doc["table2_bend_8el_modified.dat"]["status"] == "pass"
    changed = doc["column_clamped_buckling_16el.dat"]
    assert changed["status"] == "changed"
    paths = {x["path"] for x in changed["datasets"]}
    # a 2.0 result against a 1.x baseline: the datasets are named by their 2.0 paths
    assert "/buckling/critical_load_multiplier" in paths
    assert "/model/elements/BEAM/stiffness" in paths
    crit = [x for x in changed["datasets"] if x["path"] == "/buckling/critical_load_multiplier"]
    assert crit[0]["rel_diff"] == pytest.approx(0.01, rel=1e-3)
    assert doc["broken.dat"]["status"] == "failed"
    assert "unknown keyword 'BEEM'" in doc["broken.dat"]["message"]
    assert doc["hang.dat"]["status"] == "failed"
    assert "timed out after 30 s" in doc["hang.dat"]["message"]
    assert "CHANGED  column_clamped_buckling_16el.dat" in out
    suite = ET.parse(xml_report).getroot().find("testsuite")
    assert suite.get("tests") == "4" and suite.get("failures") == "1" \
        and suite.get("errors") == "2"
    failure = [tc for tc in suite if tc.get("name") == "column_clamped_buckling_16el.dat"][0]
    assert "/buckling/critical_load_multiplier" in failure.find("failure").text


@pytest.mark.slow
def test_update_baseline_then_new_and_pass(tmp_path, capsys):
    deck = tmp_path / "t.dat"
    shutil.copy(DECKS / "table3_lateral_buckling_1el_modified.dat", deck)
    base = tmp_path / "base"
    assert main(["batch", str(deck), "--baseline", str(base), "--update-baseline", "-q"]) == 0
    assert "NEW" in capsys.readouterr().out and (base / "t.h5").exists()
    assert main(["batch", str(deck), "--baseline", str(base), "-q"]) == 0
    assert "1 decks: 1 pass" in capsys.readouterr().out.replace("1 deck:", "1 decks:")
    assert compare_files(base / "t.h5", base / "t.h5") == []


def test_no_deck_is_an_input_error(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "nothing*.dat")]) == 2
    assert "names no deck" in capsys.readouterr().err


@pytest.mark.slow
def test_docs_batch_example_runs(tmp_path, monkeypatch, capsys):
    """The ``spacarpy batch`` example of docs/batch.md runs from the repository root and
    passes (the sweep example is run by tests/test_sweep.py)."""
    text = (ROOT / "docs" / "batch.md").read_text()
    commands = re.findall(r"```console\n\$ spacarpy (batch .*?)\n", text)
    assert len(commands) == 1
    monkeypatch.chdir(ROOT)
    args = shlex.split(commands[0])
    k = args.index("--report") + 1
    args[k] = str(tmp_path / args[k])
    assert main(args + ["-q"]) == 0
    assert "2 decks: 2 pass" in capsys.readouterr().out
    assert ET.parse(tmp_path / "batch.xml").getroot().find("testsuite").get("tests") == "2"


@pytest.mark.slow
def test_a_baseline_tolerance_file_loosens_named_datasets_only(tmp_path, capsys):
    """``<baseline>.tol.json`` loosens the tolerances of the datasets it names (an
    ill-conditioned quantity), with a required reason; a malformed file fails the deck."""
    import h5py
    deck = tmp_path / "decks" / "two_bar_truss.dat"
    deck.parent.mkdir()
    shutil.copy(DECKS / "two_bar_truss.dat", deck)
    base = tmp_path / "base"
    args = ["batch", str(deck.parent), "--baseline", str(base), "-q"]
    assert main(args + ["--update-baseline"]) == 0
    with h5py.File(base / "two_bar_truss.h5", "r+") as f:
        f["/static/position"][...] *= 1.0 + 1e-4            # a 1e-4 relative change
    capsys.readouterr()
    assert main(args) == 1
    assert "CHANGED" in capsys.readouterr().out
    tol = base / "two_bar_truss.tol.json"
    tol.write_text(json.dumps({"/static/reaction": {"rtol": 1e-3, "why": "other dataset"}}))
    assert main(args) == 1                                   # names another dataset
    tol.write_text(json.dumps({"/static/pos*": {"rtol": 1e-3, "why": "test"}}))
    assert main(args) == 0
    tol.write_text(json.dumps({"/static/pos*": {"rtol": 1e-3}}))       # no reason
    capsys.readouterr()
    assert main(args) == 1
    out = capsys.readouterr().out
    assert "FAILED" in out and "two_bar_truss.tol.json" in out and "reason" in out
    # the shipped leaf-spring baselines say why their soft frequencies are loosened
    from spacarpy.batch.compare import load_tolerances
    for name in ("leafspring_guidance_misalignment", "leafspring_guidance_sweep"):
        assert load_tolerances(BASELINE / f"{name}.tol.json")


def test_multipliers_compare_by_classification_not_round_off(tmp_path):
    """D3: a +mu/-mu pair stored swapped and an infinite multiplier stored as 4.9e16 (another
    machine's round-off) match the committed baseline; one infinite multiplier more does
    not."""
    import h5py
    import numpy as np
    base = BASELINE / "table3_lateral_buckling_4el_modified.h5"
    with h5py.File(base, "r") as f:
        mult = f["buckling/load_multiplier"][()]
    assert np.isnan(mult[0, 8:]).all() and mult[0, 0] == pytest.approx(-mult[0, 1], rel=1e-12)
    other = mult.copy()
    other[0, :2] = other[0, 1::-1]                    # the pair swapped
    other[0, 8:] = [4.9e16, -1.96e16]                 # round-off for "infinite"
    worse = mult.copy()
    worse[0, 6] = 1.3e17                              # a finite multiplier became infinite
    for name, data, n_diff in (("same", other, 0), ("worse", worse, 1)):
        path = tmp_path / f"{name}.h5"
        shutil.copy(base, path)
        with h5py.File(path, "r+") as f:
            f["buckling/load_multiplier"][...] = data
        diffs = compare_files(path, base)
        assert len(diffs) == n_diff, [d.message for d in diffs]
    assert diffs[0].path == "/buckling/load_multiplier"


def test_a_residual_regression_is_a_change_round_off_is_not(tmp_path):
    """The residuals are not compared by value (round-off moves them, and with them
    /static/converged_by), but a step whose residual is above 1e-6 and 100 times the
    baseline's is a change: step 0 stored with a residual of 1.0 where the baseline's is
    about 0 (report N10), a time step's grown to 1e-3."""
    import h5py
    import numpy as np
    cases = {"static": BASELINE / "table1_cantilever_1el_modified.h5",
             "transient": BASELINE / "pendulum_rigid_90deg.h5"}
    for group, base in cases.items():
        with h5py.File(base, "r") as f:
            res = f[f"{group}/residual"][()]
        assert res.max() < 1e-9
        # (name, step, its baseline residual or None: as it is, the new one, differs)
        for name, k, old, new, n_diff in (("n10", 0, None, 1.0, 1),
                                          ("grown", -1, None, 1e-3, 1),
                                          ("below 1e-6", 0, None, 9e-7, 0),
                                          ("50 times", -1, 1e-7, 5e-6, 0),
                                          ("101 times", -1, 1e-7, 1.01e-5, 1)):
            path, ref = tmp_path / f"{group}_{k}.h5", tmp_path / f"{group}_{k}_base.h5"
            shutil.copy(base, path)
            shutil.copy(base, ref)
            for file, value in ((ref, old), (path, new)):
                with h5py.File(file, "r+") as f:
                    if value is not None:
                        data = res.copy()
                        data[k] = value
                        f[f"{group}/residual"][...] = data
                    if file == path and f"{group}/converged_by" in f:    # round-off's
                        f[f"{group}/converged_by"][...] = 1 - f[f"{group}/converged_by"][()]
            diffs = compare_files(path, ref)
            assert len(diffs) == n_diff, (group, name, [d.message for d in diffs])
            if n_diff:
                assert diffs[0].path == f"/{group}/residual"
                assert diffs[0].index == (k % res.size,) and diffs[0].value == new
                assert "100 times the baseline" in diffs[0].message
        with h5py.File(base, "r") as f:                 # (the baseline untouched)
            assert np.array_equal(res, f[f"{group}/residual"][()])
