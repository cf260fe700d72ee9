"""The shipped decks of the linearized analyses, run from the command line, give the paper's
Table 3 and the closed-form values; the result files pass the validator."""
from pathlib import Path

import numpy as np
import pytest

from spacarpy.bench.cases import LATERAL, LATERAL_BUCKLING_CONSTANT
from spacarpy.cli import main
from spacarpy.results import read_results, validate_file

DECKS = Path(__file__).resolve().parents[1] / "decks"

TABLE3 = {("modified", 1): 1.495290, ("modified", 2): 1.069138, ("modified", 4): 1.015367,
          ("basic", 1): np.inf, ("basic", 2): 1.220899, ("basic", 4): 1.046009}


def run(tmp_path, deck, *extra):
    out = tmp_path / (deck + ".h5")
    assert main(["run", str(DECKS / f"{deck}.dat"), "-o", str(out), "-q", *extra]) == 0
    assert validate_file(out, require_complete=True) == []
    return read_results(out)


@pytest.mark.parametrize("variant,n", list(TABLE3))
def test_table3_decks(tmp_path, variant, n):
    res = run(tmp_path, f"table3_lateral_buckling_{n}el_{variant}")
    assert res.analysis == "buckling"
    f_th = LATERAL_BUCKLING_CONSTANT * np.sqrt(LATERAL["EI"] * LATERAL["St"]) / LATERAL["L"]**2
    ratio = res.buckling.critical_load_multiplier[-1] * LATERAL["F"] / f_th
    expected = TABLE3[(variant, n)]
    if np.isinf(expected):
        assert np.isinf(ratio)
    else:
        assert round(ratio, 6) == pytest.approx(expected, abs=1e-12)


def test_cantilever_modes_deck(tmp_path):
    res = run(tmp_path, "cantilever_modes_16el")
    f = res.eigen.frequency[-1]
    assert np.all(res.eigen.kind[-1] == 0)
    assert f[0] == pytest.approx(np.sqrt(2.0) / 4, rel=5e-4)             # torsion
    beta = np.array([1.8751040687, 4.6940911330])
    np.testing.assert_allclose(f[[1, 2]], beta[0]**2 / (2 * np.pi), rtol=1e-6)
    np.testing.assert_allclose(f[[7, 8]], beta[1]**2 / (2 * np.pi), rtol=1e-5)


def test_free_free_deck_reports_six_rigid_body_modes(tmp_path):
    res = run(tmp_path, "free_free_beam_8el")
    assert list(res.eigen.kind[-1][:7]) == [1, 1, 1, 1, 1, 1, 0]
    assert np.all(res.eigen.frequency[-1][:6] == 0)


@pytest.mark.parametrize("support", ["pinned", "clamped"])
def test_euler_load_decks(tmp_path, support):
    res = run(tmp_path, f"column_{support}_buckling_16el")
    # linearized about the state compressed by P_E: axial strain P_E / EA = 1e-5
    assert res.buckling.critical_load_multiplier[-1] == pytest.approx(1.0, rel=3e-5)


def test_frequency_versus_axial_load_per_step(tmp_path):
    res = run(tmp_path, "column_pinned_axial_load_16el", "--modes-per-step", "--modes", "2")
    eig = res.eigen
    assert list(eig.step) == list(range(13))
    ratio = -1.2 * res.static.load_factor[eig.step]                 # P / P_E at each step
    f = eig.frequency[:, 0]
    stable = ratio > -0.95
    np.testing.assert_allclose(f[stable] / f[0], np.sqrt(1 + ratio[stable]), rtol=1e-4)
    at_euler = np.isclose(ratio, -1.0)
    assert abs(f[at_euler][0]) < 0.01 * f[0]
    assert np.all(eig.kind[ratio < -1.05, 0] == 2) and np.all(f[ratio < -1.05] < 0)
    # the buckling multipliers fall as 1 / (P / P_E) along the same path
    crit = res.buckling.critical_load_multiplier
    np.testing.assert_allclose(crit[1:] * -ratio[1:], 1.0, rtol=1e-4)


def test_infinite_multipliers_are_shown_and_extracted_as_infinite(tmp_path, capsys):
    """D3: Table 3 with 4 basic elements has 6 finite multipliers (3 +-mu pairs, negative
    first) and 4 infinite ones; show and extract say "infinite", never 1e16."""
    res = run(tmp_path, "table3_lateral_buckling_4el_basic")
    mult = res.buckling.load_multiplier[-1]
    assert np.isfinite(mult[:6]).all() and np.isnan(mult[6:]).all()
    assert (np.sign(mult[:6]) == [-1, 1, -1, 1, -1, 1]).all()
    np.testing.assert_allclose(np.abs(mult[:6:2]), np.abs(mult[1:6:2]), rtol=1e-12)
    out = tmp_path / "table3_lateral_buckling_4el_basic.h5"
    capsys.readouterr()
    assert main(["extract", str(out), "buckling", "--csv"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0].endswith(",kind")
    kinds = [r.rsplit(",", 1)[1] for r in rows[1:]]
    assert kinds == ["finite"] * 6 + ["infinite"] * 4
    assert main(["show", str(out)]) == 0
    res_out = capsys.readouterr().out
    assert "e+16" not in res_out and "e+17" not in res_out
    one = tmp_path / "one.h5"
    assert main(["run", str(DECKS / "table3_lateral_buckling_1el_basic.dat"), "-o", str(one),
                 "-q"]) == 0
    capsys.readouterr()
    assert main(["show", str(one)]) == 0
    assert "       inf  infinite  infinite  infinite  infinite" in capsys.readouterr().out
